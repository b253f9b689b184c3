use super::*;

#[test]
fn layer_struct_is_256_bytes() {
    assert_eq!(std::mem::size_of::<GpuShadowLayer>() as u64, SHADOW_LAYER_STRIDE);
}

#[test]
fn shadow_wgsl_validates() {
    let module = naga::front::wgsl::parse_str(shaders::SHADOW).expect("shadow.wgsl parses");
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .expect("shadow.wgsl validates");
}

#[test]
fn cube_faces_cover_their_major_axis() {
    // A point along each face's direction projects to the centre of that face, depth in (0, 1).
    let mut set = LightSet::new(Vec3::ZERO, 2.0);
    set.push_point(Vec3::new(0.1, 0.2, 0.3), Vec3::ONE).unwrap();
    let layers = light_layers(&set, 0, 256);
    assert_eq!(layers.len(), 6);
    for (f, (dir, _)) in cube_face_dirs().iter().enumerate() {
        let m = Mat4::from_cols_array_2d(&layers[f].view_proj);
        let c = m * (set.position[0] + *dir * 0.7).extend(1.0);
        let ndc = c.truncate() / c.w;
        assert!(ndc.x.abs() < 1e-5 && ndc.y.abs() < 1e-5 && ndc.z > 0.0 && ndc.z < 1.0, "face {f}: {ndc:?}");
        assert!((c.w - 0.7).abs() < 1e-5);
    }
}
