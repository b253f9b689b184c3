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
        let r = initial_reservoir(view, lights, tree, sp, i, candidates, rng);
        let Some((j, f, wo, dist)) = r.chosen else {
            return Vec3::ZERO;
        };
        *rays += 1;
        // 0 / 1, or a masked scene's expected transmittance.
        let v = crate::cpu::visibility_crossed(&tracer, view, lights, i, j, sp.p, sp.n_g, wo, dist).0;
        if v == 0.0 {
            return Vec3::ZERO;
        }
        f * (r.w as f32 * v)
    })
}

/// A one-sample reservoir after RIS (Bitterli et al. 2020, Alg. 2).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Reservoir {
    /// The chosen light with its unshadowed contribution, wo and distance at the reservoir's view sample.
    pub chosen: Option<(usize, Vec3, Vec3, f32)>,
    /// Sum of the resampling weights.
    pub w_sum: f64,
    /// Candidates seen (M).
    pub m: u32,
    /// The unbiased contribution weight W = w_sum / (M p_hat(y)); 0 without a choice.
    pub w: f64,
}

/// Steps 1-3 of the module docs at view sample i (prepared as `sp`).
pub(crate) fn initial_reservoir(
    view: &crate::view::ViewSamples,
    lights: &crate::lights::LightSet,
    tree: &LightTree,
    sp: &crate::cpu::ShadingPoint,
    i: usize,
    candidates: usize,
    rng: &mut rand_pcg::Pcg32,
) -> Reservoir {
    let mut r = Reservoir { m: candidates as u32, ..Default::default() };
    let mut p_hat_y = 0.0;
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
        r.w_sum += w;
        if uniform(rng) * r.w_sum < w {
            r.chosen = Some((j, f, wo, dist));
            p_hat_y = p_hat;
        }
    }
    if r.chosen.is_some() {
        r.w = r.w_sum / (candidates as f64 * p_hat_y);
    }
    r
}
