//! Clustered visibility: shadow rays only between the representatives of light clusters and of view-sample
//! clusters, interpolated back to every view sample over its F nearest view clusters (the 2022 paper on
//! GPU fuzzy K-means clustering of VPLs and shading points, `seeds/gpu-fuzzy-kmeans-vpl-clustering-2022`:
//! Sec. 3.1 steps 5-6, Eqs. 6, 8, 9, 10). The clusterings themselves (K-means, fuzzy membership) are
//! inputs here; this module turns them into an image.
//!
//! # What is computed
//! - Light clusters ([`ClusterLights::new`]): every label of the light clustering becomes one cluster
//!   light. Its **representative** is the member nearest the cluster's centroid (the paper's "position
//!   of the representative VPL of cluster c", Eq. 6: a real light, so its normal, BSDF, incident
//!   direction, spot cone and texture are those of a light that exists) and its **intensity** is the sum
//!   of the members' intensities (`I_c`, Eq. 6: the cluster's total emission, so that a cluster whose
//!   members coincide shades exactly as its members do). Ties of distance go to the lowest light index.
//! - Light kinds: intensities of different kinds are different quantities (W/sr for points, spots and
//!   oriented points, W/m^2 for directional lights, W for VPL flux), so a label whose members have
//!   several kinds is **split by kind** into one cluster light per kind present (in kind order; the
//!   visibility matrix then has one column per cluster light, `ClusterLights::len` >= labels used).
//!   **Directional lights** have no position: within a label, the directional members form their own
//!   cluster light whose representative is the member whose direction is nearest the members' mean
//!   direction (their "position" on the unit sphere), intensity the sum of irradiances. A clustering
//!   that wants every directional light alone gives each its own label. Labels without members are
//!   skipped (no cluster light, no rays).
//! - View-sample clusters ([`ViewRepresentatives::new`]): the paper traces from "each shading points'
//!   cluster representative" (Sec. 3.1, step 5). The representative of view cluster k is the surface
//!   view sample nearest its centroid among the samples whose nearest cluster (membership column 0) is
//!   k; when there is none, among all samples that list k anywhere in their F clusters. A representative
//!   is a real surface point, so the shadow ray starts with Mitsuba's offset along its geometric normal,
//!   exactly as the brute-force columns' rays (a centroid can lie inside geometry on curved or folded
//!   clusters). A cluster no surface sample lists gets no representative and no rays.
//! - Visibility (item 3, [`VisibilityMatrix`]): one exact shadow ray per (view cluster with a
//!   representative, cluster light), from the view representative toward the light representative
//!   (`spawn_ray_to`), or unbounded along the light's reversed direction for a directional one. Stored
//!   bit-packed: row k (view cluster) holds `words = ceil(K_light / 32)` u32, bit c of the row = 1 when
//!   cluster light c is visible: `K_view * words * 4` bytes (8000 x 1000 clusters: 1 MiB). In a scene with
//!   masked surfaces (Mitsuba's `mask`, `raytrace::mask`) an entry is the ray's expected transmittance,
//!   exactly as the light matrix's element from the representative (`cpu::mask_visibility_at`: the
//!   representative's mask budget, the lights whose shadow rays cross masks), stored beside the bits as
//!   `K_view * K_light` f32, with a second bit matrix of the rays that crossed a mask.
//! - Shading (item 4, Eq. 6 with Eq. 9): for every surface view sample i and cluster light c,
//!   `L_i += bsdf_i(wi, wo_c) * F_c(p_i) * throughput_i * sum_f w_if V(k_if, c)`, where `F_c` is the
//!   cluster light's emission at p_i (`LightSet::emitted` with the summed intensity: the same formula and
//!   code as the light matrix's columns), `k_if` and `w_if` the sample's F nearest view clusters and their
//!   weights (Eq. 10, normalised inverse distances; F = 1 is hard clustering, Eq. 8's mean is the
//!   special case of equal weights). In a masked scene V is the transmittance, a light whose ray from
//!   cluster k crossed a mask counts without the glossy light weight (`cpu::shade`), and F_c carries
//!   Mitsuba's `valid_ray` factor of a masked sample (`cpu::shade_unshadowed`, the columns' code).
//!   Per-sample values are folded into pixels as the light matrix does
//!   (delta-chain samples add into their pixel). What the camera sees of emitters is not included
//!   (`LightMatrix::emitted`, added by the Python renderer as MRCS does).
//!
//! With every light its own label and every view sample its own cluster (F = 1), representatives are
//! the lights and samples themselves, every ray is the brute-force column's ray and the image equals
//! `LightMatrix::column_sum` up to summation order (tested).
//!
//! Both backends implement it (`Backend::clustered_shading`): the GPU's `gpu::clustered_visibility`
//! (wgpu, `shaders/clustered_visibility.wgsl`, rays through the GPU BVH) and [`cpu`] (rayon, the CPU
//! BVH). Representatives are chosen on the host by the code here for both (O(lights + view samples),
//! negligible next to the O(K_view K_light) rays and O(m K_light) shading), so both backends trace the
//! same rays.
//!
//! Symbols: n lights, m view samples (pixels + delta-chain samples), K_light = cluster lights,
//! K_view = view clusters, F = view clusters per sample, V the visibility matrix.
pub mod cpu;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::lights::{LightKind, LightSet};
use crate::view::ViewSamples;
use glam::Vec3;

/// Most view clusters one view sample may belong to (bounds the shading loop per light).
pub const MAX_FUZZINESS: usize = 64;
/// How far a membership row's weights may sum from 1.
pub const WEIGHT_SUM_TOLERANCE: f32 = 1e-3;

/// A hard clustering of the lights of a `LightSet`: `assignment[j]` = label of light j, `< centroids.len()`.
#[derive(Debug, Clone)]
pub struct LightClustering {
    pub assignment: Vec<u32>,
    /// One centroid (world position) per label.
    pub centroids: Vec<[f32; 3]>,
}

/// Each view sample's F nearest view clusters (nearest first) and their weights (rows sum to 1).
#[derive(Debug, Clone)]
pub struct Membership {
    pub f: usize,
    /// `m * f` cluster ids.
    pub clusters: Vec<u32>,
    /// `m * f` weights.
    pub weights: Vec<f32>,
}

/// K-means' fuzzy membership (`crate::cluster::kmeans::fuzzy`, Eq. 10) as the shading's input.
impl From<crate::cluster::kmeans::fuzzy::FuzzyMembership> for Membership {
    fn from(m: crate::cluster::kmeans::fuzzy::FuzzyMembership) -> Membership {
        Membership { f: m.f, clusters: m.clusters, weights: m.weights }
    }
}

/// A fuzzy clustering of the view samples.
#[derive(Debug, Clone)]
pub struct ViewClustering {
    /// One centroid (world position) per view cluster.
    pub centroids: Vec<[f32; 3]>,
    /// One mean normal per view cluster (finite; used only for validation and reported back).
    pub normals: Vec<[f32; 3]>,
    pub membership: Membership,
}

fn check_finite3(what: &str, k: usize, v: &[f32; 3]) -> Result<()> {
    if !v.iter().all(|x| x.is_finite()) {
        return Err(Error::invalid(format!("{what} {k} must be finite, got {v:?}")));
    }
    Ok(())
}

impl LightClustering {
    /// Checks lengths, labels and centroids against `n` lights.
    pub fn validate(&self, n: usize) -> Result<()> {
        if self.assignment.len() != n {
            return Err(Error::invalid(format!("light labels must have one entry per light ({n}), got {}", self.assignment.len())));
        }
        let k = self.centroids.len();
        if k == 0 {
            return Err(Error::invalid("light centroids must hold at least one cluster, got 0"));
        }
        if let Some((j, &l)) = self.assignment.iter().enumerate().find(|(_, &l)| l as usize >= k) {
            return Err(Error::invalid(format!("light label {l} (light {j}) is out of range for {k} light centroids")));
        }
        for (c, v) in self.centroids.iter().enumerate() {
            check_finite3("light centroid", c, v)?;
        }
        Ok(())
    }
}

impl ViewClustering {
    /// Checks shapes, labels, weights and centroids against `m` view samples.
    pub fn validate(&self, m: usize) -> Result<()> {
        let k = self.centroids.len();
        if k == 0 {
            return Err(Error::invalid("view centroids must hold at least one cluster, got 0"));
        }
        if self.normals.len() != k {
            return Err(Error::invalid(format!("view normals must have one entry per view centroid ({k}), got {}", self.normals.len())));
        }
        for (c, v) in self.centroids.iter().enumerate() {
            check_finite3("view centroid", c, v)?;
        }
        for (c, v) in self.normals.iter().enumerate() {
            check_finite3("view normal", c, v)?;
        }
        let mb = &self.membership;
        let f = mb.f;
        if f == 0 || f > MAX_FUZZINESS.min(k) {
            return Err(Error::invalid(format!(
                "fuzziness F (membership columns) must be in [1, min({MAX_FUZZINESS}, {k} view clusters)], got {f}"
            )));
        }
        if mb.clusters.len() != m * f || mb.weights.len() != m * f {
            return Err(Error::invalid(format!(
                "membership must have shape ({m}, {f}) (one row per view sample) for clusters and weights, got {} and {} entries",
                mb.clusters.len(),
                mb.weights.len()
            )));
        }
        if let Some((e, &l)) = mb.clusters.iter().enumerate().find(|(_, &l)| l as usize >= k) {
            return Err(Error::invalid(format!(
                "membership cluster {l} (view sample {}, column {}) is out of range for {k} view centroids",
                e / f,
                e % f
            )));
        }
        for (i, row) in mb.weights.chunks_exact(f).enumerate() {
            if let Some((c, w)) = row.iter().enumerate().find(|(_, w)| !(w.is_finite() && **w >= 0.0)) {
                return Err(Error::invalid(format!("membership weights must be finite and >= 0, got {w} (view sample {i}, column {c})")));
            }
            let s: f32 = row.iter().sum();
            if (s - 1.0).abs() > WEIGHT_SUM_TOLERANCE {
                return Err(Error::invalid(format!(
                    "membership weights of a view sample must sum to 1 (within {WEIGHT_SUM_TOLERANCE}), got {s} (view sample {i})"
                )));
            }
        }
        Ok(())
    }
}

/// The cluster lights (module docs): one light per (label, kind) present, as a `LightSet`.
#[derive(Debug, Clone)]
pub struct ClusterLights {
    /// The representatives with the clusters' summed intensities.
    pub lights: LightSet,
    /// Light index (in the input `LightSet`) of each cluster light's representative.
    pub representative: Vec<usize>,
    /// Input label of each cluster light.
    pub label: Vec<u32>,
    /// Members of each cluster light.
    pub size: Vec<u32>,
}

const KINDS: usize = 5;

impl ClusterLights {
    /// Representatives and summed intensities of `clustering` over `lights` (module docs).
    ///
    /// Errors: `InvalidParameter` from `LightClustering::validate`.
    pub fn new(lights: &LightSet, clustering: &LightClustering) -> Result<ClusterLights> {
        let n = lights.len();
        clustering.validate(n)?;
        let k = clustering.centroids.len();
        // Per (label, kind): members' summed intensity, mean direction (directional), count.
        let slot = |j: usize| clustering.assignment[j] as usize * KINDS + lights.kind[j] as usize;
        let mut sum = vec![Vec3::ZERO; k * KINDS];
        let mut dir = vec![Vec3::ZERO; k * KINDS];
        let mut count = vec![0u32; k * KINDS];
        for j in 0..n {
            let s = slot(j);
            sum[s] += lights.intensity[j];
            dir[s] += lights.direction[j];
            count[s] += 1;
        }
        // Representative: the member nearest the centroid (directional: nearest the mean direction).
        let mut best = vec![(f32::INFINITY, usize::MAX); k * KINDS];
        for j in 0..n {
            let s = slot(j);
            let d = if lights.kind[j] == LightKind::Directional {
                let mean = dir[s].normalize_or_zero();
                (lights.direction[j] - mean).length_squared()
            } else {
                (lights.position[j] - Vec3::from_array(clustering.centroids[s / KINDS])).length_squared()
            };
            if d < best[s].0 || best[s].1 == usize::MAX {
                best[s] = (d, j);
            }
        }
        let used: Vec<usize> = (0..k * KINDS).filter(|&s| count[s] > 0).collect();
        let representative: Vec<usize> = used.iter().map(|&s| best[s].1).collect();
        let mut set = lights.select(&representative)?;
        set.intensity = used.iter().map(|&s| sum[s]).collect();
        // Glossy MIS: a cluster light is weighted as its representative is in the full matrix (w_L of
        // the representative's own density), the approximation of the members' weighted sum that keeps
        // `LightMatrix::emitted`'s BSDF strategy (weighted by the full set's densities) consistent.
        set.mis_measure = representative.iter().map(|&j| lights.mis_measure[j]).collect();
        set.mis_mesh = representative.iter().map(|&j| lights.mis_mesh[j]).collect();
        Ok(ClusterLights {
            lights: set,
            representative,
            label: used.iter().map(|&s| (s / KINDS) as u32).collect(),
            size: used.iter().map(|&s| count[s]).collect(),
        })
    }

    pub fn len(&self) -> usize {
        self.representative.len()
    }

    pub fn is_empty(&self) -> bool {
        self.representative.is_empty()
    }
}

/// The representative view sample of each view cluster (module docs).
#[derive(Debug, Clone)]
pub struct ViewRepresentatives {
    /// View-sample index of each cluster's representative, `None` for clusters no surface sample lists.
    pub sample: Vec<Option<usize>>,
}

impl ViewRepresentatives {
    /// Representatives of `clustering` over `view` (module docs).
    ///
    /// Errors: `InvalidParameter` from `ViewClustering::validate`.
    pub fn new(view: &ViewSamples, clustering: &ViewClustering) -> Result<ViewRepresentatives> {
        let m = view.len();
        clustering.validate(m)?;
        let k = clustering.centroids.len();
        let f = clustering.membership.f;
        let clusters = &clustering.membership.clusters;
        // Nearest surface sample to each centroid among its hard members (column 0), and among every
        // sample listing it (any column): the second serves clusters without hard members.
        let mut hard = vec![(f32::INFINITY, usize::MAX); k];
        let mut any = vec![(f32::INFINITY, usize::MAX); k];
        for i in (0..m).filter(|&i| view.shape_index[i] >= 0) {
            for c in 0..f {
                let kc = clusters[i * f + c] as usize;
                let d = (view.position[i] - Vec3::from_array(clustering.centroids[kc])).length_squared();
                let better = |b: &(f32, usize)| b.1 == usize::MAX || d < b.0;
                if c == 0 && better(&hard[kc]) {
                    hard[kc] = (d, i);
                }
                if better(&any[kc]) {
                    any[kc] = (d, i);
                }
            }
        }
        let pick = |h: (f32, usize), a: (f32, usize)| [h.1, a.1].into_iter().find(|&i| i != usize::MAX);
        Ok(ViewRepresentatives { sample: hard.into_iter().zip(any).map(|(h, a)| pick(h, a)).collect() })
    }

    pub fn len(&self) -> usize {
        self.sample.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sample.is_empty()
    }
}

/// Everything one clustered render needs besides the light matrix's scene, view samples and lights.
#[derive(Debug, Clone)]
pub struct ClusteredShading {
    pub lights: ClusterLights,
    pub view_reps: ViewRepresentatives,
    pub membership: Membership,
}

impl ClusteredShading {
    /// Validates both clusterings against `lights` and `view` and picks the representatives.
    ///
    /// Errors: `InvalidParameter` naming the offending value (labels out of range, wrong shapes,
    /// non-finite centroids, normals or weights, rows of weights not summing to 1, F out of range, no
    /// lights).
    pub fn new(
        lights: &LightSet,
        view: &ViewSamples,
        light_clustering: &LightClustering,
        view_clustering: &ViewClustering,
    ) -> Result<ClusteredShading> {
        if lights.is_empty() {
            return Err(Error::invalid("the light set is empty: nothing to cluster"));
        }
        Ok(ClusteredShading {
            lights: ClusterLights::new(lights, light_clustering)?,
            view_reps: ViewRepresentatives::new(view, view_clustering)?,
            membership: view_clustering.membership.clone(),
        })
    }

    /// Rows (view clusters) with a representative times cluster lights: the rays a render traces.
    pub fn rays(&self) -> u64 {
        self.view_reps.sample.iter().filter(|s| s.is_some()).count() as u64 * self.lights.len() as u64
    }
}

/// The visibility matrix (module docs): `rows` view clusters x `cols` cluster lights, bit-packed, and in a
/// scene with masked surfaces also the fractional transmittance of every entry.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibilityMatrix {
    pub rows: usize,
    pub cols: usize,
    /// `rows * words_per_row(cols)` u32: bit c of row k set when V(k, c) > 0.
    pub bits: Vec<u32>,
    /// Masked scenes only (empty otherwise): `rows * cols` f32, V(k, c) in [0, 1], the expected
    /// transmittance of the ray through masked surfaces (`cpu::mask_visibility_at`).
    pub transmittance: Vec<f32>,
    /// Masked scenes only (empty otherwise): bit-packed as `bits`, set when the ray of (k, c) crossed a
    /// masked surface (only Mitsuba's BSDF sampling then reaches the light: `cpu::shade`).
    pub crossed: Vec<u32>,
}

/// u32 words of one row of the visibility matrix.
pub fn words_per_row(cols: usize) -> usize {
    cols.div_ceil(32).max(1)
}

impl VisibilityMatrix {
    /// Whether V(row, col) > 0 (the representatives see each other, through masks perhaps).
    pub fn get(&self, row: usize, col: usize) -> bool {
        self.bits[row * words_per_row(self.cols) + col / 32] >> (col % 32) & 1 == 1
    }

    /// V(row, col) and whether its ray crossed a masked surface: the transmittance in a masked scene, else
    /// 0 or 1 (and false).
    #[inline]
    pub fn value(&self, row: usize, col: usize) -> (f32, bool) {
        if self.transmittance.is_empty() {
            return (self.get(row, col) as u8 as f32, false);
        }
        let crossed = self.crossed[row * words_per_row(self.cols) + col / 32] >> (col % 32) & 1 == 1;
        (self.transmittance[row * self.cols + col], crossed)
    }
}

/// What a clustered render returns.
#[derive(Debug, Clone)]
pub struct ClusteredImage {
    /// H * W * 3 floats, row 0 at the top (emitters seen directly not included).
    pub image: Vec<f32>,
    pub visibility: VisibilityMatrix,
    /// Shadow rays traced (one per pair of a view cluster with a representative and a cluster light).
    pub rays: u64,
    /// Rays that ran out of traversal steps (GPU; counted as visible; must be 0).
    pub gave_up: u64,
    /// Seconds of the visibility stage and of the shading stage.
    pub visibility_seconds: f64,
    pub shading_seconds: f64,
}

/// Seconds since `t0`.
pub(crate) fn seconds(t0: std::time::Instant) -> f64 {
    t0.elapsed().as_secs_f64()
}
