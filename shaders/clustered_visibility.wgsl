// Clustered visibility (src/gpu/clustered_visibility.rs; design in src/cluster/visibility/mod.rs): the
// 2022 paper's step 5 (one exact shadow ray per pair of view-cluster and light-cluster representatives,
// into a bit-packed visibility matrix) and step 6 (every view sample shaded by every cluster light with
// the visibility interpolated over its F nearest view clusters, Eq. 6 / Eq. 9).
// Needs common/bsdf.wgsl, common/principled.wgsl, common/light.wgsl, common/bvh.wgsl,
// common/view_sample.wgsl (shading as shaders/columns.wgsl, rays as common/bvh.wgsl's trace_to_point /
// trace_direction, the columns' exact rays).
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
    _pad2: u32,
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
// num_view_clusters x words u32: bit c of row k = cluster light c visible from view cluster k.
@group(0) @binding(11) var<storage, read_write> visibility: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> accum: array<vec4<f32>>;
// Rays that ran out of traversal steps (counted as visible; must stay 0).
@group(0) @binding(13) var<storage, read_write> gave_up: array<atomic<u32>>;

fn bsdf_record(i: u32) -> Bsdf {
    return bsdfs[i];
}

fn bsdf_table(i: u32) -> f32 {
    return bsdf_tables[i];
}

// One ray from view cluster `row`'s representative toward cluster light c; sets the bit when free.
fn trace_pair(row: u32, c: u32) {
    let rep = representatives[row];
    if rep == NO_REPRESENTATIVE {
        return;
    }
    let s = samples[rep];
    let l = lights[c];
    var res = BVH_FREE;
    if l.kind == LIGHT_DIRECTIONAL {
        res = trace_direction(s.position, s.geo_normal, -l.direction);
    } else {
        res = trace_to_point(s.position, s.geo_normal, l.position);
    }
    if res == BVH_GAVE_UP {
        atomicAdd(&gave_up[0], 1u);
    }
    if res != BVH_BLOCKED {
        atomicOr(&visibility[row * params.words + c / 32u], 1u << (c % 32u));
    }
}

// Eq. 9: sum_f w_f V(k_f, c) for view sample i.
fn interpolated_visibility(i: u32, c: u32) -> f32 {
    var v = 0.0;
    let word = c / 32u;
    let bit = 1u << (c % 32u);
    for (var f = 0u; f < params.fuzziness; f = f + 1u) {
        let e = i * params.fuzziness + f;
        let k = membership_clusters[e];
        if (atomicLoad(&visibility[k * params.words + word]) & bit) != 0u {
            v = v + membership_weights[e];
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
            let f = light_shade(lights[c], s.position, e, fs, ft, n, wi_local, b) * s.throughput * w;
            if any(f != vec3<f32>(0.0)) {
                acc = acc + f * interpolated_visibility(i, c);
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
