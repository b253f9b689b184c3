//! CPU ray tracing over a [`Scene`]: closest hits with Mitsuba-style surface interactions and shadow
//! (visibility) queries, single or in rayon-parallel batches. Used for particle tracing of virtual point
//! lights, the exact light-matrix oracle and gather samples.
//!
//! What is implemented:
//! - Acceleration: a compressed 8-wide BVH from the `obvhs` crate (see `bvh.rs` for the papers). The
//!   `bvh` crate (svenstaro) was evaluated first and not used: its newest release (0.13) needs Rust
//!   1.90 (the project pins 1.85), and 0.11 has no closest-hit traversal that shrinks `t_max` (it returns
//!   every primitive whose box the ray hits, or a heap-ordered iterator), pulls nalgebra 0.33 + serde +
//!   rand 0.9, and its traversal was 4x slower than obvhs on a 70k-triangle mesh (0.24 vs 0.96 Mrays/s, one thread).
//! - Shadow rays (`occluded*`, `visible*_batch`, the CPU backend's visibility) take their own any-hit
//!   traversal of the same BVH (`occlusion.rs`): 8-lane box tests over the quantised child planes, the
//!   triangles of all the leaves a node keeps tested together from a struct-of-arrays copy (SSE2, AVX2
//!   where present). It answers exactly as obvhs's `ray_traverse_miss` with the same triangle test (the
//!   tests compare both on random, vertex-, edge- and surface-to-surface rays), 1.3-2x faster.
//! - Triangles: watertight test (Woop, Benthin, Wald, JCGT 2013), `intersect.rs`.
//! - `ShapeKind::Sphere` meshes are intersected as exact spheres (Mitsuba's `sphere.cpp` algorithm,
//!   f64), never through their tessellation.
//! - Surface interactions follow Mitsuba 3.9.1 `Mesh::compute_surface_interaction` and
//!   `Sphere::compute_surface_interaction`: triangle `p` is the barycentric interpolation of the
//!   vertices, `n_g = normalize(cross(p1 - p0, p2 - p0))`, `uv` interpolated or `(b1, b2)` when the mesh
//!   has none; sphere `p` is re-projected onto the sphere, `n = (p - c) / r` (negated with
//!   `flip_normals`), `uv = (phi / 2 pi, theta / pi)` of the local direction (`phi` in `[0, 2 pi)`,
//!   measured from +x toward +y, `theta` from +z).
//!   Deviation: the contract stores only a sphere's centre and radius, so a rotation in its
//!   `to_world` does not rotate the uv parameterisation (the local frame is the world frame).
//!   Checked against Mitsuba 3.9.1 `scene.ray_intersect` on cbox-lights (1875 rays, sphere and meshes):
//!   same shape and triangle everywhere, t within 2e-5 relative, p 4e-7, n 1.2e-6, uv 1.2e-6.
//! - Self-intersection: Mitsuba's `Interaction::offset_p` / `spawn_ray` / `spawn_ray_to`
//!   (`include/mitsuba/render/interaction.h`): the origin moves along the geometric normal, toward the
//!   side the ray leaves to, by `(1 + max_i |p_i|) * RAY_EPSILON`; a ray to a point stops at
//!   `dist * (1 - SHADOW_EPSILON)`. Rays have no lower bound beyond `t > 0` (as Mitsuba's).
//!
//! Symbols: `o`, `d` ray origin and direction (`d` need not be unit length; `t` is in units of `d`),
//! `n_g` geometric normal, `n_s` shading normal, `wi = -normalize(d)` (world space, unlike Mitsuba's
//! local `si.wi`), `b1`, `b2` barycentrics of vertices 1 and 2.
mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
mod intersect;
pub mod mask;
mod occlusion;

use crate::error::{Error, Result};
use crate::scene::{Mesh, Scene, ShapeKind};
use bvh::{Geometry, SceneBvh};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Mitsuba's `math::RayEpsilon<float>`: `1500 * 2^-24`.
pub const RAY_EPSILON: f32 = 1500.0 / 16_777_216.0;
/// Mitsuba's `math::ShadowEpsilon<float>`: `10 * RAY_EPSILON`; shadow rays stop this fraction short.
pub const SHADOW_EPSILON: f32 = 10.0 * RAY_EPSILON;

/// A ray-surface intersection, in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceInteraction {
    /// Parametric distance along the ray (in units of the ray direction `d`).
    pub t: f32,
    /// Hit position.
    pub p: Vec3,
    /// Geometric normal: `normalize(cross(p1 - p0, p2 - p0))` for triangles, `(p - c) / r` for spheres
    /// (negated with `flip_normals`). Not flipped toward the ray.
    pub n_g: Vec3,
    /// Shading normal: interpolated vertex normals (normalised), or `n_g` for `Mesh::face_normals`,
    /// meshes without normals and spheres.
    pub n_s: Vec3,
    /// Surface uv (see the module doc).
    pub uv: Vec2,
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// Triangle index within the mesh (0 for spheres).
    pub prim: usize,
    /// Direction toward the ray origin, `-normalize(d)`, world space.
    pub wi: Vec3,
}

/// Mesh data needed to turn a primitive hit into a [`SurfaceInteraction`].
struct MeshShading {
    kind: ShapeKind,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
    face_normals: bool,
}

/// A ray tracer over one scene; build once, query from any number of threads.
pub struct RayTracer {
    bvh: SceneBvh,
    meshes: Vec<MeshShading>,
    /// The scene's masked surfaces (`mask` module).
    masks: mask::Masks,
    /// The same triangles in Embree, for packets of shadow rays (`occluded_packet`), built on the first
    /// packet; None for scenes with analytic spheres or where Embree could not build.
    #[cfg(feature = "embree")]
    embree: std::sync::OnceLock<Option<embree::EmbreeScene>>,
}

/// Rays per [`RayTracer::occluded_packet`] call.
pub const PACKET: usize = 16;

/// Mitsuba's `Interaction::offset_p`: `p` moved along `n_g` (toward the side `d` points to) by
/// `(1 + max_i |p_i|) * RAY_EPSILON`, so a ray leaving a surface does not hit it again.
pub fn offset_p(p: Vec3, n_g: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    p + n_g * if n_g.dot(d) >= 0.0 { mag } else { -mag }
}

/// Mitsuba's `spawn_ray`: a ray leaving surface point `p` (geometric normal `n_g`) along `d`:
/// returns the offset origin (trace it with `t_min = 0`, `t_max = inf`).
pub fn spawn_ray(p: Vec3, n_g: Vec3, d: Vec3) -> Vec3 {
    offset_p(p, n_g, d)
}

/// Mitsuba's `spawn_ray_to`: a shadow ray from surface point `p` (normal `n_g`) toward point `q`:
/// `(o, d, t_max)` with `d` unit length and `t_max = |q - o| (1 - SHADOW_EPSILON)`.
pub fn spawn_ray_to(p: Vec3, n_g: Vec3, q: Vec3) -> (Vec3, Vec3, f32) {
    let o = offset_p(p, n_g, q - p);
    let d = q - o;
    let dist = d.length();
    (o, d / dist, dist * (1.0 - SHADOW_EPSILON))
}

/// Checks a mesh before it goes into the BVH: indices in range, finite positions, valid spheres.
fn validate_mesh(mesh: &Mesh, index: usize) -> Result<()> {
    let at = |what: String| Error::scene(&mesh.loc, format!("mesh {index} ('{}'): {what}", mesh.id));
    if let ShapeKind::Sphere { center, radius, .. } = mesh.kind {
        if !center.is_finite() || !(radius > 0.0 && radius.is_finite()) {
            return Err(at(format!("sphere needs a finite center and a radius > 0, got center {center}, radius {radius}")));
        }
        return Ok(());
    }
    let n = mesh.positions.len();
    if let Some((k, tri)) = mesh.indices.iter().enumerate().find(|(_, t)| t.iter().any(|&i| i as usize >= n)) {
        return Err(at(format!("triangle {k} has vertex indices {tri:?}, but the mesh has {n} vertices")));
    }
    if let Some((k, p)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(at(format!("vertex {k} has a non-finite position {p}")));
    }
    if !mesh.normals.is_empty() && mesh.normals.len() != n {
        return Err(at(format!("{} normals for {n} vertices", mesh.normals.len())));
    }
    if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
        return Err(at(format!("{} uvs for {n} vertices", mesh.uvs.len())));
    }
    Ok(())
}

impl RayTracer {
    /// Builds the BVH over every mesh of `scene` (spheres analytic).
    ///
    /// Errors: `Error::Scene` for a mesh with out-of-range indices, non-finite positions, normal or uv
    /// arrays of the wrong length, or a sphere with a non-positive radius.
    pub fn new(scene: &Scene) -> Result<RayTracer> {
        for (index, mesh) in scene.meshes.iter().enumerate() {
            validate_mesh(mesh, index)?;
        }
        let meshes = scene
            .meshes
            .iter()
            .map(|m| MeshShading {
                kind: m.kind.clone(),
                normals: m.normals.clone(),
                uvs: m.uvs.clone(),
                indices: m.indices.clone(),
                face_normals: m.face_normals,
            })
            .collect();
        Ok(RayTracer {
            bvh: SceneBvh::build(scene),
            meshes,
            masks: mask::Masks::new(scene),
            #[cfg(feature = "embree")]
            embree: std::sync::OnceLock::new(),
        })
    }

    /// Number of primitives in the BVH (triangles plus one per sphere).
    pub fn num_primitives(&self) -> usize {
        self.bvh.primitives.len()
    }

    /// Closest hit along `o + t d` for `t_min < t < t_max`, or `None` (also for a zero or non-finite `d`).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<SurfaceInteraction> {
        if !ray_is_valid(o, d) {
            return None;
        }
        let hit = self.bvh.closest(o, d, t_min, t_max)?;
        Some(self.interaction(o, d, hit))
    }

    /// Whether anything lies on `o + t d` for `0 < t < t_max` (no offsetting: use [`spawn_ray_to`]).
    pub fn occluded_ray(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        ray_is_valid(o, d) && self.bvh.any(o, d, 0.0, t_max)
    }

    /// [`RayTracer::occluded_ray`] for many rays, [`PACKET`] at a time: `out[k]` is ray k's answer (all four
    /// slices of one length). Through Embree's 16-wide packet traversal where the tracer has an Embree scene
    /// (`embree` feature, a scene without analytic spheres), otherwise one ray at a time. The two answer
    /// alike except on rays that end within rounding of a surface or pass exactly through an edge or a
    /// vertex (module `embree`: the measured agreement).
    pub fn occluded_packet(&self, o: &[Vec3], d: &[Vec3], t_max: &[f32], out: &mut [bool]) {
        #[cfg(feature = "embree")]
        if let Some(e) = self.embree_scene() {
            for (c, out) in out.chunks_mut(PACKET).enumerate() {
                let r = c * PACKET..c * PACKET + out.len();
                let (o, d, t_max) = (&o[r.clone()], &d[r.clone()], &t_max[r]);
                // Embree asserts (aborting the process) on a ray beyond its range; those go one at a time.
                let mut outside = e.occluded16(o, d, t_max, out);
                while outside != 0 {
                    let k = outside.trailing_zeros() as usize;
                    out[k] = self.occluded_ray(o[k], d[k], t_max[k]);
                    outside &= outside - 1;
                }
            }
            return;
        }
        for k in 0..o.len() {
            out[k] = self.occluded_ray(o[k], d[k], t_max[k]);
        }
    }

    /// How `occluded_packet` traces: "embree" (an Embree scene) or "own" (the library's traversal, ray by ray).
    pub fn packet_kernel(&self) -> &'static str {
        #[cfg(feature = "embree")]
        if self.embree_scene().is_some() {
            return "embree";
        }
        "own"
    }

    /// The tracer's triangles in Embree, built on first use; None with analytic spheres or where Embree
    /// could not build.
    #[cfg(feature = "embree")]
    fn embree_scene(&self) -> Option<&embree::EmbreeScene> {
        self.embree
            .get_or_init(|| {
                // Where memory is short the packets trace their own way (no abort).
                let mut triangles = Vec::new();
                triangles.try_reserve_exact(self.bvh.primitives.len()).ok()?;
                for p in &self.bvh.primitives {
                    match p.geometry {
                        Geometry::Triangle(v) => triangles.push(v),
                        Geometry::Sphere { .. } => return None,
                    }
                }
                embree::EmbreeScene::new(&triangles)
            })
            .as_ref()
    }

    /// [`RayTracer::occluded_ray`] through the reference traversal (obvhs's own, per ray).
    #[cfg(test)]
    pub(crate) fn occluded_ray_reference(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        ray_is_valid(o, d) && self.bvh.any_reference(o, d, 0.0, t_max)
    }

    /// Shadow ray from surface point `p` (geometric normal `n_g`) to point `q`, as Mitsuba traces it
    /// ([`spawn_ray_to`]): `q` itself gets no offset, only the `SHADOW_EPSILON` shortening. Use this
    /// toward point lights; between two surface points prefer [`RayTracer::occluded_between`].
    pub fn occluded(&self, p: Vec3, n_g: Vec3, q: Vec3) -> bool {
        let (o, d, t_max) = spawn_ray_to(p, n_g, q);
        self.occluded_ray(o, d, t_max)
    }

    /// Visibility between two surface points, each offset along its own geometric normal toward the
    /// other (`offset_p`), then the segment shortened by `SHADOW_EPSILON` as in [`spawn_ray_to`].
    /// Exactly symmetric: the segment is always traced from the endpoint that sorts first.
    pub fn occluded_between(&self, p: Vec3, n_p: Vec3, q: Vec3, n_q: Vec3) -> bool {
        let ((a, n_a), (b, n_b)) = if sorts_first((p, n_p), (q, n_q)) { ((p, n_p), (q, n_q)) } else { ((q, n_q), (p, n_p)) };
        let o = offset_p(a, n_a, b - a);
        let e = offset_p(b, n_b, a - b);
        let d = e - o;
        let dist = d.length();
        self.occluded_ray(o, d / dist, dist * (1.0 - SHADOW_EPSILON))
    }

    /// [`RayTracer::intersect`] for many `(o, d)` rays (`t` in `(0, inf)`), in parallel.
    pub fn intersect_batch(&self, rays: &[(Vec3, Vec3)]) -> Vec<Option<SurfaceInteraction>> {
        rays.par_iter().with_min_len(256).map(|&(o, d)| self.intersect(o, d, 0.0, f32::INFINITY)).collect()
    }

    /// `!occluded(p, n_g, q)` for many `(p, n_g, q)`, in parallel.
    pub fn visible_batch(&self, pairs: &[(Vec3, Vec3, Vec3)]) -> Vec<bool> {
        pairs.par_iter().with_min_len(256).map(|&(p, n, q)| !self.occluded(p, n, q)).collect()
    }

    /// `!occluded_between(p, n_p, q, n_q)` for many `(p, n_p, q, n_q)`, in parallel.
    pub fn visible_between_batch(&self, pairs: &[(Vec3, Vec3, Vec3, Vec3)]) -> Vec<bool> {
        pairs.par_iter().with_min_len(256).map(|&(p, n_p, q, n_q)| !self.occluded_between(p, n_p, q, n_q)).collect()
    }

    /// Builds the surface interaction of a primitive hit.
    fn interaction(&self, o: Vec3, d: Vec3, hit: bvh::PrimitiveHit) -> SurfaceInteraction {
        let prim = self.bvh.primitives[hit.index];
        let mesh = &self.meshes[prim.mesh as usize];
        let wi = -d.normalize();
        match prim.geometry {
            Geometry::Triangle([p0, p1, p2]) => {
                let (b1, b2) = (hit.b1, hit.b2);
                let b0 = 1.0 - b1 - b2;
                let p = p0 * b0 + p1 * b1 + p2 * b2;
                let n_g = (p1 - p0).cross(p2 - p0).normalize();
                let tri = mesh.indices[prim.prim as usize].map(|i| i as usize);
                let n_s = if mesh.face_normals || mesh.normals.is_empty() {
                    n_g
                } else {
                    let n = mesh.normals[tri[0]] * b0 + mesh.normals[tri[1]] * b1 + mesh.normals[tri[2]] * b2;
                    n.try_normalize().unwrap_or(n_g)
                };
                let uv = if mesh.uvs.is_empty() {
                    Vec2::new(b1, b2)
                } else {
                    mesh.uvs[tri[0]] * b0 + mesh.uvs[tri[1]] * b1 + mesh.uvs[tri[2]] * b2
                };
                SurfaceInteraction { t: hit.t, p, n_g, n_s, uv, mesh: prim.mesh as usize, prim: prim.prim as usize, wi }
            }
            Geometry::Sphere { center, radius } => {
                let local = (o + d * hit.t - center).normalize();
                // Re-project onto the sphere (Mitsuba does the same for accuracy).
                let p = center + local * radius;
                let flip = matches!(mesh.kind, ShapeKind::Sphere { flip_normals: true, .. });
                let n = if flip { -local } else { local };
                let theta = local.z.clamp(-1.0, 1.0).acos();
                let mut phi = local.y.atan2(local.x);
                if phi < 0.0 {
                    phi += 2.0 * std::f32::consts::PI;
                }
                let uv = Vec2::new(phi * 0.5 * std::f32::consts::FRAC_1_PI, theta * std::f32::consts::FRAC_1_PI);
                SurfaceInteraction { t: hit.t, p, n_g: n, n_s: n, uv, mesh: prim.mesh as usize, prim: 0, wi }
            }
        }
    }
}

/// Whether `(p, n_p)` is the canonical start of a segment (lexicographic order on the 6 floats).
fn sorts_first(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
    let ka = [a.0.x, a.0.y, a.0.z, a.1.x, a.1.y, a.1.z];
    let kb = [b.0.x, b.0.y, b.0.z, b.1.x, b.1.y, b.1.z];
    ka.iter().zip(kb.iter()).find(|(x, y)| x != y).is_none_or(|(x, y)| x < y)
}

pub(crate) fn ray_is_valid(o: Vec3, d: Vec3) -> bool {
    o.is_finite() && d.is_finite() && d != Vec3::ZERO
}

#[cfg(test)]
mod tests;
