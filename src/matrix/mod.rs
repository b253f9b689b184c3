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
//! Delta BSDF chains (`crate::view::chains`): a pixel may own several view samples (its camera hit plus
//! the surfaces seen through mirrors and glass, each with its chain's RGB throughput). The matrix rows
//! are pixels: A(i, j) = sum over pixel i's samples k of throughput_k * (light j's direct light at k).
//! The GPU shades every sample (throughput applied in the shader) and the per-sample results are summed
//! into their pixels on the host (`ViewSamples::fold`); without delta BSDFs each pixel has one sample
//! of throughput 1 and nothing changes.
//!
//! Symbols: m = number of rows = pixels (`width * height`), n = number of lights, w = weights.
pub mod backend;
pub mod bias_compensation;
pub mod emitted;
pub mod glossy;
pub mod gpu;
mod gpu_memory;
pub mod mapping;
pub mod oracle;
pub mod reconstruction;
pub mod reference;
pub mod rows;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use crate::view::ViewSamples;
use backend::{Backend, Chosen, Device, DeviceInfo};
use rows::{RowOptions, TimedRows};
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
            _ => Err(Error::invalid(format!("visibility must be 'shadow_map', 'hybrid' or 'ray_traced', got '{name}'"))),
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
            max_lights_per_batch: crate::gpu::columns::MAX_LIGHTS_PER_DISPATCH,
            shadow_memory_budget: 256 << 20,
            // Chosen by `tests::bias_sweep` (0 acne/leak pixels away from edges at 256-1024 texels).
            normal_offset: 1.0,
            depth_bias: 0.25,
            slope_bias: 0.1,
        }
    }
}

/// The light matrix of a scene, its view samples and a light set, computed by one backend
/// (`backend::Backend`: the GPU's `gpu::GpuBackend` or the CPU's `crate::cpu::CpuBackend`). Validates
/// every index and weight, then dispatches.
pub struct LightMatrix {
    pub scene: Arc<Scene>,
    pub view: Arc<ViewSamples>,
    pub lights: Arc<LightSet>,
    /// Column options (visibility and shadow maps: used by the GPU backend; the CPU always casts rays).
    pub opts: ColumnOptions,
    backend: Box<dyn Backend>,
}

impl LightMatrix {
    /// The matrix on the GPU backend of `ctx`.
    pub fn new(
        ctx: Arc<GpuContext>,
        scene: Arc<Scene>,
        view: Arc<ViewSamples>,
        lights: Arc<LightSet>,
        opts: ColumnOptions,
    ) -> Result<LightMatrix> {
        let gpu = gpu::GpuBackend::new(ctx, scene.clone(), view.clone(), lights.clone(), opts.clone())?;
        Ok(LightMatrix { scene, view, lights, opts, backend: Box::new(gpu) })
    }

    /// The GPU backend when this matrix runs on the GPU (passes that keep their data there).
    pub fn gpu_backend(&self) -> Option<&gpu::GpuBackend> {
        self.backend.as_gpu()
    }

    /// The matrix on the CPU backend with the scene's ray tracer (`RayTracer::new(&scene)`).
    pub fn new_cpu(tracer: Arc<RayTracer>, scene: Arc<Scene>, view: Arc<ViewSamples>, lights: Arc<LightSet>) -> Result<LightMatrix> {
        check_view(&view)?;
        let opts = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
        let cpu = crate::cpu::CpuBackend::new(tracer, view.clone(), lights.clone())?;
        Ok(LightMatrix { scene, view, lights, opts, backend: Box::new(cpu) })
    }

    /// The matrix on a chosen device (`Device::choose`). The CPU backend casts exact rays only:
    /// `opts.visibility` other than `RayTraced` is refused there. `tracer` gives the scene's ray tracer
    /// when one exists (else it is built here for the CPU, on first use for the GPU's oracle).
    ///
    /// Errors: `InvalidParameter` for shadow-map visibility on the CPU; what the backend's `new` raises.
    pub fn with_device(
        chosen: &Chosen,
        scene: Arc<Scene>,
        view: Arc<ViewSamples>,
        lights: Arc<LightSet>,
        opts: ColumnOptions,
        tracer: Option<Arc<RayTracer>>,
    ) -> Result<LightMatrix> {
        match chosen {
            Chosen::Gpu(ctx) => {
                let gpu = gpu::GpuBackend::new(ctx.clone(), scene.clone(), view.clone(), lights.clone(), opts.clone())?;
                if let Some(t) = tracer {
                    let _ = gpu.oracle.set(t);
                }
                Ok(LightMatrix { scene, view, lights, opts, backend: Box::new(gpu) })
            }
            Chosen::Cpu => {
                if opts.visibility != Visibility::RayTraced {
                    return Err(Error::invalid(format!(
                        "visibility {:?} uses shadow maps, which only the GPU backend renders; the CPU backend \
                         casts an exact ray for every shadow test (visibility 'ray_traced')",
                        opts.visibility
                    )));
                }
                let tracer = match tracer {
                    Some(t) => t,
                    None => Arc::new(RayTracer::new(&scene)?),
                };
                LightMatrix::new_cpu(tracer, scene, view, lights)
            }
        }
    }

    /// `with_device` for a device name ("auto", "gpu", "cpu"; `MANYLIGHTS_DEVICE` replaces "auto").
    pub fn on_device(
        device: Device,
        scene: Arc<Scene>,
        view: Arc<ViewSamples>,
        lights: Arc<LightSet>,
        opts: ColumnOptions,
    ) -> Result<LightMatrix> {
        let (chosen, _) = device.choose_for_scene(&scene)?;
        LightMatrix::with_device(&chosen, scene, view, lights, opts, None)
    }

    /// Which device computes this matrix.
    pub fn device(&self) -> DeviceInfo {
        self.backend.info()
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

    /// Visibility counters since creation or the last `reset_visibility_stats` (waits for the GPU).
    pub fn visibility_stats(&self) -> Result<VisibilityStats> {
        self.backend.visibility_stats()
    }

    /// Sets the visibility counters to 0.
    pub fn reset_visibility_stats(&self) {
        self.backend.reset_visibility_stats()
    }

    /// Columns `js` (any order, repeats allowed): k * H * W * 3 floats, column-major by light, then
    /// row 0 at the top, then RGB (a pixel's delta-chain samples summed into it).
    pub fn columns(&self, js: &[usize]) -> Result<Vec<f32>> {
        self.check_indices(js)?;
        self.backend.columns(js)
    }

    /// `sum_j w_j A(:, j)` over all lights (weights `None` = all 1) as H * W * 3 floats;
    /// `progress(done, n)` as it goes.
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
    /// floats; `progress(done, k)` as it goes.
    pub fn weighted_sum(&self, js: &[usize], weights: &[[f32; 3]], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
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
        self.backend.weighted_sum(js, weights, progress)
    }

    /// Clustered visibility (`crate::cluster::visibility`) of this matrix's scene, view samples and lights
    /// with the given clusterings, on this matrix's backend.
    ///
    /// Errors: `InvalidParameter` naming the bad value (module docs of `cluster::visibility`); GPU errors.
    pub fn clustered_shading(
        &self,
        lights: &crate::cluster::visibility::LightClustering,
        view: &crate::cluster::visibility::ViewClustering,
    ) -> Result<(crate::cluster::visibility::ClusteredShading, crate::cluster::visibility::ClusteredImage)> {
        let job = crate::cluster::visibility::ClusteredShading::new(&self.lights, &self.view, lights, view)?;
        let out = self.backend.clustered_shading(&job)?;
        Ok((job, out))
    }

    /// Rows `is` (pixel indices `y * width + x`, any order, repeats allowed) as r * n * 3 floats,
    /// `[row][light][rgb]`, with the default `RowOptions`; `progress(rows_done, r)` as it goes. A pixel
    /// with delta-chain samples (`crate::view::chains`) has the sum of its samples' rows.
    pub fn rows(&self, is: &[usize], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
        Ok(self.rows_timed(is, &RowOptions::default(), progress)?.0)
    }

    /// `rows` with explicit options (the GPU's cube maps), also returning per-stage timings.
    pub fn rows_timed(&self, is: &[usize], opts: &RowOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<TimedRows> {
        let m = self.view.num_pixels();
        if let Some((k, &i)) = is.iter().enumerate().find(|(_, &i)| i >= m) {
            return Err(Error::invalid(format!("row index {i} (at position {k}) is out of range for {m} view samples")));
        }
        if is.is_empty() || self.lights.is_empty() {
            return Ok((Vec::new(), rows::RowTimings::default()));
        }
        self.backend.rows(is, opts, progress)
    }
}

/// View samples whose arrays agree with each other (the GPU backend checks the same and more).
fn check_view(view: &ViewSamples) -> Result<()> {
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
            view.width,
            view.height,
            view.extra_pixel.len(),
            view.position.len(),
            view.normal.len(),
            view.geo_normal.len(),
            view.wi.len(),
            view.bsdf.len(),
            view.throughput.len()
        )));
    }
    Ok(())
}
