//! Exact oracle of the light matrix on the CPU: A(i, j) by ray casting, to check the GPU's
//! shadow-mapped columns and rows element by element.
//!
//! A(i, j) is computed with the shading of `shaders/columns.wgsl`: for a surface view sample i (shading
//! normal n, Mitsuba's frame `coordinate_system(n)`), `(wo, F, dist) = LightSet::emitted(j, p, n)`,
//! `A(i, j) = bsdf::eval(bsdf_i, wi_local, wo_local) * F * V`, where `bsdf::eval` includes the cosine
//! and V is exact visibility by `raytrace::RayTracer` with Mitsuba's offsets: `RayTracer::occluded(p,
//! n_g, q)` (`spawn_ray_to`) toward a light at a finite distance (point, spot, oriented point, VPL),
//! an unbounded `spawn_ray(p, n_g, wo)` for directional lights -- the same rays the GPU's
//! `Visibility::RayTraced` casts. Background samples (`shape_index < 0`) are 0. A sample's value is
//! multiplied by its delta-chain throughput (`ViewSamples::throughput`), and a row of the matrix (a
//! pixel) is the sum of its samples in sample order (`ViewSamples::samples_of_pixel`), as the GPU's.
//!
//! The shading is one function, `crate::cpu::shade`, which the CPU backend runs for every element; the
//! oracle is that backend's arithmetic element by element. The ray tracer is the backend's (the CPU
//! backend's own; the GPU backend builds one on first use). Rows and columns run in parallel with rayon.
use super::LightMatrix;
use crate::error::{Error, Result};
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::view::ViewSamples;
use glam::Vec3;
use std::sync::Arc;

/// Elements per parallel chunk of `row_exact` / `column_exact` between interruption checks.
const ORACLE_CHUNK: usize = 4096;

/// Light j's contribution to pixel p (the sum over its view samples) with exact visibility: (A(p, j),
/// whether any shadow ray was unblocked).
pub fn exact_pixel(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, p: usize, j: usize) -> (Vec3, bool) {
    let mut samples = view.samples_of_pixel(p);
    let first = samples.next().unwrap_or(p);
    let (mut sum, mut lit) = exact_element(tracer, view, lights, first, j);
    for k in samples {
        let (v, l) = exact_element(tracer, view, lights, k, j);
        sum += v;
        lit |= l;
    }
    (sum, lit)
}

/// Light j's contribution to view sample i (throughput applied) with exact visibility: (value, whether
/// the shadow ray was unblocked; false also when the unshadowed contribution is 0 and no ray was cast).
pub fn exact_element(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, i: usize, j: usize) -> (Vec3, bool) {
    let s = crate::cpu::shade(tracer, view, lights, &crate::cpu::ShadingPoint::new(view, i), i, j);
    (s.value, s.lit)
}

impl LightMatrix {
    /// The ray tracer of the exact oracle (the CPU backend's own, or the GPU backend's built on first use).
    pub(crate) fn tracer(&self) -> Result<Arc<RayTracer>> {
        self.backend.tracer()
    }

    fn check_sample(&self, i: usize) -> Result<()> {
        let m = self.view.num_pixels();
        if i >= m {
            return Err(Error::invalid(format!("view sample index {i} is out of range for {m} view samples")));
        }
        Ok(())
    }

    /// A(i, j) by exact ray casting (module docs), RGB.
    ///
    /// Errors: `InvalidParameter` when i >= m or j >= n.
    pub fn element(&self, i: usize, j: usize) -> Result<[f32; 3]> {
        self.check_sample(i)?;
        self.check_indices(&[j])?;
        Ok(exact_pixel(&*self.tracer()?, &self.view, &self.lights, i, j).0.to_array())
    }

    /// Row i, A(i, :), by exact ray casting: n RGB values in light order.
    ///
    /// Errors: `InvalidParameter` when i >= m.
    pub fn row_exact(&self, i: usize) -> Result<Vec<[f32; 3]>> {
        self.check_sample(i)?;
        let tracer = self.tracer()?;
        crate::interrupt::par_map_chunked(self.lights.len(), ORACLE_CHUNK, |j| {
            exact_pixel(&tracer, &self.view, &self.lights, i, j).0.to_array()
        })
    }

    /// Column j, A(:, j), by exact ray casting: m RGB values, row 0 of the image first.
    ///
    /// Errors: `InvalidParameter` when j >= n.
    pub fn column_exact(&self, j: usize) -> Result<Vec<[f32; 3]>> {
        self.check_indices(&[j])?;
        let tracer = self.tracer()?;
        crate::interrupt::par_map_chunked(self.view.num_pixels(), ORACLE_CHUNK, |i| {
            exact_pixel(&tracer, &self.view, &self.lights, i, j).0.to_array()
        })
    }
}

#[cfg(test)]
mod tests;
