//! Anti-aliasing from a deep framebuffer at `factor` x the resolution (Hašan et al., "Tensor Clustering
//! for Rendering Many-Light Animations", EGSR 2008, Sec. 5, "Anti-aliasing"; the same idea as Hašan,
//! Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006, Sec. 3.6).
//!
//! Shading is computed once per pixel (any renderer's image). A deep framebuffer (DFB: position, normal,
//! diffuse albedo, the 9-vectors of `crate::view::features`) is rendered at `factor` x the resolution;
//! each high-resolution sample copies the colour of its nearest neighbour, in the 9-D metric, among the
//! 3x3 low-resolution pixels around the one containing it; each low-resolution pixel is then the box
//! filter (mean) of its `factor^2` high-resolution samples. High-resolution pixel (X, Y) lies in
//! low-resolution pixel (X / factor, Y / factor) (integer division), at film position
//! ((X + 0.5) / factor, (Y + 0.5) / factor) in low-resolution pixel units: with factor 3 the samples are
//! the 3x3 stratified grid of the pixel, so the result estimates the pixel-area average that Mitsuba's
//! box reconstruction filter gives with many samples per pixel.
//!
//! Pixels without a surface (background) have no 9-vector. A high-resolution background sample copies
//! the nearest (in film position) background pixel of the 3x3 neighbourhood; a surface sample copies
//! the nearest surface pixel by the 9-D metric (ties: the pixel containing it first, then row-major
//! order); when the neighbourhood has no pixel of its kind, the sample copies the pixel containing it.
//! Deviation: the paper does not say how background samples are treated; this rule keeps an
//! environment-lit background from bleeding onto silhouettes and vice versa.
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::view::features::{distance2, DeepFeatures};
use rayon::prelude::*;

/// Most accepted upsampling factor (a 16x16 DFB per pixel is already far past the paper's 3x3).
pub const MAX_FACTOR: u32 = 16;

/// `scene` with a film `factor` times larger in each dimension (same camera, field of view and
/// principal point offset, which is in film units): its view samples are the high-resolution DFB.
///
/// Errors: `InvalidParameter` for a factor outside [1, `MAX_FACTOR`] or a film that would overflow.
pub fn scaled_scene(scene: &Scene, factor: u32) -> Result<Scene> {
    check_factor(factor)?;
    let mut s = scene.clone();
    let (w, h) = (scene.camera.width.checked_mul(factor), scene.camera.height.checked_mul(factor));
    match (w, h) {
        (Some(w), Some(h)) if (w as u64) * (h as u64) <= u32::MAX as u64 => {
            s.camera.width = w;
            s.camera.height = h;
            Ok(s)
        }
        _ => Err(Error::invalid(format!(
            "antialias: a {}x{} film at factor {factor} has too many pixels",
            scene.camera.width, scene.camera.height
        ))),
    }
}

fn check_factor(factor: u32) -> Result<()> {
    if !(1..=MAX_FACTOR).contains(&factor) {
        return Err(Error::invalid(format!("antialias: factor must be in [1, {MAX_FACTOR}], got {factor}")));
    }
    Ok(())
}

/// Upsample `image` (low resolution, `channels` floats per pixel, row-major, `low.width * low.height`
/// pixels) to the high-resolution DFB `high` by nearest neighbours in 3x3 neighbourhoods and box-filter
/// it back down (module docs). Returns the anti-aliased image in the layout of `image`.
///
/// Errors: `InvalidParameter` when `high` is not `factor` x `low` or `image` is not one low-resolution
/// image.
pub fn antialias(image: &[f32], channels: usize, low: &DeepFeatures, high: &DeepFeatures, factor: u32) -> Result<Vec<f32>> {
    check_factor(factor)?;
    let (w, h) = (low.width as usize, low.height as usize);
    let f = factor as usize;
    if (high.width as usize, high.height as usize) != (w * f, h * f) {
        return Err(Error::invalid(format!(
            "antialias: the high-resolution deep framebuffer is {}x{}, expected {}x{} ({factor} x {w}x{h})",
            high.width,
            high.height,
            w * f,
            h * f
        )));
    }
    if channels == 0 || image.len() != w * h * channels {
        return Err(Error::invalid(format!(
            "antialias: image has {} values, expected {w}x{h} pixels x {channels} channels",
            image.len()
        )));
    }
    let hw = w * f;
    let inv = 1.0 / (f * f) as f32;
    let mut out = vec![0.0f32; image.len()];
    out.par_chunks_mut(w * channels).enumerate().for_each(|(ly, row)| {
        let mut acc = vec![0.0f32; channels];
        for lx in 0..w {
            acc.iter_mut().for_each(|a| *a = 0.0);
            for sy in 0..f {
                for sx in 0..f {
                    let (hx, hy) = (lx * f + sx, ly * f + sy);
                    let hi = hy * hw + hx;
                    // Sample position inside the low-resolution pixel grid (pixel units).
                    let (px, py) = ((hx as f32 + 0.5) / f as f32, (hy as f32 + 0.5) / f as f32);
                    let src = nearest_low_pixel(low, high, hi, lx, ly, px, py);
                    let v = &image[src * channels..(src + 1) * channels];
                    acc.iter_mut().zip(v).for_each(|(a, x)| *a += x);
                }
            }
            row[lx * channels..(lx + 1) * channels].iter_mut().zip(&acc).for_each(|(o, a)| *o = a * inv);
        }
    });
    Ok(out)
}

/// The low-resolution pixel whose colour high-resolution sample `hi` (at (px, py) in low-resolution
/// pixel units, inside pixel (lx, ly)) copies.
fn nearest_low_pixel(low: &DeepFeatures, high: &DeepFeatures, hi: usize, lx: usize, ly: usize, px: f32, py: f32) -> usize {
    let (w, h) = (low.width as usize, low.height as usize);
    let own = ly * w + lx;
    let surface = high.valid[hi];
    let mut best = own;
    let mut best_d = f32::INFINITY;
    let mut found = false;
    // The containing pixel first, so that it wins ties.
    let candidates = std::iter::once((0i64, 0i64)).chain((-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))).filter(|&d| d != (0, 0)));
    for (dx, dy) in candidates {
        let (x, y) = (lx as i64 + dx, ly as i64 + dy);
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            continue;
        }
        let j = y as usize * w + x as usize;
        if low.valid[j] != surface {
            continue;
        }
        let d = if surface {
            distance2(&low.features[j], &high.features[hi])
        } else {
            let (cx, cy) = (x as f32 + 0.5 - px, y as f32 + 0.5 - py);
            cx * cx + cy * cy
        };
        if d < best_d {
            best_d = d;
            best = j;
            found = true;
        }
    }
    if found {
        best
    } else {
        own
    }
}

#[cfg(test)]
mod tests {
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
}
