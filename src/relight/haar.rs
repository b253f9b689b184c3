//! 2D Haar wavelets on the gather image and the two kinds of coefficient culling of direct-to-indirect
//! transfer (Hašan, Pellacini, Bala, SIGGRAPH 2006, Sec. 3.3, 3.5, 4.3, 5).
//!
//! Decomposition: the non-standard one (as the paper's GPU transform, "at each pass the image is shrunk
//! by a factor of 2 and a shader computes the coefficients corresponding to that level", and as
//! Ng et al. 2003 whose wavelet lighting it follows): each pass maps every 2 x 2 block
//!     [a b]
//!     [c d]
//! of the current s x s average image to one average and three details,
//!     average (a + b + c + d) / 2,  horizontal (a - b + c - d) / 2,
//!     vertical (a + b - c - d) / 2,   diagonal (a - b - c + d) / 2,
//! stored Mallat-style: averages in the top-left s/2 x s/2 quadrant (transformed again by the next
//! pass), horizontal details top-right, vertical bottom-left, diagonal bottom-right. The factor 1/2 makes
//! every pass, hence the whole transform W, orthonormal: W^-1 = W^T, energy (sum of squares) is kept and
//! T g = (T W^T)(W g) (Eq. 3) holds exactly up to float rounding. The 2 x 2 blocks of the gather image
//! are the quad-tree's clusters (`hierarchy`), so every basis function is constant with a sign pattern on
//! one cluster: a "wavelet light" spans that cluster's surfaces.
//!
//! Images are row-major, `side` x `side` pixels (side a power of 2), `channels` interleaved values per
//! pixel (1 for F_d rows, 3 for RGB).
//!
//! Support ("area", Sec. 4.3): the coefficient at (0, 0) is the scaling function, supported on the whole
//! image (side^2 pixels); a detail at (r, c) != (0, 0) with L = floor(log2(max(r, c))) belongs to the
//! pass that produced a 2^L x 2^L detail quadrant, and is supported on a block of (side / 2^L)^2 pixels.
//!
//! Area-weighted culling of a matrix row (4.3): each coefficient's importance is its magnitude (the 2-norm
//! over channels) times the area of its basis function's support; the `keep` most important ones are
//! kept (ties: lower index first; coefficients of importance 0 are never kept: they change nothing).
//!
//! Transport-weighted on-the-fly culling of wavelet lights (3.5): wavelet light j (coefficient j of the
//! projected lighting W g) is skipped when |g^w_j| * ||T^w_{:, j}|| < epsilon, the norm of its intensity
//! (2-norm over channels) times the norm of its image (the 2-norm of column j of the projected transfer
//! matrix, over all rows and channels: `column_norms`). epsilon = 0 keeps every light.
use crate::error::{Error, Result};

/// A sparse row of wavelet coefficients: sorted coefficient indices and `channels` values per index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SparseRow {
    pub index: Vec<u32>,
    pub value: Vec<f32>,
}

/// Checks an image buffer: `side` a power of 2 (>= 1), `channels` >= 1, `data.len() == side^2 channels`.
pub fn check_image(len: usize, side: usize, channels: usize) -> Result<()> {
    if side == 0 || !side.is_power_of_two() {
        return Err(Error::invalid(format!("the Haar transform needs a 2^k x 2^k image, got side {side}")));
    }
    if channels == 0 {
        return Err(Error::invalid("the image needs at least one channel"));
    }
    match side.checked_mul(side).and_then(|s| s.checked_mul(channels)) {
        Some(n) if n == len => Ok(()),
        _ => Err(Error::invalid(format!(
            "a {side} x {side} image of {channels} channels has {} values, got {len}",
            side as u128 * side as u128 * channels as u128
        ))),
    }
}

/// Forward non-standard orthonormal 2D Haar transform, in place (module docs).
pub fn forward(data: &mut [f32], side: usize, channels: usize) -> Result<()> {
    check_image(data.len(), side, channels)?;
    let mut tmp = vec![0.0f32; data.len()];
    let mut s = side;
    while s > 1 {
        let h = s / 2;
        for r in 0..h {
            for c in 0..h {
                for ch in 0..channels {
                    let at = |rr: usize, cc: usize| data[(rr * side + cc) * channels + ch];
                    let (a, b) = (at(2 * r, 2 * c), at(2 * r, 2 * c + 1));
                    let (cl, d) = (at(2 * r + 1, 2 * c), at(2 * r + 1, 2 * c + 1));
                    tmp[(r * side + c) * channels + ch] = 0.5 * ((a + b) + (cl + d));
                    tmp[(r * side + c + h) * channels + ch] = 0.5 * ((a - b) + (cl - d));
                    tmp[((r + h) * side + c) * channels + ch] = 0.5 * ((a + b) - (cl + d));
                    tmp[((r + h) * side + c + h) * channels + ch] = 0.5 * ((a - b) - (cl - d));
                }
            }
        }
        for r in 0..s {
            let row = r * side * channels;
            data[row..row + s * channels].copy_from_slice(&tmp[row..row + s * channels]);
        }
        s = h;
    }
    Ok(())
}

/// Inverse of `forward`, in place.
pub fn inverse(data: &mut [f32], side: usize, channels: usize) -> Result<()> {
    check_image(data.len(), side, channels)?;
    let mut tmp = vec![0.0f32; data.len()];
    let mut s = 2;
    while s <= side {
        let h = s / 2;
        for r in 0..h {
            for c in 0..h {
                for ch in 0..channels {
                    let at = |rr: usize, cc: usize| data[(rr * side + cc) * channels + ch];
                    let (av, ho) = (at(r, c), at(r, c + h));
                    let (ve, di) = (at(r + h, c), at(r + h, c + h));
                    tmp[(2 * r * side + 2 * c) * channels + ch] = 0.5 * ((av + ve) + (ho + di));
                    tmp[(2 * r * side + 2 * c + 1) * channels + ch] = 0.5 * ((av + ve) - (ho + di));
                    tmp[((2 * r + 1) * side + 2 * c) * channels + ch] = 0.5 * ((av - ve) + (ho - di));
                    tmp[((2 * r + 1) * side + 2 * c + 1) * channels + ch] = 0.5 * ((av - ve) - (ho - di));
                }
            }
        }
        for r in 0..s {
            let row = r * side * channels;
            data[row..row + s * channels].copy_from_slice(&tmp[row..row + s * channels]);
        }
        s *= 2;
    }
    Ok(())
}

/// Number of pixels in the support of the basis function of coefficient `index` (row-major) of a
/// `side` x `side` transform (module docs).
pub fn support_area(index: usize, side: usize) -> usize {
    let (r, c) = (index / side, index % side);
    let m = r.max(c);
    if m == 0 {
        return side * side;
    }
    let level = usize::BITS - 1 - m.leading_zeros();
    let block = side >> level;
    block * block
}

/// 2-norm of entry `i` (its `channels` values).
fn norm(values: &[f32], i: usize, channels: usize) -> f64 {
    values[i * channels..(i + 1) * channels].iter().map(|&v| (v as f64) * (v as f64)).sum::<f64>().sqrt()
}

/// Keeps the `keep` coefficients of a wavelet-projected row (a `side` x `side` image of `channels`) of
/// highest area-weighted magnitude (module docs, Sec. 4.3).
pub fn cull_area_weighted(coeffs: &[f32], side: usize, channels: usize, keep: usize) -> Result<SparseRow> {
    check_image(coeffs.len(), side, channels)?;
    let n = side * side;
    let importance: Vec<f64> = (0..n).map(|i| norm(coeffs, i, channels) * support_area(i, side) as f64).collect();
    if let Some(i) = importance.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(format!("wavelet coefficient {i} is not finite")));
    }
    let mut candidates: Vec<u32> = (0..n as u32).filter(|&i| importance[i as usize] > 0.0).collect();
    if keep < candidates.len() {
        let by_importance = |a: &u32, b: &u32| importance[*b as usize].total_cmp(&importance[*a as usize]).then(a.cmp(b));
        if keep == 0 {
            candidates.clear();
        } else {
            candidates.select_nth_unstable_by(keep - 1, by_importance);
            candidates.truncate(keep);
        }
    }
    candidates.sort_unstable();
    let mut value = Vec::with_capacity(candidates.len() * channels);
    for &i in &candidates {
        value.extend_from_slice(&coeffs[i as usize * channels..(i as usize + 1) * channels]);
    }
    Ok(SparseRow { index: candidates, value })
}

/// The 2-norm of every column (over rows and channels) of a matrix of sparse rows with `n` columns:
/// the norms of the wavelet lights' images (Sec. 3.5).
///
/// Errors: `InvalidParameter` for an index >= n or rows whose value count is not `channels` per index.
pub fn column_norms(rows: &[SparseRow], n: usize, channels: usize) -> Result<Vec<f32>> {
    let mut sum = vec![0.0f64; n];
    for (r, row) in rows.iter().enumerate() {
        if row.value.len() != row.index.len() * channels {
            return Err(Error::invalid(format!(
                "row {r}: {} values for {} indices of {channels} channels",
                row.value.len(),
                row.index.len()
            )));
        }
        for (k, &j) in row.index.iter().enumerate() {
            let j = j as usize;
            if j >= n {
                return Err(Error::invalid(format!("row {r}: column {j} out of range (n = {n})")));
            }
            sum[j] += norm(&row.value, k, channels).powi(2);
        }
    }
    Ok(sum.into_iter().map(|s| s.sqrt() as f32).collect())
}

/// The wavelet lights that survive transport-weighted culling (Sec. 3.5): the indices j (ascending) with
/// |light_j| * image_norms[j] >= epsilon, `light` holding `channels` values per light.
///
/// Errors: `InvalidParameter` for mismatched lengths, a negative or non-finite epsilon, non-finite
/// values or negative norms.
pub fn cull_wavelet_lights(light: &[f32], channels: usize, image_norms: &[f32], epsilon: f32) -> Result<Vec<u32>> {
    if channels == 0 || light.len() != image_norms.len() * channels {
        return Err(Error::invalid(format!(
            "{} light values for {} image norms of {channels} channels each",
            light.len(),
            image_norms.len()
        )));
    }
    if !(epsilon >= 0.0 && epsilon.is_finite()) {
        return Err(Error::invalid(format!("epsilon must be finite and >= 0, got {epsilon}")));
    }
    if let Some(j) = (0..image_norms.len()).find(|&j| !(image_norms[j] >= 0.0 && image_norms[j].is_finite())) {
        return Err(Error::invalid(format!("image norm {j} must be finite and >= 0, got {}", image_norms[j])));
    }
    if let Some(k) = light.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(format!("wavelet light {} has a non-finite value {}", k / channels, light[k])));
    }
    Ok((0..image_norms.len() as u32)
        .filter(|&j| norm(light, j as usize, channels) * image_norms[j as usize] as f64 >= epsilon as f64)
        .collect())
}

#[cfg(test)]
mod tests;
