//! The backend interface of the light matrix and the choice of device.
//!
//! A `LightMatrix` owns one `Backend`, which computes the four things every many-light renderer asks of
//! the matrix A (m x n, A(i, j) = light j's contribution to pixel i; Hašan, Pellacini, Bala, "Matrix
//! Row-Column Sampling for the Many-Light Problem", SIGGRAPH 2007, Sec. 3):
//!
//! | method         | paper's name                 | what it returns                                   |
//! | -------------- | ---------------------------- | ------------------------------------------------- |
//! | `columns(J)`   | columns A(:, j)              | k * H * W * 3 f32, column-major by light           |
//! | `weighted_sum` | reconstruction sum_k w_k A(:, j_k) | H * W * 3 f32, accumulated without readback |
//! | `rows(I)`      | the reduced matrix R (r x n) | r * n * 3 f32 and per-stage timings                |
//! | `element(i, j)`| one element A(i, j)          | RGB, exact visibility                              |
//!
//! Two implementations: `gpu::GpuBackend` (wgpu: shadow maps + exact BVH rays on the GPU) and
//! `crate::cpu::CpuBackend` (rayon + the obvhs BVH: an exact shadow ray per test). Renderers call only
//! `LightMatrix`, which validates indices and weights and dispatches here, so every renderer runs on
//! either backend unchanged.
//!
//! Choosing the device (`Device::choose`): `"cpu"` and `"gpu"` are taken as asked (`"gpu"` with no
//! adapter at all raises `GpuUnavailable` with what to install; a software adapter such as lavapipe is
//! used when it is the only one). `"auto"` (the default) reads `MANYLIGHTS_DEVICE` (`auto`, `cpu` or
//! `gpu`) when it is set; otherwise it takes a hardware GPU when one exists (as `GpuContext` ranks
//! adapters; `MANYLIGHTS_ADAPTER` still selects among them, and an adapter it names that does not exist
//! is an error, one it names is used even if it is software) and the CPU backend otherwise: on a software adapter exact CPU rays are 5-20x faster
//! than the emulated GPU. An adapter whose limits do not meet every pass's needs (`gpu::needs`) is not
//! used: `"auto"` takes the CPU and `device_info()["reason"]` says why, `"gpu"` raises
//! `GpuUnavailable` naming the pass and the limit.
use super::rows::{RowOptions, TimedRows};
use super::VisibilityStats;
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::raytrace::RayTracer;
use std::sync::Arc;

/// The environment variable that replaces `device="auto"`.
pub const DEVICE_ENV: &str = "MANYLIGHTS_DEVICE";

/// What ran a light matrix: reported by `manylights.device_info()`, `LightMatrix.device` and every
/// `RenderResult`.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceInfo {
    /// "cpu" or "gpu".
    pub kind: &'static str,
    /// The GPU adapter's name, or the CPU's model name.
    pub name: String,
    /// The graphics API ("vulkan", "gl", ...) or "rayon" for the CPU backend.
    pub backend: String,
    /// Whether a GPU adapter is a software rasteriser (lavapipe, llvmpipe); false for the CPU backend.
    pub is_software: bool,
    /// Worker threads of the CPU backend (rayon's pool); 0 for the GPU.
    pub threads: usize,
    /// How the CPU backend traces its shadow rays: "embree" (16-ray packets through Embree,
    /// `raytrace::embree`) or "own" (the library's traversal, a ray at a time: a build without the `embree`
    /// feature, or a scene with analytic spheres); "gpu" on the GPU.
    pub shadow_rays: &'static str,
}

impl DeviceInfo {
    /// The CPU backend on this machine: model name from `/proc/cpuinfo` where it exists; `shadow_rays` as
    /// built (a scene with analytic spheres still traces its own way: `CpuBackend::info`).
    pub fn cpu() -> DeviceInfo {
        let model = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| s.lines().find(|l| l.starts_with("model name")).and_then(|l| l.split(':').nth(1)).map(|m| m.trim().to_string()))
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        DeviceInfo {
            kind: "cpu",
            name: model,
            backend: "rayon".into(),
            is_software: false,
            threads: rayon::current_num_threads(),
            shadow_rays: if cfg!(feature = "embree") { "embree" } else { "own" },
        }
    }

    /// The GPU backend on `ctx`'s adapter.
    pub fn gpu(ctx: &GpuContext) -> DeviceInfo {
        let s = &ctx.summary;
        DeviceInfo {
            kind: "gpu",
            name: s.name.clone(),
            backend: s.backend.clone(),
            is_software: s.is_software,
            threads: 0,
            shadow_rays: "gpu",
        }
    }
}

/// The computations of the light matrix (module docs). Indices and weights are validated by
/// `LightMatrix` before a backend sees them; `is` are pixel indices (`y * width + x`).
pub trait Backend: Send + Sync {
    /// Which device this is.
    fn info(&self) -> DeviceInfo;
    /// Columns `js`: `js.len() * H * W * 3` floats, column-major by light, then pixels (row 0 at the
    /// top), then RGB; a pixel's delta-chain samples summed into it.
    fn columns(&self, js: &[usize]) -> Result<Vec<f32>>;
    /// `sum_k weights[k] * A(:, js[k])`, H * W * 3 floats; `progress(done, js.len())` as it goes.
    fn weighted_sum(&self, js: &[usize], weights: &[[f32; 3]], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>>;
    /// Rows `is`: `is.len() * n * 3` floats (`[row][light][rgb]`) and per-stage timings;
    /// `progress(done, is.len())` as it goes. `opts` are the GPU's cube maps (the CPU ignores them).
    fn rows(&self, is: &[usize], opts: &RowOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<TimedRows>;
    /// The ray tracer of the exact oracle (`element`, `row_exact`, `column_exact`).
    fn tracer(&self) -> Result<Arc<RayTracer>>;
    /// Shadow tests and rays since creation or the last reset.
    fn visibility_stats(&self) -> Result<VisibilityStats>;
    /// Sets the counters to 0.
    fn reset_visibility_stats(&self);
    /// The GPU backend itself, for passes that keep their data on the GPU (None on the CPU).
    fn as_gpu(&self) -> Option<&super::gpu::GpuBackend> {
        None
    }
    /// Clustered visibility (`crate::cluster::visibility`): the representatives' visibility matrix and
    /// the image shaded with it (emitters seen directly not included).
    fn clustered_shading(&self, job: &crate::cluster::visibility::ClusteredShading) -> Result<crate::cluster::visibility::ClusteredImage>;
}

/// The device asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Device {
    /// A hardware GPU if there is one, else the CPU backend (`MANYLIGHTS_DEVICE` replaces it).
    #[default]
    Auto,
    /// The wgpu backend on the adapter `GpuContext` picks (software if that is all there is).
    Gpu,
    /// The CPU backend.
    Cpu,
}

/// A device resolved to something that runs.
#[derive(Clone)]
pub enum Chosen {
    Gpu(Arc<GpuContext>),
    Cpu,
}

impl Chosen {
    pub fn is_cpu(&self) -> bool {
        matches!(self, Chosen::Cpu)
    }

    /// The visibility a `LightMatrix` gets when none is asked for: exact rays on the CPU and on a hardware
    /// GPU, hybrid shadow maps on a software adapter. Measured (`bench backends`, 256 wide, 1k-4k lights): on
    /// an NVIDIA H200 exact GPU rays beat hybrid maps on every operation (weighted column sums 3.2x on cbox
    /// and 16x on veach-ajar, rows 15x and 9x) and MRCS 300/900 at the paper's size took 8.2 s against
    /// 21.5 s; on lavapipe hybrid rows are 1.3x faster than exact ones.
    pub fn default_visibility(&self) -> crate::matrix::Visibility {
        match self {
            Chosen::Gpu(ctx) if ctx.summary.is_software => crate::matrix::Visibility::Hybrid,
            _ => crate::matrix::Visibility::RayTraced,
        }
    }
}

impl Device {
    /// "auto", "gpu" or "cpu" (case and surrounding spaces ignored).
    ///
    /// Errors: `InvalidParameter` naming the value and the choices.
    pub fn parse(name: &str) -> Result<Device> {
        match name.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Device::Auto),
            "gpu" => Ok(Device::Gpu),
            "cpu" => Ok(Device::Cpu),
            _ => Err(Error::invalid(format!("device must be 'auto', 'gpu' or 'cpu', got {name:?}"))),
        }
    }

    /// `self`, with `Auto` replaced by `MANYLIGHTS_DEVICE` when that is set (and not empty).
    ///
    /// Errors: an invalid `MANYLIGHTS_DEVICE`, named as such.
    pub fn with_env(self) -> Result<Device> {
        if self != Device::Auto {
            return Ok(self);
        }
        match std::env::var(DEVICE_ENV) {
            Ok(v) if !v.trim().is_empty() => {
                Device::parse(&v).map_err(|_| Error::invalid(format!("{DEVICE_ENV} must be 'auto', 'gpu' or 'cpu', got {v:?}")))
            }
            _ => Ok(Device::Auto),
        }
    }

    /// The device that runs (module docs).
    ///
    /// Errors: `GpuUnavailable` for `Gpu` without any adapter or with one that cannot run every pass;
    /// an invalid `MANYLIGHTS_DEVICE`.
    pub fn choose(self) -> Result<Chosen> {
        self.choose_explained().map(|(c, _)| c)
    }

    /// `choose`, with why `"auto"` took the CPU (None when it took the GPU or another device was asked).
    pub fn choose_explained(self) -> Result<(Chosen, Option<String>)> {
        match self.with_env()? {
            Device::Cpu => Ok((Chosen::Cpu, None)),
            Device::Gpu => {
                let ctx = GpuContext::shared()?;
                ctx.check_needs()?;
                Ok((Chosen::Gpu(ctx), None))
            }
            Device::Auto => match GpuContext::shared() {
                Ok(ctx) if !ctx.unmet.is_empty() => {
                    let e = ctx.check_needs().expect_err("unmet needs");
                    if adapter_requested() {
                        return Err(e);
                    }
                    Ok((Chosen::Cpu, Some(e.to_string())))
                }
                // A hardware GPU, or the adapter `MANYLIGHTS_ADAPTER` asked for even if it is software.
                Ok(ctx) if !ctx.summary.is_software || adapter_requested() => Ok((Chosen::Gpu(ctx), None)),
                Ok(ctx) => Ok((
                    Chosen::Cpu,
                    Some(format!(
                        "only software GPU adapters exist ({}); exact CPU rays are faster than an emulated GPU \
                         (device=\"gpu\" or MANYLIGHTS_ADAPTER=software uses it anyway)",
                        ctx.summary.adapters
                    )),
                )),
                // An adapter the user named that does not exist is an error, not a reason to fall back.
                Err(e) if adapter_requested() => Err(e),
                Err(e) => Ok((Chosen::Cpu, Some(format!("no usable GPU adapter: {e}")))),
            },
        }
    }
}

/// Why the GPU backend cannot compute `scene`'s light matrix, or None when it can: a mask BSDF around a
/// BSDF whose sampling density the GPU's masked shading lacks (`crate::gpu::mask::unsupported`; masked
/// surfaces themselves are implemented on both backends, `crate::raytrace::mask`).
pub fn gpu_unsupported(scene: &crate::scene::Scene) -> Option<String> {
    crate::gpu::mask::unsupported(scene)
}

impl Device {
    /// `choose_explained` for `scene`: "auto" takes the CPU, saying why, for a scene the GPU backend
    /// does not support (`gpu_unsupported`).
    ///
    /// Errors: `InvalidParameter` when "gpu" (also through `MANYLIGHTS_DEVICE`) is asked for such a
    /// scene; else those of `choose_explained`.
    pub fn choose_for_scene(self, scene: &crate::scene::Scene) -> Result<(Chosen, Option<String>)> {
        if let Some(why) = gpu_unsupported(scene) {
            match self.with_env()? {
                Device::Auto => return Ok((Chosen::Cpu, Some(why))),
                Device::Gpu => return Err(Error::invalid(format!("device \"gpu\": {why}; use device=\"cpu\" or \"auto\""))),
                Device::Cpu => {}
            }
        }
        self.choose_explained()
    }
}

/// Whether `MANYLIGHTS_ADAPTER` asks for a particular adapter (anything but empty / "auto").
fn adapter_requested() -> bool {
    std::env::var("MANYLIGHTS_ADAPTER").is_ok_and(|v| !v.trim().is_empty() && !v.trim().eq_ignore_ascii_case("auto"))
}

#[cfg(test)]
mod tests;
