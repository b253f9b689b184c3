//! Mitsuba 3.9.1's `cylinder` (`src/shapes/cylinder.cpp`, analytic there) as a fine triangle mesh.
//!
//! Mitsuba's cylinder is the open tube `x^2 + y^2 = 1, 0 <= z <= 1` in local space (no caps), placed by
//! `to_world * translate(p0) * to_frame(frame(d / |d|)) * scale(radius, radius, |d|)` with `d = p1 - p0`
//! (defaults p0 = 0, p1 = (0, 0, 1), radius 1). `frame(n)` is Mitsuba's `coordinate_system` (Duff et
//! al., JCGT 2017), so uv match: u = phi / 2pi with phi = atan2(y, x) of the local point, v = local z.
//! Normals point away from the axis (`flip_normals` turns them inward).
//!
//! Here the tube is [`CYLINDER_SEGMENTS`] flat strips, each spanning the whole length (the surface is
//! straight along its axis, so only the circular direction is approximated). Vertices lie on the exact
//! surface with radial unit normals and Mitsuba's uv; the seam is duplicated (u = 0 and u = 1).
//! Inside a strip the position is up to `radius (1 - cos(pi / N))` (1.9e-5 radius) inside the true
//! surface, the interpolated shading normal is the exact radial direction of that point, the geometric
//! (face) normal is off by at most pi / N = 6.1e-3 rad, and the area is `sin(2pi/N) / (2pi/N)` =
//! 1 - 2.5e-5 of the true one. `prim_index` is the strip triangle (Mitsuba's is 0).
use super::MeshData;
use glam::{DMat4, DVec3, Vec2, Vec3};

/// Strips around the axis.
pub const CYLINDER_SEGMENTS: u32 = 512;

/// The local unit tube (radius 1, z in [0, 1]).
pub fn cylinder() -> MeshData {
    let n = CYLINDER_SEGMENTS;
    let mut d = MeshData::default();
    for i in 0..=n {
        let u = i as f32 / n as f32;
        // The seam vertex (i = n) repeats i = 0 exactly, with u = 1.
        let phi = (i % n) as f64 * std::f64::consts::TAU / n as f64;
        let (s, c) = (phi.sin() as f32, phi.cos() as f32);
        for z in [0.0f32, 1.0] {
            d.positions.push(Vec3::new(c, s, z));
            d.normals.push(Vec3::new(c, s, 0.0));
            d.uvs.push(Vec2::new(u, z));
        }
    }
    for i in 0..n {
        let (a0, a1, b0, b1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        // cross(p1 - p0, p2 - p0) points away from the axis.
        d.indices.push([a0, b0, b1]);
        d.indices.push([a0, b1, a1]);
    }
    d
}

/// Mitsuba's `coordinate_system(n)`: (s, t) completing the unit vector `n` to a right-handed frame.
pub fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = if n.z.is_sign_negative() { -1.0 } else { 1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(sign * n.x * n.x * a + 1.0, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// The cylinder's world_from_local: `to_world * T(p0) * to_frame(d/|d|) * S(r, r, |d|)`. `None` when
/// p0 == p1 (Mitsuba divides by zero there).
pub fn cylinder_to_world(to_world: DMat4, p0: DVec3, p1: DVec3, radius: f64) -> Option<DMat4> {
    let d = p1 - p0;
    let length = d.length();
    if !(length > 0.0 && length.is_finite()) {
        return None;
    }
    let nz = d / length;
    let (s, t) = coordinate_system(nz);
    let frame = DMat4::from_cols(s.extend(0.0), t.extend(0.0), nz.extend(0.0), glam::DVec4::W);
    Some(to_world * DMat4::from_translation(p0) * frame * DMat4::from_scale(DVec3::new(radius, radius, length)))
}

#[cfg(test)]
mod tests;
