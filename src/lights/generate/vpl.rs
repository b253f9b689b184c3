//! Indirect light -> virtual point lights by particle tracing (Keller, "Instant Radiosity", SIGGRAPH 1997;
//! MRCS 2007 Sec. 4: "indirect lights are computed using particle tracing as in [Keller 1997]").
//!
//! Emission: each particle picks an emitter with probability proportional to its power (mean of RGB):
//! area (uniform point by area, cosine direction on the +normal side; Phi_e = pi A L), environment
//! (direction from `EnvSampler`, origin on the scene's bounding disk facing it; Phi_e = pi r^2 int L),
//! point (uniform direction; 4 pi I), spot (uniform in the cutoff cone, times the falloff; its
//! `spot_solid_angle` power), directional (origin on the bounding disk; pi r^2 E). A particle starts
//! with flux Phi_0 = L_e(y, w) / (p(e) p(y, w) N) -- per emitter that is Phi_e / (p(e) N) times the
//! (unit-mean) ratio of emission to its sampling density -- with N the number of particles.
//!
//! Tracing: at the k-th surface hit x_k (k = 1, 2, ...), with incident direction w_in (toward x_{k-1})
//! and flux Phi, a VPL is stored when the BSDF has a non-delta lobe (diffuse, plastic, roughplastic,
//! roughconductor, principled) and w_in is on its reflecting side (a principled with spec_trans > 0
//! reflects from both sides): flux Phi_vpl = Phi |w_in . n_s| / |w_in . n_g|
//! (the adjoint shading-normal correction), so that its intensity Phi_vpl f(w_in, w) |w . n_g|
//! (`LightSet::emitted`) is the particle estimate of the radiance x_k reflects. VPLs are stored for
//! k <= max_depth - 2 (Mitsuba's max_depth). The particle continues along w sampled from the BSDF
//! (`sampling::sample_bsdf`) with flux Phi_vpl f |w . n_g| / pdf(w) (= I(w) / pdf, the same correction)
//! for non-delta lobes and Phi * weight for delta lobes (smooth conductor / dielectric / plastic's
//! coating, where no VPL is stored); a blendbsdf acts as one of its two BSDFs, picked with its weight;
//! principled's glossy transmission continues through the surface. A `roughdielectric` stores no VPL (its
//! transmission is not reciprocal, and a VPL lights only its incident side) but scatters the particle by
//! sampling it (reflection or glossy transmission, importance-mode weight, the same shading-normal
//! correction); its glossy reflection of VPL light is therefore missing from the VPL set. A
//! `thindielectric` is a delta BSDF (mirror or straight through). A
//! reflection whose sampled direction crosses the geometric surface (or a transmission that does not)
//! ends the particle. A VPL only lights its incident side (transmission from a VPL is not modelled). Russian roulette from the 3rd bounce on: continue with
//! probability q = min(0.95, lum(Phi_next) / lum(Phi_0)), dividing the flux by q.
//!
//! Masked surfaces (`mask`, `crate::raytrace::mask`): a particle passes straight through with probability
//! 1 - a (the flux unchanged, one bounce of depth, no record), else it meets the nested BSDF as above
//! (a VPL of the nested BSDF with the full flux: in expectation a times the flux, Mitsuba's `eval`). A
//! particle from a delta emitter (point, spot, directional) that meets a mask on its first segment does not
//! pass: Mitsuba reaches a delta emitter only by emitter sampling, whose shadow rays masks block.
//!
//! Unbiasedness: E[sum over VPLs at bounce k of Phi_vpl] = the flux arriving at bounce k; so the set's
//! total reflected flux (sum of `LightSet::power`) estimates the power the scene reflects at bounces
//! 1 ..= max_depth - 2 (tested on a closed diffuse box against Phi sum_k rho^k).
//!
//! Count: N is fixed before the main run from a pilot run (its own random streams) as
//! ceil(indirect / mean VPLs per particle), so N does not depend on the main run and the flux stays
//! unbiased; the number of VPLs is random with expectation about `indirect`.
use super::area::AreaEmitter;
use super::environment::{EnvSampler, Environment};
use super::sampling::{
    cosine_hemisphere, has_smooth_lobe_only, sample_bsdf, stream, to_local, to_world, uniform, uniform_cone, uniform_sphere,
    STREAM_PARTICLE, STREAM_PILOT,
};
use super::GenerateOptions;
use crate::error::Result;
use crate::lights::{scene_sphere, spot_falloff, spot_solid_angle, LightKind, LightSet};
use crate::raytrace::{offset_p, spawn_ray, RayTracer};
use crate::scene::Scene;
use crate::shading::bsdf::{resolve_records, FLAG_BLEND, FLAG_TWOSIDED};
use crate::shading::GpuBsdf;
use glam::Vec3;
use rand_pcg::Pcg32;
use std::f32::consts::PI;

/// Bounce from which Russian roulette applies.
const RR_DEPTH: u32 = 3;
/// Pilot particles used to estimate VPLs per particle.
const PILOT_PARTICLES: usize = 4096;

/// Where particles come from.
enum Source<'a> {
    Area(&'a AreaEmitter),
    Env(EnvSampler),
    /// Index into the delta `LightSet`.
    Delta(usize),
}

/// One VPL (or photon) before it enters the set.
pub(crate) struct Vpl {
    pub position: Vec3,
    pub n_s: Vec3,
    pub n_g: Vec3,
    pub incident: Vec3,
    pub flux: Vec3,
    pub bsdf: GpuBsdf,
    /// The bounce it was stored at (`walk`'s depth, null events included): `LightSet::vpl_depth`.
    pub depth: u32,
}

impl Vpl {
    /// Appends this VPL to `set` with flux `flux` and its depth.
    pub(crate) fn push_into(&self, set: &mut LightSet, flux: Vec3) -> Result<()> {
        set.push_vpl(self.position, self.n_s, self.n_g, self.incident, flux, self.bsdf)?;
        set.set_vpl_depth(set.len() - 1, self.depth.max(1))
    }
}

pub(crate) struct Tracer<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) rt: RayTracer,
    sources: Vec<(Source<'a>, Vec3)>,
    /// Selection CDF over `sources` (by mean power) and the probabilities.
    cdf: Vec<f64>,
    prob: Vec<f32>,
    delta: LightSet,
    env: Option<&'a Environment>,
    pub(crate) center: Vec3,
    pub(crate) radius: f32,
    max_vpl_depth: u32,
    /// First bounce that stores a record (1: VPLs; 2: photons without the first hit).
    min_vpl_depth: u32,
}

fn luminance(v: Vec3) -> f32 {
    v.element_sum() / 3.0
}

impl<'a> Tracer<'a> {
    /// Emits one particle: (origin, direction, flux before division by N, whether it comes from a delta
    /// emitter: point, spot, directional).
    fn emit_from(&self, rng: &mut Pcg32) -> Option<(Vec3, Vec3, Vec3, bool)> {
        let total = *self.cdf.last()?;
        let u = uniform(rng) as f64 * total;
        let s = self.cdf.partition_point(|&c| c <= u).min(self.sources.len() - 1);
        let (source, power) = &self.sources[s];
        let p_select = self.prob[s];
        let (u0, u1, u2, u3) = (uniform(rng), uniform(rng), uniform(rng), uniform(rng));
        // A point on the bounding disk facing direction `d` (toward the sky), outside the scene.
        let disk_origin = |d: Vec3, a: f32, b: f32| {
            let r = a.sqrt() * self.radius;
            let phi = 2.0 * PI * b;
            self.center + to_world(d, Vec3::new(r * phi.cos(), r * phi.sin(), 1.01 * self.radius))
        };
        let delta = matches!(source, Source::Delta(_));
        let emitted = match source {
            Source::Area(e) => {
                let (p, n, uv) = e.sample_point_uv(u0, u1);
                let w = to_world(n, cosine_hemisphere(u2, u3));
                // pi A L(uv) / p_select (= power / p_select for a constant radiance).
                let phi = if e.texture.is_some() { e.radiance_at(uv) * (PI * e.area) } else { *power };
                Some((offset_p(p, n, w), w, phi / p_select))
            }
            Source::Env(sampler) => {
                let (d, pdf) = sampler.sample(u0, u1, u2);
                let l = self.env_radiance(d);
                if !(pdf > 0.0) {
                    return None;
                }
                let v = uniform(rng);
                Some((disk_origin(d, u3, v), -d, l * (PI * self.radius * self.radius / (pdf * p_select))))
            }
            Source::Delta(j) => {
                let j = *j;
                let i = self.delta.intensity[j];
                match self.delta.kind[j] {
                    LightKind::Point => Some((self.delta.position[j], uniform_sphere(u0, u1), *power / p_select)),
                    LightKind::Spot => {
                        let (c, b) = (self.delta.cutoff_angle[j], self.delta.beam_width[j]);
                        let cos_c = c.cos();
                        let local = uniform_cone(u0, u1, cos_c);
                        let falloff = spot_falloff(local.z, c, b);
                        let w = to_world(self.delta.direction[j], local);
                        let solid = 2.0 * PI * (1.0 - cos_c);
                        // A projected texture multiplies the particle's flux (Mitsuba's sample_ray weight).
                        let i = match &self.delta.spot_texture[j] {
                            Some(t) => i * t.eval_world(w, self.delta.direction[j]),
                            None => i,
                        };
                        Some((self.delta.position[j], w, i * (falloff * solid / p_select)))
                    }
                    _ => {
                        let dir = self.delta.direction[j];
                        Some((disk_origin(-dir, u2, u3), dir, *power / p_select))
                    }
                }
            }
        };
        emitted.map(|(o, d, phi)| (o, d, phi, delta))
    }

    fn env_radiance(&self, d: Vec3) -> Vec3 {
        self.env.map_or(Vec3::ZERO, |e| e.radiance(d))
    }

    /// Traces particle `index` of stream family `family`; VPL fluxes still to be divided by N.
    pub(crate) fn trace(&self, seed: u64, family: u64, index: u64, out: &mut Vec<Vpl>) {
        let mut rng = stream(seed, family, index);
        let Some((o, d, phi_0, delta)) = self.emit_from(&mut rng) else { return };
        walk(self.scene, &self.rt, o, d, phi_0, delta, &mut rng, self.min_vpl_depth, self.max_vpl_depth, &mut |v| out.push(v));
    }
}

/// Follows one particle leaving `o` along `d` with flux `phi_0` through the scene's BSDFs (module docs:
/// tracing, Russian roulette), calling `store` with the record of every hit whose bounce index lies in
/// `min_depth ..= max_depth` (1 = the first hit); the path ends after bounce `max_depth`. A masked surface
/// passed straight through is a bounce for `max_depth` (Mitsuba's depth) but not for `min_depth`: a record
/// with `min_depth` 2 has met at least one BSDF before, whatever masks it crossed. Shared by the
/// VPLs and photons of light sources and the photons of direct-to-indirect transfer's multi-bounce
/// matrix (`relight::multibounce`, particles leaving the gather samples).
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk(
    scene: &Scene,
    rt: &RayTracer,
    o: Vec3,
    d: Vec3,
    phi_0: Vec3,
    delta_source: bool,
    rng: &mut Pcg32,
    min_depth: u32,
    max_depth: u32,
    store: &mut dyn FnMut(Vpl),
) {
    let (mut o, mut d) = (o, d);
    if !(phi_0.max_element() > 0.0 && phi_0.is_finite()) {
        return;
    }
    let lum_0 = luminance(phi_0);
    let mut phi = phi_0;
    let mut depth = 0u32;
    // Null events so far (`depth - nulls` is the index of the BSDF interaction).
    let mut nulls = 0u32;
    loop {
        let Some(hit) = rt.intersect(o, d, 0.0, f32::INFINITY) else { return };
        depth += 1;
        if let Some(a) = rt.masks().opacity(hit.mesh, hit.uv) {
            // A masked surface: its null lobe with probability 1 - a, straight on with the flux unchanged
            // (one bounce of depth, no record); else its nested BSDF below (module docs).
            if uniform(rng) >= a {
                if (depth == 1 && delta_source) || depth >= max_depth {
                    return;
                }
                nulls += 1;
                o = spawn_ray(hit.p, hit.n_g, d);
                continue;
            }
        }
        let mesh = &scene.meshes[hit.mesh];
        // A blendbsdf: one of its two records, the second with probability w (unbiased: the expected
        // VPL BSDF and continuation weight are (1 - w) f_0 + w f_1).
        let b = match resolve_records(&scene.bsdfs, &scene.textures, mesh.bsdf, hit.uv) {
            (first, Some(second)) => {
                let mut b = if uniform(rng) < first.extra[2] { second } else { first };
                b.flags &= !FLAG_BLEND;
                (b.extra[2], b.extra[3]) = (0.0, 0.0);
                b
            }
            (b, None) => b,
        };
        let mut b = b;
        crate::shading::perturb::apply(scene, hit.mesh, hit.prim, hit.p, hit.n_g, hit.n_s, hit.uv, &mut [&mut b]);
        let (n_s, n_g, w_in) = (hit.n_s, hit.n_g, hit.wi);
        let (cos_s_in, cos_g_in) = (w_in.dot(n_s), w_in.dot(n_g));
        let non_delta = !has_smooth_lobe_only(&b);
        if non_delta {
            // Reflecting side: w_in on the same side of n_s and n_g, and the front unless two-sided.
            let back_ok =
                b.flags & (FLAG_TWOSIDED | crate::shading::bsdf::FLAG_TWOSIDED_OUTER) != 0 || crate::shading::principled::has_back_side(&b);
            if !(cos_s_in * cos_g_in > 0.0) || (!back_ok && cos_s_in <= 0.0) {
                return;
            }
            let phi_vpl = phi * (cos_s_in.abs() / cos_g_in.abs());
            if depth <= max_depth && depth - nulls >= min_depth {
                store(Vpl { position: offset_p(hit.p, n_g, w_in), n_s, n_g, incident: w_in, flux: phi_vpl, bsdf: b, depth });
            }
        }
        if depth >= max_depth {
            return;
        }
        let wi_local = to_local(n_s, w_in);
        let Some(mut sample) = sample_bsdf(&b, wi_local, rng) else { return };
        if b.flags & crate::shading::bsdf::FLAG_BUMP != 0 && !sample.delta {
            // The perturbation is not reciprocal: weight by Mitsuba's direction (`perturb::adjoint_eval`).
            let (e, a) =
                (crate::shading::bsdf::eval(&b, wi_local, sample.wo), crate::shading::perturb::adjoint_eval(&b, wi_local, sample.wo));
            sample.weight = Vec3::select(e.cmpgt(Vec3::ZERO), sample.weight * a / e, Vec3::ZERO);
        }
        let w = to_world(n_s, sample.wo);
        let cos_g_out = w.dot(n_g);
        let mut phi_next = if sample.delta {
            phi * sample.weight
        } else {
            // Reflection lobes stay on w_in's side, glossy transmission (principled) crosses, for both
            // normals alike; f |w . n_g| / pdf = weight |w . n_g| / |w . n_s|.
            // A roughdielectric (no VPL stored) takes the same shading-normal factor |cos_s_in| / |cos_g_in|.
            let transmitted = sample.wo.z * cos_s_in < 0.0;
            if !(cos_g_out * cos_g_in > 0.0) != transmitted || cos_g_out == 0.0 || sample.wo.z == 0.0 || !(cos_s_in * cos_g_in > 0.0) {
                return;
            }
            phi * (cos_s_in.abs() / cos_g_in.abs()) * sample.weight * (cos_g_out.abs() / sample.wo.z.abs())
        };
        if depth >= RR_DEPTH {
            let q = (luminance(phi_next) / lum_0).min(0.95);
            if !(uniform(rng) < q) {
                return;
            }
            phi_next /= q;
        }
        if !(phi_next.max_element() > 0.0 && phi_next.is_finite()) {
            return;
        }
        phi = phi_next;
        o = spawn_ray(hit.p, n_g, w);
        d = w;
    }
}

/// About `opts.indirect` VPLs (module docs); `areas` and `env` are the scene's area emitters and
/// environment. Returns an empty set when no particle deposits a VPL.
pub fn trace_vpls(scene: &Scene, areas: &[AreaEmitter], env: Option<&Environment>, opts: &GenerateOptions) -> Result<LightSet> {
    trace_particles(scene, areas, env, opts, 1)
}

/// Photons for density estimation of multiple-bounce light (`lights::animated`): `trace_vpls` without the
/// first hit, i.e. about `opts.indirect` records of the flux arriving at bounces 2 ..= max_depth - 2 (each a
/// VPL record: position, normals, incident direction, flux in `intensity`).
pub fn trace_photons(scene: &Scene, areas: &[AreaEmitter], env: Option<&Environment>, opts: &GenerateOptions) -> Result<LightSet> {
    trace_particles(scene, areas, env, opts, 2)
}

/// Particle tracing storing a record at every hit with bounce index in [min_depth, max_depth - 2];
/// with `opts.vpl_importance`, the VPLs are importance sampled by the camera (`vpl_importance`).
fn trace_particles(
    scene: &Scene,
    areas: &[AreaEmitter],
    env: Option<&Environment>,
    opts: &GenerateOptions,
    min_depth: u32,
) -> Result<LightSet> {
    let (center, radius) = scene_sphere(scene);
    if opts.indirect == 0 || opts.max_depth < 3 {
        return Ok(LightSet::new(center, radius));
    }
    let Some(tracer) = Tracer::new(scene, areas, env, opts, min_depth)? else {
        return Ok(LightSet::new(center, radius));
    };
    match &opts.vpl_importance {
        Some(imp) => Ok(super::vpl_importance::trace_importance(&tracer, opts, imp)?.0),
        None => trace_plain(&tracer, opts),
    }
}

impl<'a> Tracer<'a> {
    /// The particle sources of the scene (area, environment, delta emitters, chosen by power); `None`
    /// when nothing emits (or the scene has no extent).
    pub(crate) fn new(
        scene: &'a Scene,
        areas: &'a [AreaEmitter],
        env: Option<&'a Environment>,
        opts: &GenerateOptions,
        min_depth: u32,
    ) -> Result<Option<Tracer<'a>>> {
        let (center, radius) = scene_sphere(scene);
        let delta = LightSet::from_scene(scene)?;
        let mut sources: Vec<(Source, Vec3)> = Vec::new();
        for e in areas {
            sources.push((Source::Area(e), e.power()));
        }
        if let Some(env) = env {
            let sampler = env.sampler();
            let power = sampler.integral * (PI * radius * radius);
            sources.push((Source::Env(sampler), power));
        }
        for j in 0..delta.len() {
            let power = match delta.kind[j] {
                LightKind::Spot if delta.spot_texture[j].is_none() => {
                    delta.intensity[j] * spot_solid_angle(delta.cutoff_angle[j], delta.beam_width[j])
                }
                _ => delta.power(j),
            };
            sources.push((Source::Delta(j), power));
        }
        let weights: Vec<f64> = sources.iter().map(|(_, p)| luminance(*p).max(0.0) as f64).collect();
        let total: f64 = weights.iter().sum();
        if !(total > 0.0) || radius <= 0.0 {
            return Ok(None);
        }
        let mut acc = 0.0;
        let cdf: Vec<f64> = weights
            .iter()
            .map(|w| {
                acc += w;
                acc
            })
            .collect();
        let prob: Vec<f32> = weights.iter().map(|w| (w / total) as f32).collect();
        Ok(Some(Tracer {
            scene,
            rt: RayTracer::new(scene)?,
            sources,
            cdf,
            prob,
            delta,
            env,
            center,
            radius,
            max_vpl_depth: opts.max_depth.saturating_sub(2),
            min_vpl_depth: min_depth,
        }))
    }
}

/// Plain particle tracing: N from the pilot (module docs), every record kept with flux / N.
fn trace_plain(tracer: &Tracer, opts: &GenerateOptions) -> Result<LightSet> {
    let mut out = LightSet::new(tracer.center, tracer.radius);
    // Particles in parallel chunks with interruption checks between them (Ctrl-C; `crate::interrupt`).
    let run = |family: u64, n: usize| -> Result<Vec<Vec<Vpl>>> {
        crate::interrupt::par_map_chunked(n, 8192, |k| {
            let mut v = Vec::new();
            tracer.trace(opts.seed, family, k as u64, &mut v);
            v
        })
    };
    // Pilot: mean VPLs per particle fixes N independently of the main run.
    let pilot = PILOT_PARTICLES.min(opts.indirect.max(256));
    let pilot_count: usize = run(STREAM_PILOT, pilot)?.iter().map(Vec::len).sum();
    if pilot_count == 0 {
        return Ok(out);
    }
    let per_particle = pilot_count as f64 / pilot as f64;
    let n = ((opts.indirect as f64 / per_particle).ceil() as usize).max(1);
    let inv_n = 1.0 / n as f32;
    for v in run(STREAM_PARTICLE, n)?.into_iter().flatten() {
        v.push_into(&mut out, v.flux * inv_n)?;
    }
    Ok(out)
}
