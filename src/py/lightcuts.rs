//! Lightcuts and reconstruction cuts over a `LightMatrix` (core: `baselines::lightcuts`,
//! `baselines::reconstruction_cuts`, `baselines::cut_tree`).
use super::matrix::LightMatrix;
use super::signals;
use super::util::array;
use crate::baselines::cut_tree::CutTree;
use crate::baselines::Criterion;
use pyo3::prelude::*;

/// Lightcuts (block = 0) or reconstruction cuts with sparse blocks of `block` pixels, refined by
/// `criterion` ("cluster": every bound, the paper's; "pixel": the sum of the bounds; "hoeffding": their
/// root-sum-square times sqrt(ln(200) / 2)): dict of image
/// (H, W, 3) float32, cut_sizes (H, W) float32, shadow_rays, seconds (dict of stage -> s), tree_seconds,
/// full_cuts, capped_cuts (full cuts stopped by max_cut before the criterion held), tree_nodes, exact_lights.
#[pyfunction]
#[pyo3(signature = (matrix, error, max_cut, seed, block=0, criterion="cluster"))]
fn lightcuts<'py>(
    py: Python<'py>,
    matrix: &LightMatrix,
    error: f64,
    max_cut: usize,
    seed: u64,
    block: usize,
    criterion: &str,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let criterion = match criterion {
        "cluster" => Criterion::Cluster,
        "pixel" => Criterion::Pixel,
        "hoeffding" => Criterion::Hoeffding,
        other => {
            return Err(crate::error::Error::invalid(format!("criterion must be 'cluster', 'pixel' or 'hoeffding', got {other:?}")).into())
        }
    };
    let a = matrix.inner.clone();
    let (tree, tree_seconds, e) = signals::detach(py, move || {
        let t0 = std::time::Instant::now();
        let tree = CutTree::build(&a.lights, seed)?;
        let tree_seconds = t0.elapsed().as_secs_f64();
        let e = if block == 0 {
            crate::baselines::lightcuts(&a, &tree, error, max_cut, criterion)?
        } else {
            crate::baselines::reconstruction_cuts(&a, &tree, error, max_cut, criterion, block)?
        };
        Ok((tree, tree_seconds, e))
    })?;
    let (h, w) = matrix.inner.image_size();
    let d = pyo3::types::PyDict::new(py);
    d.set_item("image", array(py, e.image, &[h, w, 3])?)?;
    d.set_item("cut_sizes", array(py, e.cut_sizes, &[h, w])?)?;
    d.set_item("shadow_rays", e.shadow_rays)?;
    let seconds = pyo3::types::PyDict::new(py);
    for (k, v) in e.seconds {
        seconds.set_item(k, v)?;
    }
    d.set_item("seconds", seconds)?;
    d.set_item("tree_seconds", tree_seconds)?;
    d.set_item("full_cuts", e.full_cuts)?;
    d.set_item("capped_cuts", e.capped_cuts)?;
    d.set_item("tree_nodes", tree.nodes.len())?;
    d.set_item("exact_lights", tree.exact.len())?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(lightcuts, m)?)?;
    Ok(())
}
