use super::*;

#[test]
fn nearest_matches_brute_force() {
    let pts: Vec<Vec3> = (0..500)
        .map(|i| {
            let f = i as f32;
            Vec3::new((f * 0.37).sin() * 3.0, (f * 0.11).cos() * 2.0, (f * 0.05).fract())
        })
        .collect();
    let map = PhotonMap::new(&pts);
    for q in [Vec3::ZERO, Vec3::new(1.0, -1.0, 0.5), Vec3::splat(10.0)] {
        let (mut got, r2) = map.nearest(q, 16);
        let mut all: Vec<(f32, usize)> = pts.iter().enumerate().map(|(i, p)| (p.distance_squared(q), i)).collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut want: Vec<usize> = all[..16].iter().map(|x| x.1).collect();
        got.sort();
        want.sort();
        assert_eq!(got, want);
        assert!((r2 - all[15].0).abs() <= 1e-6 * all[15].0.max(1.0));
    }
    assert_eq!(PhotonMap::new(&[]).nearest(Vec3::ZERO, 4), (vec![], 0.0));
    assert_eq!(map.nearest(Vec3::ZERO, 1000).0.len(), 500);
}
