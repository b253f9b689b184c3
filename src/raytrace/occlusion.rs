//! Traversal of the compressed wide BVH for shadow rays (any hit) and, with AVX2, closest hits, with the
//! answers of testing every primitive (`SceneBvh::closest_brute_force`), 1.5-2x faster than obvhs's own
//! `CwBvh::ray_traverse_miss` (docs/validation/backends.md).
//!
//! Why the answer is the brute force's: a ray is blocked iff some primitive that the traversal reaches
//! passes the watertight test, and the closest hit is the least t among those. So two things must hold:
//! every primitive that the test would hit is reached, and the primitive test is the scalar one.
//! - Reached: each node's 8 child boxes are tested with obvhs's arithmetic of
//!   `CwBvhNode::intersect_ray_simd` (Ylitie, Karras and Laine, HPG 2017, Sec. 3: quantised child planes
//!   `p + e * q`, the ray moved into the node's grid), with three differences that only keep more boxes:
//!   the lower clamp is the ray's own `t_min` (obvhs clamps at `1e-4`), the exit is widened by a few ulps
//!   (`BOX_T_MAX_SCALE`), and every slab distance and the entry by a bound on their rounding and on the
//!   rounding of the triangle test's t (`SLAB_SLACK`, `TRIANGLE_SLACK`). obvhs's box test left 6.8% of the
//!   rays aimed at a closed cube's edges out of it. The rest is cost: the 48 quantised planes are widened
//!   to f32 with SSE2 unpacks (obvhs converts them one at a time), the children come out as a plain 8-bit
//!   mask, leaves are tested before the node's internal children are pushed (a shadow ray can stop
//!   early), and the stack holds (first child, internal mask, children left) words, not obvhs's groups.
//!   Closest hits shrink the boxes' upper bound to the nearest hit so far.
//! - Test: the watertight test of `intersect.rs` (Woop, Benthin and Wald, JCGT 2013) on the up to 3
//!   triangles of a leaf at once in 4 SSE lanes, or on all the leaves a node keeps 8 at a time with AVX2,
//!   from a struct-of-arrays copy of the triangles (one f32 array per vertex and axis, in leaf order). The
//!   lanes compute each scalar operation of `WatertightRay::intersect_triangle` in the same order; the
//!   one-hot products there (`v[kx] == v.dot(ex)`) can differ from the direct component only in the sign
//!   of a zero, which no comparison sees. A leaf where an edge function is exactly 0 in a valid lane (the
//!   f64 fallback) and every sphere go through the scalar tests.
//!
//! Targets without SSE2 (not x86_64) use obvhs's traversal for both queries, and x86_64 without AVX2 for
//! closest hits.
use super::bvh::{Geometry, Primitive};
use super::intersect::{intersect_sphere, WatertightRay};
use glam::Vec3;

/// Triangles as one array per vertex and axis (`v[3 * vertex + axis][primitive]`), in BVH leaf order,
/// padded by 7 entries so an 8-lane load at any primitive stays in bounds. Spheres are NaN (no lane hits).
pub(crate) struct TriangleSoa {
    v: [Vec<f32>; 9],
}

impl TriangleSoa {
    pub fn new(primitives: &[Primitive]) -> TriangleSoa {
        let mut v: [Vec<f32>; 9] = Default::default();
        for prim in primitives {
            let verts = match prim.geometry {
                Geometry::Triangle(p) => p,
                Geometry::Sphere { .. } => [Vec3::NAN; 3],
            };
            for (k, p) in verts.iter().enumerate() {
                for axis in 0..3 {
                    v[3 * k + axis].push(p[axis]);
                }
            }
        }
        for a in v.iter_mut() {
            a.extend([0.0; 7]);
        }
        TriangleSoa { v }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use sse::any_hit;

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::LaneHit;

/// The closest hit on `o + t d` with `t_min < t < t_max` through the AVX2 traversal: `None` where AVX2 is
/// missing or the stack overflowed (the caller then takes obvhs's traversal). Its box tests clamp at the
/// ray's own `t_min` and widen the exit (`BOX_T_MAX_SCALE`) as the shadow rays' do, so a camera or bounce
/// ray through the edge where two faces meet hits one of them; the hit is the brute force's up to ties.
#[cfg(target_arch = "x86_64")]
pub(crate) fn closest_hit(
    bvh: &obvhs::cwbvh::CwBvh,
    tris: &TriangleSoa,
    prims: &[Primitive],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<Option<LaneHit>> {
    if !std::is_x86_feature_detected!("avx2") {
        return None;
    }
    // SAFETY: AVX2 is checked above (the check is cached); every node and primitive index comes from the BVH.
    unsafe { avx2::traverse::<true>(bvh, tris, prims, o, d, t_min, t_max) }
}

/// The SSE2 traversal even where AVX2 is available (for tests of both paths).
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) fn any_hit_sse(
    bvh: &obvhs::cwbvh::CwBvh,
    tris: &TriangleSoa,
    prims: &[Primitive],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<bool> {
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe { sse::traverse(bvh, tris, prims, o, d, t_min, t_max) }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    pub(super) use super::super::bvh::{obvhs_ray, Geometry, Primitive};
    use super::{intersect_sphere, TriangleSoa, WatertightRay};
    use glam::{Vec3, Vec3A};
    use obvhs::cwbvh::CwBvh;
    use std::arch::x86_64::*;

    /// A child box's exit distance is widened by this factor (8 ulps of 1): the slab test's products and
    /// sums round, and a ray leaving a closed cube exactly through the edge of two faces found the entry of
    /// both faces' flat boxes a rounding step past their exit (Ize, "Robust BVH Ray Traversal", JCGT 2013,
    /// widens by 1 + 2 gamma(3) for the same reason). Only more boxes are visited; hits are the triangle
    /// test's.
    pub(super) const BOX_T_MAX_SCALE: f32 = 1.0 + 8.0 * f32::EPSILON;
    /// The box tests' margin for rounding, in two parts, both only making boxes larger (more visits, the
    /// same hits as testing every primitive): each slab distance `q * adj_inv + adj_orig` of a child box is
    /// widened on both sides by `SLAB_SLACK` units of `|255 adj_inv| + |adj_orig|` on its axis (a bound on
    /// its own rounding: `p - o`, the product with the inverse direction and the sum each round by half an
    /// ulp), and by `TRIANGLE_SLACK` units of the node's L1 reach from the origin over the direction's
    /// largest component (the rounding of the watertight test's t, whose sheared coordinates are as large
    /// as the vertices' distance from the origin). Without them a box whose entry lay within that rounding
    /// of the ray's `t_max` (or of the nearest hit so far) was culled although the primitive test hits
    /// before `t_max`: about 1 in 1,000 rays aimed just past a surface on the Cornell box.
    pub(super) const SLAB_SLACK: f32 = 4.0 * f32::EPSILON;
    pub(super) const TRIANGLE_SLACK: f32 = 8.0 * f32::EPSILON;
    /// Stack words; deeper trees (never seen: a CWBVH is about a third as deep as its BVH2) fall back to
    /// obvhs's traversal.
    pub(super) const STACK: usize = 64;

    /// Whether anything is hit on `o + t d` with `t_min < t < t_max`; `None` when the stack overflowed.
    pub(crate) fn any_hit(bvh: &CwBvh, tris: &TriangleSoa, prims: &[Primitive], o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<bool> {
        // SAFETY: SSE2 is part of the x86_64 baseline, AVX2 is checked (the check is cached); every node and
        // primitive index comes from the BVH.
        unsafe {
            if std::is_x86_feature_detected!("avx2") {
                super::avx2::traverse::<false>(bvh, tris, prims, o, d, t_min, t_max).map(|hit| hit.is_some())
            } else {
                traverse(bvh, tris, prims, o, d, t_min, t_max)
            }
        }
    }

    /// The widening of a node's child boxes: per axis for each slab distance (`SLAB_SLACK`), and for the
    /// entry alone (`TRIANGLE_SLACK`: a box is culled when its entry passes `t_max`, never kept because its
    /// exit reaches back before `t_min`, so a shadow ray leaving its own surface tests no more leaves),
    /// from the node's quantisation step `extent`, `p - o` of its origin `p` and the ray's `adj_inv`,
    /// `adj_orig` (obvhs's inverse direction is finite: it clamps near-zero components).
    #[inline(always)]
    pub(super) fn slab_slack(extent: Vec3A, rel: Vec3A, adj_inv: Vec3A, adj_orig: Vec3A, inv_max_d: f32) -> (Vec3A, f32) {
        let entry = (extent * 255.0 + rel.abs()).element_sum() * (inv_max_d * TRIANGLE_SLACK);
        ((adj_inv.abs() * 255.0 + adj_orig.abs()) * SLAB_SLACK, entry)
    }

    /// The ray in obvhs's form, broadcast for the box tests.
    struct BoxRay {
        origin: Vec3A,
        inv_direction: Vec3A,
        neg: [bool; 3],
        /// `1 / max_i |d_i|` (the dominant axis of the watertight test).
        inv_max_d: f32,
        t_min: __m128,
        t_max: __m128,
    }

    /// The 8 quantised planes `q` of one axis side as f32 (exact: integers below 256), in two halves.
    #[inline(always)]
    unsafe fn widen(q: &[u8; 8]) -> [__m128; 2] {
        let zero = _mm_setzero_si128();
        let bytes = _mm_loadl_epi64(q.as_ptr() as *const __m128i);
        let words = _mm_unpacklo_epi8(bytes, zero);
        [_mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero)), _mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero))]
    }

    /// Mask of the child slots whose boxes the ray hits (slot i = bit i), as `intersect_ray_simd` decides.
    #[inline(always)]
    unsafe fn child_hits(node: &obvhs::cwbvh::node::CwBvhNode, ray: &BoxRay) -> u32 {
        let extent = node.compute_extent();
        let rel = Vec3A::from(node.p) - ray.origin;
        let (adj_inv, adj_orig) = (extent * ray.inv_direction, rel * ray.inv_direction);
        let pick = |neg: bool, lo: &[u8; 8], hi: &[u8; 8]| if neg { (widen(hi), widen(lo)) } else { (widen(lo), widen(hi)) };
        let (x_near, x_far) = pick(ray.neg[0], &node.child_min_x, &node.child_max_x);
        let (y_near, y_far) = pick(ray.neg[1], &node.child_min_y, &node.child_max_y);
        let (z_near, z_far) = pick(ray.neg[2], &node.child_min_z, &node.child_max_z);
        let (ix, iy, iz) = (_mm_set1_ps(adj_inv.x), _mm_set1_ps(adj_inv.y), _mm_set1_ps(adj_inv.z));
        let (ox, oy, oz) = (_mm_set1_ps(adj_orig.x), _mm_set1_ps(adj_orig.y), _mm_set1_ps(adj_orig.z));
        let (e, entry) = slab_slack(extent, rel, adj_inv, adj_orig, ray.inv_max_d);
        let (ex, ey, ez) = (_mm_set1_ps(e.x), _mm_set1_ps(e.y), _mm_set1_ps(e.z));
        let entry = _mm_set1_ps(entry);
        let mut mask = 0;
        for h in 0..2 {
            let tmin_x = _mm_sub_ps(_mm_add_ps(_mm_mul_ps(x_near[h], ix), ox), ex);
            let tmax_x = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x_far[h], ix), ox), ex);
            let tmin_y = _mm_sub_ps(_mm_add_ps(_mm_mul_ps(y_near[h], iy), oy), ey);
            let tmax_y = _mm_add_ps(_mm_add_ps(_mm_mul_ps(y_far[h], iy), oy), ey);
            let tmin_z = _mm_sub_ps(_mm_add_ps(_mm_mul_ps(z_near[h], iz), oz), ez);
            let tmax_z = _mm_add_ps(_mm_add_ps(_mm_mul_ps(z_far[h], iz), oz), ez);
            let tmin = _mm_max_ps(tmin_x, _mm_max_ps(tmin_y, tmin_z));
            let tmax = _mm_min_ps(tmax_x, _mm_min_ps(tmax_y, tmax_z));
            let tmin = _mm_max_ps(_mm_sub_ps(tmin, entry), ray.t_min);
            let tmax = _mm_min_ps(_mm_mul_ps(tmax, _mm_set1_ps(BOX_T_MAX_SCALE)), ray.t_max);
            mask |= (_mm_movemask_ps(_mm_cmple_ps(tmin, tmax)) as u32) << (4 * h);
        }
        mask
    }

    /// Whether one of the `count` (1 to 3) primitives from `start` is hit.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn leaf_hit(
        tris: &TriangleSoa,
        prims: &[Primitive],
        wt: &WatertightRay,
        o: &[__m128; 3],
        d: Vec3,
        start: usize,
        count: usize,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        let [kx, ky, kz] = wt.k;
        let load = |vertex: usize, axis: usize, o: __m128| _mm_sub_ps(_mm_loadu_ps(tris.v[3 * vertex + axis].as_ptr().add(start)), o);
        // `a = p0 - o` etc. in the permuted frame.
        let (akx, aky, akz) = (load(0, kx, o[0]), load(0, ky, o[1]), load(0, kz, o[2]));
        let (bkx, bky, bkz) = (load(1, kx, o[0]), load(1, ky, o[1]), load(1, kz, o[2]));
        let (ckx, cky, ckz) = (load(2, kx, o[0]), load(2, ky, o[1]), load(2, kz, o[2]));
        let (sx, sy, sz) = (_mm_set1_ps(wt.sx), _mm_set1_ps(wt.sy), _mm_set1_ps(wt.sz));
        let ax = _mm_sub_ps(akx, _mm_mul_ps(sx, akz));
        let ay = _mm_sub_ps(aky, _mm_mul_ps(sy, akz));
        let bx = _mm_sub_ps(bkx, _mm_mul_ps(sx, bkz));
        let by = _mm_sub_ps(bky, _mm_mul_ps(sy, bkz));
        let cx = _mm_sub_ps(ckx, _mm_mul_ps(sx, ckz));
        let cy = _mm_sub_ps(cky, _mm_mul_ps(sy, ckz));
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let lanes = (1 << count) - 1;
        let zero = _mm_setzero_ps();
        let on_edge = _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)), _mm_cmpeq_ps(w, zero));
        // NaN: a sphere (or an overflow, which the scalar test handles as it does).
        let scalar = _mm_or_ps(on_edge, _mm_cmpunord_ps(u, u));
        if _mm_movemask_ps(scalar) & lanes != 0 {
            return leaf_hit_scalar(prims, wt, d, start, count, t_min, t_max);
        }
        // Rejected when some edge function is negative and some positive.
        let neg = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
        let pos = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        let az = _mm_mul_ps(sz, akz);
        let bz = _mm_mul_ps(sz, bkz);
        let cz = _mm_mul_ps(sz, ckz);
        let t_scaled = _mm_add_ps(_mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)), _mm_mul_ps(w, cz));
        let t = _mm_mul_ps(t_scaled, _mm_div_ps(_mm_set1_ps(1.0), det));
        let inside = _mm_andnot_ps(_mm_and_ps(neg, pos), _mm_cmpneq_ps(det, zero));
        let in_range = _mm_and_ps(_mm_cmpgt_ps(t, _mm_set1_ps(t_min)), _mm_cmplt_ps(t, _mm_set1_ps(t_max)));
        _mm_movemask_ps(_mm_and_ps(inside, in_range)) & lanes != 0
    }

    /// `leaf_hit` one primitive at a time with the scalar tests (spheres, and the f64 edge fallback).
    #[cold]
    pub(super) fn leaf_hit_scalar(
        prims: &[Primitive],
        wt: &WatertightRay,
        d: Vec3,
        start: usize,
        count: usize,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        prims[start..start + count].iter().any(|p| match p.geometry {
            Geometry::Triangle([p0, p1, p2]) => wt.intersect_triangle(p0, p1, p2, t_min, t_max).is_some(),
            Geometry::Sphere { center, radius } => intersect_sphere(center, radius, wt.o, d, t_min, t_max).is_some(),
        })
    }

    /// Bits of an 8-bit slot mask reordered so that bit `k` is slot `k ^ oct` (the nearest children, for a
    /// ray in octant `oct`, come first).
    #[inline(always)]
    pub(super) fn permute(mut m: u32, oct: u32) -> u32 {
        if oct & 1 != 0 {
            m = ((m & 0x55) << 1) | ((m >> 1) & 0x55);
        }
        if oct & 2 != 0 {
            m = ((m & 0x33) << 2) | ((m >> 2) & 0x33);
        }
        if oct & 4 != 0 {
            m = ((m & 0x0f) << 4) | ((m >> 4) & 0x0f);
        }
        m
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn traverse(
        bvh: &CwBvh,
        tris: &TriangleSoa,
        prims: &[Primitive],
        o: Vec3,
        d: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<bool> {
        if bvh.nodes.is_empty() {
            return Some(false);
        }
        let r = obvhs_ray(o, d, t_min, t_max);
        let dir = r.direction;
        let wt = WatertightRay::new(o, d);
        let ray = BoxRay {
            origin: r.origin,
            inv_direction: r.inv_direction,
            neg: [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0],
            // The ray's own t_min: obvhs clamps at 1e-4 and misses what is nearer (`bvh::OBVHS_BOX_T_MIN`).
            t_min: _mm_set1_ps(r.tmin.max(0.0)),
            t_max: _mm_set1_ps(r.tmax),
            // `|1 / d[kz]|` of the watertight test, kz the dominant axis: 1 / max_i |d_i| exactly.
            inv_max_d: wt.sz.abs(),
        };
        // obvhs orders children by the octant of the ray direction.
        let oct = (ray.neg[0] as u32) << 2 | (ray.neg[1] as u32) << 1 | ray.neg[2] as u32;
        let [kx, ky, kz] = wt.k;
        let op = [_mm_set1_ps(o[kx]), _mm_set1_ps(o[ky]), _mm_set1_ps(o[kz])];
        // A word: first child node index << 16 | internal-child mask << 8 | children left (permuted).
        // Uninitialised (a zeroed stack was a memset per ray); only written words are read.
        let mut stack = [std::mem::MaybeUninit::<u64>::uninit(); STACK];
        let mut sp = 0;
        let mut node = bvh.nodes.get_unchecked(0);
        loop {
            let hits = child_hits(node, &ray);
            let imask = node.imask as u32;
            let mut leaves = hits & !imask;
            while leaves != 0 {
                let slot = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                let meta = *node.child_meta.get_unchecked(slot) as u32;
                let count = ((meta >> 5) & 7).count_ones() as usize;
                if count != 0 {
                    let start = (node.primitive_base_idx + (meta & 31)) as usize;
                    if leaf_hit(tris, prims, &wt, &op, d, start, count, t_min, t_max) {
                        return Some(true);
                    }
                }
            }
            let inner = hits & imask;
            if inner != 0 {
                if sp == STACK {
                    return None;
                }
                stack.get_unchecked_mut(sp).write((node.child_base_idx as u64) << 16 | (imask as u64) << 8 | permute(inner, oct) as u64);
                sp += 1;
            }
            // The next child: the nearest one left on the top of the stack.
            if sp == 0 {
                return Some(false);
            }
            let top = stack.get_unchecked_mut(sp - 1).assume_init_mut();
            let left = (*top & 0xff) as u32;
            let slot = left.trailing_zeros() ^ oct;
            if left & (left - 1) == 0 {
                sp -= 1;
            } else {
                *top &= !(1u64 << left.trailing_zeros());
            }
            let word = *top;
            let (base, imask) = ((word >> 16) as u32, ((word >> 8) & 0xff) as u32);
            let index = base + (imask & ((1 << slot) - 1)).count_ones();
            node = bvh.nodes.get_unchecked(index as usize);
        }
    }
}

/// The traversal of `sse` with 8-lane AVX2 box tests (the same arithmetic per lane), and the primitives of
/// all the leaves a node's box test keeps tested together, 8 lanes at a time (a CWBVH node's leaf children
/// own one run of up to 24 primitives from `primitive_base_idx`).
#[cfg(target_arch = "x86_64")]
mod avx2;
