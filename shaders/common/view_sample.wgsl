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
    // Mitsuba's `valid_ray` factor P_valid of a masked sample (common/mask.wgsl), 1 for the others.
    mask_valid: f32,
    throughput: vec3<f32>,
    // The opacity of a masked sample, 1 for the others.
    mask_opacity: f32,
}

// Only light from the front side of the geometric normal counts (gather samples of relighting:
// `lights::animated::irradiance`); keep in sync with `VIEW_FLAG_GEO_FRONT` in src/gpu/columns.rs.
const VIEW_FLAG_GEO_FRONT: u32 = 1u;

// The view belongs to a scene with masked surfaces (common/mask.wgsl): the sample's mask budget (how many
// masked surfaces its shadow rays toward area and environment lights and VPLs may cross, 0xffff =
// unlimited) is in bits 16..31 of `flags`. Keep in sync with `VIEW_FLAG_MASKS` in src/gpu/columns.rs.
const VIEW_FLAG_MASKS: u32 = 2u;
const VIEW_MASK_BUDGET_SHIFT: u32 = 16u;
