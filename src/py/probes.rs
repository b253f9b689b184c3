//! `probe_pixels`: the unbiased CPU path tracer at probe pixels (`crate::pathtrace`).
use super::lightset::LightSet;
use super::scene::Scene;
use super::signals::{self, progress_callback};
use super::util::array;
use crate::error::Error;
use crate::pathtrace::{probe_pixels, ProbeOptions};
use numpy::{PyArrayDyn, PyReadonlyArray2};
use pyo3::prelude::*;

/// Mean radiance and variance of the mean at probe pixels by Mitsuba's `path` integrator semantics
/// (`crate::pathtrace`; the Python wrapper `manylights.probe_pixels` documents it).
///
/// Args: pixels (k, 2) int64 (row, column); spp >= 2; max_depth -1 or >= 1; seed; progress(done, total)
/// in paths; lights: a LightSet lighting the scene instead of its emitters; guided_env: sample the environment
/// guided by the camera's pilot view (else by luminance). Returns two (k, 3) float32 arrays. Raises ValueError for bad arguments or an unsupported
/// scene (principled BSDFs), KeyboardInterrupt on Ctrl-C.
#[pyfunction]
#[pyo3(name = "probe_pixels", signature = (scene, pixels, spp, max_depth, seed, progress=None, lights=None, guided_env=true))]
pub fn probe_pixels_py<'py>(
    py: Python<'py>,
    scene: &Scene,
    pixels: PyReadonlyArray2<'py, i64>,
    spp: i64,
    max_depth: i64,
    seed: u64,
    progress: Option<Py<PyAny>>,
    lights: Option<&LightSet>,
    guided_env: bool,
) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Bound<'py, PyArrayDyn<f32>>)> {
    let a = pixels.as_array();
    if a.ncols() != 2 {
        return Err(Error::invalid(format!("pixels must have shape (k, 2) of (row, column), got {:?}", a.shape())).into());
    }
    let (w, h) = (scene.inner.camera.width as i64, scene.inner.camera.height as i64);
    let mut px = Vec::with_capacity(a.nrows());
    for (k, r) in a.rows().into_iter().enumerate() {
        let (row, col) = (r[0], r[1]);
        if !(0..h).contains(&row) || !(0..w).contains(&col) {
            return Err(Error::invalid(format!("pixel {k} is (row={row}, column={col}), outside the {h}x{w} (rows x columns) film")).into());
        }
        px.push((col as u32, row as u32));
    }
    if !(2..=u32::MAX as i64).contains(&spp) {
        return Err(Error::invalid(format!("spp must be in 2..={} (the variance of the mean needs two paths), got {spp}", u32::MAX)).into());
    }
    if max_depth == 0 || max_depth < -1 {
        return Err(Error::invalid(format!("max_depth must be -1 (unlimited) or >= 1, got {max_depth}")).into());
    }
    let opts = ProbeOptions { spp: spp as u32, max_depth: max_depth.min(i32::MAX as i64) as i32, seed, guided_env, ..Default::default() };
    crate::pathtrace::check_supported(&scene.inner)?;
    let view = scene.camera_samples(py)?;
    let tracer = scene.tracer(py)?;
    let env = if lights.is_none() { scene.probe_env(py, guided_env)? } else { None };
    let inner = scene.inner.clone();
    let lights = lights.map(|l| (*l.inner).clone());
    let est = signals::detach(py, move || {
        let mut cb = progress_callback(progress);
        probe_pixels(&inner, &tracer, &view, &px, &opts, lights, env, &mut cb)
    })?;
    let k = est.len();
    let mean = est.iter().flat_map(|e| e.mean.to_array()).collect();
    let var = est.iter().flat_map(|e| e.variance_of_mean.to_array()).collect();
    Ok((array(py, mean, &[k, 3])?, array(py, var, &[k, 3])?))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(probe_pixels_py, m)?)?;
    Ok(())
}
