//! Rows of the light matrix on the GPU (the reduced matrix R of Hašan, Pellacini, Bala, "Matrix
//! Row-Column Sampling for the Many-Light Problem", SIGGRAPH 2007, DOI 10.1145/1276377.1276410):
//! Sec. 3.1 (a row = one sample shaded by all lights, from a depth map centred at the sample) and Sec. 4
//! ("Rows are selected by stratified uniform sampling: we divide the image into blocks and pick a row in
//! each block"; "Row visibility is evaluated by computing a cube shadow map at the sample location").
//!
//! Symbols: r = `is.len()` (num_rows), n = number of lights, R = the r x n RGB reduced matrix.
//!
//! `LightMatrix::rows(is)` returns R as r * n * 3 f32 (`[row][light][rgb]`). Rows are processed in
//! batches: a batch's cube maps (6 layers each, `RowOptions::resolution` texels per side) are layers of
//! one depth array texture (at most 341 cubes = 2046 of the 2048 layers, and `RowOptions::memory_budget`
//! bytes), rendered in one submission; then one thread per (row, light) evaluates the rows
//! (`gpu::rows`, `shaders/rows.wgsl`) into an output buffer of at most one storage binding (128 MiB:
//! 300 rows x 100k lights x RGB f32 = 343 MiB is read back in 3+ chunks), light chunks of at most
//! `gpu::rows::MAX_LIGHTS_PER_DISPATCH` lights (and 128 MiB of `GpuLight`s) per dispatch.
//!
//! The matrix keeps the row pass's GPU memory between calls (all lights as `GpuLight`s, the cube atlas
//! and the output buffer: at most `RowOptions::memory_budget` + 128 MiB + 256 bytes per light), so that a
//! budget sweep does not pay hundreds of MiB of allocation per call; a larger call grows it.
//!
//! Values equal the column pass's (`columns.wgsl`) up to visibility decisions: the same WGSL evaluates
//! emission and BSDF; visibility follows `ColumnOptions::visibility` (hybrid by default: the row's cube
//! map where its 2x2 footprint is certain, else the column pass's exact BVH ray from the view sample).
//! Background samples (no surface) have all-zero rows and get no cube map.
//!
//! Deviations / limits: geometry closer to the cube centre than its near plane (1e-3 scene radius,
//! `shadow::light_layers`) is clipped, so an occluder touching the sample within that distance can be
//! missed by a certain-looking map (as for point lights in columns); the cube centre is the sample
//! moved off its surface by Mitsuba's offset_p toward the viewer.
//!
//! Measured (`tests::bench_rows_cbox`, cbox 128x128, 100,072 lights = 50k oriented points + 50k VPLs,
//! r = 300, 256^2 cubes, llvmpipe on a shared 2-core machine): hybrid 12.9 s = cube maps 0.49 +
//! evaluation 11.9 + readback 0.52 s (7.7% of 19.3M shadow tests cast rays); shadow-map-only evaluation
//! 9.9 s, exact rays only 17.3 s: evaluation (emission + BSDF of 30M pairs), not shadow maps, dominates.
//!
//! `stratified_rows(width, height, r, seed)`: the image is cut into `gy` horizontal bands
//! (`gy = round(sqrt(r * height / width))`, clamped to [ceil(r / width), min(r, height)]); band b holds
//! `r_b = floor((b + 1) r / gy) - floor(b r / gy)` blocks (r_b differ by at most 1) of equal width, and
//! its height is proportional to r_b (rounded; equal band heights if rounding would empty a band). So
//! there are exactly r non-empty blocks for any r, factorable or not, of nearly equal area (pixel
//! rounding only: 49..64 pixels for r = 300 at 128x128); for r = gx * gy with the image's aspect this is
//! the plain gx x gy grid. One pixel is drawn uniformly in each
//! block (`rand_pcg::Pcg32` seeded by `seed`). Background pixels are allowed (their rows are zero): the
//! choice keeps the row distribution uniform over the image, so estimators built on R stay simple;
//! callers wanting surface samples only can redraw.
use super::gpu::GpuBackend;
use super::Visibility;
use crate::error::{Error, Result};
use crate::gpu::columns::{storage_buffer, GpuLight};
use crate::gpu::rows::{row_cube_layers, GpuRowInfo, RowParams, RowsInputs, RowsPass, MAX_LIGHTS_PER_DISPATCH, ROW_NO_MAP};
use crate::gpu::shadow::ShadowAtlas;
use std::time::Instant;

/// Most cubes in one depth array texture (2048 layers / 6).
pub const MAX_CUBES_PER_BATCH: usize = 341;
/// Bytes of one `GpuLight`.
const LIGHT_BYTES: u64 = 256;
/// Mitsuba's math::RayEpsilon<float> (offset_p), as `bvh.wgsl`.
const RAY_EPSILON: f32 = 8.940_697e-5;
/// The directional stand-in point lies this factor beyond the scene's bounding sphere as seen from the
/// cube centre (inside the cube's far plane, which `light_layers` puts at 1.01 times that distance).
const FAR_POINT_SCALE: f32 = 1.002;

/// How rows are computed.
#[derive(Debug, Clone)]
pub struct RowOptions {
    /// Texels per side of each cube face.
    pub resolution: u32,
    /// Bytes of cube maps per batch (Depth32Float: 24 * resolution^2 per cube; at least one cube).
    pub memory_budget: u64,
}

impl Default for RowOptions {
    fn default() -> Self {
        RowOptions { resolution: 256, memory_budget: 192 << 20 }
    }
}

/// GPU memory of the row pass kept between calls: the cube atlas and the output buffer.
pub(crate) struct RowScratch {
    atlas: ShadowAtlas,
    out_buf: wgpu::Buffer,
}

/// Wall-clock seconds of `LightMatrix::rows_timed`, each stage waited for on the GPU.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RowTimings {
    /// Allocating the cube atlas and output buffer and uploading the lights (first call, or a larger one).
    pub setup: f64,
    /// Uploading row data and rendering the cube depth maps.
    pub shadow_maps: f64,
    /// The evaluation dispatches (all lights against each row's cube).
    pub evaluation: f64,
    /// Copying the r x n x 3 output to the host.
    pub readback: f64,
    /// Row batches (cube-map submissions).
    pub batches: usize,
}

/// The r x n x 3 rows and how long they took.
pub type TimedRows = (Vec<f32>, RowTimings);

impl GpuBackend {
    /// Rows on the GPU (module docs), with per-stage timings (`LightMatrix::rows_timed` validates first).
    pub(crate) fn rows_timed(&self, is: &[usize], opts: &RowOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<TimedRows> {
        let n = self.lights.len();
        // Pixels -> their samples (the pixel itself, then its delta-chain samples).
        let requested = is;
        let expanded: Vec<usize>;
        let is: &[usize] = if self.view.extra_pixel.is_empty() {
            requested
        } else {
            expanded = requested.iter().flat_map(|&p| self.view.samples_of_pixel(p)).collect();
            &expanded
        };
        let max_dim = self.ctx.limits.max_texture_dimension_2d;
        if opts.resolution == 0 || opts.resolution > max_dim {
            return Err(Error::invalid(format!("row cube resolution must be in [1, {max_dim}], got {}", opts.resolution)));
        }
        let mut timings = RowTimings::default();
        let r = is.len();
        if r == 0 || n == 0 {
            return Ok((Vec::new(), timings));
        }
        let out_limit = self.max_binding.min(128 << 20);
        let row_bytes = n as u64 * 12;
        if row_bytes > out_limit {
            return Err(Error::invalid(format!(
                "one row of {n} lights ({row_bytes} bytes) exceeds the {out_limit}-byte storage binding limit"
            )));
        }
        // Refuse what cannot fit before allocating (host output, GPU lights and one batch of cubes).
        crate::memory::check_host(
            &format!("rows: {r} rows x {n} lights x RGB float32"),
            crate::memory::product(&[r as u64, n as u64, 12]),
        )?;
        crate::memory::check_gpu(
            &self.ctx,
            &format!("rows: {n} lights (256 bytes each on the GPU)"),
            crate::memory::product(&[n as u64, LIGHT_BYTES]),
            false,
        )?;
        if self.opts.visibility != Visibility::RayTraced {
            let res = opts.resolution as u64;
            crate::memory::check_gpu(
                &self.ctx,
                &format!("rows: a {res}^2 cube depth map (shadow_map_size = {res})"),
                crate::memory::product(&[24, res, res]),
                false,
            )?;
        }
        let device = &self.ctx.device;
        let pass = crate::gpu::pipeline::shared_pass(device, RowsPass::new);

        let t_setup = Instant::now();
        // Lights, in chunks of at most one dispatch and one binding (uploaded on the first call).
        let light_chunk = MAX_LIGHTS_PER_DISPATCH.min((self.max_binding / LIGHT_BYTES) as usize).max(1);
        if self.row_lights.get().is_none() {
            let chunks = (0..n)
                .step_by(light_chunk)
                .map(|first| {
                    let gpu: Vec<GpuLight> = (first..(first + light_chunk).min(n)).map(|j| self.gpu_light(j, 0)).collect();
                    Ok((first, storage_buffer(device, "LightMatrix::row_lights", &gpu, wgpu::BufferUsages::STORAGE)?))
                })
                .collect::<Result<Vec<_>>>()?;
            let _ = self.row_lights.set(chunks);
        }
        let light_chunks = self.row_lights.get().expect("row lights uploaded above");

        // Batches of rows: cube layers of one texture within the memory budget.
        let res = opts.resolution;
        let cube_bytes = 24 * res as u64 * res as u64;
        let rendered = self.opts.visibility != Visibility::RayTraced;
        let per_batch =
            if rendered { ((opts.memory_budget / cube_bytes) as usize).clamp(1, MAX_CUBES_PER_BATCH) } else { MAX_CUBES_PER_BATCH };
        let surface = |i: usize| self.view.shape_index[i] >= 0;
        let most_cubes =
            if rendered { is.chunks(per_batch).map(|c| c.iter().filter(|&&i| surface(i)).count()).max().unwrap_or(0) } else { 0 };
        let rows_per_chunk = ((out_limit / row_bytes) as usize).min(per_batch).max(1);
        // The cube atlas and the output buffer are kept for the next call (allocating hundreds of MiB
        // costs as much as evaluating tens of rows on a software adapter); a larger call grows them.
        let (atlas_res, atlas_layers) = if most_cubes > 0 { (res, 6 * most_cubes as u32) } else { (1, 1) };
        let out_size = (rows_per_chunk.min(r) as u64 * row_bytes).max(16);
        let mut scratch_guard = self.row_scratch.lock().unwrap_or_else(|e| e.into_inner());
        let fits = |s: &RowScratch| s.atlas.resolution == atlas_res && s.atlas.num_layers >= atlas_layers && s.out_buf.size() >= out_size;
        if !scratch_guard.as_ref().is_some_and(fits) {
            let (layers, size) = match scratch_guard.as_ref() {
                Some(s) if s.atlas.resolution == atlas_res => (s.atlas.num_layers.max(atlas_layers), s.out_buf.size().max(out_size)),
                _ => (atlas_layers, out_size),
            };
            *scratch_guard = None;
            *scratch_guard = Some(RowScratch {
                atlas: ShadowAtlas::new(device, atlas_res, layers)?,
                out_buf: crate::gpu::alloc::buffer(
                    device,
                    &wgpu::BufferDescriptor {
                        label: Some("LightMatrix::rows_out"),
                        size,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    },
                )?,
            });
        }
        let scratch = scratch_guard.as_ref().expect("row scratch allocated above");
        let (atlas, out_buf) = (&scratch.atlas, &scratch.out_buf);
        timings.setup = t_setup.elapsed().as_secs_f64();
        let (center, radius) = (self.lights.scene_center, self.lights.scene_radius.max(1e-6));
        let mut out = Vec::with_capacity(r * n * 3);
        let mut done = 0usize;
        for batch in is.chunks(per_batch) {
            let t0 = Instant::now();
            let mut infos = Vec::with_capacity(batch.len());
            let mut layers = Vec::new();
            for &i in batch {
                let p = self.view.position[i];
                let n_g = self.view.geo_normal[i];
                let side = if n_g.dot(self.view.wi[i]) >= 0.0 { n_g } else { -n_g };
                let c = p + side * ((1.0 + p.abs().max_element()) * RAY_EPSILON);
                let mut first_layer = ROW_NO_MAP;
                if surface(i) && rendered {
                    first_layer = layers.len() as u32;
                    layers.extend(row_cube_layers(center, radius, c, res));
                }
                infos.push(GpuRowInfo {
                    center: c.to_array(),
                    sample: i as u32,
                    far_dist: ((c - center).length() + radius) * FAR_POINT_SCALE,
                    first_layer,
                    _pad0: [0; 2],
                });
            }
            let num_layers = layers.len() as u32;
            if layers.is_empty() {
                // The binding needs one whole layer even when no row has a cube.
                layers.push(bytemuck::Zeroable::zeroed());
            }
            let layers_buf =
                storage_buffer(device, "LightMatrix::row_layers", &layers, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE)?;
            let rows_buf = storage_buffer(device, "LightMatrix::row_infos", &infos, wgpu::BufferUsages::STORAGE)?;
            if num_layers > 0 {
                let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::row_cubes") });
                self.shadow_pass.encode(device, &mut encoder, atlas, &layers_buf, num_layers, &self.geometry);
                let submission = self.ctx.queue.submit(Some(encoder.finish()));
                self.wait_for(submission)?;
            }
            timings.shadow_maps += t0.elapsed().as_secs_f64();
            for first_row in (0..batch.len()).step_by(rows_per_chunk) {
                let num_rows = rows_per_chunk.min(batch.len() - first_row);
                let t1 = Instant::now();
                let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::rows") });
                for (first_light, lights_buf) in light_chunks {
                    let params = RowParams {
                        num_rows: num_rows as u32,
                        num_lights: light_chunk.min(n - first_light) as u32,
                        first_row: first_row as u32,
                        first_light: *first_light as u32,
                        total_lights: n as u32,
                        resolution: atlas.resolution,
                        visibility: self.opts.visibility as u32,
                        _pad0: 0,
                        normal_offset: self.opts.normal_offset,
                        depth_bias: self.opts.depth_bias,
                        slope_bias: self.opts.slope_bias,
                        _pad1: 0.0,
                    };
                    pass.encode(
                        device,
                        &mut encoder,
                        &RowsInputs {
                            params,
                            view: &self.view_buffers,
                            lights: lights_buf,
                            rows: &rows_buf,
                            layers: &layers_buf,
                            cube_maps: &atlas.array_view,
                            out_rows: out_buf,
                            bvh_nodes: &self.bvh.nodes,
                            bvh_prims: &self.bvh.primitives,
                            stats: &self.stats,
                            spot_textures: &self.spot_textures,
                            masks: &self.masks,
                        },
                    )?;
                }
                let submission = self.ctx.queue.submit(Some(encoder.finish()));
                self.wait_for(submission)?;
                let t2 = Instant::now();
                timings.evaluation += (t2 - t1).as_secs_f64();
                self.ctx.read_buffer_into::<f32>(out_buf, 0, num_rows * n * 3, &mut out)?;
                timings.readback += t2.elapsed().as_secs_f64();
            }
            timings.batches += 1;
            done += batch.len();
            progress(done, r);
        }
        if is.len() != requested.len() {
            // Sum each pixel's sample rows, in sample order.
            let row = n * 3;
            let mut folded = Vec::with_capacity(requested.len() * row);
            let mut k = 0;
            for &p in requested {
                let count = self.view.samples_of_pixel(p).count();
                let mut acc = out[k * row..(k + 1) * row].to_vec();
                for extra in 1..count {
                    for (a, v) in acc.iter_mut().zip(&out[(k + extra) * row..(k + extra + 1) * row]) {
                        *a += v;
                    }
                }
                folded.extend(acc);
                k += count;
            }
            out = folded;
        }
        Ok((out, timings))
    }
}

/// One pixel index (`y * width + x`) per block of a stratification of the image into `r` blocks of
/// nearly equal area (module docs), drawn uniformly within each block with `Pcg32` seeded by `seed`;
/// band-major order (top band first, left to right).
///
/// Errors: `r == 0`, an empty image, or `r > width * height`.
pub fn stratified_rows(width: u32, height: u32, r: usize, seed: u64) -> Result<Vec<usize>> {
    use rand::{RngExt, SeedableRng};
    let m = width as usize * height as usize;
    if r == 0 || r > m {
        return Err(Error::invalid(format!("the number of rows must be in [1, {m}] (view samples of a {width}x{height} image), got {r}")));
    }
    // r comes from the caller: refuse a count whose index vectors cannot be allocated (an allocation
    // failure would abort the process).
    let mut probe: Vec<(usize, usize, usize, usize)> = Vec::new();
    if probe.try_reserve_exact(r).is_err() {
        return Err(Error::invalid(format!("{r} rows: their block list ({} bytes) cannot be allocated", r.saturating_mul(32))));
    }
    drop(probe);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    Ok(stratified_blocks(width, height, r)
        .into_iter()
        .map(|(y0, y1, x0, x1)| {
            let x = rng.random_range(x0..x1);
            let y = rng.random_range(y0..y1);
            y * width as usize + x
        })
        .collect())
}

/// The r blocks (y0, y1, x0, x1) (half-open pixel ranges) of `stratified_rows`, in its order; empty for
/// an invalid r.
pub fn stratified_blocks(width: u32, height: u32, r: usize) -> Vec<(usize, usize, usize, usize)> {
    let (w, h) = (width as usize, height as usize);
    if r == 0 || r > w * h {
        return Vec::new();
    }
    let gy = ((r as f64 * h as f64 / w as f64).sqrt().round() as usize).clamp(r.div_ceil(w), r.min(h));
    // Blocks before band b; band heights proportional to their block counts, or equal heights when
    // rounding would leave a band empty.
    let before = |b: usize| b * r / gy;
    let mut band_y: Vec<usize> = (0..=gy).map(|b| h * before(b) / r).collect();
    if band_y.windows(2).any(|y| y[1] <= y[0]) {
        band_y = (0..=gy).map(|b| b * h / gy).collect();
    }
    let mut out = Vec::with_capacity(r);
    for b in 0..gy {
        let blocks = before(b + 1) - before(b);
        for k in 0..blocks {
            out.push((band_y[b], band_y[b + 1], k * w / blocks, (k + 1) * w / blocks));
        }
    }
    out
}

#[cfg(test)]
mod tests;
