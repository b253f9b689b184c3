use super::*;

#[test]
fn weights_follow_the_documented_scales() {
    let m = DeepMetric::for_diagonal(3.0);
    assert_eq!(m.position_scale, 10.0);
    let f = m.feature(Vec3::new(0.3, 0.0, -0.6), Vec3::Y, Vec3::new(0.5, 0.25, 0.0));
    assert_eq!(f, [3.0, 0.0, -6.0, 0.0, 1.0, 0.0, 0.5, 0.25, 0.0]);
    // An offset of diagonal / K costs as much as a unit normal difference.
    let g = m.feature(Vec3::new(0.4, 0.0, -0.6), Vec3::Y, Vec3::new(0.5, 0.25, 0.0));
    let h = m.feature(Vec3::new(0.3, 0.0, -0.6), Vec3::Y + Vec3::X, Vec3::new(0.5, 0.25, 0.0));
    assert!((distance2(&f, &g) - 1.0).abs() < 1e-5 && (distance2(&f, &h) - 1.0).abs() < 1e-6);
    assert_eq!(DeepMetric::for_diagonal(0.0).position_scale, 1.0);
    assert_eq!(DeepMetric::for_diagonal(f32::NAN).position_scale, 1.0);
}

#[test]
fn background_and_non_finite_samples_have_no_feature() {
    let view = ViewSamples {
        width: 3,
        height: 1,
        position: vec![Vec3::ONE, Vec3::ZERO, Vec3::ONE],
        normal: vec![Vec3::Z, Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)],
        albedo: vec![Vec3::splat(0.5); 3],
        shape_index: vec![0, -1, 2],
        ..Default::default()
    };
    let f = DeepMetric::for_diagonal(30.0).features(&view);
    assert_eq!(f.valid, vec![true, false, false]);
    assert_eq!(f.features[0], [1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5]);
    assert_eq!(f.features[2], [0.0; DIM]);
}
