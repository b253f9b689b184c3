//! Triangle meshes as Mitsuba 3.9.1 builds them: OBJ and PLY loaders (`obj`, `ply`), the built-in shapes
//! (`shapes`) and [`finalize`], which takes local-space [`MeshData`] to world space.
//!
//! What `finalize` reproduces (Mitsuba `src/render/mesh.cpp`, `src/shapes/*.cpp`):
//! - positions are transformed by `world_from_local`, file normals by its inverse transpose and normalised;
//! - missing normals are recomputed in world space as Mitsuba's `recompute_vertex_normals` does: the sum of
//!   the unit face normals weighted by the face's angle at the vertex (Thürmer & Wüthrich, JGT 1998),
//!   normalised; a vertex that no face touches gets Mitsuba's fallback normal (1, 0, 0);
//! - `face_normals=true`: Mitsuba shades with the geometric normal `normalize(cross(p1-p0, p2-p0))`; here
//!   the vertices are unshared (3 per triangle) and carry that normal.
//!
//! Deviations (all on inputs Mitsuba either rejects or handles by accident):
//! - zero-area triangles (world space, `cross == 0` in f32, the test Mitsuba's normal computation uses) are
//!   dropped with a `log::warn`: the shared scene veach-ajar (`models/Mesh015.obj`) has 62 of them. Mitsuba
//!   keeps them (rays never hit them), so primitive indices after the first dropped face shift. A mesh
//!   whose triangles are *all* zero-area becomes an empty mesh (no vertices, no triangles), as it adds
//!   nothing in Mitsuba either; it keeps its place so that shape indices stay Mitsuba's.
//! - `flip_normals=true` negates the normals *and* reverses the winding (`[i0, i2, i1]`), so that
//!   `cross(p1-p0, p2-p0)` is Mitsuba's flipped geometric normal; Mitsuba keeps the winding and negates
//!   `si.n` at intersection time.
//! - normals given by the file or shape are transformed by the normal matrix Mitsuba's transform carries
//!   (`transform::Affine::inverse_transpose`, [`finalize_with_normal_matrix`]), then normalised. It is
//!   the inverse transpose of `world_from_local` except after a `rotate` about a non-unit axis, where
//!   Mitsuba 3.9.1 uses the rotation matrix itself (checked against its OBJ, PLY, cube and rectangle
//!   normals). [`finalize`] uses the true inverse transpose. Recomputed normals match Mitsuba exactly.
//! - non-finite positions or normals, indices out of range and zero-length file normals are errors naming
//!   the vertex or triangle.
pub mod cylinder;
pub mod obj;
pub mod ply;
pub mod serialized;
pub mod shapes;

use crate::error::{Error, Location, Result};
use glam::{Mat3, Mat4, Vec2, Vec3};

pub use cylinder::{cylinder, cylinder_to_world, CYLINDER_SEGMENTS};
pub use obj::load_obj;
pub use ply::load_ply;
pub use serialized::load_serialized;
pub use shapes::{cube, disk, rectangle, sphere, DISK_SEGMENTS, SPHERE_PHI_SEGMENTS, SPHERE_THETA_SEGMENTS};

/// A mesh in local space, as a loader or built-in shape produced it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals (local space); empty when the file has none.
    pub normals: Vec<Vec3>,
    /// Per-vertex uv in Mitsuba's convention (OBJ: v flipped); empty when the file has none.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
}

/// World-space pieces of a mesh: positions, unit normals (one per position), uvs (empty or one per
/// position), triangles.
pub type WorldMesh = (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>);

/// Transforms `data` to world space, computes or transforms normals, validates.
///
/// Args: `world_from_local` the shape's `to_world`; `face_normals` flat shading (vertices unshared);
/// `flip_normals` Mitsuba's `flip_normals`; `loc` the mesh file (or the XML shape) for error messages.
/// Returns (positions, normals, uvs, indices), all in world space.
/// Errors: `Error::Scene` for non-finite positions/normals, zero-length normals, indices out of range, or
/// attribute arrays whose length differs from the vertex count.
pub fn finalize(data: MeshData, world_from_local: Mat4, face_normals: bool, flip_normals: bool, loc: &Location) -> Result<WorldMesh> {
    let normal_from_local = Mat3::from_mat4(world_from_local).inverse().transpose();
    finalize_with_normal_matrix(data, world_from_local, normal_from_local, face_normals, flip_normals, loc)
}

/// [`finalize`] with the matrix that transforms the given normals (Mitsuba's tracked
/// `inverse_transpose`, `transform::Affine`, which differs from the true inverse transpose after a
/// `rotate` about a non-unit axis). Same arguments, results and errors otherwise.
pub fn finalize_with_normal_matrix(
    data: MeshData,
    world_from_local: Mat4,
    normal_from_local: Mat3,
    face_normals: bool,
    flip_normals: bool,
    loc: &Location,
) -> Result<WorldMesh> {
    let MeshData { positions, normals, uvs, indices } = data;
    let n = positions.len();
    if !normals.is_empty() && normals.len() != n {
        return Err(Error::scene(loc, format!("mesh has {} normals for {} vertices", normals.len(), n)));
    }
    if !uvs.is_empty() && uvs.len() != n {
        return Err(Error::scene(loc, format!("mesh has {} texture coordinates for {} vertices", uvs.len(), n)));
    }
    for (i, p) in positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(Error::scene(loc, format!("vertex {i} has a non-finite position {p}")));
        }
    }
    for (t, tri) in indices.iter().enumerate() {
        if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(Error::scene(loc, format!("triangle {t} {tri:?} references vertex {bad}, but the mesh has {n} vertices")));
        }
    }

    let world: Vec<Vec3> = positions.iter().map(|&p| world_from_local.transform_point3(p)).collect();
    if let Some((i, p)) = world.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(Error::scene(loc, format!("vertex {i} is non-finite after to_world: {p}")));
    }

    // Drop zero-area triangles (see the module doc).
    let total = indices.len();
    let mut first_dropped = None;
    let indices: Vec<[u32; 3]> = indices
        .into_iter()
        .enumerate()
        .filter(|(t, tri)| {
            let keep = face_cross(&world, tri).length_squared() > 0.0;
            if !keep && first_dropped.is_none() {
                first_dropped = Some((*t, tri.map(|v| world[v as usize])));
            }
            keep
        })
        .map(|(_, tri)| tri)
        .collect();
    if let Some((t, corners)) = first_dropped {
        if indices.is_empty() {
            // Mitsuba loads such a mesh (it adds nothing); the caller reports it (`Scene::warnings`).
            log::warn!(
                "{loc}: all {total} triangles have zero area (e.g. triangle {t} with corners {} {} {}); the mesh adds nothing",
                corners[0],
                corners[1],
                corners[2]
            );
            return Ok((Vec::new(), Vec::new(), Vec::new(), Vec::new()));
        }
        log::warn!("{loc}: dropped {} zero-area triangles of {total} (first: triangle {t})", total - indices.len());
    }

    let (mut world, mut normals, mut uvs, mut indices) = if face_normals {
        unshare_with_face_normals(&world, &uvs, &indices)
    } else if !normals.is_empty() {
        let mut out = Vec::with_capacity(n);
        for (i, nl) in normals.iter().enumerate() {
            let nw = (normal_from_local * *nl).normalize();
            if !nw.is_finite() {
                return Err(Error::scene(loc, format!("vertex {i} has an invalid normal {nl}")));
            }
            out.push(nw);
        }
        (world, out, uvs, indices)
    } else {
        let normals = angle_weighted_normals(&world, &indices);
        (world, normals, uvs, indices)
    };

    if flip_normals {
        normals.iter_mut().for_each(|nv| *nv = -*nv);
        indices.iter_mut().for_each(|tri| tri.swap(1, 2));
    }
    world.shrink_to_fit();
    uvs.shrink_to_fit();
    Ok((world, normals, uvs, indices))
}

/// `cross(p1 - p0, p2 - p0)` of a triangle.
fn face_cross(p: &[Vec3], tri: &[u32; 3]) -> Vec3 {
    let p0 = p[tri[0] as usize];
    (p[tri[1] as usize] - p0).cross(p[tri[2] as usize] - p0)
}

/// Angle between two unit vectors, computed as Dr.Jit's `unit_angle` does (accurate near 0 and pi).
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        std::f32::consts::PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin()
    } else {
        2.0 * ((a - b).length() * 0.5).min(1.0).asin()
    }
}

/// Mitsuba's `recompute_vertex_normals`: per vertex, the sum over incident faces of the unit face normal
/// times the face angle at the vertex, normalised; (1, 0, 0) for vertices no face touches.
pub fn angle_weighted_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for tri in indices {
        let c = face_cross(positions, tri);
        let len_sqr = c.length_squared();
        if len_sqr <= 0.0 {
            continue;
        }
        let n = c / len_sqr.sqrt();
        let v = tri.map(|i| positions[i as usize]);
        for j in 0..3 {
            let a = (v[(j + 1) % 3] - v[j]).normalize();
            let b = (v[(j + 2) % 3] - v[j]).normalize();
            acc[tri[j] as usize] += n * unit_angle(a, b);
        }
    }
    let mut invalid = 0usize;
    let out = acc
        .into_iter()
        .map(|s| {
            let len = s.length();
            if len != 0.0 {
                s / len
            } else {
                invalid += 1;
                Vec3::X
            }
        })
        .collect();
    if invalid > 0 {
        log::debug!("computed vertex normals: {invalid} vertices touch no face and got (1, 0, 0)");
    }
    out
}

/// Three vertices per triangle, each with the face's geometric normal.
fn unshare_with_face_normals(world: &[Vec3], uvs: &[Vec2], indices: &[[u32; 3]]) -> WorldMesh {
    let mut p = Vec::with_capacity(indices.len() * 3);
    let mut nrm = Vec::with_capacity(indices.len() * 3);
    let mut uv = Vec::with_capacity(if uvs.is_empty() { 0 } else { indices.len() * 3 });
    let mut idx = Vec::with_capacity(indices.len());
    for tri in indices {
        let n = face_cross(world, tri).normalize();
        let base = p.len() as u32;
        for &i in tri {
            p.push(world[i as usize]);
            nrm.push(n);
            if !uvs.is_empty() {
                uv.push(uvs[i as usize]);
            }
        }
        idx.push([base, base + 1, base + 2]);
    }
    (p, nrm, uv, idx)
}

#[cfg(test)]
mod tests;
