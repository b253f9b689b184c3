//! The variance of the MRCS estimator at chosen rows, for an error estimate without the reference
//! (Hašan et al. 2007, Sec. 3.3 and Appendix A).
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
mod tests;
