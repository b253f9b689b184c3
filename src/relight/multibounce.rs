//! The multiple-bounce matrix M of direct-to-indirect transfer by photon tracing from the gather samples
//! (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006,
//! Sec. 3.2 Eq. 2, 3.3 Eq. 7, 4.3 "The multiple-bounce matrix").
//!
//! Two ways to compute M are offered (`Multibounce`, `TransferOptions::multibounce`):
//! - `Gather`: the exact gather-to-gather transfer of `transfer` (the hierarchical gather run from every
//!   gather sample, exact visibility; relighting iterates it b - 1 times: M = K + ... + K^(b-1)).
//! - `Photons` (this module, the paper's method): every gather sample g with k_d(g) > 0 is a Lambertian
//!   emitter of unit radiance over its area A_g on the front of its geometric normal, placed where it
//!   emits in the final gather (`Transfer::emit_position`). It shoots P = `photons_per_sample` photons,
//!   directions cosine-distributed about n_g (stratified in sin^2 theta; a direction behind the emitting
//!   shading normal carries nothing, as in F_d), each with flux pi A_g / P (W per unit radiance). The
//!   photons are traced through the scene's BSDFs exactly as the light sources' particles
//!   (`lights::generate::vpl::walk`: BSDF sampling, the adjoint shading-normal correction, Russian
//!   roulette from the 3rd bounce) and deposited, with the id of the gather sample they left, at every
//!   non-delta hit of bounce 1 ..= b - 1 (b = `bounces`; the paper limits paths to 3). A photon stores its
//!   position, the geometric normal turned toward the side it arrived from, and its RGB flux.
//!   After tracing, a K-nearest query (K = `photon_neighbours`; `lights::photon_map`, a kiddo kd-tree) at
//!   every gather sample h with k_d(h) > 0 keeps the photons whose (turned) normal has a cosine >= 0.7
//!   with n_g(h) -- photons on h's surface, arrived on its emitting side -- and gives the row
//!
//!     M_E(h, g) = sum_{q from g} Phi_q / (pi r^2)    (RGB, r the distance to the K-th photon),
//!
//!   the irradiance at h per unit radiance leaving g, over paths of 1 ..= b - 1 bounces (RGB: the
//!   intermediate bounces colour it). Each row is laid out as the gather image, projected to 2D Haar
//!   wavelets (3 channels) and culled to `multibounce_coefficients` (area-weighted, Sec. 4.3; the
//!   paper's 40). Relighting adds, once (no iteration), B = B_1 + k_d / pi * (M_E^w W B_1) to the gather
//!   samples' direct radiance B_1 = k_d / pi E: the paper's (M + I) g_d with M = diag(k_d / pi) M_E.
//!
//! Default (`Photons`, P = 64, K = 400), measured against Mitsuba 3.9.1's path tracer (max_depth -1,
//! 1024 spp, reference noise 1.6%) on tests/data/relight_box.xml at 32x32, bounces 6, 100 final-gather
//! coefficients, 40 multi-bounce coefficients, relative L2 over the image (precompute on 2 cores):
//!
//! | n_g | gather (exact gather-to-gather) | photons P 16, K 100 | P 64, K 100 | P 64, K 400 | P 256, K 400 |
//! |---|---|---|---|---|---|
//! | 4^6 | 4.13% (0.96 s) | 3.86% (0.55 s) | 3.61% (0.72 s) | 3.80% (0.92 s) | 3.72% (1.88 s) |
//! | 4^7 | 20.1% (10.1 s) | 3.38% (7.8 s) | 3.36% (10.5 s) | 3.40% (10.7 s) | - |
//!
//! The exact gather-to-gather transfer point-samples 1 / d^2 between neighbouring gather samples, which
//! spikes as n_g grows (unclamped) and is iterated b - 1 times (with clamp = 100 it reaches 3.9% at 4^7,
//! photons 3.6%); the photon estimate is bounded by its K-nearest disk and applied once. So photons are
//! the default, at about the same precompute time. K = 400 (10x the kept coefficients, the paper's "K much higher than the
//! number of preserved wavelet coefficients") costs little over K = 100 for a smoother M.
//!
//! Estimator: the photon density estimate is consistent, not unbiased: it blurs M over the K-nearest
//! disk (radius ~ sqrt(K A / (pi N_photons))) and loses the photons of other surfaces inside that disk
//! near edges and corners (the normal test), which darkens M there. Its noise falls as photons grow.
//! Sizes: about n_g P (1 + rho + rho^2 ...) photons of 40 bytes each.
use super::haar::{self, SparseRow};
use super::hierarchy::ClusterHierarchy;
use super::transfer::{Transfer, TransferOptions};
use crate::error::{Error, Result};
use crate::lights::gather::GatherCloud;
use crate::lights::generate::sampling::{cosine_hemisphere, stream, to_world, uniform};
use crate::lights::generate::vpl::walk;
use crate::lights::photon_map::PhotonMap;
use crate::raytrace::{offset_p, RayTracer};
use crate::scene::Scene;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// Photons shot from each gather sample when none are given (measured: module docs).
pub const DEFAULT_PHOTONS_PER_SAMPLE: usize = 64;
/// Photons of each K-nearest query when none are given.
pub const DEFAULT_PHOTON_NEIGHBOURS: usize = 400;
/// Largest photons_per_sample and photon_neighbours accepted.
pub const MAX_PHOTON_COUNT: usize = 1 << 20;
/// Random stream family of the photons ("mbph").
const STREAM_MULTIBOUNCE: u64 = 0x6d62_7068;
/// Cosine between a photon's normal and the gather sample's below which the photon is another surface's.
const PHOTON_NORMAL_COS: f32 = 0.7;
/// Host bytes of one stored photon (with kd-tree overhead).
const PHOTON_BYTES: u64 = 64;
/// Receivers per parallel task and between interruption checks.
const ROW_CHUNK: usize = 16;
const ROW_BLOCK: usize = 256;

/// How the multi-bounce matrix M is computed (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Multibounce {
    /// The exact hierarchical gather-to-gather transfer, iterated b - 1 times.
    Gather,
    /// The paper's photon tracing from the gather samples with K-nearest density estimation.
    Photons,
}

impl Multibounce {
    /// "gather" or "photons".
    pub fn parse(s: &str) -> Result<Multibounce> {
        match s {
            "gather" => Ok(Multibounce::Gather),
            "photons" => Ok(Multibounce::Photons),
            _ => Err(Error::invalid(format!("multibounce must be 'photons' or 'gather', got '{s}'"))),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Multibounce::Gather => "gather",
            Multibounce::Photons => "photons",
        }
    }
}

/// Checks the photon options (`photons_per_sample`, `photon_neighbours` in 1 ..= `MAX_PHOTON_COUNT`).
pub fn check_options(opts: &TransferOptions) -> Result<()> {
    for (name, v) in [("photons_per_sample", opts.photons_per_sample), ("photon_neighbours", opts.photon_neighbours)] {
        if !(1..=MAX_PHOTON_COUNT).contains(&v) {
            return Err(Error::invalid(format!("{name} must be in 1 ..= {MAX_PHOTON_COUNT}, got {v}")));
        }
    }
    Ok(())
}

/// One deposited photon.
struct Photon {
    position: Vec3,
    /// Geometric normal turned toward the side the photon arrived from.
    normal: Vec3,
    flux: Vec3,
    source: u32,
}

/// The photon-mapped rows of M_E (3 channels, one per gather sample; empty for k_d = 0) and the number
/// of photons deposited.
pub struct PhotonRows {
    pub rows: Vec<SparseRow>,
    pub photons: u64,
}

/// Traces the photons of every emitting gather sample and density-estimates the culled wavelet rows of
/// M_E (module docs); `progress(done, total)` over the receivers.
///
/// Errors: `OutOfMemory` when the photons would not fit; `Interrupted`.
#[allow(clippy::too_many_arguments)]
pub fn photon_rows(
    scene: &Scene,
    tracer: &RayTracer,
    cloud: &GatherCloud,
    hierarchy: &ClusterHierarchy,
    emit_position: &[Vec3],
    emit_normal: &[Vec3],
    opts: &TransferOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PhotonRows> {
    let n = cloud.len();
    let per = opts.photons_per_sample;
    let emits = |g: usize| cloud.k_d[g].max_element() > 0.0 && cloud.geo_normal[g] != Vec3::ZERO && cloud.area[g] > 0.0;
    let emitters = (0..n).filter(|&g| emits(g)).count() as u64;
    // Expected deposits: a few per photon (1 + rho + rho^2 ... <= bounces - 1).
    let depth = opts.bounces.saturating_sub(1).min(4) as u64;
    crate::memory::check_host(
        &format!("{} photons from {emitters} gather samples", emitters * per as u64),
        crate::memory::product(&[emitters, per as u64, depth, PHOTON_BYTES]),
    )?;
    let max_depth = opts.bounces.saturating_sub(1);
    let traced = crate::interrupt::par_map_chunked(n, 16, |g| {
        let mut out = Vec::new();
        if max_depth == 0 || !emits(g) {
            return out;
        }
        let n_g = cloud.geo_normal[g];
        let phi = Vec3::splat(PI * cloud.area[g] / per as f32);
        let mut rng = stream(opts.seed, STREAM_MULTIBOUNCE, g as u64);
        for k in 0..per {
            let (u1, u2) = ((k as f32 + uniform(&mut rng)) / per as f32, uniform(&mut rng));
            let w = to_world(n_g, cosine_hemisphere(u1, u2));
            if w.dot(emit_normal[g]) <= 0.0 {
                continue;
            }
            let o = offset_p(emit_position[g], n_g, w);
            walk(scene, tracer, o, w, phi, false, &mut rng, 1, max_depth, &mut |v| {
                let side = if v.incident.dot(v.n_g) >= 0.0 { v.n_g } else { -v.n_g };
                out.push(Photon { position: v.position, normal: side, flux: v.flux, source: g as u32 });
            });
        }
        out
    })?;
    let photons: Vec<Photon> = traced.into_iter().flatten().collect();
    let positions: Vec<Vec3> = photons.iter().map(|p| p.position).collect();
    let map = PhotonMap::new(&positions);
    let side = hierarchy.side();
    let keep = opts.multibounce_coefficients;
    let mut rows = Vec::with_capacity(n);
    let mut start = 0;
    while start < n {
        let end = (start + ROW_BLOCK).min(n);
        let part = crate::interrupt::par_map_chunked(end - start, ROW_CHUNK, |k| -> Result<SparseRow> {
            let h = start + k;
            let n_h = cloud.geo_normal[h];
            if !emits(h) || photons.is_empty() {
                return Ok(SparseRow::default());
            }
            let (near, r2) = map.nearest(cloud.position[h], opts.photon_neighbours);
            if !(r2 > 0.0) {
                return Ok(SparseRow::default());
            }
            let mut dense = vec![0f32; 3 * n];
            let scale = 1.0 / (PI * r2);
            for q in near {
                let p = &photons[q];
                if p.normal.dot(n_h) >= PHOTON_NORMAL_COS {
                    let s = 3 * p.source as usize;
                    for (c, v) in p.flux.to_array().into_iter().enumerate() {
                        dense[s + c] += v * scale;
                    }
                }
            }
            let mut image = hierarchy.to_image(&dense, 3);
            haar::forward(&mut image, side, 3)?;
            haar::cull_area_weighted(&image, side, 3, keep)
        })?;
        for r in part {
            rows.push(r?);
        }
        start = end;
        progress(start, n);
    }
    Ok(PhotonRows { rows, photons: photons.len() as u64 })
}

/// The multi-bounce radiance k_d(h) / pi (M_E^w W B_1)(h) (RGB per gather sample, sample order) of the
/// direct radiance `b1` (sample order), to be added to it (module docs).
///
/// Errors: `InvalidParameter` when `b1` or the rows do not match the cloud; `Interrupted`.
pub fn apply(t: &Transfer, b1: &[Vec3]) -> Result<Vec<Vec3>> {
    let n = t.cloud.len();
    if b1.len() != n || t.photon_rows.len() != n {
        return Err(Error::invalid(format!("{} radiance values and {} photon rows for {n} gather samples", b1.len(), t.photon_rows.len())));
    }
    let flat: Vec<f32> = b1.iter().flat_map(|v| v.to_array()).collect();
    let mut bw = t.hierarchy.to_image(&flat, 3);
    haar::forward(&mut bw, t.hierarchy.side(), 3)?;
    crate::interrupt::par_map_chunked(n, 256, |h| {
        let row = &t.photon_rows[h];
        let mut s = Vec3::ZERO;
        for (k, &j) in row.index.iter().enumerate() {
            let (j, v) = (3 * j as usize, &row.value[3 * k..3 * k + 3]);
            s += Vec3::new(v[0] * bw[j], v[1] * bw[j + 1], v[2] * bw[j + 2]);
        }
        t.cloud.k_d[h] * FRAC_1_PI * s
    })
}

#[cfg(test)]
mod tests;
