// STAND-IN until shaders/common/bsdf.wgsl (helper "bsdf") lands: same `Bsdf` layout and `bsdf_eval`
// signature, diffuse only (f = diffuse / pi, one-sided), result includes cos(theta_o).
// Keep in sync with `GpuBsdf` in src/shading/mod.rs (80 bytes).
struct Bsdf {
    diffuse: vec3<f32>,
    kind: u32,
    specular: vec3<f32>,
    flags: u32,
    eta: vec3<f32>,
    alpha_u: f32,
    k: vec3<f32>,
    alpha_v: f32,
    extra: vec4<f32>,
}

// wi toward the viewer, wo toward the light, both in the local shading frame (z = shading normal).
fn bsdf_eval(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    return b.diffuse * (wo.z * 0.31830988618379067);
}
