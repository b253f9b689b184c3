//! `LightTree` and the light-tree samplers (`light_bvh_sampling`, `ris`) over a `LightMatrix`
//! (core: `lights::light_tree`, `baselines`).
use super::matrix::{LightMatrix, LightSet};
use super::signals;
use super::util::array;
use crate::baselines::Estimate;
use crate::error::Error;
use crate::lights::light_tree;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use std::sync::Arc;

/// LightTree(lights): a binary BVH over a LightSet with the bounds of light-BVH importance sampling
/// (Conty Estevez and Kulla 2018; pbrt-v4's LightBounds), built once (binned SAOH, one light per leaf).
///
/// Node arrays (N nodes, depth-first, node 0 the root): ``bounds_min`` / ``bounds_max`` (N, 3) float64
/// (world units; the lights' positions, area-light patches and VSL spheres), ``axis`` (N, 3) float64
/// (unit cone axis w), ``theta_o`` (N,) float64 (radians, bound on the lights' axes around w; pi =
/// omnidirectional), ``theta_e`` (N,) float64 (radians, emission spread beyond theta_o), ``power`` (N,)
/// float64 (phi: summed luminance power, W; spots 4 pi I as pbrt), ``children`` (N, 2) int64 (-1 at
/// leaves), ``leaf_light`` (N,) int64 (the light of a leaf, -1 for inner nodes). ``infinite`` (k,) int64:
/// the directional lights (environment strata included), kept outside the tree and sampled by power.
/// ``pdf(matrix, sample)``: (n,) float64, each light's probability at view sample ``sample`` of
/// ``matrix`` (sums to 1 where any light can reach it, else all 0). Rules: src/lights/light_tree.rs.
///
/// Raises: ValueError for an empty LightSet; ``pdf``: a matrix over other lights, a sample out of range.
#[pyclass(module = "manylights._native", frozen)]
pub struct LightTree {
    pub(crate) inner: Arc<light_tree::LightTree>,
    lights: Arc<crate::lights::LightSet>,
}

type Arr<'py, T> = PyResult<Bound<'py, PyArrayDyn<T>>>;

impl LightTree {
    /// The tree to use with matrix `a`: `tree` when given (it must be over the same LightSet), else a new one.
    fn for_matrix(py: Python<'_>, tree: Option<&LightTree>, a: &LightMatrix) -> PyResult<Arc<light_tree::LightTree>> {
        let lights = a.inner.lights.clone();
        match tree {
            Some(t) if Arc::ptr_eq(&t.lights, &lights) => Ok(t.inner.clone()),
            Some(_) => Err(Error::invalid("the light tree was built over another LightSet than the light matrix's").into()),
            None => Ok(Arc::new(py.detach(move || light_tree::LightTree::build(&lights))?)),
        }
    }
}

#[pymethods]
impl LightTree {
    #[new]
    fn new(py: Python<'_>, lights: &LightSet) -> PyResult<Self> {
        let l = lights.inner.clone();
        let inner = py.detach(move || light_tree::LightTree::build(&l))?;
        Ok(LightTree { inner: Arc::new(inner), lights: lights.inner.clone() })
    }
    fn __len__(&self) -> usize {
        self.inner.nodes.len()
    }
    #[getter]
    fn num_lights(&self) -> usize {
        self.inner.num_lights
    }
    #[getter]
    fn bounds_min<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        let v: Vec<f64> = self.inner.nodes.iter().flat_map(|b| b.lo.to_array()).collect();
        array(py, v, &[self.inner.nodes.len(), 3])
    }
    #[getter]
    fn bounds_max<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        let v: Vec<f64> = self.inner.nodes.iter().flat_map(|b| b.hi.to_array()).collect();
        array(py, v, &[self.inner.nodes.len(), 3])
    }
    #[getter]
    fn axis<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        let v: Vec<f64> = self.inner.nodes.iter().flat_map(|b| b.w.to_array()).collect();
        array(py, v, &[self.inner.nodes.len(), 3])
    }
    #[getter]
    fn theta_o<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        array(py, self.inner.nodes.iter().map(|b| b.theta_o).collect(), &[self.inner.nodes.len()])
    }
    #[getter]
    fn theta_e<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        array(py, self.inner.nodes.iter().map(|b| b.theta_e).collect(), &[self.inner.nodes.len()])
    }
    #[getter]
    fn power<'py>(&self, py: Python<'py>) -> Arr<'py, f64> {
        array(py, self.inner.nodes.iter().map(|b| b.phi).collect(), &[self.inner.nodes.len()])
    }
    #[getter]
    fn children<'py>(&self, py: Python<'py>) -> Arr<'py, i64> {
        let v: Vec<i64> = self.inner.children.iter().flat_map(|c| c.map(|x| if x == u32::MAX { -1 } else { x as i64 })).collect();
        array(py, v, &[self.inner.nodes.len(), 2])
    }
    #[getter]
    fn leaf_light<'py>(&self, py: Python<'py>) -> Arr<'py, i64> {
        let v = self.inner.leaf_light.iter().map(|&x| if x == u32::MAX { -1 } else { x as i64 }).collect();
        array(py, v, &[self.inner.nodes.len()])
    }
    #[getter]
    fn infinite<'py>(&self, py: Python<'py>) -> Arr<'py, i64> {
        array(py, self.inner.infinite.iter().map(|&x| x as i64).collect(), &[self.inner.infinite.len()])
    }
    /// (n,) float64: the probability of each light at view sample `sample` of `matrix`.
    fn pdf<'py>(&self, py: Python<'py>, matrix: &LightMatrix, sample: usize) -> Arr<'py, f64> {
        let a = &matrix.inner;
        if !Arc::ptr_eq(&self.lights, &a.lights) {
            return Err(Error::invalid("the light tree was built over another LightSet than the light matrix's").into());
        }
        let m = a.view.len();
        if sample >= m {
            return Err(Error::invalid(format!("view sample {sample} is out of range for {m} view samples")).into());
        }
        let sp = crate::cpu::ShadingPoint::new(&a.view, sample);
        let n = self.inner.num_lights;
        let v: Vec<f64> = if sp.surface { (0..n).map(|j| self.inner.pdf(sp.p, sp.n, j)).collect() } else { vec![0.0; n] };
        array(py, v, &[n])
    }
}

/// The light tree of `matrix` (`tree`, or built here and timed as `tree_seconds`), then `sampler` on both
/// with the GIL released: the estimate as `estimate_dict` gives it, plus `tree_seconds`.
fn with_tree<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    tree: Option<&LightTree>,
    sampler: impl FnOnce(&crate::matrix::LightMatrix, &light_tree::LightTree) -> crate::error::Result<Estimate> + Send,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let t0 = std::time::Instant::now();
    let t = LightTree::for_matrix(py, tree, matrix)?;
    let tree_seconds = t0.elapsed().as_secs_f64();
    let a = matrix.inner.clone();
    let e = signals::detach(py, move || sampler(&a, &t))?;
    let d = estimate_dict(py, matrix, e)?;
    d.set_item("tree_seconds", tree_seconds)?;
    Ok(d)
}

fn estimate_dict<'py>(py: Python<'py>, a: &LightMatrix, e: Estimate) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let (h, w) = a.inner.image_size();
    let d = pyo3::types::PyDict::new(py);
    d.set_item("image", array(py, e.image, &[h, w, 3])?)?;
    match e.variance {
        Some(v) => d.set_item("variance", array(py, v, &[h, w, 3])?)?,
        None => d.set_item("variance", py.None())?,
    }
    d.set_item("shadow_rays", e.shadow_rays)?;
    d.set_item("seconds", e.seconds)?;
    Ok(d)
}

/// Light-BVH sampling: dict of image (H, W, 3) float32, variance (H, W, 3) float32 or None, shadow_rays,
/// seconds, tree_seconds.
#[pyfunction]
#[pyo3(signature = (matrix, samples, seed, tree=None))]
fn light_bvh_sampling<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    samples: usize,
    seed: u64,
    tree: Option<&LightTree>,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    with_tree(py, matrix, tree, move |a, t| crate::baselines::light_bvh_sampling(a, t, samples, seed))
}

/// RIS over the light tree (`neighbours` > 0: with spatial reuse over that many pixels within `radius`):
/// the same dict as `light_bvh_sampling`.
#[pyfunction]
#[pyo3(signature = (matrix, samples, candidates, seed, tree=None, neighbours=0, radius=3))]
#[allow(clippy::too_many_arguments)]
fn ris<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    samples: usize,
    candidates: usize,
    seed: u64,
    tree: Option<&LightTree>,
    neighbours: usize,
    radius: u32,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    with_tree(py, matrix, tree, move |a, t| {
        if neighbours > 0 {
            crate::baselines::ris_spatial(a, t, samples, candidates, neighbours, radius, seed)
        } else {
            crate::baselines::ris(a, t, samples, candidates, seed)
        }
    })
}

/// Stochastic Lightcuts over the light tree (cut of `cut_size` nodes, `samples` estimates per view
/// sample): the same dict as `light_bvh_sampling`.
#[pyfunction]
#[pyo3(signature = (matrix, cut_size, samples, seed, tree=None))]
fn stochastic_lightcuts<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    cut_size: usize,
    samples: usize,
    seed: u64,
    tree: Option<&LightTree>,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    with_tree(py, matrix, tree, move |a, t| crate::baselines::stochastic_lightcuts(a, t, cut_size, samples, seed))
}

/// LightSlice: dict of image (H, W, 3) float32, slices (H, W) int32 (-1 without a surface), rows (S,)
/// int64, global_assignment (n,) int64, clusters_per_slice (S,) int64, shadow_rays, timings {stage: s}.
#[pyfunction]
#[pyo3(signature = (matrix, slices, columns, global_columns, neighbours, normal_weight, seed))]
#[allow(clippy::too_many_arguments)]
fn lightslice<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    slices: usize,
    columns: usize,
    global_columns: usize,
    neighbours: usize,
    normal_weight: f64,
    seed: u64,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let a = matrix.inner.clone();
    let opts = crate::baselines::LightSliceOptions { slices, columns, global_columns, neighbours, normal_weight, seed };
    let out = signals::detach(py, move || crate::baselines::lightslice(&a, &opts))?;
    let (h, w) = matrix.inner.image_size();
    let d = pyo3::types::PyDict::new(py);
    d.set_item("image", array(py, out.image, &[h, w, 3])?)?;
    d.set_item("slices", array(py, out.slice_of_pixel, &[h, w])?)?;
    let s = out.rows.len();
    d.set_item("rows", array(py, out.rows.iter().map(|&r| r as i64).collect(), &[s])?)?;
    let n = out.global_assignment.len();
    d.set_item("global_assignment", array(py, out.global_assignment.iter().map(|&x| x as i64).collect(), &[n])?)?;
    d.set_item("clusters_per_slice", array(py, out.clusters_per_slice.iter().map(|&x| x as i64).collect(), &[s])?)?;
    d.set_item("shadow_rays", out.shadow_rays)?;
    let t = pyo3::types::PyDict::new(py);
    for (k, v) in out.timings {
        t.set_item(k, v)?;
    }
    d.set_item("timings", t)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<LightTree>()?;
    m.add_function(wrap_pyfunction!(light_bvh_sampling, m)?)?;
    m.add_function(wrap_pyfunction!(ris, m)?)?;
    m.add_function(wrap_pyfunction!(stochastic_lightcuts, m)?)?;
    m.add_function(wrap_pyfunction!(lightslice, m)?)?;
    Ok(())
}
