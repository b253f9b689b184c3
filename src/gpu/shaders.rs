//! WGSL modules, assembled at compile time (WGSL has no includes): each pass's source is the shared
//! snippets of `shaders/common/` it needs followed by `shaders/<pass>.wgsl`, joined with `concat!`
//! so edits trigger rebuilds and nothing is read from disk at run time. Every pass takes its source from
//! here: one const per pass, named after its file (`COLUMNS` for `shaders/columns.wgsl`).
use crate::error::{Error, Result};

/// The column and row passes: every shared snippet they need, then the pass itself.
macro_rules! light_pass {
    ($pass:literal) => {
        concat!(
            include_str!("../../shaders/common/bsdf.wgsl"),
            include_str!("../../shaders/common/principled.wgsl"),
            include_str!("../../shaders/common/light.wgsl"),
            include_str!("../../shaders/common/glossy.wgsl"),
            include_str!("../../shaders/common/shadow_layer.wgsl"),
            include_str!("../../shaders/common/bvh.wgsl"),
            include_str!("../../shaders/common/view_sample.wgsl"),
            include_str!("../../shaders/common/visibility.wgsl"),
            include_str!("../../shaders/common/mask.wgsl"),
            include_str!($pass),
        )
    };
}

/// `shaders/bsdf_eval.wgsl`: batch BSDF evaluation (`gpu::bsdf_eval`); common BSDF code, then the pass,
/// each followed by a newline.
pub const BSDF_EVAL: &str = concat!(
    include_str!("../../shaders/common/bsdf.wgsl"),
    "\n",
    include_str!("../../shaders/common/principled.wgsl"),
    "\n",
    include_str!("../../shaders/bsdf_eval.wgsl")
);
/// `shaders/clustered_visibility.wgsl`: clustered visibility (`gpu::clustered_visibility`); the shared
/// snippets, then the pass.
pub const CLUSTERED_VISIBILITY: &str = concat!(
    include_str!("../../shaders/common/bsdf.wgsl"),
    include_str!("../../shaders/common/principled.wgsl"),
    include_str!("../../shaders/common/light.wgsl"),
    include_str!("../../shaders/common/glossy.wgsl"),
    include_str!("../../shaders/common/bvh.wgsl"),
    include_str!("../../shaders/common/view_sample.wgsl"),
    include_str!("../../shaders/common/mask.wgsl"),
    include_str!("../../shaders/clustered_visibility.wgsl"),
);
/// `shaders/columns.wgsl`: light columns (`gpu::columns`).
pub const COLUMNS: &str = light_pass!("../../shaders/columns.wgsl");
/// `shaders/gbuffer.wgsl` (no shared snippets): the G-buffer visibility pass of `gpu::gbuffer`.
pub const GBUFFER: &str = concat!(include_str!("../../shaders/gbuffer.wgsl"));
/// `shaders/kmeans.wgsl` (no shared snippets): the K-means passes (`gpu::kmeans`).
pub const KMEANS: &str = include_str!("../../shaders/kmeans.wgsl");
/// `shaders/mapping.wgsl` (no shared snippets): the pixel-mapping pass (`gpu::mapping`).
pub const MAPPING: &str = include_str!("../../shaders/mapping.wgsl");
/// `shaders/occluded.wgsl`: batch shadow-ray queries (`gpu::bvh::OccludedPass`); the BVH snippet, then the pass.
pub const OCCLUDED: &str = concat!(include_str!("../../shaders/common/bvh.wgsl"), include_str!("../../shaders/occluded.wgsl"));
/// `shaders/reconstruction.wgsl` (no shared snippets): tensor clustering's reconstruction (`gpu::reconstruction`).
pub const RECONSTRUCTION: &str = include_str!("../../shaders/reconstruction.wgsl");
/// `shaders/relight.wgsl` (no shared snippets): the relighting kernels (`gpu::relight`).
pub const RELIGHT: &str = include_str!("../../shaders/relight.wgsl");
/// `shaders/rows.wgsl`: light rows (`gpu::rows`).
pub const ROWS: &str = light_pass!("../../shaders/rows.wgsl");
/// `shaders/shadow.wgsl`: the shadow-map depth pass (`gpu::shadow`); the shadow-layer snippet, then the pass.
pub const SHADOW: &str = concat!(include_str!("../../shaders/common/shadow_layer.wgsl"), include_str!("../../shaders/shadow.wgsl"));

/// `shaders/common/bsdf.wgsl` alone, the WGSL twin of `shading::bsdf` (no entry points; needs
/// `fn bsdf_table(i: u32) -> f32` from the including module).
pub const COMMON_BSDF: &str = include_str!("../../shaders/common/bsdf.wgsl");
/// `shaders/common/principled.wgsl` alone, the WGSL twin of `shading::principled` (functions only; needs
/// `bsdf.wgsl` for the microfacet and Fresnel helpers).
pub const COMMON_PRINCIPLED: &str = include_str!("../../shaders/common/principled.wgsl");

/// Parse and validate a WGSL module with naga (all capabilities a downlevel device may lack are
/// refused), so broken shaders fail in `cargo test` on machines without a GPU. `name` labels errors.
pub fn validate_wgsl(name: &str, source: &str) -> Result<naga::Module> {
    let module =
        naga::front::wgsl::parse_str(source).map_err(|e| Error::Gpu(format!("{name}: WGSL parse error: {}", e.emit_to_string(source))))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .map_err(|e| Error::Gpu(format!("{name}: WGSL validation error: {}", e.emit_to_string(source))))?;
    Ok(module)
}

/// Validate `source` and check that each named WGSL struct has the byte size of its Rust mirror.
#[cfg(test)]
pub fn assert_struct_sizes(name: &str, source: &str, sizes: &[(&str, u32)]) -> naga::Module {
    let module = validate_wgsl(name, source).unwrap_or_else(|e| panic!("{e}"));
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    for &(ty, size) in sizes {
        let (h, _) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(ty)).unwrap_or_else(|| panic!("{name}: no struct {ty}"));
        assert_eq!(layouter[h].size, size, "{name}: struct {ty}");
    }
    module
}

#[cfg(test)]
mod tests;
