// Clustered visibility (src/gpu/clustered_visibility.rs; design in src/cluster/visibility/mod.rs): the
// 2022 paper's step 5 (one exact shadow ray per pair of view-cluster and light-cluster representatives,
// into a bit-packed visibility matrix) and step 6 (every view sample shaded by every cluster light with
// the visibility interpolated over its F nearest view clusters, Eq. 6 / Eq. 9).
// Needs common/bsdf.wgsl, common/principled.wgsl, common/light.wgsl, common/bvh.wgsl,
// common/view_sample.wgsl, common/mask.wgsl (shading as shaders/columns.wgsl, rays as common/bvh.wgsl's
// trace_to_point / trace_direction, the columns' exact rays; through masked surfaces common/mask.wgsl's
// mask_transmittance, as the columns' `visibility_masked` with exact rays).
//
// Loop bounds (Mesa 22.3 stops an invocation after 65,535 loop iterations): the visibility stage traces
// one ray per invocation (<= BVH_MAX_RAY_STEPS steps); the shading stage loops over params.count
// cluster lights, each with an F-iteration interpolation loop, and the host keeps count * (F + 1) below
// 48,000 by splitting the lights over dispatches.

const WORKGROUP_SIZE: u32 = 64u;
const STAGE_VISIBILITY: u32 = 0u;
const STAGE_SHADE: u32 = 1u;
// A view cluster without a representative (no rays, all bits 0).
const NO_REPRESENTATIVE: u32 = 0xffffffffu;

// Keep in sync with `ClusteredParams` in src/gpu/clustered_visibility.rs (48 bytes).
struct ClusteredParams {
    stage: u32,
    num_samples: u32,
    // Cluster lights (columns of the visibility matrix) and u32 words per row.
    num_lights: u32,
    words: u32,
    num_view_clusters: u32,
    // View clusters per view sample.
    fuzziness: u32,
    // Threads per dispatch row (groups_x * WORKGROUP_SIZE).
    dispatch_width: u32,
    // Visibility: first pair (row * num_lights + light) of this dispatch; shading: first light.
    first: u32,
    // Pairs (visibility) or lights (shading) of this dispatch.
    count: u32,
    // Shading: the view samples [first_sample, first_sample + num_dispatch_samples) of this dispatch.
    first_sample: u32,
    num_dispatch_samples: u32,
    // 1 in a scene with masked surfaces: the visibility buffer also holds the crossings and the
    // transmittances (see `visibility`).
    masked: u32,
}

@group(0) @binding(0) var<uniform> params: ClusteredParams;
@group(0) @binding(1) var<storage, read> samples: array<ViewSample>;
@group(0) @binding(2) var<storage, read> bsdfs: array<Bsdf>;
@group(0) @binding(3) var<storage, read> bsdf_tables: array<f32>;
// The cluster lights: representatives with the clusters' summed intensities.
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(5) var<storage, read> spot_textures: array<f32>;
@group(0) @binding(6) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(7) var<storage, read> bvh_prims: array<BvhPrim>;
// View-sample index of each view cluster's representative (NO_REPRESENTATIVE: none).
@group(0) @binding(8) var<storage, read> representatives: array<u32>;
// Each view sample's F view clusters and weights, row-major (num_samples x F).
@group(0) @binding(9) var<storage, read> membership_clusters: array<u32>;
@group(0) @binding(10) var<storage, read> membership_weights: array<f32>;
// num_view_clusters x words u32: bit c of row k = cluster light c visible from view cluster k (V > 0);
// with params.masked, then the same bits for the rays that crossed a masked surface, then
// num_view_clusters x num_lights f32 bit patterns, the transmittances V(k, c); last, one word: the rays
// that ran out of traversal steps (counted as visible; must stay 0).
@group(0) @binding(11) var<storage, read_write> visibility: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> accum: array<vec4<f32>>;
// The mask table (common/mask.wgsl, src/gpu/mask.rs); a few unused words without masks.
@group(0) @binding(13) var<storage, read> masks: array<u32>;

// common/mask.wgsl's ray counters (the columns' statistics; unused here but for the rays that gave up).
var<private> count_rays: u32 = 0u;
var<private> count_gave_up: u32 = 0u;

fn crossed_base() -> u32 {
    return params.num_view_clusters * params.words;
}

fn transmittance_base() -> u32 {
    return 2u * params.num_view_clusters * params.words;
}

fn gave_up_word() -> u32 {
    if params.masked != 0u {
        return transmittance_base() + params.num_view_clusters * params.num_lights;
    }
    return params.num_view_clusters * params.words;
}

fn bsdf_record(i: u32) -> Bsdf {
    return bsdfs[i];
}

fn bsdf_table(i: u32) -> f32 {
    return bsdf_tables[i];
}

// One ray from view cluster `row`'s representative toward cluster light c: sets the bit when V > 0 and,
// with params.masked, stores V and whether the ray crossed a masked surface (`cpu::mask_visibility_at`).
fn trace_pair(row: u32, c: u32) {
    let rep = representatives[row];
    if rep == NO_REPRESENTATIVE {
        return;
    }
    let s = samples[rep];
    let l = lights[c];
    var v = vec2<f32>(0.0);
    let budget = mask_light_budget(s, l);
    if mask_vpl_out_of_depth(s, l) {
        v = vec2<f32>(0.0);
    } else if (s.flags & VIEW_FLAG_MASKS) != 0u && budget > 0u {
        v = mask_transmittance(s.position, s.geo_normal, l, -l.direction, budget, 1.0);
    } else {
        var res = BVH_FREE;
        if l.kind == LIGHT_DIRECTIONAL {
            res = trace_direction(s.position, s.geo_normal, -l.direction);
        } else {
            res = trace_to_point(s.position, s.geo_normal, l.position);
        }
        if res == BVH_GAVE_UP {
            count_gave_up = count_gave_up + 1u;
        }
        v.x = select(1.0, 0.0, res == BVH_BLOCKED);
    }
    if count_gave_up > 0u {
        atomicAdd(&visibility[gave_up_word()], count_gave_up);
    }
    let word = row * params.words + c / 32u;
    let bit = 1u << (c % 32u);
    if v.x > 0.0 {
        atomicOr(&visibility[word], bit);
    }
    if params.masked != 0u {
        atomicStore(&visibility[transmittance_base() + row * params.num_lights + c], bitcast<u32>(v.x));
        if v.y > 0.0 {
            atomicOr(&visibility[crossed_base() + word], bit);
        }
    }
}

// Eq. 9: sum_f w_f V(k_f, c) for view sample i, split into the entries whose rays crossed no masked
// surface (x) and those that did (y).
fn interpolated_visibility(i: u32, c: u32) -> vec2<f32> {
    var v = vec2<f32>(0.0);
    let word = c / 32u;
    let bit = 1u << (c % 32u);
    for (var f = 0u; f < params.fuzziness; f = f + 1u) {
        let e = i * params.fuzziness + f;
        let k = membership_clusters[e];
        if params.masked != 0u {
            let t = bitcast<f32>(atomicLoad(&visibility[transmittance_base() + k * params.num_lights + c]));
            if (atomicLoad(&visibility[crossed_base() + k * params.words + word]) & bit) != 0u {
                v.y = v.y + membership_weights[e] * t;
            } else {
                v.x = v.x + membership_weights[e] * t;
            }
        } else if (atomicLoad(&visibility[k * params.words + word]) & bit) != 0u {
            v.x = v.x + membership_weights[e];
        }
    }
    return v;
}

// Eq. 6 over lights [first, first + count) for view sample i, added to accum[i].
fn shade_sample(i: u32) {
    let s = samples[i];
    if s.shape_index < 0 {
        return;
    }
    let n = s.normal;
    let fs = coordinate_system_s(n);
    let ft = coordinate_system_t(n);
    let wi_local = vec3<f32>(dot(s.wi, fs), dot(s.wi, ft), dot(s.wi, n));
    let b = bsdfs[i];
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < params.count; k = k + 1u) {
        let c = params.first + k;
        let e = light_emitted(lights[c], s.position, n);
        if e.valid {
            let wo_local = vec3<f32>(dot(e.wo, fs), dot(e.wo, ft), dot(e.wo, n));
            let w = glossy_light_weight(b, s.bsdf_samples, lights[c], s.position, wi_local, wo_local);
            var f = light_shade(lights[c], s.position, e, fs, ft, n, wi_local, b) * s.throughput * w;
            if (s.flags & VIEW_FLAG_MASKS) != 0u && s.mask_valid < 1.0 && lights[c].kind != LIGHT_VPL {
                // Mitsuba's `valid_ray` factor of a masked sample: direct light only (as the columns).
                f = f * mask_direct_factor(s, b, lights[c], wi_local, wo_local);
            }
            if any(f != vec3<f32>(0.0)) {
                let v = interpolated_visibility(i, c);
                var through_mask = v.y;
                if through_mask > 0.0 && s.bsdf_samples > 0u && w > 0.0 {
                    // Through a mask only Mitsuba's BSDF sampling reaches the light (weight 1; the columns).
                    through_mask = through_mask / w;
                }
                acc = acc + f * (v.x + through_mask);
            }
        }
    }
    accum[i] = accum[i] + vec4<f32>(acc, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = gid.y * params.dispatch_width + gid.x;
    if t >= params.count && params.stage == STAGE_VISIBILITY {
        return;
    }
    if params.stage == STAGE_VISIBILITY {
        let q = params.first + t;
        trace_pair(q / params.num_lights, q % params.num_lights);
    } else if t < params.num_dispatch_samples && params.first_sample + t < params.num_samples {
        shade_sample(params.first_sample + t);
    }
}
