//! The row pass (`shaders/rows.wgsl`): rows of the light matrix from cube depth maps centred at view
//! samples (Hašan, Pellacini, Bala, "Matrix Row-Column Sampling for the Many-Light Problem", SIGGRAPH
//! 2007, Sec. 3.1: "shadow mapping can be also used to evaluate the contribution of all lights to a
//! sample by computing the depth map centered at the sample location"; Sec. 4: "Row visibility is
//! evaluated by computing a cube shadow map at the sample location").
//!
//! A batch's rows each own 6 layers (cube faces, in `shadow::cube_face_dirs` order) of one
//! `ShadowAtlas`, rendered by the shared `ShadowMapPass`; then one thread per (row, light) evaluates
//! A(i, j) with the same WGSL as the column pass (`light_emitted`, `bsdf_eval`) and writes RGB f32 to
//! `[row][light][rgb]`. The driver (`matrix::rows`) sizes row chunks so the output binding stays under
//! the 128 MiB storage-binding limit and light chunks so a dispatch's x size stays under 65,535 groups.
//!
//! Deviation from the paper: visibility is the hybrid of `columns.wgsl` (cube map where its 2x2
//! footprint is unambiguous, the exact BVH ray of the column pass elsewhere), so rows equal columns up
//! to the (rare) cases where a certain-looking map disagrees with the ray; see `row_map_decide`.
use super::columns::{storage_buffer, ViewBuffers};
use crate::gpu::pipeline::{compute_pipeline, depth_array, encode_dispatch, storage, uniform};
use crate::gpu::shaders;
use crate::gpu::shadow::GpuShadowLayer;

/// Threads per workgroup (along lights); mirrored in `rows.wgsl`.
pub const WORKGROUP_SIZE: u32 = 64;

/// Most lights per dispatch: 65,535 workgroups along x.
pub const MAX_LIGHTS_PER_DISPATCH: usize = 65_535 * WORKGROUP_SIZE as usize;
/// `first_layer` of a row without a cube map (background samples); mirrored in `rows.wgsl`.
pub const ROW_NO_MAP: u32 = u32::MAX;

/// Keep in sync with `struct RowParams` in `shaders/rows.wgsl` (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RowParams {
    pub num_rows: u32,
    pub num_lights: u32,
    pub first_row: u32,
    pub first_light: u32,
    pub total_lights: u32,
    pub resolution: u32,
    /// `matrix::Visibility as u32`.
    pub visibility: u32,
    pub _pad0: u32,
    pub normal_offset: f32,
    pub depth_bias: f32,
    pub slope_bias: f32,
    pub _pad1: f32,
}

/// One row of a batch. Keep in sync with `struct RowInfo` in `shaders/rows.wgsl` (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuRowInfo {
    /// Cube centre (the view sample, offset toward the viewer's side of its surface).
    pub center: [f32; 3],
    /// View sample index i.
    pub sample: u32,
    /// Distance of the stand-in far point for directional lights.
    pub far_dist: f32,
    /// First of the row's 6 layers, `ROW_NO_MAP` for background samples.
    pub first_layer: u32,
    pub _pad0: [u32; 2],
}

/// Per-dispatch inputs.
pub struct RowsInputs<'a> {
    pub params: RowParams,
    pub view: &'a ViewBuffers,
    /// `GpuLight`s of this dispatch's light chunk.
    pub lights: &'a wgpu::Buffer,
    /// The batch's `GpuRowInfo`s.
    pub rows: &'a wgpu::Buffer,
    /// The batch's cube layers (`GpuShadowLayer`, 6 per row with a map).
    pub layers: &'a wgpu::Buffer,
    pub cube_maps: &'a wgpu::TextureView,
    /// `num_rows * total_lights * 3` f32 (at most one storage binding).
    pub out_rows: &'a wgpu::Buffer,
    pub bvh_nodes: &'a wgpu::Buffer,
    pub bvh_prims: &'a wgpu::Buffer,
    pub stats: &'a wgpu::Buffer,
    /// The spot-texture records (`crate::lights::spot_texture::gpu_table`).
    pub spot_textures: &'a wgpu::Buffer,
    /// The mask table (`crate::gpu::mask::MaskTable`; 16 unused bytes without masks).
    pub masks: &'a wgpu::Buffer,
}

/// The row evaluation pass: pipeline and bind group layout, compiled once.
pub struct RowsPass {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

impl RowsPass {
    pub fn new(device: &wgpu::Device) -> RowsPass {
        let (pipeline, bind_group_layout) = compute_pipeline(
            device,
            "RowsPass",
            shaders::ROWS,
            &[
                uniform(0),
                storage(1, true),
                storage(2, true),
                storage(3, true),
                storage(4, true),
                storage(5, true),
                depth_array(6),
                storage(7, false),
                storage(8, true),
                storage(9, true),
                storage(10, true),
                storage(11, false),
                storage(12, true),
                storage(13, true),
            ],
        );
        RowsPass { pipeline, bind_group_layout }
    }

    /// Dispatch one thread per (row, light): x over `params.num_lights`, y over `params.num_rows`.
    pub fn encode(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, inputs: &RowsInputs) -> crate::error::Result<()> {
        let params = storage_buffer(device, "RowsPass::params", &[inputs.params], wgpu::BufferUsages::UNIFORM)?;
        let gx = (inputs.params.num_lights).div_ceil(WORKGROUP_SIZE).max(1);
        encode_dispatch(
            device,
            encoder,
            "RowsPass",
            (&self.pipeline, &self.bind_group_layout),
            &[
                params.as_entire_binding(),
                inputs.view.samples.as_entire_binding(),
                inputs.view.bsdfs.as_entire_binding(),
                inputs.lights.as_entire_binding(),
                inputs.rows.as_entire_binding(),
                inputs.layers.as_entire_binding(),
                wgpu::BindingResource::TextureView(inputs.cube_maps),
                inputs.out_rows.as_entire_binding(),
                inputs.view.bsdf_tables.as_entire_binding(),
                inputs.bvh_nodes.as_entire_binding(),
                inputs.bvh_prims.as_entire_binding(),
                inputs.stats.as_entire_binding(),
                inputs.spot_textures.as_entire_binding(),
                inputs.masks.as_entire_binding(),
            ],
            (gx, inputs.params.num_rows.max(1)),
        );
        Ok(())
    }
}

/// The 6 cube layers of a row centred at `center` (90-degree faces; near/far planes of a point light
/// there, `shadow::light_layers`: far encloses the scene's bounding sphere).
pub fn row_cube_layers(scene_center: glam::Vec3, scene_radius: f32, center: glam::Vec3, resolution: u32) -> Vec<GpuShadowLayer> {
    let mut set = crate::lights::LightSet::new(scene_center, scene_radius);
    // A point light only carries the cube's centre here; its intensity is unused.
    if set.push_point(center, glam::Vec3::ONE).is_err() {
        return Vec::new();
    }
    crate::gpu::shadow::light_layers(&set, 0, resolution)
}

#[cfg(test)]
mod tests;
