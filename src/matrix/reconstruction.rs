//! Tensor clustering's final reconstruction (Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for
//! Rendering Many-Light Animations", EGSR 2008, Sec. 4.5): every cluster's representative column
//! A(:, j, k0), rendered once in its own frame k0, approximates the cluster's columns in every frame k it
//! serves: scaled by Rec(c, k) (per RGB channel) and carried from frame k0 to frame k through the chain of
//! pixel mappings M(k0 -> k0+1), ..., M(k-1 -> k) (backward mappings for k < k0). The animation is
//!
//!   frame_k(i) = sum_c Rec(c, k) * col_c(pi_{k0_c -> k}(i)),
//!
//! where pi_{k0 -> k} is the composed index map (pixel i of frame k takes the pixel of frame k0 that the
//! chain of nearest neighbours leads to). Composed maps depend only on (k0, k), so representatives are
//! grouped by their frame k0 and each composed map is built once per group while walking away from k0; a
//! group stops walking in a direction once none of its Rec entries beyond that frame is nonzero.
//!
//! Mappings are index arrays over view samples (pixels, row-major): `forward[k][i]` is the pixel of frame
//! k nearest to pixel i of frame k+1, `backward[k][i]` the pixel of frame k+1 nearest to pixel i of frame
//! k; `NO_SOURCE` marks a pixel with no source (it receives nothing through that step).
//!
//! Deterministic: every pixel sums its terms in one fixed order (groups by k0, representatives in input
//! order), whatever the number of threads. Parallel over pixel chunks of each target frame.
//!
//! Symbols: f frames, m pixels, c representatives in the batch, k0 a representative's frame, Rec the
//! c x f (RGB) reconstruction matrix.
use crate::error::{Error, Result};
use rayon::prelude::*;

/// A mapping entry for a pixel without a source pixel (the pixel mappings' own marker).
pub use super::mapping::NO_SOURCE;

/// Pixels per parallel task.
const CHUNK: usize = 1024;

/// Accumulates a batch of representative columns into `acc` (f frames x m pixels x RGB), module docs.
///
/// - `columns`: c x m x 3, representative c's column rendered in frame `source[c]`;
/// - `rec`: c x f x 3, the scale of representative c in every frame;
/// - `forward`, `backward`: f - 1 mappings of m entries each (or none for f = 1).
pub fn accumulate(
    acc: &mut [f32],
    frames: usize,
    pixels: usize,
    columns: &[f32],
    source: &[u32],
    rec: &[f32],
    forward: &[&[u32]],
    backward: &[&[u32]],
) -> Result<()> {
    let (f, m, c) = (frames, pixels, source.len());
    check(acc.len() == f * m * 3, || format!("accumulator has {} floats, expected f * m * 3 = {}", acc.len(), f * m * 3))?;
    check(columns.len() == c * m * 3, || format!("{} column floats for {c} representatives of {m} pixels", columns.len()))?;
    check_inputs(f, m, source, rec, forward, backward)?;
    let scale = |r: usize, k: usize| -> [f32; 3] {
        let s = &rec[(r * f + k) * 3..(r * f + k) * 3 + 3];
        [s[0], s[1], s[2]]
    };
    // Groups by source frame, representatives in input order within a group.
    let mut order: Vec<usize> = (0..c).collect();
    order.sort_by_key(|&r| source[r]);
    let identity: Vec<u32> = (0..m as u32).collect();
    let mut start = 0;
    while start < order.len() {
        let k0 = source[order[start]] as usize;
        let end = start + order[start..].iter().take_while(|&&r| source[r] as usize == k0).count();
        let group = &order[start..end];
        start = end;
        // Frame k0 itself, then walking forward, then backward.
        add_frame(acc, m, k0, &identity, group, columns, &|r| scale(r, k0));
        for dir in [1isize, -1] {
            let mut idx = identity.clone();
            let mut k = k0 as isize;
            loop {
                let next = k + dir;
                if next < 0 || next >= f as isize {
                    break;
                }
                let beyond = |r: &usize| {
                    if dir > 0 {
                        (next as usize..f).any(|q| scale(*r, q) != [0.0; 3])
                    } else {
                        (0..=next as usize).any(|q| scale(*r, q) != [0.0; 3])
                    }
                };
                if !group.iter().any(beyond) {
                    break;
                }
                // pi_{k0 -> next}(i) = pi_{k0 -> k}(step(i)), step the one-frame mapping into frame `next`.
                let step = if dir > 0 { forward[k as usize] } else { backward[next as usize] };
                idx = step.iter().map(|&s| if s == NO_SOURCE { NO_SOURCE } else { idx[s as usize] }).collect();
                let kn = next as usize;
                add_frame(acc, m, kn, &idx, group, columns, &|r| scale(r, kn));
                k = next;
            }
        }
    }
    Ok(())
}

/// acc[k](i) += sum over the group of scale(r) * column_r(idx(i)).
fn add_frame(
    acc: &mut [f32],
    m: usize,
    k: usize,
    idx: &[u32],
    group: &[usize],
    columns: &[f32],
    scale: &(dyn Fn(usize) -> [f32; 3] + Sync),
) {
    let active: Vec<(usize, [f32; 3])> = group.iter().map(|&r| (r, scale(r))).filter(|(_, s)| *s != [0.0; 3]).collect();
    if active.is_empty() {
        return;
    }
    acc[k * m * 3..(k + 1) * m * 3].par_chunks_mut(CHUNK * 3).enumerate().for_each(|(chunk, dst)| {
        for (e, px) in dst.chunks_exact_mut(3).enumerate() {
            let i = chunk * CHUNK + e;
            let src = idx[i];
            if src == NO_SOURCE {
                continue;
            }
            for &(r, s) in &active {
                let v = &columns[(r * m + src as usize) * 3..(r * m + src as usize) * 3 + 3];
                px[0] += s[0] * v[0];
                px[1] += s[1] * v[1];
                px[2] += s[2] * v[2];
            }
        }
    });
}

/// Checks what the CPU and GPU reconstructions share: Rec is c x f x 3, f - 1 forward and backward
/// mappings of m entries each with indices in [0, m) or `NO_SOURCE`, every source frame below f.
pub(crate) fn check_inputs(f: usize, m: usize, source: &[u32], rec: &[f32], forward: &[&[u32]], backward: &[&[u32]]) -> Result<()> {
    let c = source.len();
    check(rec.len() == c * f * 3, || format!("Rec has {} floats, expected c * f * 3 = {}", rec.len(), c * f * 3))?;
    let steps = f.saturating_sub(1);
    check(forward.len() == steps && backward.len() == steps, || {
        format!("{} forward and {} backward mappings for {f} frames, expected {steps} each", forward.len(), backward.len())
    })?;
    for (name, maps) in [("forward", forward), ("backward", backward)] {
        for (k, map) in maps.iter().enumerate() {
            check(map.len() == m, || format!("{name} mapping {k} has {} entries, expected m = {m}", map.len()))?;
            if let Some((i, &v)) = map.iter().enumerate().find(|(_, &v)| v != NO_SOURCE && v as usize >= m) {
                return Err(Error::invalid(format!("{name} mapping {k}: pixel {i} maps to {v}, outside [0, {m})")));
            }
        }
    }
    if let Some((r, &k0)) = source.iter().enumerate().find(|(_, &k)| k as usize >= f) {
        return Err(Error::invalid(format!("representative {r} is in frame {k0}, outside [0, {f})")));
    }
    Ok(())
}

fn check(ok: bool, msg: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(msg()))
    }
}

#[cfg(test)]
mod tests;
