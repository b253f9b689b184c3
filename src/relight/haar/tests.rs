use super::*;
use rand::RngExt;
use rand_pcg::Pcg32;

fn random_image(side: usize, channels: usize, seed: u64) -> Vec<f32> {
    let mut rng = Pcg32::new(seed, 7);
    (0..side * side * channels).map(|_| rng.random::<f32>() * 2.0 - 1.0).collect()
}

/// Forward then inverse gives the image back to float precision, for every size and 1 or 3 channels;
/// the transform keeps the energy (orthonormal).
#[test]
fn forward_inverse_is_exact_and_keeps_energy() {
    for k in 0..=7 {
        let side = 1usize << k;
        for channels in [1, 3] {
            let x = random_image(side, channels, k as u64);
            let mut y = x.clone();
            forward(&mut y, side, channels).unwrap();
            let e_x: f64 = x.iter().map(|v| (*v as f64).powi(2)).sum();
            let e_y: f64 = y.iter().map(|v| (*v as f64).powi(2)).sum();
            assert!((e_x - e_y).abs() <= 1e-5 * e_x, "side {side}: energy {e_x} -> {e_y}");
            inverse(&mut y, side, channels).unwrap();
            let err = x.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            // Each value passes 2k butterflies of two roundings each: a few ulps of 1.
            assert!(err <= 4.0 * k as f32 * f32::EPSILON, "side {side} channels {channels}: max error {err}");
        }
    }
}

/// Exact values: the 2 x 2 butterfly, a constant image (one scaling coefficient side * value), and a
/// 4 x 4 image whose coefficients were computed by hand.
#[test]
fn known_coefficients() {
    let mut x = vec![1.0, 2.0, 3.0, 5.0];
    forward(&mut x, 2, 1).unwrap();
    assert_eq!(x, vec![5.5, -1.5, -2.5, 0.5]);
    let mut c = vec![0.25f32; 64 * 64];
    forward(&mut c, 64, 1).unwrap();
    assert_eq!(c[0], 16.0);
    assert!(c[1..].iter().all(|&v| v == 0.0));
    // Left half 1, right half 0: only the coarsest horizontal detail and the scaling coefficient.
    let mut h: Vec<f32> = (0..16).map(|i| if i % 4 < 2 { 1.0 } else { 0.0 }).collect();
    forward(&mut h, 4, 1).unwrap();
    let mut expect = vec![0.0f32; 16];
    expect[0] = 2.0; // sum 8 / 4
    expect[1] = 2.0; // (4 - 0 + 4 - 0) / 2 / 2 at the top level: averages 2, 0, 2, 0 -> (2 - 0 + 2 - 0) / 2
    assert_eq!(h, expect);
}

/// W is orthonormal: the transforms of the 16 unit images of a 4 x 4 image are orthonormal vectors, and
/// the inverse of a unit coefficient is the transposed basis (W^-1 = W^T).
#[test]
fn basis_is_orthonormal() {
    let side = 4;
    let n = side * side;
    let mut w = vec![vec![0.0f32; n]; n];
    for (j, col) in w.iter_mut().enumerate() {
        col[j] = 1.0;
        forward(col, side, 1).unwrap();
    }
    for a in 0..n {
        for b in 0..n {
            let dot: f32 = (0..n).map(|i| w[a][i] * w[b][i]).sum();
            assert!((dot - if a == b { 1.0 } else { 0.0 }).abs() < 1e-6, "({a}, {b}): {dot}");
        }
    }
    for i in 0..n {
        let mut e = vec![0.0f32; n];
        e[i] = 1.0;
        inverse(&mut e, side, 1).unwrap();
        for j in 0..n {
            assert!((e[j] - w[j][i]).abs() < 1e-6);
        }
    }
}

/// `support_area` counts the non-zeros of each basis function (inverse transform of a unit coefficient).
#[test]
fn support_area_counts_nonzeros() {
    for side in [1usize, 2, 4, 8, 16] {
        for i in 0..side * side {
            let mut e = vec![0.0f32; side * side];
            e[i] = 1.0;
            inverse(&mut e, side, 1).unwrap();
            let nonzero = e.iter().filter(|v| **v != 0.0).count();
            assert_eq!(support_area(i, side), nonzero, "side {side} coefficient {i}");
        }
    }
    assert_eq!(support_area(0, 64), 4096);
    assert_eq!(support_area(63 * 64 + 63, 64), 4);
    assert_eq!(support_area(1, 64), 4096);
    assert_eq!(support_area(2, 64), 1024);
}

/// Dense T g equals the sparse wavelet product (T W^T)(W g) when culling keeps everything; area-weighted
/// culling to all coefficients is the identity, and with fewer the product's error shrinks as more are kept.
#[test]
fn culling_nothing_reproduces_the_dense_product() {
    let (side, channels, rows) = (16usize, 3usize, 24usize);
    let n = side * side;
    let t: Vec<Vec<f32>> = (0..rows).map(|r| random_image(side, 1, 100 + r as u64).iter().map(|v| v.abs()).collect()).collect();
    let g = random_image(side, channels, 5).iter().map(|v| v.abs()).collect::<Vec<f32>>();
    let dense: Vec<[f64; 3]> =
        t.iter().map(|row| std::array::from_fn(|ch| (0..n).map(|j| row[j] as f64 * g[j * channels + ch] as f64).sum())).collect();
    let mut gw = g.clone();
    forward(&mut gw, side, channels).unwrap();
    let product = |keep: usize| -> Vec<[f64; 3]> {
        t.iter()
            .map(|row| {
                let mut rw = row.clone();
                forward(&mut rw, side, 1).unwrap();
                let sparse = cull_area_weighted(&rw, side, 1, keep).unwrap();
                std::array::from_fn(|ch| {
                    sparse.index.iter().zip(&sparse.value).map(|(&j, &v)| v as f64 * gw[j as usize * channels + ch] as f64).sum()
                })
            })
            .collect()
    };
    let err = |p: &[[f64; 3]]| -> f64 {
        let num: f64 = p.iter().zip(&dense).flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).powi(2))).sum();
        let den: f64 = dense.iter().flat_map(|b| b.iter().map(|v| v * v)).sum();
        (num / den).sqrt()
    };
    let full = product(n);
    assert!(err(&full) < 1e-6, "relative error {}", err(&full));
    let (e16, e64) = (err(&product(16)), err(&product(64)));
    assert!(e64 < e16 && e16 < 0.5, "errors 16: {e16}, 64: {e64}");
    // Keeping everything returns every non-zero coefficient unchanged.
    let mut rw = t[0].clone();
    forward(&mut rw, side, 1).unwrap();
    let s = cull_area_weighted(&rw, side, 1, n).unwrap();
    let mut back = vec![0.0f32; n];
    for (&j, &v) in s.index.iter().zip(&s.value) {
        back[j as usize] = v;
    }
    assert_eq!(back, rw);
}

/// Area weighting prefers a smaller coefficient of a larger basis function: coarse (area 16 of a 4 x 4
/// image) 0.5 beats fine (area 4) 1.5, since 0.5 * 16 = 8 > 1.5 * 4 = 6; RGB magnitude is the 2-norm.
#[test]
fn area_weighting_picks_by_magnitude_times_support() {
    let mut c = vec![0.0f32; 16];
    c[1] = 0.5; // level 0: area 16
    c[2] = 1.5; // level 1: area 4
    c[15] = 1.9; // level 1: area 4 -> 7.6
    let s = cull_area_weighted(&c, 4, 1, 1).unwrap();
    assert_eq!(s.index, vec![1]);
    let s = cull_area_weighted(&c, 4, 1, 2).unwrap();
    assert_eq!(s.index, vec![1, 15]);
    assert_eq!(s.value, vec![0.5, 1.9]);
    let s = cull_area_weighted(&c, 4, 1, 100).unwrap();
    assert_eq!(s.index, vec![1, 2, 15]);
    assert_eq!(cull_area_weighted(&c, 4, 1, 0).unwrap().index, Vec::<u32>::new());
    let mut rgb = vec![0.0f32; 48];
    rgb[10 * 3..10 * 3 + 3].copy_from_slice(&[3.0, 4.0, 0.0]); // (2, 2): |.| = 5, area 4 -> 20
    rgb[3..6].copy_from_slice(&[1.0, 1.0, 1.0]); // coefficient 1: sqrt 3 * 16 = 27.7
    assert_eq!(cull_area_weighted(&rgb, 4, 3, 1).unwrap().index, vec![1]);
}

/// Transport-weighted culling: |g_j| * ||column j|| < epsilon is dropped; epsilon = 0 keeps all.
#[test]
fn wavelet_light_culling_uses_light_times_image_norm() {
    let rows = vec![SparseRow { index: vec![0, 2], value: vec![3.0, 1.0] }, SparseRow { index: vec![0, 3], value: vec![4.0, 0.5] }];
    let norms = column_norms(&rows, 4, 1).unwrap();
    assert_eq!(norms, vec![5.0, 0.0, 1.0, 0.5]);
    let light = [[0.1, 0.0, 0.0], [9.0, 9.0, 9.0], [0.0, 0.6, 0.8], [2.0, 0.0, 0.0]].concat();
    // products: 0.5, 0, 1.0, 1.0
    assert_eq!(cull_wavelet_lights(&light, 3, &norms, 0.0).unwrap(), vec![0, 1, 2, 3]);
    assert_eq!(cull_wavelet_lights(&light, 3, &norms, 0.6).unwrap(), vec![2, 3]);
    assert_eq!(cull_wavelet_lights(&light, 3, &norms, 1.0).unwrap(), vec![2, 3]);
    assert_eq!(cull_wavelet_lights(&light, 3, &norms, 1.01).unwrap(), Vec::<u32>::new());
}

#[test]
fn bad_input_is_an_error() {
    let mut x = vec![0.0f32; 9];
    assert!(forward(&mut x, 3, 1).unwrap_err().to_string().contains("2^k x 2^k"));
    let mut x = vec![0.0f32; 15];
    assert!(inverse(&mut x, 4, 1).unwrap_err().to_string().contains("has 16 values, got 15"));
    assert!(forward(&mut [], 0, 1).is_err());
    assert!(cull_area_weighted(&[f32::NAN, 0.0, 0.0, 0.0], 2, 1, 1).unwrap_err().to_string().contains("coefficient 0"));
    let rows = vec![SparseRow { index: vec![4], value: vec![1.0] }];
    assert!(column_norms(&rows, 4, 1).unwrap_err().to_string().contains("column 4 out of range"));
    assert!(cull_wavelet_lights(&[1.0; 3], 3, &[1.0], -1.0).unwrap_err().to_string().contains("epsilon"));
    assert!(cull_wavelet_lights(&[1.0; 3], 3, &[f32::NAN], 0.0).is_err());
    assert!(cull_wavelet_lights(&[1.0; 4], 3, &[1.0], 0.0).is_err());
    assert!(cull_wavelet_lights(&[f32::INFINITY, 0.0, 0.0], 3, &[1.0], 0.0).unwrap_err().to_string().contains("light 0"));
}
