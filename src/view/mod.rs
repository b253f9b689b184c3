//! View samples: the deep framebuffer, one surface point per pixel centre, plus the surfaces seen
//! through delta BSDF chains (mirrors, glass, smooth plastic's specular layer, the null lobe of masked
//! surfaces; `crate::view::chains`).
//!
//! Produced by `crate::gpu::gbuffer` (rasterised visibility at pixel centres, then resolved exactly on the
//! CPU from the camera ray and the hit triangle / analytic sphere). Samples `0 .. width * height` are the
//! camera's own hits, index `i = y * width + x`, row 0 at the top, as Mitsuba's images (the G-buffer).
//! Samples past `width * height` ("extra" samples) are the first non-delta surfaces reached through
//! delta chains; each belongs to the pixel `extra_pixel[k - width * height]` and carries the RGB
//! `throughput` of its chain. A row of the light matrix is a pixel: the throughput-weighted sum of the
//! pixel's samples (`ViewSamples::fold`). Without delta BSDFs or masks there are no extra samples. A masked
//! surface seen by the camera is a sample of its nested BSDF with throughput times its opacity.
pub mod chains;
pub mod features;
pub mod resolve;

use crate::shading::GpuBsdf;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Default)]
pub struct ViewSamples {
    pub width: u32,
    pub height: u32,
    /// World-space hit point (0 where `shape_index < 0`).
    pub position: Vec<Vec3>,
    /// Shading normal (interpolated vertex normal, or the face normal), unit, world space.
    pub normal: Vec<Vec3>,
    /// Geometric normal: normalize(cross(p1 - p0, p2 - p0)) (Mitsuba's), or the sphere's outward normal.
    pub geo_normal: Vec<Vec3>,
    /// Unit direction from the hit point back along the ray that reached it (Mitsuba's `-ray.d`, world
    /// space): toward the camera for the camera's hits, toward the last delta vertex for extra samples.
    pub wi: Vec<Vec3>,
    pub uv: Vec<Vec2>,
    /// Diffuse albedo at the point (textures evaluated): diffuse reflectance of diffuse/plastics, 0 else.
    pub albedo: Vec<Vec3>,
    /// Index into `Scene::meshes`, -1 for background.
    pub shape_index: Vec<i32>,
    /// Triangle index within the mesh, -1 for background.
    pub prim_index: Vec<i32>,
    /// The BSDF resolved at the point (`crate::shading::bsdf::resolve`): record i for sample i; past
    /// `len()`, the second records of blended samples (`blendbsdf`, linked from their first record; see
    /// `crate::view::resolve::append_blend_records`). Evaluate with `shading::bsdf::eval_records`.
    pub bsdf: Vec<GpuBsdf>,
    /// RGB throughput of each sample: the product of the delta BSDF weights of its chain (Fresnel,
    /// specular reflectance / transmittance, eta^2 radiance scaling). Empty = 1 for every sample.
    pub throughput: Vec<Vec3>,
    /// Pixel of extra sample `width * height + e`, ascending (a pixel's extra samples are contiguous).
    pub extra_pixel: Vec<u32>,
    /// Per pixel (`width * height`), the emission seen along its delta chains (area emitters and the
    /// environment reached after >= 1 delta bounce), throughput applied. Empty = none.
    pub chain_emitted: Vec<Vec3>,
    /// Per sample, how many masked surfaces (`mask` BSDF) its shadow rays toward area and environment
    /// lights and VPLs may cross (Mitsuba counts each null event as a bounce: `crate::raytrace::mask`);
    /// `u32::MAX` = unlimited. Empty = the scene has no masks (shadow rays stop at any surface).
    pub mask_budget: Vec<u32>,
    /// Per sample, the factor on its direct light (not on VPLs) from Mitsuba's `valid_ray` rule for a
    /// masked surface reached through null events only (`crate::raytrace::mask`). Empty = 1.
    pub mask_valid: Vec<f32>,
    /// Per sample, the opacity of a masked sample (1 for the others). Empty = no masks.
    pub mask_opacity: Vec<f32>,
    /// Per `Scene::meshes` index, Mitsuba's area-emitter sampling density 1 / (A N) (A the mesh's area,
    /// N the scene's emitter count; 0 for meshes without an area emitter), for the MIS weights of the
    /// `valid_ray` factor (`crate::raytrace::mask::direct_factor`). Empty = no masks.
    pub mask_emitter_pdf: Vec<f32>,
    /// n_B per sample: BSDF samples of a glossy view sample (`matrix::glossy`; its light columns carry
    /// the MIS weight w_L), 0 for the others. Empty = no glossy sample.
    pub bsdf_samples: Vec<u32>,
    /// Seed of the glossy samples' BSDF rays (`matrix::glossy::bsdf_image`).
    pub glossy_seed: u64,
}

impl ViewSamples {
    /// Number of samples (pixels plus extra samples).
    pub fn len(&self) -> usize {
        self.shape_index.len()
    }
    pub fn is_empty(&self) -> bool {
        self.shape_index.is_empty()
    }
    /// Number of pixels, `width * height` (the rows of the light matrix).
    pub fn num_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
    /// Mark the glossy samples (`matrix::glossy`, rule in its module docs) with their BSDF sample counts.
    ///
    /// Errors: `InvalidParameter` for bad options (`GlossyOptions::check`).
    pub fn set_glossy(&mut self, opts: &crate::matrix::glossy::GlossyOptions) -> crate::error::Result<()> {
        let n = crate::matrix::glossy::bsdf_samples_per_view_sample(self, opts)?;
        self.bsdf_samples = if n.iter().any(|&k| k > 0) { n } else { Vec::new() };
        self.glossy_seed = opts.seed;
        Ok(())
    }
    /// Glossy MIS work: (samples that get BSDF samples, BSDF samples in all); (0, 0) without glossy samples.
    pub fn glossy_work(&self) -> (usize, u64) {
        let b = &self.bsdf_samples;
        (b.iter().filter(|&&k| k > 0).count(), b.iter().map(|&k| k as u64).sum())
    }
    /// Throughput of sample `i` (1 when `throughput` is empty).
    pub fn throughput_of(&self, i: usize) -> Vec3 {
        self.throughput.get(i).copied().unwrap_or(Vec3::ONE)
    }
    /// The pixel of sample `i`: `i` itself for the pixels' own samples, else its extra sample's pixel.
    pub fn pixel_of(&self, i: usize) -> usize {
        let m = self.num_pixels();
        if i < m {
            i
        } else {
            self.extra_pixel[i - m] as usize
        }
    }
    /// Sample indices of pixel `p`: `p` itself, then its extra samples.
    pub fn samples_of_pixel(&self, p: usize) -> impl Iterator<Item = usize> + '_ {
        let lo = self.extra_pixel.partition_point(|&q| (q as usize) < p);
        let hi = self.extra_pixel.partition_point(|&q| (q as usize) <= p);
        let base = self.num_pixels();
        std::iter::once(p).chain((lo..hi).map(move |e| base + e))
    }
    /// Per-sample values (`len() * c` floats, sample-major) summed into per-pixel values
    /// (`num_pixels() * c`): each pixel's own sample plus its extra samples, in sample order.
    pub fn fold(&self, values: &[f32], c: usize) -> Vec<f32> {
        let m = self.num_pixels();
        let mut out = values[..m * c].to_vec();
        for (e, &p) in self.extra_pixel.iter().enumerate() {
            let k = m + e;
            for ch in 0..c {
                out[p as usize * c + ch] += values[k * c + ch];
            }
        }
        out
    }
}
