// A view sample (a pixel's first hit); keep in sync with `GpuViewSample` in src/gpu/columns.rs (64 bytes).
struct ViewSample {
    position: vec3<f32>,
    shape_index: i32,
    normal: vec3<f32>,
    _pad0: u32,
    geo_normal: vec3<f32>,
    _pad1: u32,
    wi: vec3<f32>,
    _pad2: u32,
}
