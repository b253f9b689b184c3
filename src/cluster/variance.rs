//! The variance of the MRCS estimator at chosen rows, for an error estimate without the reference
//! (issue 14; Hašan et al. 2007, Sec. 3.3 and Appendix A).
//!
//! For a fixed clustering C_1..C_c and the representative of cluster k drawn with probability `p_j`
//! (j in C_k, the probabilities of one cluster sum to 1) and weighted `1/p_j`, the estimate of element i of
//! the column sum is `X_i = sum_k A_{i,J_k} / p_{J_k}` with independent J_k. Its variance is, per channel,
//!
//! `Var[X_i] = sum_k ( sum_{j in C_k} A_ij^2 / p_j  -  (sum_{j in C_k} A_ij)^2 )`,
//!
//! exact for every row i of which all n elements are known (a row of the reduced matrix or an extra row).
//! A light with `p_j = 0` is never drawn; its elements are left out (the estimator then misses them: the
//! clustering assumes such lights emit nothing, see [`super`]).
use super::columns::ColumnStats;
use super::{Clustering, ReducedMatrix};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// `P(column j is the representative of its cluster)` for every column, following the rules of
/// [`super::cluster_reduced_columns`]: `|rho_j| / s_k` in a cluster of non-zero reduced columns, the
/// power (else uniform) distribution in a cluster of zero-norm columns, and the mixture of
/// [`super::representatives::pick_mixture`] in a cluster holding both (only c = 1).
pub fn selection_probabilities(stats: &ColumnStats, clustering: &Clustering, power: Option<&[f32]>) -> Vec<f64> {
    let n = stats.norm.len();
    let mut p = vec![0.0f64; n];
    for cluster in &clustering.clusters {
        let (nonzero, zero): (Vec<u32>, Vec<u32>) = cluster.iter().partition(|&&j| stats.norm[j as usize] > 0.0);
        let s: f64 = nonzero.iter().map(|&j| stats.norm[j as usize]).sum();
        let q: Vec<f64> = match power {
            Some(pw) if zero.iter().any(|&j| pw[j as usize] > 0.0) => zero.iter().map(|&j| pw[j as usize] as f64).collect(),
            _ => vec![1.0; zero.len()],
        };
        let q_total: f64 = q.iter().sum();
        let lambda = if nonzero.is_empty() { 1.0 } else { zero.len() as f64 / cluster.len() as f64 };
        for &j in &nonzero {
            p[j as usize] = (1.0 - lambda) * stats.norm[j as usize] / s;
        }
        for (&j, &w) in zero.iter().zip(&q) {
            p[j as usize] = lambda * w / q_total;
        }
    }
    p
}

/// [`selection_probabilities`] of a clustering of `reduced` (computes the column norms).
pub fn probabilities_of(reduced: &ReducedMatrix, clustering: &Clustering, power: Option<&[f32]>) -> Vec<f64> {
    selection_probabilities(&super::columns::column_stats(reduced), clustering, power)
}

/// Per row and channel, the variance of the MRCS estimate of that row's element of the column sum
/// (module doc): `rows` holds h complete rows (h x n x 3, or x 1), `assignment[j]` the cluster of column j
/// (labels < `num_clusters`), `probability[j]` its selection probability within its cluster.
/// Returns h x 3 values, row-major (scalar rows repeat their value in every channel).
///
/// Errors: lengths that do not match n, a label >= `num_clusters`, a probability outside [0, 1] or NaN.
pub fn row_variance(rows: ReducedMatrix, assignment: &[u32], probability: &[f64], num_clusters: usize) -> Result<Vec<[f64; 3]>> {
    let n = rows.num_columns();
    if assignment.len() != n || probability.len() != n {
        return Err(Error::invalid(format!(
            "assignment and probability must have n = {n} values (one per light), got {} and {}",
            assignment.len(),
            probability.len()
        )));
    }
    if let Some(j) = assignment.iter().position(|&a| a as usize >= num_clusters) {
        return Err(Error::invalid(format!("assignment[{j}] = {} is not below the {num_clusters} clusters", assignment[j])));
    }
    if let Some(j) = probability.iter().position(|p| !(0.0..=1.0 + 1e-9).contains(p)) {
        return Err(Error::invalid(format!("probability[{j}] = {} is not in [0, 1]", probability[j])));
    }
    let out = (0..rows.num_rows())
        .into_par_iter()
        .map(|i| {
            let mut first = vec![[0.0f64; 3]; num_clusters];
            let mut second = vec![[0.0f64; 3]; num_clusters];
            for j in 0..n {
                let p = probability[j];
                if p <= 0.0 {
                    continue;
                }
                let k = assignment[j] as usize;
                for ch in 0..3 {
                    let a = rows.channel(i, j, ch);
                    first[k][ch] += a;
                    second[k][ch] += a * a / p;
                }
            }
            let mut var = [0.0f64; 3];
            for (f, s) in first.iter().zip(&second) {
                for ch in 0..3 {
                    // >= 0 by Cauchy-Schwarz (sum p = 1 within a cluster); clamp the round-off.
                    var[ch] += (s[ch] - f[ch] * f[ch]).max(0.0);
                }
            }
            var
        })
        .collect();
    Ok(out)
}

#[cfg(test)]
mod tests {
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
}
