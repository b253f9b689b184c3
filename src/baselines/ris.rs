//! Resampled importance sampling of lights (Talbot, Cline, Egbert, "Importance Resampling for Global
//! Illumination", EGSR 2005; the streaming form of Bitterli et al., "Spatiotemporal reservoir
//! resampling for real-time ray tracing with dynamic direct lighting", SIGGRAPH 2020, Sec. 2-3, Alg. 2,
//! without temporal or spatial reuse). Per view sample i and per output sample:
//!
//! 1. M candidates x_1..x_M drawn independently from the light tree (source pdf p(x), `LightTree::sample`);
//! 2. target p_hat(x) = luminance of the unshadowed contribution of x (`crate::cpu::shade_unshadowed`:
//!    the element A(i, x) without its visibility), resampling weight w_m = p_hat(x_m) / p(x_m);
//! 3. y chosen among the candidates with probability w_m / w_sum (a one-sample reservoir);
//! 4. one shadow ray for y and the estimate f(y) W with W = w_sum / (M p_hat(y)) (Eq. 6 of Bitterli et
//!    al.): unbiased because p_hat > 0 wherever A(i, x) != 0 (A's channels are non-negative) and the
//!    source pdf covers every such x.
//!
//! k output samples per view sample are averaged (independent reservoirs). Cost per output: M tree
//! traversals and M unshadowed shadings, one shadow ray.
//!
//! Symbols: M = `candidates`, k = `samples`, p source pdf, p_hat target, w resampling weight, W the
//! unbiased contribution weight, y the chosen light, f(y) = A(i, y).
use super::{check_inputs, estimate_per_sample, luminance, uniform, Estimate};
use crate::error::Result;
use crate::lights::light_tree::LightTree;
use crate::matrix::LightMatrix;
use glam::Vec3;

/// The random-stream family of RIS.
const STREAM_RIS: u64 = 0x7269_7321;

/// RIS with M = `candidates` light-tree candidates, k = `samples` outputs per view sample (module docs).
///
/// Errors: `InvalidParameter` for samples = 0, candidates = 0 or a tree over other lights; `Interrupted`.
pub fn ris(a: &LightMatrix, tree: &LightTree, samples: usize, candidates: usize, seed: u64) -> Result<Estimate> {
    check_inputs(a, tree, samples, "samples")?;
    check_inputs(a, tree, candidates, "candidates")?;
    let tracer = a.tracer()?;
    let (view, lights) = (&*a.view, &*a.lights);
    estimate_per_sample(a, samples, seed, STREAM_RIS, |i, sp, rng, rays| {
        let mut w_sum = 0.0f64;
        // The chosen candidate: (light, f, wo, dist, p_hat).
        let mut chosen: Option<(usize, Vec3, Vec3, f32, f64)> = None;
        for _ in 0..candidates {
            let Some((j, pdf)) = tree.sample(sp.p, sp.n, || uniform(rng)) else {
                continue;
            };
            let Some((f, wo, dist)) = crate::cpu::shade_unshadowed(view, lights, sp, i, j) else {
                continue;
            };
            let p_hat = luminance(f);
            if !(p_hat > 0.0) {
                continue;
            }
            let w = p_hat / pdf;
            w_sum += w;
            if uniform(rng) * w_sum < w {
                chosen = Some((j, f, wo, dist, p_hat));
            }
        }
        let Some((j, f, wo, dist, p_hat)) = chosen else {
            return Vec3::ZERO;
        };
        *rays += 1;
        if crate::cpu::light_blocked(&tracer, lights, j, sp.p, sp.n_g, wo, dist) {
            return Vec3::ZERO;
        }
        f * (w_sum / (candidates as f64 * p_hat)) as f32
    })
}
