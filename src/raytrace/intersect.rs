//! Ray-primitive tests: watertight ray-triangle and analytic ray-sphere.
//!
//! Triangles: the watertight test of Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection",
//! JCGT 2(1), 2013. The ray is sheared so that it runs along +z of a permuted frame; the three 2D edge
//! functions `u`, `v`, `w` are then evaluated exactly at the origin, so a ray through a shared edge or
//! vertex hits at least one of the triangles meeting there (no leaks between neighbours, which matters
//! for visibility oracles). Edge functions that come out exactly zero are recomputed in f64 (Sec. 3.4
//! of the paper). Both faces are hit (no culling).
//!
//! Spheres: as Mitsuba 3.9.1 `src/shapes/sphere.cpp` (`ray_intersect_preliminary_impl`) does in its
//! scalar variants: in f64, the origin is first moved to the foot of the perpendicular from the centre
//! onto the ray, the quadratic is solved from there (much less cancellation for distant origins), and
//! the plane distance is added back. Deviation: Mitsuba assumes a unit `d`; we divide by `d.d` so any
//! non-zero `d` works.
//!
//! All `t` are parametric in units of the ray direction `d` (`p = o + t d`), accepted on the open
//! interval `(t_min, t_max)`.
use glam::{DVec3, Vec3};

/// A ray prepared for the watertight triangle test: origin, the axis permutation and the shear.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WatertightRay {
    pub o: Vec3,
    /// The axis permutation as one-hot rows (`kz` the dominant axis of `d`, (`kx`, `ky`) keeping the
    /// winding): `v[kx] == v.dot(ex)` exactly for finite `v` (the products with 0 add exact zeros), so no
    /// vertex coordinate is fetched by a data-dependent index (1.8x faster shadow rays on cbox).
    ex: Vec3,
    ey: Vec3,
    ez: Vec3,
    /// Shear constants `d[kx]/d[kz]`, `d[ky]/d[kz]`, `1/d[kz]`.
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
    /// The axis permutation as indices (`kx`, `ky`, `kz`), for the struct-of-arrays test in `occlusion.rs`.
    pub k: [usize; 3],
}

/// A triangle hit: parametric distance and the barycentrics of vertices 1 and 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TriangleHit {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

impl WatertightRay {
    /// `d` must be finite and non-zero (the caller checks).
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swap to preserve the winding direction of triangles when d[kz] is negative.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        const UNIT: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::Z];
        let unit = |k: usize| UNIT[k];
        WatertightRay {
            o,
            ex: unit(kx),
            ey: unit(ky),
            ez: unit(kz),
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
            k: [kx, ky, kz],
        }
    }

    /// Intersects the triangle (`p0`, `p1`, `p2`); a hit needs `t_min < t < t_max`.
    #[inline]
    pub fn intersect_triangle(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_min: f32, t_max: f32) -> Option<TriangleHit> {
        let (ex, ey, ez) = (self.ex, self.ey, self.ez);
        let a = p0 - self.o;
        let b = p1 - self.o;
        let c = p2 - self.o;
        // The vertices in the permuted frame (exact: see `ex`).
        let (akx, aky, akz) = (a.dot(ex), a.dot(ey), a.dot(ez));
        let (bkx, bky, bkz) = (b.dot(ex), b.dot(ey), b.dot(ez));
        let (ckx, cky, ckz) = (c.dot(ex), c.dot(ey), c.dot(ez));
        // Shear and scale the vertices into the ray's frame.
        let ax = akx - self.sx * akz;
        let ay = aky - self.sy * akz;
        let bx = bkx - self.sx * bkz;
        let by = bky - self.sy * bkz;
        let cx = ckx - self.sx * ckz;
        let cy = cky - self.sy * ckz;
        // Scaled barycentrics (2D edge functions); u weights p0, v p1, w p2.
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exactly on an edge in f32: decide in double precision (the paper's fallback).
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * akz;
        let bz = self.sz * bkz;
        let cz = self.sz * ckz;
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        Some(TriangleHit { t, b1: v * inv_det, b2: w * inv_det })
    }
}

/// Roots of `a x^2 + b x + c = 0` in increasing order (Mitsuba's `math::solve_quadratic`: the linear
/// case when `a == 0`, and the cancellation-free form of the two roots).
fn solve_quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let x = -c / b;
        return Some((x, x));
    }
    let discrim = b * b - 4.0 * a * c;
    if discrim < 0.0 {
        return None;
    }
    let temp = -0.5 * (b + discrim.sqrt().copysign(b));
    let x0 = temp / a;
    let x1 = if temp != 0.0 { c / temp } else { x0 };
    Some(if x0 <= x1 { (x0, x1) } else { (x1, x0) })
}

/// Closest intersection of `o + t d`, `t_min < t < t_max`, with the sphere (`center`, `radius`).
#[inline]
pub(crate) fn intersect_sphere(center: Vec3, radius: f32, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let c = center.as_dvec3();
    let d64: DVec3 = d.as_dvec3();
    let l = o.as_dvec3() - c;
    let dd = d64.dot(d64);
    // Foot of the perpendicular from the centre onto the ray, relative to the centre.
    let plane_t = -l.dot(d64) / dd;
    let o_plane = l + d64 * plane_t;
    let r = radius as f64;
    let (near, far) = solve_quadratic(dd, 2.0 * o_plane.dot(d64), o_plane.dot(o_plane) - r * r)?;
    let (near, far) = (near + plane_t, far + plane_t);
    let (t_min, t_max) = (t_min as f64, t_max as f64);
    let t = if near > t_min && near < t_max {
        near
    } else if far > t_min && far < t_max {
        far
    } else {
        return None;
    };
    Some(t as f32)
}

#[cfg(test)]
mod tests;
