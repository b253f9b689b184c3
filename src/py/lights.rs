//! `generate_lights`: area, environment and indirect light as point-like lights (`lights::generate`).
use super::matrix::LightSet;
use super::scene::Scene;
use crate::error::Error;
use crate::lights::{generate_lights as core_generate, GenerateOptions};
use pyo3::prelude::*;

/// Delta lights of the scene plus `area` oriented points, `environment` directional lights and about
/// `indirect` VPLs. Args as `manylights.generate_lights`; `max_depth < 0` = unlimited,
/// `clamp = None` = the scene-scaled default. Raises ValueError for bad values or a scene without emitters.
#[pyfunction]
#[pyo3(signature = (scene, area=4096, environment=0, indirect=0, max_depth=5, clamp=None, env_importance=false, seed=0))]
#[allow(clippy::too_many_arguments)]
pub fn generate_lights(
    py: Python<'_>,
    scene: &Scene,
    area: i64,
    environment: i64,
    indirect: i64,
    max_depth: i64,
    clamp: Option<f32>,
    env_importance: bool,
    seed: u64,
) -> PyResult<LightSet> {
    let count = |name: &str, v: i64| -> PyResult<usize> {
        usize::try_from(v).map_err(|_| Error::invalid(format!("{name} must be a count >= 0, got {v}")).into())
    };
    let opts = GenerateOptions {
        area: count("area", area)?,
        environment: count("environment", environment)?,
        indirect: count("indirect", indirect)?,
        max_depth: if max_depth < 0 { u32::MAX } else { u32::try_from(max_depth).unwrap_or(u32::MAX) },
        clamp,
        env_importance,
        seed,
    };
    let s = scene.inner.clone();
    let set = super::signals::detach(py, move || core_generate(&s, &opts))?;
    Ok(LightSet::new(set))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(generate_lights, m)?)?;
    Ok(())
}
