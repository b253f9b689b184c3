// Exact shadow rays on the GPU: any-hit traversal of a binary BVH (obvhs Bvh2, built and packed by
// src/gpu/bvh.rs) over triangles (watertight test, Woop, Benthin and Wald, JCGT 2013) and analytic
// spheres (Mitsuba 3.9.1 sphere.cpp, in f32), with Mitsuba's ray offsets (offset_p / spawn_ray_to), so
// that results match the CPU `raytrace::RayTracer::occluded`.
// Needs, declared by the including module: `bvh_nodes: array<BvhNode>` and `bvh_prims: array<BvhPrim>`
// (storage, read).
//
// Loop bounds (Mesa 22.3 silently stops an invocation after 65,535 loop iterations, WGPU_HEADLESS.md
// Trap 1): one ray takes at most BVH_MAX_RAY_STEPS steps (a step = one visited node pair or one
// primitive test), and all rays of one invocation share BVH_INVOCATION_BUDGET steps. A ray that runs
// out (or overflows its stack) returns BVH_GAVE_UP; callers count those (they must never happen).

// Keep in sync with src/gpu/bvh.rs.
const BVH_MAX_RAY_STEPS: u32 = 2048u;
const BVH_INVOCATION_BUDGET: u32 = 61440u;
const BVH_STACK_SIZE: u32 = 48u;
const PRIM_TRIANGLE: u32 = 0u;
const PRIM_SPHERE: u32 = 1u;
// Mitsuba's math::RayEpsilon<float> (1500 * 2^-24) and ShadowEpsilon (10 RayEpsilon).
const RAY_EPSILON: f32 = 8.940696716308594e-5;
const SHADOW_EPSILON: f32 = 8.940696716308594e-4;
// Results of trace_occlusion.
const BVH_FREE: u32 = 0u;
const BVH_BLOCKED: u32 = 1u;
const BVH_GAVE_UP: u32 = 2u;
const BVH_T_INF: f32 = 3.0e38;

// Keep in sync with `GpuBvhNode` in src/gpu/bvh.rs (32 bytes). Inner node: prim_count 0, children at
// first_index and first_index + 1. Leaf: prim_count primitives from bvh_prims[first_index].
struct BvhNode {
    aabb_min: vec3<f32>,
    prim_count: u32,
    aabb_max: vec3<f32>,
    first_index: u32,
}

// Keep in sync with `GpuPrimitive` in src/gpu/bvh.rs (48 bytes). Triangle: v0, v1, v2.
// Sphere: v0 = centre, v1.x = radius.
struct BvhPrim {
    v0: vec3<f32>,
    kind: u32,
    v1: vec3<f32>,
    // Offset of its mesh's record in the mask table (common/mask.wgsl), MASK_NONE when not masked.
    mask: u32,
    v2: vec3<f32>,
    // The triangle's index in its mesh (0 for a sphere).
    index: u32,
}

// Steps left for this invocation (shared by all its rays).
var<private> bvh_budget: u32 = BVH_INVOCATION_BUDGET;
// Steps taken by the current ray.
var<private> bvh_ray_steps: u32 = 0u;

// One more step of the current ray; false when the ray or the invocation is out of steps.
fn bvh_step() -> bool {
    if bvh_ray_steps >= BVH_MAX_RAY_STEPS || bvh_budget == 0u {
        return false;
    }
    bvh_ray_steps = bvh_ray_steps + 1u;
    bvh_budget = bvh_budget - 1u;
    return true;
}

// Mitsuba's Interaction::offset_p: p moved along n_g toward the side d points to by
// (1 + max_i |p_i|) RAY_EPSILON.
fn offset_p(p: vec3<f32>, n_g: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    let mag = (1.0 + max(max(a.x, a.y), a.z)) * RAY_EPSILON;
    return p + n_g * select(-mag, mag, dot(n_g, d) >= 0.0);
}

// A ray prepared for the watertight triangle test: origin, permuted axes, shear constants.
struct WatertightRay {
    o: vec3<f32>,
    kx: u32,
    ky: u32,
    kz: u32,
    sx: f32,
    sy: f32,
    sz: f32,
    // Smallest accepted triangle t: (1 + max_i |o_i|) 2^-20 (see hit_triangle).
    t_min: f32,
}

fn watertight_ray(o: vec3<f32>, d: vec3<f32>) -> WatertightRay {
    var r: WatertightRay;
    let a = abs(d);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    r.o = o;
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.sx = d[kx] / d[kz];
    r.sy = d[ky] / d[kz];
    r.sz = 1.0 / d[kz];
    let ao = abs(o);
    r.t_min = (1.0 + max(max(ao.x, ao.y), ao.z)) * 9.5367431640625e-7;
    return r;
}

// Edge functions robust to fused multiply-adds. WGSL cannot forbid contraction, and drivers (Metal's
// fast math, others) may evaluate a*b - c*d as fma(a, b, -c*d) or fma(-c, d, a*b). Without contraction
// the rounded difference has the exact sign or is 0 (rounding is monotonic), which is what makes
// Woop's test watertight; with it, the sign can be wrong, so that a ray through an edge shared by two
// triangles (or a vertex) misses all of them. Under any grouping the rounded result is within
// 2 u (|a b| + |c d|) of the exact one (u = 2^-24), so a result above EDGE_FILTER (|a b| + |c d|) has
// the exact sign; the others are recomputed exactly by `exact_diff_of_products`. Valid while the
// products stay normal floats (above 2^-126).
const EDGE_FILTER: f32 = 4.76837158203125e-7;

// a = hi + lo, each of at most 12 significant bits (hi: a with the low 12 bits of its significand
// cleared; lo = a - hi is exact): every product of two halves is exact, so a fused multiply-add of
// one rounds like a multiply then an add. Integer masking leaves nothing to contract (Dekker's
// 4097 a split does not survive contraction).
fn split_bits(a: f32) -> vec2<f32> {
    let hi = bitcast<f32>(bitcast<u32>(a) & 0xfffff000u);
    return vec2<f32>(hi, a - hi);
}

// Knuth's TwoSum: (s, e) with s = fl(a + b) and a + b = s + e exactly (additions only).
fn two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    let bb = s - a;
    return vec2<f32>(s, (a - (s - bb)) + (b - bb));
}

// Shewchuk's Grow-Expansion of the nonoverlapping expansion e (increasing magnitude) by b: the five
// components of e + b, exactly, in `lo` (four) and `top`.
struct Expansion5 {
    lo: vec4<f32>,
    top: f32,
}

fn grow4(e: vec4<f32>, b: f32) -> Expansion5 {
    let q0 = two_sum(b, e.x);
    let q1 = two_sum(q0.x, e.y);
    let q2 = two_sum(q1.x, e.z);
    let q3 = two_sum(q2.x, e.w);
    return Expansion5(vec4<f32>(q0.y, q1.y, q2.y, q3.y), q3.x);
}

fn grow2(e: vec2<f32>, b: f32) -> vec3<f32> {
    let q0 = two_sum(b, e.x);
    let q1 = two_sum(q0.x, e.y);
    return vec3<f32>(q0.y, q1.y, q1.x);
}

// Expansion-Sum of two 2-component expansions (each (error, sum)): 4 components, exactly.
fn sum22(e: vec2<f32>, f: vec2<f32>) -> vec4<f32> {
    let g = grow2(e, f.x);
    let h = grow2(g.yz, f.y);
    return vec4<f32>(g.x, h);
}

// a*b - c*d with the sign exact under any contraction: eight exact partial products summed into a
// nonoverlapping expansion (Shewchuk 1997, Expansion-Sum), whose largest nonzero component carries the
// sign. Returns the expansion's rounded sum, or that component where rounding disagreed in sign.
fn exact_diff_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let sa = split_bits(a);
    let sb = split_bits(b);
    let sc = split_bits(c);
    let sd = split_bits(d);
    let e0 = two_sum(sa.x * sb.x, -(sc.x * sd.x));
    let e1 = two_sum(sa.x * sb.y, -(sc.x * sd.y));
    let e2 = two_sum(sa.y * sb.x, -(sc.y * sd.x));
    let e3 = two_sum(sa.y * sb.y, -(sc.y * sd.y));
    let f = sum22(e0.yx, e1.yx);
    let g = sum22(e2.yx, e3.yx);
    // Expansion-Sum of f and g: g's components grow the upper part of the expansion one at a time.
    let h0 = grow4(f, g.x);
    let h1 = grow4(vec4<f32>(h0.lo.yzw, h0.top), g.y);
    let h2 = grow4(vec4<f32>(h1.lo.yzw, h1.top), g.z);
    let h3 = grow4(vec4<f32>(h2.lo.yzw, h2.top), g.w);
    let low = vec4<f32>(h0.lo.x, h1.lo.x, h2.lo.x, h3.lo.x);
    let high = vec4<f32>(h3.lo.yzw, h3.top);
    // The largest nonzero component, without loops (they would count against Mesa's iteration cap).
    var top = select(0.0, low.x, low.x != 0.0);
    top = select(top, low.y, low.y != 0.0);
    top = select(top, low.z, low.z != 0.0);
    top = select(top, low.w, low.w != 0.0);
    top = select(top, high.x, high.x != 0.0);
    top = select(top, high.y, high.y != 0.0);
    top = select(top, high.z, high.z != 0.0);
    top = select(top, high.w, high.w != 0.0);
    let sum = (((low.x + low.y) + (low.z + low.w)) + high.x + high.y) + high.z + high.w;
    return select(top, sum, sign(sum) == sign(top));
}

// The edge function a*b - c*d: rounded when that has the exact sign, else exact (see EDGE_FILTER).
fn edge_function(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let e = a * b - c * d;
    if abs(e) <= EDGE_FILTER * (abs(a * b) + abs(c * d)) {
        return exact_diff_of_products(a, b, c, d);
    }
    return e;
}

// Watertight ray-triangle test (both faces); a hit needs t_min < t < t_max. Each edge function has its
// exact sign under any contraction (`edge_function`), so triangles sharing an edge or a vertex agree.
// Deviation: the CPU tracer (and Mitsuba) accept any t > 0; when the origin lies exactly in a
// triangle's plane (a shadow ray from a wall/ceiling contact edge, offset along the wall's normal,
// starts in the ceiling's plane) the sign of t is rounding noise, and the GPU's rounding (fused
// multiply-adds) differs from the CPU's. Hits closer than about 1e-6 relative to the origin's magnitude
// (100x below Mitsuba's ray offset) are treated as that degenerate case and ignored.
// src/gpu/watertight.rs mirrors `triangle_hit` line for line (its tests contract every a*b +- c*d).
// `triangle_hit` returns (t, b1, b2): the hit distance and the barycentric weights of p1 and p2 (as the
// CPU's `WatertightRay::intersect_triangle`), t = -1 for a miss; `hit_triangle` whether it hit.
fn hit_triangle(r: WatertightRay, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, t_max: f32) -> bool {
    return triangle_hit(r, p0, p1, p2, t_max).x > 0.0;
}

fn triangle_hit(r: WatertightRay, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, t_max: f32) -> vec3<f32> {
    let a = p0 - r.o;
    let b = p1 - r.o;
    let c = p2 - r.o;
    let ax = a[r.kx] - r.sx * a[r.kz];
    let ay = a[r.ky] - r.sy * a[r.kz];
    let bx = b[r.kx] - r.sx * b[r.kz];
    let by = b[r.ky] - r.sy * b[r.kz];
    let cx = c[r.kx] - r.sx * c[r.kz];
    let cy = c[r.ky] - r.sy * c[r.kz];
    let u = edge_function(cx, by, cy, bx);
    let v = edge_function(ax, cy, ay, cx);
    let w = edge_function(bx, ay, by, ax);
    let miss = vec3<f32>(-1.0, 0.0, 0.0);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return miss;
    }
    let det = u + v + w;
    if det == 0.0 {
        return miss;
    }
    let t_scaled = u * (r.sz * a[r.kz]) + v * (r.sz * b[r.kz]) + w * (r.sz * c[r.kz]);
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    // A NaN t (degenerate or non-finite vertices) misses, tested on the bits (bsdf.wgsl's `is_nan_f32`
    // is not in every module that includes this file).
    if t > r.t_min && t < t_max && (bitcast<u32>(t) & 0x7fffffffu) <= 0x7f800000u {
        return vec3<f32>(t, v * inv_det, w * inv_det);
    }
    return miss;
}

// Ray-sphere test as Mitsuba's sphere.cpp: the origin is moved to the foot of the perpendicular from the
// centre before solving the quadratic (in f32 here; the CPU tracer uses f64). Hit when 0 < t < t_max.
fn hit_sphere(center: vec3<f32>, radius: f32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return sphere_hit(center, radius, o, d, 0.0, t_max) > 0.0;
}

// The nearest t of the sphere with t_min < t < t_max (t_min >= 0), -1 when there is none.
fn sphere_hit(center: vec3<f32>, radius: f32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    let l = o - center;
    let dd = dot(d, d);
    let plane_t = -dot(l, d) / dd;
    let o_plane = l + d * plane_t;
    let qa = dd;
    let qb = 2.0 * dot(o_plane, d);
    let qc = dot(o_plane, o_plane) - radius * radius;
    let discrim = qb * qb - 4.0 * qa * qc;
    if discrim < 0.0 {
        return -1.0;
    }
    let temp = -0.5 * (qb + select(-sqrt(discrim), sqrt(discrim), qb >= 0.0));
    let x0 = temp / qa;
    let x1 = select(x0, qc / temp, temp != 0.0);
    let near = min(x0, x1) + plane_t;
    let far = max(x0, x1) + plane_t;
    if near > t_min && near < t_max {
        return near;
    }
    if far > t_min && far < t_max {
        return far;
    }
    return -1.0;
}

// Entry distance of the ray into a node's box, or -1 when it misses [0, t_max]. Boxes are padded on the
// host and the exit distance is scaled by 1 + 2 gamma(3) (Ize, "Robust BVH Ray Traversal", JCGT 2013),
// so rounding never culls a box the ray touches.
fn box_entry(bmin: vec3<f32>, bmax: vec3<f32>, o: vec3<f32>, inv_d: vec3<f32>, t_max: f32) -> f32 {
    let t1 = (bmin - o) * inv_d;
    let t2 = (bmax - o) * inv_d;
    let tn = min(t1, t2);
    let tf = max(t1, t2);
    let t_near = max(max(max(tn.x, tn.y), tn.z), 0.0);
    let t_far = min(min(min(tf.x, tf.y), tf.z), t_max) * 1.0000004;
    return select(-1.0, t_near, t_near <= t_far);
}

// Any primitive of a leaf hit with 0 < t < t_max? BVH_GAVE_UP when out of steps.
fn leaf_occlusion(node: BvhNode, r: WatertightRay, d: vec3<f32>, t_max: f32) -> u32 {
    for (var k = 0u; k < node.prim_count; k = k + 1u) {
        if !bvh_step() {
            return BVH_GAVE_UP;
        }
        let prim = bvh_prims[node.first_index + k];
        var hit = false;
        if prim.kind == PRIM_SPHERE {
            hit = hit_sphere(prim.v0, prim.v1.x, r.o, d, t_max);
        } else {
            hit = hit_triangle(r, prim.v0, prim.v1, prim.v2, t_max);
        }
        if hit {
            return BVH_BLOCKED;
        }
    }
    return BVH_FREE;
}

// Whether anything lies on o + t d for 0 < t < t_max: BVH_FREE, BVH_BLOCKED or BVH_GAVE_UP.
fn trace_occlusion(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> u32 {
    bvh_ray_steps = 0u;
    // Zero components become tiny ones of either sign: the slab of that axis then holds the origin or not.
    let tiny = vec3<f32>(1e-30);
    let d_safe = select(d, select(tiny, -tiny, d < vec3<f32>(0.0)), abs(d) < tiny);
    let inv_d = 1.0 / d_safe;
    let r = watertight_ray(o, d);
    let root = bvh_nodes[0];
    if box_entry(root.aabb_min, root.aabb_max, o, inv_d, t_max) < 0.0 {
        return BVH_FREE;
    }
    if root.prim_count > 0u {
        return leaf_occlusion(root, r, d, t_max);
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var current = root.first_index;
    loop {
        if !bvh_step() {
            return BVH_GAVE_UP;
        }
        var near_node = bvh_nodes[current];
        var far_node = bvh_nodes[current + 1u];
        var t_near = box_entry(near_node.aabb_min, near_node.aabb_max, o, inv_d, t_max);
        var t_far = box_entry(far_node.aabb_min, far_node.aabb_max, o, inv_d, t_max);
        // Visit the nearer child first (misses sort last).
        if t_far >= 0.0 && (t_near < 0.0 || t_far < t_near) {
            let tn = near_node;
            near_node = far_node;
            far_node = tn;
            let tt = t_near;
            t_near = t_far;
            t_far = tt;
        }
        var go_near = false;
        if t_near >= 0.0 {
            if near_node.prim_count > 0u {
                let res = leaf_occlusion(near_node, r, d, t_max);
                if res != BVH_FREE {
                    return res;
                }
            } else {
                go_near = true;
            }
        }
        var go_far = false;
        if t_far >= 0.0 {
            if far_node.prim_count > 0u {
                let res = leaf_occlusion(far_node, r, d, t_max);
                if res != BVH_FREE {
                    return res;
                }
            } else {
                go_far = true;
            }
        }
        if go_near && go_far {
            if sp >= BVH_STACK_SIZE {
                return BVH_GAVE_UP;
            }
            stack[sp] = far_node.first_index;
            sp = sp + 1u;
            current = near_node.first_index;
        } else if go_near {
            current = near_node.first_index;
        } else if go_far {
            current = far_node.first_index;
        } else {
            if sp == 0u {
                return BVH_FREE;
            }
            sp = sp - 1u;
            current = stack[sp];
        }
    }
    return BVH_FREE;
}

// Whether anything lies on o + t d for 0 < t < t_max (d need not be unit length). A ray that gave up
// counts as occluded; use trace_occlusion to tell.
fn occluded(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return trace_occlusion(o, d, t_max) != BVH_FREE;
}

// Mitsuba's spawn_ray_to + ray_test: shadow ray from surface point p (geometric normal n_g) to point q.
fn trace_to_point(p: vec3<f32>, n_g: vec3<f32>, q: vec3<f32>) -> u32 {
    let o = offset_p(p, n_g, q - p);
    let d = q - o;
    let dist = length(d);
    return trace_occlusion(o, d / dist, dist * (1.0 - SHADOW_EPSILON));
}

// Mitsuba's spawn_ray + ray_test: from surface point p along unit direction wo, unbounded.
fn trace_direction(p: vec3<f32>, n_g: vec3<f32>, wo: vec3<f32>) -> u32 {
    return trace_occlusion(offset_p(p, n_g, wo), wo, BVH_T_INF);
}

// ---- Closest hits (masked surfaces, common/mask.wgsl): the same traversal, the ray shortened to each hit.

// The closest hit of a ray: status BVH_FREE (none), BVH_BLOCKED (a hit) or BVH_GAVE_UP; the primitive
// (index into bvh_prims), its t and, for a triangle, the barycentric weights b1, b2 of v1 and v2.
struct BvhHit {
    status: u32,
    prim: u32,
    t: f32,
    b1: f32,
    b2: f32,
}

// Shortens `best` to the leaf's closest primitive hit with t < best.t; false when out of steps.
fn leaf_closest(node: BvhNode, r: WatertightRay, d: vec3<f32>, best: ptr<function, BvhHit>) -> bool {
    for (var k = 0u; k < node.prim_count; k = k + 1u) {
        if !bvh_step() {
            return false;
        }
        let index = node.first_index + k;
        let prim = bvh_prims[index];
        if prim.kind == PRIM_SPHERE {
            let t = sphere_hit(prim.v0, prim.v1.x, r.o, d, r.t_min, (*best).t);
            if t > 0.0 {
                *best = BvhHit(BVH_BLOCKED, index, t, 0.0, 0.0);
            }
        } else {
            let h = triangle_hit(r, prim.v0, prim.v1, prim.v2, (*best).t);
            if h.x > 0.0 {
                *best = BvhHit(BVH_BLOCKED, index, h.x, h.y, h.z);
            }
        }
    }
    return true;
}

// The closest primitive on o + t d for t_floor < t < t_max (the CPU's `RayTracer::intersect`, t_floor
// = (1 + max |o|) 2^-20 for triangles and spheres alike, as `SceneBvh::closest` floors its queries).
fn trace_closest(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> BvhHit {
    bvh_ray_steps = 0u;
    let tiny = vec3<f32>(1e-30);
    let d_safe = select(d, select(tiny, -tiny, d < vec3<f32>(0.0)), abs(d) < tiny);
    let inv_d = 1.0 / d_safe;
    let r = watertight_ray(o, d);
    var best = BvhHit(BVH_FREE, 0u, t_max, 0.0, 0.0);
    let root = bvh_nodes[0];
    if box_entry(root.aabb_min, root.aabb_max, o, inv_d, t_max) < 0.0 {
        return best;
    }
    if root.prim_count > 0u {
        if !leaf_closest(root, r, d, &best) {
            best.status = BVH_GAVE_UP;
        }
        return best;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var current = root.first_index;
    loop {
        if !bvh_step() {
            best.status = BVH_GAVE_UP;
            return best;
        }
        var near_node = bvh_nodes[current];
        var far_node = bvh_nodes[current + 1u];
        var t_near = box_entry(near_node.aabb_min, near_node.aabb_max, o, inv_d, best.t);
        var t_far = box_entry(far_node.aabb_min, far_node.aabb_max, o, inv_d, best.t);
        if t_far >= 0.0 && (t_near < 0.0 || t_far < t_near) {
            let tn = near_node;
            near_node = far_node;
            far_node = tn;
            let tt = t_near;
            t_near = t_far;
            t_far = tt;
        }
        var go_near = false;
        if t_near >= 0.0 {
            if near_node.prim_count > 0u {
                if !leaf_closest(near_node, r, d, &best) {
                    best.status = BVH_GAVE_UP;
                    return best;
                }
            } else {
                go_near = true;
            }
        }
        var go_far = false;
        // The near leaf may have shortened the ray past the far child's box.
        if t_far >= 0.0 && t_far <= best.t {
            if far_node.prim_count > 0u {
                if !leaf_closest(far_node, r, d, &best) {
                    best.status = BVH_GAVE_UP;
                    return best;
                }
            } else {
                go_far = true;
            }
        }
        if go_near && go_far {
            if sp >= BVH_STACK_SIZE {
                best.status = BVH_GAVE_UP;
                return best;
            }
            stack[sp] = far_node.first_index;
            sp = sp + 1u;
            current = near_node.first_index;
        } else if go_near {
            current = near_node.first_index;
        } else if go_far {
            current = far_node.first_index;
        } else {
            if sp == 0u {
                return best;
            }
            sp = sp - 1u;
            current = stack[sp];
        }
    }
    return best;
}
