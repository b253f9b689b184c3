//! The traversal of `sse` with 8-lane AVX2 box tests (the same arithmetic per lane), and the primitives of
//! all the leaves a node's box test keeps tested together, 8 lanes at a time (a CWBVH node's leaf children
//! own one run of up to 24 primitives from `primitive_base_idx`). One loop answers both queries: any hit
//! (shadow rays, stops at the first) and the closest hit (camera, bounce and VPL rays: the box tests' upper
//! bound shrinks to the nearest hit so far).
use super::super::intersect::intersect_sphere;
use super::sse::{leaf_hit_scalar, obvhs_ray, permute, slab_slack, Geometry, Primitive, BOX_T_MAX_SCALE, STACK};
use super::{TriangleSoa, WatertightRay};
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use std::arch::x86_64::*;

struct BoxRay {
    origin: Vec3A,
    inv_direction: Vec3A,
    neg: [bool; 3],
    /// `1 / max_i |d_i|` (the dominant axis of the watertight test).
    inv_max_d: f32,
    t_min: __m256,
    t_max: __m256,
}

#[target_feature(enable = "avx2")]
#[inline]
unsafe fn widen(q: &[u8; 8]) -> __m256 {
    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(q.as_ptr() as *const __m128i)))
}

/// `sse::child_hits` in one 8-lane pass.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn child_hits(node: &CwBvhNode, ray: &BoxRay) -> u32 {
    let extent = node.compute_extent();
    let rel = Vec3A::from(node.p) - ray.origin;
    let (adj_inv, adj_orig) = (extent * ray.inv_direction, rel * ray.inv_direction);
    let (x_near, x_far) = if ray.neg[0] { (&node.child_max_x, &node.child_min_x) } else { (&node.child_min_x, &node.child_max_x) };
    let (y_near, y_far) = if ray.neg[1] { (&node.child_max_y, &node.child_min_y) } else { (&node.child_min_y, &node.child_max_y) };
    let (z_near, z_far) = if ray.neg[2] { (&node.child_max_z, &node.child_min_z) } else { (&node.child_min_z, &node.child_max_z) };
    let (ix, iy, iz) = (_mm256_set1_ps(adj_inv.x), _mm256_set1_ps(adj_inv.y), _mm256_set1_ps(adj_inv.z));
    let (ox, oy, oz) = (_mm256_set1_ps(adj_orig.x), _mm256_set1_ps(adj_orig.y), _mm256_set1_ps(adj_orig.z));
    let (e, entry) = slab_slack(extent, rel, adj_inv, adj_orig, ray.inv_max_d);
    let (ex, ey, ez) = (_mm256_set1_ps(e.x), _mm256_set1_ps(e.y), _mm256_set1_ps(e.z));
    let tmin_x = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(widen(x_near), ix), ox), ex);
    let tmax_x = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(widen(x_far), ix), ox), ex);
    let tmin_y = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(widen(y_near), iy), oy), ey);
    let tmax_y = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(widen(y_far), iy), oy), ey);
    let tmin_z = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(widen(z_near), iz), oz), ez);
    let tmax_z = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(widen(z_far), iz), oz), ez);
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(_mm256_sub_ps(tmin, _mm256_set1_ps(entry)), ray.t_min);
    let tmax = _mm256_min_ps(_mm256_mul_ps(tmax, _mm256_set1_ps(BOX_T_MAX_SCALE)), ray.t_max);
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tmin, tmax)) as u32
}

/// The ray-frame edge functions `u`, `v`, `w` of the 8 triangles from `start` and their permuted z
/// offsets `akz`, `bkz`, `ckz` (`WatertightRay::intersect_triangle`'s scalar operations, lane by lane).
struct Edges {
    u: __m256,
    v: __m256,
    w: __m256,
    akz: __m256,
    bkz: __m256,
    ckz: __m256,
}

#[target_feature(enable = "avx2")]
#[inline]
unsafe fn edges(tris: &TriangleSoa, wt: &WatertightRay, o: &[__m256; 3], start: usize) -> Edges {
    let [kx, ky, kz] = wt.k;
    let load = |vertex: usize, axis: usize, o: __m256| _mm256_sub_ps(_mm256_loadu_ps(tris.v[3 * vertex + axis].as_ptr().add(start)), o);
    let (akx, aky, akz) = (load(0, kx, o[0]), load(0, ky, o[1]), load(0, kz, o[2]));
    let (bkx, bky, bkz) = (load(1, kx, o[0]), load(1, ky, o[1]), load(1, kz, o[2]));
    let (ckx, cky, ckz) = (load(2, kx, o[0]), load(2, ky, o[1]), load(2, kz, o[2]));
    let (sx, sy) = (_mm256_set1_ps(wt.sx), _mm256_set1_ps(wt.sy));
    let ax = _mm256_sub_ps(akx, _mm256_mul_ps(sx, akz));
    let ay = _mm256_sub_ps(aky, _mm256_mul_ps(sy, akz));
    let bx = _mm256_sub_ps(bkx, _mm256_mul_ps(sx, bkz));
    let by = _mm256_sub_ps(bky, _mm256_mul_ps(sy, bkz));
    let cx = _mm256_sub_ps(ckx, _mm256_mul_ps(sx, ckz));
    let cy = _mm256_sub_ps(cky, _mm256_mul_ps(sy, ckz));
    Edges {
        u: _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx)),
        v: _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx)),
        w: _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax)),
        akz,
        bkz,
        ckz,
    }
}

/// Lanes that the scalar test must decide (an edge function exactly 0: the f64 fallback; NaN: a sphere),
/// and for the others the hit test: (scalar lanes, inside and `t_min < t < t_max` lanes, t).
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn lane_hits(e: &Edges, wt: &WatertightRay, lanes: u32, t_min: f32, t_max: f32) -> (u32, u32, __m256) {
    let (u, v, w) = (e.u, e.v, e.w);
    let zero = _mm256_setzero_ps();
    let eq = |a| _mm256_cmp_ps::<_CMP_EQ_OQ>(a, zero);
    let on_edge = _mm256_or_ps(_mm256_or_ps(eq(u), eq(v)), eq(w));
    let scalar = _mm256_or_ps(on_edge, _mm256_cmp_ps::<_CMP_UNORD_Q>(u, u));
    let scalar_lanes = _mm256_movemask_ps(scalar) as u32 & lanes;
    let lt = |a| _mm256_cmp_ps::<_CMP_LT_OS>(a, zero);
    let gt = |a| _mm256_cmp_ps::<_CMP_GT_OS>(a, zero);
    let neg = _mm256_or_ps(_mm256_or_ps(lt(u), lt(v)), lt(w));
    let pos = _mm256_or_ps(_mm256_or_ps(gt(u), gt(v)), gt(w));
    let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    let sz = _mm256_set1_ps(wt.sz);
    let az = _mm256_mul_ps(sz, e.akz);
    let bz = _mm256_mul_ps(sz, e.bkz);
    let cz = _mm256_mul_ps(sz, e.ckz);
    let t_scaled = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, az), _mm256_mul_ps(v, bz)), _mm256_mul_ps(w, cz));
    let t = _mm256_mul_ps(t_scaled, _mm256_div_ps(_mm256_set1_ps(1.0), det));
    let inside = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero));
    let in_range =
        _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OS>(t, _mm256_set1_ps(t_min)), _mm256_cmp_ps::<_CMP_LT_OS>(t, _mm256_set1_ps(t_max)));
    (scalar_lanes, _mm256_movemask_ps(_mm256_and_ps(inside, in_range)) as u32 & lanes & !scalar_lanes, t)
}

/// Whether one of the primitives `start + i` for the set bits `i` of `lanes` is hit (`sse::leaf_hit`
/// in 8 lanes).
#[target_feature(enable = "avx2")]
#[inline]
#[allow(clippy::too_many_arguments)]
unsafe fn prims_hit(
    tris: &TriangleSoa,
    prims: &[Primitive],
    wt: &WatertightRay,
    o: &[__m256; 3],
    d: Vec3,
    start: usize,
    lanes: u32,
    t_min: f32,
    t_max: f32,
) -> bool {
    let e = edges(tris, wt, o, start);
    let (mut scalar, hits, _) = lane_hits(&e, wt, lanes, t_min, t_max);
    while scalar != 0 {
        if leaf_hit_scalar(prims, wt, d, start + scalar.trailing_zeros() as usize, 1, t_min, t_max) {
            return true;
        }
        scalar &= scalar - 1;
    }
    hits != 0
}

/// A hit: the primitive (index into the leaf-ordered primitives), t and the barycentrics of vertices 1
/// and 2 (zero for spheres), as `SceneBvh::closest_brute_force` reports them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneHit {
    pub index: usize,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

/// Moves `best` to the first hit among the primitives `start + i` (set bits `i` of `lanes`) that comes
/// before it: a smaller t, or the same t and a lower index. A lane's t and barycentrics are the scalar test's (`t_scaled * (1 / det)`, `v / det`
/// as `v * (1 / det)`). So among equal t (a shared edge or vertex) the lowest index wins, as when testing
/// every primitive in index order, and the hit does not depend on the order of the traversal.
#[target_feature(enable = "avx2")]
#[inline]
#[allow(clippy::too_many_arguments)]
unsafe fn prims_closest(
    tris: &TriangleSoa,
    prims: &[Primitive],
    wt: &WatertightRay,
    o: &[__m256; 3],
    d: Vec3,
    start: usize,
    lanes: u32,
    t_min: f32,
    best: &mut LaneHit,
) {
    // Candidates: t < t_max before the first hit, t <= best.t after it (the next float up, exclusive).
    let bound = if best.index == usize::MAX || !best.t.is_finite() { best.t } else { f32::from_bits(best.t.to_bits() + 1) };
    let e = edges(tris, wt, o, start);
    let (scalar, hits, t) = lane_hits(&e, wt, lanes, t_min, bound);
    let mut all = scalar | hits;
    if all == 0 {
        return;
    }
    let mut ts = [0f32; 8];
    _mm256_storeu_ps(ts.as_mut_ptr(), t);
    let before = |t: f32, index: usize, best: &LaneHit| t < best.t || (t == best.t && index < best.index);
    while all != 0 {
        let lane = all.trailing_zeros() as usize;
        all &= all - 1;
        let index = start + lane;
        if scalar & (1 << lane) != 0 {
            let hit = match prims.get_unchecked(index).geometry {
                Geometry::Triangle([p0, p1, p2]) => wt.intersect_triangle(p0, p1, p2, t_min, bound).map(|h| (h.t, h.b1, h.b2)),
                Geometry::Sphere { center, radius } => intersect_sphere(center, radius, wt.o, d, t_min, bound).map(|t| (t, 0.0, 0.0)),
            };
            match hit {
                Some((t, b1, b2)) if before(t, index, best) => *best = LaneHit { index, t, b1, b2 },
                _ => {}
            }
        } else if before(ts[lane], index, best) {
            let lane_of = |x: __m256| {
                let mut a = [0f32; 8];
                _mm256_storeu_ps(a.as_mut_ptr(), x);
                a[lane]
            };
            let det = lane_of(_mm256_add_ps(_mm256_add_ps(e.u, e.v), e.w));
            let inv_det = 1.0 / det;
            *best = LaneHit { index, t: ts[lane], b1: lane_of(e.v) * inv_det, b2: lane_of(e.w) * inv_det };
        }
    }
}

/// The traversal (`sse::traverse`'s order and stack): with `CLOSEST`, the nearest hit on `o + t d` with
/// `t_min < t < t_max`; otherwise the first hit found (its `index` is `usize::MAX`). `None` when the stack
/// overflowed.
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn traverse<const CLOSEST: bool>(
    bvh: &CwBvh,
    tris: &TriangleSoa,
    prims: &[Primitive],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<Option<LaneHit>> {
    if bvh.nodes.is_empty() {
        return Some(None);
    }
    let r = obvhs_ray(o, d, t_min, t_max);
    let dir = r.direction;
    let wt = WatertightRay::new(o, d);
    let mut ray = BoxRay {
        origin: r.origin,
        inv_direction: r.inv_direction,
        neg: [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0],
        t_min: _mm256_set1_ps(r.tmin.max(0.0)),
        t_max: _mm256_set1_ps(r.tmax),
        // `|1 / d[kz]|` of the watertight test, kz the dominant axis: 1 / max_i |d_i| exactly.
        inv_max_d: wt.sz.abs(),
    };
    let oct = (ray.neg[0] as u32) << 2 | (ray.neg[1] as u32) << 1 | ray.neg[2] as u32;
    let [kx, ky, kz] = wt.k;
    let op = [_mm256_set1_ps(o[kx]), _mm256_set1_ps(o[ky]), _mm256_set1_ps(o[kz])];
    let mut best = LaneHit { index: usize::MAX, t: t_max, b1: 0.0, b2: 0.0 };
    // Uninitialised (a zeroed stack was a memset per ray); only written words are read.
    let mut stack = [std::mem::MaybeUninit::<u64>::uninit(); STACK];
    let mut sp = 0;
    let mut node = bvh.nodes.get_unchecked(0);
    loop {
        let hits = child_hits(node, &ray);
        let imask = node.imask as u32;
        // The primitives of the leaves hit, as obvhs's 24-bit primitive mask.
        let mut leaves = hits & !imask;
        let mut mask = 0u32;
        while leaves != 0 {
            let meta = *node.child_meta.get_unchecked(leaves.trailing_zeros() as usize) as u32;
            leaves &= leaves - 1;
            mask |= ((meta >> 5) & 7) << (meta & 31);
        }
        while mask != 0 {
            let first = mask.trailing_zeros();
            let (start, lanes) = ((node.primitive_base_idx + first) as usize, (mask >> first) & 0xff);
            if CLOSEST {
                let before = best.t;
                prims_closest(tris, prims, &wt, &op, d, start, lanes, t_min, &mut best);
                if best.t < before {
                    ray.t_max = _mm256_set1_ps(best.t);
                }
            } else if prims_hit(tris, prims, &wt, &op, d, start, lanes, t_min, t_max) {
                return Some(Some(best));
            }
            mask &= !(0xffu32 << first);
        }
        let inner = hits & imask;
        if inner != 0 {
            if sp == STACK {
                return None;
            }
            stack.get_unchecked_mut(sp).write((node.child_base_idx as u64) << 16 | (imask as u64) << 8 | permute(inner, oct) as u64);
            sp += 1;
        }
        if sp == 0 {
            return Some((best.index != usize::MAX).then_some(best));
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
        node = bvh.nodes.get_unchecked((base + (imask & ((1 << slot) - 1)).count_ones()) as usize);
    }
}
