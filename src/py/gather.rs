//! `gather_cloud` and `GatherCloud`: the gather samples of relighting and tensor clustering
//! (`lights::gather`), with their cluster hierarchy (`relight::hierarchy`).
use super::scene::Scene;
use super::util::{array, vec3_array};
use crate::error::Error;
use crate::lights::gather::{self, GatherOptions, SPHERE_TRIANGLE};
use crate::relight::ClusterHierarchy;
use crate::shading::GpuBsdf;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// n_g = 4^k gather samples spread uniformly by area over a scene's surfaces (see `gather_cloud`).
#[pyclass(module = "manylights._native", frozen)]
pub struct GatherCloud {
    pub inner: Arc<gather::GatherCloud>,
}

fn vec2_array<'py>(py: Python<'py>, v: &[glam::Vec2]) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    array(py, v.iter().flat_map(|p| p.to_array()).collect(), &[v.len(), 2])
}

fn index_array<'py>(py: Python<'py>, v: impl Iterator<Item = i64>) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let data: Vec<i64> = v.collect();
    let n = data.len();
    array(py, data, &[n])
}

#[pymethods]
impl GatherCloud {
    fn __len__(&self) -> usize {
        self.inner.len()
    }
    fn __repr__(&self) -> String {
        let c = &self.inner;
        format!("GatherCloud(n={}, side={}, total_area={:.6}, seed={})", c.len(), 1usize << c.levels(), c.total_area, c.seed)
    }
    /// (n, 3) float32 world positions.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.position)
    }
    /// (n, 3) float32 unit shading normals (interpolated vertex normals, or the face normal).
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.normal)
    }
    /// (n, 3) float32 unit geometric normals.
    #[getter]
    fn geo_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.geo_normal)
    }
    /// (n, 2) float32 texture coordinates at the samples.
    #[getter]
    fn uv<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec2_array(py, &self.inner.uv)
    }
    /// (n,) float32 area each sample stands for (m^2): total area / n on the scene the cloud was made on.
    #[getter]
    fn areas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let a = self.inner.area.clone();
        let n = a.len();
        array(py, a, &[n])
    }
    /// (n,) int64 shape index (into the scene's shapes, document order).
    #[getter]
    fn shape<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
        index_array(py, self.inner.shape.iter().map(|&s| s as i64))
    }
    /// (n,) int64 triangle index within the shape; -1 on an analytic sphere.
    #[getter]
    fn triangle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
        index_array(py, self.inner.triangle.iter().map(|&t| if t == SPHERE_TRIANGLE { -1 } else { t as i64 }))
    }
    /// (n, 2) float32 barycentrics (b1, b2) of the triangle's vertices 1 and 2; where triangle == -1, the
    /// sphere's local coordinates (u, v) = (phi / 2 pi, theta / pi).
    #[getter]
    fn barycentrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec2_array(py, &self.inner.coords)
    }
    /// (n, 3) float32 diffuse coefficient k_d (textures evaluated at uv).
    #[getter]
    fn k_d<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.k_d)
    }
    /// (n, 3) float32 glossy coefficient k_g (0 without a glossy lobe).
    #[getter]
    fn k_g<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.k_g)
    }
    /// (n,) float32 microfacet alpha of the glossy lobe (0 without one).
    #[getter]
    fn roughness<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let a = self.inner.roughness.clone();
        let n = a.len();
        array(py, a, &[n])
    }
    /// (m, 20) uint32: the BSDF records (80 bytes each) resolved at the samples, m >= n (rows n.. are
    /// the second records of blended BSDFs). Opaque, for the GPU passes.
    #[getter]
    fn bsdf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let words: Vec<u32> = bytemuck::cast_slice(&self.inner.bsdf).to_vec();
        array(py, words, &[self.inner.bsdf.len(), std::mem::size_of::<GpuBsdf>() / 4])
    }
    /// Total sampled area (m^2).
    #[getter]
    fn total_area(&self) -> f64 {
        self.inner.total_area
    }
    /// Bounding-box diagonal of the scene (the hierarchy's position scale).
    #[getter]
    fn diagonal(&self) -> f32 {
        self.inner.diagonal
    }
    #[getter]
    fn seed(&self) -> u64 {
        self.inner.seed
    }
    /// Side 2^k of the gather image (n = side^2).
    #[getter]
    fn side(&self) -> usize {
        1 << self.inner.levels()
    }
    /// The same samples on `scene`, a scene of the same topology (e.g. the next frame of an animation):
    /// positions, normals, uvs, areas (scaled by each triangle's change of area), k_d, k_g recomputed
    /// from (shape, triangle, barycentrics).
    ///
    /// Raises:
    ///     ValueError: the scene's topology differs (the message names the shape and what differs).
    ///     SceneError: non-finite vertices or a bad sphere in `scene`.
    fn on(&self, py: Python<'_>, scene: &Scene) -> PyResult<GatherCloud> {
        let (c, s) = (self.inner.clone(), scene.inner.clone());
        let moved = super::signals::detach(py, move || c.on(&s))?;
        Ok(GatherCloud { inner: Arc::new(moved) })
    }
    /// The cluster hierarchy (Sec. 4.2): a balanced quad-tree by modified 2-means on position and normal,
    /// d = K^2 |dp|^2 + D^2 |dn|^2 (D the scene diagonal), defining the 2^k x 2^k gather image.
    ///
    /// Args:
    ///     K: position weight of Eq. 9 (finite, > 0; the paper: 20 to 40).
    ///
    /// Returns:
    ///     dict with `order` (n,) int64 (the sample at each Morton code = quad-tree leaf order),
    ///     `pixel` (n,) int64 (row * side + col of each sample in the gather image),
    ///     `sample_at_pixel` (n,) int64 (inverse of pixel: `values[sample_at_pixel].reshape(side, side, ...)`
    ///     is the gather image of per-sample values), `side`, `levels` (k) and `K`. The cluster at depth j
    ///     with Morton index c is `order[c * 4**(k-j):(c + 1) * 4**(k-j)]`, the aligned image block of side
    ///     2**(k-j) at (row, col) = de-interleaved bits of c (odd bits row, even bits column) times 2**(k-j).
    ///
    /// Raises:
    ///     ValueError: K not finite and > 0.
    #[pyo3(signature = (K=crate::relight::DEFAULT_K))]
    #[allow(non_snake_case)]
    fn hierarchy<'py>(&self, py: Python<'py>, K: f32) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.clone();
        let h = super::signals::detach(py, move || ClusterHierarchy::of_cloud(&c, K))?;
        let out = PyDict::new(py);
        out.set_item("order", index_array(py, h.order.iter().map(|&i| i as i64))?)?;
        out.set_item("pixel", index_array(py, h.pixel.iter().map(|&i| i as i64))?)?;
        out.set_item("sample_at_pixel", index_array(py, h.sample_at_pixel.iter().map(|&i| i as i64))?)?;
        out.set_item("side", h.side())?;
        out.set_item("levels", h.levels)?;
        out.set_item("K", K)?;
        Ok(out)
    }
}

/// Samples a gather cloud (`manylights.gather_cloud`); see there for arguments and errors.
#[pyfunction]
#[pyo3(signature = (scene, n=16384, seed=0, include_emitters=true))]
pub fn gather_cloud(py: Python<'_>, scene: &Scene, n: i64, seed: u64, include_emitters: bool) -> PyResult<GatherCloud> {
    let n = usize::try_from(n).map_err(|_| Error::invalid(format!("the number of gather samples must be a power of 4, got {n}")))?;
    let s = scene.inner.clone();
    let opts = GatherOptions { n, seed, include_emitters };
    let c = super::signals::detach(py, move || gather::GatherCloud::new(&s, &opts))?;
    Ok(GatherCloud { inner: Arc::new(c) })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<GatherCloud>()?;
    m.add_function(wrap_pyfunction!(gather_cloud, m)?)?;
    Ok(())
}
