use super::*;
use rand::SeedableRng;

#[test]
fn stats_and_costs_match_direct_formulas() {
    // 2 rows, 3 columns, RGB.
    let data = [
        1.0, 2.0, 2.0, /**/ 0.0, 0.0, 0.0, /**/ 3.0, 0.0, 4.0, //
        0.0, 0.0, 0.0, /**/ 0.0, 0.0, 1.0, /**/ 0.0, 0.0, 0.0,
    ];
    let reduced = ReducedMatrix::new(&data, 2, 3, 3).unwrap();
    let stats = column_stats(&reduced);
    assert_eq!(stats.norm, vec![3.0, 1.0, 5.0]);
    assert_eq!(stats.channel_norm[2], [3.0, 0.0, 4.0]);
    // rho_0 = (3, 0), rho_1 = (0, 1), rho_2 = (5, 0). Cluster {0, 1}: 2 * (3*1 - 0) = 6; {2}: 0.
    let costs = cluster_costs(&reduced, &[0, 0, 1], 2, &stats.norm);
    assert!((costs[0] - 6.0).abs() < 1e-12 && costs[1] == 0.0, "{costs:?}");
    // {0, 2} are parallel: cost 0; {1}: 0.
    let costs = cluster_costs(&reduced, &[0, 1, 0], 2, &stats.norm);
    assert!(costs.iter().all(|c| c.abs() < 1e-9), "{costs:?}");
}

#[test]
fn projection_preserves_norms_roughly_and_is_identity_for_small_r() {
    let (r, n) = (200, 40);
    let mut rng = Pcg64::seed_from_u64(3);
    let data: Vec<f32> = (0..r * n).map(|_| normal(&mut rng).abs() as f32).collect();
    let reduced = ReducedMatrix::new(&data, r, n, 1).unwrap();
    let cols: Vec<u32> = (0..n as u32).collect();
    let f = project(&reduced, &cols, 50, &mut Pcg64::seed_from_u64(1));
    assert_eq!(f.dim, 50);
    let stats = column_stats(&reduced);
    // Johnson-Lindenstrauss: |G x| / |x| concentrates around 1 (std ~ 1/sqrt(2 r') = 0.1).
    for j in 0..n {
        let ratio = f.norm[j] / stats.norm[j];
        assert!((0.6..1.4).contains(&ratio), "column {j}: ratio {ratio}");
    }
    let f = project(&reduced, &cols, 500, &mut Pcg64::seed_from_u64(1));
    assert_eq!(f.dim, r);
    assert_eq!(f.column(7)[5], data[5 * n + 7] as f64);
}
