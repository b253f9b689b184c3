//! Mitsuba 3 XML reader (being written).
use crate::error::Result;
use crate::scene::Scene;
use std::path::Path;

/// Options of `load_scene`: `$name` substitutions (like `mitsuba.load_file(path, **params)`) and an
/// optional film size override.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    pub params: Vec<(String, String)>,
    /// Replaces the film's width and height (for scenes whose film size is not a parameter).
    pub size: Option<(u32, u32)>,
}

pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let _ = (path, opts);
    Err(crate::error::Error::invalid("scene loading is being written"))
}
