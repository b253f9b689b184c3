//! `generate_lights`: area, environment and indirect light as point-like lights (`lights::generate`).
use super::matrix::LightSet;
use super::scene::Scene;
use crate::error::Error;
use crate::lights::{generate_lights as core_generate, GenerateOptions, VplImportance, VslOptions};
use pyo3::prelude::*;

/// Delta lights of the scene plus `area` oriented points, `environment` directional lights and about
/// `indirect` VPLs. Args as `manylights.generate_lights`; `max_depth < 0` = unlimited,
/// `clamp = None` = the scene-scaled default; `indirect_kind = "vsl"` makes the VPLs virtual spherical
/// lights (`lights::vsl`); `vpl_importance` accepts VPL candidates by their image contribution
/// (`lights::generate::vpl_importance`); `env_visibility` allocates the environment strata by the
/// camera's pilot view (`lights::generate::env_visibility`). Raises ValueError for bad values or a scene without emitters.
#[pyfunction]
#[pyo3(signature = (scene, area=4096, environment=0, indirect=0, max_depth=5, clamp=None, env_importance=false, seed=0,
                    indirect_kind="vpl", vsl_radius_scale=1.0, vsl_neighbours=crate::lights::vsl::DEFAULT_NEIGHBOURS,
                    vpl_importance=false, vpl_view_samples=crate::lights::generate::vpl_importance::DEFAULT_VIEW_SAMPLES as i64,
                    vpl_accept_min=crate::lights::generate::vpl_importance::DEFAULT_ACCEPT_MIN, env_visibility=false))]
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
    indirect_kind: &str,
    vsl_radius_scale: f32,
    vsl_neighbours: usize,
    vpl_importance: bool,
    vpl_view_samples: i64,
    vpl_accept_min: f32,
    env_visibility: bool,
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
        env_visibility,
        seed,
        vsl: match indirect_kind {
            "vpl" => None,
            "vsl" => Some(VslOptions { scale: vsl_radius_scale, neighbours: vsl_neighbours }),
            k => return Err(Error::invalid(format!("indirect_kind must be 'vpl' or 'vsl', got {k:?}")).into()),
        },
        vpl_importance: match vpl_importance {
            true => Some(VplImportance { view_samples: count("vpl_view_samples", vpl_view_samples)?, accept_min: vpl_accept_min }),
            false => None,
        },
    };
    let s = scene.inner.clone();
    let set = super::signals::detach(py, move || core_generate(&s, &opts))?;
    Ok(LightSet::new(set))
}

/// One light set per frame, light j the same light in every frame (`lights::animated`). Args as
/// `manylights.generate_animation_lights`. Returns (light sets, counts {delta, area, environment, indirect}).
#[pyfunction]
#[pyo3(signature = (frames, area=1024, environment=0, indirect=0, photons=0, max_depth=-1, clamp=None, seed=0))]
#[allow(clippy::too_many_arguments)]
pub fn generate_animation_lights(
    py: Python<'_>,
    frames: Vec<PyRef<'_, Scene>>,
    area: i64,
    environment: i64,
    indirect: i64,
    photons: i64,
    max_depth: i64,
    clamp: Option<f32>,
    seed: u64,
) -> PyResult<(Vec<LightSet>, std::collections::BTreeMap<String, usize>)> {
    let count = |name: &str, v: i64| -> PyResult<usize> {
        usize::try_from(v).map_err(|_| Error::invalid(format!("{name} must be a count >= 0, got {v}")).into())
    };
    let opts = crate::lights::animated::AnimationLightOptions {
        area: count("area", area)?,
        environment: count("environment", environment)?,
        indirect: count("indirect", indirect)?,
        photons: count("photons", photons)?,
        max_depth: if max_depth < 0 { u32::MAX } else { u32::try_from(max_depth).unwrap_or(u32::MAX) },
        clamp,
        seed,
    };
    let scenes: Vec<_> = frames.iter().map(|s| s.inner.clone()).collect();
    let out = super::signals::detach(py, move || {
        let refs: Vec<&crate::scene::Scene> = scenes.iter().map(|s| s.as_ref()).collect();
        crate::lights::animated::generate_animation_lights(&refs, &opts)
    })?;
    let counts = [("delta", out.delta), ("area", out.area), ("environment", out.environment), ("indirect", out.indirect)]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    Ok((out.frames.into_iter().map(LightSet::new).collect(), counts))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(generate_animation_lights, m)?)?;
    m.add_function(wrap_pyfunction!(generate_lights, m)?)?;
    Ok(())
}
