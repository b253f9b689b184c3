//! GPU passes on wgpu. `context` creates the device; one file per pass, each driving its own WGSL in
//! `shaders/` (assembled in `shaders`).
pub mod bsdf_eval;
pub mod columns;
pub mod context;
pub mod shadow;

pub use context::GpuContext;
