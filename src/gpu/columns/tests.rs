use super::*;

#[test]
fn struct_sizes() {
    assert_eq!(std::mem::size_of::<GpuLight>(), 256);
    assert_eq!(std::mem::size_of::<GpuViewSample>(), 80);
    assert_eq!(std::mem::size_of::<ColumnParams>(), 48);
    assert_eq!(std::mem::size_of::<crate::shading::GpuBsdf>(), 80);
}

#[test]
fn columns_wgsl_validates_and_layouts_match() {
    crate::gpu::shaders::assert_struct_sizes(
        "columns.wgsl",
        shaders::COLUMNS,
        &[("Light", 256), ("ViewSample", 80), ("ColumnParams", 48), ("Bsdf", 80), ("ShadowLayer", 256)],
    );
}

#[test]
fn dispatch_covers_large_images() {
    let (gx, gy, w) = dispatch_size(4096 * 4096);
    assert!(gx <= 65_535 && (gx * gy * WORKGROUP_SIZE) as u64 >= 4096 * 4096 && w == gx * WORKGROUP_SIZE);
    assert_eq!(dispatch_size(100), (2, 1, 128));
}
