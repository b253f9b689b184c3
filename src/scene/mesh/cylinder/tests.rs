use super::*;

#[test]
fn tube_is_on_the_surface_with_outward_winding() {
    let d = cylinder();
    assert_eq!(d.positions.len() as u32, 2 * (CYLINDER_SEGMENTS + 1));
    assert_eq!(d.indices.len() as u32, 2 * CYLINDER_SEGMENTS);
    for (p, n) in d.positions.iter().zip(&d.normals) {
        assert!((p.truncate().length() - 1.0).abs() < 1e-6 && (p.truncate() - n.truncate()).length() < 1e-7);
    }
    for t in &d.indices {
        let [a, b, c] = t.map(|i| d.positions[i as usize]);
        let g = (b - a).cross(c - a).normalize();
        let centre = (a + b + c) / 3.0;
        assert!(g.dot(Vec3::new(centre.x, centre.y, 0.0).normalize()) > 0.9999, "{t:?}");
    }
    assert_eq!(d.positions[2 * CYLINDER_SEGMENTS as usize], d.positions[0]);
    assert_eq!(d.uvs[2 * CYLINDER_SEGMENTS as usize + 1], Vec2::new(1.0, 1.0));
}

#[test]
fn frame_matches_mitsuba() {
    // mitsuba 3.9.1 scalar_rgb: mi.coordinate_system(mi.Vector3f(n)) -> (s, t).
    let cases = [
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        ([0.6, 0.0, 0.8], [0.8, 0.0, -0.6], [0.0, 1.0, 0.0]),
        ([0.0, -0.6, -0.8], [1.0, 0.0, 0.0], [0.0, -0.8, 0.6]),
        ([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
    ];
    for (n, s_want, t_want) in cases {
        let (s, t) = coordinate_system(DVec3::from_array(n));
        assert!((s - DVec3::from_array(s_want)).length() < 1e-12, "{n:?}: s {s}");
        assert!((t - DVec3::from_array(t_want)).length() < 1e-12, "{n:?}: t {t}");
    }
    assert!(cylinder_to_world(DMat4::IDENTITY, DVec3::ONE, DVec3::ONE, 1.0).is_none());
}
