//! Representative selection (Sec. 3.3 and Sec. 4 "Representative selection and color averaging") and
//! the zero-norm clusters (the unbiased treatment that Sec. 3.3 names). Every function returns the
//! representative column and its RGB weight; see the module doc of [`super`] for why the default
//! weight is `1 / P(representative)` in every channel.
use super::columns::ColumnStats;
use rand::RngExt;
use rand_pcg::Pcg64;

/// Draws an index with probability proportional to `weights` (sum > 0): (index, probability).
fn draw(weights: &[f64], rng: &mut Pcg64) -> (usize, f64) {
    let total: f64 = weights.iter().sum();
    let u = rng.random::<f64>() * total;
    let mut acc = 0.0;
    let mut last_positive = 0;
    for (i, &w) in weights.iter().enumerate() {
        if w > 0.0 {
            acc += w;
            last_positive = i;
            if u < acc {
                return (i, w / total);
            }
        }
    }
    // Round-off put u at the very end.
    (last_positive, weights[last_positive] / total)
}

/// Sec. 3.3: representative drawn with `p_j = |rho_j| / s` (all norms > 0), weight `s / |rho_j|`; with
/// `color_averaging` the Sec. 4 per-channel weight `(sum_{j in C} |rho^c_j|_k) / |rho^c_rep|_k` (biased,
/// unbiased fallback for a representative channel of norm 0).
pub fn pick_by_norm(columns: &[u32], stats: &ColumnStats, color_averaging: bool, rng: &mut Pcg64) -> (u32, [f32; 3]) {
    let norms: Vec<f64> = columns.iter().map(|&j| stats.norm[j as usize]).collect();
    let (at, p) = draw(&norms, rng);
    let rep = columns[at];
    let grey = 1.0 / p;
    let weight = if color_averaging {
        let mut sums = [0.0f64; 3];
        for &j in columns {
            for (s, v) in sums.iter_mut().zip(&stats.channel_norm[j as usize]) {
                *s += v;
            }
        }
        let rep_norm = stats.channel_norm[rep as usize];
        std::array::from_fn(|k| if rep_norm[k] > 0.0 { (sums[k] / rep_norm[k]) as f32 } else { grey as f32 })
    } else {
        [grey as f32; 3]
    };
    (rep, weight)
}

/// Zero-norm cluster: representative drawn proportionally to `power` (uniformly when absent or when
/// the cluster's power sums to 0), weight `1/q_j` in every channel.
pub fn pick_by_power(columns: &[u32], power: Option<&[f32]>, rng: &mut Pcg64) -> (u32, [f32; 3]) {
    let weights = power_weights(columns, power);
    let (at, q) = draw(&weights, rng);
    (columns[at], [(1.0 / q) as f32; 3])
}

fn power_weights(columns: &[u32], power: Option<&[f32]>) -> Vec<f64> {
    match power {
        Some(p) if columns.iter().any(|&j| p[j as usize] > 0.0) => columns.iter().map(|&j| p[j as usize] as f64).collect(),
        _ => vec![1.0; columns.len()],
    }
}

/// c = 1 with zero-norm columns: one cluster of all columns, representative from the mixture
/// `(1 - lambda) |rho_j| / s + lambda q_j` (q: [`pick_by_power`]'s distribution on the zero-norm columns,
/// `lambda = #zero / n`), weight `1/p_j`.
pub fn pick_mixture(nonzero: &[u32], zero: &[u32], stats: &ColumnStats, power: Option<&[f32]>, rng: &mut Pcg64) -> (u32, [f32; 3]) {
    let lambda = zero.len() as f64 / (zero.len() + nonzero.len()) as f64;
    let s: f64 = nonzero.iter().map(|&j| stats.norm[j as usize]).sum();
    let q = power_weights(zero, power);
    let q_total: f64 = q.iter().sum();
    let mut weights: Vec<f64> = nonzero.iter().map(|&j| (1.0 - lambda) * stats.norm[j as usize] / s).collect();
    weights.extend(q.iter().map(|w| lambda * w / q_total));
    let (at, p) = draw(&weights, rng);
    let rep = if at < nonzero.len() { nonzero[at] } else { zero[at - nonzero.len()] };
    (rep, [(1.0 / p) as f32; 3])
}

/// `count` contiguous strata of (nearly) equal size of the sorted `columns` (count <= columns.len()).
pub fn strata(columns: &[u32], count: usize) -> Vec<Vec<u32>> {
    (0..count).map(|k| columns[k * columns.len() / count..(k + 1) * columns.len() / count].to_vec()).collect()
}

#[cfg(test)]
mod tests;
