//! LightMatrix: the m x n light-to-pixel matrix A, A(i, j) = light j's direct contribution (RGB) to view
//! sample i, evaluated on the GPU column by column (Hašan, Pellacini, Bala, "Matrix Row-Column Sampling
//! for the Many-Light Problem", SIGGRAPH 2007, Sec. 3: columns are shadow-mapped lights).
//!
//! `columns(J)` reads individual columns back; `column_sum(w)` accumulates `sum_j w_j A(:, j)` on the GPU
//! and reads back only the final image. Lights are processed in batches: a batch's shadow maps (cube
//! faces, spot and orthographic maps) are layers of one depth array texture, rendered and consumed in one
//! command submission; a batch holds at most `max_lights_per_batch` (<= 256) lights and as many layers as
//! `shadow_memory_budget` allows. `reference` evaluates elements on the CPU by ray casting (tests);
//! `oracle` gives exact elements, rows and columns (`element`, `row_exact`, `column_exact`) with the
//! scene BVH; `emitted` is what the camera sees directly (added to every image, not a column).
//!
//! Visibility (`ColumnOptions::visibility`): `ShadowMap` tests shadow maps with biases only;
//! `RayTraced` casts an exact shadow ray per test against the scene BVH on the GPU (`gpu::bvh`, Mitsuba's
//! ray offsets, so columns equal the CPU `RayTracer`'s); `Hybrid` (default) decides from the shadow map
//! where its 2x2 footprint around p is unambiguous (all taps on p's own plane: lit; all on one occluder
//! plane well in front of p: shadow) and casts the exact ray everywhere else (contact edges, grazing or
//! curved receivers, shadow boundaries, map edges; design in `shaders/columns.wgsl`, `shadow_map_decide`).
//! `visibility_stats` counts shadow tests and ray casts. With rays, a dispatch shades at most
//! `gpu::bvh::RAYS_PER_INVOCATION` lights so that an invocation's loops stay below Mesa 22.3's 65,535
//! iterations even if every ray takes the most steps.
//!
//! Delta BSDF chains (`crate::view_chains`): a pixel may own several view samples (its camera hit plus
//! the surfaces seen through mirrors and glass, each with its chain's RGB throughput). The matrix rows
//! are pixels: A(i, j) = sum over pixel i's samples k of throughput_k * (light j's direct light at k).
//! The GPU shades every sample (throughput applied in the shader) and the per-sample results are summed
//! into their pixels on the host (`ViewSamples::fold`); without delta BSDFs each pixel has one sample
//! of throughput 1 and nothing changes.
//!
//! Symbols: m = number of rows = pixels (`width * height`), n = number of lights, w = weights.
pub mod emitted;
pub mod oracle;
pub mod reference;
pub mod rows;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::gpu::columns::{
    dispatch_size, storage_buffer, ColumnParams, ColumnsInputs, ColumnsPass, GpuLight, ViewBuffers,
    MAX_LIGHTS_PER_DISPATCH,
};
use crate::gpu::bvh::{GpuBvh, RAYS_PER_INVOCATION};
use crate::gpu::scene_buffers::SceneGeometry;
use crate::gpu::shadow::{layer_count, light_layers, uses_cube, ShadowAtlas, ShadowMapPass};
use crate::gpu::GpuContext;
use crate::lights::LightSet;
use crate::scene::Scene;
use crate::view::ViewSamples;
use std::sync::Arc;

/// How shadow tests are decided. Keep in sync with `VISIBILITY_*` in `shaders/columns.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Visibility {
    /// Shadow maps with normal offset, depth and slope biases (fast; acne/leaks at contact edges).
    ShadowMap = 0,
    /// Shadow maps where they are certain, exact BVH rays elsewhere.
    #[default]
    Hybrid = 1,
    /// An exact BVH ray for every shadow test (no shadow maps are rendered).
    RayTraced = 2,
}

impl Visibility {
    /// "shadow_map", "hybrid" or "ray_traced".
    pub fn parse(name: &str) -> Result<Visibility> {
        match name {
            "shadow_map" => Ok(Visibility::ShadowMap),
            "hybrid" => Ok(Visibility::Hybrid),
            "ray_traced" => Ok(Visibility::RayTraced),
            _ => Err(Error::invalid(format!(
                "visibility must be 'shadow_map', 'hybrid' or 'ray_traced', got '{name}'"
            ))),
        }
    }
}

/// Visibility counters of a `LightMatrix` since creation or `reset_visibility_stats`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct VisibilityStats {
    /// Shadow tests (light-sample pairs with a non-zero unshadowed contribution).
    pub shadow_tests: u64,
    /// Tests resolved by an exact BVH ray.
    pub ray_casts: u64,
    /// Rays that ran out of traversal steps or stack (then the biased shadow map decided); must be 0.
    pub gave_up: u64,
}

/// How columns are computed.
#[derive(Debug, Clone)]
pub struct ColumnOptions {
    /// Shadow maps, exact rays, or both (default `Hybrid`).
    pub visibility: Visibility,
    /// Shadow-map texels per side (each cube face, spot or orthographic map).
    pub shadow_resolution: u32,
    /// Most lights shaded per dispatch (<= 256, keeps shader loops far below 65,535 iterations).
    pub max_lights_per_batch: usize,
    /// Bytes of shadow-map layers per batch (Depth32Float: 4 * resolution^2 per layer; at least one cube).
    pub shadow_memory_budget: u64,
    /// Normal offset (toward the light's side of the geometric normal), in shadow-map texels.
    pub normal_offset: f32,
    /// Constant depth bias toward the light, in texels.
    pub depth_bias: f32,
    /// Slope-scaled depth bias (times tan of the angle between geometric normal and light), in texels.
    pub slope_bias: f32,
}

impl Default for ColumnOptions {
    fn default() -> Self {
        ColumnOptions {
            visibility: Visibility::Hybrid,
            shadow_resolution: 1024,
            max_lights_per_batch: MAX_LIGHTS_PER_DISPATCH,
            shadow_memory_budget: 256 << 20,
            // Chosen by `tests::bias_sweep` (0 acne/leak pixels away from edges at 256-1024 texels).
            normal_offset: 1.0,
            depth_bias: 0.25,
            slope_bias: 0.1,
        }
    }
}

/// The light matrix of a scene, its view samples and a light set.
pub struct LightMatrix {
    ctx: Arc<GpuContext>,
    pub scene: Arc<Scene>,
    pub view: Arc<ViewSamples>,
    pub lights: Arc<LightSet>,
    pub opts: ColumnOptions,
    shadow_pass: ShadowMapPass,
    columns_pass: ColumnsPass,
    /// The scene's triangles (unshared vertices), drawn into every shadow map.
    geometry: SceneGeometry,
    view_buffers: ViewBuffers,
    atlas: ShadowAtlas,
    /// The scene BVH for exact shadow rays (a one-leaf empty BVH in `ShadowMap` mode).
    bvh: GpuBvh,
    /// `VisibilityStats` as six u32 (lo, hi pairs), added to by every column dispatch.
    stats: wgpu::Buffer,
    /// Largest storage binding in bytes.
    max_binding: u64,
    /// Projected textures of spot lights (`crate::lights::spot_texture::gpu_table`) and each light's
    /// record offset in them.
    spot_textures: wgpu::Buffer,
    spot_texture_offsets: Vec<u32>,
    /// The row pass (`rows.rs`), compiled on first use.
    rows_pass: std::sync::OnceLock<crate::gpu::rows::RowsPass>,
    /// All lights as `GpuLight`s for the row pass, in chunks (first light, buffer); uploaded once.
    row_lights: std::sync::OnceLock<Vec<(usize, wgpu::Buffer)>>,
    /// The row pass's cube atlas and output buffer, reused by later calls.
    row_scratch: std::sync::Mutex<Option<rows::RowScratch>>,
    /// CPU ray tracer of the exact oracle (`oracle.rs`), built on first use.
    oracle: std::sync::OnceLock<crate::raytrace::RayTracer>,
}

/// Lights `js[start..end]` and the first layer of each.
struct Batch {
    start: usize,
    end: usize,
    layers: Vec<u32>,
    num_layers: u32,
}

impl LightMatrix {
    pub fn new(
        ctx: Arc<GpuContext>,
        scene: Arc<Scene>,
        view: Arc<ViewSamples>,
        lights: Arc<LightSet>,
        opts: ColumnOptions,
    ) -> Result<LightMatrix> {
        let m = view.len();
        let wh = view.num_pixels();
        if m != wh + view.extra_pixel.len()
            || [view.position.len(), view.normal.len(), view.geo_normal.len(), view.wi.len()].iter().any(|&l| l != m)
            || !(m..=2 * m).contains(&view.bsdf.len())
            || !(view.throughput.is_empty() || view.throughput.len() == m)
            || view.extra_pixel.windows(2).any(|p| p[1] < p[0])
            || view.extra_pixel.last().is_some_and(|&p| p as usize >= wh)
        {
            return Err(Error::invalid(format!(
                "view samples are inconsistent: {}x{} = {wh} pixels, {} extra samples, shape_index {m}, position {}, \
                 normal {}, geo_normal {}, wi {}, bsdf {}, throughput {}",
                view.width, view.height, view.extra_pixel.len(), view.position.len(), view.normal.len(),
                view.geo_normal.len(), view.wi.len(), view.bsdf.len(), view.throughput.len()
            )));
        }
        let limits = &ctx.limits;
        if opts.shadow_resolution == 0 || opts.shadow_resolution > limits.max_texture_dimension_2d {
            return Err(Error::invalid(format!(
                "shadow_resolution must be in [1, {}], got {}",
                limits.max_texture_dimension_2d, opts.shadow_resolution
            )));
        }
        if opts.max_lights_per_batch == 0 || opts.max_lights_per_batch > MAX_LIGHTS_PER_DISPATCH {
            return Err(Error::invalid(format!(
                "max_lights_per_batch must be in [1, {MAX_LIGHTS_PER_DISPATCH}], got {}",
                opts.max_lights_per_batch
            )));
        }
        for (name, v) in [("normal_offset", opts.normal_offset), ("depth_bias", opts.depth_bias), ("slope_bias", opts.slope_bias)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(format!("{name} must be finite and >= 0, got {v}")));
            }
        }
        let max_binding = (limits.max_storage_buffer_binding_size as u64).min(limits.max_buffer_size);
        if view.bsdf.len() as u64 * 80 > max_binding {
            return Err(Error::invalid(format!(
                "{m} view samples need {} bytes of BSDFs, above the {max_binding}-byte storage binding limit",
                view.bsdf.len() as u64 * 80
            )));
        }
        let layer_bytes = 4 * opts.shadow_resolution as u64 * opts.shadow_resolution as u64;
        let max_layers = (opts.shadow_memory_budget / layer_bytes)
            .min(limits.max_texture_array_layers as u64)
            .min(6 * opts.max_lights_per_batch as u64)
            .max(6) as u32;
        let device = &ctx.device;
        let geometry = SceneGeometry::upload(device, &scene)?;
        let tables = crate::shading::bsdf::roughplastic_table_buffer(&scene.bsdfs);
        let view_buffers = ViewBuffers::upload(device, &view, &tables);
        let res = opts.shadow_resolution as u64;
        let what = format!("shadow maps: {max_layers} layers of {res}^2 texels (shadow_map_size = {res})");
        crate::memory::check_gpu(&ctx, &what, crate::memory::product(&[max_layers as u64, res, res, 4]), false)?;
        let atlas = crate::memory::gpu_alloc(device, &what, || ShadowAtlas::new(device, opts.shadow_resolution, max_layers))?;
        let bvh = if opts.visibility == Visibility::ShadowMap {
            GpuBvh::empty(device)?
        } else {
            GpuBvh::upload(device, &scene, max_binding)?
        };
        let stats = storage_buffer::<u32>(
            device,
            "LightMatrix::stats",
            &[0; 6],
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        let (texels, spot_texture_offsets) = crate::lights::spot_texture::gpu_table(&lights);
        if texels.len() as u64 * 4 > max_binding {
            return Err(Error::invalid(format!(
                "the spot lights' projected textures need {} bytes, above the {max_binding}-byte storage binding limit",
                texels.len() as u64 * 4
            )));
        }
        let spot_textures = storage_buffer(device, "LightMatrix::spot_textures", &texels, wgpu::BufferUsages::STORAGE);
        Ok(LightMatrix {
            spot_textures,
            spot_texture_offsets,
            bvh,
            stats,
            shadow_pass: ShadowMapPass::new(device),
            columns_pass: ColumnsPass::new(device),
            geometry,
            view_buffers,
            atlas,
            max_binding,
            rows_pass: std::sync::OnceLock::new(),
            row_lights: std::sync::OnceLock::new(),
            row_scratch: std::sync::Mutex::new(None),
            oracle: std::sync::OnceLock::new(),
            ctx,
            scene,
            view,
            lights,
            opts,
        })
    }

    /// (m, n): rows (pixels) x lights.
    pub fn shape(&self) -> (usize, usize) {
        (self.view.num_pixels(), self.lights.len())
    }

    /// Image size (height, width) of the view samples, numpy order.
    pub fn image_size(&self) -> (usize, usize) {
        (self.view.height as usize, self.view.width as usize)
    }

    fn check_indices(&self, js: &[usize]) -> Result<()> {
        let n = self.lights.len();
        if let Some((k, &j)) = js.iter().enumerate().find(|(_, &j)| j >= n) {
            return Err(Error::invalid(format!("light index {j} (at position {k}) is out of range for {n} lights")));
        }
        Ok(())
    }

    /// Split `js` into batches by lights per dispatch, shadow-map layers and (if given) columns per batch.
    fn batches(&self, js: &[usize], max_columns: usize) -> Vec<Batch> {
        let cap = self.opts.max_lights_per_batch.min(max_columns).max(1);
        let mut out: Vec<Batch> = Vec::new();
        let mut cur = Batch { start: 0, end: 0, layers: Vec::new(), num_layers: 0 };
        for (k, &j) in js.iter().enumerate() {
            let need = layer_count(&self.lights, j);
            if cur.end > cur.start && (cur.end - cur.start >= cap || cur.num_layers + need > self.atlas.num_layers) {
                let start = cur.end;
                out.push(std::mem::replace(&mut cur, Batch { start, end: start, layers: Vec::new(), num_layers: 0 }));
            }
            cur.layers.push(cur.num_layers);
            cur.num_layers += need;
            cur.end = k + 1;
        }
        if cur.end > cur.start {
            out.push(cur);
        }
        out
    }

    /// Encode and submit one batch: shadow maps, then the column pass. Returns the submission.
    fn run_batch(
        &self,
        js: &[usize],
        batch: &Batch,
        weights: &[[f32; 4]],
        accum: &wgpu::Buffer,
        columns: Option<&wgpu::Buffer>,
    ) -> wgpu::SubmissionIndex {
        let device = &self.ctx.device;
        let res = self.opts.shadow_resolution;
        let mut gpu_lights = Vec::with_capacity(batch.end - batch.start);
        let mut layers = Vec::with_capacity(batch.num_layers as usize);
        for (k, &j) in js[batch.start..batch.end].iter().enumerate() {
            gpu_lights.push(GpuLight::new(&self.lights, j, batch.layers[k], uses_cube(&self.lights, j), self.spot_texture_offsets[j]));
            layers.extend(light_layers(&self.lights, j, res));
        }
        let layers_buf = storage_buffer(
            device,
            "LightMatrix::layers",
            &layers,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
        );
        let lights_buf = storage_buffer(device, "LightMatrix::lights", &gpu_lights, wgpu::BufferUsages::STORAGE);
        let weights_buf = storage_buffer(device, "LightMatrix::weights", weights, wgpu::BufferUsages::STORAGE);
        let (_, _, dispatch_width) = dispatch_size(self.view_buffers.num_samples);
        let dummy;
        let columns_buf = match columns {
            Some(b) => b,
            None => {
                dummy = storage_buffer::<f32>(device, "LightMatrix::no_columns", &[], wgpu::BufferUsages::STORAGE);
                &dummy
            }
        };
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::batch") });
        if self.opts.visibility != Visibility::RayTraced {
            self.shadow_pass.encode(device, &mut encoder, &self.atlas, &layers_buf, batch.num_layers, &self.geometry);
        }
        // With rays, few enough lights per dispatch that an invocation's loops stay bounded (module doc).
        let per_dispatch = match self.opts.visibility {
            Visibility::ShadowMap => gpu_lights.len(),
            Visibility::Hybrid | Visibility::RayTraced => RAYS_PER_INVOCATION as usize,
        };
        for first in (0..gpu_lights.len()).step_by(per_dispatch.max(1)) {
            let params = ColumnParams {
                num_samples: self.view_buffers.num_samples,
                num_lights: per_dispatch.min(gpu_lights.len() - first) as u32,
                write_columns: columns.is_some() as u32,
                accumulate: columns.is_none() as u32,
                resolution: res,
                dispatch_width,
                first_light: first as u32,
                visibility: self.opts.visibility as u32,
                normal_offset: self.opts.normal_offset,
                depth_bias: self.opts.depth_bias,
                slope_bias: self.opts.slope_bias,
                _pad1: 0.0,
            };
            let params_buf = storage_buffer(device, "LightMatrix::params", &[params], wgpu::BufferUsages::UNIFORM);
            self.columns_pass.encode(
                device,
                &mut encoder,
                &ColumnsInputs {
                    params: &params_buf,
                    view: &self.view_buffers,
                    lights: &lights_buf,
                    layers: &layers_buf,
                    weights: &weights_buf,
                    shadow_maps: &self.atlas.array_view,
                    accum,
                    columns: columns_buf,
                    bvh_nodes: &self.bvh.nodes,
                    bvh_prims: &self.bvh.primitives,
                    stats: &self.stats,
                    spot_textures: &self.spot_textures,
                },
            );
        }
        self.ctx.queue.submit(Some(encoder.finish()))
    }

    fn wait_for(&self, submission: wgpu::SubmissionIndex) -> Result<()> {
        crate::interrupt::wait_gpu(&self.ctx.device, Some(submission), "a column batch")
    }

    /// Visibility counters since creation or the last `reset_visibility_stats` (waits for the GPU).
    pub fn visibility_stats(&self) -> Result<VisibilityStats> {
        let w = self.ctx.read_buffer::<u32>(&self.stats, 0, 6)?;
        let c = |k: usize| w[2 * k] as u64 | (w[2 * k + 1] as u64) << 32;
        Ok(VisibilityStats { shadow_tests: c(0), ray_casts: c(1), gave_up: c(2) })
    }

    /// Sets the visibility counters to 0.
    pub fn reset_visibility_stats(&self) {
        self.ctx.queue.write_buffer(&self.stats, 0, bytemuck::cast_slice(&[0u32; 6]));
    }

    /// Columns `js` (any order, repeats allowed): k * H * W * 3 floats, column-major by light, then
    /// row 0 at the top, then RGB (a pixel's delta-chain samples summed into it).
    pub fn columns(&self, js: &[usize]) -> Result<Vec<f32>> {
        self.check_indices(js)?;
        let m = self.view.len();
        let column_bytes = (m as u64 * 12).max(4);
        let max_columns = (self.max_binding.min(128 << 20) / column_bytes) as usize;
        if max_columns == 0 {
            return Err(Error::invalid(format!(
                "one column of {m} view samples ({column_bytes} bytes) exceeds the storage binding limit"
            )));
        }
        crate::memory::check_host(
            &format!("columns: {} columns x {m} view samples x RGB float32", js.len()),
            crate::memory::product(&[js.len() as u64, m as u64, 12]),
        )?;
        let batches = self.batches(js, max_columns);
        let largest = batches.iter().map(|b| b.end - b.start).max().unwrap_or(0);
        let columns_buf = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("LightMatrix::columns"),
            size: (largest as u64 * column_bytes).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let accum = storage_buffer::<f32>(&self.ctx.device, "LightMatrix::no_accum", &[], wgpu::BufferUsages::STORAGE);
        let pixels = self.view.num_pixels();
        let mut out = Vec::with_capacity(js.len() * pixels * 3);
        for batch in &batches {
            let zeros = vec![[0.0f32; 4]; batch.end - batch.start];
            self.run_batch(js, batch, &zeros, &accum, Some(&columns_buf));
            let data = self.ctx.read_buffer::<f32>(&columns_buf, 0, (batch.end - batch.start) * m * 3)?;
            if m == pixels {
                out.extend(data);
            } else {
                for column in data.chunks_exact(m * 3) {
                    out.extend(self.view.fold(column, 3));
                }
            }
        }
        Ok(out)
    }

    /// `sum_j w_j A(:, j)` over all lights (weights `None` = all 1) as H * W * 3 floats, accumulated on
    /// the GPU; `progress(done, n)` after each batch.
    pub fn column_sum(&self, weights: Option<&[f32]>, progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
        let n = self.lights.len();
        let w: Vec<[f32; 3]> = match weights {
            Some(w) => {
                if w.len() != n {
                    return Err(Error::invalid(format!("weights must have length {n} (one per light), got {}", w.len())));
                }
                w.iter().map(|&v| [v; 3]).collect()
            }
            None => vec![[1.0; 3]; n],
        };
        let js: Vec<usize> = (0..n).collect();
        self.weighted_sum(&js, &w, progress)
    }

    /// `sum_k weights[k] * A(:, js[k])` with RGB weights, rendering only the listed columns (repeats add
    /// up): the reconstruction of clustered renderers (representatives and their weights). H * W * 3
    /// floats; `progress(done, k)` after each batch.
    pub fn weighted_sum(
        &self,
        js: &[usize],
        weights: &[[f32; 3]],
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Vec<f32>> {
        self.check_indices(js)?;
        if weights.len() != js.len() {
            return Err(Error::invalid(format!(
                "weights must have one RGB triple per column: {} columns, {} weights",
                js.len(),
                weights.len()
            )));
        }
        if let Some((k, v)) = weights.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
            return Err(Error::invalid(format!("weights must be finite, got {v:?} for light {}", js[k])));
        }
        let w4: Vec<[f32; 4]> = weights.iter().map(|v| [v[0], v[1], v[2], 0.0]).collect();
        let m = self.view.len();
        let accum = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("LightMatrix::accum"),
            size: (m as u64 * 16).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        for batch in self.batches(js, usize::MAX) {
            let submission = self.run_batch(js, &batch, &w4[batch.start..batch.end], &accum, None);
            self.wait_for(submission)?;
            progress(batch.end, js.len());
        }
        let rgba = self.ctx.read_buffer::<[f32; 4]>(&accum, 0, m)?;
        let rgb: Vec<f32> = rgba.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        Ok(if m == self.view.num_pixels() { rgb } else { self.view.fold(&rgb, 3) })
    }
}
