use super::*;
use crate::view::features::DIM;

/// A DFB of a vertical edge at x = `edge` (film units of the low-resolution image): surface A
/// (normal +z, albedo 0.2) left of it, surface B (normal +x, albedo 0.8) right of it, or background
/// right of it when `background`.
fn edge_dfb(w: u32, h: u32, f: u32, edge: f32, background: bool) -> DeepFeatures {
    let (fw, fh) = (w * f, h * f);
    let mut features = Vec::new();
    let mut valid = Vec::new();
    for y in 0..fh {
        for x in 0..fw {
            let px = (x as f32 + 0.5) / f as f32;
            let py = (y as f32 + 0.5) / f as f32;
            let left = px < edge;
            valid.push(left || !background);
            let mut v = [0.0f32; DIM];
            v[0] = px * 0.1;
            v[1] = py * 0.1;
            if left {
                v[5] = 1.0;
                v[6..9].copy_from_slice(&[0.2; 3]);
            } else if !background {
                v[3] = 1.0;
                v[6..9].copy_from_slice(&[0.8; 3]);
            }
            features.push(v);
        }
    }
    DeepFeatures { width: fw, height: fh, features, valid }
}

#[test]
fn edge_pixels_get_the_area_fraction_and_interiors_stay() {
    let (w, h) = (8, 4);
    // The edge crosses pixel column 3 at 1/3 of its width (x = 3.34: one of 3 sub-columns left).
    for background in [false, true] {
        let low = edge_dfb(w, h, 1, 3.34, background);
        let high = edge_dfb(w, h, 3, 3.34, background);
        // Shade: 1 on A, 5 on B (or the background), one channel.
        let image: Vec<f32> = (0..w * h).map(|i| if (i % w) as f32 + 0.5 < 3.34 { 1.0 } else { 5.0 }).collect();
        let out = antialias(&image, 1, &low, &high, 3).unwrap();
        for y in 0..h as usize {
            for x in 0..w as usize {
                let want = if x == 3 { (1.0 + 2.0 * 5.0) / 3.0 } else { image[y * w as usize + x] };
                assert!((out[y * w as usize + x] - want).abs() < 1e-6, "bg {background} ({x},{y}): {} vs {want}", out[y * w as usize + x]);
            }
        }
    }
}

#[test]
fn factor_one_is_the_identity_and_bad_sizes_fail() {
    let low = edge_dfb(5, 3, 1, 2.5, false);
    let image: Vec<f32> = (0..15 * 3).map(|v| v as f32).collect();
    assert_eq!(antialias(&image, 3, &low, &low, 1).unwrap(), image);
    let high = edge_dfb(5, 3, 3, 2.5, false);
    assert!(antialias(&image, 3, &low, &high, 2).unwrap_err().to_string().contains("expected 10x6"));
    assert!(antialias(&image[..9], 3, &low, &high, 3).unwrap_err().to_string().contains("expected 5x3 pixels x 3 channels"));
    assert!(antialias(&image, 3, &low, &high, 0).is_err());
    assert!(antialias(&image, 3, &low, &high, 17).is_err());
}
