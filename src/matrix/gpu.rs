//! The GPU backend of the light matrix (wgpu): columns by shadow maps and exact BVH rays on the GPU
//! (module docs of `crate::matrix` for batches and visibility), rows by cube maps (`rows.rs`).
//!
//! `GpuBackend` owns every GPU resource of one `LightMatrix`: the scene geometry and BVH, the view
//! samples' buffers, the shadow atlas and the passes. It implements `Backend`; `element` uses the exact
//! CPU oracle (`oracle.rs`) with a ray tracer built on first use.
use super::backend::{Backend, DeviceInfo};
use super::gpu_memory::atlas_layers;
pub use super::gpu_memory::{check_gpu_estimate, estimate_gpu_bytes, GpuMemoryEstimate};
use super::rows::{RowOptions, TimedRows};
use super::{ColumnOptions, Visibility, VisibilityStats};
use crate::error::{Error, Result};
use crate::gpu::bvh::{GpuBvh, RAYS_PER_INVOCATION};
use crate::gpu::columns::{
    dispatch_size, storage_buffer, ColumnParams, ColumnsInputs, ColumnsPass, GpuLight, ViewBuffers, MAX_LIGHTS_PER_DISPATCH,
};
use crate::gpu::scene_buffers::SceneGeometry;
use crate::gpu::shadow::{layer_count, light_layers, uses_cube, ShadowAtlas, ShadowMapPass};
use crate::gpu::GpuContext;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use crate::view::ViewSamples;
use std::sync::Arc;

/// The GPU resources of a light matrix (module docs).
pub struct GpuBackend {
    pub(crate) ctx: Arc<GpuContext>,
    pub scene: Arc<Scene>,
    pub view: Arc<ViewSamples>,
    pub lights: Arc<LightSet>,
    pub opts: ColumnOptions,
    pub(crate) shadow_pass: Arc<ShadowMapPass>,
    pub(crate) columns_pass: Arc<ColumnsPass>,
    /// The scene's triangles (unshared vertices), drawn into every shadow map.
    pub(crate) geometry: SceneGeometry,
    pub(crate) view_buffers: ViewBuffers,
    pub(crate) atlas: ShadowAtlas,
    /// The scene BVH for exact shadow rays (a one-leaf empty BVH in `ShadowMap` mode).
    pub(crate) bvh: GpuBvh,
    /// `VisibilityStats` as six u32 (lo, hi pairs), added to by every column dispatch.
    pub(crate) stats: wgpu::Buffer,
    /// Largest storage binding in bytes.
    pub(crate) max_binding: u64,
    /// Projected textures of spot lights (`crate::lights::spot_texture::gpu_table`) and each light's
    /// record offset in them.
    pub(crate) spot_textures: wgpu::Buffer,
    pub(crate) spot_texture_offsets: Vec<u32>,
    /// All lights as `GpuLight`s for the row pass, in chunks (first light, buffer); uploaded once.
    pub(crate) row_lights: std::sync::OnceLock<Vec<(usize, wgpu::Buffer)>>,
    /// The row pass's cube atlas and output buffer, reused by later calls.
    pub(crate) row_scratch: std::sync::Mutex<Option<super::rows::RowScratch>>,
    /// CPU ray tracer of the exact oracle (`oracle.rs`), built on first use (or given).
    pub(crate) oracle: std::sync::OnceLock<Arc<RayTracer>>,
    /// The mask table (`crate::gpu::mask`; 16 unused bytes when the scene has no masked surfaces).
    pub(crate) masks: wgpu::Buffer,
    /// Whether the view has masks (`ViewSamples::mask_budget` not empty) and the scene's directional
    /// lights are environment strata whose shadow rays cross them (`gpu::mask::light_fields`).
    pub(crate) has_masks: bool,
    pub(crate) directional_crosses_masks: bool,
}

/// Lights `js[start..end]` and the first layer of each.
struct Batch {
    start: usize,
    end: usize,
    layers: Vec<u32>,
    num_layers: u32,
}

impl GpuBackend {
    pub fn new(
        ctx: Arc<GpuContext>,
        scene: Arc<Scene>,
        view: Arc<ViewSamples>,
        lights: Arc<LightSet>,
        opts: ColumnOptions,
    ) -> Result<GpuBackend> {
        if let Some(why) = super::backend::gpu_unsupported(&scene) {
            return Err(Error::invalid(format!("the GPU backend cannot compute this light matrix: {why}; use device=\"cpu\"")));
        }
        super::check_view(&view)?;
        let m = view.len();
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
        let max_layers = atlas_layers(&opts, limits.max_texture_array_layers);
        let res = opts.shadow_resolution as u64;
        let atlas_what = format!("shadow maps: {max_layers} layers of {res}^2 texels (shadow_map_size = {res})");
        crate::memory::check_gpu(&ctx, &atlas_what, crate::memory::product(&[max_layers as u64, res, res, 4]), false)?;
        let triangles = scene.meshes.iter().map(|mesh| mesh.indices.len() as u64).sum::<u64>();
        let mut est = estimate_gpu_bytes(m as u64, lights.len() as u64, triangles, &opts);
        if opts.visibility == Visibility::ShadowMap && !view.mask_budget.is_empty() {
            // Masked surfaces need the BVH in every mode.
            est.bvh = estimate_gpu_bytes(m as u64, 0, triangles, &ColumnOptions { visibility: Visibility::RayTraced, ..opts.clone() }).bvh;
        }
        est.shadow_atlas = max_layers as u64 * opts.shadow_resolution as u64 * opts.shadow_resolution as u64 * 4;
        let what = format!("a light matrix of {m} view samples, {} lights and {triangles} triangles on the GPU", lights.len());
        check_gpu_estimate(&ctx, &est, &what)?;
        // The view samples' BSDF records (blended BSDFs add a second one) in one binding.
        let bsdf_bytes = view.bsdf.len() as u128 * std::mem::size_of::<crate::shading::GpuBsdf>() as u128;
        crate::gpu::alloc::check_buffer(limits, &format!("the BSDFs of {m} view samples"), bsdf_bytes, true)?;
        let device = &ctx.device;
        let geometry = SceneGeometry::upload(device, &scene)?;
        let tables = crate::shading::bsdf::roughplastic_table_buffer(&scene.bsdfs);
        let view_buffers = ViewBuffers::upload(device, &view, &tables)?;
        let atlas = ShadowAtlas::new(device, opts.shadow_resolution, max_layers).map_err(|e| match e {
            Error::OutOfMemory(m) => Error::OutOfMemory(format!("{atlas_what}: {m}")),
            e => e,
        })?;
        // Masked surfaces need exact rays in every mode (`visibility_masked` in columns.wgsl).
        let has_masks = !view.mask_budget.is_empty();
        let bvh = if opts.visibility == Visibility::ShadowMap && !has_masks {
            GpuBvh::empty(device)?
        } else {
            GpuBvh::upload(device, &scene, max_binding)?
        };
        let table = if has_masks { crate::gpu::mask::MaskTable::build(&scene) } else { Default::default() };
        let table_what = "the mask table (the masked surfaces' opacities and textures)";
        crate::gpu::alloc::check_buffer(limits, table_what, table.bytes() as u128, true)?;
        crate::memory::check_gpu(&ctx, table_what, table.bytes() as u128, false)?;
        let masks = storage_buffer(device, "LightMatrix::masks", &table.words, wgpu::BufferUsages::STORAGE)?;
        let directional_crosses_masks = crate::raytrace::mask::Masks::new(&scene).directional_is_environment;
        let stats = storage_buffer::<u32>(
            device,
            "LightMatrix::stats",
            &[0; 6],
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        )?;
        let (texels, spot_texture_offsets) = crate::lights::spot_texture::gpu_table(&lights);
        if texels.len() as u64 * 4 > max_binding {
            return Err(Error::invalid(format!(
                "the spot lights' projected textures need {} bytes, above the {max_binding}-byte storage binding limit",
                texels.len() as u64 * 4
            )));
        }
        let spot_textures = storage_buffer(device, "LightMatrix::spot_textures", &texels, wgpu::BufferUsages::STORAGE)?;
        Ok(GpuBackend {
            spot_textures,
            spot_texture_offsets,
            bvh,
            stats,
            shadow_pass: crate::gpu::pipeline::shared_pass(device, ShadowMapPass::new),
            columns_pass: crate::gpu::pipeline::shared_pass(device, ColumnsPass::new),
            geometry,
            view_buffers,
            atlas,
            max_binding,
            row_lights: std::sync::OnceLock::new(),
            row_scratch: std::sync::Mutex::new(None),
            oracle: std::sync::OnceLock::new(),
            masks,
            has_masks,
            directional_crosses_masks,
            ctx,
            scene,
            view,
            lights,
            opts,
        })
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

    /// The batch's lights (`GpuLight`s) and shadow-map layers as GPU buffers, and the light count.
    fn batch_buffers(&self, js: &[usize], batch: &Batch) -> Result<(wgpu::Buffer, wgpu::Buffer, usize)> {
        let device = &self.ctx.device;
        let res = self.opts.shadow_resolution;
        let mut gpu_lights = Vec::with_capacity(batch.end - batch.start);
        let mut layers = Vec::with_capacity(batch.num_layers as usize);
        for (k, &j) in js[batch.start..batch.end].iter().enumerate() {
            gpu_lights.push(self.gpu_light(j, batch.layers[k]));
            layers.extend(light_layers(&self.lights, j, res));
        }
        let layers_buf = storage_buffer(device, "LightMatrix::layers", &layers, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE)?;
        let lights_buf = storage_buffer(device, "LightMatrix::lights", &gpu_lights, wgpu::BufferUsages::STORAGE)?;
        Ok((lights_buf, layers_buf, gpu_lights.len()))
    }

    /// Light j as a `GpuLight` whose shadow map starts at `first_layer`, with its mask fields
    /// (`gpu::mask::light_fields`) when the view has masks.
    pub(crate) fn gpu_light(&self, j: usize, first_layer: u32) -> GpuLight {
        let mut l = GpuLight::new(&self.lights, j, first_layer, uses_cube(&self.lights, j), self.spot_texture_offsets[j]);
        if self.has_masks {
            let [pdf, passes] = crate::gpu::mask::light_fields(&self.view, &self.lights, j, self.directional_crosses_masks);
            l.patch[1][3] = pdf;
            l.patch[2][3] = passes;
        }
        l
    }

    /// Record the batch's shadow maps (none with exact rays only).
    fn encode_shadow_maps(&self, encoder: &mut wgpu::CommandEncoder, layers_buf: &wgpu::Buffer, batch: &Batch) {
        if self.opts.visibility != Visibility::RayTraced {
            self.shadow_pass.encode(&self.ctx.device, encoder, &self.atlas, layers_buf, batch.num_layers, &self.geometry);
        }
    }

    /// Record the column pass of `num_lights` lights (their shadow maps rendered) over the shading points
    /// `view`: weighted sum into `accum`, or the columns into `columns`.
    #[allow(clippy::too_many_arguments)]
    fn encode_columns(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &ViewBuffers,
        (lights_buf, layers_buf, num_lights): (&wgpu::Buffer, &wgpu::Buffer, usize),
        weights: &[[f32; 4]],
        accum: &wgpu::Buffer,
        columns: Option<&wgpu::Buffer>,
    ) -> Result<()> {
        let device = &self.ctx.device;
        let weights_buf = storage_buffer(device, "LightMatrix::weights", weights, wgpu::BufferUsages::STORAGE)?;
        let dummy;
        let columns_buf = match columns {
            Some(b) => b,
            None => {
                dummy = storage_buffer::<f32>(device, "LightMatrix::no_columns", &[], wgpu::BufferUsages::STORAGE)?;
                &dummy
            }
        };
        // With rays, few enough lights per dispatch that an invocation's loops stay bounded (module doc);
        // a mask ray may take several traversals (`gpu::mask::MASK_RAY_COST`).
        let per_dispatch = match (self.opts.visibility, self.has_masks) {
            (Visibility::ShadowMap, false) => num_lights,
            (_, true) => (RAYS_PER_INVOCATION / crate::gpu::mask::MASK_RAY_COST).max(1) as usize,
            (Visibility::Hybrid | Visibility::RayTraced, false) => RAYS_PER_INVOCATION as usize,
        };
        // And few enough (sample, light) pairs per dispatch for the work budget (`gpu::dispatch`).
        let rays = self.opts.visibility != Visibility::ShadowMap || self.has_masks;
        for d in crate::gpu::dispatch::plan_columns(view.num_samples, num_lights as u32, per_dispatch as u32, rays) {
            let (_, _, dispatch_width) = dispatch_size(d.num_samples);
            let params = ColumnParams {
                num_samples: view.num_samples,
                num_lights: d.num_lights,
                write_columns: columns.is_some() as u32,
                accumulate: columns.is_none() as u32,
                resolution: self.opts.shadow_resolution,
                dispatch_width,
                first_light: d.first_light,
                visibility: self.opts.visibility as u32,
                normal_offset: self.opts.normal_offset,
                depth_bias: self.opts.depth_bias,
                slope_bias: self.opts.slope_bias,
                first_sample: d.first_sample,
            };
            let params_buf = storage_buffer(device, "LightMatrix::params", &[params], wgpu::BufferUsages::UNIFORM)?;
            self.columns_pass.encode(
                device,
                encoder,
                &ColumnsInputs {
                    params: &params_buf,
                    view,
                    lights: lights_buf,
                    layers: layers_buf,
                    weights: &weights_buf,
                    shadow_maps: &self.atlas.array_view,
                    accum,
                    columns: columns_buf,
                    bvh_nodes: &self.bvh.nodes,
                    bvh_prims: &self.bvh.primitives,
                    stats: &self.stats,
                    spot_textures: &self.spot_textures,
                    masks: &self.masks,
                },
                d.num_samples,
            );
        }
        Ok(())
    }

    /// Encode and submit one batch: shadow maps, then the column pass. Returns the submission.
    fn run_batch(
        &self,
        js: &[usize],
        batch: &Batch,
        weights: &[[f32; 4]],
        accum: &wgpu::Buffer,
        columns: Option<&wgpu::Buffer>,
    ) -> Result<wgpu::SubmissionIndex> {
        let (lights_buf, layers_buf, n) = self.batch_buffers(js, batch)?;
        let mut encoder = self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::batch") });
        self.encode_shadow_maps(&mut encoder, &layers_buf, batch);
        self.encode_columns(&mut encoder, &self.view_buffers, (&lights_buf, &layers_buf, n), weights, accum, columns)?;
        Ok(self.ctx.queue.submit(Some(encoder.finish())))
    }

    /// Replaces the light set (same scene, view samples, shadow atlas and BVH): relighting re-uses one
    /// backend for every light configuration (`crate::relight::gpu`).
    ///
    /// Errors: `InvalidParameter` when the spot lights' textures exceed the storage binding limit.
    pub(crate) fn set_lights(&mut self, lights: Arc<LightSet>) -> Result<()> {
        let (texels, offsets) = crate::lights::spot_texture::gpu_table(&lights);
        if texels.len() as u64 * 4 > self.max_binding {
            return Err(Error::invalid(format!(
                "the spot lights' projected textures need {} bytes, above the {}-byte storage binding limit",
                texels.len() as u64 * 4,
                self.max_binding
            )));
        }
        self.spot_textures = storage_buffer(&self.ctx.device, "LightMatrix::spot_textures", &texels, wgpu::BufferUsages::STORAGE)?;
        self.spot_texture_offsets = offsets;
        self.row_lights = std::sync::OnceLock::new();
        self.lights = lights;
        Ok(())
    }

    /// Adds every light's column (weight 1) over each target's shading points to that target's RGBA f32
    /// accumulator, stage by stage with a wait after each: per batch the shadow maps, then each
    /// target's column pass. Returns the seconds spent in the shadow maps and in each target's pass
    /// (the waits make the stages' times honest at the cost of the overlap between them).
    pub(crate) fn accumulate_staged(&self, targets: &[(&ViewBuffers, &wgpu::Buffer)]) -> Result<(f64, Vec<f64>)> {
        let js: Vec<usize> = (0..self.lights.len()).collect();
        let mut seconds = vec![0.0; targets.len()];
        let mut shadow = 0.0;
        for batch in self.batches(&js, usize::MAX) {
            let t0 = std::time::Instant::now();
            let (lights_buf, layers_buf, n) = self.batch_buffers(&js, &batch)?;
            let mut encoder =
                self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::shadow") });
            self.encode_shadow_maps(&mut encoder, &layers_buf, &batch);
            self.wait_for(self.ctx.queue.submit(Some(encoder.finish())))?;
            shadow += t0.elapsed().as_secs_f64();
            let ones = vec![[1.0f32; 4]; n];
            for (k, (view, accum)) in targets.iter().enumerate() {
                let t1 = std::time::Instant::now();
                let mut encoder =
                    self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("LightMatrix::columns") });
                self.encode_columns(&mut encoder, view, (&lights_buf, &layers_buf, n), &ones, accum, None)?;
                self.wait_for(self.ctx.queue.submit(Some(encoder.finish())))?;
                seconds[k] += t1.elapsed().as_secs_f64();
            }
        }
        Ok((shadow, seconds))
    }

    pub(crate) fn wait_for(&self, submission: wgpu::SubmissionIndex) -> Result<()> {
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

    /// Columns `js` (any order, repeats allowed; validated by `LightMatrix`): k * H * W * 3 floats,
    /// column-major by light, then row 0 at the top, then RGB (a pixel's delta-chain samples summed into it).
    pub(crate) fn columns(&self, js: &[usize]) -> Result<Vec<f32>> {
        let m = self.view.len();
        let column_bytes = (m as u64 * 12).max(4);
        let max_columns = (self.max_binding.min(128 << 20) / column_bytes) as usize;
        if max_columns == 0 {
            return Err(Error::invalid(format!("one column of {m} view samples ({column_bytes} bytes) exceeds the storage binding limit")));
        }
        crate::memory::check_host(
            &format!("columns: {} columns x {m} view samples x RGB float32", js.len()),
            crate::memory::product(&[js.len() as u64, m as u64, 12]),
        )?;
        let batches = self.batches(js, max_columns);
        let largest = batches.iter().map(|b| b.end - b.start).max().unwrap_or(0);
        let columns_buf = crate::gpu::alloc::buffer(
            &self.ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("LightMatrix::columns"),
                size: (largest as u64 * column_bytes).max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        )?;
        let accum = storage_buffer::<f32>(&self.ctx.device, "LightMatrix::no_accum", &[], wgpu::BufferUsages::STORAGE)?;
        let pixels = self.view.num_pixels();
        let mut out = Vec::with_capacity(js.len() * pixels * 3);
        for batch in &batches {
            let zeros = vec![[0.0f32; 4]; batch.end - batch.start];
            self.run_batch(js, batch, &zeros, &accum, Some(&columns_buf))?;
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

    /// Columns `js` rendered batch by batch into one GPU buffer that is never read back: after each
    /// batch's column pass has run, `each(buffer, range, seconds)` gets the buffer (column `range.start + c`
    /// of `js` at floats `[c * m * 3, (c + 1) * m * 3)`, m view samples, RGB; delta-chain samples not
    /// folded), the batch's range of `js` and the seconds its shadow maps and column pass took. Work
    /// `each` submits runs before the next batch overwrites the buffer (one queue, in order). At most
    /// `max_columns` columns per batch. Tensor clustering's GPU-resident reconstruction
    /// (`crate::gpu::reconstruction`).
    pub(crate) fn columns_on_gpu(
        &self,
        js: &[usize],
        max_columns: usize,
        each: &mut dyn FnMut(&wgpu::Buffer, std::ops::Range<usize>, f64) -> Result<()>,
    ) -> Result<()> {
        let m = self.view.len();
        let column_bytes = (m as u64 * 12).max(4);
        let fit = (self.max_binding.min(128 << 20) / column_bytes) as usize;
        if fit == 0 {
            return Err(Error::invalid(format!("one column of {m} view samples ({column_bytes} bytes) exceeds the storage binding limit")));
        }
        let batches = self.batches(js, fit.min(max_columns.max(1)));
        let largest = batches.iter().map(|b| b.end - b.start).max().unwrap_or(0);
        let columns_buf = crate::gpu::alloc::buffer(
            &self.ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("LightMatrix::gpu_columns"),
                size: (largest as u64 * column_bytes).max(16),
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            },
        )?;
        let accum = storage_buffer::<f32>(&self.ctx.device, "LightMatrix::no_accum", &[], wgpu::BufferUsages::STORAGE)?;
        for batch in &batches {
            let t = std::time::Instant::now();
            let zeros = vec![[0.0f32; 4]; batch.end - batch.start];
            self.wait_for(self.run_batch(js, batch, &zeros, &accum, Some(&columns_buf))?)?;
            each(&columns_buf, batch.start..batch.end, t.elapsed().as_secs_f64())?;
        }
        Ok(())
    }

    /// `sum_k weights[k] * A(:, js[k])` with RGB weights, rendering only the listed columns (repeats add
    /// up): the reconstruction of clustered renderers (representatives and their weights). H * W * 3
    /// floats; `progress(done, k)` after each batch. Indices and weights are validated by `LightMatrix`.
    pub(crate) fn weighted_sum(&self, js: &[usize], weights: &[[f32; 3]], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
        let w4: Vec<[f32; 4]> = weights.iter().map(|v| [v[0], v[1], v[2], 0.0]).collect();
        let m = self.view.len();
        let accum = crate::gpu::alloc::buffer(
            &self.ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("LightMatrix::accum"),
                size: (m as u64 * 16).max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        )?;
        for batch in self.batches(js, usize::MAX) {
            let submission = self.run_batch(js, &batch, &w4[batch.start..batch.end], &accum, None)?;
            self.wait_for(submission)?;
            progress(batch.end, js.len());
        }
        let rgba = self.ctx.read_buffer::<[f32; 4]>(&accum, 0, m)?;
        let rgb: Vec<f32> = rgba.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        Ok(if m == self.view.num_pixels() { rgb } else { self.view.fold(&rgb, 3) })
    }
}

impl Backend for GpuBackend {
    fn as_gpu(&self) -> Option<&GpuBackend> {
        Some(self)
    }
    fn info(&self) -> DeviceInfo {
        DeviceInfo::gpu(&self.ctx)
    }
    fn columns(&self, js: &[usize]) -> Result<Vec<f32>> {
        GpuBackend::columns(self, js)
    }
    fn weighted_sum(&self, js: &[usize], weights: &[[f32; 3]], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
        GpuBackend::weighted_sum(self, js, weights, progress)
    }
    fn rows(&self, is: &[usize], opts: &RowOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<TimedRows> {
        self.rows_timed(is, opts, progress)
    }
    fn tracer(&self) -> Result<Arc<RayTracer>> {
        if let Some(t) = self.oracle.get() {
            return Ok(t.clone());
        }
        let t = Arc::new(RayTracer::new(&self.scene)?);
        // Another thread may have won the race; either tracer is the same.
        Ok(self.oracle.get_or_init(|| t).clone())
    }
    fn visibility_stats(&self) -> Result<VisibilityStats> {
        GpuBackend::visibility_stats(self)
    }
    fn reset_visibility_stats(&self) {
        GpuBackend::reset_visibility_stats(self)
    }
    fn clustered_shading(&self, job: &crate::cluster::visibility::ClusteredShading) -> Result<crate::cluster::visibility::ClusteredImage> {
        crate::gpu::clustered_visibility::render(self, job)
    }
}
