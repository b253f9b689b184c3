//! The scalar reduced columns of one chunk of frames, stored light-frame-pair-major so that a reduced
//! column `R(:, j, k)` and a light's slab `R(:, j, K)` are contiguous, with the weights `w_p` and the
//! per-channel norms of every pair (Sec. 4.3.1, Sec. 5).
use super::ReducedTensor;
use crate::cluster::columns::ScalarColumns;
use rayon::prelude::*;

/// Lights per parallel block of [`ChunkStore::build`].
const LIGHT_BLOCK: usize = 64;

pub(crate) struct ChunkStore {
    pub num_rows: usize,
    pub num_lights: usize,
    pub num_frames: usize,
    /// Global index of the chunk's first frame.
    pub first_frame: usize,
    /// `scalar[(j * fc + kk) * r + i]` = 2-norm of the RGB element (i, j, first_frame + kk).
    scalar: Vec<f32>,
    /// `weight[j * fc + kk]` = w_p = |R(:, j, k)| (f64 sum of the f32 scalars squared).
    weight: Vec<f64>,
    /// Per-channel 2-norms of the reduced column of every pair.
    channel_norm: Vec<[f64; 3]>,
}

impl ChunkStore {
    /// Frames [start, end) of `tensor`.
    pub fn build(tensor: &ReducedTensor, start: usize, end: usize) -> Self {
        let (r, n, fc) = (tensor.num_rows(), tensor.num_lights(), end - start);
        let mut scalar = vec![0.0f32; n * fc * r];
        let mut squares = vec![[0.0f64; 4]; n * fc];
        let one_channel = tensor.channels() == 1;
        scalar.par_chunks_mut(LIGHT_BLOCK * fc * r).zip(squares.par_chunks_mut(LIGHT_BLOCK * fc)).enumerate().for_each(|(b, (out, sq))| {
            let j0 = b * LIGHT_BLOCK;
            let lights = sq.len() / fc;
            let mut element = |i: usize, jj: usize, kk: usize| {
                let c: [f64; 3] = std::array::from_fn(|ch| tensor.channel(i, j0 + jj, start + kk, ch));
                let s = if one_channel { c[0] } else { (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() };
                let s32 = s as f32;
                out[(jj * fc + kk) * r + i] = s32;
                let acc = &mut sq[jj * fc + kk];
                for ch in 0..3 {
                    acc[ch] += c[ch] * c[ch];
                }
                acc[3] += (s32 as f64) * (s32 as f64);
            };
            // Read the tensor in its memory order (lights innermost for frame-major data, frames innermost
            // otherwise); every pair's sums still run over the rows in order, so both layouts give
            // bit-identical stores.
            if tensor.is_frame_major() {
                for kk in 0..fc {
                    for i in 0..r {
                        for jj in 0..lights {
                            element(i, jj, kk);
                        }
                    }
                }
            } else {
                for i in 0..r {
                    for jj in 0..lights {
                        for kk in 0..fc {
                            element(i, jj, kk);
                        }
                    }
                }
            }
        });
        let weight = squares.iter().map(|s| s[3].sqrt()).collect();
        let channel_norm = squares.iter().map(|s| [s[0].sqrt(), s[1].sqrt(), s[2].sqrt()]).collect();
        ChunkStore { num_rows: r, num_lights: n, num_frames: fc, first_frame: start, scalar, weight, channel_norm }
    }

    /// The scalar reduced column of pair (j, kk) (kk local to the chunk).
    #[inline]
    pub fn column(&self, j: usize, kk: usize) -> &[f32] {
        let at = (j * self.num_frames + kk) * self.num_rows;
        &self.scalar[at..at + self.num_rows]
    }
    #[inline]
    pub fn weight(&self, j: usize, kk: usize) -> f64 {
        self.weight[j * self.num_frames + kk]
    }
    #[inline]
    pub fn channel_norm(&self, j: usize, kk: usize) -> [f64; 3] {
        self.channel_norm[j * self.num_frames + kk]
    }
    /// Total weight of light j over the chunk's frames.
    pub fn slab_weight(&self, j: usize) -> f64 {
        self.weight[j * self.num_frames..(j + 1) * self.num_frames].iter().sum()
    }
    /// The slabs as the columns of `reshape(permute(R, 1, 3, 2), r f, n)` (row `kk * r + i`).
    pub fn slabs(&self) -> Slabs<'_> {
        Slabs(self)
    }
}

pub(crate) struct Slabs<'a>(&'a ChunkStore);

impl ScalarColumns for Slabs<'_> {
    fn num_rows(&self) -> usize {
        self.0.num_rows * self.0.num_frames
    }
    #[inline]
    fn scalar(&self, row: usize, column: usize) -> f64 {
        let s = self.0;
        s.scalar[column * s.num_frames * s.num_rows + row] as f64
    }
}

#[cfg(test)]
mod tests;
