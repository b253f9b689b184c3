// A view sample (a pixel's first hit, or a surface seen through its delta chain with that chain's
// RGB throughput); keep in sync with `GpuViewSample` in src/gpu/columns.rs (80 bytes).
struct ViewSample {
    position: vec3<f32>,
    shape_index: i32,
    normal: vec3<f32>,
    _pad0: u32,
    geo_normal: vec3<f32>,
    _pad1: u32,
    wi: vec3<f32>,
    _pad2: u32,
    throughput: vec3<f32>,
    _pad3: u32,
}
