//! The column pass (`shaders/columns.wgsl`): for a batch of lights whose shadow maps are in a
//! `ShadowAtlas`, shade every view sample from every light of the batch.
//!
//! Column j of the light matrix is light j's direct contribution to each view sample:
//! `bsdf_eval(local wi, local wo) * emitted * visibility`, in Mitsuba's shading frame built from the
//! shading normal (`coordinate_system(n)`; for isotropic BSDFs only its z axis matters; Mitsuba builds
//! its shading frame's tangent from dp/du, so anisotropic BSDFs may differ by a rotation about n).
//! Background samples (`shape_index < 0`) are 0.
//!
//! One thread per view sample loops over the batch's lights (at most `MAX_LIGHTS_PER_DISPATCH`, far below
//! Mesa 22.3's 65,535 loop iterations per invocation) and
//! (a) adds `sum_j w_j column_j` to a GPU-resident RGBA f32 accumulator (read back once at the end),
//! (b) optionally writes the individual columns (`[j][i][rgb]` f32) for readback; the caller keeps that
//!     buffer under the 128 MiB storage-binding limit by sizing batches.
use crate::error::Result;
use crate::gpu::pipeline::{compute_pipeline, depth_array, encode_dispatch, storage, uniform};
use crate::gpu::shaders;
use crate::lights::{LightKind, LightSet};
use crate::view::ViewSamples;

/// Threads per workgroup; mirrored in `columns.wgsl`.
pub const WORKGROUP_SIZE: u32 = 64;
/// Most lights one dispatch loops over.
pub const MAX_LIGHTS_PER_DISPATCH: usize = 256;

/// Keep in sync with `struct Light` in `shaders/common/light.wgsl` (256 bytes: 64 for every kind, then
/// oriented-point / VPL fields, the VPL's 80-byte BSDF and an oriented point's patch, stored in the light itself so the column
/// pass needs no extra binding; its roughplastic table offset indexes the scene's table buffer). A
/// textured spot's texture is in the separate `spot_textures` binding (`crate::lights::spot_texture`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub kind: u32,
    pub direction: [f32; 3],
    pub first_layer: u32,
    pub intensity: [f32; 3],
    pub cos_cutoff: f32,
    /// Spot: cutoff angle (radians); VPL: its virtual-spherical-light radius (m, 0 = a point VPL).
    pub cutoff_angle: f32,
    pub cos_beam: f32,
    pub inv_transition: f32,
    pub is_cube: u32,
    /// Oriented point: emission normal; VPL: shading normal.
    pub normal: [f32; 3],
    /// VPL geometry-term clamp (1/m^2); f32::MAX when there is none.
    pub clamp: f32,
    /// VPL geometric normal.
    pub geo_normal: [f32; 3],
    /// Spot: offset (f32s) of its projected texture's record in the spot-texture buffer
    /// (`crate::lights::spot_texture`), `NO_TEXTURE` when it has none; 0 for other kinds.
    pub texture: u32,
    /// VPL incident direction (toward where its particle came from).
    pub incident: [f32; 3],
    /// Textured spot: tan(cutoff_angle).
    pub tan_cutoff: f32,
    /// VPL BSDF (zero for other kinds).
    pub bsdf: crate::shading::GpuBsdf,
    /// Oriented point: its patch's 4 corners (xyz, w unused; all zero = none; `crate::lights::patch`).
    pub patch: [[f32; 4]; 4],
}

impl GpuLight {
    /// Light j of `lights`, its shadow map starting at `first_layer` of the batch's atlas.
    /// `texture`: its record offset from `crate::lights::spot_texture::gpu_table`. A textured spot's
    /// local x and y axes travel in `normal` and `geo_normal`.
    pub fn new(lights: &LightSet, j: usize, first_layer: u32, is_cube: bool, texture: u32) -> GpuLight {
        let frame = lights.spot_texture[j].as_ref();
        let (cutoff, beam) = (lights.cutoff_angle[j], lights.beam_width[j]);
        let spot = lights.kind[j] == LightKind::Spot;
        GpuLight {
            position: lights.position[j].to_array(),
            kind: lights.kind[j] as u32,
            direction: lights.direction[j].to_array(),
            first_layer,
            intensity: lights.intensity[j].to_array(),
            cos_cutoff: if spot { cutoff.cos() } else { -2.0 },
            cutoff_angle: if lights.kind[j] == LightKind::Vpl { lights.vsl_radius[j] } else { cutoff },
            cos_beam: if spot { beam.cos() } else { -2.0 },
            inv_transition: if cutoff > beam { 1.0 / (cutoff - beam) } else { 0.0 },
            is_cube: is_cube as u32,
            normal: frame.map_or(lights.normal[j], |t| t.x_axis).to_array(),
            clamp: lights.vpl_clamp.min(f32::MAX),
            geo_normal: frame.map_or(lights.geo_normal[j], |t| t.y_axis).to_array(),
            texture: if spot { texture } else { 0 },
            incident: lights.incident[j].to_array(),
            tan_cutoff: frame.map_or(0.0, |t| t.tan_cutoff),
            bsdf: lights.bsdf[j],
            // The glossy-MIS measure rides in the first corner's unused w (`shaders/common/glossy.wgsl`).
            patch: {
                let mut c = lights.patch[j].map(|c| c.extend(0.0).to_array());
                c[0][3] = lights.mis_measure[j];
                c
            },
        }
    }
}

/// Keep in sync with `struct ViewSample` in `shaders/common/view_sample.wgsl` (80 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuViewSample {
    pub position: [f32; 3],
    pub shape_index: i32,
    pub normal: [f32; 3],
    /// `VIEW_FLAG_*` bits (0 for the camera's view samples).
    pub flags: u32,
    pub geo_normal: [f32; 3],
    /// n_B of a glossy view sample (`ViewSamples::bsdf_samples`), 0 for the others.
    pub bsdf_samples: u32,
    pub wi: [f32; 3],
    /// Mitsuba's `valid_ray` factor of a masked sample (`ViewSamples::mask_valid`), 1 for the others.
    pub mask_valid: f32,
    /// RGB throughput of the sample's delta chain (1 for the camera's own hits).
    pub throughput: [f32; 3],
    /// The opacity of a masked sample (`ViewSamples::mask_opacity`), 1 for the others.
    pub mask_opacity: f32,
}

/// `GpuViewSample::flags`: light only from the front side of the geometric normal counts (`wo . n_g > 0`,
/// as `lights::animated::irradiance` demands of gather samples). Keep in sync with `view_sample.wgsl`.
pub const VIEW_FLAG_GEO_FRONT: u32 = 1;
/// `GpuViewSample::flags`: the view belongs to a scene with masked surfaces (`ViewSamples::mask_budget` is
/// not empty); the sample's mask budget, clamped to `VIEW_MASK_BUDGET_UNLIMITED`, is in the bits from
/// `VIEW_MASK_BUDGET_SHIFT` up (`crate::gpu::mask`). Keep in sync with `view_sample.wgsl`.
pub const VIEW_FLAG_MASKS: u32 = 2;
pub const VIEW_MASK_BUDGET_SHIFT: u32 = 16;
/// The stored mask budget that means unlimited (`u32::MAX` in `ViewSamples::mask_budget`). A shadow ray
/// crosses at most `crate::gpu::mask::MAX_CROSSINGS` (< this) masked surfaces either way.
pub const VIEW_MASK_BUDGET_UNLIMITED: u32 = 0xffff;

/// `GpuViewSample::flags` of view sample i: `VIEW_FLAG_MASKS` and its budget when the view has masks.
pub fn view_flags(view: &ViewSamples, i: usize) -> u32 {
    match view.mask_budget.get(i) {
        Some(&b) => VIEW_FLAG_MASKS | b.min(VIEW_MASK_BUDGET_UNLIMITED) << VIEW_MASK_BUDGET_SHIFT,
        None => 0,
    }
}

/// Keep in sync with `struct ColumnParams` in `shaders/columns.wgsl` (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ColumnParams {
    pub num_samples: u32,
    pub num_lights: u32,
    pub write_columns: u32,
    pub accumulate: u32,
    pub resolution: u32,
    pub dispatch_width: u32,
    /// First light (index into the batch's light, weight and column arrays) of this dispatch.
    pub first_light: u32,
    /// `matrix::Visibility as u32`.
    pub visibility: u32,
    pub normal_offset: f32,
    pub depth_bias: f32,
    pub slope_bias: f32,
    /// First view sample of this dispatch (`gpu::dispatch::plan_columns`).
    pub first_sample: u32,
}

/// View samples on the GPU: geometry and throughput (80 B each) and BSDFs (80 B each), separate bindings, plus the
/// rough-plastic tables the BSDFs index (`crate::shading::bsdf::roughplastic_table_buffer`).
pub struct ViewBuffers {
    pub samples: wgpu::Buffer,
    pub bsdfs: wgpu::Buffer,
    pub bsdf_tables: wgpu::Buffer,
    pub num_samples: u32,
}

impl ViewBuffers {
    pub fn upload(device: &wgpu::Device, view: &ViewSamples, bsdf_tables: &[f32]) -> Result<ViewBuffers> {
        let samples: Vec<GpuViewSample> = (0..view.len())
            .map(|i| GpuViewSample {
                position: view.position[i].to_array(),
                shape_index: view.shape_index[i],
                normal: view.normal[i].to_array(),
                flags: view_flags(view, i),
                geo_normal: view.geo_normal[i].to_array(),
                bsdf_samples: view.bsdf_samples.get(i).copied().unwrap_or(0),
                wi: view.wi[i].to_array(),
                mask_valid: view.mask_valid.get(i).copied().unwrap_or(1.0),
                throughput: view.throughput_of(i).to_array(),
                mask_opacity: view.mask_opacity.get(i).copied().unwrap_or(1.0),
            })
            .collect();
        ViewBuffers::from_parts(device, &samples, &view.bsdf, bsdf_tables)
    }

    /// Buffers of any shading points: `samples[i]` shaded with `bsdfs[i]` (blended BSDFs' second records
    /// after the first `samples.len()`), `bsdf_tables` the rough-plastic tables they index.
    pub fn from_parts(
        device: &wgpu::Device,
        samples: &[GpuViewSample],
        bsdfs: &[crate::shading::GpuBsdf],
        bsdf_tables: &[f32],
    ) -> Result<ViewBuffers> {
        let empty = [0u8; 256];
        fn pad<'a>(bytes: &'a [u8], empty: &'a [u8]) -> &'a [u8] {
            if bytes.is_empty() {
                empty
            } else {
                bytes
            }
        }
        let samples_buf = crate::gpu::alloc::buffer_init(
            device,
            "ViewBuffers::samples",
            pad(bytemuck::cast_slice(samples), &empty),
            wgpu::BufferUsages::STORAGE,
        )?;
        let bsdfs = crate::gpu::alloc::buffer_init(
            device,
            "ViewBuffers::bsdfs",
            pad(bytemuck::cast_slice(bsdfs), &empty),
            wgpu::BufferUsages::STORAGE,
        )?;
        let bsdf_tables = storage_buffer(device, "ViewBuffers::bsdf_tables", bsdf_tables, wgpu::BufferUsages::STORAGE)?;
        Ok(ViewBuffers { samples: samples_buf, bsdfs, bsdf_tables, num_samples: samples.len() as u32 })
    }
}

/// Per-dispatch inputs.
pub struct ColumnsInputs<'a> {
    pub params: &'a wgpu::Buffer,
    pub view: &'a ViewBuffers,
    pub lights: &'a wgpu::Buffer,
    pub layers: &'a wgpu::Buffer,
    pub weights: &'a wgpu::Buffer,
    pub shadow_maps: &'a wgpu::TextureView,
    pub accum: &'a wgpu::Buffer,
    pub columns: &'a wgpu::Buffer,
    /// The scene BVH (`gpu::bvh::GpuBvh`) for exact shadow rays.
    pub bvh_nodes: &'a wgpu::Buffer,
    pub bvh_prims: &'a wgpu::Buffer,
    /// The spot-texture records (`crate::lights::spot_texture::gpu_table`).
    pub spot_textures: &'a wgpu::Buffer,
    /// Six u32 (64-bit counters as lo, hi): shadow tests, ray casts, rays that gave up.
    pub stats: &'a wgpu::Buffer,
    /// The mask table (`crate::gpu::mask::MaskTable`; 16 unused bytes without masks).
    pub masks: &'a wgpu::Buffer,
}

pub struct ColumnsPass {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

/// Workgroup counts (x, y) and threads per row for `num_samples` threads.
pub fn dispatch_size(num_samples: u32) -> (u32, u32, u32) {
    let groups = num_samples.div_ceil(WORKGROUP_SIZE).max(1);
    let gx = groups.min(65_535);
    let gy = groups.div_ceil(gx);
    (gx, gy, gx * WORKGROUP_SIZE)
}

impl ColumnsPass {
    pub fn new(device: &wgpu::Device) -> ColumnsPass {
        let (pipeline, bind_group_layout) = compute_pipeline(
            device,
            "ColumnsPass",
            shaders::COLUMNS,
            &[
                uniform(0),
                storage(1, true),
                storage(2, true),
                storage(3, true),
                storage(4, true),
                storage(5, true),
                depth_array(6),
                storage(7, false),
                storage(8, false),
                storage(9, true),
                storage(10, true),
                storage(11, true),
                storage(12, false),
                storage(13, true),
                storage(14, true),
            ],
        );
        ColumnsPass { pipeline, bind_group_layout }
    }

    /// Dispatch one thread per view sample of `samples` (from `params.first_sample`).
    pub fn encode(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, inputs: &ColumnsInputs, samples: u32) {
        let (gx, gy, _) = dispatch_size(samples);
        encode_dispatch(
            device,
            encoder,
            "ColumnsPass",
            (&self.pipeline, &self.bind_group_layout),
            &[
                inputs.params.as_entire_binding(),
                inputs.view.samples.as_entire_binding(),
                inputs.view.bsdfs.as_entire_binding(),
                inputs.lights.as_entire_binding(),
                inputs.layers.as_entire_binding(),
                inputs.weights.as_entire_binding(),
                wgpu::BindingResource::TextureView(inputs.shadow_maps),
                inputs.accum.as_entire_binding(),
                inputs.columns.as_entire_binding(),
                inputs.view.bsdf_tables.as_entire_binding(),
                inputs.bvh_nodes.as_entire_binding(),
                inputs.bvh_prims.as_entire_binding(),
                inputs.stats.as_entire_binding(),
                inputs.spot_textures.as_entire_binding(),
                inputs.masks.as_entire_binding(),
            ],
            (gx, gy),
        );
    }
}

/// A storage buffer initialised with `data` (at least 16 bytes so empty inputs still bind).
/// Errors: `OutOfMemory` / `Gpu` from the guarded allocation (`gpu::alloc`).
pub fn storage_buffer<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, data: &[T], usage: wgpu::BufferUsages) -> Result<wgpu::Buffer> {
    let bytes = bytemuck::cast_slice::<T, u8>(data);
    if bytes.len() < 16 {
        let mut padded = bytes.to_vec();
        padded.resize(16, 0);
        return crate::gpu::alloc::buffer_init(device, label, &padded, usage);
    }
    crate::gpu::alloc::buffer_init(device, label, bytes, usage)
}

#[cfg(test)]
mod tests;
