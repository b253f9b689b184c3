//! The deep framebuffer as 9-vectors: per pixel, the world-space position, shading normal and diffuse
//! albedo of the surface its centre sees (Hašan et al., "Tensor Clustering for Rendering Many-Light
//! Animations", EGSR 2008, Sec. 5, "Pixel mapping computation" and "Anti-aliasing": "We treat each
//! sample as a 9-vector").
//!
//! The paper does not give the weights of the three parts. We scale as its companion paper does for the
//! same kind of samples (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic Relighting",
//! SIGGRAPH 2006, Eq. 9: `d(s, c) = K^2 |p_s - p_c|^2 + d^2 |n_s - n_c|^2`, d the scene's bounding-box
//! diagonal, K "about 20 to 40"), divided by d^2, and add the albedo with weight 1:
//!
//! `f = (K / d * p, 1 * n, 1 * albedo)`, K = [`DeepMetric::K`] = 30,
//!
//! so a position offset of d / 30 (3.3% of the diagonal) costs as much as a unit normal difference
//! (60 degrees) or an albedo difference of 1 in one channel. Squared Euclidean distance on `f` is the
//! metric of the pixel mappings (`crate::matrix::mapping`) and of the anti-aliasing upsampling
//! (`crate::image::antialias`).
//!
//! Pixels whose centre sees no surface (`shape_index < 0`) have no feature (`DeepFeatures::valid` false);
//! only the camera's own samples (the first `width * height` view samples) are used, not the surfaces
//! seen through mirrors and glass.
use crate::view::ViewSamples;
use glam::Vec3;

/// Dimension of a deep-framebuffer sample.
pub const DIM: usize = 9;

/// Weights of the 9-vector (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeepMetric {
    /// Multiplies world-space positions (1/m): `K / diagonal`.
    pub position_scale: f32,
    /// Multiplies the unit shading normal.
    pub normal_weight: f32,
    /// Multiplies the diffuse albedo (RGB).
    pub albedo_weight: f32,
}

impl DeepMetric {
    /// K of Eq. 9 of the direct-to-indirect paper (it recommends 20 to 40).
    pub const K: f32 = 30.0;

    /// The metric for a scene whose bounding-box diagonal is `diagonal` (world units): position scale
    /// `K / diagonal` (1 when the diagonal is zero or not finite), normal and albedo weights 1.
    pub fn for_diagonal(diagonal: f32) -> DeepMetric {
        let position_scale = if diagonal.is_finite() && diagonal > 0.0 { Self::K / diagonal } else { 1.0 };
        DeepMetric { position_scale, normal_weight: 1.0, albedo_weight: 1.0 }
    }

    /// The 9-vector of one sample.
    pub fn feature(&self, position: Vec3, normal: Vec3, albedo: Vec3) -> [f32; DIM] {
        let p = position * self.position_scale;
        let n = normal * self.normal_weight;
        let a = albedo * self.albedo_weight;
        [p.x, p.y, p.z, n.x, n.y, n.z, a.x, a.y, a.z]
    }

    /// The deep framebuffer of `view` (its first `width * height` samples, one per pixel).
    pub fn features(&self, view: &ViewSamples) -> DeepFeatures {
        let m = view.num_pixels();
        let mut features = Vec::with_capacity(m);
        let mut valid = Vec::with_capacity(m);
        for i in 0..m {
            let f = self.feature(view.position[i], view.normal[i], view.albedo[i]);
            // Non-finite values (a degenerate normal) would break the kd-tree's ordering: no feature.
            let ok = view.shape_index[i] >= 0 && f.iter().all(|v| v.is_finite());
            features.push(if ok { f } else { [0.0; DIM] });
            valid.push(ok);
        }
        DeepFeatures { width: view.width, height: view.height, features, valid }
    }
}

/// Squared Euclidean distance of two 9-vectors.
pub fn distance2(a: &[f32; DIM], b: &[f32; DIM]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// One 9-vector per pixel (`y * width + x`, row 0 at the top) and whether the pixel sees a surface.
#[derive(Debug, Clone, PartialEq)]
pub struct DeepFeatures {
    pub width: u32,
    pub height: u32,
    /// Zero where `valid` is false.
    pub features: Vec<[f32; DIM]>,
    pub valid: Vec<bool>,
}

impl DeepFeatures {
    pub fn num_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

#[cfg(test)]
mod tests;
