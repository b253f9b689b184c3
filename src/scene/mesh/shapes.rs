//! Mitsuba 3.9.1's built-in shapes as local-space triangle meshes.
//!
//! - `rectangle` (`src/shapes/rectangle.cpp`, a mesh in Mitsuba too): vertex k at
//!   `(2(k&1)-1, 2(k>>1)-1, 0)` with uv `(k&1, k>>1)`, normal +z, faces `[1,2,0], [1,3,2]`: exact.
//! - `cube` (`src/shapes/cube.cpp`, a mesh in Mitsuba too): Mitsuba's 24 vertices, normals, uvs and 12
//!   triangles, verbatim: exact.
//! - `disk` (analytic in Mitsuba): a fan of [`DISK_SEGMENTS`] triangles in z=0, normal +z. Mitsuba's uv
//!   is `(r, phi / 2pi)` with phi in [0, 2pi): rim vertex i has uv `(1, i/N)` (the seam is duplicated, so
//!   the last rim vertex has v=1) and each triangle has its own centre vertex with uv `(0, (i+1/2)/N)`.
//! - `sphere` (analytic in Mitsuba): a UV sphere of [`SPHERE_PHI_SEGMENTS`] x [`SPHERE_THETA_SEGMENTS`]
//!   with Mitsuba's parameterisation: local point `(sin t cos p, sin t sin p, cos t)`, uv `(p/2pi, t/pi)`,
//!   outward unit normals; seam duplicated (u=0 and u=1), one pole vertex per segment at u=(i+1/2)/N.
//!   The exact sphere is used by ray-traced code through `ShapeKind::Sphere`.
//!
//! Tessellated shapes are inscribed: the largest radial error is `1 - cos(pi/N)` (3.0e-4 for the sphere,
//! 7.5e-5 for the disk).
use super::MeshData;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Number of rim segments of the disk.
pub const DISK_SEGMENTS: u32 = 256;
/// Segments around the sphere's z axis (phi).
pub const SPHERE_PHI_SEGMENTS: u32 = 128;
/// Rings from +z to -z (theta).
pub const SPHERE_THETA_SEGMENTS: u32 = 64;

/// Mitsuba's `rectangle`: [-1,1]^2 in z=0, normal +z.
pub fn rectangle() -> MeshData {
    let mut d = MeshData::default();
    for k in 0..4u32 {
        let (xf, yf) = ((k & 1) as f32, (k >> 1) as f32);
        d.positions.push(Vec3::new(2.0 * xf - 1.0, 2.0 * yf - 1.0, 0.0));
        d.normals.push(Vec3::Z);
        d.uvs.push(Vec2::new(xf, yf));
    }
    d.indices = vec![[1, 2, 0], [1, 3, 2]];
    d
}

/// Mitsuba's `cube`: [-1,1]^3, 24 vertices (4 per face), per-face normals and uvs.
pub fn cube() -> MeshData {
    const P: [[f32; 3]; 24] = [
        [1., -1., -1.],
        [1., -1., 1.],
        [-1., -1., 1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [-1., 1., -1.],
        [-1., 1., 1.],
        [1., 1., 1.],
        [1., -1., -1.],
        [1., 1., -1.],
        [1., 1., 1.],
        [1., -1., 1.],
        [1., -1., 1.],
        [1., 1., 1.],
        [-1., 1., 1.],
        [-1., -1., 1.],
        [-1., -1., 1.],
        [-1., 1., 1.],
        [-1., 1., -1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [1., -1., -1.],
        [-1., -1., -1.],
        [-1., 1., -1.],
    ];
    // One normal per group of 4 vertices: -y, +y, +x, +z, -x, -z.
    const N: [[f32; 3]; 6] = [[0., -1., 0.], [0., 1., 0.], [1., 0., 0.], [0., 0., 1.], [-1., 0., 0.], [0., 0., -1.]];
    const UV: [[f32; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
    let mut d = MeshData::default();
    for (i, p) in P.iter().enumerate() {
        d.positions.push(Vec3::from_array(*p));
        d.normals.push(Vec3::from_array(N[i / 4]));
        d.uvs.push(Vec2::from_array(UV[i % 4]));
    }
    for f in 0..6u32 {
        let b = 4 * f;
        d.indices.push([b, b + 1, b + 2]);
        d.indices.push([b + 3, b, b + 2]);
    }
    d
}

/// Mitsuba's `disk`: the unit disk in z=0, normal +z, uv (r, phi/2pi).
pub fn disk() -> MeshData {
    let n = DISK_SEGMENTS;
    let mut d = MeshData::default();
    for i in 0..=n {
        let phi = 2.0 * PI * (i % n) as f32 / n as f32;
        d.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        d.normals.push(Vec3::Z);
        d.uvs.push(Vec2::new(1.0, i as f32 / n as f32));
    }
    for i in 0..n {
        let centre = d.positions.len() as u32;
        d.positions.push(Vec3::ZERO);
        d.normals.push(Vec3::Z);
        d.uvs.push(Vec2::new(0.0, (i as f32 + 0.5) / n as f32));
        d.indices.push([centre, i, i + 1]);
    }
    d
}

/// Unit sphere (centre 0, radius 1), Mitsuba's uv and outward normals.
pub fn sphere() -> MeshData {
    let (np, nt) = (SPHERE_PHI_SEGMENTS, SPHERE_THETA_SEGMENTS);
    let mut d = MeshData::default();
    for j in 0..=nt {
        let theta = PI * j as f32 / nt as f32;
        let (sin_t, cos_t) = if j == 0 {
            (0.0, 1.0)
        } else if j == nt {
            (0.0, -1.0)
        } else {
            theta.sin_cos()
        };
        let pole = j == 0 || j == nt;
        for i in 0..=np {
            let phi = 2.0 * PI * (i % np) as f32 / np as f32;
            let (sin_p, cos_p) = phi.sin_cos();
            let p = Vec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
            d.positions.push(p);
            d.normals.push(p);
            let u = if pole { (i as f32 + 0.5) / np as f32 } else { i as f32 / np as f32 };
            d.uvs.push(Vec2::new(u, j as f32 / nt as f32));
        }
    }
    let at = |j: u32, i: u32| j * (np + 1) + i;
    for j in 0..nt {
        for i in 0..np {
            let (a, b, c, e) = (at(j, i), at(j + 1, i), at(j + 1, i + 1), at(j, i + 1));
            if j != nt - 1 {
                d.indices.push([a, b, c]);
            }
            if j != 0 {
                d.indices.push([a, c, e]);
            }
        }
    }
    d
}

#[cfg(test)]
mod tests;
