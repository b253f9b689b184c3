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
        return Err(Error::invalid(format!("antialias: image has {} values, expected {w}x{h} pixels x {channels} channels", image.len())));
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
mod tests;
