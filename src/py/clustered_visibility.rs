//! `clustered_shading`: clustered visibility with given clusterings (src/cluster/visibility); the public
//! wrapper with argument checks is `manylights.clustered_shading` (python/manylights/renderers/clustered_visibility.py).
use super::matrix::LightMatrix;
use super::util::array;
use crate::cluster::visibility::{LightClustering, Membership, ViewClustering};
use crate::error::Error;
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Rows of an (k, 3) float32 array.
fn rows3(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<[f32; 3]>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(Error::invalid(format!("{name} must have shape (k, 3), got {shape:?}")).into());
    }
    Ok(a.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// Clustered visibility of light matrix `A` with the given light and view-sample clusterings
/// (module docs of src/cluster/visibility): visibility between representatives, then Eq. 6/9 shading.
///
/// Args:
///     A: the LightMatrix (its device runs it).
///     light_labels: (n,) uint32 label of each light, < k_light.
///     light_centroids: (k_light, 3) float32 centroid of each label.
///     view_centroids, view_normals: (k_view, 3) float32.
///     membership_clusters: (m, F) uint32, each view sample's F nearest view clusters.
///     membership_weights: (m, F) float32, rows summing to 1.
///
/// Returns:
///     dict: image (H, W, 3) float32 (no emitters), visibility (k_view, ceil(K/32)) uint32 bit rows
///     (bit c set when V(k, c) > 0), transmittance (k_view, K) float32 V(k, c) in [0, 1] in a scene with
///     masked surfaces (None otherwise), crossed (k_view, ceil(K/32)) uint32 bit rows of the rays that
///     crossed a masked surface (None without masks), rays, gave_up (int), visibility_seconds, shading_seconds (float), light_representatives (K,) int64,
///     light_cluster_labels (K,) int64, light_cluster_sizes (K,) int64, view_representatives (k_view,)
///     int64 (-1 = none), light_clusters K and view_clusters k_view (int).
///
/// Raises:
///     ValueError: shapes, labels, weights or values out of range (named).
#[pyfunction]
#[pyo3(name = "clustered_shading")]
#[allow(non_snake_case, clippy::too_many_arguments)]
pub fn clustered_shading_py<'py>(
    py: Python<'py>,
    A: &LightMatrix,
    light_labels: PyReadonlyArray1<'py, u32>,
    light_centroids: PyReadonlyArray2<'py, f32>,
    view_centroids: PyReadonlyArray2<'py, f32>,
    view_normals: PyReadonlyArray2<'py, f32>,
    membership_clusters: PyReadonlyArray2<'py, u32>,
    membership_weights: PyReadonlyArray2<'py, f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let f = membership_clusters.shape()[1];
    if membership_weights.shape() != membership_clusters.shape() {
        return Err(Error::invalid(format!(
            "membership_weights must have the shape of membership_clusters {:?}, got {:?}",
            membership_clusters.shape(),
            membership_weights.shape()
        ))
        .into());
    }
    let lc = LightClustering { assignment: light_labels.as_array().to_vec(), centroids: rows3("light_centroids", &light_centroids)? };
    let vc = ViewClustering {
        centroids: rows3("view_centroids", &view_centroids)?,
        normals: rows3("view_normals", &view_normals)?,
        membership: Membership {
            f,
            clusters: membership_clusters.as_array().iter().copied().collect(),
            weights: membership_weights.as_array().iter().copied().collect(),
        },
    };
    let m = A.inner.clone();
    let (job, out) = super::signals::detach(py, move || m.clustered_shading(&lc, &vc))?;
    let (h, w) = A.inner.image_size();
    let (kl, kv) = (job.lights.len(), job.view_reps.len());
    let d = PyDict::new(py);
    d.set_item("image", array(py, out.image, &[h, w, 3])?)?;
    let words = crate::cluster::visibility::words_per_row(kl);
    let vis = out.visibility;
    if vis.transmittance.is_empty() {
        d.set_item("transmittance", py.None())?;
        d.set_item("crossed", py.None())?;
    } else {
        d.set_item("transmittance", array(py, vis.transmittance, &[kv, kl])?)?;
        d.set_item("crossed", array(py, vis.crossed, &[kv, words])?)?;
    }
    d.set_item("visibility", array(py, vis.bits, &[kv, words])?)?;
    d.set_item("rays", out.rays)?;
    d.set_item("gave_up", out.gave_up)?;
    d.set_item("visibility_seconds", out.visibility_seconds)?;
    d.set_item("shading_seconds", out.shading_seconds)?;
    let to_i64 = |v: Vec<i64>, n: usize| array(py, v, &[n]);
    d.set_item("light_representatives", to_i64(job.lights.representative.iter().map(|&j| j as i64).collect(), kl)?)?;
    d.set_item("light_cluster_labels", to_i64(job.lights.label.iter().map(|&l| l as i64).collect(), kl)?)?;
    d.set_item("light_cluster_sizes", to_i64(job.lights.size.iter().map(|&s| s as i64).collect(), kl)?)?;
    d.set_item("view_representatives", to_i64(job.view_reps.sample.iter().map(|s| s.map_or(-1, |i| i as i64)).collect(), kv)?)?;
    d.set_item("light_clusters", kl)?;
    d.set_item("view_clusters", kv)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(clustered_shading_py, m)?)?;
    Ok(())
}
