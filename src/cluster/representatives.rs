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
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn stats(norm_rgb: &[[f64; 3]]) -> ColumnStats {
        ColumnStats {
            norm: norm_rgb.iter().map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()).collect(),
            channel_norm: norm_rgb.to_vec(),
        }
    }

    #[test]
    fn norm_sampling_frequencies_and_weights() {
        let st = stats(&[[1.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 4.0]]);
        let cols = [0u32, 1, 3];
        let mut rng = Pcg64::seed_from_u64(4);
        let mut counts = [0usize; 4];
        for _ in 0..80_000 {
            let (rep, w) = pick_by_norm(&cols, &st, false, &mut rng);
            counts[rep as usize] += 1;
            let expected = 8.0 / st.norm[rep as usize];
            assert!(w.iter().all(|&v| (v as f64 - expected).abs() < 1e-5), "{w:?} vs {expected}");
        }
        // p = (1, 3, 4) / 8; 4 standard deviations of a binomial with 80k draws ~ 0.0074.
        for (j, p) in [(0usize, 0.125), (1, 0.375), (3, 0.5)] {
            assert!((counts[j] as f64 / 80_000.0 - p).abs() < 0.0074, "{counts:?}");
        }
        // Colour averaging: channel sums (1, 3, 4) over the representative's channel norms, fallback grey.
        let (rep, w) = pick_by_norm(&cols, &st, true, &mut rng);
        let grey = (8.0 / st.norm[rep as usize]) as f32;
        let c = st.channel_norm[rep as usize];
        for k in 0..3 {
            let want = if c[k] > 0.0 { ([1.0, 3.0, 4.0][k] / c[k]) as f32 } else { grey };
            assert!((w[k] - want).abs() < 1e-6, "channel {k}: {} vs {want}", w[k]);
        }
    }

    #[test]
    fn power_sampling_and_strata() {
        let power = [0.0f32, 1.0, 3.0, 0.0];
        let mut rng = Pcg64::seed_from_u64(8);
        for _ in 0..1000 {
            let (rep, w) = pick_by_power(&[0, 1, 2, 3], Some(&power), &mut rng);
            assert!(rep == 1 || rep == 2, "zero-power lights are never drawn");
            assert_eq!(w[0], if rep == 1 { 4.0 } else { 4.0 / 3.0 });
        }
        let (_, w) = pick_by_power(&[0, 3], Some(&power), &mut rng);
        assert_eq!(w, [2.0; 3], "all-zero power in a cluster falls back to uniform");
        let s = strata(&[5, 6, 7, 8, 9, 10, 11], 3);
        assert_eq!(s, vec![vec![5, 6], vec![7, 8], vec![9, 10, 11]]);
    }
}
