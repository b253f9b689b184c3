use super::*;

fn arrays() -> LightArrays {
    LightArrays {
        kind: vec![0, 1, 2, 3],
        position: Some(vec![Vec3::ONE, Vec3::Y, Vec3::new(9.0, 9.0, 9.0), Vec3::ZERO]),
        direction: Some(vec![Vec3::X, -Vec3::Y, Vec3::new(0.0, -0.6, 0.8), Vec3::ZERO]),
        normal: Some(vec![Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::Z]),
        intensity: vec![Vec3::ONE; 4],
        cutoff_angle: Some(vec![0.0, 0.5, 0.0, 0.0]),
        beam_width: Some(vec![0.0, 0.25, 0.0, 0.0]),
        ..Default::default()
    }
}

#[test]
fn from_arrays_canonical_and_checked() {
    let s = LightSet::from_arrays(&arrays(), Vec3::ZERO, 2.0, f32::INFINITY).unwrap();
    assert_eq!(s.len(), 4);
    // Unused fields are zero: the point's direction, the directional light's position.
    assert_eq!(s.direction[0], Vec3::ZERO);
    assert_eq!(s.position[2], Vec3::ZERO);
    assert_eq!(s.geo_normal[3], Vec3::Z);
    assert_eq!((s.cutoff_angle[1], s.beam_width[1]), (0.5, 0.25));
    // The same lights through push_* give the same set.
    let mut p = LightSet::new(Vec3::ZERO, 2.0);
    p.push_point(Vec3::ONE, Vec3::ONE).unwrap();
    p.push_spot(Vec3::Y, -Vec3::Y, Vec3::ONE, 0.5, 0.25).unwrap();
    p.push_directional(Vec3::new(0.0, -0.6, 0.8), Vec3::ONE).unwrap();
    p.push_oriented_point(Vec3::ZERO, Vec3::Z, Vec3::ONE).unwrap();
    assert_eq!((&s.kind, &s.position, &s.direction, &s.normal), (&p.kind, &p.position, &p.direction, &p.normal));

    let mut bad = arrays();
    bad.normal.as_mut().unwrap()[3] = Vec3::new(0.0, 0.0, 2.0);
    let e = LightSet::from_arrays(&bad, Vec3::ZERO, 2.0, f32::INFINITY).unwrap_err().to_string();
    assert!(e.contains("normal[3]") && e.contains("unit") && e.contains("length 2"), "{e}");
    let mut bad = arrays();
    bad.intensity[1] = Vec3::new(1.0, -1.0, 0.0);
    let e = LightSet::from_arrays(&bad, Vec3::ZERO, 2.0, f32::INFINITY).unwrap_err().to_string();
    assert!(e.contains("intensity[1]") && e.contains(">= 0"), "{e}");
    let mut bad = arrays();
    bad.kind[2] = 7;
    assert!(LightSet::from_arrays(&bad, Vec3::ZERO, 2.0, f32::INFINITY).unwrap_err().to_string().contains("kind[2] = 7"));
    let mut bad = arrays();
    bad.position.as_mut().unwrap().pop();
    let e = LightSet::from_arrays(&bad, Vec3::ZERO, 2.0, f32::INFINITY).unwrap_err().to_string();
    assert!(e.contains("position") && e.contains("n = 4") && e.contains("got 3"), "{e}");
    let mut bad = arrays();
    bad.kind.push(4);
    bad.intensity.push(Vec3::ONE);
    for v in [&mut bad.position, &mut bad.direction, &mut bad.normal] {
        v.as_mut().unwrap().push(Vec3::Z);
    }
    bad.cutoff_angle.as_mut().unwrap().push(0.0);
    bad.beam_width.as_mut().unwrap().push(0.0);
    let e = LightSet::from_arrays(&bad, Vec3::ZERO, 2.0, f32::INFINITY).unwrap_err().to_string();
    assert!(e.contains("geo_normal is required for VPL lights (light 4"), "{e}");
}

#[test]
fn select_and_concat() {
    let s = LightSet::from_arrays(&arrays(), Vec3::ZERO, 2.0, f32::INFINITY).unwrap();
    let t = s.select(&[3, 1, 1]).unwrap();
    assert_eq!(t.kind, vec![LightKind::OrientedPoint, LightKind::Spot, LightKind::Spot]);
    assert_eq!(t.cutoff_angle, vec![0.0, 0.5, 0.5]);
    assert!(s.select(&[4]).unwrap_err().to_string().contains("light index 4"));
    let c = LightSet::concat(&[&s, &t]).unwrap();
    assert_eq!(c.len(), 7);
    assert_eq!(c.position[4], s.position[3]);
    let other = LightSet::from_arrays(&arrays(), Vec3::ONE, 2.0, f32::INFINITY).unwrap();
    assert!(LightSet::concat(&[&s, &other]).unwrap_err().to_string().contains("another scene"));
    assert!(LightSet::concat(&[]).is_err());
}
