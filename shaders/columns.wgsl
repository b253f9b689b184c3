// Light columns (src/gpu/columns.rs): one thread per view sample loops over the batch's lights
// (<= 256 per dispatch: far below Mesa 22.3's 65,535-iteration limit), shades each with bsdf_eval and
// shadow-map visibility, writes the individual columns if asked and adds sum_j w_j column_j to a
// GPU-resident accumulator. Needs common/bsdf.wgsl, common/light.wgsl, common/shadow_layer.wgsl,
// common/bvh.wgsl, common/mask.wgsl. Visibility: shadow map, exact BVH ray, or the hybrid of both (see
// `visibility`); in a scene with masked surfaces `visibility_masked`.

const WORKGROUP_SIZE: u32 = 64u;

// Keep in sync with `ColumnParams` in src/gpu/columns.rs (48 bytes).
struct ColumnParams {
    num_samples: u32,
    num_lights: u32,
    write_columns: u32,
    accumulate: u32,
    resolution: u32,
    // Threads per dispatch row (groups_x * WORKGROUP_SIZE); sample i = gid.y * dispatch_width + gid.x.
    dispatch_width: u32,
    // Lights [first_light, first_light + num_lights) of the batch's arrays are shaded by this dispatch.
    first_light: u32,
    // VISIBILITY_SHADOW_MAP, VISIBILITY_HYBRID or VISIBILITY_RAY_TRACED.
    visibility: u32,
    // Biases in units of the layer's world-space texel size.
    normal_offset: f32,
    depth_bias: f32,
    slope_bias: f32,
    // First view sample of this dispatch: sample i = first_sample + gid.y * dispatch_width + gid.x.
    first_sample: u32,
}

@group(0) @binding(0) var<uniform> params: ColumnParams;
@group(0) @binding(1) var<storage, read> samples: array<ViewSample>;
@group(0) @binding(2) var<storage, read> bsdfs: array<Bsdf>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> layers: array<ShadowLayer>;
// RGB weight of each light of the batch (w unused).
@group(0) @binding(5) var<storage, read> weights: array<vec4<f32>>;
@group(0) @binding(6) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(7) var<storage, read_write> accum: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> columns: array<f32>;
@group(0) @binding(9) var<storage, read> bsdf_tables: array<f32>;
@group(0) @binding(10) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(11) var<storage, read> bvh_prims: array<BvhPrim>;
// 64-bit counters as (lo, hi) u32 pairs: shadow tests, ray casts, rays that gave up.
@group(0) @binding(12) var<storage, read_write> stats: array<atomic<u32>, 6>;
// Projected textures of spot lights (common/light.wgsl `spot_texture_eval`).
@group(0) @binding(13) var<storage, read> spot_textures: array<f32>;
// The mask table (common/mask.wgsl, src/gpu/mask.rs); a few unused words without masks.
@group(0) @binding(14) var<storage, read> masks: array<u32>;


// A texel of the shadow maps (for common/visibility.wgsl).
fn depth_texel(xy: vec2<i32>, layer: u32) -> f32 {
    return textureLoad(shadow_maps, xy, i32(layer), 0);
}

// Rough-plastic tables for `bsdf_eval` (common/bsdf.wgsl).
fn bsdf_record(i: u32) -> Bsdf {
    return bsdfs[i];
}

fn bsdf_table(i: u32) -> f32 {
    return bsdf_tables[i];
}

fn light_layer(l: Light, p: vec3<f32>) -> u32 {
    if l.is_cube != 0u {
        return l.first_layer + cube_face(p - l.position);
    }
    return l.first_layer;
}

// Shadow-map-only visibility with biases (ColumnOptions::normal_offset, depth_bias, slope_bias):
// 1 if p (geometric normal n_g) sees light l along wo.
fn visibility_biased(l: Light, p: vec3<f32>, n_g: vec3<f32>, wo: vec3<f32>) -> f32 {
    // World-space texel size at p in the layer that holds p.
    let clip0 = layers[light_layer(l, p)].view_proj * vec4<f32>(p, 1.0);
    let texel = layers[light_layer(l, p)].texel_scale * abs(clip0.w);
    // Normal offset toward the light's side of the surface, plus a slope-scaled push toward the light.
    let cos_g = dot(n_g, wo);
    let n_side = select(-n_g, n_g, cos_g >= 0.0);
    let c = max(abs(cos_g), 0.05);
    let tan_g = min(sqrt(max(1.0 - c * c, 0.0)) / c, 10.0);
    let p_off = p + n_side * (params.normal_offset * texel)
        + wo * (texel * (params.depth_bias + params.slope_bias * tan_g));
    let li = light_layer(l, p_off);
    let clip = layers[li].view_proj * vec4<f32>(p_off, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    let res = f32(params.resolution);
    let x = (ndc.x * 0.5 + 0.5) * res;
    let y = (0.5 - ndc.y * 0.5) * res;
    if l.is_cube == 0u && (x < 0.0 || x >= res || y < 0.0 || y >= res) {
        // Outside a spot's cone (falloff 0 there) or outside the scene bounds (directional).
        return 1.0;
    }
    let r = i32(params.resolution) - 1;
    let texel_xy = vec2<i32>(clamp(i32(floor(x)), 0, r), clamp(i32(floor(y)), 0, r));
    let stored = textureLoad(shadow_maps, texel_xy, i32(li), 0);
    return select(0.0, 1.0, ndc.z <= stored);
}

// The hybrid test: decide visibility from the shadow map only where the map is certain.
// The four texels whose centres surround p (its bilinear footprint) are compared with two models:
// - p's own plane (geometric normal n_g): its depth at each tap centre is predicted from the plane's
//   depth gradient in map space (NDC depth of a plane is affine in map x, y for perspective and
//   orthographic maps alike, so the prediction is exact up to rounding). All four taps on that plane
//   (within LIT_TOL + LIT_SLOPE_TOL * gradient texels, plus DEPTH_ULPS) -> nothing occludes the
//   footprint -> SM_LIT.
// - one occluder plane: the taps are coplanar (bilinear twist below PLANAR_TOL), their bilinear
//   interpolation at p (the occluder's depth on p's own light ray) lies more than OCCLUDER_GAP in front
//   of p, and every tap lies more than OCCLUDER_GAP in front of p's plane there -> SM_SHADOW.
// Everything else is SM_UNSURE and goes to an exact ray: contact edges and creases (taps on two planes,
// e.g. a grazing ceiling meeting a wall), shadow boundaries inside the footprint, curved or grazing
// receivers, taps outside the layer (map edges, cube-face seams) and points behind the light.
// Depth differences are turned into world distances along wo with the local depth scale
// k = d(NDC depth)/d(distance toward the light) at p; tolerances are in world texels at p.
// Limits: an occluder smaller than a texel that misses all four tap rays, or a gap narrower than a
// texel between two occluders aligned with the texel grid, is not seen (as in any shadow map).
fn shadow_map_decide(l: Light, p: vec3<f32>, n_g: vec3<f32>, wo: vec3<f32>) -> u32 {
    let li = light_layer(l, p);
    let m = layers[li].view_proj;
    let c = to_map(m, p);
    if c.w <= 0.0 {
        return SM_UNSURE;
    }
    let texel = layers[li].texel_scale * abs(c.w);
    let xy0 = footprint_origin(c);
    if xy0.x < 0 {
        return SM_UNSURE;
    }
    // Taps where p's own light ray would also land (the footprint must be in p's layer).
    if l.is_cube != 0u && light_layer(l, p + wo * texel) != li {
        return SM_UNSURE;
    }
    let k = depth_scale(m, c, p, wo, texel);
    let g = plane_gradient(m, c, p, n_g, texel);
    if !positive(k) || g.z == 0.0 {
        return SM_UNSURE;
    }
    return footprint_decide(li, xy0, c, g.xy, k, texel, false);
}

// 1 if p (geometric normal n_g) sees light l along wo, by params.visibility.
fn visibility(l: Light, p: vec3<f32>, n_g: vec3<f32>, wo: vec3<f32>) -> f32 {
    count_tests = count_tests + 1u;
    if params.visibility == VISIBILITY_RAY_TRACED {
        return visibility_ray(l, p, n_g, wo, 1.0);
    }
    if params.visibility == VISIBILITY_HYBRID {
        let d = shadow_map_decide(l, p, n_g, wo);
        if d == SM_UNSURE {
            return visibility_ray(l, p, n_g, wo, visibility_biased(l, p, n_g, wo));
        }
        return select(0.0, 1.0, d == SM_LIT);
    }
    return visibility_biased(l, p, n_g, wo);
}

// Visibility of light l from view sample s (direction wo) in a scene with masked surfaces
// (`cpu::mask_visibility_at`): (expected transmittance, 1 when the ray crossed a masked surface).
// Lights whose shadow rays stop at masks, and samples without budget, take `visibility` (the shadow maps
// hold masked surfaces as opaque ones); the others an exact mask ray (common/mask.wgsl), unless the
// shadow map is certain that nothing lies between (SM_LIT in hybrid mode, lit in shadow-map mode).
fn visibility_masked(l: Light, s: ViewSample, wo: vec3<f32>) -> vec2<f32> {
    if mask_vpl_out_of_depth(s, l) {
        return vec2<f32>(0.0, 0.0);
    }
    let budget = mask_light_budget(s, l);
    if budget == 0u {
        return vec2<f32>(visibility(l, s.position, s.geo_normal, wo), 0.0);
    }
    count_tests = count_tests + 1u;
    var fallback = 1.0;
    if params.visibility == VISIBILITY_HYBRID {
        if shadow_map_decide(l, s.position, s.geo_normal, wo) == SM_LIT {
            return vec2<f32>(1.0, 0.0);
        }
        fallback = visibility_biased(l, s.position, s.geo_normal, wo);
    } else if params.visibility == VISIBILITY_SHADOW_MAP {
        fallback = visibility_biased(l, s.position, s.geo_normal, wo);
        if fallback == 1.0 {
            return vec2<f32>(1.0, 0.0);
        }
    }
    return mask_transmittance(s.position, s.geo_normal, l, wo, budget, fallback);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = params.first_sample + gid.y * params.dispatch_width + gid.x;
    if i >= params.num_samples {
        return;
    }
    let s = samples[i];
    let is_surface = s.shape_index >= 0;
    // Mitsuba's shading frame from the shading normal (Frame3f(n) = coordinate_system(n), n).
    let n = s.normal;
    let fs = coordinate_system_s(n);
    let ft = coordinate_system_t(n);
    let wi_local = vec3<f32>(dot(s.wi, fs), dot(s.wi, ft), dot(s.wi, n));
    let b = bsdfs[i];
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < params.num_lights; k = k + 1u) {
        let j = params.first_light + k;
        var contribution = vec3<f32>(0.0);
        if is_surface {
            let l = lights[j];
            let e = light_emitted(l, s.position, n);
            if e.valid && ((s.flags & VIEW_FLAG_GEO_FRONT) == 0u || dot(e.wo, s.geo_normal) > 0.0) {
                let wo_local = vec3<f32>(dot(e.wo, fs), dot(e.wo, ft), dot(e.wo, n));
                let w = glossy_light_weight(b, s.bsdf_samples, l, s.position, wi_local, wo_local);
                var f = light_shade(l, s.position, e, fs, ft, n, wi_local, b) * s.throughput * w;
                let masked = (s.flags & VIEW_FLAG_MASKS) != 0u;
                if masked && s.mask_valid < 1.0 && l.kind != LIGHT_VPL {
                    // Mitsuba's `valid_ray` factor of a masked sample: direct light only.
                    f = f * mask_direct_factor(s, b, l, wi_local, wo_local);
                }
                if any(f != vec3<f32>(0.0)) {
                    if masked {
                        let v = visibility_masked(l, s, e.wo);
                        contribution = f * v.x;
                        if v.y > 0.0 && s.bsdf_samples > 0u && w > 0.0 {
                            // Through a mask only Mitsuba's BSDF sampling reaches the light (weight 1), and the
                            // glossy BSDF rays stop at masks: the light column carries it all.
                            contribution = contribution / w;
                        }
                    } else {
                        contribution = f * visibility(l, s.position, s.geo_normal, e.wo);
                    }
                }
            }
        }
        if params.write_columns != 0u {
            let base = (j * params.num_samples + i) * 3u;
            columns[base] = contribution.x;
            columns[base + 1u] = contribution.y;
            columns[base + 2u] = contribution.z;
        }
        acc = acc + weights[j].xyz * contribution;
    }
    if params.accumulate != 0u {
        accum[i] = accum[i] + vec4<f32>(acc, 0.0);
    }
    add_stat(0u, count_tests);
    add_stat(1u, count_rays);
    add_stat(2u, count_gave_up);
}
