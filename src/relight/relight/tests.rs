use super::*;

#[test]
fn empty_and_non_finite_light_sets_are_refused() {
    let mut s = LightSet::new(Vec3::ZERO, 1.0);
    assert!(check_lights(&s).unwrap_err().to_string().contains("empty"));
    s.push_point(Vec3::new(0.0, 1.0, 0.0), Vec3::ONE).unwrap();
    check_lights(&s).unwrap();
    s.intensity[0] = Vec3::new(f32::NAN, 1.0, 1.0);
    assert!(check_lights(&s).unwrap_err().to_string().contains("light 0"));
}
