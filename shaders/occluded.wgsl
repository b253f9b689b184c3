// Batch shadow-ray queries (src/gpu/bvh.rs `OccludedPass`): one thread per query, any-hit traversal of
// the scene BVH. Needs common/bvh.wgsl.

const WORKGROUP_SIZE: u32 = 64u;
const QUERY_RAY: u32 = 0u;
const QUERY_TO_POINT: u32 = 1u;
const QUERY_DIRECTION: u32 = 2u;

// Keep in sync with `OcclusionQuery` in src/gpu/bvh.rs (48 bytes).
struct OcclusionQuery {
    // QUERY_RAY: ray origin; otherwise the surface point.
    p: vec3<f32>,
    mode: u32,
    // QUERY_RAY / QUERY_DIRECTION: direction; QUERY_TO_POINT: the geometric normal at p.
    v: vec3<f32>,
    t_max: f32,
    // QUERY_TO_POINT: target point; QUERY_DIRECTION: geometric normal at p.
    q: vec3<f32>,
    _pad: u32,
}

struct QueryParams {
    num_queries: u32,
    dispatch_width: u32,
    _pad: vec2<u32>,
}

@group(0) @binding(0) var<uniform> params: QueryParams;
@group(0) @binding(1) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> bvh_prims: array<BvhPrim>;
@group(0) @binding(3) var<storage, read> queries: array<OcclusionQuery>;
@group(0) @binding(4) var<storage, read_write> results: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.y * params.dispatch_width + gid.x;
    if i >= params.num_queries {
        return;
    }
    let query = queries[i];
    var res = BVH_FREE;
    if query.mode == QUERY_TO_POINT {
        res = trace_to_point(query.p, query.v, query.q);
    } else if query.mode == QUERY_DIRECTION {
        res = trace_direction(query.p, query.q, query.v);
    } else {
        res = trace_occlusion(query.p, query.v, query.t_max);
    }
    results[i] = res | (bvh_ray_steps << 2u);
}
