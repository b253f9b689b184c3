//! Distance-based fuzzy membership (Sec. 3.2.2, Eq. 9-10, Alg. 2): each data point belongs to its F
//! nearest clusters (Eq. 7 order, nearest first) with weights `w_f = w'_f / W`, `w'_f = 1 / dist(p, p_f)`,
//! `W = sum_f w'_f`. F = 1 is hard clustering (weight 1).
//!
//! Rules where Eq. 10 is undefined (ours; the GPU's `fuzzy_weights` kernel does the same):
//! - An inadmissible cluster (Eq. 7 distance infinite) gets weight 1/inf = 0. When none of the F clusters is
//!   admissible (a point whose normal matches no centroid), the weights use the Euclidean distances.
//! - A cluster at distance 0 takes all the weight (shared equally among several at distance 0).
use super::{check_points, nearest_f, MAX_FUZZY};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// The F nearest clusters of each data point and their Eq. 10 weights.
#[derive(Debug, Clone, PartialEq)]
pub struct FuzzyMembership {
    /// F, clusters per data point.
    pub f: usize,
    /// `n * f` cluster indices, row i = point i's clusters, nearest first (Eq. 7 order).
    pub clusters: Vec<u32>,
    /// `n * f` weights, each row sums to 1 (Eq. 10).
    pub weights: Vec<f32>,
    /// `n * f` squared Euclidean distances to those centroids.
    pub distances2: Vec<f32>,
    /// `n * f`: whether the cluster is admissible (normals within the threshold).
    pub admissible: Vec<bool>,
}

/// Eq. 10 weights of one row from its (admissible, squared distance) entries, nearest first (rules in the
/// module docs). The same f32 operations as `fuzzy_weights` in `shaders/kmeans.wgsl`.
pub fn eq10_weights(row: &[(bool, f32)]) -> Vec<f32> {
    let any_admissible = row.first().is_some_and(|e| e.0);
    let used = |e: &(bool, f32)| !any_admissible || e.0;
    let zeros = row.iter().filter(|e| used(e) && e.1 == 0.0).count();
    let total: f32 = row.iter().filter(|e| used(e) && e.1 != 0.0).map(|e| 1.0 / e.1.sqrt()).sum();
    row.iter()
        .map(|e| match (used(e), zeros) {
            (false, _) => 0.0,
            (true, 0) => (1.0 / e.1.sqrt()) / total,
            (true, z) => {
                if e.1 == 0.0 {
                    1.0 / z as f32
                } else {
                    0.0
                }
            }
        })
        .collect()
}

pub(crate) fn check_f(f: usize, k: usize) -> Result<()> {
    if f == 0 || f > k || f > MAX_FUZZY {
        return Err(Error::invalid(format!(
            "fuzzy membership: F must be in [1, min(k, {MAX_FUZZY})] = [1, {}], got {f}",
            k.min(MAX_FUZZY)
        )));
    }
    Ok(())
}

pub(crate) fn check_centroids(centroids: &[[f32; 3]], centroid_normals: &[[f32; 3]], cos_threshold: Option<f32>) -> Result<Vec<[f32; 3]>> {
    if centroids.is_empty() {
        return Err(Error::invalid("fuzzy membership: no centroids (k = 0)"));
    }
    check_points(centroids, centroid_normals, cos_threshold, "fuzzy membership (centroids)")
}

pub(crate) fn membership_from_lists(f: usize, lists: Vec<Vec<(bool, f32, u32)>>) -> FuzzyMembership {
    let mut out = FuzzyMembership { f, clusters: Vec::new(), weights: Vec::new(), distances2: Vec::new(), admissible: Vec::new() };
    for list in lists {
        let row: Vec<(bool, f32)> = list.iter().map(|e| (!e.0, e.1)).collect();
        out.weights.extend(eq10_weights(&row));
        out.clusters.extend(list.iter().map(|e| e.2));
        out.distances2.extend(list.iter().map(|e| e.1));
        out.admissible.extend(list.iter().map(|e| !e.0));
    }
    out
}

/// Alg. 2 on the CPU (exhaustive over the centroids, rayon-parallel): the F nearest clusters of each of the
/// `points` (with `normals`, unit or normalised here; zeros allowed when `cos_threshold` is None) among
/// `centroids` / `centroid_normals`, and their Eq. 10 weights.
///
/// Errors: `InvalidParameter` for F outside [1, min(k, 16)], no points or centroids, length mismatches,
/// non-finite values, zero normals with the threshold on, a threshold outside [-1, 1].
pub fn fuzzy_membership(
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    centroids: &[[f32; 3]],
    centroid_normals: &[[f32; 3]],
    f: usize,
    cos_threshold: Option<f32>,
) -> Result<FuzzyMembership> {
    let normals = check_points(points, normals, cos_threshold, "fuzzy membership")?;
    let cn = check_centroids(centroids, centroid_normals, cos_threshold)?;
    check_f(f, centroids.len())?;
    crate::interrupt::check()?;
    let lists: Vec<Vec<(bool, f32, u32)>> =
        points.par_iter().zip(normals.par_iter()).map(|(p, np)| nearest_f(p, np, centroids, &cn, f, cos_threshold)).collect();
    Ok(membership_from_lists(f, lists))
}
