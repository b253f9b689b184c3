//! Relighting on the GPU (Hašan, Pellacini, Bala, SIGGRAPH 2006, Sec. 3.5 and 5): the same result as
//! `relight::relight` (the CPU), with every stage on the device and one readback per relight.
//!
//! Uploaded once (`GpuRelight::new`): the transfer's F_d^w rows; with `bounces` > 1 its gather-to-gather
//! rows or its photon-mapped M_E^w rows (RGB: three values per coefficient), in gather-image order (row p
//! = the sample at gather-image pixel p); its glossy F_g^w rows (one per pixel) with the pixels' k_g --
//! all as CSR buffers (row starts, u32 indices, f32 values; split into parts of rows that each fit one
//! storage binding); the wavelet lights' image norms of F_d^w and F_g^w, the pixels' diffuse albedo, the
//! gather image's k_d, the gather samples as shading points, and a light-matrix GPU backend
//! (`matrix::gpu::GpuBackend`: scene triangles for shadow maps, BVH for exact rays, the view samples).
//!
//! Per relight (`GpuRelight::relight`), for any `LightSet`:
//! 1. shadow maps of the lights, rendered once (`ColumnOptions::visibility`: hybrid by default);
//! 2. direct light at the gather samples by the column pass: each gather sample is a shading point with a
//!    diffuse BSDF of reflectance 1 (f = cos / pi), throughput k_d(g), wi along its normal and
//!    `VIEW_FLAG_GEO_FRONT` (light from the front of its geometric normal only, as
//!    `lights::animated::irradiance`), so the column sum over the lights is
//!    k_d(g) / pi * sum_j L_j cos_j V_j = B_1(g), the gather samples' outgoing radiance, written straight
//!    into the gather image (the samples are uploaded in gather-image order);
//! 3. direct light at the view samples: the same column pass over the camera's view samples (the
//!    light matrix's column sum, delta-chain samples included);
//! 4. with `bounces` b > 1, as `relight::bounce`: b - 1 times B_{k+1} = k_d / pi (F_gg^w W B_k),
//!    total += B_{k+1} (gather-to-gather rows); or once total = B_1 + k_d / pi (M_E^w W B_1) with the
//!    photon-mapped M (`multibounce::apply`: RGB rows, each value times its channel of the light);
//! 5. the Haar transform of the total, on-the-fly culling of wavelet lights by epsilon (3.5) against
//!    F_d^w's image norms, and, with glossy pixels, a second culling of the same lights against F_g^w's
//!    image norms into their own buffer (`glossy::add_glossy`);
//! 6. the sparse product per row, times the row sample's k_d / pi, plus (glossy samples) k_g times the
//!    glossy row's product, summed per pixel (with masks, over the pixel's view samples), plus its direct
//!    light;
//! 7. one readback of the H x W x 3 image (and the three culling counters in the same copy).
//!
//! Masked surfaces (`relight::masks` module docs): every view sample has a row; its albedo and glossy
//! colour are uploaded times its throughput, and `combine` adds a pixel's extra samples' indirect light to
//! its own (`RelightParams::count` > `num_rows`). The gather samples carry the mask flag and the gather
//! budget (so the column pass crosses masks as the CPU's `irradiance` does) and the throughput k_d times
//! their opacity; the gather-to-gather bounce reflects k_d times the opacity, the photon-mapped one k_d.
//!
//! Stage times are measured with a wait after each stage (`RelightStats`); the waits cost the overlap
//! between stages, a few per cent here.
use super::haar::SparseRow;
use super::relight::{check_lights, RelightStats};
use super::transfer::Transfer;
use crate::error::{Error, Result};
use crate::gpu::columns::{
    storage_buffer, GpuViewSample, ViewBuffers, VIEW_FLAG_GEO_FRONT, VIEW_FLAG_MASKS, VIEW_MASK_BUDGET_SHIFT, VIEW_MASK_BUDGET_UNLIMITED,
};
use crate::gpu::relight::{RelightParams, RelightPasses, ROW_CHUNK};
use crate::gpu::GpuContext;
use crate::lights::LightSet;
use crate::matrix::backend::{Chosen, Device};
use crate::matrix::gpu::GpuBackend;
use crate::matrix::ColumnOptions;
use crate::scene::Scene;
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Sparse rows on the GPU: parts of consecutive rows, each part's arrays within one storage binding.
struct SparseParts {
    /// Values per coefficient: 1, or 3 (RGB rows, `product_rgb`).
    channels: usize,
    /// (first row, rows, longest row, row starts, indices, values).
    parts: Vec<(u32, u32, u32, wgpu::Buffer, wgpu::Buffer, wgpu::Buffer)>,
}

impl SparseParts {
    /// `rows` (`channels` values per coefficient: 1 or 3) in the order given; `max_binding` bytes per
    /// array at most.
    fn upload(device: &wgpu::Device, rows: &[&SparseRow], channels: usize, max_binding: u64, what: &str) -> Result<SparseParts> {
        assert!(channels == 1 || channels == 3, "SparseParts: {channels} channels");
        let max_entries = (max_binding / 4).max(1) as usize;
        // Coefficients per part: their values (channels per coefficient) fit one binding too.
        let max_coeffs = (max_entries / channels).max(1);
        let mut parts = Vec::new();
        let mut first = 0usize;
        while first < rows.len() {
            let (mut end, mut count, mut longest) = (first, 0usize, 0usize);
            while end < rows.len() && (end == first || count + rows[end].index.len() <= max_coeffs) && end - first + 1 < max_entries {
                count += rows[end].index.len();
                longest = longest.max(rows[end].index.len());
                end += 1;
            }
            if count > max_coeffs {
                return Err(Error::invalid(format!(
                    "{what}: row {first} has {count} coefficients ({channels} values each), above the {max_binding}-byte storage binding limit"
                )));
            }
            let mut start = Vec::with_capacity(end - first + 1);
            let mut index = Vec::with_capacity(count);
            let mut value = Vec::with_capacity(count);
            start.push(0u32);
            for r in &rows[first..end] {
                if r.value.len() != channels * r.index.len() {
                    return Err(Error::invalid(format!(
                        "{what}: a row has {} values for {} indices ({channels} per index)",
                        r.value.len(),
                        r.index.len()
                    )));
                }
                index.extend_from_slice(&r.index);
                value.extend_from_slice(&r.value);
                start.push(index.len() as u32);
            }
            let usage = wgpu::BufferUsages::STORAGE;
            parts.push((
                first as u32,
                (end - first) as u32,
                longest as u32,
                storage_buffer(device, "GpuRelight::row_start", &start, usage)?,
                storage_buffer(device, "GpuRelight::row_index", &index, usage)?,
                storage_buffer(device, "GpuRelight::row_value", &value, usage)?,
            ));
            first = end;
        }
        Ok(SparseParts { channels, parts })
    }

    /// Whether there are no rows.
    fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// Record `partial[r] = sum_k value * lights[index]` for every row (RGB rows: each value times its
    /// channel), chunk by chunk.
    fn encode(
        &self,
        device: &wgpu::Device,
        enc: &mut wgpu::CommandEncoder,
        passes: &RelightPasses,
        lights: &wgpu::Buffer,
        partial: &wgpu::Buffer,
    ) -> Result<()> {
        for (first_row, rows, longest, start, index, value) in &self.parts {
            let mut first = 0;
            loop {
                let p = RelightParams { num_rows: *rows, row_offset: *first_row, first, count: ROW_CHUNK, ..Default::default() };
                let kernel = if self.channels == 3 { &passes.product_rgb } else { &passes.product };
                kernel.encode(device, enc, &p, *rows, &[lights, start, index, value, partial])?;
                first += ROW_CHUNK;
                if first >= *longest {
                    break;
                }
            }
        }
        Ok(())
    }
}

/// The GPU buffers of one relighting setup (module docs).
struct Buffers {
    gather_view: ViewBuffers,
    /// B_1, then the total B (gather image order, RGBA).
    gather_accum: wgpu::Buffer,
    /// Direct light of every view sample (RGBA).
    view_accum: wgpu::Buffer,
    /// B_k of the bounce passes.
    current: wgpu::Buffer,
    scratch: [wgpu::Buffer; 2],
    coeffs: wgpu::Buffer,
    wavelet_lights: wgpu::Buffer,
    partial_pixels: wgpu::Buffer,
    partial_gather: wgpu::Buffer,
    norms: wgpu::Buffer,
    gather_k_d: wgpu::Buffer,
    albedo: wgpu::Buffer,
    extra_start: wgpu::Buffer,
    /// H * W * 3 f32, then the three culling counters (u32 bits: non-zero wavelet lights, culled ones,
    /// culled against F_g^w).
    image: wgpu::Buffer,
    counters: wgpu::Buffer,
    rows: SparseParts,
    /// Gather-to-gather rows (gather-image order; empty unless `Multibounce::Gather` with b > 1).
    bounce_rows: SparseParts,
    /// Photon-mapped M_E^w rows, RGB (gather-image order; empty unless `Multibounce::Photons`, b > 1).
    photon_rows: SparseParts,
    /// The glossy final gather (None without glossy pixels).
    glossy: Option<GlossyBuffers>,
}

/// The glossy final gather's buffers: F_g^w rows (one per pixel), k_g, its image norms, its culled
/// wavelet lights, its product and its counters (non-zero, culled).
struct GlossyBuffers {
    rows: SparseParts,
    color: wgpu::Buffer,
    norms: wgpu::Buffer,
    wavelet_lights: wgpu::Buffer,
    partial: wgpu::Buffer,
    counters: wgpu::Buffer,
}

/// Relighting on one GPU for one transfer (module docs).
pub struct GpuRelight {
    ctx: Arc<GpuContext>,
    passes: Arc<RelightPasses>,
    /// The light-matrix backend: shadow maps and column passes; its lights are replaced per relight.
    backend: Mutex<GpuBackend>,
    buffers: Buffers,
    side: u32,
    pixels: u32,
    /// Final-gather rows: `pixels`, or with masks every view sample (`masks::row_samples`).
    samples: u32,
    /// Gather-to-gather passes (b - 1, or 0).
    bounce_passes: u32,
}

/// Per-sample rows in gather-image order (row p = the sample at gather-image pixel p; none for none).
fn in_gather_order<'a>(rows: &'a [SparseRow], order: &[usize]) -> Vec<&'a SparseRow> {
    if rows.is_empty() {
        return Vec::new();
    }
    order.iter().map(|&g| &rows[g]).collect()
}

fn rgba(v: &[glam::Vec3]) -> Vec<[f32; 4]> {
    v.iter().map(|c| [c.x, c.y, c.z, 0.0]).collect()
}

impl GpuRelight {
    /// Uploads `t` (computed for `view` of `scene`) to `ctx` (module docs). `opts`: the column pass's
    /// shadow maps and visibility.
    ///
    /// Errors: `InvalidParameter` for a view of another size than the transfer's (or, with masks, other
    /// view samples) or rows above a storage binding; what `GpuBackend::new` raises (shadow-map size, memory).
    pub fn new(ctx: Arc<GpuContext>, scene: Arc<Scene>, view: Arc<ViewSamples>, t: &Transfer, opts: ColumnOptions) -> Result<GpuRelight> {
        let masked = crate::raytrace::mask::scene_has_masks(&scene);
        if (view.width, view.height) != (t.width, t.height) || super::masks::row_samples(&view, masked) != t.rows.len() {
            return Err(Error::invalid(format!(
                "the view is {}x{} but the transfer was precomputed for {}x{}",
                view.width, view.height, t.width, t.height
            )));
        }
        let n = t.cloud.len();
        if !t.photon_rows.is_empty() && t.photon_rows.len() != n {
            return Err(Error::invalid(format!("{} photon rows for {n} gather samples", t.photon_rows.len())));
        }
        let samples = t.rows.len();
        if !t.glossy_rows.is_empty()
            && (t.glossy_rows.len() != samples || t.glossy_color.len() != samples || t.glossy_image_norms.len() != n)
        {
            return Err(Error::invalid(format!(
                "glossy rows: {} rows, {} colours, {} image norms for {samples} final-gather rows and {n} gather samples",
                t.glossy_rows.len(),
                t.glossy_color.len(),
                t.glossy_image_norms.len(),
            )));
        }
        let side = t.hierarchy.side() as u32;
        let pixels = view.num_pixels();
        let (center, radius) = crate::lights::scene_sphere(&scene);
        let backend = GpuBackend::new(ctx.clone(), scene, view.clone(), Arc::new(LightSet::new(center, radius)), opts)?;
        let device = &ctx.device;
        let max_binding = (ctx.limits.max_storage_buffer_binding_size as u64).min(ctx.limits.max_buffer_size);
        // Bytes per coefficient: a u32 index and one f32 value (RGB rows: three).
        let coefficients =
            t.coefficients_kept() + t.bounce_coefficients_kept() + t.glossy_coefficients_kept() + 2 * t.photon_coefficients_kept();
        let bytes = crate::memory::product(&[coefficients as u64, 8]);
        crate::memory::check_gpu(&ctx, "the transfer's sparse rows", bytes, false)?;

        // Gather samples in gather-image order: pixel p holds sample sample_at_pixel[p]. With masks each
        // reflects its opacity times k_d, and its shadow rays cross masks within the gather budget.
        let c = &t.cloud;
        let order: Vec<usize> = t.hierarchy.sample_at_pixel.iter().map(|&g| g as usize).collect();
        let opacity = |g: usize| t.opacity.get(g).copied().unwrap_or(1.0);
        let gather_flags = VIEW_FLAG_GEO_FRONT
            | if masked {
                VIEW_FLAG_MASKS | super::masks::gather_mask_budget(t.opts.bounces).min(VIEW_MASK_BUDGET_UNLIMITED) << VIEW_MASK_BUDGET_SHIFT
            } else {
                0
            };
        let gather_samples: Vec<GpuViewSample> = order
            .iter()
            .map(|&g| GpuViewSample {
                position: c.position[g].to_array(),
                shape_index: if c.normal[g] == glam::Vec3::ZERO { -1 } else { 0 },
                normal: c.normal[g].to_array(),
                flags: gather_flags,
                geo_normal: c.geo_normal[g].to_array(),
                bsdf_samples: 0,
                wi: c.normal[g].to_array(),
                mask_valid: 1.0,
                throughput: (c.k_d[g] * opacity(g)).to_array(),
                mask_opacity: 1.0,
            })
            .collect();
        let white = GpuBsdf { diffuse: [1.0; 3], kind: crate::shading::bsdf::KIND_DIFFUSE, ..bytemuck::Zeroable::zeroed() };
        let gather_view = ViewBuffers::from_parts(device, &gather_samples, &vec![white; n], &[0.0])?;

        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let vec4s = |label: &str, count: usize| {
            crate::gpu::alloc::buffer(
                device,
                &wgpu::BufferDescriptor { label: Some(label), size: (count as u64 * 16).max(16), usage: rw, mapped_at_creation: false },
            )
        };
        // The bounce passes' reflectance: k_d times the opacity for the gather-to-gather rows; photons are
        // stored on a masked sample only when they meet its nested BSDF, so theirs carry the opacity already.
        let photons = !t.photon_rows.is_empty();
        let k_d_image: Vec<glam::Vec3> = order.iter().map(|&g| if photons { c.k_d[g] } else { c.k_d[g] * opacity(g) }).collect();
        let mut extra_start = vec![0u32; pixels + 1];
        for &p in &view.extra_pixel {
            extra_start[p as usize + 1] += 1;
        }
        for p in 0..pixels {
            extra_start[p + 1] += extra_start[p];
        }
        let usage = wgpu::BufferUsages::STORAGE;
        let rows: Vec<&SparseRow> = t.rows.iter().collect();
        // Gather-to-gather rows in gather-image order (row p = the sample at pixel p).
        // The photon-mapped M_E^w rows likewise; `relight::bounce` applies them in place of the former.
        let photon_rows = in_gather_order(&t.photon_rows, &order);
        let bounce_rows = if t.opts.bounces > 1 && photon_rows.is_empty() { in_gather_order(&t.bounce_rows, &order) } else { Vec::new() };
        let glossy = if t.glossy_rows.is_empty() {
            None
        } else {
            let rows: Vec<&SparseRow> = t.glossy_rows.iter().collect();
            Some(GlossyBuffers {
                rows: SparseParts::upload(device, &rows, 1, max_binding, "glossy final-gather rows")?,
                color: storage_buffer(
                    device,
                    "GpuRelight::glossy_color",
                    &rgba(&t.glossy_color.iter().enumerate().map(|(i, &k)| view.throughput_of(i) * k).collect::<Vec<_>>()),
                    usage,
                )?,
                norms: storage_buffer(device, "GpuRelight::glossy_norms", &t.glossy_image_norms, usage)?,
                wavelet_lights: vec4s("GpuRelight::glossy_wavelet_lights", n)?,
                partial: vec4s("GpuRelight::partial_glossy", samples)?,
                counters: crate::gpu::alloc::buffer(
                    device,
                    &wgpu::BufferDescriptor { label: Some("GpuRelight::glossy_counters"), size: 8, usage: rw, mapped_at_creation: false },
                )?,
            })
        };
        let buffers = Buffers {
            gather_view,
            gather_accum: vec4s("GpuRelight::gather_accum", n)?,
            view_accum: vec4s("GpuRelight::view_accum", view.len())?,
            current: vec4s("GpuRelight::current", n)?,
            scratch: [vec4s("GpuRelight::scratch0", n)?, vec4s("GpuRelight::scratch1", n)?],
            coeffs: vec4s("GpuRelight::coeffs", n)?,
            wavelet_lights: vec4s("GpuRelight::wavelet_lights", n)?,
            partial_pixels: vec4s("GpuRelight::partial_pixels", samples)?,
            partial_gather: vec4s("GpuRelight::partial_gather", n)?,
            norms: storage_buffer(device, "GpuRelight::norms", &t.image_norms, usage)?,
            gather_k_d: storage_buffer(device, "GpuRelight::gather_k_d", &rgba(&k_d_image), usage)?,
            // Each row sample's albedo times its throughput (masked scenes: the camera hit's opacity, the
            // surfaces behind it); the glossy colours likewise.
            albedo: storage_buffer(
                device,
                "GpuRelight::albedo",
                &rgba(&(0..samples).map(|i| view.throughput_of(i) * super::diffuse::albedo(&view, i)).collect::<Vec<_>>()),
                usage,
            )?,
            extra_start: storage_buffer(device, "GpuRelight::extra_start", &extra_start, usage)?,
            image: crate::gpu::alloc::buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some("GpuRelight::image"),
                    size: (pixels as u64 * 3 + 3) * 4,
                    usage: rw,
                    mapped_at_creation: false,
                },
            )?,
            counters: crate::gpu::alloc::buffer(
                device,
                &wgpu::BufferDescriptor { label: Some("GpuRelight::counters"), size: 8, usage: rw, mapped_at_creation: false },
            )?,
            rows: SparseParts::upload(device, &rows, 1, max_binding, "final-gather rows")?,
            bounce_rows: SparseParts::upload(device, &bounce_rows, 1, max_binding, "gather-to-gather rows")?,
            photon_rows: SparseParts::upload(device, &photon_rows, 3, max_binding, "photon-mapped multiple-bounce rows")?,
            glossy,
        };
        Ok(GpuRelight {
            passes: crate::gpu::pipeline::shared_pass(device, RelightPasses::new),
            backend: Mutex::new(backend),
            buffers,
            side,
            pixels: pixels as u32,
            samples: samples as u32,
            bounce_passes: if bounce_rows.is_empty() { 0 } else { t.opts.bounces - 1 },
            ctx,
        })
    }

    /// The device's description.
    pub fn device(&self) -> crate::matrix::backend::DeviceInfo {
        crate::matrix::backend::DeviceInfo::gpu(&self.ctx)
    }

    fn submit(&self, enc: wgpu::CommandEncoder, what: &str) -> Result<()> {
        let s = self.ctx.queue.submit(Some(enc.finish()));
        crate::interrupt::wait_gpu(&self.ctx.device, Some(s), what)
    }

    fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GpuRelight") })
    }

    /// Haar transform of `image` into `coeffs` (a copy for a 1 x 1 gather image).
    fn haar(&self, enc: &mut wgpu::CommandEncoder, image: &wgpu::Buffer) -> Result<()> {
        let b = &self.buffers;
        if self.side == 1 {
            enc.copy_buffer_to_buffer(image, 0, &b.coeffs, 0, 16);
        } else {
            self.passes.encode_haar(&self.ctx.device, enc, self.side, image, [&b.scratch[0], &b.scratch[1]], &b.coeffs)?;
        }
        Ok(())
    }

    /// The relit image (H * W * 3 f32, as `relight::relight`) and the stage times (module docs).
    ///
    /// Errors: `InvalidParameter` for an empty light set, non-finite light values, a negative or
    /// non-finite epsilon; `Interrupted`; a lost device.
    pub fn relight(&self, lights: Arc<LightSet>, epsilon: f32) -> Result<(Vec<f32>, RelightStats)> {
        check_lights(&lights)?;
        if !(epsilon >= 0.0 && epsilon.is_finite()) {
            return Err(Error::invalid(format!("epsilon must be finite and >= 0, got {epsilon}")));
        }
        let device = &self.ctx.device;
        let b = &self.buffers;
        let n = self.side * self.side;
        let mut stats = RelightStats::default();
        let mut backend = self.backend.lock().unwrap_or_else(|e| e.into_inner());
        backend.set_lights(lights)?;
        let mut enc = self.encoder();
        for buf in [&b.gather_accum, &b.view_accum, &b.counters] {
            enc.clear_buffer(buf, 0, None);
        }
        if let Some(g) = &b.glossy {
            enc.clear_buffer(&g.counters, 0, None);
        }
        self.ctx.queue.submit(Some(enc.finish()));
        // 1-3: shadow maps, then the column pass over the gather and the view samples.
        let view_buffers = &backend.view_buffers;
        let (shadow, direct) = backend.accumulate_staged(&[(&b.gather_view, &b.gather_accum), (view_buffers, &b.view_accum)])?;
        stats.seconds_shadow_maps = shadow;
        stats.seconds_gather_direct = direct[0];
        stats.seconds_view_direct = direct[1];
        // 4: bounces among the gather samples.
        let t0 = Instant::now();
        let finish = RelightParams { num_rows: n, ..Default::default() };
        if self.bounce_passes > 0 {
            let mut enc = self.encoder();
            enc.copy_buffer_to_buffer(&b.gather_accum, 0, &b.current, 0, n as u64 * 16);
            for _ in 0..self.bounce_passes {
                self.haar(&mut enc, &b.current)?;
                b.bounce_rows.encode(device, &mut enc, &self.passes, &b.coeffs, &b.partial_gather)?;
                self.passes.finish_bounce.encode(
                    device,
                    &mut enc,
                    &finish,
                    n,
                    &[&b.current, &b.partial_gather, &b.gather_k_d, &b.gather_accum],
                )?;
            }
            self.submit(enc, "the bounce passes")?;
        } else if !b.photon_rows.is_empty() {
            // Once: total = B_1 + k_d / pi (M_E^w W B_1) (`current` takes the unused B_2).
            let mut enc = self.encoder();
            self.haar(&mut enc, &b.gather_accum)?;
            b.photon_rows.encode(device, &mut enc, &self.passes, &b.coeffs, &b.partial_gather)?;
            self.passes.finish_bounce.encode(
                device,
                &mut enc,
                &finish,
                n,
                &[&b.current, &b.partial_gather, &b.gather_k_d, &b.gather_accum],
            )?;
            self.submit(enc, "the photon-mapped multiple bounces")?;
        }
        stats.seconds_bounces = t0.elapsed().as_secs_f64();
        // 5: wavelet projection and on-the-fly culling.
        let t0 = Instant::now();
        let mut enc = self.encoder();
        self.haar(&mut enc, &b.gather_accum)?;
        let p = RelightParams { num_rows: n, epsilon, ..Default::default() };
        self.passes.cull.encode(device, &mut enc, &p, n, &[&b.coeffs, &b.norms, &b.wavelet_lights, &b.counters])?;
        if let Some(g) = &b.glossy {
            self.passes.cull.encode(device, &mut enc, &p, n, &[&b.coeffs, &g.norms, &g.wavelet_lights, &g.counters])?;
        }
        self.submit(enc, "the wavelet transform")?;
        stats.seconds_wavelet = t0.elapsed().as_secs_f64();
        // 6: sparse products, times k_d / pi, plus direct.
        let t0 = Instant::now();
        let mut enc = self.encoder();
        b.rows.encode(device, &mut enc, &self.passes, &b.wavelet_lights, &b.partial_pixels)?;
        let p = RelightParams { num_rows: self.pixels, count: self.samples, ..Default::default() };
        let tail = self.pixels as u64 * 12;
        enc.copy_buffer_to_buffer(&b.counters, 0, &b.image, tail, 8);
        if let Some(g) = &b.glossy {
            g.rows.encode(device, &mut enc, &self.passes, &g.wavelet_lights, &g.partial)?;
            let bufs = [&b.partial_pixels, &b.albedo, &b.view_accum, &b.extra_start, &b.image, &g.partial, &g.color];
            self.passes.combine_glossy.encode(device, &mut enc, &p, self.pixels, &bufs)?;
            enc.copy_buffer_to_buffer(&g.counters, 4, &b.image, tail + 8, 4);
        } else {
            self.passes.combine.encode(
                device,
                &mut enc,
                &p,
                self.pixels,
                &[&b.partial_pixels, &b.albedo, &b.view_accum, &b.extra_start, &b.image],
            )?;
        }
        self.submit(enc, "the transfer product")?;
        stats.seconds_transfer = t0.elapsed().as_secs_f64();
        // 7: one readback.
        let t0 = Instant::now();
        let mut img: Vec<f32> = self.ctx.read_buffer(&b.image, 0, self.pixels as usize * 3 + 3)?;
        // Written only with glossy rows (0 otherwise, as the CPU's count).
        let culled_glossy = img.pop().filter(|_| b.glossy.is_some()).map_or(0, |v| v.to_bits() as usize);
        let culled = img.pop().unwrap_or(0.0).to_bits() as usize;
        let lights_nonzero = img.pop().unwrap_or(0.0).to_bits() as usize;
        stats.wavelet_lights = lights_nonzero;
        stats.wavelet_lights_culled = culled;
        stats.wavelet_lights_culled_glossy = culled_glossy;
        stats.seconds_readback = t0.elapsed().as_secs_f64();
        Ok((img, stats))
    }
}

/// The device relighting runs on for a device asked for (`"auto"` replaced by `MANYLIGHTS_DEVICE`): as
/// the light matrix's `Device::choose`, i.e. `Auto` takes a hardware GPU (or the adapter
/// `MANYLIGHTS_ADAPTER` names) and the CPU otherwise. Measured on the 2-core test machine with only
/// lavapipe (Cornell box, 4^7 gather samples, ~70-93 coefficients per row, one moving spot light, medians):
/// the CPU relights 128x128 at 140/s, 320x240 at 20/s, 640x480 at 8/s; lavapipe at 8/s, 5/s and 1.7/s
/// (its column pass costs ~1 us per shading point, the CPU's exact rays ~0.05 us on this box), so the
/// CPU is the one that meets the 10 relights/s at 320x240 here; a hardware GPU runs the same
/// passes in parallel over thousands of cores. With the photon-mapped M (`bench_relight`,
/// RELIGHT_BENCH_BOUNCES=1,6, 320x240, epsilon 0, one run): bounces 1: CPU 31/s (transfer 25.6 ms, view
/// direct 4.2, gather direct 1.5), lavapipe 5.3/s (view direct 113 ms, transfer 42, gather direct 25,
/// shadow maps 6); bounces 6: CPU 29/s (M 4.5 ms), lavapipe 5.3/s (M 9.4 ms, 633k RGB coefficients).
/// The column pass over the view samples dominates on lavapipe.
///
/// Errors: `GpuUnavailable` for `Gpu` without any adapter; an invalid `MANYLIGHTS_DEVICE`.
pub fn choose_device(device: Device) -> Result<Chosen> {
    device.choose()
}

#[cfg(test)]
mod tests;
