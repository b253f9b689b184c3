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
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        let pts: Vec<Vec3> = (0..500).map(|i| {
            let f = i as f32;
            Vec3::new((f * 0.37).sin() * 3.0, (f * 0.11).cos() * 2.0, (f * 0.05).fract())
        }).collect();
        let map = PhotonMap::new(&pts);
        for q in [Vec3::ZERO, Vec3::new(1.0, -1.0, 0.5), Vec3::splat(10.0)] {
            let (mut got, r2) = map.nearest(q, 16);
            let mut all: Vec<(f32, usize)> = pts.iter().enumerate().map(|(i, p)| (p.distance_squared(q), i)).collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut want: Vec<usize> = all[..16].iter().map(|x| x.1).collect();
            got.sort();
            want.sort();
            assert_eq!(got, want);
            assert!((r2 - all[15].0).abs() <= 1e-6 * all[15].0.max(1.0));
        }
        assert_eq!(PhotonMap::new(&[]).nearest(Vec3::ZERO, 4), (vec![], 0.0));
        assert_eq!(map.nearest(Vec3::ZERO, 1000).0.len(), 500);
    }
}
