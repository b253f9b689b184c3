use super::*;

#[test]
fn struct_sizes() {
    assert_eq!(std::mem::size_of::<RowParams>(), 48);
    assert_eq!(std::mem::size_of::<GpuRowInfo>(), 32);
}

#[test]
fn rows_wgsl_validates_and_layouts_match() {
    crate::gpu::shaders::assert_struct_sizes(
        "rows.wgsl",
        shaders::ROWS,
        &[("RowParams", 48), ("RowInfo", 32), ("Light", 256), ("ViewSample", 80), ("ShadowLayer", 256)],
    );
    // The WGSL mirrors of the Rust constants.
    assert!(shaders::ROWS.contains(&format!("const WORKGROUP_SIZE: u32 = {WORKGROUP_SIZE}u;")));
    assert!(shaders::ROWS.contains("const ROW_NO_MAP: u32 = 0xffffffffu;"));
}

#[test]
fn row_cube_faces_look_along_their_axes() {
    let c = glam::Vec3::new(0.2, -0.1, 0.3);
    let layers = row_cube_layers(glam::Vec3::ZERO, 2.0, c, 64);
    assert_eq!(layers.len(), 6);
    for (f, (dir, _)) in crate::gpu::shadow::cube_face_dirs().iter().enumerate() {
        let m = glam::Mat4::from_cols_array_2d(&layers[f].view_proj);
        let clip = m * (c + *dir * 1.5).extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1e-5 && ndc.y.abs() < 1e-5 && ndc.z > 0.0 && ndc.z < 1.0, "face {f}: {ndc:?}");
    }
}
