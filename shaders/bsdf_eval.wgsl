// Batch BSDF evaluation (src/gpu/bsdf_eval.rs): one invocation per (bsdf, wi, wo) triple, no loops.
// Prepended: shaders/common/bsdf.wgsl.

// Keep in sync with `BsdfEvalParams` in src/gpu/bsdf_eval.rs.
struct BsdfEvalParams {
    count: u32,
    // 1 when one BSDF serves every triple.
    broadcast: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: BsdfEvalParams;
@group(0) @binding(1) var<storage, read> bsdfs: array<Bsdf>;
// (wi, wo) per triple, xyz used.
@group(0) @binding(2) var<storage, read> directions: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> tables: array<f32>;
@group(0) @binding(4) var<storage, read_write> results: array<vec4<f32>>;

const WORKGROUP_SIZE: u32 = 64u;

fn bsdf_record(i: u32) -> Bsdf {
    return bsdfs[i];
}

fn bsdf_table(i: u32) -> f32 {
    return tables[i];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * WORKGROUP_SIZE;
    if i >= params.count {
        return;
    }
    let b = bsdfs[select(i, 0u, params.broadcast != 0u)];
    let wi = directions[2u * i].xyz;
    let wo = directions[2u * i + 1u].xyz;
    results[i] = vec4<f32>(bsdf_eval(b, wi, wo), 0.0);
}
