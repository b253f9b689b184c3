// One layer (a cube face, a spot map or an orthographic map) of a batch's shadow-map array.
// Keep in sync with `GpuShadowLayer` in src/gpu/shadow.rs (256 bytes: the dynamic-offset stride).
struct ShadowLayer {
    view_proj: mat4x4<f32>,
    // World-space size of one texel per unit of clip w (perspective: 2 tan(fov/2) / res; ortho: 2 extent / res).
    texel_scale: f32,
    is_ortho: u32,
    _pad0: vec2<u32>,
    _pad1: array<vec4<f32>, 11>,
}

// Cube face of direction v: 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z (the order of shadow::cube_face_dirs).
fn cube_face(v: vec3<f32>) -> u32 {
    let a = abs(v);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, v.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, v.y >= 0.0);
    }
    return select(5u, 4u, v.z >= 0.0);
}
