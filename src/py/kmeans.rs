//! `kmeans` and `fuzzy_membership`: K-means of (position, normal) points with Eq. 7's orientation threshold
//! and the distance-based fuzzy membership (src/cluster/kmeans; the public face is python/manylights/kmeans.py).
use super::util::array;
use crate::cluster::kmeans::{self, KMeansParams, DEFAULT_COS_THRESHOLD};
use crate::error::Error;
use crate::matrix::backend::{Chosen, Device};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// An (N, 3) float32 array as N triples (`name` labels errors).
fn triples(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<[f32; 3]>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(Error::invalid(format!("{name} must have shape (N, 3), got {shape:?}")).into());
    }
    Ok(a.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// `normals` as triples matching `n` points, or zeros when absent.
fn normals_or_zero(normals: Option<PyReadonlyArray2<'_, f32>>, name: &str, n: usize, points: &str) -> PyResult<Vec<[f32; 3]>> {
    match normals {
        Some(a) => {
            let v = triples(name, &a)?;
            if v.len() != n {
                return Err(Error::invalid(format!("{name} has {} rows but {points} has {n} (need one normal per point)", v.len())).into());
            }
            Ok(v)
        }
        None => Ok(vec![[0.0; 3]; n]),
    }
}

fn count(name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| Error::invalid(format!("{name} must be >= 0, got {v}")).into())
}

fn triples_array<'py>(py: Python<'py>, v: &[[f32; 3]]) -> PyResult<Bound<'py, PyAny>> {
    Ok(array(py, v.iter().flatten().copied().collect(), &[v.len(), 3])?.into_any())
}

/// K-means of N data points (Alg. 1 of the 2022 GPU fuzzy K-means paper; module docs of
/// `manylights.kmeans`).
///
/// Args:
///     points: (N, 3) float32 positions (scene units).
///     normals: (N, 3) float32 normals (normalised here) or None (then the orientation threshold is off).
///     k: clusters, 1 <= k <= N.
///     iterations: most update steps, >= 0.
///     tolerance: stop when the objective falls by no more than this fraction; 0 = exactly `iterations`.
///     cos_threshold: Eq. 7's n_t in [-1, 1], or None for plain Euclidean K-means.
///     grid: accelerate the GPU assignment with the regular grid (same result).
///     device: "auto", "gpu" or "cpu".
///     seed: seed of the initial centroids.
///
/// Returns:
///     dict: centroids (k, 3) float32, centroid_normals (k, 3) float32, labels (N,) int64, objective
///     (list of iterations + 1 floats), iterations, initial (k,) int64, timings (dict of seconds), device.
///
/// Raises:
///     ValueError: k out of range, negative iterations or tolerance, bad shapes, NaN/inf, zero normals
///     with the threshold on, a threshold outside [-1, 1], a bad device name.
#[pyfunction]
#[pyo3(name = "kmeans", signature = (points, normals, k, iterations=10, tolerance=0.0, cos_threshold=Some(DEFAULT_COS_THRESHOLD), grid=true, device="auto", seed=0))]
#[allow(clippy::too_many_arguments)]
pub fn kmeans_py<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f32>,
    normals: Option<PyReadonlyArray2<'py, f32>>,
    k: i64,
    iterations: i64,
    tolerance: f64,
    cos_threshold: Option<f32>,
    grid: bool,
    device: &str,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let pts = triples("points", &points)?;
    let has_normals = normals.is_some();
    let nrm = normals_or_zero(normals, "normals", pts.len(), "points")?;
    if k < 1 {
        return Err(Error::invalid(format!("kmeans: k must be in [1, {}] (the number of points), got {k}", pts.len())).into());
    }
    let params = KMeansParams {
        k: k as usize,
        max_iterations: count("iterations", iterations)?,
        tolerance,
        cos_threshold: if has_normals { cos_threshold } else { None },
        use_grid: grid,
        seed,
    };
    let chosen = Device::parse(device)?;
    let r = super::signals::detach(py, move || match chosen.choose()? {
        Chosen::Cpu => kmeans::kmeans_cpu(&pts, &nrm, &params),
        Chosen::Gpu(ctx) => kmeans::kmeans_gpu(&ctx, &pts, &nrm, &params),
    })?;
    let out = PyDict::new(py);
    out.set_item("centroids", triples_array(py, &r.centroids)?)?;
    out.set_item("centroid_normals", triples_array(py, &r.centroid_normals)?)?;
    let n = r.assignment.len();
    out.set_item("labels", array(py, r.assignment.iter().map(|&a| a as i64).collect(), &[n])?)?;
    out.set_item("objective", r.objective.clone())?;
    out.set_item("iterations", r.iterations)?;
    let kk = r.initial.len();
    out.set_item("initial", array(py, r.initial.iter().map(|&a| a as i64).collect(), &[kk])?)?;
    let t = PyDict::new(py);
    t.set_item("setup", r.timings.setup_s)?;
    t.set_item("iterations", r.timings.iterations_s)?;
    t.set_item("readback", r.timings.readback_s)?;
    t.set_item("total", r.timings.total_s)?;
    out.set_item("timings", t)?;
    out.set_item("device", r.device)?;
    Ok(out)
}

/// The F nearest clusters of each point and their Eq. 10 inverse-distance weights (Alg. 2).
///
/// Args:
///     points: (N, 3) float32; normals: (N, 3) float32 or None (threshold off).
///     centroids, centroid_normals: (k, 3) float32 each (centroid_normals may be None with normals None).
///     f: clusters per point, 1 <= f <= min(k, 16).
///     cos_threshold: Eq. 7's n_t in [-1, 1] or None.
///     grid: use the grid on the GPU. device: "auto", "gpu" or "cpu".
///
/// Returns:
///     dict: clusters (N, f) int64 nearest first, weights (N, f) float32 (rows sum to 1),
///     distances (N, f) float32 Euclidean, admissible (N, f) bool, device.
///
/// Raises:
///     ValueError: f out of range, bad shapes, NaN/inf, zero normals with the threshold on, bad device.
#[pyfunction]
#[pyo3(name = "fuzzy_membership", signature = (points, normals, centroids, centroid_normals, f=6, cos_threshold=Some(DEFAULT_COS_THRESHOLD), grid=true, device="auto"))]
#[allow(clippy::too_many_arguments)]
pub fn fuzzy_membership_py<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f32>,
    normals: Option<PyReadonlyArray2<'py, f32>>,
    centroids: PyReadonlyArray2<'py, f32>,
    centroid_normals: Option<PyReadonlyArray2<'py, f32>>,
    f: i64,
    cos_threshold: Option<f32>,
    grid: bool,
    device: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let pts = triples("points", &points)?;
    let cts = triples("centroids", &centroids)?;
    if normals.is_some() != centroid_normals.is_some() {
        return Err(Error::invalid("fuzzy_membership: give both normals and centroid_normals, or neither").into());
    }
    let threshold = if normals.is_some() { cos_threshold } else { None };
    let nrm = normals_or_zero(normals, "normals", pts.len(), "points")?;
    let cnm = normals_or_zero(centroid_normals, "centroid_normals", cts.len(), "centroids")?;
    let f = count("f", f)?;
    let chosen = Device::parse(device)?;
    let (m, dev) = super::signals::detach(py, move || match chosen.choose()? {
        Chosen::Cpu => Ok((kmeans::fuzzy_membership(&pts, &nrm, &cts, &cnm, f, threshold)?, "cpu")),
        Chosen::Gpu(ctx) => Ok((kmeans::fuzzy_membership_gpu(&ctx, &pts, &nrm, &cts, &cnm, f, threshold, grid)?, "gpu")),
    })?;
    let n = m.clusters.len() / m.f;
    let out = PyDict::new(py);
    out.set_item("clusters", array(py, m.clusters.iter().map(|&c| c as i64).collect(), &[n, m.f])?)?;
    out.set_item("weights", array(py, m.weights, &[n, m.f])?)?;
    out.set_item("distances", array(py, m.distances2.iter().map(|d| d.sqrt()).collect(), &[n, m.f])?)?;
    out.set_item("admissible", array(py, m.admissible, &[n, m.f])?)?;
    out.set_item("device", dev)?;
    Ok(out)
}

/// View-sample clustering as the 2022 paper does it (Alg. 1 with downsampling, then Alg. 2):
/// K-means of the view samples `downsample_indices` keeps (one per block of `gamma`, seeded; gamma lowered
/// so that at least k remain), then the F nearest clusters of every view sample with Eq. 10 weights.
///
/// Args: points, normals (N, 3) float32 (normals required: the threshold applies); k; gamma >= 1; f;
///     iterations; cos_threshold (None: off); grid; device "auto" / "gpu" / "cpu"; seed.
///
/// Returns:
///     dict: centroids, centroid_normals (k, 3) float32, clusters (N, f) int64, weights (N, f) float32,
///     gamma (the factor used), subset (int64 indices clustered), objective (list), iterations, device,
///     seconds (K-means and membership together).
///
/// Raises:
///     ValueError: k, gamma, f or iterations out of range, bad shapes, NaN/inf, zero normals, bad device.
#[pyfunction]
#[pyo3(name = "cluster_view_samples", signature = (points, normals, k, gamma=4, f=6, iterations=10, cos_threshold=Some(DEFAULT_COS_THRESHOLD), grid=true, device="auto", seed=0))]
#[allow(clippy::too_many_arguments)]
pub fn cluster_view_samples_py<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f32>,
    normals: PyReadonlyArray2<'py, f32>,
    k: i64,
    gamma: i64,
    f: i64,
    iterations: i64,
    cos_threshold: Option<f32>,
    grid: bool,
    device: &str,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let pts = triples("points", &points)?;
    let nrm = normals_or_zero(Some(normals), "normals", pts.len(), "points")?;
    if k < 1 {
        return Err(
            Error::invalid(format!("cluster_view_samples: k must be in [1, {}] (the number of view samples), got {k}", pts.len())).into()
        );
    }
    let params = KMeansParams {
        k: k as usize,
        max_iterations: count("iterations", iterations)?,
        tolerance: 0.0,
        cos_threshold,
        use_grid: grid,
        seed,
    };
    let (gamma, f) = (count("gamma", gamma)?, count("f", f)?);
    let chosen = Device::parse(device)?;
    let t = std::time::Instant::now();
    let (r, dev) = super::signals::detach(py, move || match chosen.choose()? {
        Chosen::Cpu => Ok((kmeans::cluster_view_samples(kmeans::KMeansDevice::Cpu, &pts, &nrm, gamma, &params, f)?, "cpu")),
        Chosen::Gpu(ctx) => Ok((kmeans::cluster_view_samples(kmeans::KMeansDevice::Gpu(&ctx), &pts, &nrm, gamma, &params, f)?, "gpu")),
    })?;
    let seconds = t.elapsed().as_secs_f64();
    let m = &r.membership;
    let n = m.clusters.len() / m.f.max(1);
    let out = PyDict::new(py);
    out.set_item("centroids", triples_array(py, &r.kmeans.centroids)?)?;
    out.set_item("centroid_normals", triples_array(py, &r.kmeans.centroid_normals)?)?;
    out.set_item("clusters", array(py, m.clusters.iter().map(|&c| c as i64).collect(), &[n, m.f])?)?;
    out.set_item("weights", array(py, m.weights.clone(), &[n, m.f])?)?;
    out.set_item("gamma", r.gamma)?;
    let ns = r.subset.len();
    out.set_item("subset", array(py, r.subset.iter().map(|&i| i as i64).collect(), &[ns])?)?;
    out.set_item("objective", r.kmeans.objective.clone())?;
    out.set_item("iterations", r.kmeans.iterations)?;
    out.set_item("device", dev)?;
    out.set_item("seconds", seconds)?;
    Ok(out)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kmeans_py, m)?)?;
    m.add_function(wrap_pyfunction!(fuzzy_membership_py, m)?)?;
    m.add_function(wrap_pyfunction!(cluster_view_samples_py, m)?)?;
    Ok(())
}
