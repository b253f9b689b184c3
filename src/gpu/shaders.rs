//! WGSL modules, assembled at compile time (WGSL has no includes): each pass's source is the shared
//! snippets of `shaders/common/` it needs followed by `shaders/<pass>.wgsl`, joined with `concat!`
//! so edits trigger rebuilds and nothing is read from disk at run time.
use crate::error::{Error, Result};

/// `shaders/gbuffer.wgsl` (no shared snippets): the G-buffer visibility pass of `gpu::gbuffer`.
pub const GBUFFER: &str = concat!(include_str!("../../shaders/gbuffer.wgsl"));

/// Parse and validate a WGSL module with naga (all capabilities a downlevel device may lack are
/// refused), so broken shaders fail in `cargo test` on machines without a GPU. `name` labels errors.
pub fn validate_wgsl(name: &str, source: &str) -> Result<naga::Module> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| Error::Gpu(format!("{name}: WGSL parse error: {}", e.emit_to_string(source))))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .map_err(|e| Error::Gpu(format!("{name}: WGSL validation error: {}", e.emit_to_string(source))))?;
    Ok(module)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gbuffer_wgsl_validates() {
        let module = validate_wgsl("gbuffer.wgsl", GBUFFER).unwrap();
        let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        for name in ["vs_triangles", "fs_triangles", "vs_sphere", "fs_sphere"] {
            assert!(entries.contains(&name), "missing entry point {name}: {entries:?}");
        }
    }

    #[test]
    fn broken_wgsl_is_an_error() {
        let e = validate_wgsl("bad", "fn f() -> u32 { return 1.0; }").unwrap_err().to_string();
        assert!(e.contains("bad"), "{e}");
    }
}
