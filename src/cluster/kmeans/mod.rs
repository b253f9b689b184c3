//! K-means clustering of surface data points (position, normal) for clustered visibility:
//! the GPU K-means and the distance-based fuzzy clustering of
//! "GPU-based fuzzy K-means clustering of VPLs and shading points" (Sec. 3.2-3.3, Eq. 7-10,
//! Alg. 1-2; Computers & Graphics, 2022).
//! The GPU version ([`kmeans_gpu`], wgpu passes in `crate::gpu::kmeans`, `shaders/kmeans.wgsl`) is the
//! product; [`kmeans_cpu`] is its reference twin (same initialisation, same order of candidates, same
//! fixed-point centroid sums), used by tests and by `device="cpu"`.
//!
//! # What is implemented
//! - Eq. 7: `dist(d1, d2) = |p1 - p2|` if `n1 . n2 > nt`, else infinite; `nt` = [`KMeansParams::cos_threshold`]
//!   (default cos 30 deg = sqrt(3)/2, the paper's value; `None` = plain Euclidean K-means). Candidates are
//!   ordered by the key (inadmissible, squared distance, index), so equal distances go to the lower index.
//! - Alg. 1: initial centroids = K distinct data points drawn uniformly with the seed (the paper: "a subset
//!   of K points of D is selected as initial centroids ... often random"); then per iteration the assignment
//!   step (nearest centroid by Eq. 7) and the reduction step (centroid position = mean of its points'
//!   positions, centroid normal = normalised mean of their normals, summed with atomic adds), for a fixed
//!   number of iterations ([`KMeansParams::tolerance`] = 0) or until the objective stops falling by more than
//!   `tolerance` relatively.
//! - Alg. 1 line 5: a regular grid over the centroids, built on the GPU every iteration (count, prefix sum,
//!   fill), accelerates the assignment. Deviation: the paper searches the 27 cells around a point, which
//!   can miss the nearest centroid; we search expanding shells of cells (shells 0 and 1 are the 27 cells)
//!   until no unvisited cell can hold a closer centroid, so the grid result equals the exhaustive one
//!   (tested). A point whose search would exceed a loop budget (Mesa 22.3 cuts shader loops at 65,535
//!   iterations) is finished by exhaustive passes over chunks of 2048 centroids.
//! - Alg. 1 line 1: [`downsample_indices`] (one seeded random sample per block of gamma consecutive
//!   data points) and [`cluster_view_samples`] (K-means on the subset, then Alg. 2 on every view sample).
//! - Sec. 3.2.2 / Alg. 2 / Eq. 10: the F nearest clusters and inverse-distance weights ([`fuzzy`]).
//!
//! # Choices where the paper is silent
//! - A point with no admissible centroid (its normal differs from every centroid normal by more than the
//!   threshold: all Eq. 7 distances infinite) is assigned to the nearest centroid by position alone (the
//!   order key puts inadmissible candidates after admissible ones, then by distance). It contributes its
//!   Euclidean squared distance to the objective. The paper does not say what happens to such points.
//! - An empty cluster keeps its centroid; members whose normals cancel keep the previous centroid normal.
//! - The objective is `sum_i |p_i - c(i)|^2` with c(i) the point's assigned centroid (squared Euclidean,
//!   as scikit-learn's `inertia_`). `objective[t]` is the cost of the centroids after t updates with every
//!   point at its nearest centroid, t = 0..=iterations (so it has `iterations + 1` entries). With the
//!   threshold off it never rises; with it on, a centroid normal that moves can make a member inadmissible
//!   and the objective can rise.
//! - The paper leaves the downsampling factor gamma unspecified; [`DEFAULT_DOWNSAMPLING`] = 4 is ours.
//!
//! # Precision of the reduction (atomics on u32 only in WGSL)
//! Each coordinate is quantised to `round(2^24 (x - lo) / extent)` over the data's bounding box
//! (positions) or over [-1, 1] (normals): a step of 2^-24 of the box size, about f32's own resolution at
//! that scale. The quantised values are summed exactly in 64 bits (two u32 words with an atomic carry),
//! so the sums do not depend on the order of the atomics. The GPU converts a 64-bit sum to f32 before
//! dividing (relative error ~1e-7 of the mean, i.e. a few quantisation steps at most); the CPU divides in
//! f64. CPU and GPU centroids therefore agree to a few 2^-24 of the bounding box, not bit for bit; two GPU
//! runs (grid or not) agree bit for bit. The objective adds per-workgroup f32 partial sums (256 points) in f64.
//!
//! # Symbols
//! | paper | here |
//! |---|---|
//! | D, d_m = (p, n), M | `points`, `normals`, `points.len()` |
//! | K, C = {c_k} | [`KMeansParams::k`], [`KMeansResult::centroids`] / `centroid_normals` |
//! | A (assignment vector / matrix) | [`KMeansResult::assignment`], [`fuzzy::FuzzyMembership::clusters`] |
//! | n_t (orientation threshold) | [`KMeansParams::cos_threshold`] |
//! | gamma, S (downsampled set) | `gamma`, [`downsample_indices`] |
//! | G (regular grid) | `crate::gpu::kmeans` grid passes ([`KMeansParams::use_grid`]) |
//! | F, I_m, R_m, W, w_f | `f`, `clusters` row, squared distances, `weights` row (Eq. 10) |

pub mod fuzzy;
pub mod gpu;

#[cfg(test)]
mod tests;

pub use fuzzy::{fuzzy_membership, FuzzyMembership};
pub use gpu::{fuzzy_membership_gpu, kmeans_gpu};

use crate::error::{Error, Result};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::time::Instant;

/// The paper's orientation threshold: cos(pi / 6) = sqrt(3) / 2.
pub const DEFAULT_COS_THRESHOLD: f32 = 0.866_025_4;
/// Largest fuzziness F (mirrored as MAX_F in `shaders/kmeans.wgsl`).
pub const MAX_FUZZY: usize = 16;
/// The paper's default fuzziness (Sec. 4.1: F = 6).
pub const DEFAULT_FUZZY: usize = 6;
/// Our default downsampling factor gamma of the view samples (the paper gives none).
pub const DEFAULT_DOWNSAMPLING: usize = 4;
/// Fixed-point steps over the quantisation range (2^24).
pub const FIXED_SCALE: f64 = 16_777_216.0;

/// Parameters of [`kmeans_cpu`] / [`kmeans_gpu`].
#[derive(Debug, Clone, PartialEq)]
pub struct KMeansParams {
    /// K, the number of clusters, 1 <= k <= number of points.
    pub k: usize,
    /// Most update steps (0: only the initial assignment).
    pub max_iterations: usize,
    /// Stop when the objective falls by no more than `tolerance` times its previous value; 0 runs exactly
    /// `max_iterations` updates.
    pub tolerance: f64,
    /// Eq. 7's orientation threshold n_t (a cosine in [-1, 1]); `None` switches it off.
    pub cos_threshold: Option<f32>,
    /// Accelerate the GPU assignment with the regular grid (the result is the same; the CPU reference is
    /// always exhaustive).
    pub use_grid: bool,
    /// Seed of the initial centroids.
    pub seed: u64,
}

impl KMeansParams {
    /// `k` clusters with the paper's defaults: threshold cos 30 deg, grid on, 10 iterations, tolerance 0.
    pub fn new(k: usize) -> KMeansParams {
        KMeansParams { k, max_iterations: 10, tolerance: 0.0, cos_threshold: Some(DEFAULT_COS_THRESHOLD), use_grid: true, seed: 0 }
    }
}

/// Seconds spent per stage.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KMeansTimings {
    /// Validation, initial centroids, uploads and pipelines.
    pub setup_s: f64,
    /// The iterations (assignment, reduction, update), per-iteration objective read-backs included.
    pub iterations_s: f64,
    /// Reading centroids and assignment back.
    pub readback_s: f64,
    pub total_s: f64,
}

/// What K-means returns.
#[derive(Debug, Clone)]
pub struct KMeansResult {
    /// The K centroid positions.
    pub centroids: Vec<[f32; 3]>,
    /// The K unit centroid normals (zero vectors when the data had none).
    pub centroid_normals: Vec<[f32; 3]>,
    /// Per data point its nearest centroid (Eq. 7 order) for the final centroids.
    pub assignment: Vec<u32>,
    /// `objective[t]`: sum of squared distances to the nearest centroid after t updates, t = 0..=iterations.
    pub objective: Vec<f64>,
    /// Update steps run.
    pub iterations: usize,
    /// Indices of the data points chosen as initial centroids.
    pub initial: Vec<u32>,
    pub timings: KMeansTimings,
    /// "cpu" or "gpu".
    pub device: &'static str,
}

/// Check the inputs shared by K-means and fuzzy membership; returns unit normals (or zeros when the
/// threshold is off and normals are all zero).
pub(crate) fn check_points(points: &[[f32; 3]], normals: &[[f32; 3]], cos_threshold: Option<f32>, what: &str) -> Result<Vec<[f32; 3]>> {
    if points.is_empty() {
        return Err(Error::invalid(format!("{what}: no points (need at least 1)")));
    }
    if normals.len() != points.len() {
        return Err(Error::invalid(format!("{what}: {} normals for {} points (need one per point)", normals.len(), points.len())));
    }
    if let Some((i, p)) = points.iter().enumerate().find(|(_, p)| !p.iter().all(|v| v.is_finite())) {
        return Err(Error::invalid(format!("{what}: point {i} is not finite: {p:?}")));
    }
    if let Some((i, n)) = normals.iter().enumerate().find(|(_, n)| !n.iter().all(|v| v.is_finite())) {
        return Err(Error::invalid(format!("{what}: normal {i} is not finite: {n:?}")));
    }
    if let Some(t) = cos_threshold {
        if !(-1.0..=1.0).contains(&t) {
            return Err(Error::invalid(format!("{what}: cos_threshold must be in [-1, 1], got {t}")));
        }
    }
    normals
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                Ok([n[0] / len, n[1] / len, n[2] / len])
            } else if cos_threshold.is_none() {
                Ok([0.0; 3])
            } else {
                Err(Error::invalid(format!("{what}: normal {i} has zero length: {n:?} (Eq. 7 needs unit normals)")))
            }
        })
        .collect()
}

fn check_params(n: usize, p: &KMeansParams) -> Result<()> {
    if p.k == 0 || p.k > n {
        return Err(Error::invalid(format!("kmeans: k must be in [1, {n}] (the number of points), got {}", p.k)));
    }
    if p.k > (u32::MAX >> 1) as usize || n > u32::MAX as usize {
        return Err(Error::invalid(format!("kmeans: at most 2^31 - 1 clusters and 2^32 - 1 points, got k = {}, {n} points", p.k)));
    }
    if !(p.tolerance >= 0.0 && p.tolerance.is_finite()) {
        return Err(Error::invalid(format!("kmeans: tolerance must be finite and >= 0, got {}", p.tolerance)));
    }
    Ok(())
}

/// K distinct indices of `0..n`, uniformly at random (partial Fisher-Yates with the seed).
pub fn initial_indices(n: usize, k: usize, seed: u64) -> Vec<u32> {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x6b6d_6561_6e73_0001);
    let mut idx: Vec<u32> = (0..n as u32).collect();
    for i in 0..k.min(n) {
        let j = rng.random_range(i..n);
        idx.swap(i, j);
    }
    idx.truncate(k.min(n));
    idx
}

/// Alg. 1 line 1: the downsampled subset of `m` data points with factor `gamma` >= 1: one index drawn
/// uniformly (with the seed) from each block `[b gamma, (b + 1) gamma)` of consecutive points (for view
/// samples in scan-line order, a jittered sub-sampling of the image); ceil(m / gamma) sorted indices.
pub fn downsample_indices(m: usize, gamma: usize, seed: u64) -> Result<Vec<u32>> {
    if gamma == 0 {
        return Err(Error::invalid("downsample: gamma must be >= 1, got 0"));
    }
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x646f_776e_7361_6d70);
    Ok((0..m.div_ceil(gamma))
        .map(|b| {
            let lo = b * gamma;
            let hi = (lo + gamma).min(m);
            rng.random_range(lo..hi) as u32
        })
        .collect())
}

/// The fixed-point quantiser of the reduction step (module docs, "Precision").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantiser {
    pub lo: [f32; 3],
    pub extent: [f32; 3],
}

impl Quantiser {
    /// Over the bounding box of `points`.
    pub fn of(points: &[[f32; 3]]) -> Quantiser {
        let (lo, hi) = bounds(points);
        Quantiser { lo, extent: [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]] }
    }

    /// round(2^24 (x - lo) / extent) per axis, 0 on a flat axis (the same f32 operations as the WGSL).
    pub fn quantise(lo: [f32; 3], extent: [f32; 3], x: [f32; 3]) -> [u32; 3] {
        let mut q = [0u32; 3];
        for a in 0..3 {
            if extent[a] > 0.0 {
                let u = ((x[a] - lo[a]) / extent[a]).clamp(0.0, 1.0);
                q[a] = (u * FIXED_SCALE as f32 + 0.5).floor() as u32;
            }
        }
        q
    }
}

/// Bounding box (min, max) of non-empty `points`.
pub fn bounds(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// Candidate key (inadmissible, squared distance, index) of centroid `c` for a point: Eq. 7.
#[inline]
pub(crate) fn candidate(
    p: &[f32; 3],
    np: &[f32; 3],
    c: usize,
    cp: &[f32; 3],
    cn: &[f32; 3],
    cos_threshold: Option<f32>,
) -> (bool, f32, u32) {
    let d = [p[0] - cp[0], p[1] - cp[1], p[2] - cp[2]];
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let inadmissible = match cos_threshold {
        Some(t) => !(np[0] * cn[0] + np[1] * cn[1] + np[2] * cn[2] > t),
        None => false,
    };
    (inadmissible, d2, c as u32)
}

#[inline]
pub(crate) fn key_less(a: (bool, f32, u32), b: (bool, f32, u32)) -> bool {
    if a.0 != b.0 {
        return !a.0;
    }
    if a.1 != b.1 {
        return a.1 < b.1;
    }
    a.2 < b.2
}

/// The `f` best candidates of one point over all centroids, nearest first (exhaustive; Alg. 2's
/// insertion into a sorted list).
pub(crate) fn nearest_f(
    p: &[f32; 3],
    np: &[f32; 3],
    centroids: &[[f32; 3]],
    centroid_normals: &[[f32; 3]],
    f: usize,
    cos_threshold: Option<f32>,
) -> Vec<(bool, f32, u32)> {
    let mut list: Vec<(bool, f32, u32)> = Vec::with_capacity(f + 1);
    for (c, (cp, cn)) in centroids.iter().zip(centroid_normals).enumerate() {
        let cand = candidate(p, np, c, cp, cn, cos_threshold);
        if list.len() == f && !key_less(cand, list[f - 1]) {
            continue;
        }
        let at = list.iter().position(|&e| key_less(cand, e)).unwrap_or(list.len());
        list.insert(at, cand);
        list.truncate(f);
    }
    list
}

/// K-means on the CPU: the reference of [`kmeans_gpu`] (module docs), always exhaustive, rayon-parallel.
///
/// Errors: `InvalidParameter` for no points, k = 0 or k > number of points, a length mismatch, a non-finite
/// point or normal, a zero normal while the threshold is on, a threshold outside [-1, 1], a negative tolerance.
pub fn kmeans_cpu(points: &[[f32; 3]], normals: &[[f32; 3]], p: &KMeansParams) -> Result<KMeansResult> {
    let t0 = Instant::now();
    let normals = check_points(points, normals, p.cos_threshold, "kmeans")?;
    check_params(points.len(), p)?;
    let initial = initial_indices(points.len(), p.k, p.seed);
    let mut centroids: Vec<[f32; 3]> = initial.iter().map(|&i| points[i as usize]).collect();
    let mut centroid_normals: Vec<[f32; 3]> = initial.iter().map(|&i| normals[i as usize]).collect();
    let quant = Quantiser::of(points);
    let setup_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let mut objective = Vec::new();
    let mut iterations = 0;
    let assignment = loop {
        crate::interrupt::check()?;
        // Assignment step (Alg. 1 lines 6-11).
        let best: Vec<(bool, f32, u32)> = points
            .par_iter()
            .zip(normals.par_iter())
            .map(|(x, nx)| nearest_f(x, nx, &centroids, &centroid_normals, 1, p.cos_threshold)[0])
            .collect();
        objective.push(best.iter().map(|b| b.1 as f64).sum::<f64>());
        let t = objective.len() - 1;
        let converged = t > 0 && p.tolerance > 0.0 && objective[t - 1] - objective[t] <= p.tolerance * objective[t - 1];
        if t == p.max_iterations || converged {
            break best.iter().map(|b| b.2).collect::<Vec<u32>>();
        }
        // Reduction step (Alg. 1 lines 12-18) with the GPU's fixed-point sums.
        let mut sums = vec![(0u64, [0u64; 6]); p.k];
        for (i, b) in best.iter().enumerate() {
            let qp = Quantiser::quantise(quant.lo, quant.extent, points[i]);
            let qn = Quantiser::quantise([-1.0; 3], [2.0; 3], normals[i]);
            let s = &mut sums[b.2 as usize];
            s.0 += 1;
            for a in 0..3 {
                s.1[a] += qp[a] as u64;
                s.1[3 + a] += qn[a] as u64;
            }
        }
        for (c, (count, s)) in sums.iter().enumerate() {
            if *count == 0 {
                continue;
            }
            let mean = |v: u64| v as f64 / *count as f64 / FIXED_SCALE;
            for a in 0..3 {
                centroids[c][a] = (quant.lo[a] as f64 + mean(s[a]) * quant.extent[a] as f64) as f32;
            }
            let m: Vec<f64> = (0..3).map(|a| mean(s[3 + a]) * 2.0 - 1.0).collect();
            let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            if len > 1e-6 {
                centroid_normals[c] = [(m[0] / len) as f32, (m[1] / len) as f32, (m[2] / len) as f32];
            }
        }
        iterations += 1;
    };
    let iterations_s = t1.elapsed().as_secs_f64();
    Ok(KMeansResult {
        centroids,
        centroid_normals,
        assignment,
        objective,
        iterations,
        initial,
        timings: KMeansTimings { setup_s, iterations_s, readback_s: 0.0, total_s: t0.elapsed().as_secs_f64() },
        device: "cpu",
    })
}

/// Which device runs [`cluster_view_samples`].
pub enum KMeansDevice<'a> {
    Cpu,
    Gpu(&'a crate::gpu::GpuContext),
}

/// Clustering of view samples (Alg. 1 with downsampling, then Alg. 2).
#[derive(Debug, Clone)]
pub struct ViewSampleClustering {
    /// K-means on the downsampled subset (its `assignment` is over `subset`).
    pub kmeans: KMeansResult,
    /// The downsampled view samples (indices into the full set).
    pub subset: Vec<u32>,
    /// The factor used: the requested gamma, lowered so that the subset keeps at least k points.
    pub gamma: usize,
    /// The F nearest clusters and Eq. 10 weights of every view sample.
    pub membership: FuzzyMembership,
}

/// View-sample clustering as the paper does it: K-means on the subset [`downsample_indices`] picks with
/// factor `gamma` (lowered to `max(1, m / k)` when the subset would hold fewer than k points), then the
/// F nearest clusters of every view sample with Eq. 10 weights (Alg. 2).
pub fn cluster_view_samples(
    device: KMeansDevice,
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    gamma: usize,
    p: &KMeansParams,
    f: usize,
) -> Result<ViewSampleClustering> {
    if gamma == 0 {
        return Err(Error::invalid("cluster_view_samples: gamma must be >= 1, got 0"));
    }
    check_points(points, normals, p.cos_threshold, "cluster_view_samples")?;
    check_params(points.len(), p)?;
    let gamma = gamma.min((points.len() / p.k).max(1));
    let subset = downsample_indices(points.len(), gamma, p.seed)?;
    let sub_points: Vec<[f32; 3]> = subset.iter().map(|&i| points[i as usize]).collect();
    let sub_normals: Vec<[f32; 3]> = subset.iter().map(|&i| normals[i as usize]).collect();
    let (kmeans, membership) = match device {
        KMeansDevice::Cpu => {
            let km = kmeans_cpu(&sub_points, &sub_normals, p)?;
            let fm = fuzzy_membership(points, normals, &km.centroids, &km.centroid_normals, f, p.cos_threshold)?;
            (km, fm)
        }
        KMeansDevice::Gpu(ctx) => {
            let km = kmeans_gpu(ctx, &sub_points, &sub_normals, p)?;
            let fm = fuzzy_membership_gpu(ctx, points, normals, &km.centroids, &km.centroid_normals, f, p.cos_threshold, p.use_grid)?;
            (km, fm)
        }
    };
    Ok(ViewSampleClustering { kmeans, subset, gamma, membership })
}
