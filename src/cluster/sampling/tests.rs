use super::*;
use rand::SeedableRng;

fn features(cols: &[&[f64]]) -> Features {
    let dim = cols[0].len();
    let data: Vec<f64> = cols.iter().flat_map(|c| c.iter().copied()).collect();
    let norm = cols.iter().map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
    Features { dim, data, norm }
}

#[test]
fn alpha_is_the_sum_of_incident_edge_costs() {
    let f = features(&[&[1.0, 0.0], &[0.0, 2.0], &[3.0, 4.0], &[2.0, 0.0]]);
    let a = alpha(&f);
    for i in 0..4 {
        let direct: f64 = (0..4)
            .map(|j| {
                let dot: f64 = f.column(i).iter().zip(f.column(j)).map(|(x, y)| x * y).sum();
                f.norm[i] * f.norm[j] - dot
            })
            .sum();
        assert!((a[i] - direct).abs() < 1e-12, "alpha[{i}] = {} vs {direct}", a[i]);
    }
}

#[test]
fn multiset_weights_are_inverse_probabilities_and_centres_distinct() {
    let alpha = [1.0, 0.0, 3.0, 4.0];
    let centres = sample_centres(&alpha, &[1.0; 4], 3, &mut Pcg64::seed_from_u64(5));
    assert_eq!(centres.len(), 3);
    let mut seen: Vec<u32> = centres.iter().map(|c| c.0).collect();
    seen.sort();
    assert_eq!(seen, vec![0, 2, 3], "index 1 has alpha 0 and must never be drawn");
    for &(i, w) in &centres {
        let inv_p = 8.0 / alpha[i as usize];
        let times = w / inv_p;
        assert!((times - times.round()).abs() < 1e-9 && times >= 1.0, "weight {w} is not a multiple of 1/p = {inv_p}");
    }
}

#[test]
fn assignment_follows_the_weighted_distance() {
    // Two centres along the axes; x = (1, 1) is equally far from both unscaled, so the smaller
    // weight wins; (5, 0.1) is nearest to the x-axis centre.
    let f = features(&[&[1.0, 0.0], &[0.0, 1.0], &[1.0, 1.0], &[5.0, 0.1]]);
    let a = assign(&f, &[(0, 2.0), (1, 1.0)]).unwrap();
    assert_eq!(a, vec![0, 1, 1, 0]);
    let a = assign(&f, &[(0, 1.0), (1, 2.0)]).unwrap();
    assert_eq!(a, vec![0, 1, 0, 0]);
}
