//! The pixel-mapping pass (`shaders/mapping.wgsl`): applies a `crate::matrix::mapping::PixelMapping`
//! to an image that stays on the GPU, `target[i] (+)= weight * source[map[i]]` (Hašan et al., EGSR
//! 2008, Sec. 5: "Once a representative column is computed, the mappings are applied on the GPU, so that
//! slow readbacks can be avoided until the whole sequence is rendered").
//!
//! Images are RGBA f32 per pixel (`array<vec4<f32>>`, alpha 0), the layout of the column pass's
//! accumulator (`gpu::columns`; fold a pixel's delta-chain samples first, the mapping is per pixel).
//! A mapping is uploaded once ([`upload_mapping`]) and used by any number of dispatches;
//! [`MappingPass::encode`] records one gather into an encoder, so a chain k -> k+1 -> k+2 is a sequence
//! of dispatches ping-ponging two buffers with no readback ([`apply_chain_gpu`]).
use super::GpuContext;
use crate::error::{Error, Result};
use crate::gpu::pipeline::{compute_pipeline, encode_dispatch, storage, uniform};
use crate::gpu::shaders;
use crate::matrix::mapping::PixelMapping;
use std::sync::{Arc, Mutex, OnceLock};

/// Threads per workgroup (mirrored in `shaders/mapping.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// Uniforms. Keep in sync with `MappingParams` in `shaders/mapping.wgsl` (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct MappingParams {
    num_pixels: u32,
    accumulate: u32,
    _pad: [u32; 2],
    weight: [f32; 4],
}

/// One gather: `target (+)= weight * M source`.
pub struct MappingInputs<'a> {
    /// Frame k's image, `num_pixels` RGBA f32 texels.
    pub source: &'a wgpu::Buffer,
    /// The index array (`upload_mapping`).
    pub mapping: &'a wgpu::Buffer,
    /// Frame l's image, `num_pixels` RGBA f32 texels (STORAGE).
    pub target: &'a wgpu::Buffer,
    pub num_pixels: u32,
    /// RGB scale.
    pub weight: [f32; 3],
    /// Add to the target instead of overwriting it.
    pub accumulate: bool,
}

/// The compute pipeline (built once per device).
pub struct MappingPass {
    pipeline: wgpu::ComputePipeline,
    bind_group_layout: wgpu::BindGroupLayout,
}

impl MappingPass {
    pub fn new(device: &wgpu::Device) -> MappingPass {
        let (pipeline, bind_group_layout) =
            compute_pipeline(device, "MappingPass", shaders::MAPPING, &[uniform(0), storage(1, true), storage(2, true), storage(3, false)]);
        MappingPass { pipeline, bind_group_layout }
    }

    /// The pass for `ctx`'s device, built on first use.
    pub fn shared(ctx: &GpuContext) -> Arc<MappingPass> {
        static PASSES: OnceLock<Mutex<Vec<(wgpu::Device, Arc<MappingPass>)>>> = OnceLock::new();
        let mut passes = PASSES.get_or_init(|| Mutex::new(Vec::new())).lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = passes.iter().find(|(d, _)| *d == ctx.device) {
            return p.clone();
        }
        let p = Arc::new(MappingPass::new(&ctx.device));
        passes.push((ctx.device.clone(), p.clone()));
        p
    }

    /// Record one gather into `encoder`.
    pub fn encode(&self, ctx: &GpuContext, encoder: &mut wgpu::CommandEncoder, inputs: &MappingInputs) -> Result<()> {
        let params = MappingParams {
            num_pixels: inputs.num_pixels,
            accumulate: inputs.accumulate as u32,
            _pad: [0; 2],
            weight: [inputs.weight[0], inputs.weight[1], inputs.weight[2], 0.0],
        };
        let params_buf =
            super::alloc::buffer_init(&ctx.device, "MappingPass::params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM)?;
        let groups = inputs.num_pixels.div_ceil(WORKGROUP_SIZE).max(1);
        let gx = groups.min(ctx.limits.max_compute_workgroups_per_dimension.max(1));
        let gy = groups.div_ceil(gx);
        encode_dispatch(
            &ctx.device,
            encoder,
            "MappingPass",
            (&self.pipeline, &self.bind_group_layout),
            &[
                params_buf.as_entire_binding(),
                inputs.source.as_entire_binding(),
                inputs.mapping.as_entire_binding(),
                inputs.target.as_entire_binding(),
            ],
            (gx, gy),
        );
        Ok(())
    }
}

/// Upload a mapping's index array (after checking every index).
pub fn upload_mapping(ctx: &GpuContext, mapping: &PixelMapping) -> Result<wgpu::Buffer> {
    mapping.validate()?;
    super::alloc::buffer_init(&ctx.device, "MappingPass::mapping", bytemuck::cast_slice(&mapping.source), wgpu::BufferUsages::STORAGE)
}

/// `count` RGB images (`count * m * 3` floats) as one RGBA storage buffer per image.
fn upload_images(ctx: &GpuContext, images: &[f32], m: usize) -> Result<Vec<wgpu::Buffer>> {
    images
        .chunks(m * 3)
        .map(|img| {
            let rgba: Vec<[f32; 4]> = img.chunks(3).map(|c| [c[0], c[1], c[2], 0.0]).collect();
            super::alloc::buffer_init(
                &ctx.device,
                "MappingPass::image",
                bytemuck::cast_slice(&rgba),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            )
        })
        .collect()
}

/// Apply the chain `maps[0]`, then `maps[1]`, ... on the GPU to `count` RGB images
/// (`images.len() = count * m * 3`, m pixels each), one dispatch per mapping and image, ping-ponging two
/// GPU buffers per image, read back once at the end. With one mapping this is `M x`.
///
/// Errors: `InvalidParameter` for no mappings, mappings of different sizes, an index out of range or
/// images that are not whole frames; `Gpu` errors of the device.
pub fn apply_chain_gpu(ctx: &GpuContext, maps: &[&PixelMapping], images: &[f32]) -> Result<Vec<f32>> {
    let first = maps.first().ok_or_else(|| Error::invalid("apply_chain_gpu: no mappings"))?;
    let m = first.num_pixels();
    if maps.iter().any(|p| (p.width, p.height) != (first.width, first.height)) {
        return Err(Error::invalid("apply_chain_gpu: mappings of different sizes"));
    }
    if m == 0 || images.len() % (m * 3) != 0 {
        return Err(Error::invalid(format!(
            "apply_mapping: {} values are not whole images of {}x{} pixels x 3 channels",
            images.len(),
            first.width,
            first.height
        )));
    }
    let pass = MappingPass::shared(ctx);
    let index_bufs = maps.iter().map(|p| upload_mapping(ctx, p)).collect::<Result<Vec<_>>>()?;
    let sources = upload_images(ctx, images, m)?;
    let scratch: Vec<wgpu::Buffer> = (0..sources.len())
        .map(|_| {
            super::alloc::buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some("MappingPass::scratch"),
                    size: (m * 16) as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            )
        })
        .collect::<Result<_>>()?;
    let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("MappingPass::encoder") });
    for (a, b) in sources.iter().zip(&scratch) {
        let (mut from, mut to) = (a, b);
        for index in &index_bufs {
            pass.encode(
                ctx,
                &mut enc,
                &MappingInputs { source: from, mapping: index, target: to, num_pixels: m as u32, weight: [1.0; 3], accumulate: false },
            )?;
            std::mem::swap(&mut from, &mut to);
        }
    }
    ctx.queue.submit(Some(enc.finish()));
    // After an odd number of passes the result is in the scratch buffer, else back in the source.
    let results = if index_bufs.len() % 2 == 1 { &scratch } else { &sources };
    let mut out = Vec::with_capacity(images.len());
    for buf in results {
        let rgba: Vec<[f32; 4]> = ctx.read_buffer(buf, 0, m)?;
        out.extend(rgba.iter().flat_map(|p| [p[0], p[1], p[2]]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
