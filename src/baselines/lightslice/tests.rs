//! Slices partition the visible pixels, every slice has the requested clusters, the estimate is close
//! to brute force and bad parameters are errors (cbox-lights, CPU backend).
use super::*;
use crate::baselines::tests::cbox_lights;

fn options() -> LightSliceOptions {
    LightSliceOptions { slices: 48, columns: 64, global_columns: 32, neighbours: 6, normal_weight: 0.25, seed: 1 }
}

#[test]
fn slices_cover_the_image_and_the_estimate_is_near_brute_force() {
    let a = cbox_lights(16);
    let out = lightslice(&a, &options()).unwrap();
    let visible = (0..a.view.num_pixels()).filter(|&p| a.view.shape_index[p] >= 0).count();
    assert_eq!(out.slice_of_pixel.iter().filter(|&&s| s >= 0).count(), visible);
    assert_eq!(out.rows.len(), 48);
    for (s, &row) in out.rows.iter().enumerate() {
        assert_eq!(out.slice_of_pixel[row], s as i32, "slice {s}'s row is one of its pixels");
    }
    let sizes: Vec<usize> = (0..48).map(|s| out.slice_of_pixel.iter().filter(|&&x| x == s).count()).collect();
    // Median splits of the largest slice: sizes within a factor 2 (+1 for odd halves).
    assert!(sizes.iter().max().unwrap() <= &(2 * sizes.iter().min().unwrap() + 1), "median splits: {sizes:?}");
    assert!(out.clusters_per_slice.iter().all(|&c| c == 64), "{:?}", out.clusters_per_slice);
    let reference = a.column_sum(None, &mut |_, _| {}).unwrap();
    let err = |img: &[f32]| {
        let d: f64 = img.iter().zip(&reference).map(|(&x, &r)| ((x - r) as f64).powi(2)).sum();
        (d / reference.iter().map(|&r| (r as f64).powi(2)).sum::<f64>()).sqrt()
    };
    let e = err(&out.image);
    eprintln!("lightslice: relative L2 {e:.4}, {} rays", out.shadow_rays);
    // Measured 0.10 at 16x16 (48 slices of ~5 pixels), 64 clusters per slice.
    assert!(e < 0.2, "relative L2 {e}");
}

#[test]
fn bad_parameters_are_errors() {
    let a = cbox_lights(8);
    for bad in [
        LightSliceOptions { slices: 0, ..options() },
        LightSliceOptions { columns: 0, ..options() },
        LightSliceOptions { global_columns: 0, ..options() },
        LightSliceOptions { neighbours: 0, ..options() },
        LightSliceOptions { global_columns: 65, ..options() },
        LightSliceOptions { normal_weight: f64::NAN, ..options() },
    ] {
        assert!(lightslice(&a, &bad).is_err(), "{bad:?}");
    }
}

#[test]
fn unbiased_over_seeds_given_the_clusterings() {
    // Every seed draws new rows, clusterings and representatives; the image total's mean over seeds
    // must match brute force, and the spread over 96 seeds resolves a 5% bias.
    let a = cbox_lights(12);
    let reference = a.column_sum(None, &mut |_, _| {}).unwrap();
    let truth: f64 = reference.iter().map(|&v| v as f64).sum();
    let opts = LightSliceOptions { slices: 16, columns: 48, global_columns: 24, neighbours: 4, normal_weight: 0.25, seed: 0 };
    let totals: Vec<f64> = (0..96)
        .map(|seed| lightslice(&a, &LightSliceOptions { seed, ..opts.clone() }).unwrap().image.iter().map(|&v| v as f64).sum())
        .collect();
    let n = totals.len() as f64;
    let mean = totals.iter().sum::<f64>() / n;
    let sd = (totals.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() / n.sqrt();
    let (z, z_biased) = ((mean - truth) / sd, (mean - 1.05 * truth) / sd);
    eprintln!("lightslice over seeds: z {z:.3}, 5% biased z {z_biased:.3}");
    assert!(z.abs() < 4.0, "z = {z}");
    // Measured z = -7.4 against a 5% brighter reference (96 seeds).
    assert!(z_biased.abs() > 4.0, "a 5% bias gives only z = {z_biased}");
}
