//! LightSet: the typed point-like lights that are the columns of the light matrix.
//!
//! Struct-of-arrays: `kind[j]`, `position[j]`, `direction[j]`, `intensity[j]` ... describe light j.
//! Kinds: `Point`, `Spot`, `Directional` (the scene's `point`, `spot`, `directional` emitters, and the
//! strata of environment maps), `OrientedPoint` (samples of area emitters) and `Vpl` (virtual point
//! lights from particle tracing); `generate` makes the last three from a scene (`generate_lights`).
//!
//! Emission (what `emitted(j, p, n)` returns: wo toward the light, a radiance factor F and the distance;
//! the receiver multiplies F by its `bsdf_eval(wi, wo)`, i.e. f_r |cos theta_r|). Delta lights follow
//! Mitsuba 3.9.1 (`src/emitters/{point,spot,directional}.cpp`):
//! - point: F = I / d^2, wo = (position - p) / d.
//! - spot: I * falloff(theta) / d^2, theta = angle between the light's +z axis and (p - position):
//!   falloff = 1 if cos(theta) >= cos(beam_width), (cutoff_angle - theta) / (cutoff_angle - beam_width)
//!   otherwise, and 0 unless cos(theta) > cos(cutoff_angle) (Mitsuba's `falloff_curve`).
//!   A projected `texture` (`spot_texture`) multiplies I by its value at Mitsuba's `direction_to_uv`.
//! - directional: F = E (irradiance at normal incidence), wo = -direction.
//! - oriented point (a piece of area A_k of an emitter of radiance L, `intensity` I0 = L A_k in W/sr):
//!   I(w) = I0 max(0, cos theta), theta between `normal` and w = (p - position) / d; F = I(w) / d^2.
//!   With a `patch` (the piece of the emitter the point stands for) and p within a few patch radii,
//!   F = I0 PSA / (A |cos_r|) instead: the projected solid angle of the part of the patch on the
//!   light's side of the receiver's plane (either side: `twosided` receivers are lit from their back),
//!   no 1 / d^2 spike (`patch` module; the rule, its unbiasedness and its deviation for glossy
//!   receivers are documented there).
//! - VPL (`intensity` = Phi, W): a particle that arrived at the VPL from direction `incident` (unit,
//!   pointing from the VPL back toward where the particle came from) with flux Phi (already multiplied
//!   by the shading-normal correction |incident . n_s| / |incident . n_g|). Its radiant intensity toward
//!   w = (p - position) / d is
//!       I(w) = Phi f(incident, w) |w . n_g|        (W/sr)
//!   with f the VPL's BSDF (`bsdf[j]`, evaluated by `shading::bsdf::eval` in the frame of `normal` = n_s:
//!   `eval(incident, w) / |w . n_s| = f`; Mitsuba's BSDFs here are reciprocal so the order does not matter),
//!   zero unless `incident` and w lie on the same side of the geometric normal n_g (`geo_normal`).
//!   F = I(w) / d^2, scaled by min(1, clamp / G) with G = |w . n_g| |wo . n| / d^2 the geometry term
//!   (n = the receiver's shading normal): the VPL contribution becomes Phi f_v f_r min(G, clamp),
//!   the usual bound of the 1 / d^2 singularity (`vpl_clamp`, infinite = no clamp).
//!   A VPL with `vsl_radius` r > 0 is a virtual spherical light instead (`vsl` module): not clamped,
//!   F = `vsl::spread(I(w), |w . n_g|, |wo . n|, d^2, r)`, which tends to I(w) / d^2 for d >> r; shading
//!   sites integrate the receiver's lobe over the sphere's cap instead (`shade_receiver`).
//!
//! `power()` (W): point 4 pi I; spot I * 2 pi (1 - (sin c - sin b) / (c - b)) with c = cutoff_angle,
//! b = beam_width (the exact integral of Mitsuba's falloff over the sphere, i.e. the mean weight of its
//! `sample_ray`; 2 pi (1 - cos c) when b = c; with a projected texture, the integral of falloff times
//! texture by quadrature, `spot_texture::spot_power_textured`); directional E * pi r^2 with r the radius of the scene's
//! bounding sphere (half the bounding-box diagonal): the power crossing the scene's bounding disk;
//! oriented point pi I0; VPL the reflected flux Phi * rho(incident), rho = integral of f |w . n_g| over
//! the sphere, by a fixed 32 x 32 stratified cosine-weighted quadrature (exact for diffuse).
//! Powers are per RGB channel; `power_luminance()` gives a scalar (mean of the channels).
//!
//! Deviation: a spot `world_from_light` must be a rotation times a uniform scale (plus translation);
//! shear or non-uniform scale (which would distort Mitsuba's cone) is an error.
//!
//! Rust twin of `shaders/common/light.wgsl` (`light_emitted`), used by the CPU reference.
pub mod animated;
pub mod arrays;
mod emission;
pub mod gather;
pub mod generate;
pub mod light_tree;
pub mod patch;
pub mod photon_map;
pub mod spot_texture;
pub mod vsl;

pub use arrays::LightArrays;
pub use generate::{generate_lights, GenerateOptions, VplImportance, VslOptions};

use crate::error::{Error, Result};
use crate::scene::{Emitter, Scene};
use crate::shading::GpuBsdf;
use glam::Vec3;

/// Light types. Values are shared with `shaders/common/light.wgsl` (`LIGHT_*`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightKind {
    Point = 0,
    Spot = 1,
    Directional = 2,
    /// A piece of an area emitter: cosine lobe around `normal`.
    OrientedPoint = 3,
    /// Virtual point light: a particle's flux reflected by the BSDF at its hit.
    Vpl = 4,
}

/// A set of delta lights, struct of arrays.
#[derive(Debug, Clone, Default)]
pub struct LightSet {
    pub kind: Vec<LightKind>,
    /// World position (point, spot); zero for directional.
    pub position: Vec<Vec3>,
    /// Unit vector: spot axis (local +z in world); directional: the direction the light travels; point: 0.
    pub direction: Vec<Vec3>,
    /// Intensity I in W/sr (point, spot), irradiance E in W/m^2 (directional), I0 in W/sr (oriented
    /// point: intensity along its normal), flux Phi in W (VPL); RGB.
    pub intensity: Vec<Vec3>,
    /// Unit emission normal (oriented point), shading normal n_s (VPL); 0 for other kinds.
    pub normal: Vec<Vec3>,
    /// Unit geometric normal n_g (VPL; oriented point: equal to `normal`); 0 for other kinds.
    pub geo_normal: Vec<Vec3>,
    /// VPL: unit direction from the VPL toward where its particle came from; 0 for other kinds.
    pub incident: Vec<Vec3>,
    /// VPL: the BSDF at its hit (resolved, textures evaluated); `GpuBsdf::zeroed()` for other kinds.
    pub bsdf: Vec<GpuBsdf>,
    /// Spot cutoff angle (radians); 0 for other kinds.
    pub cutoff_angle: Vec<f32>,
    /// Spot beam width (radians); 0 for other kinds.
    pub beam_width: Vec<f32>,
    /// Spot: its projected texture (`spot_texture` module), multiplying the intensity; None otherwise.
    pub spot_texture: Vec<Option<std::sync::Arc<spot_texture::SpotTexture>>>,
    /// Centre and radius of the scene's bounding sphere (directional power and shadow-map fitting).
    pub scene_center: Vec3,
    pub scene_radius: f32,
    /// Oriented point: the piece of its area emitter it stands for (4 corners of a planar convex
    /// quadrilateral, `patch` module), used in the near field; all zero = none (other kinds too).
    pub patch: Vec<[Vec3; 4]>,
    /// VPL: the radius r (m) of its virtual spherical light (`vsl` module), 0 = a point VPL (then the
    /// clamp applies); 0 for other kinds.
    pub vsl_radius: Vec<f32>,
    /// VPL: its depth d >= 1, the bounce at which its particle was stored (`generate::vpl`: Mitsuba's depth
    /// of its vertex, null events through masks included); 1 for VPLs made otherwise (`push_vpl`,
    /// `from_arrays` without it); 0 for other kinds. In a scene with masked surfaces a VPL's shadow ray from a
    /// view sample of mask budget b crosses at most b - d masks, and none reaches a sample with b < d
    /// (`cpu::mask_visibility_at`).
    pub vpl_depth: Vec<u32>,
    /// Bound on the VPL geometry term G = cos cos / d^2 (1/m^2); `f32::INFINITY` = no clamp. VSLs
    /// (`vsl_radius > 0`) are not clamped.
    pub vpl_clamp: f32,
    /// The sampling measure of light j for glossy MIS (`matrix::glossy`): the area (m^2) of the
    /// equal-area stratum an area-light sample stands for (its emitter's area / its count), the solid
    /// angle (sr) of a uniform environment stratum; 0 = not a sample of an emitter BSDF sampling can hit
    /// (delta lights, VPLs, user-made lights, importance-allocated environment strata, subsets).
    pub mis_measure: Vec<f32>,
    /// The `Scene::meshes` index of the emitter an area-light sample was drawn on (`mis_measure` > 0);
    /// -1 otherwise.
    pub mis_mesh: Vec<i32>,
}

fn check_vec(what: &str, j: usize, v: Vec3, nonneg: bool) -> Result<()> {
    if !v.is_finite() || (nonneg && v.min_element() < 0.0) {
        return Err(Error::invalid(format!(
            "light {j}: {what} must be finite{}, got {v:?}",
            if nonneg { " and non-negative" } else { "" }
        )));
    }
    Ok(())
}

impl LightSet {
    /// An empty set for the scene whose bounding sphere is (center, radius).
    /// Reserve room for `additional` more lights in every array at once, exactly (no doubling), failing
    /// with `OutOfMemory` instead of aborting the process when the allocator refuses (an address-space
    /// or data limit that other threads' allocations used up after `memory::check_host` passed).
    pub fn try_reserve(&mut self, additional: usize) -> Result<()> {
        let fail = |e: std::collections::TryReserveError| {
            Error::OutOfMemory(format!("LightSet: room for {additional} more lights could not be allocated ({e})"))
        };
        macro_rules! reserve {
            ($($f:ident),*) => { $( self.$f.try_reserve_exact(additional).map_err(fail)?; )* };
        }
        reserve!(
            kind,
            position,
            direction,
            intensity,
            normal,
            geo_normal,
            incident,
            bsdf,
            cutoff_angle,
            beam_width,
            spot_texture,
            patch,
            vsl_radius,
            vpl_depth,
            mis_measure,
            mis_mesh
        );
        Ok(())
    }

    pub fn new(scene_center: Vec3, scene_radius: f32) -> Self {
        LightSet { scene_center, scene_radius, vpl_clamp: f32::INFINITY, ..Default::default() }
    }

    /// The scene's point, spot and directional emitters, in `Scene::emitters` order (others are skipped).
    pub fn from_scene(scene: &Scene) -> Result<LightSet> {
        let (center, radius) = scene_sphere(scene);
        let mut set = LightSet::new(center, radius);
        for e in &scene.emitters {
            let r = match e {
                Emitter::Point { position, intensity, loc } => {
                    set.push_point(*position, *intensity).map_err(|err| Error::scene(loc, err.to_string()))
                }
                Emitter::Spot { world_from_light, intensity, cutoff_angle, beam_width, texture, loc } => {
                    let m = glam::Mat3::from_mat4(*world_from_light);
                    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
                    let s = z.length();
                    let tol = 1e-4 * s.max(1e-20);
                    if !(s > 0.0)
                        || (x.length() - s).abs() > tol
                        || (y.length() - s).abs() > tol
                        || x.dot(y).abs() > tol * s
                        || x.dot(z).abs() > tol * s
                        || y.dot(z).abs() > tol * s
                    {
                        return Err(Error::scene(loc, format!("spot to_world must be a rotation with uniform scale, got {m:?}")));
                    }
                    let position = world_from_light.w_axis.truncate();
                    let r = set.push_spot(position, z / s, *intensity, *cutoff_angle, *beam_width);
                    if let (Ok(()), Some(t)) = (&r, texture) {
                        let tex = spot_texture::SpotTexture {
                            x_axis: x / s,
                            y_axis: y / s,
                            tan_cutoff: cutoff_angle.tan(),
                            texture: std::sync::Arc::new(scene.textures[*t].clone()),
                        };
                        *set.spot_texture.last_mut().unwrap() = Some(std::sync::Arc::new(tex));
                    }
                    r.map_err(|err| Error::scene(loc, err.to_string()))
                }
                Emitter::Directional { direction, irradiance, loc } => {
                    set.push_directional(*direction, *irradiance).map_err(|err| Error::scene(loc, err.to_string()))
                }
                _ => Ok(()),
            };
            r?;
        }
        Ok(set)
    }

    pub fn len(&self) -> usize {
        self.kind.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kind.is_empty()
    }

    fn push(&mut self, kind: LightKind, position: Vec3, direction: Vec3, intensity: Vec3, cutoff: f32, beam: f32) {
        self.kind.push(kind);
        self.position.push(position);
        self.direction.push(direction);
        self.intensity.push(intensity);
        self.cutoff_angle.push(cutoff);
        self.beam_width.push(beam);
        self.spot_texture.push(None);
        self.normal.push(Vec3::ZERO);
        self.geo_normal.push(Vec3::ZERO);
        self.incident.push(Vec3::ZERO);
        self.bsdf.push(bytemuck::Zeroable::zeroed());
        self.patch.push([Vec3::ZERO; 4]);
        self.vsl_radius.push(0.0);
        self.vpl_depth.push(0);
        self.mis_measure.push(0.0);
        self.mis_mesh.push(-1);
    }

    /// Mark light j as a sample of an emitter for glossy MIS (`mis_measure`, `mis_mesh`; generation only).
    pub(crate) fn set_mis(&mut self, j: usize, measure: f32, mesh: i32) {
        self.mis_measure[j] = if measure.is_finite() && measure > 0.0 { measure } else { 0.0 };
        self.mis_mesh[j] = mesh;
    }

    /// Give oriented point j its patch (`patch` module; all-zero corners = none).
    ///
    /// Errors: `InvalidParameter` for another kind, non-finite corners or a patch of zero area.
    pub fn set_patch(&mut self, j: usize, corners: [Vec3; 4]) -> Result<()> {
        patch::check(j, &corners)?;
        if self.kind[j] != LightKind::OrientedPoint && !patch::is_none(&corners) {
            return Err(Error::invalid(format!("light {j}: only oriented points have a patch, got a {:?}", self.kind[j])));
        }
        self.patch[j] = corners;
        Ok(())
    }

    /// Add an oriented point light: I(w) = I0 max(0, cos theta) around the unit `normal`; I0 in W/sr.
    pub fn push_oriented_point(&mut self, position: Vec3, normal: Vec3, intensity: Vec3) -> Result<()> {
        let j = self.len();
        check_vec("position", j, position, false)?;
        check_vec("intensity", j, intensity, true)?;
        let n = unit("normal", j, normal)?;
        self.push(LightKind::OrientedPoint, position, Vec3::ZERO, intensity, 0.0, 0.0);
        self.normal[j] = n;
        self.geo_normal[j] = n;
        Ok(())
    }

    /// Add a VPL (formula in the module docs): flux Phi (W), shading normal `n_s`, geometric normal
    /// `n_g`, `incident` (unit, toward where the particle came from) and the BSDF at the hit.
    pub fn push_vpl(&mut self, position: Vec3, n_s: Vec3, n_g: Vec3, incident: Vec3, flux: Vec3, bsdf: GpuBsdf) -> Result<()> {
        let j = self.len();
        check_vec("position", j, position, false)?;
        check_vec("flux", j, flux, true)?;
        let (n_s, n_g, incident) = (unit("n_s", j, n_s)?, unit("n_g", j, n_g)?, unit("incident", j, incident)?);
        self.push(LightKind::Vpl, position, Vec3::ZERO, flux, 0.0, 0.0);
        self.normal[j] = n_s;
        self.geo_normal[j] = n_g;
        self.incident[j] = incident;
        self.bsdf[j] = bsdf;
        self.vpl_depth[j] = 1;
        Ok(())
    }

    /// Set VPL j's depth (`vpl_depth`).
    ///
    /// Errors: `InvalidParameter` for another kind or a depth of 0.
    pub fn set_vpl_depth(&mut self, j: usize, depth: u32) -> Result<()> {
        if self.kind[j] != LightKind::Vpl || depth == 0 {
            return Err(Error::invalid(format!(
                "light {j}: vpl_depth must be >= 1 and only VPLs have one, got {depth} for a {:?}",
                self.kind[j]
            )));
        }
        self.vpl_depth[j] = depth;
        Ok(())
    }

    /// Append every light of `other` (same scene sphere expected; `vpl_clamp` is kept from `self`).
    ///
    /// Errors: `OutOfMemory` when the room cannot be allocated (`try_reserve`).
    pub fn extend(&mut self, other: &LightSet) -> Result<()> {
        self.try_reserve(other.len())?;
        self.kind.extend_from_slice(&other.kind);
        self.position.extend_from_slice(&other.position);
        self.direction.extend_from_slice(&other.direction);
        self.intensity.extend_from_slice(&other.intensity);
        self.cutoff_angle.extend_from_slice(&other.cutoff_angle);
        self.beam_width.extend_from_slice(&other.beam_width);
        self.spot_texture.extend_from_slice(&other.spot_texture);
        self.normal.extend_from_slice(&other.normal);
        self.geo_normal.extend_from_slice(&other.geo_normal);
        self.incident.extend_from_slice(&other.incident);
        self.bsdf.extend_from_slice(&other.bsdf);
        self.patch.extend_from_slice(&other.patch);
        self.mis_measure.extend_from_slice(&other.mis_measure);
        self.mis_mesh.extend_from_slice(&other.mis_mesh);
        self.vsl_radius.extend_from_slice(&other.vsl_radius);
        self.vpl_depth.extend_from_slice(&other.vpl_depth);
        Ok(())
    }

    /// Make VPL j a virtual spherical light of radius `r` (m; `vsl` module), or a point VPL with r = 0.
    ///
    /// Errors: `InvalidParameter` for another kind with r != 0, or r NaN, infinite or negative.
    pub fn set_vsl_radius(&mut self, j: usize, r: f32) -> Result<()> {
        if !(r >= 0.0 && r.is_finite()) {
            return Err(Error::invalid(format!("vsl_radius[{j}] must be finite and >= 0 (m; 0 = a point VPL), got {r}")));
        }
        if r != 0.0 && self.kind[j] != LightKind::Vpl {
            return Err(Error::invalid(format!("light {j}: only VPLs have a vsl_radius, got a {:?} with radius {r}", self.kind[j])));
        }
        self.vsl_radius[j] = r;
        Ok(())
    }

    /// Add an isotropic point light of intensity I (W/sr).
    pub fn push_point(&mut self, position: Vec3, intensity: Vec3) -> Result<()> {
        let j = self.len();
        check_vec("position", j, position, false)?;
        check_vec("intensity", j, intensity, true)?;
        self.push(LightKind::Point, position, Vec3::ZERO, intensity, 0.0, 0.0);
        Ok(())
    }

    /// Add a spot light at `position` pointing along `axis`; angles in radians,
    /// 0 <= beam_width <= cutoff_angle <= pi.
    pub fn push_spot(&mut self, position: Vec3, axis: Vec3, intensity: Vec3, cutoff_angle: f32, beam_width: f32) -> Result<()> {
        let j = self.len();
        check_vec("position", j, position, false)?;
        check_vec("intensity", j, intensity, true)?;
        check_vec("axis", j, axis, false)?;
        if axis.length() < 1e-12 {
            return Err(Error::invalid(format!("light {j}: spot axis must be non-zero, got {axis:?}")));
        }
        if !(cutoff_angle > 0.0 && cutoff_angle <= std::f32::consts::PI) {
            return Err(Error::invalid(format!("light {j}: spot cutoff_angle must be in (0, pi], got {cutoff_angle}")));
        }
        if !(beam_width >= 0.0 && beam_width <= cutoff_angle) {
            return Err(Error::invalid(format!(
                "light {j}: spot beam_width must be in [0, cutoff_angle = {cutoff_angle}], got {beam_width}"
            )));
        }
        self.push(LightKind::Spot, position, axis.normalize(), intensity, cutoff_angle, beam_width);
        Ok(())
    }

    /// Add a directional light travelling along `direction` with irradiance E (W/m^2).
    pub fn push_directional(&mut self, direction: Vec3, irradiance: Vec3) -> Result<()> {
        let j = self.len();
        check_vec("direction", j, direction, false)?;
        check_vec("irradiance", j, irradiance, true)?;
        if direction.length() < 1e-12 {
            return Err(Error::invalid(format!("light {j}: direction must be non-zero, got {direction:?}")));
        }
        self.push(LightKind::Directional, Vec3::ZERO, direction.normalize(), irradiance, 0.0, 0.0);
        Ok(())
    }

    /// Emitted power of light j per RGB channel (W); formulas in the module docs.
    pub fn power(&self, j: usize) -> Vec3 {
        let i = self.intensity[j];
        match self.kind[j] {
            LightKind::Point => i * (4.0 * std::f32::consts::PI),
            LightKind::Spot => match &self.spot_texture[j] {
                Some(t) => i * spot_texture::spot_power_textured(t, self.cutoff_angle[j], self.beam_width[j]),
                None => i * spot_solid_angle(self.cutoff_angle[j], self.beam_width[j]),
            },
            LightKind::Directional => i * (std::f32::consts::PI * self.scene_radius * self.scene_radius),
            LightKind::OrientedPoint => i * std::f32::consts::PI,
            LightKind::Vpl => i * vpl_reflectance(&self.bsdf[j], self.normal[j], self.geo_normal[j], self.incident[j]),
        }
    }

    /// `power(j)` of every light, computed in parallel (VPLs on glossy BSDFs need a quadrature each).
    pub fn powers(&self) -> Vec<Vec3> {
        use rayon::prelude::*;
        (0..self.len()).into_par_iter().map(|j| self.power(j)).collect()
    }

    /// Scalar power (mean of the RGB channels) of every light.
    pub fn power_luminance(&self) -> Vec<f32> {
        self.powers().iter().map(|p| p.element_sum() / 3.0).collect()
    }
}

/// Centre and radius of the scene's bounding sphere (half the bounding-box diagonal); (0, 0) without
/// geometry.
pub fn scene_sphere(scene: &Scene) -> (Vec3, f32) {
    let (lo, hi) = scene.bounds();
    if lo.is_finite() && hi.is_finite() {
        ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
    } else {
        (Vec3::ZERO, 0.0)
    }
}

fn unit(what: &str, j: usize, v: Vec3) -> Result<Vec3> {
    check_vec(what, j, v, false)?;
    let len = v.length();
    if !(len > 1e-12) {
        return Err(Error::invalid(format!("light {j}: {what} must be non-zero, got {v:?}")));
    }
    Ok(v / len)
}

/// Mitsuba's `coordinate_system(n)` (Duff et al. 2017): (s, t) completing n to a right-handed frame;
/// the same as `coordinate_system_s/t` in `light.wgsl`.
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// rho(incident) = integral over the sphere of f(incident, w) |w . n_g| dw for a VPL, by a 32 x 32
/// stratified cosine-weighted quadrature about n_s on the side of `incident` (exact for diffuse).
/// A diffuse BSDF whose shading normal is the geometric one (within 0.8 degrees: transformed normals
/// differ by rounding; the reflectance then changes by < 1e-4) takes the closed form pi * f(incident,
/// n_s) (the integrand is then constant), 1024x cheaper.
pub fn vpl_reflectance(bsdf: &GpuBsdf, n_s: Vec3, n_g: Vec3, incident: Vec3) -> Vec3 {
    const N: usize = 32;
    let (s, t) = coordinate_system(n_s);
    let local = |v: Vec3| Vec3::new(v.dot(s), v.dot(t), v.dot(n_s));
    let wi = local(incident);
    let side = if incident.dot(n_g) >= 0.0 { 1.0 } else { -1.0 };
    let zs = if wi.z >= 0.0 { 1.0 } else { -1.0 };
    let plain = bsdf.flags & (crate::shading::bsdf::FLAG_BUMP | crate::shading::bsdf::FLAG_TWOSIDED_OUTER) == 0;
    if plain && bsdf.kind == crate::shading::bsdf::KIND_DIFFUSE && n_s.dot(n_g).abs() > 1.0 - 1e-4 {
        return crate::shading::bsdf::eval(bsdf, wi, Vec3::new(0.0, 0.0, zs)) * std::f32::consts::PI;
    }
    let mut sum = Vec3::ZERO;
    for a in 0..N {
        for b in 0..N {
            let (u1, u2) = ((a as f32 + 0.5) / N as f32, (b as f32 + 0.5) / N as f32);
            let r = u1.sqrt();
            let phi = 2.0 * std::f32::consts::PI * u2;
            let z = (1.0 - u1).max(0.0).sqrt();
            let wo = Vec3::new(r * phi.cos(), r * phi.sin(), zs * z);
            let w_world = s * wo.x + t * wo.y + n_s * wo.z;
            let cos_g = w_world.dot(n_g) * side;
            if !(cos_g > 0.0) || z <= 0.0 {
                continue;
            }
            // eval / pdf with pdf = z / pi; times |w . n_g| / |w . n_s|.
            sum += crate::shading::perturb::adjoint_eval(bsdf, wi, wo) * (std::f32::consts::PI * cos_g / (z * z));
        }
    }
    sum / (N * N) as f32
}

/// Mitsuba's spot `falloff_curve` for cos(theta) (theta from the axis).
pub fn spot_falloff(cos_theta: f32, cutoff_angle: f32, beam_width: f32) -> f32 {
    if !(cos_theta > cutoff_angle.cos()) {
        return 0.0;
    }
    if cos_theta >= beam_width.cos() {
        1.0
    } else {
        (cutoff_angle - cos_theta.clamp(-1.0, 1.0).acos()) / (cutoff_angle - beam_width)
    }
}

/// Integral of Mitsuba's spot falloff over the sphere (sr): 2 pi (1 - (sin c - sin b) / (c - b)).
pub fn spot_solid_angle(cutoff_angle: f32, beam_width: f32) -> f32 {
    let (c, b) = (cutoff_angle as f64, beam_width as f64);
    let inner = if c - b > 1e-6 { (c.sin() - b.sin()) / (c - b) } else { c.cos() };
    (2.0 * std::f64::consts::PI * (1.0 - inner)) as f32
}

#[cfg(test)]
mod tests;
