//! The cluster hierarchy of the gather cloud and its flattening into the gather image (Hašan, Pellacini,
//! Bala, "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006, Sec. 3.4 and 4.2).
//!
//! A perfectly balanced quad-tree over n = 4^k samples: the root holds all of them, every cluster of
//! more than one sample has four children of equal size. It is built top-down by binary splits into two
//! equal halves, two binary levels per quad level. A split is the paper's modified 2-means: with two
//! centroids c_1, c_2, every sample s gets d(s, c_1) - d(s, c_2), the samples are sorted by it and the
//! first half becomes the first subset (closer to c_1), the second half the second; the centroids are
//! recomputed as the subsets' means and the two steps repeat until the partition stops changing (at most
//! `MAX_ITERATIONS`). The distance (Eq. 9) is
//!     d(s, c) = K^2 |p_s - p_c|^2 + D^2 |n_s - n_c|^2,
//! D the scene's bounding-box diagonal, K ~ 20-40 (`DEFAULT_K` = 30): a position difference of D / K
//! weighs as much as a unit normal difference. Since d(s, c_1) - d(s, c_2) = 2 f_s . (c_2 - c_1) + const
//! in the feature space f = (K p / D, n) (Eq. 9 divided by D^2, which keeps the order), the sort is a
//! sort of the projections on c_2 - c_1; a median selection replaces the full sort. Initial centroids:
//! the sample farthest from the subset's mean and the sample farthest from that one (ties: lowest
//! index), so the build is deterministic (no seed).
//!
//! The flattening (the gather image, side 2^k, row-major, row 0 at the top): the quad-tree path of a
//! leaf, q_1 ... q_k from the root (q_j in 0..4, q = 2 row_bit + col_bit), is its Morton code
//! m = sum_j q_j 4^(k - j); its pixel is row = sum_j row_bit_j 2^(k - j), col = sum_j col_bit_j 2^(k - j).
//! The first binary split of a cluster chooses the row bit (top half / bottom half of its block), the
//! second split of each half the column bit. So the cluster at depth j with Morton index c (0 <= c < 4^j)
//! is exactly the aligned block of side 2^(k - j) at (row, col) = morton_pixel(c) * 2^(k - j), and each
//! binary half is the top or bottom half of its block. `order[m]` is the sample at Morton code m;
//! `pixel[i]` = row * side + col of sample i; `sample_at_pixel` its inverse.
use crate::error::{Error, Result};
use glam::Vec3;

/// Eq. 9's position weight K when none is given.
pub const DEFAULT_K: f32 = 30.0;
/// Iterations of one modified 2-means split at most.
pub const MAX_ITERATIONS: usize = 64;
/// Subsets of at least this many samples split their halves in parallel (results do not depend on it).
const PARALLEL_MIN: usize = 4096;

/// The cluster hierarchy and gather-image index of a gather cloud (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterHierarchy {
    /// k: n = 4^k samples, a 2^k x 2^k gather image.
    pub levels: u32,
    /// Eq. 9's K.
    pub k_weight: f32,
    /// Sample at each Morton code (leaf order of the quad-tree).
    pub order: Vec<u32>,
    /// Gather-image pixel (row * side + col) of each sample.
    pub pixel: Vec<u32>,
    /// Sample at each pixel (inverse of `pixel`).
    pub sample_at_pixel: Vec<u32>,
}

/// (row, col) of Morton code m (even bits: column, odd bits: row).
pub fn morton_pixel(m: u64) -> (u32, u32) {
    let compact = |mut x: u64| {
        x &= 0x5555_5555_5555_5555;
        x = (x | (x >> 1)) & 0x3333_3333_3333_3333;
        x = (x | (x >> 2)) & 0x0f0f_0f0f_0f0f_0f0f;
        x = (x | (x >> 4)) & 0x00ff_00ff_00ff_00ff;
        x = (x | (x >> 8)) & 0x0000_ffff_0000_ffff;
        x = (x | (x >> 16)) & 0x0000_0000_ffff_ffff;
        x as u32
    };
    (compact(m >> 1), compact(m))
}

/// Morton code of (row, col): the inverse of `morton_pixel`.
pub fn pixel_morton(row: u32, col: u32) -> u64 {
    let spread = |v: u32| {
        let mut x = v as u64;
        x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
        x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
        x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        x = (x | (x << 2)) & 0x3333_3333_3333_3333;
        x = (x | (x << 1)) & 0x5555_5555_5555_5555;
        x
    };
    (spread(row) << 1) | spread(col)
}

type Feature = [f64; 6];

fn dist2(a: &Feature, b: &Feature) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn mean(set: &[u32], f: &[Feature]) -> Feature {
    let mut m = [0.0; 6];
    for &i in set {
        for (a, b) in m.iter_mut().zip(&f[i as usize]) {
            *a += b;
        }
    }
    m.map(|v| v / set.len().max(1) as f64)
}

/// The feature of `set` farthest from `c` (ties: lowest sample index).
fn farthest(set: &[u32], f: &[Feature], c: &Feature) -> Feature {
    let mut best = (f64::NEG_INFINITY, u32::MAX);
    for &i in set {
        let d = dist2(&f[i as usize], c);
        if d > best.0 || (d == best.0 && i < best.1) {
            best = (d, i);
        }
    }
    f[best.1 as usize]
}

/// Reorders `set` so that its first half is the first subset of the modified 2-means split.
fn split(set: &mut [u32], f: &[Feature]) {
    let half = set.len() / 2;
    let m = mean(set, f);
    let mut c1 = farthest(set, f, &m);
    let mut c2 = farthest(set, f, &c1);
    let mut previous: Option<Vec<u32>> = None;
    for _ in 0..MAX_ITERATIONS {
        let dir: Feature = std::array::from_fn(|a| c2[a] - c1[a]);
        let key = |i: u32| f[i as usize].iter().zip(&dir).map(|(x, d)| x * d).sum::<f64>();
        // Median selection by (key, index): a total order, so the halves are deterministic.
        set.select_nth_unstable_by(half, |&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        let mut first = set[..half].to_vec();
        first.sort_unstable();
        if previous.as_ref() == Some(&first) {
            break;
        }
        c1 = mean(&set[..half], f);
        c2 = mean(&set[half..], f);
        previous = Some(first);
    }
}

/// Splits `set` recursively down to single samples (the whole tree below it, in Morton order).
fn build(set: &mut [u32], f: &[Feature]) {
    if set.len() <= 1 {
        return;
    }
    split(set, f);
    let (a, b) = set.split_at_mut(set.len() / 2);
    if a.len() >= PARALLEL_MIN {
        rayon::join(|| build(a, f), || build(b, f));
    } else {
        build(a, f);
        build(b, f);
    }
}

impl ClusterHierarchy {
    /// Builds the hierarchy of n = 4^k samples (module docs): `positions` and unit `normals` (n each),
    /// `diagonal` the scene's bounding-box diagonal (> 0), `k_weight` Eq. 9's K (> 0).
    ///
    /// Errors: `InvalidParameter` for n not a power of 4, mismatched lengths, a K or diagonal that is not
    /// finite and > 0, or non-finite positions / normals (the sample is named).
    pub fn build(positions: &[Vec3], normals: &[Vec3], diagonal: f32, k_weight: f32) -> Result<ClusterHierarchy> {
        let n = positions.len();
        let levels = crate::lights::gather::gather_levels(n)?;
        if normals.len() != n {
            return Err(Error::invalid(format!("{n} positions but {} normals", normals.len())));
        }
        if !(k_weight > 0.0 && k_weight.is_finite()) {
            return Err(Error::invalid(format!("K (Eq. 9's position weight) must be finite and > 0, got {k_weight}")));
        }
        if !(diagonal > 0.0 && diagonal.is_finite()) {
            return Err(Error::invalid(format!("the scene diagonal must be finite and > 0, got {diagonal}")));
        }
        if let Some(i) = (0..n).find(|&i| !positions[i].is_finite() || !normals[i].is_finite()) {
            return Err(Error::invalid(format!("gather sample {i} has a non-finite position {} or normal {}", positions[i], normals[i])));
        }
        let scale = (k_weight / diagonal) as f64;
        let f: Vec<Feature> = positions
            .iter()
            .zip(normals)
            .map(|(p, nn)| {
                let p = p.as_dvec3() * scale;
                let nn = nn.as_dvec3();
                [p.x, p.y, p.z, nn.x, nn.y, nn.z]
            })
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        build(&mut order, &f);
        let side = 1u32 << levels;
        let mut pixel = vec![0u32; n];
        let mut sample_at_pixel = vec![0u32; n];
        for (m, &i) in order.iter().enumerate() {
            let (r, c) = morton_pixel(m as u64);
            let px = r * side + c;
            pixel[i as usize] = px;
            sample_at_pixel[px as usize] = i;
        }
        Ok(ClusterHierarchy { levels, k_weight, order, pixel, sample_at_pixel })
    }

    /// Builds the hierarchy of a gather cloud with the diagonal of the scene it was evaluated on.
    pub fn of_cloud(cloud: &crate::lights::gather::GatherCloud, k_weight: f32) -> Result<ClusterHierarchy> {
        ClusterHierarchy::build(&cloud.position, &cloud.normal, cloud.diagonal, k_weight)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Side of the gather image (2^k).
    pub fn side(&self) -> usize {
        1 << self.levels
    }

    /// Samples of the cluster at `depth` (0 = root, `levels` = leaves) with Morton index `c`
    /// (0 <= c < 4^depth); it is the image block of side 2^(levels - depth) at
    /// `morton_pixel(c) * 2^(levels - depth)`.
    pub fn cluster(&self, depth: u32, c: usize) -> &[u32] {
        let size = 1usize << (2 * (self.levels - depth.min(self.levels)));
        &self.order[c * size..(c + 1) * size]
    }

    /// Per-sample values (n entries of `channels` each) laid out as the gather image (row-major).
    pub fn to_image<T: Copy>(&self, values: &[T], channels: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(values.len());
        for &i in &self.sample_at_pixel {
            out.extend_from_slice(&values[i as usize * channels..(i as usize + 1) * channels]);
        }
        out
    }

    /// The inverse of `to_image`: per-sample values from a gather image.
    pub fn from_image<T: Copy>(&self, image: &[T], channels: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(image.len());
        for &px in &self.pixel {
            out.extend_from_slice(&image[px as usize * channels..(px as usize + 1) * channels]);
        }
        out
    }

    /// Axis-aligned bounds (min, max) of the positions of every cluster at `depth`, in Morton order.
    pub fn cluster_bounds(&self, depth: u32, positions: &[Vec3]) -> Vec<(Vec3, Vec3)> {
        let depth = depth.min(self.levels);
        (0..1usize << (2 * depth))
            .map(|c| {
                self.cluster(depth, c).iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), &i| {
                    (lo.min(positions[i as usize]), hi.max(positions[i as usize]))
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests;
