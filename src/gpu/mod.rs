//! GPU passes on wgpu. `context` creates the device; one file per pass, each driving its own WGSL in
//! `shaders/`.
pub mod alloc;
pub mod bsdf_eval;
pub mod bvh;
pub mod clustered_visibility;
pub mod columns;
pub mod context;
pub mod dispatch;
pub mod gbuffer;
pub mod kmeans;
pub mod mapping;
pub mod mask;
pub mod needs;
pub mod pipeline;
pub mod reconstruction;
pub mod relight;
pub mod rows;
pub mod scene_buffers;
pub mod shaders;
pub mod shadow;
#[cfg(test)]
pub mod watertight;
pub mod wsi_env;

pub use context::GpuContext;
