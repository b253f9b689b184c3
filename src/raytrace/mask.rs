//! Masked surfaces (Mitsuba 3.9.1's `mask` BSDF, `src/bsdfs/mask.cpp`) as Mitsuba's `path` integrator
//! (`src/integrators/path.cpp`) sees them, for shadow rays and delta chains.
//!
//! Mitsuba's semantics, read from its source and measured with mitsuba 3.9.1 (`scalar_rgb` and
//! `llvm_ad_rgb`, `path` integrator; numbers below):
//! - `mask` is the nested BSDF times the opacity a = clip(eval_1(opacity), 0, 1) (`eval`, and its `pdf`
//!   times a) plus a `BSDFFlags::Null` component: `sample` picks the nested BSDF with probability a (its
//!   weight unchanged, pdf times a) and else passes straight through (`wo = -wi`, weight 1, pdf 1 - a).
//!   `Null` is part of `BSDFFlags::Delta`, so an emitter hit after a null event has MIS weight 1.
//! - Shadow rays of emitter sampling (`sample_emitter_direction(.., test_visibility = true)`,
//!   `Scene::ray_test`) ignore BSDFs: a masked surface blocks them whatever its opacity. Light crosses a
//!   masked surface only along BSDF-sampled paths, and every null event is one unit of `max_depth`
//!   (`depth += 1` for every valid interaction). So a light behind j masked surfaces reaches a point
//!   reached after k bounces only when k + 1 + j < max_depth, and then with the factor prod(1 - a_l)
//!   (the BSDF-sampled hit is not MIS-weighted); a delta emitter (point, spot, directional) never does
//!   (BSDF sampling cannot hit it). Measured (a floor under a 1.2 x 1.2 quad of opacity 0.5 one unit
//!   above it, a 0.4 x 0.4 area light two units above, 16 x 16, 4096 spp, mean over the pixels the
//!   opaque quad shadows fully, relative to no quad; `scalar_rgb` / `llvm_ad_rgb`): max_depth 2: 0.0009 /
//!   0.0009 (the opaque quad's value), 3: 0.493 / 0.527, 4: 0.4905 / 0.527, -1: 0.4905 / 0.527 (only
//!   BSDF samples find the small light: about 3% noise); with a point light instead, 0.006 at every depth
//!   (`scalar_rgb`; the opaque quad's value). Camera looking down at the quad over the lit floor, the light
//!   beside it (`llvm_ad_rgb`, pixels on the quad): 0.04476 at max_depth 2 (0.5 x the opaque quad's
//!   0.08953: the floor behind is reached at depth 1 and samples no emitter), 0.06360 at 3 (plus the floor
//!   behind, lit except through the quad), 0.07077 at 4 and -1 (plus the light through the quad onto it);
//!   0.5 x quad + 0.5 x bare floor would be 0.07886.
//! - `valid_ray` (path.cpp): the path's value is discarded unless some vertex drew a non-null BSDF
//!   sample (or the scene has an environment emitter). Everything the path gathered is dropped, including
//!   the emitter-sampled light at the masked surface itself. The two CPU variants differ here: in
//!   `llvm_ad_rgb` (the variant of the stored references) the loop body runs once more for a lane whose
//!   `active_next` is false and still draws that last vertex's BSDF sample, so a path is discarded only
//!   when it escapes after null events only (or its last vertex also samples the null lobe); in
//!   `scalar_rgb` the early exit skips that sample, and a path ending on a non-emitting surface after
//!   null events only is discarded as well. Measured (the camera and quad above, max_depth 2, 16 x 16,
//!   4096 spp, pixels on the quad, relative to an opaque quad): opacity 0.75 / 0.5 / 0.25 give 0.7500 / 0.5000 / 0.2500 with
//!   `llvm_ad_rgb` and 0.5626 / 0.2509 / 0.0624 (about a^2) with `scalar_rgb`; `direct` gives a in both.
//!   This module follows `llvm_ad_rgb`.
//!
//! The expected factor on a masked vertex's emitter-sampled light is therefore
//! P_valid = a + (1 - a) P_next, where P_next is 1 for an unmasked surface behind, a' + (1 - a') P_next'
//! for a masked one of opacity a' that samples its BSDF (an active vertex: k + 1 < max_depth), a' for a
//! masked last vertex, 0 for an escape, and P_valid = 1 with an environment emitter in the scene.
//! `crate::view::chains` records it per masked view sample, and [`direct_factor`] applies it to the
//! emitter-sampled part of the direct light (P w_L + w_B with path.cpp's power heuristic); VPLs (reached by
//! BSDF sampling, which makes the path valid) are not scaled. Deviation: p_B is this crate's
//! `sampling::pdf_bsdf` (Mitsuba's for diffuse; its own proposal for rough lobes), and a sphere emitter's
//! p_L is the area density (Mitsuba samples its visible cone). Exact when P_valid = 1 (a surface or an
//! environment behind every masked pixel).
//!
//! VPLs (`cpu::mask_visibility_at`): a VPL stored at depth d (`LightSet::vpl_depth`) stands for d more
//! vertices on the way back to the light, the last of which samples it, so from a view sample of budget b
//! its shadow ray crosses at most b - d masks and none reaches a sample with b < d (a surface seen through a
//! mask at max_depth 3 gets no VPL light). Direct-to-indirect relighting's gather samples follow the same
//! rule as first-bounce VPLs (`relight::transfer`).
//!
//! Glossy view samples (`matrix::glossy`): light through a mask reaches Mitsuba only by BSDF sampling,
//! with MIS weight 1, and the glossy BSDF rays stop at masks, so `cpu::shade` gives a light column whose
//! shadow ray crossed a mask its full value (w_L divided out).
//!
//! GPU backend (`crate::gpu::mask`, `shaders/common/mask.wgsl`): the same rules per element. A shadow ray
//! toward a light that may cross masks, from a sample with budget left, is an exact closest-hit walk over
//! the GPU BVH (the loop of [`RayTracer::mask_transmittance_crossed`], opacities from a mask table of
//! constants, per-triangle uvs and the opacity textures); every other shadow test is the GPU's usual one
//! (shadow maps hold masked surfaces as opaque, which is what emitter sampling sees). In hybrid and
//! shadow-map visibility a map that is certain the segment is empty answers 1 without a ray. P_valid, the
//! opacity and the budget travel in the view samples, the area-emitter density and whether a light
//! crosses masks in the light records. Not ported: the BSDF-sampling density of a bump or normal map inside a
//! mask (`direct_factor`'s w_B), which the loader refuses; a scene built in code with one stays on the CPU
//! (`matrix::backend::gpu_unsupported`).
//!
//! Validation (`tests/scene/test_mask.py`, `tests/data/mask_leaves.xml`: quads of opacity 0.5 and a
//! 0.1 / 0.85 checkerboard over a floor, an area light, 64 x 48, pixel-centre `llvm_ad_rgb` references):
//! the brute-force light matrix is within 0.402% / 0.398% / 0.218% relative L2 of the references at
//! max_depth -1 / 3 / 2, whose own noise is 0.400% / 0.399% / 0.200%.
use super::{offset_p, spawn_ray, spawn_ray_to, RayTracer};
use crate::lights::{LightKind, LightSet};
use crate::scene::texture::eval_param_1;
use crate::scene::{Bsdf, Emitter, Param, Scene, Texture};
use crate::view::ViewSamples;
use glam::{Vec2, Vec3};

/// Mitsuba's area-emitter sampling density per mesh, `ViewSamples::mask_emitter_pdf`: 1 / (A N) for a
/// mesh with an area emitter (A its world-space area: the triangles' sum, 4 pi r^2 for a sphere; N the
/// scene's emitter count, Mitsuba's uniform emitter selection), 0 for the others.
pub fn emitter_area_pdfs(scene: &Scene) -> Vec<f32> {
    let n = scene.emitters.len().max(1) as f32;
    let mut out = vec![0f32; scene.meshes.len()];
    for e in &scene.emitters {
        let Emitter::Area { mesh, .. } = e else { continue };
        let Some(m) = scene.meshes.get(*mesh) else { continue };
        let area: f64 = match &m.kind {
            crate::scene::ShapeKind::Sphere { radius, .. } => 4.0 * std::f64::consts::PI * (*radius as f64).powi(2),
            _ => m
                .indices
                .iter()
                .map(|t| {
                    let p = t.map(|k| m.positions[k as usize].as_dvec3());
                    0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
                })
                .sum(),
        };
        if area > 0.0 {
            out[*mesh] = (1.0 / (area * n as f64)) as f32;
        }
    }
    out
}

/// The factor on light j's direct contribution to masked view sample i whose `valid_ray` factor is
/// P = `ViewSamples::mask_valid[i]` < 1 (module docs): Mitsuba drops only the emitter-sampled part, so
/// the factor is P w_L + w_B = P + (1 - P) w_B with the power heuristic w_B = p_B^2 / (p_B^2 + p_L^2) of
/// path.cpp: p_B = a * pdf_nested(wi, wo) (the mask's pdf; `sampling::pdf_bsdf`, Mitsuba's cosine pdf
/// for diffuse), p_L = `mask_emitter_pdf` d^2 / cos_l toward an area-light sample (`OrientedPoint` with
/// `mis_mesh`); w_B = 0 for every other light (delta emitters: BSDF sampling never hits them).
/// `wi_local`, `wo_local`: unit directions in the sample's shading frame; `p` its position.
pub fn direct_factor(view: &ViewSamples, lights: &LightSet, i: usize, p: Vec3, wi_local: Vec3, wo_local: Vec3, j: usize) -> f32 {
    let valid = view.mask_valid.get(i).copied().unwrap_or(1.0);
    let mut w_b = 0.0;
    if lights.kind[j] == LightKind::OrientedPoint {
        let pa = usize::try_from(lights.mis_mesh[j]).ok().and_then(|k| view.mask_emitter_pdf.get(k)).copied().unwrap_or(0.0);
        let d = lights.position[j] - p;
        let dist2 = d.length_squared();
        let cos_l = -d.dot(lights.normal[j]) / dist2.sqrt();
        if pa > 0.0 && cos_l > 0.0 {
            let p_l = pa * dist2 / cos_l;
            let a = view.mask_opacity.get(i).copied().unwrap_or(1.0);
            let p_b = a * crate::lights::generate::sampling::pdf_bsdf(&view.bsdf[i], wi_local, wo_local);
            let (b2, l2) = (p_b * p_b, p_l * p_l);
            if b2 + l2 > 0.0 && (b2 / (b2 + l2)).is_finite() {
                w_b = b2 / (b2 + l2);
            }
        }
    }
    valid + (1.0 - valid) * w_b
}

/// The masks of a scene: each mesh's opacity parameter (None = not masked) and the textures they read.
#[derive(Debug, Clone, Default)]
pub struct Masks {
    /// Per `Scene::meshes` index.
    pub opacity: Vec<Option<Param>>,
    /// The scene's textures (kept only when some mesh is masked).
    pub textures: Vec<Texture>,
    /// Whether the scene has an environment emitter (envmap, constant): Mitsuba's `valid_ray` starts true.
    pub environment: bool,
    /// Whether a `Directional` light of a `LightSet` is an environment stratum (lets light through masks):
    /// the scene has an environment emitter and no directional emitter.
    pub directional_is_environment: bool,
}

/// The opacity parameter of scene BSDF `index` when it is a `mask` or a `twosided` around one.
pub fn mask_opacity_param(bsdfs: &[Bsdf], index: usize) -> Option<&Param> {
    match bsdfs.get(index)? {
        Bsdf::Mask { opacity, .. } => Some(opacity),
        Bsdf::TwoSided { front, .. } if *front != index => match bsdfs.get(*front)? {
            Bsdf::Mask { opacity, .. } => Some(opacity),
            _ => None,
        },
        _ => None,
    }
}

/// Whether any mesh of the scene has a masked BSDF.
pub fn scene_has_masks(scene: &Scene) -> bool {
    scene.meshes.iter().any(|m| mask_opacity_param(&scene.bsdfs, m.bsdf).is_some())
}

/// Mitsuba's opacity `clip(eval_1(opacity, uv), 0, 1)`.
pub fn eval_opacity(textures: &[Texture], p: &Param, uv: Vec2) -> f32 {
    let a = eval_param_1(textures, p, uv);
    if a.is_nan() {
        0.0
    } else {
        a.clamp(0.0, 1.0)
    }
}

impl Masks {
    /// The masks of `scene` (empty `opacity` when it has none).
    pub fn new(scene: &Scene) -> Masks {
        if !scene_has_masks(scene) {
            return Masks::default();
        }
        let environment = scene.emitters.iter().any(|e| matches!(e, Emitter::EnvMap { .. } | Emitter::Constant { .. }));
        let directional = scene.emitters.iter().any(|e| matches!(e, Emitter::Directional { .. }));
        Masks {
            opacity: scene.meshes.iter().map(|m| mask_opacity_param(&scene.bsdfs, m.bsdf).copied()).collect(),
            textures: scene.textures.clone(),
            environment,
            directional_is_environment: environment && !directional,
        }
    }

    /// Whether any mesh is masked.
    pub fn any(&self) -> bool {
        !self.opacity.is_empty()
    }

    /// The opacity of mesh `mesh` at `uv`, None when it is not masked.
    pub fn opacity(&self, mesh: usize, uv: Vec2) -> Option<f32> {
        let p = self.opacity.get(mesh)?.as_ref()?;
        Some(eval_opacity(&self.textures, p, uv))
    }
}

impl RayTracer {
    /// The scene's masks (`Masks::any` is false without).
    pub fn masks(&self) -> &Masks {
        &self.masks
    }

    /// Expected transmittance of a shadow ray from surface point `p` (geometric normal `n_g`) toward
    /// point `q` (`Some`) or along unit direction `d` to infinity (`q` None) that may pass at most
    /// `budget` masked surfaces (module docs): prod(1 - a) over the masked surfaces crossed, 0 when a
    /// surface without a mask, or more than `budget` masked ones, lie on it. Rays as
    /// [`RayTracer::occluded`] / `spawn_ray`; each crossing continues from the hit with Mitsuba's
    /// `spawn_ray_to` / `spawn_ray` offsets.
    pub fn mask_transmittance(&self, p: Vec3, n_g: Vec3, q: Option<Vec3>, d: Vec3, budget: u32) -> f32 {
        self.mask_transmittance_crossed(p, n_g, q, d, budget).0
    }

    /// [`RayTracer::mask_transmittance`] and whether the ray crossed at least one masked surface (then
    /// only Mitsuba's BSDF sampling reaches the light, with MIS weight 1).
    pub fn mask_transmittance_crossed(&self, p: Vec3, n_g: Vec3, q: Option<Vec3>, d: Vec3, budget: u32) -> (f32, bool) {
        let (mut o, mut dir, mut t_max) = match q {
            Some(q) => spawn_ray_to(p, n_g, q),
            None => (spawn_ray(p, n_g, d), d, f32::INFINITY),
        };
        let mut tr = 1.0f32;
        let mut left = budget;
        // Bounded: each step moves past one hit; a pathological scene stops after this many.
        for _ in 0..1024 {
            let Some(si) = self.intersect(o, dir, 0.0, t_max) else {
                return (tr, left != budget);
            };
            let Some(a) = self.masks.opacity(si.mesh, si.uv) else {
                return (0.0, false);
            };
            if left == 0 {
                return (0.0, false);
            }
            left -= 1;
            tr *= 1.0 - a;
            if tr <= 0.0 {
                return (0.0, false);
            }
            match q {
                Some(q) => (o, dir, t_max) = spawn_ray_to(si.p, si.n_g, q),
                None => o = offset_p(si.p, si.n_g, dir),
            }
        }
        (0.0, false)
    }
}

#[cfg(test)]
mod tests;
