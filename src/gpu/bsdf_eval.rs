//! Batch BSDF evaluation on the GPU: `bsdf_eval` of `shaders/common/bsdf.wgsl` for N (bsdf, wi, wo)
//! triples, read back to the host. Used to check the WGSL twin against `shading::bsdf::eval` and Mitsuba.
use super::GpuContext;
use crate::error::{Error, Result};
use crate::gpu::pipeline::{compute_pipeline, encode_dispatch, storage, uniform};
use crate::gpu::shaders;
use crate::shading::GpuBsdf;
use glam::Vec3;
use std::sync::Arc;

/// Threads per workgroup (mirrored in `shaders/bsdf_eval.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// Uniforms. Keep in sync with `BsdfEvalParams` in `shaders/bsdf_eval.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BsdfEvalParams {
    count: u32,
    broadcast: u32,
    _pad: [u32; 2],
}

/// The compute pipeline (built once per device).
pub struct BsdfEvalPass {
    pipeline: wgpu::ComputePipeline,
    bind_group_layout: wgpu::BindGroupLayout,
}

impl BsdfEvalPass {
    pub fn new(device: &wgpu::Device) -> BsdfEvalPass {
        let (pipeline, bind_group_layout) = compute_pipeline(
            device,
            "BsdfEvalPass",
            shaders::BSDF_EVAL,
            &[uniform(0), storage(1, true), storage(2, true), storage(3, true), storage(4, false)],
        );
        BsdfEvalPass { pipeline, bind_group_layout }
    }

    /// The pass for `ctx`'s device, built on first use.
    fn shared(ctx: &GpuContext) -> Arc<BsdfEvalPass> {
        crate::gpu::pipeline::shared_pass(&ctx.device, BsdfEvalPass::new)
    }
}

/// Evaluate `bsdf_eval(bsdfs[i], wi[i], wo[i])` on the GPU, or `bsdfs[0]` for every i when `broadcast`.
/// `bsdfs` is a record array (`shading::bsdf::resolve_records`: a blend's second record lies in it, past
/// the evaluated ones). `tables` is `shading::bsdf::roughplastic_table_buffer` of the scene the BSDFs came
/// from.
pub fn eval_batch_gpu(ctx: &GpuContext, bsdfs: &[GpuBsdf], broadcast: bool, tables: &[f32], wi: &[Vec3], wo: &[Vec3]) -> Result<Vec<Vec3>> {
    let n = wi.len();
    if wo.len() != n || bsdfs.is_empty() || !(broadcast || bsdfs.len() >= n) {
        return Err(Error::invalid(format!(
            "eval_batch_gpu: wi and wo must have equal lengths and bsdfs at least 1 (broadcast) or N records (got wi {n}, wo {}, bsdfs {})",
            wo.len(),
            bsdfs.len()
        )));
    }
    if n == 0 {
        return Ok(Vec::new());
    }
    let pass = BsdfEvalPass::shared(ctx);
    let device = &ctx.device;
    let params = BsdfEvalParams { count: n as u32, broadcast: broadcast as u32, _pad: [0; 2] };
    let directions: Vec<[f32; 4]> = wi.iter().zip(wo).flat_map(|(a, b)| [a.extend(0.0).to_array(), b.extend(0.0).to_array()]).collect();
    let tables: &[f32] = if tables.is_empty() { &[0.0] } else { tables };
    let init = |label, contents: &[u8], usage| super::alloc::buffer_init(device, label, contents, usage);
    let params_buf = init("BsdfEvalPass::params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM)?;
    let bsdf_buf = init("BsdfEvalPass::bsdfs", bytemuck::cast_slice(bsdfs), wgpu::BufferUsages::STORAGE)?;
    let dir_buf = init("BsdfEvalPass::directions", bytemuck::cast_slice(&directions), wgpu::BufferUsages::STORAGE)?;
    let table_buf = init("BsdfEvalPass::tables", bytemuck::cast_slice(tables), wgpu::BufferUsages::STORAGE)?;
    let out_buf = super::alloc::buffer(
        device,
        &wgpu::BufferDescriptor {
            label: Some("BsdfEvalPass::results"),
            size: (n * 16) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    )?;
    let groups = (n as u32).div_ceil(WORKGROUP_SIZE);
    let gx = groups.min(ctx.limits.max_compute_workgroups_per_dimension.max(1));
    let gy = groups.div_ceil(gx);
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("BsdfEvalPass::encoder") });
    encode_dispatch(
        device,
        &mut enc,
        "BsdfEvalPass",
        (&pass.pipeline, &pass.bind_group_layout),
        &[
            params_buf.as_entire_binding(),
            bsdf_buf.as_entire_binding(),
            dir_buf.as_entire_binding(),
            table_buf.as_entire_binding(),
            out_buf.as_entire_binding(),
        ],
        (gx, gy),
    );
    ctx.queue.submit(Some(enc.finish()));
    let out: Vec<[f32; 4]> = ctx.read_buffer(&out_buf, 0, n)?;
    Ok(out.into_iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
}

#[cfg(test)]
mod tests;
