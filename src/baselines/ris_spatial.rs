//! RIS with spatial reuse (Bitterli et al., "Spatiotemporal reservoir resampling for real-time ray
//! tracing with dynamic direct lighting", SIGGRAPH 2020, Sec. 4, Alg. 3-4 and the unbiased combination
//! of Sec. 4.3, without temporal reuse and without visibility reuse).
//!
//! Pass 1: every view sample q builds k independent reservoirs r_{q,s} by RIS (`ris` module, M
//! candidates from the light tree, target p_hat_q = luminance of the unshadowed element at q).
//! Pass 2: for each pixel q and chain s, the reservoirs r_{n,s} of up to K neighbour pixels n (uniform
//! offsets in a square of half-width R pixels; background samples and neighbours whose shading normal
//! differs by more than 25 degrees are skipped, a choice made before looking at any reservoir) and q's own
//! are combined with the generalized balance heuristic (Bitterli et al. 2020, Sec. 4.3, the MIS form of
//! Eq. 16): y is chosen among their samples y_n with weights
//!
//! ```text
//! w_n = m_n(y_n) p_hat_q(y_n) W_n,   m_n(y) = M_n p_hat_n(y) / sum_k M_k p_hat_k(y)
//! ```
//!
//! and W = w_sum / p_hat_q(y). The m_n sum to 1 wherever some reservoir could have produced y, which
//! keeps the estimate unbiased where the neighbours' target functions differ from q's (measured: the
//! plain 1/Z weights of Alg. 6 had 1.6x the error of RIS without reuse on cbox-lights, where VPLs near
//! a surface make neighbours' targets very different). The estimate is f_q(y) V_q(y) W with one exact
//! shadow ray; the k chains are averaged and their spread gives the per-pixel variance. Delta-
//! chain samples (pixels' extra view samples) keep their own reservoir (no neighbours).
//!
//! Pixels share reservoirs, so their errors are correlated: the per-pixel variance is right, sums of it
//! over pixels underestimate the variance of image totals.
//!
//! Symbols: q pixel, n neighbour, s chain (k = `samples`), M = `candidates`, K = `neighbours`,
//! R = `radius`, p_hat target, W unbiased contribution weight, m_n MIS weight.
use super::ris::{initial_reservoir, Reservoir};
use super::{check_inputs, luminance, uniform, Estimate};
use crate::cpu::ShadingPoint;
use crate::error::{Error, Result};
use crate::lights::light_tree::LightTree;
use crate::matrix::LightMatrix;
use glam::{DVec3, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The random-stream families of the two passes.
const STREAM_RIS_INITIAL: u64 = 0x7269_7331;
const STREAM_RIS_SPATIAL: u64 = 0x7269_7332;
/// cos(25 degrees): neighbours with a more different shading normal are not reused.
const NORMAL_COS: f32 = 0.906_307_8;
/// View samples per parallel chunk between interruption checks.
const CHUNK: usize = 2048;

/// RIS with spatial reuse over K = `neighbours` pixels within R = `radius` (module docs).
///
/// Errors: `InvalidParameter` for samples, candidates or radius = 0, or a tree over other lights;
/// `Interrupted`.
pub fn ris_spatial(
    a: &LightMatrix,
    tree: &LightTree,
    samples: usize,
    candidates: usize,
    neighbours: usize,
    radius: u32,
    seed: u64,
) -> Result<Estimate> {
    check_inputs(a, tree, samples, "samples")?;
    check_inputs(a, tree, candidates, "candidates")?;
    if radius == 0 {
        return Err(Error::invalid("the spatial reuse radius must be >= 1 pixel, got 0"));
    }
    let t0 = Instant::now();
    let tracer = a.tracer()?;
    let (view, lights) = (&*a.view, &*a.lights);
    let k = samples;
    // Pass 1: k reservoirs per view sample.
    let initial: Vec<Vec<Reservoir>> = crate::interrupt::par_map_chunked(view.len(), CHUNK, |i| {
        let sp = ShadingPoint::new(view, i);
        if !sp.surface {
            return vec![Reservoir::default(); k];
        }
        let mut rng = crate::lights::generate::sampling::stream(seed, STREAM_RIS_INITIAL, i as u64);
        (0..k).map(|_| initial_reservoir(view, lights, tree, &sp, i, candidates, &mut rng)).collect()
    })?;
    let (w, h) = (view.width as i64, view.height as i64);
    let pixels = view.num_pixels();
    let rays = AtomicU64::new(0);
    // Pass 2: spatial reuse and shading.
    let per_sample = crate::interrupt::par_map_chunked(view.len(), CHUNK, |q| {
        let sp = ShadingPoint::new(view, q);
        if !sp.surface {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let mut rng = crate::lights::generate::sampling::stream(seed, STREAM_RIS_SPATIAL, q as u64);
        let (mut sum, mut sum2, mut r) = (DVec3::ZERO, DVec3::ZERO, 0u64);
        for s in 0..k {
            // The reused view samples: q itself, then the accepted neighbours.
            let mut reused: Vec<(usize, Option<ShadingPoint>)> = vec![(q, None)];
            if q < pixels {
                let (x, y) = ((q as i64) % w, (q as i64) / w);
                for _ in 0..neighbours {
                    let span = 2 * radius as i64 + 1;
                    let dx = (uniform(&mut rng) * span as f64) as i64 - radius as i64;
                    let dy = (uniform(&mut rng) * span as f64) as i64 - radius as i64;
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h {
                        continue;
                    }
                    let n = (ny * w + nx) as usize;
                    let spn = ShadingPoint::new(view, n);
                    if spn.surface && spn.n.dot(sp.n) >= NORMAL_COS {
                        reused.push((n, Some(spn)));
                    }
                }
            }
            // p_hat of light j at reused view sample number `k`.
            let p_hat_at = |k: usize, j: usize| -> f64 {
                let (n, spn) = &reused[k];
                let spn = spn.as_ref().unwrap_or(&sp);
                crate::cpu::shade_unshadowed(view, lights, spn, *n, j).map_or(0.0, |(g, ..)| luminance(g))
            };
            let mut w_sum = 0.0f64;
            let mut chosen: Option<(usize, Vec3, Vec3, f32, f64)> = None;
            for (kn, &(n, _)) in reused.iter().enumerate() {
                let rn = &initial[n][s];
                let Some((j, f_n, ..)) = rn.chosen else { continue };
                // p_hat at q of the neighbour's sample (q's own: its stored shading).
                let at_q =
                    if n == q { rn.chosen.map(|(_, f, wo, d)| (f, wo, d)) } else { crate::cpu::shade_unshadowed(view, lights, &sp, q, j) };
                let Some((f, wo, dist)) = at_q else { continue };
                let p_hat = luminance(f);
                if !(p_hat > 0.0) {
                    continue;
                }
                // Balance-heuristic MIS weight m_n(y_n) = M_n p_hat_n(y_n) / sum_k M_k p_hat_k(y_n), times
                // W_n M_n p_hat_n(y_n) = w_sum_n: w_n = p_hat_q(y_n) w_sum_n / sum_k M_k p_hat_k(y_n).
                let own = luminance(f_n);
                let den: f64 =
                    (0..reused.len()).map(|k| initial[reused[k].0][s].m as f64 * if k == kn { own } else { p_hat_at(k, j) }).sum();
                let wn = p_hat * rn.w_sum / den;
                w_sum += wn;
                if uniform(&mut rng) * w_sum < wn {
                    chosen = Some((j, f, wo, dist, p_hat));
                }
            }
            let value = match chosen {
                None => Vec3::ZERO,
                Some((j, f, wo, dist, p_hat)) => {
                    r += 1;
                    // 0 / 1, or a masked scene's expected transmittance.
                    let v = crate::cpu::visibility_crossed(&tracer, view, lights, q, j, sp.p, sp.n_g, wo, dist).0;
                    if v == 0.0 {
                        Vec3::ZERO
                    } else {
                        f * ((w_sum / p_hat) as f32 * v)
                    }
                }
            };
            let v = value.as_dvec3();
            sum += v;
            sum2 += v * v;
        }
        rays.fetch_add(r, Ordering::Relaxed);
        let kf = k as f64;
        let mean = sum / kf;
        let var = if k > 1 { ((sum2 - sum * mean) / (kf - 1.0)).max(DVec3::ZERO) / kf } else { DVec3::ZERO };
        (mean, var)
    })?;
    let flat = |f: fn(&(DVec3, DVec3)) -> DVec3| -> Vec<f32> {
        let v: Vec<f32> = per_sample.iter().flat_map(|s| f(s).as_vec3().to_array()).collect();
        if view.len() == pixels {
            v
        } else {
            view.fold(&v, 3)
        }
    };
    Ok(Estimate {
        image: flat(|s| s.0),
        variance: (k > 1).then(|| flat(|s| s.1)),
        shadow_rays: rays.into_inner(),
        seconds: t0.elapsed().as_secs_f64(),
    })
}
