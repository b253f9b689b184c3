//! Importance sampling of VPLs by their estimated image contribution: Georgiev and Slusallek, "Simple and
//! Robust Iterative Importance Sampling of Virtual Point Lights", Eurographics 2010 short paper, Sec. 2-3
//! (`GenerateOptions::vpl_importance`, Python `generate_lights(vpl_importance=True)`).
//!
//! Candidates are traced as plain VPLs (`vpl::walk`, the same particle streams). Each candidate j gets a
//! Russian-roulette decision: it is accepted with probability
//!
//!   p_j = min(1, Phi_j / Phi_v + eps)                                                      (paper, Sec. 2)
//!
//! and an accepted VPL's flux is divided by p_j, a rejected one is dropped (the particle's path goes on
//! either way: the decision changes no later vertex). Then E[flux_j 1(u < p_j) / p_j] = flux_j for every
//! candidate, whatever p_j is (p_j > 0 by eps; it depends only on the candidate, never on the decision's
//! uniform), so every column sum keeps the plain VPLs' expectation: the estimator stays unbiased, only
//! its variance changes. Accepted VPLs that were below the target carry about Phi_v each ("all VPLs bring
//! the same power to the image"), so the power goes where the camera looks.
//!
//! - **Phi_j**, the image contribution of candidate j: the sum over the pilot view samples i (surface
//!   points at the pixel centres of a film of about `view_samples` pixels with the camera's aspect,
//!   delta chains resolved, throughput applied) of the luminance of `cpu::shade` -- the CPU backend's
//!   element A(i, j) with exact visibility (one shadow ray), both BSDFs and the clamped geometry term
//!   (the scene's VPL clamp, also for VSLs: the pilot shades them as points) -- with the candidate's
//!   flux before the division by N.
//! - **Phi_v**, the target contribution: the paper's Phi / N_VPL, the image's total indirect
//!   contribution shared among the requested VPL count M = `indirect`. Our fluxes are divided by the
//!   number N of traced particles, which is fixed before the main run (as `vpl` fixes it, so that the
//!   flux stays unbiased) such that M VPLs are accepted in expectation. In per-particle units
//!   tau = N Phi_v, p_j = min(1, Phi_j / tau + eps), and the two conditions (Phi_v = mu / M, expected
//!   acceptances N a(tau) = M) give one equation in tau, solved by bisection on a pilot batch of
//!   candidates (its own random streams, so N and tau do not depend on the main run):
//!
//!     h(tau) = (1/n) sum_j min(tau, Phi_j + eps tau) = mu,     mu = (1/n) sum_j Phi_j,
//!
//!   over the pilot's n particles; h is continuous and increasing with h(mu / K) <= mu <= h(mu / (eps K))
//!   (K = candidates per particle). Then a = mu / tau accepted VPLs per particle and N = ceil(M / a).
//! - **eps** (`accept_min`), the floor of p: keeps candidates that the pilot view samples do not see
//!   (but pixels between them might) unbiased; it also bounds the cost: a >= eps K, so at most M / eps
//!   candidates are traced (a pathological scene cannot loop: N is checked against
//!   `MAX_CANDIDATE_PARTICLES` before the main run and the error names `vpl_accept_min`).
//!
//! Cost: every candidate casts up to `view_samples` shadow rays (pilot and main run); generation runs
//! on the CPU only (there is no GPU light generation), the VPLs it makes are ordinary columns for both
//! backends, MRCS and every renderer. The pilot view needs a copy of the scene with the pilot camera.
//! Same seed -> same bits (random streams `STREAM_IMPORTANCE_PILOT`, `STREAM_PARTICLE` and
//! `STREAM_ACCEPT`, indexed by particle; parallel results collected in order).
//!
//! | paper / symbol | name here |
//! |---|---|
//! | Phi_i (a VPL's estimated image contribution) | `phi` (`contributions`, `PilotView`) |
//! | Phi_v (target contribution per VPL) | `tau / N` (`ImportanceStats::phi_v`) |
//! | p_i (acceptance probability) | `p_accept` |
//! | eps | `VplImportance::accept_min` |
//! | camera points (importons) | `PilotView` (`VplImportance::view_samples`) |
//! | N (requested VPLs) | M = `GenerateOptions::indirect` |
//! | paths traced | N = `ImportanceStats::particles` |
use super::pilot_view::PilotView;
use super::sampling::{stream, uniform, STREAM_ACCEPT, STREAM_IMPORTANCE_PILOT, STREAM_PARTICLE};
use super::vpl::{Tracer, Vpl};
use super::GenerateOptions;
use crate::error::{Error, Result};
use crate::lights::LightSet;

/// Default number of pilot view samples (pixel centres of the pilot film).
pub const DEFAULT_VIEW_SAMPLES: usize = 256;
/// Default floor eps of the acceptance probability.
pub const DEFAULT_ACCEPT_MIN: f32 = 0.01;
/// Most pilot view samples.
pub const MAX_VIEW_SAMPLES: usize = 1 << 16;
/// Particles of the pilot batch that fixes tau and N (fewer when `indirect` is smaller, at least 1024).
pub const PILOT_PARTICLES: usize = 16384;
/// Most candidate particles of the main run.
pub const MAX_CANDIDATE_PARTICLES: usize = 1 << 28;
/// Particles per parallel chunk between interruption checks.
const CHUNK: usize = 1024;

/// Options of VPL importance sampling (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VplImportance {
    /// About this many pilot view samples (pixel centres of a film with the camera's aspect).
    pub view_samples: usize,
    /// eps in (0, 1]: the floor of the acceptance probability (1 = every candidate accepted).
    pub accept_min: f32,
}

impl Default for VplImportance {
    fn default() -> Self {
        VplImportance { view_samples: DEFAULT_VIEW_SAMPLES, accept_min: DEFAULT_ACCEPT_MIN }
    }
}

impl VplImportance {
    /// Errors: `InvalidParameter` naming `vpl_view_samples` (outside 1 ..= `MAX_VIEW_SAMPLES`) or
    /// `vpl_accept_min` (NaN or outside (0, 1]).
    pub fn check(&self) -> Result<()> {
        if !(1..=MAX_VIEW_SAMPLES).contains(&self.view_samples) {
            return Err(Error::invalid(format!("vpl_view_samples must be in 1..={MAX_VIEW_SAMPLES}, got {}", self.view_samples)));
        }
        if !(self.accept_min > 0.0 && self.accept_min <= 1.0) {
            return Err(Error::invalid(format!("vpl_accept_min must be in (0, 1], got {}", self.accept_min)));
        }
        Ok(())
    }
}

/// What one importance-sampled generation did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportanceStats {
    /// Pilot view samples with a surface (camera hits and delta-chain samples).
    pub view_samples: usize,
    /// tau (per-particle units, module docs).
    pub tau: f64,
    /// Phi_v = tau / N: the target contribution of one accepted VPL to the pilot view.
    pub phi_v: f64,
    /// Mean candidates per particle (pilot).
    pub candidates_per_particle: f64,
    /// Expected fraction of candidates accepted (pilot): a / K.
    pub acceptance: f64,
    /// N, particles of the main run.
    pub particles: usize,
    /// Candidates traced and VPLs accepted in the main run.
    pub candidates: usize,
    pub accepted: usize,
}

/// Phi_j of each candidate (module docs): the luminance of its elements summed over the pilot view, with
/// the flux the candidate carries and the geometry-term clamp `clamp`.
fn contributions(pilot: &PilotView, tracer: &Tracer, vpls: &[Vpl], clamp: f32) -> Result<Vec<f64>> {
    let mut set = LightSet::new(tracer.center, tracer.radius);
    set.vpl_clamp = clamp;
    for v in vpls {
        v.push_into(&mut set, v.flux)?;
    }
    Ok((0..vpls.len()).map(|j| pilot.contribution(&tracer.rt, &set, j)).collect())
}

/// p_accept = min(1, phi / tau + eps).
#[inline]
pub fn p_accept(phi: f64, tau: f64, eps: f64) -> f64 {
    (phi / tau + eps).min(1.0)
}

/// tau solving h(tau) = (1/n) sum_j min(tau, phi_j + eps tau) = mu = (1/n) sum_j phi_j over the pilot's
/// `n` particles (module docs), by bisection in log tau; `None` when no phi is > 0.
pub fn solve_tau(phis: &[f64], n: usize, eps: f64) -> Option<f64> {
    let mu = phis.iter().sum::<f64>();
    let k = phis.len() as f64;
    if !(mu > 0.0 && mu.is_finite()) || n == 0 {
        return None;
    }
    // In sums over the pilot (the 1/n cancels): h(lo) <= lo k = mu, h(hi) >= eps hi k = mu.
    let h = |tau: f64| phis.iter().map(|&p| tau.min(p + eps * tau)).sum::<f64>();
    let (mut lo, mut hi) = (mu / k, mu / (eps * k));
    for _ in 0..200 {
        if hi <= lo * (1.0 + 1e-12) {
            break;
        }
        let mid = (lo * hi).sqrt();
        if h(mid) < mu {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(hi)
}

/// About `opts.indirect` importance-sampled VPLs (module docs) with fluxes divided by N and p_j, and
/// what the sampling did.
///
/// Errors: `InvalidParameter` for bad options (`VplImportance::check`), a pilot view in which the camera
/// sees no surface or that no pilot VPL reaches (then importance sampling has nothing to go by: use
/// plain VPLs), or more than `MAX_CANDIDATE_PARTICLES` particles needed; `Interrupted`.
pub(crate) fn trace_importance(tracer: &Tracer, opts: &GenerateOptions, imp: &VplImportance) -> Result<(LightSet, ImportanceStats)> {
    imp.check()?;
    let mut out = LightSet::new(tracer.center, tracer.radius);
    let pilot_view = PilotView::new(tracer.scene, &tracer.rt, imp.view_samples)?;
    if pilot_view.len() == 0 {
        return Err(Error::invalid(format!(
            "vpl_importance: the camera sees no surface at the pixel centres of the pilot film (vpl_view_samples={}); \
             use vpl_importance=False",
            imp.view_samples
        )));
    }
    let clamp = opts.clamp.unwrap_or_else(|| super::default_clamp(tracer.scene));
    let candidates = |family: u64, k: usize| -> Result<(Vec<Vpl>, Vec<f64>)> {
        let mut v = Vec::new();
        tracer.trace(opts.seed, family, k as u64, &mut v);
        let phi = contributions(&pilot_view, tracer, &v, clamp)?;
        Ok((v, phi))
    };
    // Pilot batch: tau and N.
    let n_pilot = PILOT_PARTICLES.min(opts.indirect.max(1024));
    let mut phis = Vec::new();
    for r in crate::interrupt::par_map_chunked(n_pilot, CHUNK, |k| candidates(STREAM_IMPORTANCE_PILOT, k).map(|(_, p)| p))? {
        phis.extend(r?);
    }
    if phis.is_empty() {
        return Ok((
            out,
            ImportanceStats {
                view_samples: pilot_view.len(),
                tau: 0.0,
                phi_v: 0.0,
                candidates_per_particle: 0.0,
                acceptance: 0.0,
                particles: 0,
                candidates: 0,
                accepted: 0,
            },
        ));
    }
    let eps = imp.accept_min as f64;
    let Some(tau) = solve_tau(&phis, n_pilot, eps) else {
        return Err(Error::invalid(format!(
            "vpl_importance: none of the {} pilot VPLs reaches the {} pilot view samples (raise vpl_view_samples, \
             or use vpl_importance=False)",
            phis.len(),
            pilot_view.len()
        )));
    };
    let mu = phis.iter().sum::<f64>() / n_pilot as f64;
    let per_particle = phis.len() as f64 / n_pilot as f64;
    let accepted_per_particle = mu / tau;
    let n = (opts.indirect as f64 / accepted_per_particle).ceil().max(1.0);
    if n > MAX_CANDIDATE_PARTICLES as f64 {
        return Err(Error::invalid(format!(
            "vpl_importance: {n:.3e} candidate particles would be needed for {} VPLs (acceptance {:.2e}); at most \
             {MAX_CANDIDATE_PARTICLES}: raise vpl_accept_min (now {})",
            opts.indirect,
            accepted_per_particle / per_particle,
            imp.accept_min
        )));
    }
    let n = n as usize;
    let inv_n = 1.0 / n as f64;
    let (mut n_candidates, mut n_accepted) = (0usize, 0usize);
    for r in crate::interrupt::par_map_chunked(n, CHUNK, |k| -> Result<(usize, Vec<Vpl>)> {
        let (vpls, phi) = candidates(STREAM_PARTICLE, k)?;
        let mut rng = stream(opts.seed, STREAM_ACCEPT, k as u64);
        let total = vpls.len();
        let mut kept = Vec::new();
        for (mut v, phi) in vpls.into_iter().zip(phi) {
            let p = p_accept(phi, tau, eps);
            if (uniform(&mut rng) as f64) < p {
                v.flux *= (inv_n / p) as f32;
                kept.push(v);
            }
        }
        Ok((total, kept))
    })? {
        let (total, kept) = r?;
        n_candidates += total;
        n_accepted += kept.len();
        for v in kept {
            v.push_into(&mut out, v.flux)?;
        }
    }
    let stats = ImportanceStats {
        view_samples: pilot_view.len(),
        tau,
        phi_v: tau * inv_n,
        candidates_per_particle: per_particle,
        acceptance: accepted_per_particle / per_particle,
        particles: n,
        candidates: n_candidates,
        accepted: n_accepted,
    };
    log::info!("vpl_importance: {stats:?}");
    Ok((out, stats))
}

#[cfg(test)]
mod tests;
