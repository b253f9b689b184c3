//! `scene_lights` and `LightMatrix` (the `LightSet` class is in `lightset.rs`, re-exported here).
pub use super::lightset::LightSet;
use super::scene::Scene;
use super::signals::{self, progress_callback};
use super::util::array;
use crate::error::Error;
use crate::lights;
use crate::matrix::backend::Device;
use crate::matrix::{ColumnOptions, LightMatrix as CoreMatrix, Visibility};
use numpy::{PyArrayDyn, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::Arc;

/// The scene's point, spot and directional emitters.
#[pyfunction]
pub fn scene_lights(scene: &Scene) -> PyResult<LightSet> {
    Ok(LightSet::new(lights::LightSet::from_scene(&scene.inner)?))
}

/// The light matrix of a scene and a light set (GPU columns; see `manylights.LightMatrix`).
#[pyclass(module = "manylights._native", frozen)]
pub struct LightMatrix {
    pub(crate) inner: Arc<CoreMatrix>,
}

#[pymethods]
impl LightMatrix {
    #[new]
    #[pyo3(signature = (scene, lights, shadow_map_size=1024, normal_offset=None, depth_bias=None, slope_bias=None, visibility=None, max_depth=-1, device="auto", glossy_roughness=crate::matrix::glossy::DEFAULT_ROUGHNESS, bsdf_samples=crate::matrix::glossy::DEFAULT_BSDF_SAMPLES, glossy_seed=0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Scene,
        lights: &LightSet,
        shadow_map_size: u32,
        normal_offset: Option<f32>,
        depth_bias: Option<f32>,
        slope_bias: Option<f32>,
        visibility: Option<&str>,
        max_depth: i64,
        device: &str,
        glossy_roughness: f32,
        bsdf_samples: u32,
        glossy_seed: u64,
    ) -> PyResult<Self> {
        let glossy = crate::matrix::glossy::GlossyOptions { roughness: glossy_roughness, bsdf_samples, seed: glossy_seed };
        glossy.check()?;
        if !(16..=8192).contains(&shadow_map_size) {
            return Err(Error::invalid(format!("shadow_map_size must be in 16..=8192, got {shadow_map_size}")).into());
        }
        let chains = crate::view::chains::ChainOptions::with_max_depth(max_depth)?;
        let visibility = visibility.map(Visibility::parse).transpose()?;
        let mut device = Device::parse(device)?.with_env()?;
        if device == Device::Auto && visibility.is_some_and(|v| v != Visibility::RayTraced) {
            // Shadow maps were asked for: only the GPU renders them.
            device = Device::Gpu;
        }
        let s = scene.inner.clone();
        let (chosen, _) = py.detach(move || device.choose_for_scene(&s))?;
        let visibility = visibility.unwrap_or_else(|| chosen.default_visibility());
        let mut view = scene.view_samples_on(py, chains, &chosen)?;
        if glossy.roughness > 0.0
            && (0..view.len()).any(|i| crate::matrix::glossy::glossy_alpha(&view.bsdf, i).is_some_and(|a| a < glossy.roughness))
        {
            let mut v = (*view).clone();
            v.set_glossy(&glossy)?;
            view = Arc::new(v);
        }
        let tracer = if chosen.is_cpu() { Some(scene.tracer(py)?) } else { None };
        let (s, l) = (scene.inner.clone(), lights.inner.clone());
        let mut opts = ColumnOptions { visibility, shadow_resolution: shadow_map_size, ..Default::default() };
        for (name, v, slot) in [
            ("normal_offset", normal_offset, &mut opts.normal_offset),
            ("depth_bias", depth_bias, &mut opts.depth_bias),
            ("slope_bias", slope_bias, &mut opts.slope_bias),
        ] {
            if let Some(v) = v {
                if !v.is_finite() || v < 0.0 {
                    return Err(Error::invalid(format!("{name} must be finite and >= 0 (shadow-map texels), got {v}")).into());
                }
                *slot = v;
            }
        }
        let m = signals::detach(py, move || CoreMatrix::with_device(&chosen, s, view, l, opts, tracer))?;
        Ok(LightMatrix { inner: Arc::new(m) })
    }
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.inner.shape()
    }
    /// The device computing this matrix: dict with kind ("cpu" / "gpu"), name, backend, is_software, threads.
    #[getter]
    fn device<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        super::scene::device_dict(py, &self.inner.device())
    }
    /// Glossy MIS work (src/matrix/glossy.rs): the number of view samples that get BSDF samples (their
    /// lobe's alpha is below `glossy_roughness`) and the BSDF samples they take in all; (0, 0) when none
    /// does (e.g. a diffuse-only scene: pure many-light columns).
    #[getter]
    fn glossy_work(&self) -> (usize, u64) {
        self.inner.view.glossy_work()
    }
    /// The visibility in use: "hybrid", "ray_traced" or "shadow_map".
    #[getter]
    fn visibility(&self) -> &'static str {
        match self.inner.opts.visibility {
            Visibility::Hybrid => "hybrid",
            Visibility::RayTraced => "ray_traced",
            Visibility::ShadowMap => "shadow_map",
        }
    }
    /// Visibility counters since creation or `reset_visibility_stats()`: dict with shadow_tests,
    /// ray_casts, gave_up (ints).
    fn visibility_stats(&self, py: Python<'_>) -> PyResult<std::collections::HashMap<&'static str, u64>> {
        let m = self.inner.clone();
        let s = py.detach(move || m.visibility_stats())?;
        Ok([("shadow_tests", s.shadow_tests), ("ray_casts", s.ray_casts), ("gave_up", s.gave_up)].into_iter().collect())
    }
    /// Sets the visibility counters to 0.
    fn reset_visibility_stats(&self) {
        self.inner.reset_visibility_stats()
    }
    /// The view samples of the matrix (the shading points, pixels first, then the delta-chain samples):
    /// dict of position (m, 3) float32 (world units), normal (m, 3) float32 (unit shading normal), pixel
    /// (m,) int64 (the pixel each sample belongs to, row-major) and surface (m,) bool (false for
    /// background pixels, whose position and normal are 0).
    fn view_samples<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let v = &self.inner.view;
        let m = v.len();
        let flat = |a: &[glam::Vec3]| -> Vec<f32> { a.iter().flat_map(|x| [x.x, x.y, x.z]).collect() };
        let pixel: Vec<i64> = (0..m).map(|i| v.pixel_of(i) as i64).collect();
        let surface: Vec<bool> = v.shape_index.iter().map(|&s| s >= 0).collect();
        let d = pyo3::types::PyDict::new(py);
        d.set_item("position", array(py, flat(&v.position), &[m, 3])?)?;
        d.set_item("normal", array(py, flat(&v.normal), &[m, 3])?)?;
        d.set_item("pixel", array(py, pixel, &[m])?)?;
        d.set_item("surface", numpy::PyArray1::from_vec(py, surface))?;
        Ok(d)
    }
    /// Columns `indices` as a (k, H, W, 3) float32 array.
    fn columns<'py>(&self, py: Python<'py>, indices: Vec<usize>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let k = indices.len();
        let data = signals::detach(py, move || m.columns(&indices))?;
        let (h, w) = self.inner.image_size();
        array(py, data, &[k, h, w, 3])
    }
    /// Weighted sum of all columns, (H, W, 3) float32; `progress(done, total)` is called per batch.
    #[pyo3(signature = (weights=None, progress=None))]
    fn column_sum<'py>(
        &self,
        py: Python<'py>,
        weights: Option<PyReadonlyArray1<'py, f32>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let w: Option<Vec<f32>> = weights.map(|w| w.as_array().to_vec());
        let m = self.inner.clone();
        let data = signals::detach(py, move || {
            let mut cb = progress_callback(progress);
            m.column_sum(w.as_deref(), &mut cb)
        })?;
        let (h, w) = self.inner.image_size();
        array(py, data, &[h, w, 3])
    }
    /// `sum_k weights[k] * column[indices[k]]` with (k, 3) RGB weights, rendering only those columns
    /// (repeated indices add up); (H, W, 3) float32.
    #[pyo3(signature = (indices, weights, progress=None))]
    fn weighted_sum<'py>(
        &self,
        py: Python<'py>,
        indices: Vec<usize>,
        weights: PyReadonlyArray2<'py, f32>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let shape = weights.shape().to_vec();
        if shape.len() != 2 || shape[1] != 3 || shape[0] != indices.len() {
            return Err(Error::invalid(format!(
                "weights must have shape ({}, 3) for {} indices, got {shape:?}",
                indices.len(),
                indices.len()
            ))
            .into());
        }
        let w: Vec<[f32; 3]> = weights.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
        let m = self.inner.clone();
        let data = signals::detach(py, move || {
            let mut cb = progress_callback(progress);
            m.weighted_sum(&indices, &w, &mut cb)
        })?;
        let (h, w) = self.inner.image_size();
        array(py, data, &[h, w, 3])
    }
    /// What the camera sees directly (area emitters from their front side, the environment behind
    /// background pixels), (H, W, 3) float32; not part of any column.
    fn emitted<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let data = signals::detach(py, move || m.emitted())?;
        let (h, w) = self.inner.image_size();
        array(py, data, &[h, w, 3])
    }
    /// Kollig-Keller compensation of the VPL clamp (`matrix::bias_compensation`), (H, W, 3) float32.
    /// `max_depth` < 0 = unlimited; `light_samples` = 0 traces every light at each path vertex;
    /// `pixels`: flat pixel indices to estimate (the rest 0), None = all.
    #[pyo3(signature = (max_depth=-1, spp=1, light_samples=64, seed=0, pixels=None))]
    fn bias_compensation<'py>(
        &self,
        py: Python<'py>,
        max_depth: i64,
        spp: u32,
        light_samples: usize,
        seed: u64,
        pixels: Option<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let opts = crate::matrix::bias_compensation::BiasCompensationOptions {
            max_depth: if max_depth < 0 { u32::MAX } else { u32::try_from(max_depth).unwrap_or(u32::MAX) },
            spp,
            light_samples,
            seed,
        };
        let data = signals::detach(py, move || m.bias_compensation(&opts, pixels.as_deref()))?;
        let (h, w) = self.inner.image_size();
        array(py, data, &[h, w, 3])
    }
    /// Rows `indices` (view sample indices) as an (r, n, 3) float32 array and the per-stage timings
    /// (dict of seconds: shadow_maps, evaluation, readback; batches). `progress(done, total)` is called
    /// per row batch; `shadow_map_size` = texels per cube face.
    #[pyo3(signature = (indices, progress=None, shadow_map_size=256))]
    fn rows<'py>(
        &self,
        py: Python<'py>,
        indices: Vec<usize>,
        progress: Option<Py<PyAny>>,
        shadow_map_size: u32,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, std::collections::HashMap<&'static str, f64>)> {
        let m = self.inner.clone();
        let r = indices.len();
        let opts = crate::matrix::rows::RowOptions { resolution: shadow_map_size, ..Default::default() };
        let (data, t) = signals::detach(py, move || {
            let mut cb = progress_callback(progress);
            m.rows_timed(&indices, &opts, &mut cb)
        })?;
        let n = self.inner.shape().1;
        let timings = [
            ("shadow_maps", t.shadow_maps),
            ("evaluation", t.evaluation),
            ("readback", t.readback),
            ("setup", t.setup),
            ("batches", t.batches as f64),
        ]
        .into_iter()
        .collect();
        Ok((array(py, data, &[r, n, 3])?, timings))
    }
    /// A(i, j) by exact CPU ray casting, (3,) float32. ValueError for an index out of range.
    fn element<'py>(&self, py: Python<'py>, i: usize, j: usize) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let v = signals::detach(py, move || m.element(i, j))?;
        array(py, v.to_vec(), &[3])
    }
    /// Row i by exact CPU ray casting, (n, 3) float32. ValueError for i out of range.
    fn row_exact<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let row = signals::detach(py, move || m.row_exact(i))?;
        let n = row.len();
        array(py, row.into_iter().flatten().collect(), &[n, 3])
    }
    /// Column j by exact CPU ray casting, (H, W, 3) float32. ValueError for j out of range.
    fn column_exact<'py>(&self, py: Python<'py>, j: usize) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let m = self.inner.clone();
        let col = signals::detach(py, move || m.column_exact(j))?;
        let (h, w) = self.inner.image_size();
        array(py, col.into_iter().flatten().collect(), &[h, w, 3])
    }
    /// The exact shadow rays of the elements of pixels `view_indices` x `light_indices` (each pixel's view
    /// samples, its delta-chain samples included; `crate::cpu::shadow_rays`),
    /// light by light (`order="columns"`) or view sample by view sample (`"rows"`); elements whose
    /// unshadowed value is 0 cast none and are left out, unless `every_element` (then every element of a
    /// surface view sample has its ray toward the light, lit or not). Dict: origin, direction (r, 3) float32 (world units,
    /// unit directions), t_max (r,) float32 (inf toward directional lights), view, pixel, light (r,) int64,
    /// elements (int), seconds (float: the set-up, unshadowed shading included). ValueError for an index out
    /// of range, an unknown order, more than 2^31 elements.
    #[pyo3(signature = (view_indices, light_indices, order="columns", every_element=false))]
    fn shadow_rays<'py>(
        &self,
        py: Python<'py>,
        view_indices: Vec<usize>,
        light_indices: Vec<usize>,
        order: &str,
        every_element: bool,
    ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        use crate::cpu::shadow_rays::{shadow_rays, Order};
        let order = match order {
            "columns" => Order::Columns,
            "rows" => Order::Rows,
            o => return Err(Error::invalid(format!("order must be 'columns' or 'rows', got {o:?}")).into()),
        };
        let m = self.inner.clone();
        let r = signals::detach(py, move || shadow_rays(&m.view, &m.lights, &view_indices, &light_indices, order, every_element))?;
        let k = r.view.len();
        let flat = |a: &[glam::Vec3]| -> Vec<f32> { a.iter().flat_map(|x| [x.x, x.y, x.z]).collect() };
        let d = pyo3::types::PyDict::new(py);
        d.set_item("origin", array(py, flat(&r.origin), &[k, 3])?)?;
        d.set_item("direction", array(py, flat(&r.direction), &[k, 3])?)?;
        d.set_item("t_max", array(py, r.t_max, &[k])?)?;
        d.set_item("view", array(py, r.view.iter().map(|&v| v as i64).collect(), &[k])?)?;
        d.set_item("pixel", array(py, r.pixel.iter().map(|&v| v as i64).collect(), &[k])?)?;
        d.set_item("light", array(py, r.light.iter().map(|&v| v as i64).collect(), &[k])?)?;
        d.set_item("elements", r.elements)?;
        d.set_item("seconds", r.seconds)?;
        Ok(d)
    }
    /// Whether each ray is blocked, traced by this matrix's CPU ray tracer alone (the backend's BVH
    /// traversal and triangle tests, in parallel): (blocked (r,) bool, seconds of the tracing).
    /// origin, direction (r, 3) float32, t_max (r,) float32. ValueError for arrays of other shapes.
    fn trace_shadow_rays<'py>(
        &self,
        py: Python<'py>,
        origin: PyReadonlyArray2<'py, f32>,
        direction: PyReadonlyArray2<'py, f32>,
        t_max: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<(Bound<'py, numpy::PyArray1<bool>>, f64)> {
        let vecs = |a: &PyReadonlyArray2<'py, f32>, what: &str| -> PyResult<Vec<glam::Vec3>> {
            if a.shape().len() != 2 || a.shape()[1] != 3 {
                return Err(Error::invalid(format!("{what} must have shape (r, 3), got {:?}", a.shape())).into());
            }
            Ok(a.as_array().rows().into_iter().map(|r| glam::Vec3::new(r[0], r[1], r[2])).collect())
        };
        let (o, d, t) = (vecs(&origin, "origin")?, vecs(&direction, "direction")?, t_max.as_array().to_vec());
        let m = self.inner.clone();
        let (blocked, seconds) = signals::detach(py, move || {
            let tracer = m.tracer()?;
            crate::cpu::shadow_rays::trace(&tracer, &o, &d, &t)
        })?;
        Ok((numpy::PyArray1::from_vec(py, blocked), seconds))
    }
}

/// One view sample index (`y * width + x`) per block of an r-block stratification of a width x height
/// image, drawn uniformly in each block (seeded); (r,) int64. Raises ValueError for r = 0 or r > width * height.
#[pyfunction]
#[pyo3(signature = (width, height, r, seed=0))]
pub fn stratified_rows<'py>(py: Python<'py>, width: u32, height: u32, r: usize, seed: u64) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let rows: Vec<i64> = crate::matrix::rows::stratified_rows(width, height, r, seed)?.into_iter().map(|i| i as i64).collect();
    array(py, rows, &[r])
}

/// Tensor clustering's reconstruction (`crate::matrix::reconstruction`): adds a batch of representative
/// columns (c, H, W, 3), rendered in frames `source` (c,), scaled by `rec` (c, f, 3) and carried through the
/// pixel mappings `forward` / `backward` (f - 1, H * W) uint32, into `acc` (f, H, W, 3) in place.
#[pyfunction]
pub fn tensor_accumulate(
    py: Python<'_>,
    mut acc: numpy::PyReadwriteArrayDyn<'_, f32>,
    columns: numpy::PyReadonlyArrayDyn<'_, f32>,
    source: PyReadonlyArray1<'_, u32>,
    rec: numpy::PyReadonlyArrayDyn<'_, f32>,
    forward: PyReadonlyArray2<'_, u32>,
    backward: PyReadonlyArray2<'_, u32>,
) -> PyResult<()> {
    let shape = acc.shape().to_vec();
    if shape.len() != 4 || shape[3] != 3 {
        return Err(Error::invalid(format!("acc must have shape (f, H, W, 3), got {shape:?}")).into());
    }
    let (f, m) = (shape[0], shape[1] * shape[2]);
    let contiguous = |what: &str| Error::invalid(format!("{what} must be C-contiguous"));
    let cols = columns.as_slice().map_err(|_| contiguous("columns"))?;
    let src = source.as_slice().map_err(|_| contiguous("source"))?;
    let rc = rec.as_slice().map_err(|_| contiguous("rec"))?;
    let fw = forward.as_array();
    let bw = backward.as_array();
    let rows = |a: &numpy::ndarray::ArrayView2<'_, u32>| -> Vec<Vec<u32>> { a.outer_iter().map(|r| r.to_vec()).collect() };
    let (fw, bw) = (rows(&fw), rows(&bw));
    let out = acc.as_slice_mut().map_err(|_| contiguous("acc"))?;
    let fr: Vec<&[u32]> = fw.iter().map(|v| v.as_slice()).collect();
    let br: Vec<&[u32]> = bw.iter().map(|v| v.as_slice()).collect();
    py.detach(|| crate::matrix::reconstruction::accumulate(out, f, m, &cols, &src, &rc, &fr, &br))?;
    Ok(())
}

/// Tensor clustering's reconstruction on the GPU (`crate::gpu::reconstruction`): renders each
/// representative `representatives[c] = (light, frame)` in its frame's light matrix (`frames`, all on one
/// GPU), scales it by `rec` (c, f, 3), carries it through the pixel mappings `forward` / `backward`
/// (f - 1, H * W) uint32 and accumulates every frame on the GPU, read back once. Returns ((f, H, W, 3)
/// float32, seconds of the columns, seconds of the reconstruction).
#[pyfunction]
pub fn tensor_reconstruct_gpu<'py>(
    py: Python<'py>,
    frames: Vec<PyRef<'py, LightMatrix>>,
    representatives: PyReadonlyArray2<'py, u32>,
    rec: numpy::PyReadonlyArrayDyn<'py, f32>,
    forward: PyReadonlyArray2<'py, u32>,
    backward: PyReadonlyArray2<'py, u32>,
) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, f64, f64)> {
    let reps = representatives.as_array();
    if reps.ncols() != 2 {
        return Err(Error::invalid(format!("representatives must have shape (c, 2), got {:?}", reps.shape())).into());
    }
    let reps: Vec<(u32, u32)> = reps.outer_iter().map(|r| (r[0], r[1])).collect();
    let rc = rec.as_slice().map_err(|_| Error::invalid("rec must be C-contiguous"))?.to_vec();
    let rows = |a: numpy::ndarray::ArrayView2<'_, u32>| -> Vec<Vec<u32>> { a.outer_iter().map(|r| r.to_vec()).collect() };
    let (fw, bw) = (rows(forward.as_array()), rows(backward.as_array()));
    let mats: Vec<Arc<CoreMatrix>> = frames.iter().map(|m| m.inner.clone()).collect();
    let f = mats.len();
    let (h, w) = mats.first().map(|m| m.image_size()).ok_or_else(|| Error::invalid("no frames to reconstruct"))?;
    let out = signals::detach(py, move || {
        let refs: Vec<&CoreMatrix> = mats.iter().map(|m| m.as_ref()).collect();
        let fr: Vec<&[u32]> = fw.iter().map(|v| v.as_slice()).collect();
        let br: Vec<&[u32]> = bw.iter().map(|v| v.as_slice()).collect();
        crate::gpu::reconstruction::reconstruct(&refs, &reps, &rc, &fr, &br)
    })?;
    Ok((array(py, out.frames, &[f, h, w, 3])?, out.columns_seconds, out.reconstruction_seconds))
}

/// Raises MemoryError (naming `what`) when `bytes` of host memory would break the policy
/// (`crate::memory::check_host`: available memory, `MANYLIGHTS_MEMORY_LIMIT`).
#[pyfunction]
pub fn check_host_memory(what: &str, bytes: u128) -> PyResult<()> {
    Ok(crate::memory::check_host(what, bytes)?)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(check_host_memory, m)?)?;
    m.add_function(wrap_pyfunction!(tensor_accumulate, m)?)?;
    m.add_function(wrap_pyfunction!(tensor_reconstruct_gpu, m)?)?;
    m.add_function(wrap_pyfunction!(stratified_rows, m)?)?;
    m.add_class::<LightSet>()?;
    m.add_class::<LightMatrix>()?;
    m.add_function(wrap_pyfunction!(scene_lights, m)?)?;
    Ok(())
}
