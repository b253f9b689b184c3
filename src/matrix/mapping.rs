//! Pixel mappings between frames (Hašan, Velázquez-Armendáriz, Pellacini, Bala, "Tensor Clustering for
//! Rendering Many-Light Animations", EGSR 2008, Sec. 4.4 and 5).
//!
//! The mapping M(k -> l) gives, for each pixel of frame l, its nearest neighbour among the pixels of
//! frame k in the 9-D deep framebuffer (`crate::view::features`: position, normal, albedo, scaled). As a
//! sparse m x m matrix it has one 1 per row, so `M(k -> l) x` is an image rendered in frame k moved into
//! frame l: we store it as an index array, `source[i]` = the pixel of frame k whose value pixel i of
//! frame l takes, and apply it as a gather (CPU: [`PixelMapping::apply`], rayon; GPU:
//! `crate::gpu::mapping`, `shaders/mapping.wgsl`, on GPU-resident images). Chains
//! `M(k+1 -> k+2) M(k -> k+1)` compose into one index array ([`PixelMapping::then`]); applying the
//! composition equals applying the chain, exactly.
//!
//! Nearest neighbours come from a kd-tree (`kiddo::ImmutableKdTree`, squared Euclidean distance) over
//! frame k's surface pixels, queried in parallel. Ties at distance 0 prefer the same pixel index, so a
//! static scene maps every surface pixel to itself exactly.
//!
//! Pixels without a surface (the centre sees the background): they are left out of the tree (nothing
//! maps from them) and map to [`NO_SOURCE`] (they take the value 0: a column of the light matrix is 0
//! there; what the camera sees directly is added per frame, not mapped). A frame without any surface
//! pixel maps every pixel to `NO_SOURCE`.
//!
//! Chains, not direct mappings, and nearest neighbours, not interpolation, as the paper: measured on the
//! bundled animation (8 frames, 48x48, moving camera, `scripts/tensor_flicker_decomposition.py`), one
//! direct nearest-neighbour mapping from the representative's frame gives the same tensor-clustering
//! flicker as the chain (0.0126), and bilinear taps on the same surface 0.0125: what the mappings cannot
//! carry is the moving box's shadow, not the resampling (docs/validation/animations.md).
//!
//! Symbols: m = pixels per frame, `source` = the index array (one `u32` per pixel of the destination).
use crate::error::{Error, Result};
use crate::view::features::{DeepFeatures, DIM};
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

/// The index of a destination pixel that takes no value (0).
pub const NO_SOURCE: u32 = u32::MAX;

/// Leaf bucket size of the kd-tree (kiddo's default).
const BUCKET: usize = 32;

/// M(k -> l) as an index array over the pixels of frame l (module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PixelMapping {
    pub width: u32,
    pub height: u32,
    /// Per destination pixel (`y * width + x`): a source pixel index, or `NO_SOURCE`.
    pub source: Vec<u32>,
}

impl PixelMapping {
    /// M(k -> k): every pixel maps to itself (background included).
    pub fn identity(width: u32, height: u32) -> PixelMapping {
        PixelMapping { width, height, source: (0..width * height).collect() }
    }

    /// Pixels per frame.
    pub fn num_pixels(&self) -> usize {
        self.source.len()
    }

    /// The nearest-neighbour mapping from the pixels of `src` (frame k) to those of `dst` (frame l).
    ///
    /// Errors: `InvalidParameter` when the two deep framebuffers differ in size.
    pub fn nearest(src: &DeepFeatures, dst: &DeepFeatures) -> Result<PixelMapping> {
        if (src.width, src.height) != (dst.width, dst.height) {
            return Err(Error::invalid(format!(
                "pixel mapping: frames differ in size ({}x{} vs {}x{})",
                src.width, src.height, dst.width, dst.height
            )));
        }
        let pixels: Vec<u32> = (0..src.num_pixels() as u32).filter(|&i| src.valid[i as usize]).collect();
        let mut source = vec![NO_SOURCE; dst.num_pixels()];
        if pixels.is_empty() {
            return Ok(PixelMapping { width: dst.width, height: dst.height, source });
        }
        let points: Vec<[f32; DIM]> = pixels.iter().map(|&i| src.features[i as usize]).collect();
        let tree: ImmutableKdTree<f32, u32, DIM, BUCKET> = ImmutableKdTree::new_from_slice(&points);
        source.par_iter_mut().enumerate().for_each(|(i, s)| {
            if !dst.valid[i] {
                return;
            }
            let q = &dst.features[i];
            // Distance 0 to the same pixel: that pixel (exact identity on static frames).
            if src.valid[i] && src.features[i] == *q {
                *s = i as u32;
                return;
            }
            let nn = tree.nearest_one::<SquaredEuclidean>(q);
            *s = pixels[nn.item as usize];
        });
        Ok(PixelMapping { width: dst.width, height: dst.height, source })
    }

    /// `self` (k -> l) followed by `next` (l -> q): the mapping k -> q, `result[i] = self[next[i]]`.
    ///
    /// Errors: `InvalidParameter` for different sizes.
    pub fn then(&self, next: &PixelMapping) -> Result<PixelMapping> {
        if (self.width, self.height) != (next.width, next.height) {
            return Err(Error::invalid(format!(
                "composing pixel mappings of different sizes ({}x{} then {}x{})",
                self.width, self.height, next.width, next.height
            )));
        }
        let source = next.source.iter().map(|&j| if j == NO_SOURCE { NO_SOURCE } else { self.source[j as usize] }).collect();
        Ok(PixelMapping { width: self.width, height: self.height, source })
    }

    /// The chain `maps[0]`, then `maps[1]`, ... composed (identity of `width` x `height` for none).
    pub fn chain(width: u32, height: u32, maps: &[&PixelMapping]) -> Result<PixelMapping> {
        let mut out = PixelMapping::identity(width, height);
        for m in maps {
            out = out.then(m)?;
        }
        Ok(out)
    }

    /// Checks that every index is a pixel or `NO_SOURCE` (for index arrays from users).
    pub fn validate(&self) -> Result<()> {
        let m = self.num_pixels();
        if m != self.width as usize * self.height as usize {
            return Err(Error::invalid(format!("pixel mapping has {m} entries but {}x{} pixels", self.width, self.height)));
        }
        if let Some((i, &s)) = self.source.iter().enumerate().find(|(_, &s)| s != NO_SOURCE && s as usize >= m) {
            return Err(Error::invalid(format!(
                "pixel mapping entry {i} (x={}, y={}) is {s}, outside [0, {m}) (use -1 for no source)",
                i % self.width.max(1) as usize,
                i / self.width.max(1) as usize
            )));
        }
        Ok(())
    }

    /// `M x` for `images` of `channels` floats per pixel, several images back to back
    /// (`len = count * m * channels`): `out[i] = values[source[i]]`, 0 where `source[i] = NO_SOURCE`.
    /// Parallel over pixels (rayon).
    ///
    /// Errors: `InvalidParameter` when the length is not a multiple of `m * channels`.
    pub fn apply(&self, images: &[f32], channels: usize) -> Result<Vec<f32>> {
        let m = self.num_pixels();
        let frame = m * channels;
        if channels == 0 || frame == 0 || images.len() % frame != 0 {
            return Err(Error::invalid(format!(
                "apply_mapping: {} values are not whole images of {}x{} pixels x {channels} channels",
                images.len(),
                self.width,
                self.height
            )));
        }
        let mut out = vec![0.0f32; images.len()];
        out.par_chunks_mut(frame).zip(images.par_chunks(frame)).for_each(|(o, img)| {
            o.par_chunks_mut(channels).zip(self.source.par_iter()).for_each(|(px, &s)| {
                if s != NO_SOURCE {
                    let s = s as usize * channels;
                    px.copy_from_slice(&img[s..s + channels]);
                }
            });
        });
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
