//! The field's many-light samplers on the light matrix's own shading and visibility: each draws lights
//! per view sample, shades them with `crate::cpu::shade` (the CPU backend's exact element: the same
//! BSDF, emission and shadow ray as every column of `LightMatrix`) and returns an unbiased estimate of
//! the view sample's row sum, `sum_j A(i, j)`.
//!
//! - `light_bvh_sampling`: k lights per view sample drawn from the light tree (`lights::light_tree`;
//!   Conty Estevez and Kulla 2018, pbrt-v4's `BVHLightSampler`), estimate mean(f / pdf).
//! - `ris`: resampled importance sampling (Talbot et al. 2005; the per-pixel core of ReSTIR DI,
//!   Bitterli et al. 2020, Sec. 3 and Alg. 1-2): M candidates from the light tree, one chosen by the
//!   unshadowed contribution, one shadow ray.
//! - `ris_spatial`: the same reservoirs combined with those of neighbouring pixels (ReSTIR DI's spatial
//!   reuse with unbiased balance-heuristic MIS weights, Bitterli et al. 2020, Sec. 4.3).
//! - `lightcuts` and `reconstruction_cuts` (Walter et al. 2005): deterministic cuts of a cluster tree
//!   (`cut_tree`) refined by upper bounds of each cluster's contribution, not unbiased estimators.
//! - `stochastic_lightcuts`: a cut of the light tree per view sample and one light sampled below each
//!   cut node (Yuksel 2019).
//! - `lightslice`: matrix slices with per-slice light clusterings refined from a global one (Ou and
//!   Pellacini 2011); not a sampler of the tree, it reuses MRCS's clustering (`crate::cluster`).
//!
//! `estimate_per_sample` runs an estimator k times per view sample (in parallel over view samples,
//! one random stream per view sample so that results do not depend on threads) and returns the image
//! (mean of the k estimates, view samples folded into their pixels) and, for k >= 2, the per-pixel
//! variance of that mean (the sample variance / k of each view sample, summed over a pixel's samples).
//!
//! Symbols: i view sample, j light, k samples per view sample, f the exact (shadowed) element A(i, j),
//! pdf the light tree's probability of j at i, m view samples.
pub mod cut_tree;
pub mod light_bvh_sampling;
pub mod lightcuts;
pub mod lightslice;
pub mod reconstruction_cuts;
pub mod ris;
pub mod ris_spatial;
pub mod stochastic_lightcuts;

pub use light_bvh_sampling::light_bvh_sampling;
pub use lightcuts::{lightcuts, Criterion, CutsEstimate};
pub use lightslice::{lightslice, LightSliceOptions};
pub use reconstruction_cuts::reconstruction_cuts;
pub use ris::ris;
pub use ris_spatial::ris_spatial;
pub use stochastic_lightcuts::stochastic_lightcuts;

use crate::cpu::ShadingPoint;
use crate::error::{Error, Result};
use crate::lights::light_tree::LightTree;
use crate::matrix::LightMatrix;
use glam::{DVec3, Vec3};
use rand_pcg::Pcg32;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// View samples per parallel chunk between interruption checks.
const CHUNK: usize = 4096;

/// An estimated image and its statistics.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// H * W * 3 floats: the estimate of the column sum (without `emitted`).
    pub image: Vec<f32>,
    /// H * W * 3 floats: the estimated variance of each pixel's value; None for k = 1.
    pub variance: Option<Vec<f32>>,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Seconds spent drawing, shading and tracing.
    pub seconds: f64,
}

/// Checks that `tree` was built over the lights of `a` and that k >= 1.
pub(crate) fn check_inputs(a: &LightMatrix, tree: &LightTree, k: usize, what: &str) -> Result<()> {
    if k == 0 {
        return Err(Error::invalid(format!("{what} must be >= 1, got 0")));
    }
    if tree.num_lights != a.lights.len() {
        return Err(Error::invalid(format!(
            "the light tree has {} lights but the light matrix has {}: build it over the matrix's LightSet",
            tree.num_lights,
            a.lights.len()
        )));
    }
    Ok(())
}

/// Runs `one(i, sp, rng, rays)` (one unbiased estimate of view sample i's row sum, counting its shadow
/// rays) `k` times per view sample with random stream `(seed, stream, i)` (module docs).
pub(crate) fn estimate_per_sample(
    a: &LightMatrix,
    k: usize,
    seed: u64,
    stream: u64,
    one: impl Fn(usize, &ShadingPoint, &mut Pcg32, &mut u64) -> Vec3 + Sync,
) -> Result<Estimate> {
    estimate_per_sample_with(a, k, seed, stream, |_, _| (), |i, sp, _: &(), rng, rays| one(i, sp, rng, rays))
}

/// `estimate_per_sample` with per-view-sample state: `prepare(i, sp)` runs once per surface view sample
/// and its result is passed to each of the k calls of `one`.
pub(crate) fn estimate_per_sample_with<S>(
    a: &LightMatrix,
    k: usize,
    seed: u64,
    stream: u64,
    prepare: impl Fn(usize, &ShadingPoint) -> S + Sync,
    one: impl Fn(usize, &ShadingPoint, &S, &mut Pcg32, &mut u64) -> Vec3 + Sync,
) -> Result<Estimate> {
    let t0 = Instant::now();
    let view = &a.view;
    let rays = AtomicU64::new(0);
    let per_sample = crate::interrupt::par_map_chunked(view.len(), CHUNK, |i| {
        let sp = ShadingPoint::new(view, i);
        if !sp.surface {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let mut rng = crate::lights::generate::sampling::stream(seed, stream, i as u64);
        let state = prepare(i, &sp);
        let (mut sum, mut sum2, mut r) = (DVec3::ZERO, DVec3::ZERO, 0u64);
        for _ in 0..k {
            let v = one(i, &sp, &state, &mut rng, &mut r).as_dvec3();
            sum += v;
            sum2 += v * v;
        }
        rays.fetch_add(r, Ordering::Relaxed);
        let kf = k as f64;
        let mean = sum / kf;
        let var_of_mean = if k > 1 { ((sum2 - sum * mean) / (kf - 1.0)).max(DVec3::ZERO) / kf } else { DVec3::ZERO };
        (mean, var_of_mean)
    })?;
    let flat = |f: fn(&(DVec3, DVec3)) -> DVec3| -> Vec<f32> {
        let v: Vec<f32> = per_sample.iter().flat_map(|s| f(s).as_vec3().to_array()).collect();
        if view.len() == view.num_pixels() {
            v
        } else {
            view.fold(&v, 3)
        }
    };
    let image = flat(|s| s.0);
    let variance = (k > 1).then(|| flat(|s| s.1));
    Ok(Estimate { image, variance, shadow_rays: rays.into_inner(), seconds: t0.elapsed().as_secs_f64() })
}

/// A uniform f64 in [0, 1).
#[inline]
pub(crate) fn uniform(rng: &mut Pcg32) -> f64 {
    use rand::RngExt;
    rng.random::<f64>()
}

/// Rec. 709 luminance.
#[inline]
pub(crate) fn luminance(v: Vec3) -> f64 {
    0.2126 * v.x as f64 + 0.7152 * v.y as f64 + 0.0722 * v.z as f64
}

#[cfg(test)]
mod tests;
