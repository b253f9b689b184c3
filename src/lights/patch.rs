//! The patch of an area-light sample: the near field of oriented point lights without the 1 / d^2 spike.
//!
//! An oriented point j made by `generate_lights` from a mesh emitter stands for a piece P of the
//! emitter: its compact stratum (`generate::strata`: a triangle's equal-area piece cut by longest-edge
//! bisection, a triangle), or, on meshes with fewer lights than triangles, the part of its equal-area
//! stratum of the cumulative area that lies in the triangle the point fell in (a strip of the triangle
//! between two lines parallel to one edge: a trapezoid, or a triangle at the strip next to a vertex;
//! `generate::area`). The point is uniform in P, so its usual contribution
//! `f_r(wo_j) cos_r I0 cos_l / d^2` (I0 = L A_j, A_j the stratum's area) is an unbiased estimate of
//! `L (A_j / A_P) int_P f_r cos_r cos_l / r^2 dA` -- with unbounded variance when the receiver is near P.
//!
//! Near field: when the receiver p lies within `NEAR_FIELD_RADII` patch radii of the patch's centre
//! (radius = largest distance from the centre, the mean of the four corners, to a corner), the
//! radiance factor becomes
//!     F = I0 * PSA(P+) / (A(P+) * |cos_r(wo_j)|),
//! with P+ the part of P on the side of the receiver's tangent plane (shading normal n) that the point
//! lies on -- above it when wo_j . n > 0, below it when wo_j . n < 0 (`receiver_side`) --, A(P+) its
//! area and PSA(P+) = int_{P+} |cos_r| cos_l / r^2 dA its projected solid angle (Lambert's polygon
//! formula, `(1/2) sum_i theta_i (m . g_i)` over the edges, m = +-n the side's normal, theta_i the angle
//! an edge subtends and g_i the unit normal of the plane through p and the edge). The receiver multiplies
//! F by `f_r(wo_j) |cos_r(wo_j)|`, so a diffuse receiver gets `f_r I0 PSA / A(P+)`: the exact patch
//! irradiance share, no 1 / d^2. Unbiased for receivers that are Lambertian on each side (one-sided,
//! `twosided`, diffuse transmission): the point lies in the part above the plane with probability
//! A(above) / A_P and below it with A(below) / A_P, each part's estimate is its exact share, and whether
//! the rule applies depends on p and P only, never on where the point fell. The side is the point's,
//! not a fixed one: clipping always to the upper side gave 0 for every near-field point of a `twosided`
//! receiver seen and lit from below its normal (Mitsuba evaluates `twosided` on the side the camera
//! sees; a one-sided BSDF gives 0 there by itself). Glossy
//! receivers get the BSDF at the point's direction times the patch's irradiance share (deviation: not
//! the lobe integrated over the patch; exact for Lambertian receivers). Visibility stays the one ray
//! to the point. Far from the patch (and for lights without a patch) F is today's point formula, bit
//! for bit.
//!
//! A patch is stored as 4 corners in order around a planar convex quadrilateral (a triangle repeats a
//! corner); all zero = no patch (user-made oriented points, sphere emitters, textured emitters -- the
//! formula assumes L constant over the patch --, and the lights of animations, `lights::animated`).
//! Angles use `angle_between` (2 atan(|a-b| / |a+b|) with the Cephes single-precision atan), written
//! identically in `shaders/common/light.wgsl` so that the GPU equals the CPU.
use crate::error::{Error, Result};
use glam::Vec3;

/// The near-field rule applies within this many patch radii of the patch's centre. Compact pieces are
/// small: at 3 radii the floor 0.015-2.9 mm in front of a panel (`tests/lights/test_twosided.py`) missed
/// the exact Lambert integral's tolerance, points of neighbouring pieces falling back to 1 / d^2; at 8 it
/// holds on both backends.
pub const NEAR_FIELD_RADII: f32 = 8.0;

/// Whether the 4 corners are "no patch".
#[inline]
pub fn is_none(c: &[Vec3; 4]) -> bool {
    c.iter().all(|v| *v == Vec3::ZERO)
}

/// Area of the (planar, convex) quadrilateral: half the length of its diagonals' cross product.
pub fn quad_area(c: &[Vec3; 4]) -> f32 {
    0.5 * (c[2] - c[0]).cross(c[3] - c[1]).length()
}

/// Checks light j's patch: all zero (none), or finite corners of a quadrilateral of positive area.
pub fn check(j: usize, c: &[Vec3; 4]) -> Result<()> {
    if c.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(format!("patch[{j}] must have finite corners, got {:?}", c.map(|v| v.to_array()))));
    }
    if !is_none(c) && !(quad_area(c) > 0.0) {
        return Err(Error::invalid(format!(
            "patch[{j}] has zero area (corners {:?}); use all-zero corners for an oriented point without a patch",
            c.map(|v| v.to_array())
        )));
    }
    Ok(())
}

/// Whether receiver p is in the near field of the patch (module docs); false without a patch.
#[inline]
pub fn is_near(c: &[Vec3; 4], p: Vec3) -> bool {
    let centre = (c[0] + c[1] + c[2] + c[3]) * 0.25;
    let r2 = (c[0] - centre)
        .length_squared()
        .max((c[1] - centre).length_squared())
        .max((c[2] - centre).length_squared())
        .max((c[3] - centre).length_squared());
    r2 > 0.0 && (p - centre).length_squared() < r2 * (NEAR_FIELD_RADII * NEAR_FIELD_RADII)
}

/// atan(z) for z in [0, 1] (Cephes `atanf`, ~2 ulp), twin of `atan_unit` in light.wgsl.
#[inline]
pub(crate) fn atan_unit(z: f32) -> f32 {
    let (base, x) = if z > 0.414_213_57 { (std::f32::consts::FRAC_PI_4, (z - 1.0) / (z + 1.0)) } else { (0.0, z) };
    let x2 = x * x;
    base + ((((8.053_744_5e-2 * x2 - 1.387_768_6e-1) * x2 + 1.997_771_1e-1) * x2 - 3.333_295e-1) * x2 * x + x)
}

/// The angle between unit vectors a and b, accurate for small and large angles.
#[inline]
pub fn angle_between(a: Vec3, b: Vec3) -> f32 {
    let y = (a - b).length();
    let x = (a + b).length();
    let half = if y <= x { atan_unit(y / x) } else { std::f32::consts::FRAC_PI_2 - atan_unit(x / y) };
    2.0 * half
}

/// (PSA, area) of the part of the patch above the plane through p with unit normal n (module docs):
/// PSA = int cos_r cos_l / r^2 dA (sr), area in m^2. Twin of `patch_clipped` in light.wgsl.
pub fn clipped_projected_solid_angle(c: &[Vec3; 4], p: Vec3, n: Vec3) -> (f32, f32) {
    // Sutherland-Hodgman against n . (x - p) >= 0: at most 5 vertices, relative to p.
    let mut v = [Vec3::ZERO; 5];
    let mut k = 0usize;
    for i in 0..4 {
        let a = c[i] - p;
        let b = c[(i + 1) % 4] - p;
        let (ha, hb) = (n.dot(a), n.dot(b));
        if ha >= 0.0 {
            v[k] = a;
            k += 1;
        }
        if (ha >= 0.0) != (hb >= 0.0) {
            let t = ha / (ha - hb);
            v[k] = a + (b - a) * t;
            k += 1;
        }
    }
    let (mut psa, mut cross_sum) = (0.0f32, Vec3::ZERO);
    for i in 0..k {
        let a = v[i];
        let b = v[(i + 1) % k];
        let g = a.cross(b);
        cross_sum += g;
        let gl = g.length();
        let (la, lb) = (a.length(), b.length());
        if gl > 0.0 && la > 0.0 && lb > 0.0 {
            psa += angle_between(a / la, b / lb) * (n.dot(g) / gl);
        }
    }
    (0.5 * psa.abs(), 0.5 * cross_sum.length())
}

/// What a light with a patch sends to receiver `p` (shading normal `n`), as `LightSet::emitted`: (wo, radiance
/// factor F, distance), from the point of the emitter's SURFACE beneath the light: the light moved onto its
/// patch's plane (the corners lie on the surface). Generated lights sit on the surface already (then this is
/// the light itself); a light placed off its surface by a user (e.g. Mitsuba's `offset_p`, ~1e-4 m at unit
/// scale) would otherwise give a receiver at height h above the emitter's plane the cosine (h - o) / d
/// instead of h / d (o the offset): 11% dark at h = 0.8 mm, and 0 for h < o (a floor meeting a wall emitter).
/// Twin of the oriented-point branch of `light_emitted` in light.wgsl.
pub fn surface_emitted(c: &[Vec3; 4], position: Vec3, normal: Vec3, intensity: Vec3, p: Vec3, n: Vec3) -> Option<(Vec3, Vec3, f32)> {
    let d = surface_point(c, position, normal) - p;
    let dist2 = d.length_squared();
    if !(dist2 > 0.0) {
        return None;
    }
    let dist = dist2.sqrt();
    surface_emitted_toward(c, normal, intensity, p, n, d / dist, dist2, dist)
}

/// The light at `position` moved onto its patch's plane along its `normal` (`surface_emitted`).
#[inline]
pub fn surface_point(c: &[Vec3; 4], position: Vec3, normal: Vec3) -> Vec3 {
    position - normal * (position - c[0]).dot(normal)
}

/// `surface_emitted` given the unit direction `wo` from p toward `surface_point`, its squared distance and
/// distance (`LightSet::toward`).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn surface_emitted_toward(
    c: &[Vec3; 4],
    normal: Vec3,
    intensity: Vec3,
    p: Vec3,
    n: Vec3,
    wo: Vec3,
    dist2: f32,
    dist: f32,
) -> Option<(Vec3, Vec3, f32)> {
    let cos = -wo.dot(normal);
    if !(cos > 0.0) {
        return None;
    }
    let radiance = if is_near(c, p) { near_field(c, intensity, p, n, wo)? } else { intensity * (cos / dist2) };
    Some((wo, radiance, dist))
}

/// The near-field radiance factor F of an oriented point of intensity I0 (module docs), or None when
/// wo lies in the receiver's plane or the patch sends nothing from wo's side of it.
pub fn near_field(c: &[Vec3; 4], intensity: Vec3, p: Vec3, n: Vec3, wo: Vec3) -> Option<Vec3> {
    let (side, cos_r) = receiver_side(n, wo)?;
    let (psa, area) = clipped_projected_solid_angle(c, p, side);
    if !(psa > 0.0 && area > 0.0) {
        return None;
    }
    Some(intensity * (psa / (area * cos_r)))
}

/// The side of the receiver's plane (shading normal n) that light arriving along `wo` (unit, toward the
/// light) comes from, as the normal of that half-space, and |cos_r| = |wo . n| > 0; None when wo lies
/// in the plane (or is NaN). The near field clips the patch to this half-space (module docs), so that a
/// receiver lit from below its normal -- a `twosided` BSDF seen and lit from its back, or transmission --
/// gets the part of the patch on that side; a BSDF that reflects nothing from there gives 0 itself.
/// Twin of the side choice in `light_emitted` (light.wgsl).
#[inline]
pub fn receiver_side(n: Vec3, wo: Vec3) -> Option<(Vec3, f32)> {
    let cos_r = wo.dot(n);
    if cos_r > 0.0 {
        Some((n, cos_r))
    } else if cos_r < 0.0 {
        Some((-n, -cos_r))
    } else {
        None
    }
}

#[cfg(test)]
mod tests;
