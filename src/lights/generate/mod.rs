//! Many-light generation: area emitters, environment maps and indirect light turned into point-like
//! lights (`generate_lights`), as the many-light papers prepare their columns:
//! Hašan, Pellacini, Bala, "Matrix Row-Column Sampling for the Many-Light Problem", SIGGRAPH 2007,
//! Sec. 4 ("area lights and environment lighting are handled by stratified uniform sampling ... indirect
//! lights are computed using particle tracing as in [Keller 1997]"); Hašan et al., "Tensor Clustering for
//! Rendering Many-Light Animations", EGSR 2008, Sec. 5 (environment map -> directional lights by
//! stratified sampling; "we shoot photons ... without storing the first hit" there is for gather samples,
//! see `vpl` for what our VPLs represent); Keller, "Instant Radiosity", SIGGRAPH 1997 (VPLs);
//! the VPL estimator of Eq. (5) in the 2022 GPU fuzzy k-means paper's Sec. 2.1.
//!
//! - `area` (`area.rs`): `OrientedPoint` lights, stratified by area over all emitting surfaces, counts
//!   split among emitters by power; the total power equals sum_e pi A_e L_e exactly.
//! - `environment` (`environment.rs`): `Directional` lights, one per stratum of an equal-area
//!   (cylindrical) partition of the sphere, each carrying the radiance integrated over its stratum;
//!   optionally allocated by what the camera sees of them (`GenerateOptions::env_visibility`,
//!   `env_visibility.rs`: a room lit through a window gets its strata in the window).
//! - `indirect` (`vpl.rs`): `Vpl` lights from particle tracing (paths with >= 1 bounce); optionally
//!   virtual spherical lights (`GenerateOptions::vsl`, `lights::vsl`): the same VPLs with a radius each;
//!   optionally importance sampled by their contribution to the camera's view
//!   (`GenerateOptions::vpl_importance`, `vpl_importance.rs`: Georgiev and Slusallek 2010).
//! - the scene's `point`, `spot`, `directional` emitters are included as they are (first, in
//!   `Scene::emitters` order), then area lights, environment lights, VPLs.
//!
//! Direct + indirect = full global illumination without double counting: the direct lights (delta,
//! area, environment) carry paths emitter -> receiver; a VPL at the k-th surface hit of a particle
//! (k >= 1) carries paths emitter -> x_1 -> ... -> x_k -> receiver. With `max_depth` as Mitsuba's
//! (`path` integrator: 2 = direct only), VPLs are deposited for k <= max_depth - 2, so the sum of all
//! columns estimates Mitsuba's `path` image of the same `max_depth` (up to the VPL clamp bias and
//! delta-lobe paths a point light cannot reach).
//!
//! Determinism: every random number comes from `rand_pcg::Pcg32` streams seeded from `seed` (one stream
//! per stratum family and per particle), so the same seed gives a bit-identical `LightSet` whatever the
//! rayon thread count.
pub mod area;
pub mod env_visibility;
pub mod environment;
mod pilot_view;
pub mod sampling;
pub mod strata;
#[cfg(test)]
mod tests;
pub mod vpl;
pub mod vpl_importance;

pub use vpl_importance::VplImportance;

use super::{scene_sphere, LightSet};
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Largest count accepted for each of `area`, `environment`, `indirect`.
pub const MAX_LIGHTS: usize = 1 << 26;
/// The default VPL clamp bounds G = cos cos / d^2 at 1 / (CLAMP_DISTANCE_REL * diagonal)^2, i.e. as
/// if no VPL came closer than a tenth of the scene's bounding-box diagonal.
pub const CLAMP_DISTANCE_REL: f32 = 0.1;

/// What `generate_lights` makes.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateOptions {
    /// Oriented point lights over all area emitters.
    pub area: usize,
    /// Directional lights over the environment (envmap / constant emitters).
    pub environment: usize,
    /// Expected number of VPLs (the count is random; its expectation is `indirect`).
    pub indirect: usize,
    /// Mitsuba's `max_depth` of the paths the lights represent (>= 3 when `indirect > 0`): VPLs at
    /// bounces 1 ..= max_depth - 2. `u32::MAX` = unlimited (Russian roulette ends paths).
    pub max_depth: u32,
    /// VPL geometry-term clamp (1/m^2); `None` = 1 / (CLAMP_DISTANCE_REL * diagonal)^2,
    /// `Some(f32::INFINITY)` = no clamp.
    pub clamp: Option<f32>,
    /// Allocate environment strata by luminance (each stratum carries an equal share of the power).
    pub env_importance: bool,
    /// Allocate environment strata by the camera's pilot view of them (`env_visibility`); exclusive with
    /// `env_importance`.
    pub env_visibility: bool,
    pub seed: u64,
    /// `Some`: the VPLs become virtual spherical lights (`lights::vsl`) with these radii (no clamp);
    /// `None`: point VPLs with the geometry-term clamp.
    pub vsl: Option<VslOptions>,
    /// `Some`: VPL candidates are accepted by their estimated image contribution (`vpl_importance`);
    /// `None`: every particle record is a VPL. Applies to the VPLs (and VSLs) of `indirect`.
    pub vpl_importance: Option<VplImportance>,
}

/// Radii of virtual spherical lights: `scale` times the distance to the `neighbours`-th nearest VPL.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VslOptions {
    pub scale: f32,
    pub neighbours: usize,
}

impl Default for VslOptions {
    fn default() -> Self {
        VslOptions { scale: 1.0, neighbours: crate::lights::vsl::DEFAULT_NEIGHBOURS }
    }
}

impl Default for GenerateOptions {
    fn default() -> Self {
        GenerateOptions {
            area: 4096,
            environment: 0,
            indirect: 0,
            max_depth: 5,
            clamp: None,
            env_importance: false,
            env_visibility: false,
            seed: 0,
            vsl: None,
            vpl_importance: None,
        }
    }
}

/// The default VPL clamp of a scene (see `CLAMP_DISTANCE_REL`).
pub fn default_clamp(scene: &Scene) -> f32 {
    let d = CLAMP_DISTANCE_REL * scene.diagonal();
    if d > 0.0 && d.is_finite() {
        1.0 / (d * d)
    } else {
        f32::INFINITY
    }
}

/// Delta lights of the scene, then `area` oriented points, `environment` directional lights and about
/// `indirect` VPLs (module docs).
///
/// With `opts.vsl`, every VPL gets its virtual-spherical-light radius (`lights::vsl::radii`).
///
/// Errors: `InvalidParameter` for counts above `MAX_LIGHTS`, a clamp that is NaN or <= 0, a VSL scale
/// that is not finite and > 0 or 0 neighbours, bad `vpl_importance` options (`VplImportance::check`) or a
/// view importance sampling cannot use (`vpl_importance::trace_importance`), `max_depth < 3`
/// with `indirect > 0`, or a scene without emitters; `Scene` errors from the emitters (bad spot frames).
pub fn generate_lights(scene: &Scene, opts: &GenerateOptions) -> Result<LightSet> {
    for (name, v) in [("area", opts.area), ("environment", opts.environment), ("indirect", opts.indirect)] {
        if v > MAX_LIGHTS {
            return Err(Error::invalid(format!("{name} must be at most {MAX_LIGHTS} lights, got {v}")));
        }
    }
    // VPLs count twice: particle paths are collected before they become lights.
    let requested = opts.area as u64 + opts.environment as u64 + 2 * opts.indirect as u64;
    crate::memory::check_host(
        &format!("generate_lights: {} area + {} environment + about {} indirect lights", opts.area, opts.environment, opts.indirect),
        crate::memory::product(&[requested, crate::memory::HOST_BYTES_PER_LIGHT]),
    )?;
    let clamp = match opts.clamp {
        None => default_clamp(scene),
        Some(c) if c > 0.0 => c,
        Some(c) => return Err(Error::invalid(format!("clamp must be > 0 (or infinite for no clamp), got {c}"))),
    };
    if opts.env_importance && opts.env_visibility {
        return Err(Error::invalid(
            "env_importance and env_visibility are two allocations of the environment strata: choose one".to_string(),
        ));
    }
    if opts.indirect > 0 && opts.max_depth < 3 {
        return Err(Error::invalid(format!(
            "max_depth must be >= 3 for indirect light (Mitsuba's max_depth: 2 = direct only), got {}",
            opts.max_depth
        )));
    }
    if scene.emitters.is_empty() {
        return Err(Error::invalid(format!(
            "{}: the scene has no emitters (no area, envmap, constant, point, spot or directional light)",
            scene.path.display()
        )));
    }
    let (center, radius) = scene_sphere(scene);
    let mut set = LightSet::from_scene(scene)?;
    set.vpl_clamp = clamp;
    let areas = area::area_emitters(scene);
    set.extend(&area::area_lights(&areas, opts.area, opts.seed, center, radius)?)?;
    let env = environment::Environment::from_scene(scene);
    if let Some(env) = &env {
        let strata = if opts.env_visibility {
            env_visibility::visibility_strata_lights(env, scene, opts.environment, opts.seed, center, radius)?
        } else {
            env.strata_lights(opts.environment, opts.env_importance, opts.seed, center, radius)?
        };
        set.extend(&strata)?;
    }
    if let Some(v) = &opts.vsl {
        crate::lights::vsl::check_scale(v.scale)?;
    }
    if let Some(imp) = &opts.vpl_importance {
        imp.check()?;
    }
    if opts.indirect > 0 {
        let mut vpls = vpl::trace_vpls(scene, &areas, env.as_ref(), opts)?;
        if let Some(v) = &opts.vsl {
            vpls.vsl_radius = crate::lights::vsl::radii(&vpls.position, v.neighbours, v.scale, radius)?;
        }
        set.extend(&vpls)?;
    }
    Ok(set)
}
