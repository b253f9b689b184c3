//! Clustered visibility on the GPU (`shaders/clustered_visibility.wgsl`; what is computed: module docs of
//! `cluster::visibility`). Two stages of one compute pipeline over the light matrix's own GPU resources
//! (`matrix::gpu::GpuBackend`: view-sample and BSDF buffers, the scene BVH):
//! 1. visibility: one thread per (view cluster, cluster light) pair casts the exact shadow ray
//!    (common/bvh.wgsl, the columns' rays) from the view cluster's representative and `atomicOr`s its
//!    bit into the bit-packed K_view x ceil(K_light / 32) u32 matrix, which stays on the GPU; in a scene
//!    with masked surfaces the ray walks through them (common/mask.wgsl's `mask_transmittance`, the
//!    columns' exact masked rays) and the same buffer also holds the crossings (bits) and the K_view x
//!    K_light transmittances (f32); pairs go in dispatches of at most `PAIRS_PER_DISPATCH`, each waited
//!    for (interruptible).
//! 2. shading: one thread per view sample loops over a range of cluster lights (Eq. 6) with the
//!    visibility interpolated over its F view clusters (Eq. 9) and adds to an RGBA f32 accumulator;
//!    ranges hold at most `SHADE_LOOP_BUDGET / (F + 1)` lights, so an invocation's loops stay below
//!    Mesa's 65,535 iterations whatever K_light is.
//!
//! Only the image (m x 16 bytes) and the visibility matrix are read back. The stages' seconds exclude the
//! set-up (uploads, the pipeline compiled on a matrix's first call).
//!
//! GPU memory besides the backend's: cluster lights (256 B each), membership (8 B per sample and
//! column), representatives (4 B per view cluster), the visibility matrix (4 B per word; masked scenes
//! twice that plus 4 B per pair) and the accumulator (16 B per sample). A backend made with shadow-map-only visibility has no BVH; one is
//! built and uploaded here then.
use super::bvh::GpuBvh;
use super::columns::{dispatch_size, storage_buffer, GpuLight};
use super::pipeline::{compute_pipeline, encode_dispatch, storage, uniform};
use crate::cluster::visibility::{seconds, words_per_row, ClusteredImage, ClusteredShading, VisibilityMatrix};
use crate::error::{Error, Result};
use crate::gpu::shaders;
use crate::matrix::gpu::GpuBackend;
use crate::matrix::Visibility;
use std::time::Instant;

/// Threads per workgroup; mirrored in the WGSL.
pub const WORKGROUP_SIZE: u32 = 64;
/// Most (view cluster, light) pairs per visibility dispatch.
pub const PAIRS_PER_DISPATCH: u64 = 1 << 22;
/// Most loop iterations of one shading invocation: lights per dispatch times (F + 1).
pub const SHADE_LOOP_BUDGET: usize = 48_000;
/// Shading loop count per dispatch for fuzziness `f`.
pub fn lights_per_dispatch(f: usize) -> usize {
    (SHADE_LOOP_BUDGET / (f + 1)).max(1)
}

const STAGE_VISIBILITY: u32 = 0;
const STAGE_SHADE: u32 = 1;
const NO_REPRESENTATIVE: u32 = u32::MAX;

/// Keep in sync with `struct ClusteredParams` in `shaders/clustered_visibility.wgsl` (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClusteredParams {
    pub stage: u32,
    pub num_samples: u32,
    pub num_lights: u32,
    pub words: u32,
    pub num_view_clusters: u32,
    pub fuzziness: u32,
    pub dispatch_width: u32,
    pub first: u32,
    pub count: u32,
    /// Shading: the view samples `[first_sample, first_sample + num_dispatch_samples)` of this
    /// dispatch (`gpu::dispatch::plan_clustered_shading`).
    pub first_sample: u32,
    pub num_dispatch_samples: u32,
    /// 1 in a scene with masked surfaces (the visibility buffer's layout: `shaders/clustered_visibility.wgsl`).
    pub masked: u32,
}

/// The compiled pipeline.
pub struct ClusteredVisibilityPass {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

impl ClusteredVisibilityPass {
    pub fn new(device: &wgpu::Device) -> ClusteredVisibilityPass {
        let mut entries = vec![uniform(0)];
        entries.extend((1..=10).map(|b| storage(b, true)));
        entries.extend((11..=12).map(|b| storage(b, false)));
        entries.push(storage(13, true));
        let (pipeline, bind_group_layout) = compute_pipeline(device, "ClusteredVisibilityPass", shaders::CLUSTERED_VISIBILITY, &entries);
        ClusteredVisibilityPass { pipeline, bind_group_layout }
    }
}

/// Renders `job` with the GPU resources of `backend` (module docs): the image (pixels), the visibility
/// matrix, rays and per-stage seconds.
///
/// Errors: `InvalidParameter` when a buffer exceeds the storage binding limit or the pair count
/// exceeds 2^32; GPU errors; `Interrupted` on Ctrl-C between dispatches.
pub fn render(backend: &GpuBackend, job: &ClusteredShading) -> Result<ClusteredImage> {
    let ctx = &backend.ctx;
    let device = &ctx.device;
    let view = &backend.view;
    let m = view.len();
    let lights = &job.lights.lights;
    let (k_view, k_light, f) = (job.view_reps.len(), lights.len(), job.membership.f);
    let words = words_per_row(k_light);
    let masked = backend.has_masks;
    // The visibility buffer: bits, then (masked) crossing bits and transmittances, then the rays that gave up.
    let bit_words = k_view * words;
    let vis_words = bit_words + if masked { bit_words + k_view * k_light } else { 0 } + 1;
    let pairs = k_view as u64 * k_light as u64;
    if pairs >= u32::MAX as u64 {
        return Err(Error::invalid(format!(
            "{k_view} view clusters x {k_light} light clusters = {pairs} pairs: at most 2^32 - 1 fit the GPU pass"
        )));
    }
    let sizes = [
        ("the cluster lights", k_light as u64 * std::mem::size_of::<GpuLight>() as u64),
        ("the membership", (m * f) as u64 * 4),
        ("the visibility matrix", vis_words as u64 * 4),
        ("the accumulator", m as u64 * 16),
    ];
    for (what, bytes) in sizes {
        if bytes > backend.max_binding {
            return Err(Error::invalid(format!("{what} need {bytes} bytes, above the {}-byte storage binding limit", backend.max_binding)));
        }
    }
    crate::memory::check_gpu(ctx, "clustered visibility buffers", sizes.iter().map(|s| s.1 as u128).sum(), false)?;
    let own_bvh;
    let bvh = if backend.opts.visibility == Visibility::ShadowMap && !masked {
        own_bvh = GpuBvh::upload(device, &backend.scene, backend.max_binding)?;
        &own_bvh
    } else {
        &backend.bvh
    };
    let (texels, offsets) = crate::lights::spot_texture::gpu_table(lights);
    let gpu_lights: Vec<GpuLight> = (0..k_light)
        .map(|c| {
            let mut l = GpuLight::new(lights, c, 0, false, offsets[c]);
            if masked {
                let [pdf, passes] = crate::gpu::mask::light_fields(view, lights, c, backend.directional_crosses_masks);
                (l.patch[1][3], l.patch[2][3]) = (pdf, passes);
            }
            l
        })
        .collect();
    let usage = wgpu::BufferUsages::STORAGE;
    let lights_buf = storage_buffer(device, "ClusteredVisibility::lights", &gpu_lights, usage)?;
    let spot_buf = storage_buffer(device, "ClusteredVisibility::spot_textures", &texels, usage)?;
    let reps: Vec<u32> = job.view_reps.sample.iter().map(|s| s.map_or(NO_REPRESENTATIVE, |i| i as u32)).collect();
    let reps_buf = storage_buffer(device, "ClusteredVisibility::representatives", &reps, usage)?;
    let clusters_buf = storage_buffer(device, "ClusteredVisibility::membership_clusters", &job.membership.clusters, usage)?;
    let weights_buf = storage_buffer(device, "ClusteredVisibility::membership_weights", &job.membership.weights, usage)?;
    let vis_buf = storage_buffer(device, "ClusteredVisibility::visibility", &vec![0u32; vis_words], usage | wgpu::BufferUsages::COPY_SRC)?;
    let accum = crate::gpu::alloc::buffer(
        device,
        &wgpu::BufferDescriptor {
            label: Some("ClusteredVisibility::accum"),
            size: (m as u64 * 16).max(16),
            usage: usage | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    )?;
    let pass = super::pipeline::shared_pass(device, ClusteredVisibilityPass::new);
    let base = ClusteredParams {
        stage: STAGE_VISIBILITY,
        num_samples: m as u32,
        num_lights: k_light as u32,
        words: words as u32,
        num_view_clusters: k_view as u32,
        fuzziness: f as u32,
        dispatch_width: 0,
        first: 0,
        count: 0,
        first_sample: 0,
        num_dispatch_samples: 0,
        masked: masked as u32,
    };
    let run = |params: ClusteredParams, threads: u32, label: &str| -> Result<()> {
        crate::interrupt::check()?;
        let (gx, gy, width) = dispatch_size(threads);
        let params = ClusteredParams { dispatch_width: width, ..params };
        let params_buf = storage_buffer(device, "ClusteredVisibility::params", &[params], wgpu::BufferUsages::UNIFORM)?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        encode_dispatch(
            device,
            &mut encoder,
            "ClusteredVisibilityPass",
            (&pass.pipeline, &pass.bind_group_layout),
            &[
                params_buf.as_entire_binding(),
                backend.view_buffers.samples.as_entire_binding(),
                backend.view_buffers.bsdfs.as_entire_binding(),
                backend.view_buffers.bsdf_tables.as_entire_binding(),
                lights_buf.as_entire_binding(),
                spot_buf.as_entire_binding(),
                bvh.nodes.as_entire_binding(),
                bvh.primitives.as_entire_binding(),
                reps_buf.as_entire_binding(),
                clusters_buf.as_entire_binding(),
                weights_buf.as_entire_binding(),
                vis_buf.as_entire_binding(),
                accum.as_entire_binding(),
                backend.masks.as_entire_binding(),
            ],
            (gx, gy),
        );
        let submission = ctx.queue.submit(Some(encoder.finish()));
        crate::interrupt::wait_gpu(device, Some(submission), label)
    };
    // Stage 1: the visibility matrix (set-up above: uploads and the pipeline, compiled once per matrix).
    let t0 = Instant::now();
    let mut first = 0u64;
    while first < pairs {
        let count = PAIRS_PER_DISPATCH.min(pairs - first) as u32;
        run(ClusteredParams { first: first as u32, count, ..base }, count, "clustered visibility rays")?;
        first += count as u64;
    }
    let visibility_seconds = seconds(t0);
    // Stage 2: shading, the lights in ranges.
    let t1 = Instant::now();
    // Light ranges within Mesa's loop cap, samples split for the work budget (`gpu::dispatch`).
    for d in crate::gpu::dispatch::plan_clustered_shading(m as u32, k_light as u32, lights_per_dispatch(f) as u32, f as u32) {
        let params = ClusteredParams {
            stage: STAGE_SHADE,
            first: d.first_light,
            count: d.num_lights,
            first_sample: d.first_sample,
            num_dispatch_samples: d.num_samples,
            ..base
        };
        run(params, d.num_samples, "clustered shading")?;
    }
    let rgba = ctx.read_buffer::<[f32; 4]>(&accum, 0, m)?;
    let rgb: Vec<f32> = rgba.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
    let image = if m == view.num_pixels() { rgb } else { view.fold(&rgb, 3) };
    let shading_seconds = seconds(t1);
    let mut bits = ctx.read_buffer::<u32>(&vis_buf, 0, vis_words)?;
    let gave_up = bits.pop().unwrap_or(0) as u64;
    let (transmittance, crossed) = if masked {
        let rest = bits.split_off(bit_words);
        let (crossed, transmittance) = rest.split_at(bit_words);
        (transmittance.iter().map(|&w| f32::from_bits(w)).collect(), crossed.to_vec())
    } else {
        (Vec::new(), Vec::new())
    };
    Ok(ClusteredImage {
        image,
        visibility: VisibilityMatrix { rows: k_view, cols: k_light, bits, transmittance, crossed },
        rays: job.rays(),
        gave_up,
        visibility_seconds,
        shading_seconds,
    })
}

#[cfg(test)]
mod tests;
