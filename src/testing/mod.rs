//! Test-only helpers shared by the unit tests of every module: where the shared scenes are, and
//! (`scenes`) hand-made scene builders and CPU-cast view samples.
use std::path::{Path, PathBuf};

/// Where the shared scenes are: `$MANYLIGHTS_SHARED`, then `<manifest>/../shared` (CI: `shared/` beside
/// the checkout), then `/work/shared`; the folder must contain `scenes/`.
pub fn shared_dir() -> PathBuf {
    let candidates = [
        std::env::var("MANYLIGHTS_SHARED").ok().map(PathBuf::from),
        Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared")),
        Some(PathBuf::from("/work/shared")),
    ];
    candidates
        .into_iter()
        .flatten()
        .find(|d| d.join("scenes").is_dir())
        .expect("shared scenes not found: set MANYLIGHTS_SHARED to the folder holding scenes/")
}

pub mod scenes;
