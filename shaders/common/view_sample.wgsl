// A view sample (a pixel's first hit, or a surface seen through its delta chain with that chain's
// RGB throughput); keep in sync with `GpuViewSample` in src/gpu/columns.rs (80 bytes).
struct ViewSample {
    position: vec3<f32>,
    shape_index: i32,
    normal: vec3<f32>,
    // VIEW_FLAG_* bits.
    flags: u32,
    geo_normal: vec3<f32>,
    // n_B: BSDF samples of a glossy view sample (common/glossy.wgsl), 0 for the others.
    bsdf_samples: u32,
    wi: vec3<f32>,
    _pad2: u32,
    throughput: vec3<f32>,
    _pad3: u32,
}

// Only light from the front side of the geometric normal counts (gather samples of relighting:
// `lights::animated::irradiance`); keep in sync with `VIEW_FLAG_GEO_FRONT` in src/gpu/columns.rs.
const VIEW_FLAG_GEO_FRONT: u32 = 1u;
