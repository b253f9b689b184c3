use super::*;
use crate::cluster::{cluster_reduced_columns, ClusterOptions};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

#[test]
fn variance_matches_enumeration_and_sampling() {
    // 2 rows x 4 lights x 3 channels, clusters {0, 2} and {1, 3}.
    let data: Vec<f32> = (0..24).map(|v| ((v * 7) % 5) as f32 + 0.5).collect();
    let rows = ReducedMatrix::new(&data, 2, 4, 3).unwrap();
    let assignment = [0u32, 1, 0, 1];
    let probability = [0.25, 0.5, 0.75, 0.5];
    let var = row_variance(rows, &assignment, &probability, 2).unwrap();
    // Exact: enumerate the 2 x 2 outcomes with their probabilities.
    for i in 0..2 {
        for ch in 0..3 {
            let a = |j: usize| rows.channel(i, j, ch);
            let total: f64 = (0..4).map(a).sum();
            let mut second = 0.0;
            for (j0, p0) in [(0usize, 0.25), (2, 0.75)] {
                for (j1, p1) in [(1usize, 0.5), (3, 0.5)] {
                    let x = a(j0) / p0 + a(j1) / p1;
                    second += p0 * p1 * (x - total) * (x - total);
                }
            }
            assert!((var[i][ch] - second).abs() < 1e-9 * second.max(1.0), "row {i} ch {ch}: {} vs {second}", var[i][ch]);
        }
    }
    // Monte Carlo check of the same number (independent of the formula's algebra).
    let mut rng = Pcg64::seed_from_u64(3);
    let (mut s1, mut s2) = (0.0, 0.0);
    let trials = 200_000;
    for _ in 0..trials {
        let j0 = if rng.random::<f64>() < 0.25 { 0 } else { 2 };
        let j1 = if rng.random::<f64>() < 0.5 { 1 } else { 3 };
        let x = rows.channel(0, j0, 0) / probability[j0] + rows.channel(0, j1, 0) / probability[j1];
        s1 += x;
        s2 += x * x;
    }
    let mean = s1 / trials as f64;
    let mc = s2 / trials as f64 - mean * mean;
    assert!((mc - var[0][0]).abs() < 0.02 * var[0][0], "{mc} vs {}", var[0][0]);
}

#[test]
fn probabilities_sum_to_one_per_cluster_and_match_weights() {
    let mut rng = Pcg64::seed_from_u64(5);
    let (r, n) = (6usize, 40usize);
    let mut data = vec![0.0f32; r * n * 3];
    for (at, v) in data.iter_mut().enumerate() {
        // Columns 30.. are zero-norm.
        if (at / 3) % n < 30 {
            *v = rng.random::<f32>();
        }
    }
    let reduced = ReducedMatrix::new(&data, r, n, 3).unwrap();
    let power: Vec<f32> = (0..n).map(|j| if j == 35 { 0.0 } else { 1.0 + j as f32 }).collect();
    for c in [1usize, 5, 12] {
        let opts = ClusterOptions { seed: 9, power: Some(&power), ..Default::default() };
        let cl = cluster_reduced_columns(reduced, c, &opts).unwrap();
        let p = probabilities_of(&reduced, &cl, Some(&power));
        for cluster in &cl.clusters {
            let total: f64 = cluster.iter().map(|&j| p[j as usize]).sum();
            assert!((total - 1.0).abs() < 1e-12, "c = {c}: cluster probabilities sum to {total}");
        }
        for (rep, w) in cl.representatives.iter().zip(&cl.weights) {
            let expected = 1.0 / p[*rep as usize];
            assert!((w[0] as f64 - expected).abs() < 1e-5 * expected, "c = {c}: weight {} vs 1/p {expected}", w[0]);
        }
        assert_eq!(p[35], 0.0, "a zero-power light in a zero-norm cluster is never drawn");
    }
}

#[test]
fn bad_lengths_and_labels() {
    let data = vec![1.0f32; 6];
    let rows = ReducedMatrix::new(&data, 1, 2, 3).unwrap();
    assert!(row_variance(rows, &[0], &[1.0, 1.0], 1).unwrap_err().to_string().contains("n = 2"));
    assert!(row_variance(rows, &[0, 2], &[1.0, 1.0], 2).unwrap_err().to_string().contains("assignment[1]"));
    assert!(row_variance(rows, &[0, 1], &[1.0, f64::NAN], 2).unwrap_err().to_string().contains("probability[1]"));
}
