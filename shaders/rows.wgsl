// Light rows (src/gpu/rows.rs): row i of the light matrix = every light's contribution to view sample i.
// Each row has a cube depth map (6 layers of the batch's depth array) centred at its view sample, and
// one thread per (row, light) evaluates A(i, j) = bsdf_eval(...) * light_emitted(l_j, p_i, n_i) * V(i, j)
// exactly as columns.wgsl does (same light.wgsl / bsdf.wgsl), with V read from the row's cube map: the
// roles of `shadow_map_decide` are swapped (the map is centred at the receiver, the light end is tested).
// Needs common/bsdf.wgsl, common/light.wgsl, common/shadow_layer.wgsl, common/bvh.wgsl, common/mask.wgsl.
//
// Loops per invocation: 4 footprint taps and at most one BVH ray (<= BVH_MAX_RAY_STEPS = 2048 steps), or
// in a scene with masked surfaces one mask ray (its traversals share BVH_INVOCATION_BUDGET): below Mesa
// 22.3's 65,535 iterations.

const WORKGROUP_SIZE: u32 = 64u;

// Keep in sync with `RowParams` in src/gpu/rows.rs (48 bytes).
struct RowParams {
    // Rows of this dispatch: entries [first_row, first_row + num_rows) of `rows`; output row k = gid.y.
    num_rows: u32,
    // Lights of this dispatch: `lights[0 .. num_lights]` are global lights first_light + gid.x.
    num_lights: u32,
    first_row: u32,
    first_light: u32,
    // n: the output row stride (in RGB triples).
    total_lights: u32,
    resolution: u32,
    // VISIBILITY_SHADOW_MAP, VISIBILITY_HYBRID or VISIBILITY_RAY_TRACED.
    visibility: u32,
    _pad0: u32,
    // Biases of the shadow-map-only mode, in texels of the cube face at the light end.
    normal_offset: f32,
    depth_bias: f32,
    slope_bias: f32,
    _pad1: f32,
}

// Keep in sync with `GpuRowInfo` in src/gpu/rows.rs (32 bytes).
struct RowInfo {
    // Cube centre: the view sample offset off its surface toward the viewer's side (Mitsuba's offset_p).
    center: vec3<f32>,
    // View sample index i.
    sample: u32,
    // Distance from the centre of the far point standing in for directional lights (outside the scene).
    far_dist: f32,
    // First of the row's 6 layers; ROW_NO_MAP for background samples (no cube rendered).
    first_layer: u32,
    _pad0: vec2<u32>,
}

@group(0) @binding(0) var<uniform> params: RowParams;
@group(0) @binding(1) var<storage, read> samples: array<ViewSample>;
@group(0) @binding(2) var<storage, read> bsdfs: array<Bsdf>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> rows: array<RowInfo>;
@group(0) @binding(5) var<storage, read> layers: array<ShadowLayer>;
@group(0) @binding(6) var cube_maps: texture_depth_2d_array;
@group(0) @binding(7) var<storage, read_write> out_rows: array<f32>;
@group(0) @binding(8) var<storage, read> bsdf_tables: array<f32>;
@group(0) @binding(9) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(10) var<storage, read> bvh_prims: array<BvhPrim>;
// 64-bit counters as (lo, hi) u32 pairs: shadow tests, ray casts, rays that gave up (shared with columns).
@group(0) @binding(11) var<storage, read_write> stats: array<atomic<u32>, 6>;
// Projected textures of spot lights (common/light.wgsl `spot_texture_eval`).
@group(0) @binding(12) var<storage, read> spot_textures: array<f32>;
// The mask table (common/mask.wgsl, src/gpu/mask.rs); a few unused words without masks.
@group(0) @binding(13) var<storage, read> masks: array<u32>;

const ROW_NO_MAP: u32 = 0xffffffffu;

fn bsdf_record(i: u32) -> Bsdf {
    return bsdfs[i];
}

fn bsdf_table(i: u32) -> f32 {
    return bsdf_tables[i];
}

// A texel of the rows' cube maps (for common/visibility.wgsl).
fn depth_texel(xy: vec2<i32>, layer: u32) -> f32 {
    return textureLoad(cube_maps, xy, i32(layer), 0);
}

// Where the light is tested in the row's cube: its position, or for a directional light a point at
// far_dist along wo (outside the scene's bounding sphere, inside the cube's far plane).
fn light_end(row: RowInfo, l: Light, wo: vec3<f32>) -> vec3<f32> {
    if l.kind == LIGHT_DIRECTIONAL {
        return row.center + wo * row.far_dist;
    }
    return l.position;
}

// The plane a light lies on (oriented points: their emission normal; VPLs: their geometric normal);
// zero for lights in free space.
fn light_plane(l: Light) -> vec3<f32> {
    if l.kind == LIGHT_ORIENTED_POINT {
        return l.normal;
    }
    if l.kind == LIGHT_VPL {
        return l.geo_normal;
    }
    return vec3<f32>(0.0);
}

// The hybrid test from the row's cube map: the 2x2 texel footprint around the light end q decides where
// it is unambiguous, everything else is SM_UNSURE (-> exact ray, as columns.wgsl).
// - Light on a surface (oriented point, VPL; plane normal n_l): all four taps on q's own plane (depth
//   predicted from the plane's map-space gradient) -> the light's surface is the first thing seen from
//   the view sample -> SM_LIT. (This replaces an offset of q along n_l: the ties are tested directly.)
// - Light in free space (point, spot, directional's far point): all four taps farther than q (or empty:
//   depth 1) -> nothing lies between the view sample and q -> SM_LIT.
// - One coplanar occluder well in front of q at every tap and at q's own ray -> SM_SHADOW.
// Also SM_UNSURE: lights on the other side of the sample's geometric plane than the viewer (the cube is
// centred on the viewer's side; the exact ray decides those as columns do), q behind the near plane,
// footprints crossing a face edge.
fn row_map_decide(row: RowInfo, s: ViewSample, l: Light, wo: vec3<f32>) -> u32 {
    if dot(wo, s.geo_normal) * dot(s.wi, s.geo_normal) <= 0.0 {
        return SM_UNSURE;
    }
    let q = light_end(row, l, wo);
    let v = q - row.center;
    let li = row.first_layer + cube_face(v);
    let m = layers[li].view_proj;
    let c = to_map(m, q);
    if c.w <= 0.0 || c.z < 0.0 {
        return SM_UNSURE;
    }
    let texel = layers[li].texel_scale * abs(c.w);
    let xy0 = footprint_origin(c);
    if xy0.x < 0 {
        return SM_UNSURE;
    }
    let k = depth_scale(m, c, q, -normalize(v), texel);
    if !positive(k) {
        return SM_UNSURE;
    }
    let n_l = light_plane(l);
    let free_end = all(n_l == vec3<f32>(0.0));
    var g = vec3<f32>(0.0, 0.0, 1.0);
    if !free_end {
        g = plane_gradient(m, c, q, n_l, texel);
        if g.z == 0.0 {
            return SM_UNSURE;
        }
    }
    return footprint_decide(li, xy0, c, g.xy, k, texel, free_end);
}

// Shadow-map-only visibility (biases of ColumnOptions, in texels at the light end): the light end moved
// toward the cube centre by depth_bias (+ slope_bias * tan of the angle to a surface light's plane) and,
// for lights on surfaces, along their plane normal toward the centre by normal_offset; then one depth
// comparison at its texel.
fn row_visibility_biased(row: RowInfo, l: Light, wo: vec3<f32>) -> f32 {
    let q = light_end(row, l, wo);
    let li0 = row.first_layer + cube_face(q - row.center);
    let c0 = layers[li0].view_proj * vec4<f32>(q, 1.0);
    let texel = layers[li0].texel_scale * abs(c0.w);
    let toward = normalize(row.center - q);
    var q_off = q + toward * (texel * params.depth_bias);
    let n_l = light_plane(l);
    if any(n_l != vec3<f32>(0.0)) {
        let cos_l = dot(n_l, toward);
        let side = select(-n_l, n_l, cos_l >= 0.0);
        let cl = max(abs(cos_l), 0.05);
        let tan_l = min(sqrt(max(1.0 - cl * cl, 0.0)) / cl, 10.0);
        q_off = q_off + side * (texel * params.normal_offset) + toward * (texel * params.slope_bias * tan_l);
    }
    let li = row.first_layer + cube_face(q_off - row.center);
    let c = to_map(layers[li].view_proj, q_off);
    if c.w <= 0.0 {
        return 1.0;
    }
    let r = i32(params.resolution) - 1;
    let xy = vec2<i32>(clamp(i32(floor(c.x)), 0, r), clamp(i32(floor(c.y)), 0, r));
    let stored = textureLoad(cube_maps, xy, i32(li), 0);
    return select(0.0, 1.0, c.z <= stored);
}

fn row_visibility(row: RowInfo, s: ViewSample, l: Light, wo: vec3<f32>) -> f32 {
    count_tests = count_tests + 1u;
    if params.visibility == VISIBILITY_RAY_TRACED {
        return visibility_ray(l, s.position, s.geo_normal, wo, 1.0);
    }
    if params.visibility == VISIBILITY_HYBRID {
        let d = row_map_decide(row, s, l, wo);
        if d == SM_UNSURE {
            // The exact ray of the column pass, from the view sample, so rows and columns agree there.
            return visibility_ray(l, s.position, s.geo_normal, wo, row_visibility_biased(row, l, wo));
        }
        return select(0.0, 1.0, d == SM_LIT);
    }
    return row_visibility_biased(row, l, wo);
}

// `row_visibility` in a scene with masked surfaces, as columns.wgsl's `visibility_masked`: (expected
// transmittance, 1 when the ray crossed a masked surface); the exact mask ray is cast from the view
// sample unless the row's cube map is certain that nothing lies between.
fn row_visibility_masked(row: RowInfo, s: ViewSample, l: Light, wo: vec3<f32>) -> vec2<f32> {
    if mask_vpl_out_of_depth(s, l) {
        return vec2<f32>(0.0, 0.0);
    }
    let budget = mask_light_budget(s, l);
    if budget == 0u {
        return vec2<f32>(row_visibility(row, s, l, wo), 0.0);
    }
    count_tests = count_tests + 1u;
    var fallback = 1.0;
    if params.visibility == VISIBILITY_HYBRID {
        if row_map_decide(row, s, l, wo) == SM_LIT {
            return vec2<f32>(1.0, 0.0);
        }
        fallback = row_visibility_biased(row, l, wo);
    } else if params.visibility == VISIBILITY_SHADOW_MAP {
        fallback = row_visibility_biased(row, l, wo);
        if fallback == 1.0 {
            return vec2<f32>(1.0, 0.0);
        }
    }
    return mask_transmittance(s.position, s.geo_normal, l, wo, budget, fallback);
}

// Per-workgroup visibility counters, added to `stats` by one thread (one global atomic per workgroup).
var<workgroup> wg_stats: array<atomic<u32>, 3>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let k = gid.x;
    if k < params.num_lights && gid.y < params.num_rows {
        let row = rows[params.first_row + gid.y];
        let s = samples[row.sample];
        var contribution = vec3<f32>(0.0);
        if s.shape_index >= 0 {
            // Mitsuba's shading frame from the shading normal, as columns.wgsl.
            let n = s.normal;
            let fs = coordinate_system_s(n);
            let ft = coordinate_system_t(n);
            let wi_local = vec3<f32>(dot(s.wi, fs), dot(s.wi, ft), dot(s.wi, n));
            let l = lights[k];
            let e = light_emitted(l, s.position, n);
            if e.valid {
                let wo_local = vec3<f32>(dot(e.wo, fs), dot(e.wo, ft), dot(e.wo, n));
                let b = bsdfs[row.sample];
                let w = glossy_light_weight(b, s.bsdf_samples, l, s.position, wi_local, wo_local);
                var f = light_shade(l, s.position, e, fs, ft, n, wi_local, b) * s.throughput * w;
                let masked = (s.flags & VIEW_FLAG_MASKS) != 0u;
                if masked && s.mask_valid < 1.0 && l.kind != LIGHT_VPL {
                    f = f * mask_direct_factor(s, b, l, wi_local, wo_local);
                }
                if any(f != vec3<f32>(0.0)) {
                    if masked {
                        let v = row_visibility_masked(row, s, l, e.wo);
                        contribution = f * v.x;
                        if v.y > 0.0 && s.bsdf_samples > 0u && w > 0.0 {
                            contribution = contribution / w;
                        }
                    } else {
                        contribution = f * row_visibility(row, s, l, e.wo);
                    }
                }
            }
        }
        let base = (gid.y * params.total_lights + params.first_light + k) * 3u;
        out_rows[base] = contribution.x;
        out_rows[base + 1u] = contribution.y;
        out_rows[base + 2u] = contribution.z;
        if count_tests != 0u {
            atomicAdd(&wg_stats[0], count_tests);
        }
        if count_rays != 0u {
            atomicAdd(&wg_stats[1], count_rays);
        }
        if count_gave_up != 0u {
            atomicAdd(&wg_stats[2], count_gave_up);
        }
    }
    workgroupBarrier();
    if local == 0u {
        add_stat(0u, atomicLoad(&wg_stats[0]));
        add_stat(1u, atomicLoad(&wg_stats[1]));
        add_stat(2u, atomicLoad(&wg_stats[2]));
    }
}
