use super::*;

#[test]
fn wgsl_validates_and_layouts_match() {
    assert_eq!(std::mem::size_of::<ClusteredParams>(), 48);
    crate::gpu::shaders::assert_struct_sizes(
        "clustered_visibility.wgsl",
        shaders::CLUSTERED_VISIBILITY,
        &[("ClusteredParams", 48), ("Light", 256), ("ViewSample", 80), ("Bsdf", 80)],
    );
}

#[test]
fn shading_loops_stay_below_mesas_limit() {
    for f in 1..=crate::cluster::visibility::MAX_FUZZINESS {
        assert!(lights_per_dispatch(f) * (f + 1) <= 65_535, "F = {f}");
    }
}
