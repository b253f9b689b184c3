//! Exact oracle of the light matrix on the CPU: A(i, j) by ray casting, to check the GPU's
//! shadow-mapped columns and rows element by element (issue 3, "Exact oracle").
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
mod tests {
    use super::*;
    use crate::gpu::GpuContext;
    use crate::lights::{generate_lights, GenerateOptions};
    use crate::matrix::{ColumnOptions, Visibility};
    use crate::scene::{load_scene, LoadOptions};
    use std::sync::Arc;

    /// GPU `RayTraced` columns cast the same rays as the oracle: only f32 rounding of the shading
    /// separates them (the spot falloff's acos is `acos_precise` on the GPU, within ~2 ulp of libm's).
    const REL_TOL: f32 = 1e-5;
    /// Absolute floor relative to the column maximum (rounding near zero).
    const ABS_TOL: f32 = 1e-6;
    /// Pixels allowed to differ: rays grazing an edge may be decided differently by the GPU's and the
    /// CPU's watertight tests (1e-4 of the pixels, as the BVH agreement measured in `gpu::bvh`).
    const MAX_MISMATCH_FRACTION: f64 = 1e-3;

    fn matrix(visibility: Visibility) -> LightMatrix {
        let xml = crate::testing::shared_dir().join("scenes/cbox-lights/scene.xml");
        let opts = LoadOptions { params: vec![("res".into(), "32".into())], size: None };
        let scene = load_scene(&xml, &opts).unwrap();
        let gen = GenerateOptions { area: 16, environment: 16, indirect: 200, seed: 3, ..Default::default() };
        let lights = generate_lights(&scene, &gen).unwrap();
        let ctx = GpuContext::shared().expect("a GPU adapter (software is fine) must exist in tests");
        let view = crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap();
        let opts = ColumnOptions { visibility, shadow_resolution: 256, ..Default::default() };
        LightMatrix::new(ctx, Arc::new(scene), Arc::new(view), Arc::new(lights), opts).unwrap()
    }

    #[test]
    fn oracle_matches_gpu_ray_traced_columns_for_every_kind() {
        let a = matrix(Visibility::RayTraced);
        let js = crate::testing::lights_of_every_kind(&a.lights, 3);
        let gpu = a.columns(&js).unwrap();
        let m = a.view.len();
        let (mut bad, mut lit) = (0usize, 0usize);
        for (k, &j) in js.iter().enumerate() {
            let cpu = a.column_exact(j).unwrap();
            let scale = cpu.iter().flatten().fold(0f32, |s, &v| s.max(v));
            for i in 0..m {
                let g = &gpu[(k * m + i) * 3..(k * m + i) * 3 + 3];
                lit += (cpu[i][0] > 0.0) as usize;
                if (0..3).any(|c| (g[c] - cpu[i][c]).abs() > REL_TOL * cpu[i][c].abs() + ABS_TOL * scale) {
                    bad += 1;
                }
            }
        }
        let frac = bad as f64 / (js.len() * m) as f64;
        eprintln!("{} lights: {bad} of {} elements differ ({lit} lit)", js.len(), js.len() * m);
        assert!(lit > js.len() * m / 10, "too few lit elements: {lit}");
        assert!(frac <= MAX_MISMATCH_FRACTION, "{frac} of the elements differ");
    }

    #[test]
    fn element_row_column_agree_and_indices_are_checked() {
        let a = matrix(Visibility::ShadowMap);
        let (m, n) = a.shape();
        let i = (m / 2) + 7;
        let row = a.row_exact(i).unwrap();
        assert_eq!(row.len(), n);
        for j in [0, 1, n / 2, n - 1] {
            assert_eq!(a.element(i, j).unwrap(), row[j]);
            assert_eq!(a.column_exact(j).unwrap()[i], row[j]);
        }
        assert!(row.iter().flatten().any(|&v| v > 0.0));
        for e in [a.element(m, 0).unwrap_err(), a.element(0, n).unwrap_err(), a.row_exact(m).unwrap_err(), a.column_exact(n).unwrap_err()] {
            assert!(matches!(e, Error::InvalidParameter(_)), "{e}");
            assert!(e.to_string().contains("out of range"), "{e}");
        }
    }
}
