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
fn add_frame(acc: &mut [f32], m: usize, k: usize, idx: &[u32], group: &[usize], columns: &[f32], scale: &(dyn Fn(usize) -> [f32; 3] + Sync)) {
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
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// The definition, step by step: carry each representative's image through the mappings frame by frame
    /// (materialising mapped images) and add its scaled copy where Rec is nonzero.
    fn naive(f: usize, m: usize, columns: &[f32], source: &[u32], rec: &[f32], fw: &[Vec<u32>], bw: &[Vec<u32>]) -> Vec<f32> {
        let mut acc = vec![0f32; f * m * 3];
        let c = source.len();
        let mut order: Vec<usize> = (0..c).collect();
        order.sort_by_key(|&r| source[r]);
        // Per frame, the terms in the implementation's order: groups by k0, input order within.
        for k in 0..f {
            for &r in &order {
                let k0 = source[r] as usize;
                let s = &rec[(r * f + k) * 3..(r * f + k) * 3 + 3];
                if s == [0.0; 3] {
                    continue;
                }
                let mut img: Vec<Option<[f32; 3]>> =
                    (0..m).map(|i| Some([columns[(r * m + i) * 3], columns[(r * m + i) * 3 + 1], columns[(r * m + i) * 3 + 2]])).collect();
                let mut q = k0;
                while q != k {
                    let (map, nq) = if k > q { (&fw[q], q + 1) } else { (&bw[q - 1], q - 1) };
                    img = map.iter().map(|&s| if s == NO_SOURCE { None } else { img[s as usize] }).collect();
                    q = nq;
                }
                for i in 0..m {
                    if let Some(v) = img[i] {
                        for ch in 0..3 {
                            acc[(k * m + i) * 3 + ch] += s[ch] * v[ch];
                        }
                    }
                }
            }
        }
        acc
    }

    fn refs(v: &[Vec<u32>]) -> Vec<&[u32]> {
        v.iter().map(|x| x.as_slice()).collect()
    }

    #[test]
    fn matches_the_definition_on_random_mappings() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let (f, m, c) = (6, 3000, 9);
        let columns: Vec<f32> = (0..c * m * 3).map(|_| rng.random::<f32>()).collect();
        let source: Vec<u32> = (0..c).map(|r| (r * 5 % f) as u32).collect();
        // Each representative serves a contiguous frame range around its frame (zero elsewhere).
        let mut rec = vec![0f32; c * f * 3];
        for r in 0..c {
            let k0 = source[r] as usize;
            let (lo, hi) = (k0.saturating_sub(r % 3), (k0 + r % 4).min(f - 1));
            for k in lo..=hi {
                for ch in 0..3 {
                    rec[(r * f + k) * 3 + ch] = 0.5 + rng.random::<f32>();
                }
            }
        }
        let map = |rng: &mut rand_pcg::Pcg32| -> Vec<u32> {
            (0..m).map(|_| if rng.random::<f32>() < 0.05 { NO_SOURCE } else { rng.random_range(0..m as u32) }).collect()
        };
        let fw: Vec<Vec<u32>> = (0..f - 1).map(|_| map(&mut rng)).collect();
        let bw: Vec<Vec<u32>> = (0..f - 1).map(|_| map(&mut rng)).collect();
        let mut acc = vec![0f32; f * m * 3];
        accumulate(&mut acc, f, m, &columns, &source, &rec, &refs(&fw), &refs(&bw)).unwrap();
        let want = naive(f, m, &columns, &source, &rec, &fw, &bw);
        assert_eq!(acc, want);
        // Accumulating in two batches gives the same sums when the batches split by source frame.
        let mut acc2 = vec![0f32; f * m * 3];
        let (a, b): (Vec<usize>, Vec<usize>) = (0..c).partition(|&r| source[r] < 3);
        for part in [a, b] {
            let cols: Vec<f32> = part.iter().flat_map(|&r| columns[r * m * 3..(r + 1) * m * 3].to_vec()).collect();
            let src: Vec<u32> = part.iter().map(|&r| source[r]).collect();
            let rc: Vec<f32> = part.iter().flat_map(|&r| rec[r * f * 3..(r + 1) * f * 3].to_vec()).collect();
            accumulate(&mut acc2, f, m, &cols, &src, &rc, &refs(&fw), &refs(&bw)).unwrap();
        }
        assert_eq!(acc2, want);
    }

    #[test]
    fn identity_mappings_sum_scaled_columns() {
        let (f, m) = (3, 4);
        let id: Vec<Vec<u32>> = vec![(0..m as u32).collect(); f - 1];
        let columns: Vec<f32> = (0..2 * m * 3).map(|x| x as f32).collect();
        let source = [1u32, 2];
        let mut rec = vec![0f32; 2 * f * 3];
        rec[..9].copy_from_slice(&[1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0]); // rep 0: frames 0, 1
        rec[9..].copy_from_slice(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0]); // rep 1: frame 2
        let mut acc = vec![0f32; f * m * 3];
        accumulate(&mut acc, f, m, &columns, &source, &rec, &refs(&id), &refs(&id)).unwrap();
        for i in 0..m * 3 {
            assert_eq!(acc[i], columns[i]);
            assert_eq!(acc[m * 3 + i], 2.0 * columns[i]);
            assert_eq!(acc[2 * m * 3 + i], 3.0 * columns[m * 3 + i]);
        }
    }

    #[test]
    fn a_shift_moves_the_image() {
        // Frame k+1 is frame k shifted right by one pixel (1D image of m pixels).
        let (f, m) = (3, 5);
        let fw: Vec<Vec<u32>> = vec![(0..m as u32).map(|i| if i == 0 { NO_SOURCE } else { i - 1 }).collect(); f - 1];
        let bw: Vec<Vec<u32>> = vec![(0..m as u32).map(|i| if i + 1 == m as u32 { NO_SOURCE } else { i + 1 }).collect(); f - 1];
        let columns: Vec<f32> = (0..m).flat_map(|i| [i as f32 + 1.0; 3]).collect();
        let rec = vec![1f32; f * 3];
        let mut acc = vec![0f32; f * m * 3];
        accumulate(&mut acc, f, m, &columns, &[1], &rec, &refs(&fw), &refs(&bw)).unwrap();
        let red = |k: usize| -> Vec<f32> { (0..m).map(|i| acc[(k * m + i) * 3]).collect() };
        assert_eq!(red(1), vec![1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(red(2), vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(red(0), vec![2.0, 3.0, 4.0, 5.0, 0.0]);
    }

    #[test]
    fn bad_input_is_named() {
        let id = vec![vec![0u32, 1]];
        let mut acc = vec![0f32; 2 * 2 * 3];
        let cols = vec![0f32; 6];
        let e = accumulate(&mut acc, 2, 2, &cols, &[2], &[0.0; 6], &refs(&id), &refs(&id)).unwrap_err();
        assert!(e.to_string().contains("representative 0 is in frame 2"), "{e}");
        let bad = vec![vec![0u32, 7]];
        let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 6], &refs(&bad), &refs(&id)).unwrap_err();
        assert!(e.to_string().contains("forward mapping 0: pixel 1 maps to 7"), "{e}");
        let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 3], &refs(&id), &refs(&id)).unwrap_err();
        assert!(e.to_string().contains("Rec has 3 floats"), "{e}");
        let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 6], &[], &[]).unwrap_err();
        assert!(e.to_string().contains("0 forward and 0 backward mappings for 2 frames"), "{e}");
    }
}
