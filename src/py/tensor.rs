//! `cluster_tensor`: tensor clustering of the reduced tensor (src/cluster/tensor).
use super::util::array;
use crate::cluster::tensor::{self, ReducedTensor, Representative, TensorOptions};
use crate::error::Error;
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::borrow::Cow;

/// Clusters the light-frame pairs of the reduced tensor (Hašan et al. 2008, Sec. 4.3-4.5; see
/// src/cluster/tensor/mod.rs). `slices`: (r, n, f, 3) or (r, n, f) float32. Returns a dict: assignment
/// (n, f) int32, representatives (c, 2) int64 (light, frame), frames (c, 2) int64 [start, end), sizes (c,)
/// int64 pairs per cluster, rec (c, f, 3) float32, cost (c,) float64, rendered (c,) bool,
/// shadow_maps_per_frame (f,) int64, clusters_per_frame (f,) int64, chunks (list of dicts).
/// Raises ValueError on bad shapes, non-finite values, columns outside [f, n f], zero chunk.
#[pyfunction]
#[pyo3(name = "cluster_tensor", signature = (slices, columns, seed=0, chunk=40, init_clusters=100, projection_dim=50, representative="max", color_averaging=true, time_weight=1.0, frame_major=false, first_chunk=0))]
#[allow(clippy::too_many_arguments)]
pub fn cluster_tensor_py<'py>(
    py: Python<'py>,
    slices: PyReadonlyArrayDyn<'py, f32>,
    columns: usize,
    seed: u64,
    chunk: usize,
    init_clusters: usize,
    projection_dim: usize,
    representative: &str,
    color_averaging: bool,
    time_weight: f64,
    frame_major: bool,
    first_chunk: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let shape = slices.shape().to_vec();
    // frame_major: the array is (f, r, n[, 3]), the same tensor stored frame by frame.
    let dims = match *shape {
        [a, b, c] => (a, b, c, 1),
        [a, b, c, 3] => (a, b, c, 3),
        _ => return Err(Error::invalid(format!("slices must have shape (r, n, f, 3) or (r, n, f), got {shape:?}")).into()),
    };
    let (r, n, f, channels) = if frame_major { (dims.1, dims.2, dims.0, dims.3) } else { dims };
    let representative = match representative {
        "max" => Representative::MaxWeight,
        "sampled" => Representative::Sampled,
        "centroid" => Representative::Centroid,
        other => return Err(Error::invalid(format!("representative must be 'max', 'sampled' or 'centroid', got {other:?}")).into()),
    };
    let data = match slices.as_slice() {
        Ok(s) if slices.is_c_contiguous() => Cow::Borrowed(s),
        _ => Cow::Owned(slices.as_array().iter().copied().collect()),
    };
    let opts = TensorOptions { seed, chunk, init_clusters, projection_dim, representative, color_averaging, time_weight, first_chunk };
    let result = super::signals::detach(py, || {
        let t =
            if frame_major { ReducedTensor::frame_major(&data, r, n, f, channels)? } else { ReducedTensor::new(&data, r, n, f, channels)? };
        tensor::cluster_tensor(t, columns, &opts)
    })?;
    let c = result.num_clusters();
    let out = PyDict::new(py);
    out.set_item("assignment", array(py, result.assignment.iter().map(|&a| a as i32).collect(), &[n, f])?)?;
    let reps: Vec<i64> = result.representatives.iter().flat_map(|&(j, k)| [j as i64, k as i64]).collect();
    out.set_item("representatives", array(py, reps, &[c, 2])?)?;
    out.set_item("frames", array(py, result.frames.iter().flat_map(|&(a, b)| [a as i64, b as i64]).collect(), &[c, 2])?)?;
    let sizes: Vec<i64> = result.lights.iter().zip(&result.frames).map(|(l, &(a, b))| (l.len() * (b - a) as usize) as i64).collect();
    out.set_item("sizes", array(py, sizes, &[c])?)?;
    out.set_item("rec", array(py, result.rec.iter().flatten().copied().collect(), &[c, f, 3])?)?;
    out.set_item("cost", array(py, result.cost.clone(), &[c])?)?;
    out.set_item("rendered", array(py, result.rendered(), &[c])?)?;
    out.set_item("shadow_maps_per_frame", array(py, result.shadow_maps_per_frame().iter().map(|&v| v as i64).collect(), &[f])?)?;
    out.set_item("clusters_per_frame", array(py, result.clusters_per_frame().iter().map(|&v| v as i64).collect(), &[f])?)?;
    let chunks = PyList::empty(py);
    for ch in &result.chunks {
        let d = PyDict::new(py);
        d.set_item("frames", (ch.frames.0, ch.frames.1))?;
        d.set_item("budget", ch.budget)?;
        d.set_item("init_clusters", ch.init_clusters)?;
        d.set_item("time_splits", ch.time_splits)?;
        d.set_item("light_splits", ch.light_splits)?;
        chunks.append(d)?;
    }
    out.set_item("chunks", chunks)?;
    Ok(out)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(cluster_tensor_py, m)?)?;
    Ok(())
}
