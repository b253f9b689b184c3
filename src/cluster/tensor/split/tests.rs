use super::*;
use crate::cluster::tensor::ReducedTensor;
use rand::SeedableRng;

/// Direct double sum of the paper's d(p, q) / 2 over ordered pairs of the cluster.
fn direct_cost(store: &ChunkStore, cl: &Cluster) -> f64 {
    let pairs: Vec<(usize, usize)> = cl.lights.iter().flat_map(|&j| (cl.k0..cl.k1).map(move |k| (j as usize, k))).collect();
    let mut total = 0.0;
    for &(j, k) in &pairs {
        for &(j2, k2) in &pairs {
            let (w1, w2) = (store.weight(j, k), store.weight(j2, k2));
            if w1 > 0.0 && w2 > 0.0 {
                let d: f64 =
                    store.column(j, k).iter().zip(store.column(j2, k2)).map(|(&a, &b)| (a as f64 / w1 - b as f64 / w2).powi(2)).sum();
                total += 0.5 * w1 * w2 * d;
            }
        }
    }
    total
}

#[test]
fn costs_of_both_splits_equal_the_paper_double_sum() {
    let (r, n, f) = (6, 9, 7);
    let mut rng = Pcg64::seed_from_u64(11);
    let data: Vec<f32> = (0..r * n * f * 3).map(|_| (normal(&mut rng).abs() * rng.random::<f64>()) as f32).collect();
    let tensor = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let store = ChunkStore::build(&tensor, 1, 7);
    let cl = Cluster { lights: vec![0, 2, 3, 5, 8], k0: 1, k1: 6 };
    let c = cluster_cost(&store, &cl);
    assert!((c - direct_cost(&store, &cl)).abs() < 1e-9 * c, "{c} vs {}", direct_cost(&store, &cl));
    for seed in 0..5 {
        let s = split(&store, &cl, &mut Pcg64::seed_from_u64(seed), 1.0);
        assert_eq!(s.left.size() + s.right.size(), cl.size());
        for (part, cost) in [(&s.left, s.cost_left), (&s.right, s.cost_right)] {
            assert!((cost - direct_cost(&store, part)).abs() < 1e-9 * c, "{cost} vs {}", direct_cost(&store, part));
            assert!(part.size() > 0);
        }
        assert!(s.cost_left + s.cost_right < c);
        // The chosen split is at least as good as every time cut.
        for cut in cl.k0 + 1..cl.k1 {
            let a = Cluster { lights: cl.lights.clone(), k0: cl.k0, k1: cut };
            let b = Cluster { lights: cl.lights.clone(), k0: cut, k1: cl.k1 };
            let t = direct_cost(&store, &a) + direct_cost(&store, &b);
            assert!(s.cost_left + s.cost_right <= t * (1.0 + 1e-9), "cut {cut}: {t} beats {:?}", s.kind);
        }
    }
}

#[test]
fn time_split_finds_the_scene_change_and_light_split_the_two_kinds() {
    // Lights 0..4 light rows 0..2, lights 4..8 rows 3..5; frames 0..3 and 3..6 differ in pattern.
    let (r, n, f) = (6, 8, 6);
    let mut data = vec![0.0f32; r * n * f * 3];
    for i in 0..r {
        for j in 0..n {
            for k in 0..f {
                let first_kind = j < 4;
                let row_lit = if k < 3 { (i < 3) == first_kind } else { (i % 2 == 0) == first_kind };
                if row_lit {
                    let v = 1.0 + j as f32 * 0.1;
                    data[((i * n + j) * f + k) * 3..][..3].copy_from_slice(&[v, v, v]);
                }
            }
        }
    }
    let tensor = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let store = ChunkStore::build(&tensor, 0, f);
    // Within one kind of light, only time separates: the cut must be at frame 3 at zero cost.
    let s = split(&store, &Cluster { lights: vec![0, 1, 2, 3], k0: 0, k1: 6 }, &mut Pcg64::seed_from_u64(1), 1.0);
    assert_eq!(s.kind, SplitKind::Time);
    assert_eq!((s.left.k1, s.right.k0), (3, 3));
    assert!(s.cost_left == 0.0 && s.cost_right == 0.0, "{} {}", s.cost_left, s.cost_right);
    // Within frames 0..3, the two kinds of light separate at zero cost by a light split.
    let s = split(&store, &Cluster { lights: (0..8).collect(), k0: 0, k1: 3 }, &mut Pcg64::seed_from_u64(2), 1.0);
    assert_eq!(s.kind, SplitKind::Light);
    let mut parts = [s.left.lights.clone(), s.right.lights.clone()];
    parts.sort();
    assert_eq!(parts, [vec![0, 1, 2, 3], vec![4, 5, 6, 7]]);
    assert!(s.cost_left == 0.0 && s.cost_right == 0.0);
}
