use super::*;
use crate::view::features::DeepMetric;
use rand::{RngExt, SeedableRng};

fn random_features(w: u32, h: u32, seed: u64, hole: usize) -> DeepFeatures {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let m = (w * h) as usize;
    let features = (0..m).map(|_| std::array::from_fn(|_| rng.random::<f32>())).collect();
    let mut valid = vec![true; m];
    valid[hole] = false;
    let mut f = DeepFeatures { width: w, height: h, features, valid };
    f.features[hole] = [0.0; DIM];
    f
}

#[test]
fn nearest_matches_brute_force_and_is_identity_on_equal_frames() {
    let (w, h) = (13, 11);
    let a = random_features(w, h, 1, 5);
    let b = random_features(w, h, 2, 7);
    let map = PixelMapping::nearest(&a, &b).unwrap();
    for i in 0..(w * h) as usize {
        if i == 7 {
            assert_eq!(map.source[i], NO_SOURCE);
            continue;
        }
        let best = (0..(w * h) as usize)
            .filter(|&j| a.valid[j])
            .min_by(|&x, &y| {
                crate::view::features::distance2(&a.features[x], &b.features[i])
                    .total_cmp(&crate::view::features::distance2(&a.features[y], &b.features[i]))
            })
            .unwrap();
        assert_eq!(map.source[i], best as u32, "pixel {i}");
        assert_ne!(map.source[i], 5, "a pixel without surface is no source");
    }
    let same = PixelMapping::nearest(&a, &a).unwrap();
    for (i, &s) in same.source.iter().enumerate() {
        assert_eq!(s, if i == 5 { NO_SOURCE } else { i as u32 });
    }
}

#[test]
fn duplicate_features_still_map_to_themselves() {
    // A flat, uniformly coloured wall: many pixels share every coordinate but position.
    let metric = DeepMetric::for_diagonal(1.0);
    let (w, h) = (40, 40);
    let features: Vec<[f32; DIM]> = (0..w * h)
        .map(|i| metric.feature(glam::Vec3::new((i % 4) as f32 * 1e-3, 0.0, 0.0), glam::Vec3::Z, glam::Vec3::splat(0.5)))
        .collect();
    let f = DeepFeatures { width: w, height: h, features, valid: vec![true; (w * h) as usize] };
    let map = PixelMapping::nearest(&f, &f).unwrap();
    assert_eq!(map, PixelMapping::identity(w, h));
}

#[test]
fn composition_equals_the_chain_and_apply_gathers() {
    let (w, h) = (9, 7);
    let a = random_features(w, h, 3, 0);
    let b = random_features(w, h, 4, 1);
    let c = random_features(w, h, 5, 2);
    let ab = PixelMapping::nearest(&a, &b).unwrap();
    let bc = PixelMapping::nearest(&b, &c).unwrap();
    let ac = PixelMapping::chain(w, h, &[&ab, &bc]).unwrap();
    let m = (w * h) as usize;
    let img: Vec<f32> = (0..2 * m * 3).map(|v| v as f32 + 0.5).collect();
    let step = bc.apply(&ab.apply(&img, 3).unwrap(), 3).unwrap();
    assert_eq!(ac.apply(&img, 3).unwrap(), step);
    for i in 0..m {
        let s = ab.source[i];
        for ch in 0..3 {
            let want = if s == NO_SOURCE { 0.0 } else { img[s as usize * 3 + ch] };
            assert_eq!(ab.apply(&img, 3).unwrap()[i * 3 + ch], want);
        }
    }
    assert_eq!(PixelMapping::identity(w, h).then(&ab).unwrap(), ab);
    assert!(ab.apply(&img[..10], 3).is_err());
    let bad = PixelMapping { width: w, height: h, source: vec![m as u32; m] };
    assert!(bad.validate().unwrap_err().to_string().contains("entry 0 (x=0, y=0)"));
    let other = PixelMapping::identity(w + 1, h);
    assert!(ab.then(&other).is_err());
    assert!(PixelMapping::nearest(&a, &random_features(w + 1, h, 6, 0)).is_err());
}

#[test]
fn empty_source_frame_maps_nothing() {
    let mut a = random_features(4, 4, 7, 0);
    a.valid = vec![false; 16];
    let b = random_features(4, 4, 8, 0);
    assert!(PixelMapping::nearest(&a, &b).unwrap().source.iter().all(|&s| s == NO_SOURCE));
}
