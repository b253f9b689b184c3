//! Glossy highlights of area and environment emitters: BSDF sampling combined with the light samples by
//! multiple importance sampling (Veach and Guibas, "Optimally Combining Sampling
//! Techniques for Monte Carlo Rendering", SIGGRAPH 1995, Sec. 4, the power heuristic; Veach's thesis Ch. 9).
//!
//! The many-light columns sample an emitter by its light samples: an area emitter e of area A_e by n_e
//! points, one per equal-area stratum (`lights::generate::area`); a uniform environment by one
//! directional light per stratum of solid angle 4 pi / n. A BSDF lobe narrower than the solid angle one
//! light sample stands for (a rough plastic of alpha 0.005 reflecting a sphere light) is then
//! undersampled: the highlight is a few bright points or missing. For such "glossy" view samples a second
//! strategy, n_B BSDF samples per view sample, covers the lobe, and both are weighted so that every
//! direction is counted once (the power heuristic, exponent 2):
//!     w_L(wo) = q_L^2 / (q_L^2 + (n_B p_B)^2),   w_B(wo) = (n_B p_B)^2 / (q_L^2 + (n_B p_B)^2) = 1 - w_L,
//! with q_L = n_L p_L the density (1/sr) with which the light samples cover wo and p_B the BSDF sampling
//! density of wo. The BSDF strategy samples the microfacet lobe only (h with density D(h) cos theta_h,
//! isotropic alpha = sqrt(alpha_u alpha_v), wo = reflect(wi, h), p_B = D(h) cos theta_h / (4 |wo . h|)):
//! the light samples already cover every direction toward their emitters (their strata tile the
//! emitter), so the BSDF strategy need only add where it is better -- the narrow lobe -- and spends no
//! rays on the diffuse lobe, which the light samples handle well (w_B ~ 0 there):
//! - an area-light sample j (stratum area A_j = A_e / n_e, `LightSet::mis_measure`) at distance d with
//!   emission cosine cos_l: q_L = d^2 / (A_j cos_l) (area density 1 / A_j turned into solid angle);
//!   a BSDF ray hitting emitter e at distance t with cos_l: q_L = t^2 / (A_j cos_l), the same density;
//! - an environment stratum of solid angle Omega: q_L = 1 / Omega (a BSDF ray that escapes: the Omega
//!   of the stratum whose direction is nearest, where the strata differ in size, `env_visibility`).
//! The matrix entry A(i, j) of such a light is multiplied by w_L (`light_weight`; columns, rows, the
//! oracle, CPU and GPU alike: `shaders/common/glossy.wgsl` is the WGSL twin), so there is still one column
//! per light and MRCS and every renderer use the matrix unchanged; the BSDF strategy is a per-pixel image
//! (`bsdf_image`: sum over the n_B samples of f cos L w_B / (n_B p_B), exact visibility by the CPU BVH,
//! seeded) added to `LightMatrix::emitted`, which every renderer adds to its image.
//!
//! Choices, measured on the Veach plates (tests/data/veach_plates.xml, 64 x 48, against the Mitsuba
//! reference; docs/validation/accuracy.md, "Glossy highlights"): the power heuristic beat the balance heuristic (at 4,096 area
//! points and n_B = 128: 0.77% against 1.25% relative L2 on the plates); the BSDF samples are jittered on a
//! floor(sqrt(n_B))^2 grid of the (u1, u2) square (a one-pixel highlight of a tiny sphere is a hit/miss
//! edge in that square: stratified, its error falls faster than 1 / sqrt(n_B)); a rule that left a
//! lobe to the light samples alone where at least K of them fall in its solid angle 4 pi alpha^2 cos_i
//! (tried K = 4, 16, 64) was worse at every K (a lobe's tails hold the error), so the weights decide
//! everywhere.
//!
//! Rule (which view samples are glossy): a sample whose BSDF has a rough lobe (`roughplastic`,
//! `roughconductor` or `principled`'s GGX specular lobe, alone or as a component of a `blendbsdf`, float or
//! texture weight) with isotropic GGX/Beckmann alpha = sqrt(alpha_u alpha_v) below
//! `GlossyOptions::roughness` gets `bsdf_samples` BSDF samples; all others (diffuse, plastic, smooth,
//! blends of those) keep w_L = 1 and pure many-light columns. The threshold compares the lobe with the
//! light density: a lobe of roughness alpha spans about pi alpha^2 sr around the mirror direction, a light
//! sample stands for Omega_j = A_j cos_l / d^2; light samples resolve the lobe when several fall in it,
//! i.e. alpha >~ sqrt(Omega_j / pi) times a few.
//! Because both strategies are weighted, the choice affects only noise and cost, never the expectation:
//! a sample below the threshold that the light samples would have resolved loses nothing (w_L stays
//! near 1 where q_L >> n_B p_B). The default `DEFAULT_ROUGHNESS` (0.2) takes every Veach plate
//! (alpha <= 0.1) at 1k-4k area points; rougher lobes (alpha 0.2 spans ~0.5 sr) are resolved by a few
//! thousand light samples of an emitter in view.
//!
//! A blend's BSDF strategy (`strategy_lobes`, `sample`, `strategy_pdf`) is Mitsuba's `blendbsdf` sampling
//! restricted to the lobes above: a component is chosen by its weight (the second if u1 < w, u1 rescaled
//! and reused), its microfacet lobe is sampled as a lone rough record's, and p_B is the weighted mixture
//! (1 - w) p_0 + w p_1 of the components' lobe pdfs (used in both weights and in f / p_B, f the whole
//! blend); a component without a rough lobe (diffuse, plastic, smooth) is left to the light
//! samples like a rough plastic's diffuse lobe, and the weights are renormalised over the rough
//! component(s) (one rough component takes every sample, p_B its own pdf). Measured on
//! tests/data/glossy_blend.xml (tests/lights/test_glossy.py).
//! `principled` fits the same machinery: its specular lobe is GGX of (alpha_u, alpha_v) =
//! `dist_params(anisotropic, roughness)`, sampled and weighted like a rough conductor's (isotropic
//! sqrt(alpha_u alpha_v), front side, reflection); its other lobes are left to the light samples as a
//! rough plastic's diffuse lobe is: diffuse, sheen, transmission, the back side (p_B = 0 there, w_L = 1)
//! and the GTR1 clearcoat (alpha down to 0.001: a sharp clearcoat's highlights stay with the light samples
//! alone, covered only where they overlap the specular lobe). Measured on tests/data/glossy_principled.xml.
//!
//! Lights that BSDF sampling cannot hit, or whose density is unknown, keep w_L = 1 and the BSDF strategy
//! ignores them (so nothing is counted twice or dropped): delta lights, VPLs, user-made oriented points,
//! importance-allocated environment strata (`env_importance`: runs of unequal solid angle; the
//! visibility-allocated strata of `env_visibility` are cells, and keep MIS), subsets of a
//! light set (`LightSet::select`), textured emitters are included (the strata stay equal-area).
//! Deviations: the environment's light strategy is the deterministic stratum quadrature (one direction per
//! stratum), weighted as if its direction were uniform in the stratum; near an area-light patch
//! (`lights::patch`) the light strategy's glossy value is already the deviation documented there.
//!
//! Symbols: i view sample, j light, wi / wo directions to the viewer / the light (local: in the shading
//! frame), n_B = `bsdf_samples` (`ViewSamples::bsdf_samples`), p_B BSDF pdf (1/sr), q_L light density
//! (1/sr), A_j stratum area (m^2), Omega stratum solid angle (sr), w_L / w_B the MIS weights.
use crate::error::{Error, Result};
use crate::lights::generate::environment::Environment;
use crate::lights::generate::sampling::{reflect, sample_microfacet, stream, uniform, STREAM_GLOSSY};
use crate::lights::{LightKind, LightSet};
use crate::matrix::emitted::AreaRadiance;
use crate::raytrace::{spawn_ray, RayTracer};
use crate::scene::Scene;
use crate::shading::bsdf::{
    eval_records, microfacet_d, FLAG_BLEND, FLAG_GGX, FLAG_TWOSIDED, KIND_PRINCIPLED, KIND_ROUGHCONDUCTOR, KIND_ROUGHPLASTIC,
};
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;

/// Default roughness threshold (module docs).
pub const DEFAULT_ROUGHNESS: f32 = 0.2;
/// Default BSDF samples per glossy view sample.
pub const DEFAULT_BSDF_SAMPLES: u32 = 256;
/// Largest accepted `bsdf_samples`.
pub const MAX_BSDF_SAMPLES: u32 = 65_536;

/// Which view samples are glossy and how many BSDF samples they get (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlossyOptions {
    /// Samples whose lobe alpha is below this (in [0, 1]; 0 = none) are glossy.
    pub roughness: f32,
    /// n_B, BSDF samples per glossy view sample (>= 1 when `roughness` > 0).
    pub bsdf_samples: u32,
    /// Seed of the BSDF samples.
    pub seed: u64,
}

impl Default for GlossyOptions {
    fn default() -> Self {
        GlossyOptions { roughness: DEFAULT_ROUGHNESS, bsdf_samples: DEFAULT_BSDF_SAMPLES, seed: 0 }
    }
}

impl GlossyOptions {
    /// No glossy samples (pure many-light columns everywhere).
    pub fn off() -> Self {
        GlossyOptions { roughness: 0.0, bsdf_samples: 0, seed: 0 }
    }

    /// Errors: `InvalidParameter` for a roughness outside [0, 1] (or NaN), or `bsdf_samples` of 0 (with a
    /// positive roughness) or above `MAX_BSDF_SAMPLES`.
    pub fn check(&self) -> Result<()> {
        if !(0.0..=1.0).contains(&self.roughness) {
            return Err(Error::invalid(format!(
                "glossy_roughness must be in [0, 1] (the GGX/Beckmann alpha below which view samples get BSDF samples; 0 = off), got {}",
                self.roughness
            )));
        }
        if self.bsdf_samples > MAX_BSDF_SAMPLES || (self.roughness > 0.0 && self.bsdf_samples == 0) {
            return Err(Error::invalid(format!(
                "bsdf_samples must be in 1..={MAX_BSDF_SAMPLES} when glossy_roughness > 0, got {}",
                self.bsdf_samples
            )));
        }
        Ok(())
    }
}

/// The isotropic alpha of a record with a rough lobe the BSDF strategy samples (roughplastic /
/// roughconductor, principled's GGX specular lobe; one record: a blend's first record answers for its
/// own lobe).
pub fn lobe_alpha(b: &GpuBsdf) -> Option<f32> {
    matches!(b.kind, KIND_ROUGHPLASTIC | KIND_ROUGHCONDUCTOR | KIND_PRINCIPLED).then(|| (b.alpha_u * b.alpha_v).sqrt())
}

/// Whether record `b`'s lobe is GGX (principled's always is), else Beckmann.
fn lobe_ggx(b: &GpuBsdf) -> bool {
    b.flags & FLAG_GGX != 0 || b.kind == KIND_PRINCIPLED
}

/// The lobes the BSDF strategy samples at record `i` of a record array (`ViewSamples::bsdf`: a blend's
/// second record past `len()`, `shading::bsdf::link_blend`), each with the probability that it is chosen
/// (module docs): a roughplastic / roughconductor / principled record alone (probability 1); a blend's
/// rough records, chosen by their blend weights (1 - w, w) renormalised over the rough ones (both rough:
/// exactly Mitsuba's `blendbsdf` choice; one rough: it takes every sample). Empty when there is none.
pub fn strategy_lobes(records: &[GpuBsdf], i: usize) -> ([(GpuBsdf, f32); 2], usize) {
    let b = records[i];
    let mut out = [(b, 0.0f32); 2];
    if b.flags & FLAG_BLEND == 0 {
        let n = usize::from(lobe_alpha(&b).is_some());
        out[0].1 = 1.0;
        return (out, n);
    }
    let w = b.extra[2];
    let second = records.get(b.extra[3].to_bits() as usize).copied();
    // (record, blend weight) of the rough records with a positive weight.
    let rough = |r: Option<GpuBsdf>, p: f32| r.filter(|r| p > 0.0 && lobe_alpha(r).is_some()).map(|r| (r, p));
    let mut n = 0;
    for (r, p) in [rough(Some(b), 1.0 - w), rough(second, w)].into_iter().flatten() {
        out[n] = (r, p);
        n += 1;
    }
    let total: f32 = out[..n].iter().map(|(_, p)| p).sum();
    for lobe in &mut out[..n] {
        lobe.1 /= total;
    }
    (out, n)
}

/// The smallest alpha among the lobes the BSDF strategy samples at record `i` (`strategy_lobes`); None
/// when it samples none (diffuse, plastic, smooth, a blend of those).
pub fn glossy_alpha(records: &[GpuBsdf], i: usize) -> Option<f32> {
    let (lobes, n) = strategy_lobes(records, i);
    lobes[..n].iter().filter_map(|(r, _)| lobe_alpha(r)).reduce(f32::min)
}

/// n_B of every view sample under `opts` (0 = not glossy; background samples are never glossy).
///
/// Errors: `opts.check()`'s.
pub fn bsdf_samples_per_view_sample(view: &ViewSamples, opts: &GlossyOptions) -> Result<Vec<u32>> {
    opts.check()?;
    Ok((0..view.len())
        .map(|i| match glossy_alpha(&view.bsdf, i) {
            Some(a) if view.shape_index[i] >= 0 && a < opts.roughness => opts.bsdf_samples,
            _ => 0,
        })
        .collect())
}

/// `wi`, `wo` on the side `wi` lies (a `twosided` seen from below flips both), or None below a one-sided BSDF.
fn upper(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> Option<(Vec3, Vec3, bool)> {
    let flip = b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0;
    let f = if flip { Vec3::new(1.0, 1.0, -1.0) } else { Vec3::ONE };
    (wi.z * f.z > 0.0).then_some((wi * f, wo * f, flip))
}

/// p_B(wo) of one rough lobe: D(h) cos theta_h / (4 |wo . h|) (module docs) for record `b` at local `wi`,
/// `wo`; 0 where it samples nothing. Twin of `glossy_lobe_pdf` in `shaders/common/glossy.wgsl`.
pub fn bsdf_pdf(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> f32 {
    let Some((wi, wo, _)) = upper(b, wi, wo) else { return 0.0 };
    if !(wo.z > 0.0) {
        return 0.0;
    }
    let alpha = (b.alpha_u * b.alpha_v).sqrt();
    let h = (wi + wo).normalize();
    microfacet_d(lobe_ggx(b), alpha, alpha, h) * h.z / (4.0 * wo.dot(h).abs())
}

/// p_B(wo): the BSDF strategy's density at record `i` of a record array: the mixture over its lobes
/// (`strategy_lobes`) of their `bsdf_pdf`, weighted by their choice probabilities (one lobe: its own
/// pdf). Twin of `glossy_bsdf_pdf` in `shaders/common/glossy.wgsl`.
pub fn strategy_pdf(records: &[GpuBsdf], i: usize, wi: Vec3, wo: Vec3) -> f32 {
    let (lobes, n) = strategy_lobes(records, i);
    let mut pdf = 0.0;
    for (r, p) in &lobes[..n] {
        pdf += p * bsdf_pdf(r, wi, wo);
    }
    pdf
}

/// One sample of rough lobe `b` at local `wi` (microfacet normal with density D(h) cos theta_h,
/// reflected); None below a one-sided BSDF.
fn sample_lobe(b: &GpuBsdf, wi: Vec3, u1: f32, u2: f32) -> Option<Vec3> {
    let (wi_up, _, flip) = upper(b, wi, Vec3::Z)?;
    let alpha = (b.alpha_u * b.alpha_v).sqrt();
    let mut wo = reflect(wi_up, sample_microfacet(lobe_ggx(b), alpha, u1, u2));
    if flip {
        wo.z = -wo.z;
    }
    Some(wo)
}

/// One BSDF-strategy sample at record `i` of a record array, local `wi`: (local wo, f(wi, wo) / p_B, p_B)
/// with f the whole BSDF (`eval_records`, a blend's both records) and p_B = `strategy_pdf`, or None when
/// it leaves below the surface or the record has no lobe to sample. A blend chooses its lobe with `u1`
/// (the second if u1 < its probability, as Mitsuba's `blendbsdf`) and reuses `u1` rescaled, so the
/// jittered strata stay stratified within each lobe.
pub fn sample(records: &[GpuBsdf], i: usize, wi: Vec3, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
    let (lobes, n) = strategy_lobes(records, i);
    let (lobe, u1) = match n {
        0 => return None,
        1 => (&lobes[0].0, u1),
        _ => {
            let p1 = lobes[1].1;
            if u1 < p1 {
                (&lobes[1].0, (u1 / p1).min(1.0 - f32::EPSILON))
            } else {
                (&lobes[0].0, ((u1 - p1) / lobes[0].1).clamp(0.0, 1.0 - f32::EPSILON))
            }
        }
    };
    let wo = sample_lobe(lobe, wi, u1, u2)?;
    let pdf = strategy_pdf(records, i, wi, wo);
    if !(pdf > 0.0) {
        return None;
    }
    Some((wo, eval_records(records, i, wi, wo) / pdf, pdf))
}

/// q_L: the density (1/sr) with which light j's emitter is covered by its light samples in the
/// direction of light j from p (module docs); None for lights without glossy MIS.
#[inline]
pub fn light_density(lights: &LightSet, j: usize, p: Vec3) -> Option<f32> {
    let measure = lights.mis_measure[j];
    if !(measure > 0.0) {
        return None;
    }
    match lights.kind[j] {
        LightKind::Directional => Some(1.0 / measure),
        LightKind::OrientedPoint => {
            let d = lights.position[j] - p;
            let dist2 = d.length_squared();
            let cos_l = -d.dot(lights.normal[j]) / dist2.sqrt();
            if cos_l > 0.0 {
                Some(dist2 / (measure * cos_l))
            } else {
                None
            }
        }
        _ => None,
    }
}

/// w_L of light j at view sample i (local directions `wi_local`, `wo_local`, world position `p`): 1 for
/// non-glossy samples and lights without MIS (module docs).
#[inline]
pub fn light_weight(view: &ViewSamples, lights: &LightSet, i: usize, p: Vec3, wi_local: Vec3, wo_local: Vec3, j: usize) -> f32 {
    let n_b = view.bsdf_samples.get(i).copied().unwrap_or(0);
    if n_b == 0 {
        return 1.0;
    }
    let Some(q) = light_density(lights, j, p) else { return 1.0 };
    let pb = n_b as f32 * strategy_pdf(&view.bsdf, i, wi_local, wo_local);
    power_heuristic(q, pb)
}

/// Veach's power heuristic (exponent 2) of a strategy with density `a` against one with density `b`
/// (both already multiplied by their sample counts): a^2 / (a^2 + b^2); the two weights sum to 1.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// The light densities BSDF rays meet: 1 / A_j per mesh (0 = the light set holds no MIS sample of it)
/// and the environment's (`EnvDensity`).
struct HitDensities {
    per_mesh: Vec<f32>,
    environment: EnvDensity,
}

/// 1 / Omega of the environment stratum an escaping BSDF ray falls in: one value when every stratum has
/// the same solid angle (the uniform strata), else that of the stratum whose direction is nearest
/// (visibility-allocated strata, `env_visibility`, whose size changes from coarse cell to coarse cell:
/// exact inside a cell, the neighbour's near a cell's border).
enum EnvDensity {
    None,
    Uniform(f32),
    Nearest { tree: crate::lights::photon_map::PhotonMap, density: Vec<f32> },
}

impl EnvDensity {
    fn any(&self) -> bool {
        !matches!(self, EnvDensity::None)
    }

    /// The density toward `wo` (world, toward the sky).
    fn at(&self, wo: Vec3) -> f32 {
        match self {
            EnvDensity::None => 0.0,
            EnvDensity::Uniform(d) => *d,
            EnvDensity::Nearest { tree, density } => tree.nearest(wo, 1).0.first().map_or(0.0, |&k| density[k]),
        }
    }
}

impl HitDensities {
    fn new(scene: &Scene, lights: &LightSet) -> Self {
        let mut per_mesh = vec![0f32; scene.meshes.len()];
        let (mut sky, mut density) = (Vec::new(), Vec::new());
        for j in 0..lights.len() {
            let m = lights.mis_measure[j];
            if !(m > 0.0) {
                continue;
            }
            match lights.kind[j] {
                LightKind::OrientedPoint => {
                    if let Some(slot) = usize::try_from(lights.mis_mesh[j]).ok().and_then(|k| per_mesh.get_mut(k)) {
                        *slot = 1.0 / m;
                    }
                }
                LightKind::Directional => {
                    sky.push(-lights.direction[j]);
                    density.push(1.0 / m);
                }
                _ => {}
            }
        }
        let environment = match density.first() {
            None => EnvDensity::None,
            Some(&d) if density.iter().all(|&x| (x - d).abs() <= 1e-4 * d) => EnvDensity::Uniform(d),
            Some(_) => EnvDensity::Nearest { tree: crate::lights::photon_map::PhotonMap::new(&sky), density },
        };
        HitDensities { per_mesh, environment }
    }
}

/// The BSDF strategy (module docs): per pixel (H * W, row 0 at the top), the sum over its glossy view
/// samples of (1 / n_B) sum_k f cos L w_B / p_B times the sample's throughput, with n_B samples from
/// the stream (`seed`, view sample i); zero where no sample is glossy. Deterministic for a seed.
pub fn bsdf_image(scene: &Scene, tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, seed: u64) -> Vec<Vec3> {
    let m = view.len();
    if view.bsdf_samples.iter().all(|&n| n == 0) {
        return vec![Vec3::ZERO; view.num_pixels()];
    }
    let dens = HitDensities::new(scene, lights);
    let area = AreaRadiance::new(scene);
    let env = if dens.environment.any() { Environment::from_scene(scene) } else { None };
    let per_sample: Vec<Vec3> = (0..m)
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let n_b = view.bsdf_samples.get(i).copied().unwrap_or(0);
            if n_b == 0 {
                return Vec3::ZERO;
            }
            let sp = crate::cpu::ShadingPoint::new(view, i);
            let mut rng = stream(seed, STREAM_GLOSSY, i as u64);
            let mut sum = Vec3::ZERO;
            // Jittered strata: the first g^2 samples on a g x g grid of [0,1)^2 (g = floor(sqrt(n_B))),
            // the rest uniform; each sample is uniform by itself, so the mean stays unbiased.
            let g = (n_b as f64).sqrt().floor() as u32;
            for k in 0..n_b {
                let (mut u1, mut u2) = (uniform(&mut rng), uniform(&mut rng));
                if k < g * g {
                    u1 = (((k % g) as f32 + u1) / g as f32).min(1.0 - f32::EPSILON);
                    u2 = (((k / g) as f32 + u2) / g as f32).min(1.0 - f32::EPSILON);
                }
                let Some((wo_local, weight, pdf)) = sample(&view.bsdf, i, sp.wi_local, u1, u2) else { continue };
                let wo = (sp.s * wo_local.x + sp.t * wo_local.y + sp.n * wo_local.z).normalize();
                let origin = spawn_ray(sp.p, sp.n_g, wo);
                let (radiance, q) = match tracer.intersect(origin, wo, 0.0, f32::INFINITY) {
                    Some(hit) => {
                        let inv_a = dens.per_mesh.get(hit.mesh).copied().unwrap_or(0.0);
                        let cos_l = hit.wi.dot(hit.n_s);
                        if !(inv_a > 0.0 && cos_l > 0.0) {
                            continue;
                        }
                        let t = (hit.p - origin).length();
                        (area.at(hit.mesh, hit.uv), inv_a * t * t / cos_l)
                    }
                    None => match &env {
                        Some(e) => (crate::matrix::emitted::sanitized(e.radiance(wo)), dens.environment.at(wo)),
                        None => continue,
                    },
                };
                let pb = n_b as f32 * pdf;
                sum += weight * radiance * power_heuristic(pb, q);
            }
            sum * sp.throughput / n_b as f32
        })
        .collect();
    let flat: Vec<f32> = per_sample.iter().flat_map(|v| v.to_array()).collect();
    let folded = if m == view.num_pixels() { flat } else { view.fold(&flat, 3) };
    folded.chunks_exact(3).map(Vec3::from_slice).collect()
}

#[cfg(test)]
mod tests;
