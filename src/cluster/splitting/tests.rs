use super::*;
use rand::SeedableRng;

#[test]
fn split_separates_two_directions_at_zero_cost_and_matches_direct_costs() {
    // 6 columns along two directions with different norms: the best cut costs 0.
    let dirs = [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]];
    let mut data = Vec::new();
    let mut norm = Vec::new();
    for k in 0..6 {
        let scale = 1.0 + k as f64;
        data.extend(dirs[k % 2].iter().map(|v| v * scale));
        norm.push(scale);
    }
    let f = Features { dim: 3, data, norm };
    let members: Vec<u32> = (0..6).collect();
    assert!(cluster_cost(&f, &members) > 1.0);
    let (mut left, mut right, cl, cr) = split(&f, &members, &mut Pcg64::seed_from_u64(2));
    left.sort();
    right.sort();
    let groups = [vec![0, 2, 4], vec![1, 3, 5]];
    assert!(groups.contains(&left) && groups.contains(&right), "{left:?} {right:?}");
    assert!(cl.abs() < 1e-9 && cr.abs() < 1e-9);
}

#[test]
fn incremental_cut_costs_equal_direct_costs() {
    let mut rng = Pcg64::seed_from_u64(9);
    let (d, m) = (5, 40);
    let data: Vec<f64> = (0..d * m).map(|_| normal(&mut rng).abs()).collect();
    let norm = data.chunks(d).map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
    let f = Features { dim: d, data, norm };
    let members: Vec<u32> = (0..m as u32).collect();
    let (left, right, cl, cr) = split(&f, &members, &mut rng);
    assert_eq!(left.len() + right.len(), m);
    assert!((cl - cluster_cost(&f, &left)).abs() < 1e-9 * (1.0 + cl));
    assert!((cr - cluster_cost(&f, &right)).abs() < 1e-9 * (1.0 + cr));
    assert!(cl + cr < cluster_cost(&f, &members));
}

#[test]
fn split_until_reaches_target_even_at_zero_cost() {
    // Ten parallel columns: every cluster costs 0, splitting must still produce 4 balanced parts.
    let data: Vec<f64> = (0..10).flat_map(|k| [1.0 + k as f64, 2.0 + 2.0 * k as f64]).collect();
    let norm = data.chunks(2).map(|c| (c[0] * c[0] + c[1] * c[1]).sqrt()).collect();
    let f = Features { dim: 2, data, norm };
    let mut clusters = vec![(0..10).collect::<Vec<u32>>()];
    split_until(&f, &mut clusters, 4, &mut Pcg64::seed_from_u64(1)).unwrap();
    assert_eq!(clusters.len(), 4);
    let mut all: Vec<u32> = clusters.iter().flatten().copied().collect();
    all.sort();
    assert_eq!(all, (0..10).collect::<Vec<u32>>());
    assert!(clusters.iter().all(|c| (2..=3).contains(&c.len())), "{clusters:?}");
}
