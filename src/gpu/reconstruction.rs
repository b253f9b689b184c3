//! Tensor clustering's reconstruction kept on the GPU (`shaders/reconstruction.wgsl`; Hašan, Velázquez,
//! Pellacini, Bala, "Tensor Clustering for Rendering Many-Light Animations", EGSR 2008, Sec. 4.5 and 5:
//! "Once a representative column is computed, the mappings are applied on the GPU, so that slow
//! readbacks can be avoided until the whole sequence is rendered"). The GPU twin of
//! `crate::matrix::reconstruction::accumulate`, with the same definition
//!
//!   frame_k(i) = sum_c Rec(c, k) * col_c(pi_{k0_c -> k}(i)).
//!
//! [`reconstruct`] renders every representative column in its own frame k0 with that frame's
//! `GpuBackend` (`columns_on_gpu`: shadow maps + column pass into a GPU buffer), then the dispatches of
//! each (batch, window of target frames), split within the work budget (`gpu::dispatch`), walk each
//! target pixel's chain of mappings back to frame k0, fold the delta-chain samples of the source pixel
//! and add the Rec-scaled columns of the batch to the frame's accumulator (each (frame, pixel) by one
//! invocation, so the split does not change a bit). Nothing is read back until every batch is done; then the accumulators are read
//! once.
//!
//! Memory: the pixel mappings of the stretch of frames (2 (f - 1) P u32: call it per chunk of frames,
//! as tensor clustering does) and the accumulators (f P RGBA f32, split into windows of frames that fit
//! the storage binding limit); one batch of columns (as `LightMatrix.columns`).
//!
//! Sums run in float32 in batch order, so the result equals the CPU's to float round-off, not bit for
//! bit.
//!
//! Symbols: f frames of the stretch, P pixels, m view samples of a frame (P + delta-chain extras), c
//! representatives, k0 a representative's frame, Rec the c x f (RGB) reconstruction matrix.
use super::pipeline::{compute_pipeline, encode_dispatch, storage, uniform};
use super::GpuContext;
use crate::error::{Error, Result};
use crate::gpu::shaders;
use crate::matrix::LightMatrix;
use std::sync::Arc;

/// Threads per workgroup (mirrored in `shaders/reconstruction.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// Columns per batch: bounds the shader's loop over a batch (far below Mesa's 65,535-iteration cut).
pub const MAX_BATCH: usize = 256;

/// Uniforms. Keep in sync with `Params` in `shaders/reconstruction.wgsl` (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    num_pixels: u32,
    num_samples: u32,
    num_columns: u32,
    source_frame: u32,
    first_frame: u32,
    num_frames: u32,
    window_start: u32,
    rec_frames: u32,
    first_item: u32,
    dispatch_width: u32,
    _pad0: u32,
    _pad1: u32,
}

/// The compute pipeline (built once per device).
pub struct ReconstructionPass {
    pipeline: wgpu::ComputePipeline,
    bind_group_layout: wgpu::BindGroupLayout,
}

impl ReconstructionPass {
    pub fn new(device: &wgpu::Device) -> ReconstructionPass {
        let (pipeline, bind_group_layout) = compute_pipeline(
            device,
            "ReconstructionPass",
            shaders::RECONSTRUCTION,
            &[
                uniform(0),
                storage(1, true),
                storage(2, true),
                storage(3, true),
                storage(4, true),
                storage(5, true),
                storage(6, true),
                storage(7, false),
            ],
        );
        ReconstructionPass { pipeline, bind_group_layout }
    }

    /// The pass for `ctx`'s device, built on first use.
    pub fn shared(ctx: &GpuContext) -> Arc<ReconstructionPass> {
        crate::gpu::pipeline::shared_pass(&ctx.device, ReconstructionPass::new)
    }
}

/// The reconstructed frames and where the time went.
#[derive(Debug)]
pub struct GpuReconstruction {
    /// f * P * 3 floats: frame, pixel (row 0 at the top), RGB.
    pub frames: Vec<f32>,
    /// Shadow maps and column passes of the representatives.
    pub columns_seconds: f64,
    /// Scaling, mapping and accumulating them, and the one readback.
    pub reconstruction_seconds: f64,
}

fn buffer<T: bytemuck::Pod>(ctx: &GpuContext, label: &str, data: &[T]) -> Result<wgpu::Buffer> {
    // wgpu rejects empty bindings: pad to one element.
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let padded;
    let contents = if bytes.is_empty() {
        padded = [0u8; 16];
        &padded[..]
    } else {
        bytes
    };
    super::alloc::buffer_init(&ctx.device, label, contents, wgpu::BufferUsages::STORAGE)
}

/// Renders and accumulates a stretch of f frames (module docs).
///
/// - `frames`: the f frames' light matrices, all on the GPU backend of one device, with the same image
///   size;
/// - `representatives`: (light, frame) per representative, frame in [0, f);
/// - `rec`: c x f x 3, Rec(c, k) per RGB channel (0 where representative c does not serve frame k);
/// - `forward`, `backward`: f - 1 pixel mappings of P entries each (`crate::matrix::reconstruction`).
///
/// Errors: `InvalidParameter` for a frame not on the GPU, frames on different devices or of different
/// sizes, a light index out of range, inputs `accumulate` would reject, more than 65,535 frames; device
/// errors; `Interrupted` on Ctrl-C.
pub fn reconstruct(
    frames: &[&LightMatrix],
    representatives: &[(u32, u32)],
    rec: &[f32],
    forward: &[&[u32]],
    backward: &[&[u32]],
) -> Result<GpuReconstruction> {
    let f = frames.len();
    if f == 0 {
        return Err(Error::invalid("no frames to reconstruct"));
    }
    if f > 65_535 {
        return Err(Error::invalid(format!("{f} frames in one stretch: reconstruct at most 65,535 at a time (a chunk)")));
    }
    let gpus = frames
        .iter()
        .enumerate()
        .map(|(k, m)| m.gpu_backend().ok_or_else(|| Error::invalid(format!("frame {k}'s light matrix is not on the GPU"))))
        .collect::<Result<Vec<_>>>()?;
    let ctx = gpus[0].ctx.clone();
    let (w, h) = (gpus[0].view.width, gpus[0].view.height);
    let p = gpus[0].view.num_pixels();
    for (k, g) in gpus.iter().enumerate() {
        if !Arc::ptr_eq(&g.ctx, &ctx) && g.ctx.device != ctx.device {
            return Err(Error::invalid(format!("frame {k}'s light matrix is on another GPU device than frame 0's")));
        }
        if g.view.num_pixels() != p {
            return Err(Error::invalid(format!("frame {k} has {} pixels, frame 0 {p}", g.view.num_pixels())));
        }
    }
    let source: Vec<u32> = representatives.iter().map(|r| r.1).collect();
    crate::matrix::reconstruction::check_inputs(f, p, &source, rec, forward, backward)?;
    for (c, &(j, k0)) in representatives.iter().enumerate() {
        let n = gpus[k0 as usize].lights.len();
        if j as usize >= n {
            return Err(Error::invalid(format!("representative {c}: light {j} of frame {k0} is outside [0, {n})")));
        }
    }
    let pass = ReconstructionPass::shared(&ctx);
    let max_binding = ctx.limits.max_storage_buffer_binding_size as u64;
    let map_bytes = (f.saturating_sub(1) * p * 4) as u64;
    if map_bytes > max_binding {
        return Err(Error::invalid(format!(
            "the pixel mappings of {f} frames of {p} pixels take {map_bytes} bytes, above the {max_binding}-byte storage \
             binding limit: reconstruct fewer frames at a time (a smaller chunk)"
        )));
    }
    let flat = |maps: &[&[u32]]| -> Vec<u32> { maps.iter().flat_map(|m| m.iter().copied()).collect() };
    let forward_buf = buffer(&ctx, "ReconstructionPass::forward", &flat(forward))?;
    let backward_buf = buffer(&ctx, "ReconstructionPass::backward", &flat(backward))?;
    // Accumulator windows of frames, each within the binding limit.
    let frame_bytes = (p as u64 * 16).max(16);
    let per_window = ((max_binding.min(1 << 30) / frame_bytes) as usize).max(1);
    if frame_bytes > max_binding {
        return Err(Error::invalid(format!("one frame of {p} RGBA f32 pixels exceeds the storage binding limit")));
    }
    crate::memory::check_host(
        &format!("tensor reconstruction: {f} frames x {p} pixels x RGB float32"),
        crate::memory::product(&[f as u64, p as u64, 12]),
    )?;
    let windows: Vec<(usize, usize)> = (0..f).step_by(per_window).map(|a| (a, (a + per_window).min(f))).collect();
    let accs: Vec<wgpu::Buffer> = windows
        .iter()
        .map(|&(a, b)| {
            super::alloc::buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some("ReconstructionPass::acc"),
                    size: (b - a) as u64 * frame_bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            )
        })
        .collect::<Result<_>>()?;
    let (mut columns_seconds, mut reconstruction_seconds) = (0.0, 0.0);
    let budget = super::dispatch::budget();
    for k0 in 0..f {
        let group: Vec<usize> = (0..representatives.len()).filter(|&c| source[c] as usize == k0).collect();
        if group.is_empty() {
            continue;
        }
        let g = gpus[k0];
        let m = g.view.len();
        // Frame k0's delta-chain extras per pixel, as CSR.
        let mut extra_start = vec![0u32; p + 1];
        for &px in &g.view.extra_pixel {
            extra_start[px as usize + 1] += 1;
        }
        for i in 0..p {
            extra_start[i + 1] += extra_start[i];
        }
        let mut fill = extra_start.clone();
        let mut extra_index = vec![0u32; g.view.extra_pixel.len()];
        for (e, &px) in g.view.extra_pixel.iter().enumerate() {
            extra_index[fill[px as usize] as usize] = (p + e) as u32;
            fill[px as usize] += 1;
        }
        let max_extras = extra_start.windows(2).map(|w| (w[1] - w[0]) as u64).max().unwrap_or(0);
        let extra_start_buf = buffer(&ctx, "ReconstructionPass::extra_start", &extra_start)?;
        let extra_index_buf = buffer(&ctx, "ReconstructionPass::extra_index", &extra_index)?;
        let js: Vec<usize> = group.iter().map(|&c| representatives[c].0 as usize).collect();
        g.columns_on_gpu(&js, MAX_BATCH, &mut |columns, range, seconds| {
            columns_seconds += seconds;
            let t = std::time::Instant::now();
            let batch = &group[range];
            let rec4: Vec<[f32; 4]> = batch
                .iter()
                .flat_map(|&c| (0..f).map(move |k| (c, k)))
                .map(|(c, k)| {
                    let s = &rec[(c * f + k) * 3..(c * f + k) * 3 + 3];
                    [s[0], s[1], s[2], 0.0]
                })
                .collect();
            // Target frames this batch serves.
            let served: Vec<usize> =
                (0..f).filter(|&k| batch.iter().any(|&c| rec[(c * f + k) * 3..(c * f + k) * 3 + 3].iter().any(|&v| v != 0.0))).collect();
            let (Some(&lo), Some(&hi)) = (served.first(), served.last()) else {
                return Ok(());
            };
            let rec_buf = buffer(&ctx, "ReconstructionPass::rec", &rec4)?;
            let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ReconstructionPass") });
            for (wi, &(a, b)) in windows.iter().enumerate() {
                let (first, last) = (lo.max(a), hi.min(b - 1));
                if first > last {
                    continue;
                }
                let num_frames = (last - first + 1) as u32;
                // Work per (target frame, pixel): the mapping chain back to k0, then every column's
                // sample and the most extras of one pixel (`gpu::dispatch::plan_reconstruction`).
                let chain = (first.abs_diff(k0)).max(last.abs_diff(k0)) as u64;
                let cost = chain + batch.len() as u64 * (1 + max_extras);
                for d in super::dispatch::plan_reconstruction(num_frames * p as u32, cost, &budget) {
                    let gx = d.count.div_ceil(WORKGROUP_SIZE).max(1);
                    let params = Params {
                        num_pixels: p as u32,
                        num_samples: m as u32,
                        num_columns: batch.len() as u32,
                        source_frame: k0 as u32,
                        first_frame: first as u32,
                        num_frames,
                        window_start: a as u32,
                        rec_frames: f as u32,
                        first_item: d.first,
                        dispatch_width: gx,
                        _pad0: 0,
                        _pad1: 0,
                    };
                    let params_buf = super::alloc::buffer_init(
                        &ctx.device,
                        "ReconstructionPass::params",
                        bytemuck::bytes_of(&params),
                        wgpu::BufferUsages::UNIFORM,
                    )?;
                    encode_dispatch(
                        &ctx.device,
                        &mut encoder,
                        "ReconstructionPass",
                        (&pass.pipeline, &pass.bind_group_layout),
                        &[
                            params_buf.as_entire_binding(),
                            columns.as_entire_binding(),
                            rec_buf.as_entire_binding(),
                            forward_buf.as_entire_binding(),
                            backward_buf.as_entire_binding(),
                            extra_start_buf.as_entire_binding(),
                            extra_index_buf.as_entire_binding(),
                            accs[wi].as_entire_binding(),
                        ],
                        (gx, 1),
                    );
                }
            }
            let submission = ctx.queue.submit(Some(encoder.finish()));
            crate::interrupt::wait_gpu(&ctx.device, Some(submission), "a tensor reconstruction batch")?;
            reconstruction_seconds += t.elapsed().as_secs_f64();
            Ok(())
        })?;
    }
    let t = std::time::Instant::now();
    let mut out = Vec::with_capacity(f * p * 3);
    for (wi, &(a, b)) in windows.iter().enumerate() {
        let rgba = ctx.read_buffer::<[f32; 4]>(&accs[wi], 0, (b - a) * p)?;
        out.extend(rgba.iter().flat_map(|v| [v[0], v[1], v[2]]));
    }
    reconstruction_seconds += t.elapsed().as_secs_f64();
    debug_assert_eq!(out.len(), f * (w as usize) * (h as usize) * 3);
    Ok(GpuReconstruction { frames: out, columns_seconds, reconstruction_seconds })
}
