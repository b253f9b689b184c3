// Visibility modes, the hybrid shadow-map test (tolerances and footprint decision) and exact rays, shared by
// columns.wgsl and rows.wgsl
// (rows measure texels of the cube face at the light end, columns of the light's map at the receiver).
// Keep in sync with `Visibility` in src/matrix/mod.rs.
const VISIBILITY_SHADOW_MAP: u32 = 0u;
const VISIBILITY_HYBRID: u32 = 1u;
const VISIBILITY_RAY_TRACED: u32 = 2u;
// Outcome of the hybrid shadow-map test.
const SM_SHADOW: u32 = 0u;
const SM_LIT: u32 = 1u;
const SM_UNSURE: u32 = 2u;
// Hybrid tolerances, in texels of the layer's world-space texel size at p (see `shadow_map_decide`).
// A tap matches the receiver's plane within LIT_TOL + LIT_SLOPE_TOL * (plane's depth change per texel).
const LIT_TOL: f32 = 0.05;
const LIT_SLOPE_TOL: f32 = 0.01;
// An occluder is certain when it lies at least OCCLUDER_GAP in front of p (and of p's plane at every tap).
const OCCLUDER_GAP: f32 = 0.25;
// The four taps count as one plane when their bilinear twist is below PLANAR_TOL.
const PLANAR_TOL: f32 = 0.02;
// Depth-buffer rounding allowance: this many ulps of 1.0 in NDC depth (Depth32Float).
const DEPTH_ULPS: f32 = 16.0;
// Receiver planes seen more grazing than this (texel-area ratio of the plane's projection) are unsure.
const MIN_PROJECTED_AREA: f32 = 0.02;

// ---- Helpers shared by the column and row passes. The including module defines `params.resolution`
// (texels per map side), `stats` (array<atomic<u32>, 6>: 64-bit counters as (lo, hi) pairs) and
// `fn depth_texel(xy: vec2<i32>, layer: u32) -> f32` (a texel of its depth array).

// Per-invocation visibility counters: shadow tests, ray casts, rays that gave up.
var<private> count_tests: u32 = 0u;
var<private> count_rays: u32 = 0u;
var<private> count_gave_up: u32 = 0u;

// Add v to 64-bit counter k of `stats`.
fn add_stat(k: u32, v: u32) {
    if v != 0u {
        let old = atomicAdd(&stats[2u * k], v);
        if old + v < old {
            atomicAdd(&stats[2u * k + 1u], 1u);
        }
    }
}

// q projected into a map layer with view-projection m: (texel x, texel y, NDC depth, clip w); w <= 0
// behind the map's eye.
fn to_map(m: mat4x4<f32>, q: vec3<f32>) -> vec4<f32> {
    let clip = m * vec4<f32>(q, 1.0);
    let res = f32(params.resolution);
    let ndc = clip.xyz / clip.w;
    return vec4<f32>((ndc.x * 0.5 + 0.5) * res, (0.5 - ndc.y * 0.5) * res, ndc.z, clip.w);
}

// The 2x2 footprint of map point c (`to_map` of q): its first texel, or (-1, -1) when the footprint
// leaves the layer.
fn footprint_origin(c: vec4<f32>) -> vec2<i32> {
    let x0 = i32(floor(c.x - 0.5));
    let y0 = i32(floor(c.y - 0.5));
    let r = i32(params.resolution) - 1;
    if x0 < 0 || y0 < 0 || x0 + 1 > r || y0 + 1 > r {
        return vec2<i32>(-1);
    }
    return vec2<i32>(x0, y0);
}

// Depth scale at q toward the map's eye (unit direction `toward`): d(NDC depth) per unit of distance,
// or a value <= 0 where it cannot be measured.
fn depth_scale(m: mat4x4<f32>, c: vec4<f32>, q: vec3<f32>, toward: vec3<f32>, texel: f32) -> f32 {
    let cn = to_map(m, q + toward * texel);
    if cn.w <= 0.0 {
        return -1.0;
    }
    return (c.z - cn.z) / texel;
}

// Map-space depth gradient (per texel in x, y) of the plane through q with normal n, and 1 in z; z = 0
// where the plane projects too grazing (MIN_PROJECTED_AREA) to predict depths from.
fn plane_gradient(m: mat4x4<f32>, c: vec4<f32>, q: vec3<f32>, n: vec3<f32>, texel: f32) -> vec3<f32> {
    let a = to_map(m, q + coordinate_system_s(n) * texel) - c;
    let b = to_map(m, q + coordinate_system_t(n) * texel) - c;
    let det = a.x * b.y - b.x * a.y;
    if !greater(abs(det), MIN_PROJECTED_AREA) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>((a.z * b.y - b.z * a.y) / det, (a.x * b.z - b.x * a.z) / det, 1.0);
}

// The hybrid decision from the four taps of q's footprint (origin xy0) in layer li. c = to_map(q),
// g = the depth gradient (per texel) of the plane the taps are compared with (zero for a point in free
// space), k = depth_scale at q, texel = world texel size at q.
// - on a plane (`free_end` false): all four taps on it within LIT_TOL + LIT_SLOPE_TOL * slope texels
//   (plus DEPTH_ULPS) -> SM_LIT;
// - in free space (`free_end` true): all four taps farther than q or empty -> SM_LIT;
// - one coplanar occluder (bilinear twist below PLANAR_TOL) more than OCCLUDER_GAP in front of q at
//   every tap and at q's own ray -> SM_SHADOW;
// - anything else -> SM_UNSURE (the caller casts the exact ray).
fn footprint_decide(li: u32, xy0: vec2<i32>, c: vec4<f32>, g: vec2<f32>, k: f32, texel: f32, free_end: bool) -> u32 {
    let ulps = DEPTH_ULPS * 1.1920929e-7 / k;
    let slope = (abs(g.x) + abs(g.y)) / k / texel;
    let lit_tol = texel * (LIT_TOL + LIT_SLOPE_TOL * slope) + ulps;
    let gap = texel * OCCLUDER_GAP + ulps;
    var lit_taps = 0u;
    var occluded_taps = 0u;
    var z: array<f32, 4>;
    for (var t = 0u; t < 4u; t = t + 1u) {
        let txy = xy0 + vec2<i32>(i32(t & 1u), i32(t >> 1u));
        z[t] = depth_texel(txy, li);
        // The plane's (or q's own) depth on the tap's ray, and how far the stored surface lies in front.
        let plane_z = c.z + g.x * (f32(txy.x) + 0.5 - c.x) + g.y * (f32(txy.y) + 0.5 - c.y);
        let in_front = (plane_z - z[t]) / k;
        let lit = select(abs(in_front) <= lit_tol, z[t] >= 1.0 || in_front < -lit_tol, free_end);
        if lit {
            lit_taps = lit_taps + 1u;
        } else if in_front > gap {
            occluded_taps = occluded_taps + 1u;
        }
    }
    if lit_taps == 4u {
        return SM_LIT;
    }
    if occluded_taps == 4u {
        let twist = abs(z[0] + z[3] - z[1] - z[2]) / k;
        let fx = c.x - 0.5 - f32(xy0.x);
        let fy = c.y - 0.5 - f32(xy0.y);
        let z_q = mix(mix(z[0], z[1], fx), mix(z[2], z[3], fx), fy);
        if twist <= texel * PLANAR_TOL + ulps && (c.z - z_q) / k > gap {
            return SM_SHADOW;
        }
    }
    return SM_UNSURE;
}

// Exact visibility of light l from surface point p by a BVH ray (Mitsuba's spawn_ray_to toward
// positioned lights; spawn_ray along wo, unbounded, for directional lights). `fallback` is returned
// when the ray runs out of steps (counted; must never happen).
fn visibility_ray(l: Light, p: vec3<f32>, n_g: vec3<f32>, wo: vec3<f32>, fallback: f32) -> f32 {
    count_rays = count_rays + 1u;
    var res = BVH_FREE;
    if l.kind == LIGHT_DIRECTIONAL {
        res = trace_direction(p, n_g, wo);
    } else {
        res = trace_to_point(p, n_g, l.position);
    }
    if res == BVH_GAVE_UP {
        count_gave_up = count_gave_up + 1u;
        return fallback;
    }
    return select(1.0, 0.0, res == BVH_BLOCKED);
}
