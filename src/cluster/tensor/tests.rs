//! Tensor clustering on synthetic animations: point lights above a floor with a wall (occlusion), the
//! lights drifting a little every frame.
use super::*;
use rand::RngExt;

/// Reduced tensor (r, n, f, 3): `r` floor points, `n` lights moving by `speed` per frame.
fn animation(r: usize, n: usize, f: usize, speed: f64, seed: u64) -> Vec<f32> {
    let mut rng = chunk_rng(seed, 99, 7);
    let lights: Vec<([f64; 3], [f64; 3], [f64; 3])> = (0..n)
        .map(|_| {
            let p = [rng.random::<f64>() * 2.0, rng.random::<f64>(), 0.05 + 0.4 * rng.random::<f64>()];
            let v = [rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, 0.0];
            let c = [0.2 + rng.random::<f64>(), 0.2 + rng.random::<f64>(), 0.2 + rng.random::<f64>()];
            (p, v, c)
        })
        .collect();
    let points: Vec<(f64, f64)> = (0..r).map(|_| (rng.random::<f64>() * 2.0, rng.random::<f64>())).collect();
    let mut data = vec![0.0f32; r * n * f * 3];
    for (i, &(px, py)) in points.iter().enumerate() {
        for (j, (p, v, c)) in lights.iter().enumerate() {
            for k in 0..f {
                let (lx, ly, lz) = (p[0] + speed * k as f64 * v[0], p[1] + speed * k as f64 * v[1], p[2]);
                // Wall at x = 1 with a doorway 0.4 < y < 0.6.
                if (lx - 1.0) * (px - 1.0) < 0.0 {
                    let y = ly + (1.0 - lx) / (px - lx) * (py - ly);
                    if !(0.4..0.6).contains(&y) {
                        continue;
                    }
                }
                let d2 = (px - lx).powi(2) + (py - ly).powi(2) + lz * lz;
                let g = 0.01 * lz / (d2 * d2.sqrt());
                for ch in 0..3 {
                    data[((i * n + j) * f + k) * 3 + ch] = (g * c[ch]) as f32;
                }
            }
        }
    }
    data
}

/// The clustering's estimate of the row sums, (r, f, 3): `sum_t Rec(t, k) R(:, rep_t)`.
fn estimate(c: &TensorClustering, t: &ReducedTensor) -> Vec<f64> {
    let (r, f) = (t.num_rows(), t.num_frames());
    let mut out = vec![0.0f64; r * f * 3];
    for (cl, &(j, kr)) in c.representatives.iter().enumerate() {
        for k in 0..f {
            let s = c.rec[cl * f + k];
            for i in 0..r {
                for ch in 0..3 {
                    out[(i * f + k) * 3 + ch] += s[ch] as f64 * t.channel(i, j as usize, kr as usize, ch);
                }
            }
        }
    }
    out
}

fn row_sums(t: &ReducedTensor) -> Vec<f64> {
    let (r, n, f) = (t.num_rows(), t.num_lights(), t.num_frames());
    let mut out = vec![0.0f64; r * f * 3];
    for i in 0..r {
        for j in 0..n {
            for k in 0..f {
                for ch in 0..3 {
                    out[(i * f + k) * 3 + ch] += t.channel(i, j, k, ch);
                }
            }
        }
    }
    out
}

fn relative_l2(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

/// Every pair in exactly one rectangular cluster inside one chunk, representative inside its cluster.
fn check_partition(c: &TensorClustering, columns: usize) {
    let (n, f) = (c.num_lights, c.num_frames);
    assert_eq!(c.num_clusters(), columns);
    assert_eq!(c.rec.len(), columns * f);
    let mut count = vec![0u32; n * f];
    for t in 0..columns {
        let (k0, k1) = c.frames[t];
        assert!(k0 < k1 && !c.lights[t].is_empty(), "cluster {t} is empty");
        let chunk = c.chunks.iter().find(|ch| ch.frames.0 <= k0 as usize && (k1 as usize) <= ch.frames.1);
        assert!(chunk.is_some(), "cluster {t} frames {k0}..{k1} cross a chunk boundary");
        for &j in &c.lights[t] {
            for k in k0..k1 {
                assert_eq!(c.assignment[j as usize * f + k as usize], t as u32);
                count[j as usize * f + k as usize] += 1;
            }
        }
        let (j, k) = c.representatives[t];
        assert!(c.lights[t].contains(&j) && (k0..k1).contains(&k), "representative of cluster {t} outside it");
        for k in 0..f as u32 {
            if !(k0..k1).contains(&k) {
                assert_eq!(c.rec[t * f + k as usize], [0.0; 3], "Rec outside the cluster's frames");
            }
        }
    }
    assert!(count.iter().all(|&v| v == 1), "every light-frame pair in exactly one cluster");
}

#[test]
fn full_budget_reproduces_the_row_sums_exactly() {
    let (r, n, f) = (12, 10, 6);
    let data = animation(r, n, f, 0.05, 1);
    let t = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    for chunk in [40, 4] {
        let opts = TensorOptions { chunk, init_clusters: 3, ..Default::default() };
        let c = cluster_tensor(t, n * f, &opts).unwrap();
        check_partition(&c, n * f);
        let (est, exact) = (estimate(&c, &t), row_sums(&t));
        for (a, b) in est.iter().zip(&exact) {
            assert!((a - b).abs() <= 1e-6 * b.abs() + 1e-12, "{a} vs {b}");
        }
        // Singletons: every Rec entry inside a cluster is exactly 1 (or 0 for an all-zero pair).
        for (tc, &(k0, _)) in c.frames.iter().enumerate() {
            let v = c.rec[tc * f + k0 as usize];
            assert!(v == [1.0; 3] || v == [0.0; 3], "{v:?}");
        }
    }
}

#[test]
fn chunk_budgets_are_proportional_to_frames() {
    assert_eq!(chunk_budgets(100, 40, 250), vec![(0, 40, 100), (40, 80, 100), (80, 100, 50)]);
    // 23 * (4, 4, 2) / 10 = 9.2, 9.2, 4.6: floors 9, 9, 4 and the one left over to the largest fraction.
    assert_eq!(chunk_budgets(10, 4, 23), vec![(0, 4, 9), (4, 8, 9), (8, 10, 5)]);
    assert_eq!(chunk_budgets(7, 40, 7), vec![(0, 7, 7)]);
    let (r, n, f) = (8, 30, 10);
    let data = animation(r, n, f, 0.05, 2);
    let t = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let opts = TensorOptions { chunk: 4, init_clusters: 5, ..Default::default() };
    let c = cluster_tensor(t, 23, &opts).unwrap();
    check_partition(&c, 23);
    let per_chunk: Vec<usize> =
        c.chunks.iter().map(|ch| c.frames.iter().filter(|&&(k0, _)| (ch.frames.0..ch.frames.1).contains(&(k0 as usize))).count()).collect();
    assert_eq!(per_chunk, vec![9, 9, 5]);
    assert_eq!(c.chunks.iter().map(|ch| ch.budget).collect::<Vec<_>>(), vec![9, 9, 5]);
    for ch in &c.chunks {
        assert_eq!(ch.init_clusters + ch.time_splits + ch.light_splits, ch.budget, "{ch:?}");
    }
}

#[test]
fn same_seed_same_result_other_seed_other_clustering() {
    let (r, n, f) = (16, 200, 8);
    let data = animation(r, n, f, 0.05, 3);
    let t = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let opts = TensorOptions { init_clusters: 20, seed: 5, ..Default::default() };
    let a = cluster_tensor(t, 160, &opts).unwrap();
    check_partition(&a, 160);
    assert_eq!(a, cluster_tensor(t, 160, &opts).unwrap());
    let b = cluster_tensor(t, 160, &TensorOptions { seed: 6, ..opts.clone() }).unwrap();
    assert_ne!(a.assignment, b.assignment);
    // Clustering beats a single cluster by far, and more columns give a lower error.
    let exact = row_sums(&t);
    let e160 = relative_l2(&estimate(&a, &t), &exact);
    let e800 = relative_l2(&estimate(&cluster_tensor(t, 800, &opts).unwrap(), &t), &exact);
    assert!(e160 < 0.2 && e800 < e160, "{e160} {e800}");
}

#[test]
fn paper_representative_is_the_heaviest_pair_and_rec_its_weight_ratio() {
    // One cluster (columns = f = 1 is not allowed below f; use f = 1, columns = 1): two lights.
    // R(:, 0) = (3, 0, 0) grey, R(:, 1) = (0, 4, 0) red only in row 1.
    let data = [3.0f32, 3.0, 3.0, 0.0, 0.0, 0.0, /* row 1 */ 0.0, 0.0, 0.0, 4.0, 0.0, 0.0];
    let t = ReducedTensor::new(&data, 2, 2, 1, 3).unwrap();
    let c = cluster_tensor(t, 1, &TensorOptions::default()).unwrap();
    // Weights: |R(:,0)| = 3 sqrt(3) = 5.196 > |R(:,1)| = 4.
    assert_eq!(c.representatives, vec![(0, 0)]);
    let w0 = 27f64.sqrt();
    // Colour averaging: channel norms (3, 3, 3) and (4, 0, 0): Rec = (7/3, 3/3, 3/3).
    let rec = c.rec[0];
    assert!((rec[0] - 7.0 / 3.0).abs() < 1e-6 && (rec[1] - 1.0).abs() < 1e-6 && (rec[2] - 1.0).abs() < 1e-6, "{rec:?}");
    let grey = cluster_tensor(t, 1, &TensorOptions { color_averaging: false, ..Default::default() }).unwrap();
    let want = ((w0 + 4.0) / w0) as f32;
    assert!(grey.rec[0].iter().all(|&v| (v - want).abs() < 1e-6), "{:?} vs {want}", grey.rec[0]);
    // The paper's choice is biased: the estimate of row 1 is 0 instead of 4 whatever the seed.
    let est = estimate(&c, &t);
    assert_eq!(est[3], 0.0);
    assert_eq!(c.shadow_maps_per_frame(), vec![1]);
}

#[test]
fn sampled_representatives_follow_the_weights() {
    // Same two lights: P(light 0) = w0 / (w0 + 4).
    let data = [3.0f32, 3.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0];
    let t = ReducedTensor::new(&data, 2, 2, 1, 3).unwrap();
    let w0 = 27f64.sqrt();
    let p0 = w0 / (w0 + 4.0);
    let draws = 4000;
    let mut zeros = 0;
    for seed in 0..draws {
        let opts = TensorOptions { seed, representative: Representative::Sampled, color_averaging: false, ..Default::default() };
        let c = cluster_tensor(t, 1, &opts).unwrap();
        let (j, _) = c.representatives[0];
        let w = if j == 0 { w0 } else { 4.0 };
        assert!((c.rec[0][0] as f64 - (w0 + 4.0) / w).abs() < 1e-5);
        zeros += (j == 0) as u64;
    }
    let freq = zeros as f64 / draws as f64;
    let sd = (p0 * (1.0 - p0) / draws as f64).sqrt();
    assert!((freq - p0).abs() < 4.0 * sd, "{freq} vs {p0}");
}

#[test]
fn zero_columns_and_zero_clusters_are_handled() {
    // Light 1 is dark in every frame, light 2 only in frame 0; all zero tensor too.
    let (r, n, f) = (4, 3, 3);
    let mut data = animation(r, n, f, 0.0, 4);
    for i in 0..r {
        for k in 0..f {
            for ch in 0..3 {
                data[((i * n + 1) * f + k) * 3 + ch] = 0.0;
                if k == 0 {
                    data[((i * n + 2) * f + k) * 3 + ch] = 0.0;
                }
            }
        }
    }
    let t = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    for columns in 3..=9 {
        let c = cluster_tensor(t, columns, &TensorOptions { init_clusters: 1, ..Default::default() }).unwrap();
        check_partition(&c, columns);
        let rendered = c.rendered();
        for (tc, &(j, k)) in c.representatives.iter().enumerate() {
            let zero = (0..r).all(|i| t.channel(i, j as usize, k as usize, 0) == 0.0);
            assert_eq!(rendered[tc], !zero, "cluster {tc}");
        }
        let maps: usize = c.shadow_maps_per_frame().iter().sum();
        assert_eq!(maps, rendered.iter().filter(|&&x| x).count());
    }
    let zeros = vec![0.0f32; r * n * f * 3];
    let t = ReducedTensor::new(&zeros, r, n, f, 3).unwrap();
    let c = cluster_tensor(t, 5, &TensorOptions::default()).unwrap();
    check_partition(&c, 5);
    assert!(c.rec.iter().all(|v| *v == [0.0; 3]));
    assert_eq!(c.shadow_maps_per_frame(), vec![0, 0, 0]);
}

#[test]
fn bad_input_is_refused_with_a_message() {
    let data = vec![0.5f32; 2 * 3 * 4 * 3];
    let t = ReducedTensor::new(&data, 2, 3, 4, 3).unwrap();
    let msg = |e: Error| e.to_string();
    assert!(msg(cluster_tensor(t, 3, &TensorOptions::default()).unwrap_err()).contains("at least the number of frames (4)"));
    assert!(msg(cluster_tensor(t, 13, &TensorOptions::default()).unwrap_err()).contains("n * f = 3 * 4 = 12"));
    assert!(msg(cluster_tensor(t, 5, &TensorOptions { chunk: 0, ..Default::default() }).unwrap_err()).contains("chunk"));
    assert!(msg(ReducedTensor::new(&data[1..], 2, 3, 4, 3).unwrap_err()).contains("needs 72 values, got 71"));
    let mut bad = data.clone();
    bad[((1 * 3 + 2) * 4 + 3) * 3 + 1] = f32::NAN;
    let e = msg(ReducedTensor::new(&bad, 2, 3, 4, 3).unwrap_err());
    assert!(e.contains("row 1, light 2, frame 3, channel 1"), "{e}");
    assert!(ReducedTensor::new(&[], 0, 3, 4, 3).is_err());
}

#[test]
fn centroid_representative_is_the_best_aligned_pair_not_the_heaviest() {
    // Scalar, one frame, 2 rows: a heavy outlier (10, 0) and four lights along (3, 3). Sum P = (22, 12):
    // P . x = 22 for the outlier, 34 / sqrt(2) = 24.04 for the others.
    let data = [10.0f32, 3.0, 3.0, 3.0, 3.0, /* row 1 */ 0.0, 3.0, 3.0, 3.0, 3.0];
    let t = ReducedTensor::new(&data, 2, 5, 1, 1).unwrap();
    let max = cluster_tensor(t, 1, &TensorOptions::default()).unwrap();
    let centroid = cluster_tensor(t, 1, &TensorOptions { representative: Representative::Centroid, ..Default::default() }).unwrap();
    assert_eq!(max.representatives, vec![(0, 0)]);
    assert_eq!(centroid.representatives, vec![(1, 0)]);
    // Rec = s / w_rep: (10 + 4 * 3 sqrt 2) / (3 sqrt 2).
    let s = 10.0 + 12.0 * 2f64.sqrt();
    assert!((centroid.rec[0][0] as f64 - s / (3.0 * 2f64.sqrt())).abs() < 1e-5, "{:?}", centroid.rec[0]);
    let err = |c: &TensorClustering| {
        let e = c.rec[0][0] as f64;
        let (j, _) = c.representatives[0];
        let est = [e * data[j as usize] as f64, e * data[5 + j as usize] as f64];
        ((est[0] - 22.0).powi(2) + (est[1] - 12.0).powi(2)).sqrt()
    };
    // Centroid: (s / sqrt 2)(1, 1); max: (s, 0). Errors against the row sums (22, 12):
    let h = s / 2f64.sqrt();
    let want_centroid = ((h - 22.0).powi(2) + (h - 12.0).powi(2)).sqrt();
    let want_max = ((s - 22.0).powi(2) + 144.0).sqrt();
    assert!((err(&centroid) - want_centroid).abs() < 1e-4 && (err(&max) - want_max).abs() < 1e-4);
    assert!(err(&centroid) < 0.6 * err(&max), "{} vs {}", err(&centroid), err(&max));
}

#[test]
fn frame_major_layout_is_the_same_tensor() {
    let (r, n, f) = (3, 5, 4);
    let data: Vec<f32> = (0..r * n * f * 3).map(|x| (x as f32 * 0.37).sin().abs()).collect();
    // The same values stored frame by frame: (f, r, n, 3).
    let mut fm = vec![0f32; data.len()];
    for i in 0..r {
        for j in 0..n {
            for k in 0..f {
                for c in 0..3 {
                    fm[((k * r + i) * n + j) * 3 + c] = data[((i * n + j) * f + k) * 3 + c];
                }
            }
        }
    }
    let a = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let b = ReducedTensor::frame_major(&fm, r, n, f, 3).unwrap();
    for i in 0..r {
        for j in 0..n {
            for k in 0..f {
                for c in 0..3 {
                    assert_eq!(a.channel(i, j, k, c), b.channel(i, j, k, c));
                }
            }
        }
    }
    let opts = TensorOptions { init_clusters: 2, ..Default::default() };
    let ca = cluster_tensor(a, 8, &opts).unwrap();
    let cb = cluster_tensor(b, 8, &opts).unwrap();
    assert_eq!(ca.assignment, cb.assignment);
    assert_eq!(ca.rec, cb.rec);
    fm[((2 * r + 1) * n + 4) * 3 + 2] = f32::NAN;
    let e = ReducedTensor::frame_major(&fm, r, n, f, 3).unwrap_err().to_string();
    assert!(e.contains("row 1, light 4, frame 2, channel 2"), "{e}");
}

#[test]
fn centroid_representative_skips_pairs_the_rows_barely_see() {
    // Scalar, one frame, 2 rows: a faint light (0.01, 0.01) exactly along P = (7.01, 7.01) and two
    // lights (4, 3), (3, 4). Without a weight floor the faint one wins (P . x = 9.91 against 9.81) and
    // is scaled by Rec = s / w = 708; with CENTROID_WEIGHT_FLOOR (0.5 of the mean weight 3.34) it cannot
    // be chosen and the first of the two others is, with Rec = s / 5.
    let data = [0.01f32, 4.0, 3.0, /* row 1 */ 0.01, 3.0, 4.0];
    let t = ReducedTensor::new(&data, 2, 3, 1, 1).unwrap();
    let opts = TensorOptions { representative: Representative::Centroid, ..Default::default() };
    let c = cluster_tensor(t, 1, &opts).unwrap();
    assert_eq!(c.representatives, vec![(1, 0)]);
    let s = 0.01 * 2f64.sqrt() + 10.0;
    assert!((c.rec[0][0] as f64 - s / 5.0).abs() < 1e-5, "{:?}", c.rec[0]);
    assert!(super::reconstruction::CENTROID_WEIGHT_FLOOR * s / 3.0 > 0.01 * 2f64.sqrt());
}
