//! Virtual spherical lights (VSLs): a VPL's light spread over a sphere so that its contribution to a
//! receiver next to it stays bounded, with no geometry-term clamp (Hašan, Křivánek, Walter, Bala,
//! "Virtual Spherical Lights for Many-Light Rendering of Glossy Scenes", SIGGRAPH Asia 2009, Sec. 4-5;
//! issue 13 item 2).
//!
//! A VPL j (intensity I_j(w) = Phi f_v(incident, w) |w . n_g|, `LightSet` module docs) with a radius
//! r_j > 0 (`LightSet::vsl_radius`) becomes a sphere of radius r_j around its position y that sends,
//! from every point of its projected disk (area pi r^2), the radiance I_j / (pi r^2): far away it is the
//! VPL (same intensity, same power), close by the receiver x sees a cap of solid angle
//! Omega = 2 pi (1 - cos sigma), sin^2 sigma = min(1, r^2 / d^2) (inside the sphere: the hemisphere
//! around wo). The receiver's reflected radiance is the integral over that cap of
//! f_r(x) cos_x f_v cos_y / (pi r^2) Phi; as the paper (Sec. 4.2) we split the product integral into
//! the product of the two integrals over the cap divided by Omega, each integral being a cosine lobe:
//!     F = Phi f_v(wo) * PSA(cos_y, sin^2 sigma) * PSA(cos_x, sin^2 sigma) / (Omega pi r^2 cos_x)
//! where PSA(cos theta, sin^2 sigma) is the exact projected solid angle of a spherical cap of
//! half-angle sigma whose axis makes angle theta with the normal (clipped by the horizon; Snyder,
//! "Area light sources for real-time graphics", 1996; Lagarde and de Rousiers, "Moving Frostbite to
//! PBR", 2014, Eq. 19), cos_y = |w . n_g| at the VSL and cos_x = |wo . n| at the receiver (n its
//! shading normal), both toward the sphere's centre. The receiver multiplies F by its
//! `bsdf_eval(wi, wo)` = f_r cos_x as for any light, so its reflected radiance is
//! f_r(wo) f_v(wo) Phi PSA_y PSA_x / (Omega pi r^2).
//!
//! Limits: r -> 0 (or d >> r: PSA -> pi sin^2 sigma cos, Omega -> pi sin^2 sigma) gives the VPL's
//! f_r f_v Phi cos_x cos_y / d^2 exactly; at d -> 0 the value stays below f_r f_v Phi pi / (2 r^2)
//! (no spike). Deviations from the paper: the BSDFs are evaluated at the centre direction (exact for a
//! Lambertian receiver and VSL, whose f is constant over the cap; for glossy lobes narrower than the
//! cap the paper integrates the lobe, we keep its value at the centre); visibility is the one shadow
//! ray to the centre (as the paper's shadow maps); the VSL's BSDF at directions below its plane
//! counts as 0 (the centre direction decides).
//!
//! Radii (`radii`): r_j = scale * distance from VPL j to its `k`-th nearest VPL (a kd-tree over all
//! VPL positions, `photon_map::PhotonMap`), the paper's density-adapted radius; never below
//! `MIN_RADIUS_REL` times the scene's bounding-sphere radius (coincident VPLs).
//!
//! Symbols: Phi flux (W), f_v the VSL's BSDF, f_r the receiver's, d the distance x-y, r the radius,
//! sigma the cap's half-angle, Omega its solid angle, PSA projected solid angle (sr).
//! Written identically in `shaders/common/light.wgsl` (`vsl_spread`), so the GPU equals the CPU.
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

/// Checks a user radius scale: finite and > 0.
pub fn check_scale(scale: f32) -> Result<()> {
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(Error::invalid(format!("vsl_radius_scale must be finite and > 0 (times the distance to the k-th nearest VPL), got {scale}")));
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
mod tests {
    use super::*;

    /// Projected solid angle of the cap by a midpoint quadrature in (cos, phi) about its axis.
    fn cap_numeric(cos_theta: f32, sin2_sigma: f32) -> f64 {
        let theta = (cos_theta as f64).acos();
        let n = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
        let cos_sigma = (1.0 - sin2_sigma as f64).max(0.0).sqrt();
        let (na, nb) = (400, 400);
        let mut sum = 0.0f64;
        for a in 0..na {
            let z = 1.0 - (1.0 - cos_sigma) * (a as f64 + 0.5) / na as f64;
            let rr = (1.0 - z * z).max(0.0).sqrt();
            for b in 0..nb {
                let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / nb as f64;
                let w = Vec3::new((rr * phi.cos()) as f32, (rr * phi.sin()) as f32, z as f32);
                sum += (w.dot(n) as f64).max(0.0);
            }
        }
        sum * 2.0 * std::f64::consts::PI * (1.0 - cos_sigma) / (na * nb) as f64
    }

    #[test]
    fn cap_formula_matches_quadrature() {
        for &s in &[1e-3f32, 0.05, 0.3, 0.7, 0.95, 1.0] {
            for &c in &[1.0f32, 0.9, 0.5, 0.2, 0.05, 0.0] {
                let got = cap_projected_solid_angle(c, s) as f64;
                let want = cap_numeric(c, s);
                assert!((got - want).abs() < 2e-3 * want.max(1e-2), "cos {c} sin2 {s}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn spread_tends_to_the_point_formula_and_stays_bounded() {
        let i = Vec3::new(2.0, 1.0, 0.5);
        let (cy, cx, d2) = (0.6f32, 0.8f32, 4.0f32);
        let point = i / d2;
        for r in [1e-3f32, 1e-2] {
            let f = spread(i, cy, cx, d2, r).unwrap();
            assert!(((f - point) / point).abs().max_element() < 1e-4, "r {r}: {f} vs {point}");
        }
        // Far field: identical up to rounding at r = d / 100.
        let f = spread(i, cy, cx, d2, 0.02).unwrap();
        assert!(((f - point) / point).abs().max_element() < 1e-3);
        // Receivers on the sphere's centre or inside it: F * cos_x * f_r stays below pi / (2 r^2) I / cos_y.
        for d2 in [1e-8f32, 1e-4, 0.01] {
            let f = spread(i, cy, cx, d2, 0.1).unwrap() * cx;
            let bound = i / cy * (PI / (2.0 * 0.01));
            assert!(f.cmple(bound * 1.0001).all() && f.is_finite(), "{f} vs {bound}");
        }
        assert!(spread(i, cy, 0.0, d2, 0.1).is_none());
    }

    #[test]
    fn radii_from_the_kth_neighbour_and_bad_scales() {
        let pts: Vec<Vec3> = (0..10).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
        let r = radii(&pts, 2, 0.5, 10.0).unwrap();
        // Point 0: its 2nd nearest other point is at distance 2; point 5: at distance 1.
        assert!((r[0] - 1.0).abs() < 1e-6 && (r[5] - 0.5).abs() < 1e-6, "{r:?}");
        for bad in [0.0f32, -1.0, f32::NAN, f32::INFINITY] {
            let e = radii(&pts, 2, bad, 10.0).unwrap_err().to_string();
            assert!(e.contains("vsl_radius_scale") && e.contains(&format!("{bad}")), "{e}");
        }
        assert!(radii(&pts, 0, 1.0, 10.0).unwrap_err().to_string().contains("vsl_neighbours"));
        // Coincident VPLs get the floor, never 0.
        let same = vec![Vec3::ONE; 5];
        assert!(radii(&same, 2, 1.0, 10.0).unwrap().iter().all(|&r| r == MIN_RADIUS_REL * 10.0));
    }
}
