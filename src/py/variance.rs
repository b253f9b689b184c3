//! `mrcs_row_variance`: the exact variance of the MRCS estimate at complete rows (src/cluster/variance.rs).
use super::cluster::reduced_view;
use super::util::array;
use crate::cluster::{variance, ReducedMatrix};
use crate::error::Error;
use numpy::{PyReadonlyArray1, PyReadonlyArrayDyn};
use pyo3::prelude::*;

/// Per row and channel, the variance of the MRCS estimate of that pixel of the column sum, for a fixed
/// clustering: ``sum_k (sum_{j in C_k} A_ij^2 / p_j - (sum_{j in C_k} A_ij)^2)`` (Hašan et al. 2007, Sec. 3.3).
///
/// Args:
///     rows: (h, n, 3) or (h, n) float32 complete rows of the light matrix (``LightMatrix.rows``).
///     assignment: (n,) int32 cluster of each light, labels in [0, num_clusters).
///     probability: (n,) float64 chance that each light is its cluster's representative (in [0, 1]).
///     num_clusters: c.
///
/// Returns:
///     (h, 3) float64 variances in radiance^2.
///
/// Raises:
///     ValueError: bad shapes, non-finite rows, a label out of range, a probability outside [0, 1].
#[pyfunction]
#[pyo3(name = "mrcs_row_variance")]
pub fn mrcs_row_variance_py<'py>(
    py: Python<'py>,
    rows: PyReadonlyArrayDyn<'py, f32>,
    assignment: PyReadonlyArray1<'py, i32>,
    probability: PyReadonlyArray1<'py, f64>,
    num_clusters: usize,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    let (data, h, n, channels) = reduced_view(&rows)?;
    let labels = assignment.as_array();
    if let Some(j) = labels.iter().position(|&a| a < 0) {
        return Err(Error::invalid(format!("assignment labels must be >= 0, got {} for light {j}", labels[j])).into());
    }
    let labels: Vec<u32> = labels.iter().map(|&a| a as u32).collect();
    let probability: Vec<f64> = probability.as_array().iter().copied().collect();
    let var = super::signals::detach(py, || {
        let rows = ReducedMatrix::new(&data, h, n, channels)?;
        variance::row_variance(rows, &labels, &probability, num_clusters)
    })?;
    array(py, var.into_iter().flatten().collect(), &[h, 3])
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mrcs_row_variance_py, m)?)?;
    Ok(())
}
