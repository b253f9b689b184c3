use super::*;

fn area(p: [Vec3; 3]) -> f64 {
    0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() as f64
}

fn corners(tri: &[Vec3; 3], b: [Vec3; 3]) -> [Vec3; 3] {
    b.map(|w| tri[0] * w.x + tri[1] * w.y + tri[2] * w.z)
}

/// Longest edge over the inradius-like height: 1 for an equilateral triangle's 2 / sqrt(3) scaled.
fn aspect(p: [Vec3; 3]) -> f64 {
    let longest = (0..3).map(|i| (p[(i + 1) % 3] - p[i]).length() as f64).fold(0.0, f64::max);
    longest * longest / (2.0 * area(p))
}

#[test]
fn pieces_tile_each_triangle_with_equal_areas_and_keep_the_winding() {
    // A 1 x 1 quad and a 50:1 sliver rectangle, as two triangles each.
    let quad = [[Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)], [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]];
    let cdf = [0.5, 1.0];
    for n in [2, 3, 7, 100, 4000] {
        let pieces = compact_strata(&quad, &cdf, n).unwrap();
        assert_eq!(pieces.len(), n);
        let total: f64 = pieces.iter().map(|p| area(corners(&quad[p.triangle], p.bary))).sum();
        assert!((total - 1.0).abs() < 1e-5, "n {n}: the pieces cover {total} of 1 m^2");
        for p in &pieces {
            let c = corners(&quad[p.triangle], p.bary);
            assert!((area(c) - p.area).abs() < 1e-5 * p.area.max(1e-3), "n {n}: piece {} against {}", area(c), p.area);
            // Same winding as the triangle: the normal keeps its sign (+z).
            assert!((c[1] - c[0]).cross(c[2] - c[0]).z > 0.0);
        }
    }
    // Compact at every count: longest edge^2 / (2 area) at most 5 (2 for the quad's own halves; measured
    // worst over n = 2..3000: 4.35).
    let mut worst = 0.0f64;
    for n in 2..3000 {
        let pieces = compact_strata(&quad, &cdf, n).unwrap();
        worst = pieces.iter().map(|p| aspect(corners(&quad[p.triangle], p.bary))).fold(worst, f64::max);
    }
    eprintln!("worst aspect over n = 2..3000: {worst}");
    assert!(worst <= 5.0, "aspect {worst}");
    let sliver = [[Vec3::ZERO, Vec3::new(50.0, 0.0, 0.0), Vec3::new(50.0, 1.0, 0.0)], [Vec3::ZERO, Vec3::new(50.0, 1.0, 0.0), Vec3::Y]];
    let pieces = compact_strata(&sliver, &[25.0, 50.0], 2000).unwrap();
    let worst = pieces.iter().map(|p| aspect(corners(&sliver[p.triangle], p.bary))).fold(0.0, f64::max);
    // Bisection keeps a triangle's shape classes: the pieces of a sliver triangle (aspect 50) are as thin
    // as it is, not thinner (measured 55.6), whereas the cumulative-area strips of 2,000 lights would be
    // 1,000 times thinner.
    assert!(worst <= 1.2 * aspect(sliver[0]), "sliver: aspect {worst} against the triangle's {}", aspect(sliver[0]));
}

#[test]
fn fewer_lights_than_triangles_keep_the_cumulative_strata() {
    let tri = [[Vec3::ZERO, Vec3::X, Vec3::Y]; 3];
    assert!(compact_strata(&tri, &[0.5, 1.0, 1.5], 2).is_none());
    assert_eq!(compact_strata(&tri, &[0.5, 1.0, 1.5], 3).unwrap().len(), 3);
    // A zero-area triangle gets no light and does not count.
    assert_eq!(compact_strata(&tri, &[0.5, 0.5, 1.0], 2).unwrap().iter().map(|p| p.triangle).collect::<Vec<_>>(), vec![0, 2]);
    assert!(compact_strata(&tri, &[0.0, 0.0, 0.0], 5).is_none());
}
