//! Virtual spherical lights (VSLs): a VPL's light spread over a sphere so that its contribution to a
//! receiver next to it stays bounded, with no geometry-term clamp (Hašan, Křivánek, Walter, Bala,
//! "Virtual Spherical Lights for Many-Light Rendering of Glossy Scenes", SIGGRAPH Asia 2009, Sec. 4-5).
//!
//! A VPL j (intensity I_j(w) = Phi f_v(incident, w) |w . n_g|, `LightSet` module docs) with a radius
//! r_j > 0 (`LightSet::vsl_radius`) becomes a sphere of radius r_j around its position y that sends,
//! from every point of its projected disk (area pi r^2), the radiance I_j / (pi r^2): far away it is the
//! VPL (same intensity, same power), close by the receiver x sees a cap of solid angle
//! Omega = 2 pi (1 - cos sigma), sin^2 sigma = min(1, r^2 / d^2) (inside the sphere: the hemisphere
//! around wo). The receiver reflects the integral over that cap of
//!     f_r(x; wi, w) |w . n| I_j(-w) / (pi r^2) dw,
//! both lobes integrated over the cap as the paper does (Sec. 4): `cap_shade` takes `CAP_SAMPLES`^2 = 16
//! stratified directions uniform in the cap's solid angle (the same fixed pattern on the CPU and in
//! WGSL), evaluating the receiver's BSDF and the VSL's at each. Every shading site calls it through
//! `LightSet::shade_receiver` (CPU backend, oracle, CPU reference, clustered visibility; `light_shade`
//! in `columns.wgsl`, `rows.wgsl`, `clustered_visibility.wgsl`).
//!
//! `LightSet::emitted` (what callers that do not shade see: wo, validity, distance) returns the closed
//! form with both BSDFs at the centre direction (the paper's product-of-integrals split, Sec. 4.2):
//!     F = Phi f_v(wo) * PSA(cos_y, sin^2 sigma) * PSA(cos_x, sin^2 sigma) / (Omega pi r^2 cos_x)
//! where PSA(cos theta, sin^2 sigma) is the exact projected solid angle of a spherical cap of
//! half-angle sigma whose axis makes angle theta with the normal (clipped by the horizon; Snyder,
//! "Area light sources for real-time graphics", 1996; Lagarde and de Rousiers, "Moving Frostbite to
//! PBR", 2014, Eq. 19), cos_y = |w . n_g| at the VSL and cos_x = |wo . n| at the receiver. For a
//! Lambertian receiver and VSL it is the exact cap integral that the quadrature approximates.
//!
//! Limits: r -> 0 (or d >> r) gives the VPL's f_r f_v Phi cos_x cos_y / d^2; at d -> 0 the value stays
//! bounded (no spike, no clamp). Deviations from the paper: a fixed 16-direction quadrature of the cap
//! (the paper importance-samples the lobes); visibility is the one shadow ray to the centre (as the
//! paper's shadow maps); a receiver for which the centre direction is below the VSL's plane or its
//! own horizon gets nothing (`emitted` decides validity by the centre).
//!
//! Radii (`radii`): r_j = scale * distance from VPL j to its `k`-th nearest VPL (a kd-tree over all
//! VPL positions, `photon_map::PhotonMap`), the paper's density-adapted radius; never below
//! `MIN_RADIUS_REL` times the scene's bounding-sphere radius (coincident VPLs).
//!
//! Symbols: Phi flux (W), f_v the VSL's BSDF, f_r the receiver's, d the distance x-y, r the radius,
//! sigma the cap's half-angle, Omega its solid angle, PSA projected solid angle (sr).
//! Written identically in `shaders/common/light.wgsl` (`vsl_spread`, `vsl_cap_shade`), so the GPU equals the CPU.
use super::patch::atan_unit;
use super::photon_map::PhotonMap;
use crate::error::{Error, Result};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::{FRAC_PI_2, PI};

/// Default k of the k-th nearest VPL that sets a radius.
pub const DEFAULT_NEIGHBOURS: usize = 16;
/// Smallest radius, relative to the scene's bounding-sphere radius.
pub const MIN_RADIUS_REL: f32 = 1e-4;

/// atan(z) for z >= 0 (Cephes on [0, 1], `atan_unit`); twin of `atan_pos` in light.wgsl.
#[inline]
fn atan_pos(z: f32) -> f32 {
    if z <= 1.0 {
        atan_unit(z)
    } else {
        FRAC_PI_2 - atan_unit(1.0 / z)
    }
}

/// Projected solid angle (sr) of the spherical cap of half-angle sigma (given as sin^2 sigma in
/// [0, 1]) whose axis makes angle theta with the normal (cos theta in [0, 1]), the part below the
/// horizon removed (module docs). sin^2 sigma = 1 is the hemisphere around the axis:
/// (pi / 2) (1 + cos theta).
pub fn cap_projected_solid_angle(cos_theta: f32, sin2_sigma: f32) -> f32 {
    let c = cos_theta.clamp(0.0, 1.0);
    let s = sin2_sigma.clamp(0.0, 1.0);
    if c * c > s {
        return PI * s * c;
    }
    if s >= 1.0 {
        return FRAC_PI_2 * (1.0 + c);
    }
    let sin_theta = (1.0 - c * c).max(0.0).sqrt();
    let x = (1.0 / s - 1.0).max(0.0).sqrt();
    let y = (-x * c / sin_theta).clamp(-1.0, 1.0);
    let t = sin_theta * (1.0 - y * y).max(0.0).sqrt();
    ((c * y.acos() - x * t) * s + atan_pos(t / x)).max(0.0)
}

/// The VSL radiance factor F (module docs) of a VPL whose intensity toward the receiver is `intensity`
/// (W/sr; its cosine cos_y = `cos_light` > 0 included), radius `r` > 0, at squared distance `dist2`,
/// the receiver's |cos| toward the centre `cos_receiver`. `None` when cos_receiver is 0.
#[inline]
pub fn spread(intensity: Vec3, cos_light: f32, cos_receiver: f32, dist2: f32, r: f32) -> Option<Vec3> {
    if !(cos_receiver > 0.0 && cos_light > 0.0) {
        return None;
    }
    let r2 = r * r;
    let s = (r2 / dist2).min(1.0);
    // Omega = 2 pi (1 - sqrt(1 - s)), written without cancellation for small s.
    let omega = 2.0 * PI * s / (1.0 + (1.0 - s).sqrt());
    let psa_y = cap_projected_solid_angle(cos_light, s);
    let psa_x = cap_projected_solid_angle(cos_receiver, s);
    Some(intensity * (psa_y * psa_x / (omega * PI * r2 * cos_light * cos_receiver)))
}

/// Stratified directions per axis of the cap quadrature (`cap_shade`): 4 x 4 = 16 directions.
pub const CAP_SAMPLES: usize = 4;

/// The reflected radiance at receiver `p` from VSL j (`vsl_radius[j]` > 0) whose centre lies along the
/// unit `wo` (module docs: the receiver's lobe integrated over the cap): `CAP_SAMPLES`^2 stratified
/// directions w uniform in the cap's solid angle Omega, each weighted by `receiver(w)` = f_r(wi, w)
/// |w . n| (the receiver's `bsdf_eval`) times the VSL's intensity I_j(-w) (its BSDF and |cos| at
/// that direction; 0 below its plane), times Omega / (K pi r^2). Tends to f_r(wo) I_j(-wo) / d^2 as
/// r -> 0. Twin of `vsl_cap_shade` in light.wgsl.
pub fn cap_shade(lights: &super::LightSet, j: usize, p: Vec3, wo: Vec3, receiver: impl Fn(Vec3) -> Vec3) -> Vec3 {
    let r = lights.vsl_radius[j];
    let d2 = (lights.position[j] - p).length_squared();
    let s = (r * r / d2).min(1.0);
    // 1 - cos sigma without cancellation.
    let one_minus_cos = s / (1.0 + (1.0 - s).sqrt());
    let (ta, tb) = super::coordinate_system(wo);
    let (n_s, n_g, incident) = (lights.normal[j], lights.geo_normal[j], lights.incident[j]);
    let (vs, vt) = super::coordinate_system(n_s);
    let local = |v: Vec3| Vec3::new(v.dot(vs), v.dot(vt), v.dot(n_s));
    let (wi_v, cos_g_in) = (local(incident), incident.dot(n_g));
    let k = CAP_SAMPLES as f32;
    let mut sum = Vec3::ZERO;
    for a in 0..CAP_SAMPLES {
        let z = 1.0 - one_minus_cos * ((a as f32 + 0.5) / k);
        let rr = (1.0 - z * z).max(0.0).sqrt();
        for b in 0..CAP_SAMPLES {
            let phi = 2.0 * PI * ((b as f32 + 0.5) / k);
            let w = ta * (rr * phi.cos()) + tb * (rr * phi.sin()) + wo * z;
            let out = -w;
            let cos_g_out = out.dot(n_g);
            let out_local = local(out);
            if !(cos_g_out * cos_g_in > 0.0) || out_local.z == 0.0 {
                continue;
            }
            let f_cos = crate::shading::perturb::adjoint_eval(&lights.bsdf[j], wi_v, out_local);
            sum += receiver(w) * f_cos * (cos_g_out.abs() / out_local.z.abs());
        }
    }
    lights.intensity[j] * sum * (2.0 * one_minus_cos / (k * k * r * r))
}

/// Checks a user radius scale: finite and > 0.
pub fn check_scale(scale: f32) -> Result<()> {
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(Error::invalid(format!(
            "vsl_radius_scale must be finite and > 0 (times the distance to the k-th nearest VPL), got {scale}"
        )));
    }
    Ok(())
}

/// Radius of each VPL at `positions` (module docs): `scale` times the distance to its `neighbours`-th
/// nearest other VPL, at least `MIN_RADIUS_REL * scene_radius`.
///
/// Errors: `InvalidParameter` for a scale that is not finite and > 0 or `neighbours` = 0.
pub fn radii(positions: &[Vec3], neighbours: usize, scale: f32, scene_radius: f32) -> Result<Vec<f32>> {
    check_scale(scale)?;
    if neighbours == 0 {
        return Err(Error::invalid("vsl_neighbours must be >= 1, got 0"));
    }
    let floor = (MIN_RADIUS_REL * scene_radius).max(f32::MIN_POSITIVE);
    if positions.len() < 2 {
        return Ok(vec![floor.max(scale * scene_radius); positions.len()]);
    }
    let map = PhotonMap::new(positions);
    // The query point itself is its own nearest neighbour: ask for one more.
    Ok(positions.par_iter().map(|&p| (scale * map.nearest(p, neighbours + 1).1.sqrt()).max(floor)).collect())
}

#[cfg(test)]
mod tests;
