use super::*;

#[test]
fn coordinate_system_is_orthonormal_and_right_handed() {
    for n in [Vec3::Z, -Vec3::Z, Vec3::new(0.3, -0.5, 0.8).normalize(), Vec3::new(-0.6, 0.8, -0.0)] {
        let (s, t) = coordinate_system(n);
        assert!(s.dot(t).abs() < 1e-6 && s.dot(n).abs() < 1e-6 && t.dot(n).abs() < 1e-6);
        assert!((s.cross(t) - n).length() < 1e-5, "{n:?}");
    }
    // Mitsuba's values for n = (0, 0, 1): s = (1, 0, 0), t = (0, 1, 0).
    assert_eq!(coordinate_system(Vec3::Z), (Vec3::X, Vec3::Y));
}
