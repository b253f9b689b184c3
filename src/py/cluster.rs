//! `cluster_reduced_columns` and `clustering_cost`: MRCS clustering of reduced columns (src/cluster).
use super::util::array;
use crate::cluster::{self, ClusterOptions, ReducedMatrix};
use crate::error::Error;
use numpy::{PyReadonlyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::borrow::Cow;

/// (data, r, n, channels) of an (r, n, 3) or (r, n) float32 array (copied only when not C-contiguous).
pub(crate) fn reduced_view<'a>(reduced: &'a PyReadonlyArrayDyn<'_, f32>) -> PyResult<(Cow<'a, [f32]>, usize, usize, usize)> {
    let shape = reduced.shape();
    let (r, n, channels) = match *shape {
        [r, n] => (r, n, 1),
        [r, n, 3] => (r, n, 3),
        _ => return Err(Error::invalid(format!("R must have shape (r, n, 3) or (r, n), got {shape:?}")).into()),
    };
    // as_slice() also accepts Fortran order, whose memory order is not (r, n, channels).
    let data = match reduced.as_slice() {
        Ok(s) if reduced.is_c_contiguous() => Cow::Borrowed(s),
        _ => Cow::Owned(reduced.as_array().iter().copied().collect()),
    };
    Ok((data, r, n, channels))
}

/// Partitions the n columns (lights) of the reduced matrix into `c` clusters and picks one weighted
/// representative per cluster (Hašan et al. 2007, Sec. 3-4; see src/cluster/mod.rs for deviations).
///
/// Args:
///     R: (r, n, 3) or (r, n) float32 reduced matrix (sampled rows x lights); RGB becomes the 2-norm.
///     c: number of clusters, 1 <= c <= n.
///     seed: seed of all random choices (same seed, same result).
///     power: optional (n,) float32 light power, >= 0; distribution of representatives among lights
///         whose reduced column is zero (uniform if None).
///     projection_dim: r' of the random projection (applied when r > r'), default 50.
///     sampling_fraction: fraction of clusters made by sampling before splitting, default 2/3.
///     color_averaging: the paper's per-channel colour averaging of the weights (biased), default False.
///
/// Returns:
///     dict with assignment (n,) int32, representatives (c,) int64, weights (c, 3) float32 (the column
///     sum estimate is sum_k weights[k] * column[representatives[k]]), cost (float, total objective on
///     the unprojected scalar R), cluster_costs (c,) float64 and probability (n,) float64 (the chance that
///     each light is drawn as the representative of its cluster; src/cluster/variance.rs).
///
/// Raises:
///     ValueError: bad shape, non-finite value (row and column named), c out of range, bad power.
#[pyfunction]
#[pyo3(name = "cluster_reduced_columns", signature = (R, c, seed=0, power=None, projection_dim=50, sampling_fraction=2.0/3.0, color_averaging=false))]
#[allow(non_snake_case, clippy::too_many_arguments)]
pub fn cluster_reduced_columns_py<'py>(
    py: Python<'py>,
    R: PyReadonlyArrayDyn<'py, f32>,
    c: usize,
    seed: u64,
    power: Option<PyReadonlyArray1<'py, f32>>,
    projection_dim: usize,
    sampling_fraction: f64,
    color_averaging: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (data, r, n, channels) = reduced_view(&R)?;
    let power: Option<Vec<f32>> = power.map(|p| p.as_array().iter().copied().collect());
    let (result, probability) = super::signals::detach(py, || {
        let reduced = ReducedMatrix::new(&data, r, n, channels)?;
        let opts = ClusterOptions { seed, projection_dim, sampling_fraction, power: power.as_deref(), color_averaging };
        let result = cluster::cluster_reduced_columns(reduced, c, &opts)?;
        let probability = cluster::variance::probabilities_of(&reduced, &result, power.as_deref());
        Ok::<_, Error>((result, probability))
    })?;
    let out = PyDict::new(py);
    let k = result.representatives.len();
    out.set_item("assignment", array(py, result.assignment.iter().map(|&a| a as i32).collect(), &[n])?)?;
    out.set_item("representatives", array(py, result.representatives.iter().map(|&j| j as i64).collect(), &[k])?)?;
    out.set_item("weights", array(py, result.weights.iter().flatten().copied().collect(), &[k, 3])?)?;
    out.set_item("probability", array(py, probability, &[n])?)?;
    out.set_item("cost", result.total_cost())?;
    out.set_item("cluster_costs", array(py, result.cost, &[k])?)?;
    Ok(out)
}

/// Sec. 3.4 objective of a partition on the unprojected scalar reduced matrix.
///
/// Args:
///     R: (r, n, 3) or (r, n) float32 reduced matrix.
///     assignment: (n,) int cluster label of each column (labels >= 0).
///
/// Returns:
///     float: sum over clusters of sum_{i,j in C} |rho_i||rho_j| - rho_i . rho_j.
#[pyfunction]
#[pyo3(name = "clustering_cost")]
#[allow(non_snake_case)]
pub fn clustering_cost_py<'py>(py: Python<'py>, R: PyReadonlyArrayDyn<'py, f32>, assignment: Vec<i64>) -> PyResult<f64> {
    let (data, r, n, channels) = reduced_view(&R)?;
    if let Some(j) = assignment.iter().position(|&a| !(0..=u32::MAX as i64).contains(&a)) {
        return Err(Error::invalid(format!("assignment labels must be >= 0, got {} for column {j}", assignment[j])).into());
    }
    let labels: Vec<u32> = assignment.iter().map(|&a| a as u32).collect();
    Ok(py.detach(|| cluster::clustering_cost(ReducedMatrix::new(&data, r, n, channels)?, &labels))?)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(cluster_reduced_columns_py, m)?)?;
    m.add_function(wrap_pyfunction!(clustering_cost_py, m)?)?;
    Ok(())
}
