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
