//! `DirectToIndirect`: the precomputed final-gather transfer and relighting on the CPU or the GPU
//! (`relight::transfer`, `relight::relight`, `relight::gpu`); the Python class
//! `manylights.DirectToIndirect` wraps it.
use super::lightset::LightSet;
use super::scene::Scene;
use super::signals;
use super::util::{array, vec3_array};
use crate::error::Error;
use crate::matrix::backend::{Chosen, Device, DeviceInfo};
use crate::matrix::{ColumnOptions, Visibility};
use crate::raytrace::RayTracer;
use crate::relight::gpu::{choose_device, GpuRelight};
use crate::relight::masks::chain_options;
use crate::relight::relight::{self as core, RelightStats};
use crate::relight::transfer::{NearField, Transfer, TransferOptions};
use crate::view::ViewSamples;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, Mutex};

/// Precomputed direct-to-indirect transfer of one scene and camera (see `manylights.DirectToIndirect`).
#[pyclass(module = "manylights._native", frozen)]
pub struct DirectToIndirect {
    inner: Arc<Transfer>,
    scene: Arc<crate::scene::Scene>,
    view: Arc<ViewSamples>,
    tracer: Arc<RayTracer>,
    last: Mutex<Option<RelightStats>>,
    /// Relighting on the GPU (`relight::gpu`) when the device chosen is one; None = the CPU.
    gpu: Option<Arc<GpuRelight>>,
}

impl DirectToIndirect {
    /// The precomputed transfer (for `transfer_store`).
    pub(crate) fn transfer(&self) -> &Arc<Transfer> {
        &self.inner
    }

    /// Wraps a transfer rebuilt for `scene` (`transfer_store`): the view samples, BVH and relighting
    /// device are made as `new` makes them.
    pub(crate) fn from_transfer(
        py: Python<'_>,
        scene: &Scene,
        inner: Transfer,
        device: &str,
        visibility: Option<&str>,
        shadow_map_size: u32,
    ) -> PyResult<Self> {
        let (chosen, columns) = relight_device(py, device, visibility, shadow_map_size)?;
        let view = scene.view_samples_on(py, chain_options(&scene.inner, inner.opts.bounces)?, &Chosen::Cpu)?;
        let tracer = scene.tracer(py)?;
        let rows = crate::relight::masks::row_samples(&view, tracer.masks().any());
        if rows != inner.rows.len() {
            return Err(Error::invalid(format!(
                "{}: the saved transfer has {} final-gather rows but this scene's view has {rows} samples that take one: \
                 the scene changed after the precomputation; precompute again",
                scene.inner.path.display(),
                inner.rows.len()
            ))
            .into());
        }
        Self::wrap(py, scene, inner, view, tracer, chosen, columns)
    }

    fn wrap(
        py: Python<'_>,
        scene: &Scene,
        inner: Transfer,
        view: Arc<ViewSamples>,
        tracer: Arc<RayTracer>,
        chosen: Chosen,
        columns: ColumnOptions,
    ) -> PyResult<Self> {
        let gpu = match chosen {
            Chosen::Gpu(ctx) => {
                let (s, v, t) = (scene.inner.clone(), view.clone(), &inner);
                Some(Arc::new(signals::detach(py, move || GpuRelight::new(ctx, s, v, t, columns))?))
            }
            Chosen::Cpu => None,
        };
        Ok(DirectToIndirect { inner: Arc::new(inner), scene: scene.inner.clone(), view, tracer, last: Mutex::new(None), gpu })
    }
}

#[pymethods]
impl DirectToIndirect {
    #[new]
    #[pyo3(signature = (scene, gather, coefficients, seed, threshold, clamp, k_weight, bounces=1, multibounce_coefficients=40, progress=None, multibounce="photons", photons_per_sample=crate::relight::multibounce::DEFAULT_PHOTONS_PER_SAMPLE, photon_neighbours=crate::relight::multibounce::DEFAULT_PHOTON_NEIGHBOURS, glossy=true, near_field="disc", device="auto", visibility=None, shadow_map_size=1024))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Scene,
        gather: usize,
        coefficients: usize,
        seed: u64,
        threshold: f32,
        clamp: f32,
        k_weight: f32,
        bounces: u32,
        multibounce_coefficients: usize,
        progress: Option<Py<PyAny>>,
        multibounce: &str,
        photons_per_sample: usize,
        photon_neighbours: usize,
        glossy: bool,
        near_field: &str,
        device: &str,
        visibility: Option<&str>,
        shadow_map_size: u32,
    ) -> PyResult<Self> {
        let near_field = NearField::parse(near_field)?;
        let multibounce = crate::relight::Multibounce::parse(multibounce)?;
        let opts = TransferOptions {
            gather,
            coefficients,
            seed,
            k_weight,
            threshold,
            clamp,
            bounces,
            multibounce_coefficients,
            multibounce,
            photons_per_sample,
            photon_neighbours,
            glossy,
            near_field,
        };
        crate::relight::multibounce::check_options(&opts)?;
        // Check the cheap arguments before the G-buffer and BVH are built.
        crate::lights::gather::gather_levels(gather)?;
        if !(1..=gather).contains(&coefficients) {
            return Err(Error::invalid(format!("final_gather_coefficients must be in 1 ..= gather ({gather}), got {coefficients}")).into());
        }
        let (chosen, columns) = relight_device(py, device, visibility, shadow_map_size)?;
        let view = scene.view_samples_on(py, chain_options(&scene.inner, bounces)?, &Chosen::Cpu)?;
        let tracer = scene.tracer(py)?;
        let s = scene.inner.clone();
        let (v, t) = (view.clone(), tracer.clone());
        let inner = signals::detach(py, move || {
            let mut cb = signals::progress_callback(progress);
            Transfer::new(&s, &v, &t, &opts, &mut cb)
        })?;
        Self::wrap(py, scene, inner, view, tracer, chosen, columns)
    }

    /// (H, W, 3) float32 relit image (direct + one diffuse bounce).
    fn relight<'py>(&self, py: Python<'py>, lights: &LightSet, epsilon: f32) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let (t, s, v, tr, l) = (self.inner.clone(), self.scene.clone(), self.view.clone(), self.tracer.clone(), lights.inner.clone());
        let (img, stats) = match self.gpu.clone() {
            Some(g) => signals::detach(py, move || g.relight(l, epsilon))?,
            None => signals::detach(py, move || core::relight(&t, s, v, tr, l, epsilon))?,
        };
        *self.last.lock().unwrap_or_else(|e| e.into_inner()) = Some(stats);
        array(py, img, &[self.inner.height as usize, self.inner.width as usize, 3])
    }

    /// (n_g, 3) float32 direct irradiance E_g (W/m^2) at the gather samples from `lights`.
    fn gather_irradiance<'py>(&self, py: Python<'py>, lights: &LightSet) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        core::check_lights(&lights.inner)?;
        let (t, tr, l) = (self.inner.clone(), self.tracer.clone(), lights.inner.clone());
        let e = signals::detach(py, move || core::gather_irradiance(&t, &tr, &l))?;
        vec3_array(py, &e)
    }

    /// (n_g, 3) float32: where each gather sample emits from (its VPL position).
    #[getter]
    fn gather_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.emit_position)
    }
    /// (n_g, 3) float32 emitting shading normals.
    #[getter]
    fn gather_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.emit_normal)
    }
    /// (n_g, 3) float32 geometric normals.
    #[getter]
    fn gather_geo_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.cloud.geo_normal)
    }
    /// (n_g,) float32 areas (m^2).
    #[getter]
    fn gather_areas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        array(py, self.inner.cloud.area.clone(), &[self.inner.cloud.len()])
    }
    /// (n_g, 3) float32 diffuse coefficients.
    #[getter]
    fn gather_k_d<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.cloud.k_d)
    }

    /// The device relighting runs on: dict with kind ("cpu" / "gpu"), name, backend, is_software, threads.
    #[getter]
    fn device<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let info = self.gpu.as_ref().map_or_else(DeviceInfo::cpu, |g| g.device());
        super::scene::device_dict(py, &info)
    }

    /// Seconds per stage of the precomputation and of the last relight.
    #[getter]
    fn timings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let t = &self.inner;
        d.set_item("gather_cloud", t.seconds_cloud)?;
        d.set_item("hierarchy", t.seconds_hierarchy)?;
        d.set_item("final_gather", t.seconds_rows)?;
        d.set_item("multibounce", t.seconds_bounce_rows)?;
        d.set_item("glossy_final_gather", t.seconds_glossy_rows)?;
        if let Some(s) = self.last.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            d.set_item("relight_shadow_maps", s.seconds_shadow_maps)?;
            d.set_item("relight_gather_direct", s.seconds_gather_direct)?;
            d.set_item("relight_bounces", s.seconds_bounces)?;
            d.set_item("relight_wavelet", s.seconds_wavelet)?;
            d.set_item("relight_transfer", s.seconds_transfer)?;
            d.set_item("relight_view_direct", s.seconds_view_direct)?;
            d.set_item("relight_readback", s.seconds_readback)?;
        }
        Ok(d)
    }

    /// Sizes: gather samples, pixels, coefficients kept, bytes, shadow rays, links, wavelet lights of the
    /// last relight and how many were culled.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let t = &self.inner;
        d.set_item("gather", t.cloud.len())?;
        d.set_item("pixels", t.rows.len())?;
        d.set_item("coefficients_per_row", t.opts.coefficients)?;
        d.set_item("coefficients_kept", t.coefficients_kept())?;
        d.set_item("bounces", t.opts.bounces)?;
        d.set_item("multibounce_coefficients_per_row", if t.opts.bounces > 1 { t.opts.multibounce_coefficients } else { 0 })?;
        d.set_item("multibounce_coefficients_kept", t.bounce_coefficients_kept() + t.photon_coefficients_kept())?;
        d.set_item("multibounce", if t.opts.bounces > 1 { t.opts.multibounce.name() } else { "none" })?;
        d.set_item("photons", t.photons)?;
        d.set_item("glossy_pixels", t.glossy_pixels)?;
        d.set_item("glossy_coefficients_kept", t.glossy_coefficients_kept())?;
        d.set_item("bytes", t.bytes())?;
        d.set_item("shadow_rays", t.shadow_rays)?;
        d.set_item("links", t.links)?;
        d.set_item("threshold", t.opts.threshold)?;
        d.set_item("near_field", t.opts.near_field.name())?;
        if let Some(s) = self.last.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            d.set_item("wavelet_lights", s.wavelet_lights)?;
            d.set_item("wavelet_lights_culled", s.wavelet_lights_culled)?;
            d.set_item("wavelet_lights_culled_glossy", s.wavelet_lights_culled_glossy)?;
        }
        Ok(d)
    }
}

/// The device relighting runs on and its column options (`relight::gpu::choose_device`).
fn relight_device(py: Python<'_>, device: &str, visibility: Option<&str>, shadow_map_size: u32) -> PyResult<(Chosen, ColumnOptions)> {
    if !(16..=8192).contains(&shadow_map_size) {
        return Err(Error::invalid(format!("shadow_map_size must be in 16..=8192, got {shadow_map_size}")).into());
    }
    let visibility = visibility.map(Visibility::parse).transpose()?;
    let mut device = Device::parse(device)?.with_env()?;
    if device == Device::Auto && visibility.is_some_and(|v| v != Visibility::RayTraced) {
        // Shadow maps were asked for: only the GPU renders them.
        device = Device::Gpu;
    }
    let chosen = py.detach(move || choose_device(device))?;
    if chosen.is_cpu() && visibility.is_some_and(|v| v != Visibility::RayTraced) {
        return Err(Error::invalid(format!(
            "visibility {:?} uses shadow maps, which only the GPU renders; relighting on the CPU casts exact rays \
             (visibility 'ray_traced')",
            visibility.unwrap_or_default()
        ))
        .into());
    }
    let columns = ColumnOptions { visibility: visibility.unwrap_or_default(), shadow_resolution: shadow_map_size, ..Default::default() };
    Ok((chosen, columns))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<DirectToIndirect>()?;
    Ok(())
}
