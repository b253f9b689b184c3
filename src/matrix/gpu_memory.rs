//! The GPU memory of one light matrix, estimated before anything is allocated: per part (view samples,
//! geometry, BVH, shadow atlas, accumulator, a batch of columns, the rows' lights) and checked against the
//! adapter's limits, the `MANYLIGHTS_GPU_MEMORY_LIMIT` budget and, on a software adapter, the host's memory
//! (module docs of `crate::gpu::alloc`).
use super::{ColumnOptions, Visibility};
use crate::error::Result;
use crate::gpu::columns::GpuLight;
use crate::gpu::scene_buffers::SceneGeometry;
use crate::gpu::GpuContext;

/// The GPU memory of one light matrix, by part (bytes): what `GpuBackend::new` allocates up front, and
/// the largest buffers its calls add (one batch of columns, the accumulator, every light for the rows).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GpuMemoryEstimate {
    pub view_samples: u64,
    pub view_bsdfs: u64,
    pub geometry: u64,
    pub bvh: u64,
    pub shadow_atlas: u64,
    pub accumulator: u64,
    pub column_batch: u64,
    pub row_lights: u64,
}

impl GpuMemoryEstimate {
    /// (name, bytes, bound whole as one storage binding) of every part.
    pub fn parts(&self) -> [(&'static str, u64); 8] {
        [
            ("view_samples", self.view_samples),
            ("view_bsdfs", self.view_bsdfs),
            ("geometry", self.geometry),
            ("bvh", self.bvh),
            ("shadow_atlas", self.shadow_atlas),
            ("accumulator", self.accumulator),
            ("column_batch", self.column_batch),
            ("row_lights", self.row_lights),
        ]
    }

    pub fn total(&self) -> u64 {
        self.parts().iter().map(|p| p.1).sum()
    }
}

/// Shadow-map layers of a matrix's atlas with `opts` (the budget, at least one cube) on `max_layers`
/// texture layers.
pub(super) fn atlas_layers(opts: &ColumnOptions, max_layers: u32) -> u32 {
    let layer_bytes = 4 * opts.shadow_resolution as u64 * opts.shadow_resolution as u64;
    (opts.shadow_memory_budget / layer_bytes.max(1)).min(max_layers as u64).min(6 * opts.max_lights_per_batch as u64).max(6) as u32
}

/// The GPU memory of a light matrix of `samples` view samples (pixels plus delta-chain extras),
/// `lights` lights and `triangles` triangles with `opts` (module docs of `gpu::alloc`; the BVH at its
/// largest, 2 nodes per triangle). Pure arithmetic: checked against the adapter before allocating.
pub fn estimate_gpu_bytes(samples: u64, lights: u64, triangles: u64, opts: &ColumnOptions) -> GpuMemoryEstimate {
    let res = opts.shadow_resolution as u64;
    let bvh = if opts.visibility == Visibility::ShadowMap {
        0
    } else {
        2 * triangles * std::mem::size_of::<crate::gpu::bvh::GpuBvhNode>() as u64
            + triangles * std::mem::size_of::<crate::gpu::bvh::GpuPrimitive>() as u64
    };
    GpuMemoryEstimate {
        view_samples: samples * std::mem::size_of::<crate::gpu::columns::GpuViewSample>() as u64,
        view_bsdfs: samples * std::mem::size_of::<crate::shading::GpuBsdf>() as u64,
        geometry: triangles * 3 * SceneGeometry::VERTEX_STRIDE,
        bvh,
        shadow_atlas: atlas_layers(opts, 2048) as u64 * res * res * 4,
        accumulator: samples * 16,
        column_batch: (opts.max_lights_per_batch as u64 * samples * 12).min(128 << 20),
        row_lights: lights * std::mem::size_of::<GpuLight>() as u64,
    }
}

/// Refuse a light matrix whose estimate (`estimate_gpu_bytes`) cannot fit the device: a part above
/// `max_buffer_size` or (bound whole) the storage binding limit, or the total above the budget
/// `MANYLIGHTS_GPU_MEMORY_LIMIT` (`gpu::alloc`) or, on a software adapter, above the host's memory.
///
/// Errors: `OutOfMemory` naming the part, its bytes and the limit.
pub fn check_gpu_estimate(ctx: &GpuContext, est: &GpuMemoryEstimate, what: &str) -> Result<()> {
    for (part, bytes) in est.parts() {
        let whole = part != "shadow_atlas" && part != "row_lights" && part != "geometry" && part != "bvh";
        crate::gpu::alloc::check_buffer(&ctx.limits, &format!("{what}: {part}"), bytes as u128, whole)?;
    }
    let total = est.total() as u128;
    crate::gpu::alloc::check_budget(&format!("{what} (all its GPU buffers)"), total)?;
    crate::memory::check_gpu(ctx, what, total, false)
}
