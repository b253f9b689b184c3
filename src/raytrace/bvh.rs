//! The acceleration structure: one compressed wide BVH (obvhs `CwBvh`, 8-wide, Ylitie, Karras and
//! Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017) over every
//! primitive of the scene, built with PLOC (Meister and Bittner, TVCG 2018) plus reinsertion.
//!
//! Primitives are the triangles of every mesh, except `ShapeKind::Sphere` meshes, which are one
//! analytic sphere primitive each (their tessellation is for rasterisers only). Primitives are stored
//! in BVH leaf order so a leaf's primitives are contiguous in memory. Shadow rays (`SceneBvh::any`) and
//! closest hits use `occlusion.rs`'s traversal over obvhs's nodes; obvhs's own traversal is the fallback.
use super::intersect::{intersect_sphere, WatertightRay};
use super::occlusion::TriangleSoa;
use crate::scene::{Scene, ShapeKind};
use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::{Boundable, BvhBuildParams};

/// A primitive's geometry.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Geometry {
    Triangle([Vec3; 3]),
    Sphere { center: Vec3, radius: f32 },
}

/// A primitive: its geometry and where it comes from.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Primitive {
    pub geometry: Geometry,
    /// Index into `Scene::meshes`.
    pub mesh: u32,
    /// Triangle index in the mesh (0 for spheres).
    pub prim: u32,
}

impl Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        match self.geometry {
            Geometry::Triangle([p0, p1, p2]) => Aabb::new(p0.min(p1).min(p2).into(), p0.max(p1).max(p2).into()),
            Geometry::Sphere { center, radius } => Aabb::new((center - Vec3::splat(radius)).into(), (center + Vec3::splat(radius)).into()),
        }
    }
}

/// What a closest-hit query found: the primitive and its local hit data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PrimitiveHit {
    /// Index into `SceneBvh::primitives`.
    pub index: usize,
    pub t: f32,
    /// Barycentrics of vertices 1 and 2 (zero for spheres).
    pub b1: f32,
    pub b2: f32,
}

/// The obvhs ray for `o + t d`. Negative zeros in `d` become positive: obvhs picks a slab's near
/// side from `d < 0` but inverts `-0.0` to a large negative number, which would cull every box (axis-
/// aligned rays such as `-Vec3::Z` would miss everything).
pub(super) fn obvhs_ray(o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Ray {
    Ray::new(Vec3A::from(o), Vec3A::from(d) + Vec3A::ZERO, t_min, t_max)
}

/// obvhs's traversal enters no child box before t = 1e-4 (its `cwbvh::node::EPSILON`, crate-private:
/// "ray.tmin?"), so a primitive closer than that to the origin is never tested: a wall point 0.1 mm above
/// the floor saw the sky under it (4.7x too bright against Mitsuba, whose traversal has no such floor).
/// Queries through obvhs's traversal trace that stretch again from an origin moved back by `NEAR_SHIFT`
/// along the ray, where those boxes lie past the clamp; `occlusion.rs`'s traversal clamps at the ray's
/// own `t_min` instead.
const OBVHS_BOX_T_MIN: f32 = 1e-4;
const NEAR_SHIFT: f32 = 4.0 * OBVHS_BOX_T_MIN;

/// The smallest t a query accepts: a distance of `(1 + max_i |o_i|) 2^-20` along `d`, as the GPU's traversal
/// (`shaders/common/bvh.wgsl`, unit directions), so both backends answer alike for a shading point exactly on
/// an edge, whose offset origin lies in the plane of the other face (cbox-lights' corner pixels); far below
/// any offset (`offset_p`: 1500 x that).
#[inline]
pub(crate) fn t_floor(o: Vec3, d: Vec3, t_min: f32) -> f32 {
    let len = d.length();
    let floor = (1.0 + o.abs().max_element()) * 9.536_743e-7;
    t_min.max(if len > 0.0 { floor / len } else { floor })
}

/// Every primitive of a scene and the BVH over them.
pub(crate) struct SceneBvh {
    /// In BVH leaf order.
    pub primitives: Vec<Primitive>,
    /// `None` for a scene without primitives.
    bvh: Option<CwBvh>,
    /// The triangles again, as the shadow-ray traversal reads them (`occlusion.rs`).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    soa: TriangleSoa,
}

impl SceneBvh {
    /// Collects the primitives (the caller has validated indices and positions) and builds the BVH.
    pub fn build(scene: &Scene) -> SceneBvh {
        let mut primitives = Vec::new();
        for (mesh_index, mesh) in scene.meshes.iter().enumerate() {
            if let ShapeKind::Sphere { center, radius, .. } = mesh.kind {
                primitives.push(Primitive { geometry: Geometry::Sphere { center, radius }, mesh: mesh_index as u32, prim: 0 });
                continue;
            }
            for (prim, tri) in mesh.indices.iter().enumerate() {
                let v = [mesh.positions[tri[0] as usize], mesh.positions[tri[1] as usize], mesh.positions[tri[2] as usize]];
                primitives.push(Primitive { geometry: Geometry::Triangle(v), mesh: mesh_index as u32, prim: prim as u32 });
            }
        }
        if primitives.is_empty() {
            return SceneBvh { soa: TriangleSoa::new(&primitives), primitives, bvh: None };
        }
        let mut build_time = std::time::Duration::ZERO;
        let mut bvh = build_cwbvh(&primitives, BvhBuildParams::medium_build(), &mut build_time);
        // Reorder primitives into leaf order; the BVH then indexes them directly.
        primitives = bvh.primitive_indices.iter().map(|&i| primitives[i as usize]).collect();
        bvh.primitive_indices = (0..primitives.len() as u32).collect();
        SceneBvh { soa: TriangleSoa::new(&primitives), primitives, bvh: Some(bvh) }
    }

    /// Closest primitive hit by `o + t d` with `t_min < t < t_max`: `occlusion.rs`'s AVX2 traversal, whose
    /// box tests are the shadow rays' (no 1e-4 clamp, the exit widened so a ray through the edge of two
    /// faces hits one), or [`SceneBvh::closest_reference`] without AVX2.
    pub fn closest(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<PrimitiveHit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(bvh) = self.bvh.as_ref() {
            let t_min = t_floor(o, d, t_min);
            if let Some(hit) = super::occlusion::closest_hit(bvh, &self.soa, &self.primitives, o, d, t_min, t_max) {
                return hit.map(|h| PrimitiveHit { index: h.index, t: h.t, b1: h.b1, b2: h.b2 });
            }
        }
        self.closest_reference(o, d, t_min, t_max)
    }

    /// [`SceneBvh::closest`] through obvhs's traversal, and its near stretch again (`OBVHS_BOX_T_MIN`):
    /// the path of targets without AVX2 and of trees too deep for `occlusion.rs`'s stack, and a reference
    /// of the tests.
    pub fn closest_reference(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<PrimitiveHit> {
        let t_min = t_floor(o, d, t_min);
        let far = self.closest_obvhs(o, d, t_min, t_max);
        if t_min >= OBVHS_BOX_T_MIN {
            return far;
        }
        let end = far.map_or(t_max, |h| h.t).min(t_max).min(2.0 * OBVHS_BOX_T_MIN);
        let near = self.closest_obvhs(o - d * NEAR_SHIFT, d, t_min + NEAR_SHIFT, end + NEAR_SHIFT);
        match near {
            Some(h) if h.t - NEAR_SHIFT < far.map_or(f32::INFINITY, |f| f.t) => {
                Some(PrimitiveHit { t: (h.t - NEAR_SHIFT).max(t_min.max(0.0)), ..h })
            }
            _ => far,
        }
    }

    /// Closest hit through obvhs's traversal alone (blind below `OBVHS_BOX_T_MIN`).
    fn closest_obvhs(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<PrimitiveHit> {
        let bvh = self.bvh.as_ref()?;
        let wt = WatertightRay::new(o, d);
        let mut best = PrimitiveHit { index: usize::MAX, t: f32::INFINITY, b1: 0.0, b2: 0.0 };
        let mut hit = RayHit::none();
        let ray = obvhs_ray(o, d, t_min, t_max);
        bvh.ray_traverse(ray, &mut hit, |ray, index| {
            // `ray.tmax` is the closest hit so far: anything returned below it becomes the new closest.
            match self.intersect_primitive(&wt, d, index, ray.tmin, ray.tmax) {
                Some((t, b1, b2)) => {
                    best = PrimitiveHit { index, t, b1, b2 };
                    t
                }
                None => f32::INFINITY,
            }
        });
        (best.index != usize::MAX).then_some(best)
    }

    /// Whether anything is hit with `t_min < t < t_max` (stops at the first hit): `occlusion.rs`, which
    /// answers as [`SceneBvh::any_reference`] does, bit for bit.
    pub fn any(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let t_min = t_floor(o, d, t_min);
        #[cfg(target_arch = "x86_64")]
        if let Some(bvh) = self.bvh.as_ref() {
            if let Some(hit) = super::occlusion::any_hit(bvh, &self.soa, &self.primitives, o, d, t_min, t_max) {
                return hit;
            }
        }
        self.any_reference(o, d, t_min, t_max)
    }

    /// [`SceneBvh::any`] with the SSE2 box and triangle tests even where AVX2 is available (`None` when
    /// the traversal's stack overflowed).
    #[cfg(all(test, target_arch = "x86_64"))]
    pub fn any_sse(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<bool> {
        super::occlusion::any_hit_sse(self.bvh.as_ref()?, &self.soa, &self.primitives, o, d, t_floor(o, d, t_min), t_max)
    }

    /// [`SceneBvh::any`] through obvhs's own traversal (`CwBvh::ray_traverse_miss`, and its near stretch
    /// again: `OBVHS_BOX_T_MIN`): the reference of the tests, and the path of targets without SSE2 and of
    /// trees too deep for `occlusion.rs`'s stack.
    pub fn any_reference(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let t_min = t_floor(o, d, t_min);
        self.any_obvhs(o, d, t_min, t_max)
            || (t_min < OBVHS_BOX_T_MIN
                && self.any_obvhs(o - d * NEAR_SHIFT, d, t_min + NEAR_SHIFT, t_max.min(2.0 * OBVHS_BOX_T_MIN) + NEAR_SHIFT))
    }

    fn any_obvhs(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else { return false };
        let wt = WatertightRay::new(o, d);
        let ray = obvhs_ray(o, d, t_min, t_max);
        !bvh.ray_traverse_miss(ray, |ray, index| self.intersect_primitive(&wt, d, index, ray.tmin, ray.tmax).map_or(f32::INFINITY, |h| h.0))
    }

    /// Closest hit by testing every primitive (the reference for tests); ties go to the lower index.
    #[cfg(test)]
    pub fn closest_brute_force(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<PrimitiveHit> {
        let wt = WatertightRay::new(o, d);
        let mut best: Option<PrimitiveHit> = None;
        let mut t_max = t_max;
        for index in 0..self.primitives.len() {
            if let Some((t, b1, b2)) = self.intersect_primitive(&wt, d, index, t_min, t_max) {
                best = Some(PrimitiveHit { index, t, b1, b2 });
                t_max = t;
            }
        }
        best
    }

    #[inline]
    fn intersect_primitive(&self, wt: &WatertightRay, d: Vec3, index: usize, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        match self.primitives[index].geometry {
            Geometry::Triangle([p0, p1, p2]) => wt.intersect_triangle(p0, p1, p2, t_min, t_max).map(|h| (h.t, h.b1, h.b2)),
            Geometry::Sphere { center, radius } => intersect_sphere(center, radius, wt.o, d, t_min, t_max).map(|t| (t, 0.0, 0.0)),
        }
    }
}
