//! Light-BVH importance sampling (Conty Estevez and Kulla, "Importance Sampling of Many Lights with
//! Adaptive Tree Splitting", HPG 2018, Sec. 4-5, without splitting; pbrt-v4's `BVHLightSampler`, Pharr
//! et al., "Physically Based Rendering", 4th ed., Sec. 12.6.3): for each view sample i, k lights j_1..j_k
//! drawn independently from the light tree's distribution pdf_i (`LightTree::sample`), each shaded
//! exactly with one shadow ray (`crate::cpu::shade`), and the estimate
//!
//! ```text
//! S_i = (1 / k) sum_s A(i, j_s) / pdf_i(j_s)
//! ```
//!
//! is unbiased for sum_j A(i, j) because pdf_i(j) > 0 wherever light j can light view sample i
//! (`lights::light_tree` module docs). A draw that finds no light (nothing can reach i) adds 0.
//!
//! Symbols: i view sample, j light, k = `samples`, pdf_i (`LightTree::pdf`), A(i, j) the exact element.
use super::{check_inputs, estimate_per_sample, uniform, Estimate};
use crate::error::Result;
use crate::lights::light_tree::LightTree;
use crate::matrix::LightMatrix;
use glam::Vec3;

/// The random-stream family of light-BVH sampling.
const STREAM_LIGHT_BVH: u64 = 0x6c62_7668;

/// k = `samples` light-tree samples per view sample of `a` (module docs).
///
/// Errors: `InvalidParameter` for samples = 0 or a tree over other lights; `Interrupted`.
pub fn light_bvh_sampling(a: &LightMatrix, tree: &LightTree, samples: usize, seed: u64) -> Result<Estimate> {
    check_inputs(a, tree, samples, "samples")?;
    let tracer = a.tracer()?;
    let (view, lights) = (&*a.view, &*a.lights);
    estimate_per_sample(a, samples, seed, STREAM_LIGHT_BVH, |i, sp, rng, rays| {
        let Some((j, pdf)) = tree.sample(sp.p, sp.n, || uniform(rng)) else {
            return Vec3::ZERO;
        };
        let s = crate::cpu::shade(&tracer, view, lights, sp, i, j);
        *rays += s.tested as u64;
        if s.lit {
            s.value / pdf as f32
        } else {
            Vec3::ZERO
        }
    })
}
