//! Lights for animations: one `LightSet` per frame in which light j is the same light in every frame
//! (Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for Rendering Many-Light Animations", EGSR
//! 2008, Sec. 4.3 and 5: the unit of clustering is a light-frame pair (j, k), so light j must mean the same
//! light in frame k as in frame 0).
//!
//! - Delta emitters (point, spot, directional) come from each frame's scene, in `Scene::emitters` order;
//!   every frame must have the same number.
//! - Area emitters: `area` oriented points are sampled on frame 0 exactly as `generate_lights` does
//!   (`area::area_lights_tied`: counts split by power, stratified by area) and tied to their surface
//!   (`SurfaceTie`: mesh, triangle, barycentrics; sphere, direction from the centre). In frame k each point
//!   is re-evaluated on that frame's shape: position (on the surface), emitting normal, and
//!   intensity I0 = L_e(uv) A_e(k) / n_e with the emitter's area A_e(k) in that frame, so a deforming
//!   emitter keeps its power estimate unbiased.
//! - Environment emitters: `environment` directional lights over the equal-area strata of the sphere
//!   (`environment::strata_lights` without importance), whose directions are the strata's centroids and
//!   so the same in every frame; each frame integrates its own map over them.
//! - Indirect light (the paper's Sec. 5): a gather cloud (`gather::GatherCloud::new_any_count`, `indirect`
//!   samples uniformly by area over all surfaces, stratified, tied to them) made on frame 0 and moved with the surfaces
//!   (`GatherCloud::on`). In each frame a gather sample i is shaded by that frame's direct light
//!   (every delta, area and environment light above, exact shadow rays through the frame's BVH):
//!   irradiance E_i = sum_j L_j(p_i) max(0, n_i . w_j) V(p_i, j), the area lights' G = cos cos / d^2 clamped
//!   at the VPL clamp so gather samples next to a light do not become fireflies. Multiple bounces: the
//!   `photons` of a particle pre-pass in the frame (particle tracing as `vpl`, without storing the first
//!   hit) are density-estimated at the gather samples from their `PHOTON_NEIGHBOURS` nearest photons of
//!   a similar normal: E_i += sum Phi_p / (pi r^2). The sample becomes a cosine-emitting light: a VPL
//!   with a Lambertian BSDF of its diffuse coefficient k_d (frame k's) and flux Phi_i = E_i A_i (A_i its
//!   area in that frame), lit from the front side, so I(w) = Phi_i k_d / pi |w . n_g| and the VPL clamp of
//!   `generate_lights` applies. Gather samples whose k_d is 0 in frame 0 (black surfaces, glass, mirrors,
//!   conductors) are left out.
//!
//! Masked surfaces (`mask`, `crate::raytrace::mask`): the direct light's shadow rays toward a gather
//! sample cross masked surfaces toward area points and environment strata with (1 - opacity) each, at most
//! max_depth - 3 of them (the depth of a still scene's VPL after as many null events), and never toward
//! point, spot or directional emitters (Mitsuba reaches those only by emitter sampling, whose shadow rays
//! masks block), as the VPLs of `generate::vpl` pass them; a gather sample on a masked surface of opacity a
//! (at its uv) reflects a times its nested BSDF: its flux is a E_i A_i (k_d the nested BSDF's). The photon
//! pre-pass traces particles through masks as `vpl` does (a photon is stored on a masked surface only when
//! it meets the nested BSDF, so its density carries the factor a already, and only after it met a BSDF
//! before: light that crossed masks only is the direct light above, not counted twice).
//!
//! Order within each frame: delta, area, environment, indirect (as `generate_lights`).
//!
//! Symbols: f frames, k a frame, j a light, E irradiance (W/m^2), Phi flux (W), A area (m^2), k_d diffuse
//! reflectance, L_e emitted radiance, n_e the points of emitter e.
use super::gather::{GatherCloud, GatherOptions};
use super::generate::area::{area_emitters, area_lights_tied, emitting_normal, sphere_uv, AreaEmitter, SurfaceTie, TiedLight};
use super::generate::environment::Environment;
use super::generate::{default_clamp, vpl, GenerateOptions, MAX_LIGHTS};
use super::{scene_sphere, LightKind, LightSet};
use crate::error::{Error, Result};
use crate::raytrace::{offset_p, RayTracer};
use crate::scene::{Scene, ShapeKind};
use crate::shading::bsdf::KIND_DIFFUSE;
use crate::shading::GpuBsdf;
use glam::{Vec2, Vec3};

/// Photons per density estimate (k nearest neighbours).
pub const PHOTON_NEIGHBOURS: usize = 32;
/// Photons count toward a gather sample only if their normals agree to this cosine.
const PHOTON_NORMAL_COS: f32 = 0.7;

/// What `generate_animation_lights` makes.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimationLightOptions {
    /// Oriented points over the area emitters.
    pub area: usize,
    /// Directional lights over the environment.
    pub environment: usize,
    /// Gather samples turned into indirect lights (any count; 0 for none).
    pub indirect: usize,
    /// Photons of the multiple-bounce pre-pass per frame (0: one bounce of indirect light only).
    pub photons: usize,
    /// Mitsuba's max_depth of the photon paths (>= 4 for photons to matter: bounce 2 on).
    pub max_depth: u32,
    /// VPL geometry-term clamp (1/m^2); None = `generate::default_clamp` of frame 0.
    pub clamp: Option<f32>,
    pub seed: u64,
}

impl Default for AnimationLightOptions {
    fn default() -> Self {
        AnimationLightOptions { area: 1024, environment: 0, indirect: 0, photons: 0, max_depth: u32::MAX, clamp: None, seed: 0 }
    }
}

/// One light set per frame and what it holds.
#[derive(Debug, Clone)]
pub struct AnimationLights {
    pub frames: Vec<LightSet>,
    /// Lights of each kind, the same in every frame, in order: delta, area, environment, indirect.
    pub delta: usize,
    pub area: usize,
    pub environment: usize,
    pub indirect: usize,
}

/// The tied area points of frame 0.
struct TiedArea {
    /// Emitter, tie and area share per point.
    ties: Vec<TiedLight>,
}

/// Where a tied area point is in `scene`: (position on the surface, emitting normal, uv), or None when its
/// triangle collapsed to zero area.
fn evaluate_tie(scene: &Scene, tie: &SurfaceTie, frame: usize) -> Result<Option<(Vec3, Vec3, Vec2)>> {
    match *tie {
        SurfaceTie::Triangle { mesh, triangle, b } => {
            // The gather cloud's evaluation of a tied point; the emitting side as `area_emitters` picks it.
            let sp = super::gather::surface_point(scene, mesh, triangle, b).map_err(|e| frame_error(frame, e))?;
            if sp.n_g == Vec3::ZERO {
                return Ok(None);
            }
            let idx = scene.meshes[mesh].indices[triangle as usize].map(|i| i as usize);
            Ok(Some((sp.p, emitting_normal(&scene.meshes[mesh], idx, sp.n_g), sp.uv)))
        }
        SurfaceTie::Sphere { mesh, direction } => {
            let ShapeKind::Sphere { center, radius, flip_normals } = scene.meshes[mesh].kind else {
                return Err(Error::invalid(format!("frame {frame}: shape {mesh} is no longer a sphere")));
            };
            let n = if flip_normals { -direction } else { direction };
            Ok(Some((center + direction * radius, n, sphere_uv(direction))))
        }
    }
}

/// The area points of one frame (module docs).
fn area_frame(scene: &Scene, tied: &TiedArea, areas: &[AreaEmitter], frame0: &LightSet, frame: usize, set: &mut LightSet) -> Result<()> {
    for (j, light) in tied.ties.iter().enumerate() {
        let emitter = &areas[light.emitter];
        match evaluate_tie(scene, &light.tie, frame)? {
            Some((p, n, uv)) => {
                let i0 = emitter.radiance_at(uv) * light.share.area(emitter.area);
                set.push_oriented_point(p, n, i0)?;
            }
            // A collapsed triangle emits nothing; the light keeps frame 0's place.
            None => set.push_oriented_point(frame0.position[j], frame0.normal[j], Vec3::ZERO)?,
        }
    }
    Ok(())
}

/// Irradiance (W/m^2, RGB) from `direct` at a surface point (p, shading normal n, geometric normal n_g), with
/// exact visibility and the oriented points' G clamped at `clamp` (module docs). In a scene with masked
/// surfaces a shadow ray toward an area sample or environment stratum crosses at most `mask_budget` of them
/// with (1 - opacity) each (`cpu::mask_visibility_at`; point, spot and directional emitters are blocked by
/// them); `mask_budget` is unused without masks.
pub(crate) fn irradiance(rt: &RayTracer, direct: &LightSet, p: Vec3, n: Vec3, n_g: Vec3, clamp: f32, mask_budget: u32) -> Vec3 {
    let mut e = Vec3::ZERO;
    for j in 0..direct.len() {
        let Some((wo, mut radiance, dist)) = direct.emitted(j, p, n) else { continue };
        let cos = n.dot(wo);
        if !(cos > 0.0) || wo.dot(n_g) <= 0.0 {
            continue;
        }
        if direct.kind[j] == LightKind::OrientedPoint {
            let g = cos * (-wo.dot(direct.normal[j])) / (dist * dist);
            if g > clamp {
                radiance *= clamp / g;
            }
        }
        if rt.masks().any() {
            e += radiance * cos * crate::cpu::mask_visibility_at(rt, direct, j, p, n_g, wo, dist, mask_budget).0;
        } else if !crate::cpu::light_blocked(rt, direct, j, p, n_g, wo, dist) {
            e += radiance * cos;
        }
    }
    e
}

/// The masked surfaces a direct light's shadow ray toward a one-bounce indirect light (a gather sample) may
/// cross: j with 1 + j <= max_depth - 2, the depth of a VPL stored after j null events
/// (`generate::vpl`); unlimited for `u32::MAX`.
pub(crate) fn gather_mask_budget(max_depth: u32) -> u32 {
    if max_depth == u32::MAX {
        u32::MAX
    } else {
        max_depth.saturating_sub(3)
    }
}

/// Lights for every frame of an animation (module docs). `frames[0]` fixes the area points, the gather
/// cloud and the light count.
///
/// Errors: no frames; counts above `MAX_LIGHTS`; frames whose shapes
/// differ in topology (the frame and shape are named), whose numbers of delta or area emitters differ, or
/// a frame without emitters; what `GatherCloud` and the tracers raise.
pub fn generate_animation_lights(frames: &[&Scene], opts: &AnimationLightOptions) -> Result<AnimationLights> {
    let Some(first) = frames.first() else {
        return Err(Error::invalid("the animation has no frames"));
    };
    for (name, v) in [("area", opts.area), ("environment", opts.environment), ("indirect", opts.indirect), ("photons", opts.photons)] {
        if v > MAX_LIGHTS {
            return Err(Error::invalid(format!("{name} must be at most {MAX_LIGHTS}, got {v}")));
        }
    }
    let clamp = match opts.clamp {
        None => default_clamp(first),
        Some(c) if c > 0.0 => c,
        Some(c) => return Err(Error::invalid(format!("clamp must be > 0 (or infinite for no clamp), got {c}"))),
    };
    let (center, radius) = scene_sphere(first);
    let areas0 = area_emitters(first);
    let (area0, ties) = area_lights_tied(&areas0, opts.area, opts.seed, center, radius)?;
    let tied = TiedArea { ties };
    let delta0 = LightSet::from_scene(first)?.len();
    let cloud0 = if opts.indirect > 0 {
        Some(GatherCloud::new_any_count(first, &GatherOptions { n: opts.indirect, seed: opts.seed, include_emitters: true })?)
    } else {
        None
    };
    // Gather samples that reflect (k_d > 0 in frame 0) become lights.
    let gather_lights: Vec<usize> = match &cloud0 {
        Some(c) => (0..c.len()).filter(|&i| c.k_d[i].max_element() > 0.0).collect(),
        None => Vec::new(),
    };
    let mut out = Vec::with_capacity(frames.len());
    let mut env_count = 0;
    for (k, scene) in frames.iter().enumerate() {
        crate::interrupt::check()?;
        if scene.emitters.is_empty() {
            return Err(Error::invalid(format!("frame {k}: {}: the scene has no emitters", scene.path.display())));
        }
        let mut set = LightSet::from_scene(scene)?;
        if set.len() != delta0 {
            return Err(Error::invalid(format!(
                "frame {k} has {} point/spot/directional emitters but frame 0 has {delta0}: every frame needs the same lights",
                set.len()
            )));
        }
        let (c_k, r_k) = scene_sphere(scene);
        (set.scene_center, set.scene_radius) = (c_k, r_k);
        set.vpl_clamp = clamp;
        let areas = area_emitters(scene);
        if areas.len() != areas0.len() {
            return Err(Error::invalid(format!("frame {k} has {} area emitters but frame 0 has {}", areas.len(), areas0.len())));
        }
        area_frame(scene, &tied, &areas, &area0, k, &mut set)?;
        if let Some(env) = Environment::from_scene(scene) {
            let env_set = env.strata_lights(opts.environment, false, opts.seed, c_k, r_k)?;
            if k == 0 {
                env_count = env_set.len();
            } else if env_set.len() != env_count {
                return Err(Error::invalid(format!("frame {k} has {} environment lights but frame 0 has {env_count}", env_set.len())));
            }
            set.extend(&env_set)?;
        } else if k > 0 && env_count > 0 {
            return Err(Error::invalid(format!("frame {k} has no environment emitter but frame 0 has one")));
        }
        if let Some(cloud0) = &cloud0 {
            let cloud = if k == 0 { cloud0.clone() } else { cloud0.on(scene).map_err(|e| frame_error(k, e))? };
            let rt = RayTracer::new(scene)?;
            let direct = set.clone();
            let photons = if opts.photons > 0 {
                photon_irradiance(scene, &cloud, &gather_lights, opts)?
            } else {
                vec![Vec3::ZERO; gather_lights.len()]
            };
            let budget = gather_mask_budget(opts.max_depth);
            let flux: Vec<Vec3> = crate::interrupt::par_map_chunked(gather_lights.len(), 256, |a| {
                let i = gather_lights[a];
                let (p, n, n_g) = (cloud.position[i], cloud.normal[i], cloud.geo_normal[i]);
                if n == Vec3::ZERO {
                    return Vec3::ZERO;
                }
                // A masked sample reflects a times its nested BSDF (Mitsuba's `mask` eval); photons are
                // stored on it only when they meet the nested BSDF (probability a), so theirs carry a already.
                let opacity = rt.masks().opacity(cloud.shape[i] as usize, cloud.uv[i]).unwrap_or(1.0);
                (irradiance(&rt, &direct, p, n, n_g, clamp, budget) * opacity + photons[a]) * cloud.area[i]
            })?;
            for (a, &i) in gather_lights.iter().enumerate() {
                let mut b: GpuBsdf = bytemuck::Zeroable::zeroed();
                b.kind = KIND_DIFFUSE;
                b.diffuse = cloud.k_d[i].to_array();
                let (n, n_g) = if cloud.normal[i] == Vec3::ZERO {
                    (cloud0.normal[i], cloud0.geo_normal[i])
                } else {
                    (cloud.normal[i], cloud.geo_normal[i])
                };
                let n = if n.dot(n_g) > 0.0 { n } else { n_g };
                set.push_vpl(offset_p(cloud.position[i], n_g, n_g), n, n_g, n_g, flux[a], b)?;
            }
        }
        out.push(set);
    }
    let n_area = tied.ties.len();
    Ok(AnimationLights { frames: out, delta: delta0, area: n_area, environment: env_count, indirect: gather_lights.len() })
}

fn frame_error(k: usize, e: Error) -> Error {
    Error::invalid(format!("frame {k}: {e}"))
}

/// Irradiance at the chosen gather samples from the photons of a particle pre-pass that bounced at least
/// once (module docs), by k-nearest-neighbour density estimation.
fn photon_irradiance(scene: &Scene, cloud: &GatherCloud, chosen: &[usize], opts: &AnimationLightOptions) -> Result<Vec<Vec3>> {
    let areas = area_emitters(scene);
    let env = Environment::from_scene(scene);
    let gen = GenerateOptions {
        area: 0,
        environment: 0,
        indirect: opts.photons,
        max_depth: opts.max_depth,
        clamp: None,
        env_importance: false,
        env_visibility: false,
        seed: opts.seed ^ 0x7068_6f74,
        vsl: None,
        vpl_importance: None,
    };
    let photons = vpl::trace_photons(scene, &areas, env.as_ref(), &gen)?;
    if photons.is_empty() {
        return Ok(vec![Vec3::ZERO; chosen.len()]);
    }
    let tree = super::photon_map::PhotonMap::new(&photons.position);
    crate::interrupt::par_map_chunked(chosen.len(), 256, |a| {
        let i = chosen[a];
        let (p, n) = (cloud.position[i], cloud.normal[i]);
        let (near, r2) = tree.nearest(p, PHOTON_NEIGHBOURS);
        if !(r2 > 0.0) {
            return Vec3::ZERO;
        }
        let mut e = Vec3::ZERO;
        for q in near {
            if photons.geo_normal[q].dot(n) >= PHOTON_NORMAL_COS {
                e += photons.intensity[q];
            }
        }
        e / (std::f32::consts::PI * r2)
    })
}
