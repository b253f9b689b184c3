// Pixel mapping gather (src/gpu/mapping.rs; Hašan et al. 2008, Sec. 4.4 and 5): applies M(k -> l), an
// index array over the pixels of frame l, to an image of frame k held on the GPU, optionally scaled by
// an RGB weight and added to the target (how tensor clustering accumulates scaled, mapped
// representatives into every frame they serve). One invocation per destination pixel, no loops.

// Keep in sync with `MappingParams` in src/gpu/mapping.rs (32 bytes).
struct MappingParams {
    num_pixels: u32,
    // 1: target += weight * source[map[i]]; 0: target = weight * source[map[i]].
    accumulate: u32,
    _pad0: u32,
    _pad1: u32,
    // RGB scale in xyz (w unused).
    weight: vec4<f32>,
}

// The destination pixel takes no value (0): `NO_SOURCE` in src/matrix/mapping.rs.
const NO_SOURCE: u32 = 0xffffffffu;
const WORKGROUP_SIZE: u32 = 64u;

@group(0) @binding(0) var<uniform> params: MappingParams;
// Frame k's image, one RGBA f32 texel per pixel (a = 0), as the column pass's accumulator.
@group(0) @binding(1) var<storage, read> source_image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> source_index: array<u32>;
@group(0) @binding(3) var<storage, read_write> target_image: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * WORKGROUP_SIZE;
    if i >= params.num_pixels {
        return;
    }
    let s = source_index[i];
    var v = vec4<f32>(0.0);
    if s != NO_SOURCE {
        v = source_image[s] * vec4<f32>(params.weight.xyz, 0.0);
    }
    if params.accumulate != 0u {
        v = v + target_image[i];
    }
    target_image[i] = v;
}
