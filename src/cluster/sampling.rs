//! Sec. 3.5 "Clustering by sampling" (after Schulman 1999) with the Sec. 4 matrix forms.
//!
//! `alpha_i = sum_j d(rho_i, rho_j)` with `d(x, y) = |x||y| - x.y`, i.e. `alpha = |rho_i| S - rho_i . T`
//! with `S = sum_j |rho_j|` and `T = sum_j rho_j` (the "row sums by associativity" of Sec. 4). Points are
//! drawn with `p_i = alpha_i / sum alpha` into a multi-set (weight `1/p_i`, repeated draws add up) until
//! it holds the requested number of distinct centres. The centres scaled by their weights, `K = w_k
//! rho_k`, stand for the clusters they will represent: `w_k rho_k ~ sum_{j in C_k} rho_j`, and adding a
//! column x to cluster k costs `sum_{j in C_k} d(x, rho_j) = |x| s_k - x . sum rho_j ~ d(x, w_k rho_k)`.
//! So every column joins the centre minimising `d(x, w_k rho_k) = w_k (|x||rho_k| - x . rho_k)`, the
//! Sec. 4 matrix `nK^T nR - K^T R` evaluated block-wise with faer.
use super::columns::Features;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par};
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Columns per parallel block of the assignment.
const ASSIGN_BLOCK: usize = 1024;
/// Blocks per parallel group of `assign` (interruption checks between groups).
const ASSIGN_GROUP: usize = 16;

/// `alpha_i = sum_j d(rho_i, rho_j)` for every feature column (clamped at 0 against round-off).
pub fn alpha(features: &Features) -> Vec<f64> {
    let (d, m) = (features.dim, features.len());
    let norm_sum: f64 = features.norm.iter().sum();
    let mut total = vec![0.0f64; d];
    for i in 0..m {
        for (t, v) in total.iter_mut().zip(features.column(i)) {
            *t += v;
        }
    }
    // rho_i . T for all i: the product R^T T.
    let mut dots = Mat::<f64>::zeros(m, 1);
    matmul(dots.as_mut(), Accum::Replace, features.as_mat().transpose(), MatRef::from_column_major_slice(&total, d, 1), 1.0, Par::Seq);
    (0..m).map(|i| (features.norm[i] * norm_sum - dots[(i, 0)]).max(0.0)).collect()
}

/// Draws the multi-set of centres: (feature index, weight `sum 1/p_i`), in order of first draw.
pub fn sample_centres(alpha: &[f64], norm: &[f64], num_centres: usize, rng: &mut Pcg64) -> Vec<(u32, f64)> {
    // All alpha zero (all columns parallel): any partition costs 0; fall back to p ~ |rho|.
    let weights = if alpha.iter().any(|&a| a > 0.0) { alpha } else { norm };
    let mut cdf = Vec::with_capacity(weights.len());
    let mut acc = 0.0f64;
    for &w in weights {
        acc += w;
        cdf.push(acc);
    }
    let total = acc;
    let positive = weights.iter().filter(|&&w| w > 0.0).count();
    let target = num_centres.min(positive);
    let max_draws = 64 * num_centres + 1024;
    let mut slot = vec![u32::MAX; weights.len()];
    let mut centres: Vec<(u32, f64)> = Vec::with_capacity(target);
    let mut draws = 0;
    while centres.len() < target && draws < max_draws {
        draws += 1;
        let u = rng.random::<f64>() * total;
        // First index with cdf > u; skips zero-weight entries.
        let i = cdf.partition_point(|&c| c <= u).min(weights.len() - 1);
        if weights[i] <= 0.0 {
            continue;
        }
        let inv_p = total / weights[i];
        if slot[i] == u32::MAX {
            slot[i] = centres.len() as u32;
            centres.push((i as u32, inv_p));
        } else {
            centres[slot[i] as usize].1 += inv_p;
        }
    }
    centres
}

/// Clusters (lists of feature indices) from sampled centres; each centre is in its own cluster.
/// Errors: only `Error::Interrupted` (Ctrl-C).
pub fn cluster_by_sampling(features: &Features, num_centres: usize, rng: &mut Pcg64) -> crate::error::Result<Vec<Vec<u32>>> {
    let alpha = alpha(features);
    let centres = sample_centres(&alpha, &features.norm, num_centres, rng);
    let assignment = assign(features, &centres)?;
    let mut clusters = vec![Vec::new(); centres.len()];
    for (i, &a) in assignment.iter().enumerate() {
        clusters[a as usize].push(i as u32);
    }
    Ok(clusters)
}

/// Index (into `centres`) of the centre minimising `w_k (|x||rho_k| - x . rho_k)` for every feature
/// column, ties to the lowest index; a centre always gets itself. Runs in groups of `ASSIGN_GROUP`
/// blocks with Ctrl-C checks between them (`Error::Interrupted`, its only error).
pub fn assign(features: &Features, centres: &[(u32, f64)]) -> crate::error::Result<Vec<u32>> {
    let (d, m, c) = (features.dim, features.len(), centres.len());
    // K: d x c, the unscaled centres (the weights scale the distances afterwards).
    let mut centre_data = Vec::with_capacity(d * c);
    for &(i, _) in centres {
        centre_data.extend_from_slice(features.column(i as usize));
    }
    let centre_mat = MatRef::from_column_major_slice(&centre_data, d, c);
    let centre_norm: Vec<f64> = centres.iter().map(|&(i, _)| features.norm[i as usize]).collect();
    let mut assignment = vec![0u32; m];
    for (g, group) in assignment.chunks_mut(ASSIGN_BLOCK * ASSIGN_GROUP).enumerate() {
        crate::interrupt::check()?;
        group.par_chunks_mut(ASSIGN_BLOCK).enumerate().for_each(|(b, out)| {
            let j0 = (g * ASSIGN_GROUP + b) * ASSIGN_BLOCK;
            let cols = out.len();
            let block = MatRef::from_column_major_slice(&features.data[j0 * d..(j0 + cols) * d], d, cols);
            // K^T R for this block: c x cols.
            let mut dots = Mat::<f64>::zeros(c, cols);
            matmul(dots.as_mut(), Accum::Replace, centre_mat.transpose(), block, 1.0, Par::Seq);
            for (jj, slot) in out.iter_mut().enumerate() {
                let x_norm = features.norm[j0 + jj];
                let mut best = (f64::INFINITY, 0u32);
                for k in 0..c {
                    let dist = centres[k].1 * (centre_norm[k] * x_norm - dots[(k, jj)]);
                    if dist < best.0 {
                        best = (dist, k as u32);
                    }
                }
                *slot = best.1;
            }
        });
    }
    for (k, &(i, _)) in centres.iter().enumerate() {
        assignment[i as usize] = k as u32;
    }
    Ok(assignment)
}

#[cfg(test)]
mod tests;
