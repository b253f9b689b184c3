//! A photon map's spatial index: the k nearest photons of a point (Jensen, "Realistic Image Synthesis
//! Using Photon Mapping", 2001), for the density estimation of multiple-bounce irradiance at gather
//! samples (`animated`). A `kiddo` immutable kd-tree over the photon positions (squared Euclidean).
use glam::Vec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use std::num::NonZero;

/// Photons per leaf bucket (kiddo's default).
const BUCKET: usize = 32;

/// The kd-tree over photon positions.
pub struct PhotonMap {
    tree: ImmutableKdTree<f32, u32, 3, BUCKET>,
    len: usize,
}

impl PhotonMap {
    pub fn new(positions: &[Vec3]) -> PhotonMap {
        let points: Vec<[f32; 3]> = positions.iter().map(|p| p.to_array()).collect();
        PhotonMap { tree: ImmutableKdTree::new_from_slice(&points), len: points.len() }
    }

    /// The indices of the `k` photons nearest to `p` (fewer when the map is smaller) and the squared
    /// distance to the farthest of them (0 for an empty map).
    pub fn nearest(&self, p: Vec3, k: usize) -> (Vec<usize>, f32) {
        let k = k.min(self.len);
        let Some(q) = NonZero::new(k) else { return (Vec::new(), 0.0) };
        let found = self.tree.nearest_n::<SquaredEuclidean>(&p.to_array(), q);
        let r2 = found.iter().map(|n| n.distance).fold(0.0f32, f32::max);
        (found.into_iter().map(|n| n.item as usize).collect(), r2)
    }
}

#[cfg(test)]
mod tests;
