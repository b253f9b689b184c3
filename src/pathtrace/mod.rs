//! Unbiased CPU path tracer for probe pixels: the project's own reference estimator of a pixel's
//! converged radiance (bias included), so that a render's error can be estimated without Mitsuba.
//!
//! Method: Mitsuba 3's `path` integrator (`src/integrators/path.cpp`): at every vertex one emitter
//! sample and one BSDF sample, combined by multiple importance sampling with the power heuristic
//! (Veach and Guibas, "Optimally Combining Sampling Techniques for Monte Carlo Rendering", SIGGRAPH
//! 1995; Veach's thesis, 1997, ch. 9), delta lobes followed by sampling, Russian roulette. A probe is a
//! pixel; each of its `spp` paths starts at the pixel's own view sample (`ViewSamples` sample
//! `y * width + x`: the same camera hit at the pixel centre as the image's, Mitsuba's camera ray
//! `Camera::ray(x + 0.5, y + 0.5)`), or looks up the environment along that ray for a background pixel.
//! Delta BSDFs (mirrors, glass, smooth plastic's specular layer) are sampled as Mitsuba does, so the
//! surfaces a path reaches through them are those of `view::chains` (same directions, same
//! `spawn_ray`), without the chains' bounds (`max_bounces`, `min_throughput`): their expectation is
//! the chains' sum with nothing dropped.
//!
//! Per path (depth d = number of segments so far; Mitsuba's `max_depth` M, -1 = unlimited):
//! - emission at the vertex reached by segment d (area emitter seen from its front, `dot(wi, n_s) > 0`,
//!   or the environment when the ray escapes), weighted by w_B = p_B^2 / (p_B^2 + p_L^2) unless the
//!   previous BSDF sample was a delta lobe (then 1; always 1 for the camera segment);
//! - if d + 1 < M (or M = -1) and the BSDF has a non-delta lobe: emitter sampling (below), weighted by
//!   w_L = p_L^2 / (p_L^2 + p_B^2) (1 for delta emitters);
//! - if d + 1 < M: a BSDF sample (`sampling::sample_bsdf`, its pdf `sampling::pdf_bsdf`); then d += 1
//!   and from d >= `rr_depth` (5) Russian roulette: continue with q = min(max_c(beta) eta^2, 0.95),
//!   beta /= q (Mitsuba's rule; eta the product of the relative IORs crossed).
//! Emitter sampling: with at most `ALL_EMITTERS` emitters every emitter is sampled at every vertex
//! (selection probability s = 1); with more, one emitter is chosen uniformly (s = 1 / N, as Mitsuba).
//! Point, spot and directional lights are evaluated exactly (`LightSet::emitted`, shadow ray
//! `cpu::light_blocked`); an area emitter by a point uniform on its shape's area
//! (`AreaEmitter::sample_point_uv`, p_A = 1 / A; spheres over the whole sphere), converted to solid
//! angle p_L = s d^2 / (A |cos_y|); the environment by `EnvSampler` over 16,384 equal-area cells, p_L =
//! s p_env(w): with `guided_env` (the default) a defensive mixture of 0.6 luminance x what a unit of
//! radiance from the cell adds to the camera's pilot view (`env_visibility::camera_factor`: 256 coarse
//! cells, exact shadow rays from about 1,024 pixel centres, its pilot seeded by `GUIDE_SEED` so that one
//! guide serves every probe set of a scene), 0.3 luminance and 0.1 uniform, so that in a
//! room lit through a window the samples go through the window; else 0.9 luminance + 0.1 uniform. The
//! BSDF-hit side uses the same p_L for the emitter it
//! hits, so the MIS weights of the two strategies sum to 1 and the estimator is unbiased (Veach 1997,
//! eq. 9.10) whatever the proposals.
//!
//! Radiance transport: a refraction through a smooth dielectric multiplies beta by eta_ti^2 (Mitsuba's
//! `dielectric` in radiance mode; `sample_bsdf` itself gives importance-mode weight 1), a transmission
//! through a `roughdielectric` by 1 / eta^2 (eta the relative IOR on wi's side; its importance-mode
//! weight times Mitsuba's radiance-mode scale). A `thindielectric` is a delta BSDF sampled as Mitsuba
//! does (no scaling); it blocks shadow rays, as every surface does for Mitsuba's `path`. Blended BSDFs
//! sample one record by its weight; a non-delta direction is weighted by the blend's eval over the
//! mixture density (1 - w) p_0 + w p_1.
//!
//! Output per probe: the mean of the `spp` path values and the variance of that mean (sample variance
//! / spp). Random numbers: probe k's samples come in blocks of `BLOCK` paths, block b drawing from
//! `sampling::stream(seed, STREAM_PATH, k << 32 | b)`; blocks run in parallel and are summed in block
//! order in f64, so one seed gives bit-identical output on any thread count.
//!
//! Masked surfaces (`mask`, Mitsuba's `mask.cpp`; semantics measured in `crate::raytrace::mask`): eval and
//! pdf are the nested BSDF's times the opacity a; a BSDF sample passes straight through with probability
//! 1 - a (weight 1, a delta event: the emitter it then hits has MIS weight 1, and it is one unit of depth), else
//! samples the nested BSDF (a nested delta BSDF's lobes as any delta BSDF's);
//! shadow rays stop at masked surfaces as at any other (Mitsuba's `ray_test`). A path whose BSDF samples
//! were all null events is worth 0 unless the scene has an environment (Mitsuba's `valid_ray`); as in
//! `llvm_ad_rgb`, the vertex where the depth runs out also draws its null-or-not decision.
//!
//! Not supported (refused with `InvalidParameter`): `principled` BSDFs (no pdf for their sampling
//! mixture in radiance mode yet). Deviations from Mitsuba (expectation unchanged unless noted): emitter
//! selection (all emitters when few) and the area / environment proposals differ from Mitsuba's (its
//! sphere emitters sample the visible cone, its envmap a full-resolution table); an area emitter sampled
//! by position emits where `-w . n_y > 0` with its `AreaEmitter` normal (geometric, oriented as the
//! vertex normals), a hit one where `wi . n_s > 0`: they differ only on emitters whose shading normals
//! disagree with their faces.
//!
//! Symbols: x a path vertex, w a direction, beta the path throughput, p_B the BSDF-sampling density,
//! p_L the emitter-sampling density (solid angle, selection included), s the selection probability,
//! A an emitter's area, n_y its normal at the sampled point, d the depth (segments), M `max_depth`,
//! q the Russian-roulette continuation probability, eta_ti the relative IOR across a refraction.
use crate::cpu::light_blocked;
use crate::error::{Error, Result};
use crate::lights::generate::area::{area_emitters, AreaEmitter};
use crate::lights::generate::env_visibility::camera_factor;
use crate::lights::generate::environment::{EnvSampler, Environment};
use crate::lights::generate::sampling::{stream, uniform};
use crate::lights::LightSet;
use crate::matrix::emitted::{sanitized, AreaRadiance};
use crate::raytrace::{spawn_ray, RayTracer};
use crate::scene::{Bsdf, Scene};
use crate::view::ViewSamples;
use glam::{DVec3, Vec3};
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::sync::Arc;
use vertex::{power_heuristic, Vertex};

/// Random stream family of the path tracer (`sampling::stream`).
pub const STREAM_PATH: u64 = 10;
/// Paths per block (the unit of parallel work and of the random streams).
pub const BLOCK: u32 = 64;
/// The seed of the environment guide's pilot (`camera_factor`): the guide is a sampling density, any fixed
/// one keeps the estimate unbiased, so it is a function of the scene alone and built once per scene.
pub const GUIDE_SEED: u64 = 0x0067_7569_6465;
/// Scenes with at most this many emitters sample every emitter at every vertex.
pub const ALL_EMITTERS: usize = 8;

/// What `probe_pixels` computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeOptions {
    /// Paths per probe (>= 2: the variance needs two).
    pub spp: u32,
    /// Mitsuba's `max_depth`: -1 = unlimited, else >= 1 (1 = emitters seen directly, 2 = direct light).
    pub max_depth: i32,
    /// Depth from which Russian roulette applies (Mitsuba's `rr_depth`).
    pub rr_depth: u32,
    pub seed: u64,
    /// Sample the environment guided by what the camera sees of it (`EnvSampler` from
    /// `Environment::sampler_guided` with `env_visibility::camera_factor`; module docs), else by luminance.
    pub guided_env: bool,
}

impl Default for ProbeOptions {
    fn default() -> Self {
        ProbeOptions { spp: 256, max_depth: -1, rr_depth: 5, seed: 0, guided_env: true }
    }
}

impl ProbeOptions {
    /// Errors: `InvalidParameter` for spp < 2 or max_depth < -1 or 0.
    pub fn check(&self) -> Result<()> {
        if self.spp < 2 {
            return Err(Error::invalid(format!("spp must be >= 2 (the variance of the mean needs two paths), got {}", self.spp)));
        }
        if self.max_depth == 0 || self.max_depth < -1 {
            return Err(Error::invalid(format!(
                "max_depth must be -1 (unlimited) or >= 1 (Mitsuba's path depth; 2 = direct light only), got {}",
                self.max_depth
            )));
        }
        Ok(())
    }
}

/// One probe's estimate: mean radiance (RGB) and the variance of that mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeEstimate {
    pub mean: Vec3,
    pub variance_of_mean: Vec3,
}

/// Refuses scenes the tracer does not support (module docs).
///
/// Errors: `InvalidParameter` naming the first principled BSDF.
pub fn check_supported(scene: &Scene) -> Result<()> {
    for (i, b) in scene.bsdfs.iter().enumerate() {
        if matches!(b, Bsdf::Principled(_)) && scene.meshes.iter().any(|m| uses(scene, m.bsdf, i)) {
            return Err(Error::invalid(format!(
                "the probe path tracer does not support 'principled' BSDFs (BSDF {i} of the scene): no radiance-mode pdf for its sampling yet"
            )));
        }
    }
    Ok(())
}

/// Whether scene BSDF `root` is or contains BSDF `target`.
fn uses(scene: &Scene, root: usize, target: usize) -> bool {
    if root == target {
        return true;
    }
    match scene.bsdfs.get(root) {
        Some(Bsdf::TwoSided { front, .. }) if *front != root => uses(scene, *front, target),
        Some(Bsdf::BumpMap { nested, .. } | Bsdf::NormalMap { nested, .. }) if *nested != root => uses(scene, *nested, target),
        Some(Bsdf::Blend { first, second, .. }) => uses(scene, *first, target) || uses(scene, *second, target),
        _ => false,
    }
}

/// The scene's environment as the path tracer samples it: its radiance and its sampler, guided by what the
/// camera's pilot view sees of it (`env_visibility::camera_factor` with `GUIDE_SEED`) or by luminance. A
/// function of the scene and the guide flag alone: built once per scene and shared by every tracer of it
/// (the Python `Scene`'s cache); building the sampler integrates the map over every cell.
pub struct SampledEnvironment {
    pub env: Environment,
    pub sampler: EnvSampler,
}

impl SampledEnvironment {
    /// None where the scene has no environment. `guided`: `ProbeOptions::guided_env` (a guide that sees no
    /// environment falls back to luminance). Errors: `camera_factor`'s (interruption).
    pub fn build(scene: &Scene, rt: &RayTracer, guided: bool) -> Result<Option<SampledEnvironment>> {
        let Some(env) = Environment::from_scene(scene) else { return Ok(None) };
        let guide = if guided { camera_factor(&env, scene, rt, GUIDE_SEED)? } else { None };
        let sampler = match &guide {
            Some(f) => env.sampler_guided(Some(&|d| f.of(d))),
            None => env.sampler(),
        };
        Ok(Some(SampledEnvironment { env, sampler }))
    }
}

/// The scene prepared for tracing paths (module docs).
pub struct PathTracer<'a> {
    scene: &'a Scene,
    rt: &'a RayTracer,
    delta: LightSet,
    area: Vec<AreaEmitter>,
    /// Per mesh: its index in `area` (None without an area emitter).
    area_of_mesh: Vec<Option<usize>>,
    area_radiance: AreaRadiance<'a>,
    env: Option<Arc<SampledEnvironment>>,
    /// Emitters to sample: delta lights, area emitters, the environment (one), in that order.
    num_emitters: usize,
    /// False in the light-set mode (`with_lights`): the scene's own emitters neither emit nor are sampled.
    scene_emission: bool,
    opts: ProbeOptions,
}

impl<'a> PathTracer<'a> {
    /// Errors: `check_supported`, bad options, the delta lights' checks of `LightSet::from_scene`.
    pub fn new(scene: &'a Scene, rt: &'a RayTracer, opts: &ProbeOptions) -> Result<PathTracer<'a>> {
        PathTracer::new_guided(scene, rt, opts, None)
    }

    /// `new` with the environment built beforehand (`SampledEnvironment::build` with `opts.guided_env`), for
    /// several tracers of one scene (`None`: built here). Errors: as `new`.
    pub fn new_guided(
        scene: &'a Scene,
        rt: &'a RayTracer,
        opts: &ProbeOptions,
        env: Option<Arc<SampledEnvironment>>,
    ) -> Result<PathTracer<'a>> {
        opts.check()?;
        check_supported(scene)?;
        let delta = LightSet::from_scene(scene)?;
        let area: Vec<AreaEmitter> = area_emitters(scene).into_iter().filter(|e| e.area > 0.0).collect();
        let mut area_of_mesh = vec![None; scene.meshes.len()];
        for (k, e) in area.iter().enumerate() {
            area_of_mesh[e.mesh] = Some(k);
        }
        let env = match env {
            Some(e) => Some(e),
            None => SampledEnvironment::build(scene, rt, opts.guided_env)?.map(Arc::new),
        };
        let num_emitters = delta.len() + area.len() + usize::from(env.is_some());
        Ok(PathTracer {
            scene,
            rt,
            delta,
            area,
            area_of_mesh,
            area_radiance: AreaRadiance::new(scene),
            env,
            num_emitters,
            scene_emission: true,
            opts: *opts,
        })
    }

    /// The light-set mode: the scene lit by `lights` alone (any kinds `LightSet::emitted` evaluates: point,
    /// spot, directional, oriented points with their near-field patches, VPLs with their clamp), each
    /// sampled at every vertex (or one uniformly when there are more than `ALL_EMITTERS`), exactly as the
    /// scene's delta lights are; the scene's own emitters are ignored (they neither emit nor are sampled,
    /// and a pixel on an emitter starts with zero: what `DirectToIndirect.relight` renders).
    ///
    /// Errors: `check_supported`, bad options.
    pub fn with_lights(scene: &'a Scene, rt: &'a RayTracer, lights: LightSet, opts: &ProbeOptions) -> Result<PathTracer<'a>> {
        opts.check()?;
        check_supported(scene)?;
        let num_emitters = lights.len();
        Ok(PathTracer {
            scene,
            rt,
            delta: lights,
            area: Vec::new(),
            area_of_mesh: vec![None; scene.meshes.len()],
            area_radiance: AreaRadiance::new(scene),
            env: None,
            num_emitters,
            scene_emission: false,
            opts: *opts,
        })
    }

    fn select_all(&self) -> bool {
        self.num_emitters <= ALL_EMITTERS
    }

    /// Selection probability of one emitter.
    fn selection(&self) -> f32 {
        if self.select_all() {
            1.0
        } else {
            1.0 / self.num_emitters as f32
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn vertex(&self, mesh: usize, prim: usize, p: Vec3, n_s: Vec3, n_g: Vec3, wi: Vec3, uv: glam::Vec2) -> Vertex {
        Vertex::at_hit(self.scene, self.rt, mesh, prim, p, n_s, n_g, wi, uv)
    }

    /// Emitter `e` (module order) sampled at `x`: its MIS-weighted contribution / selection probability.
    fn sample_emitter(&self, x: &Vertex, e: usize, s: f32, rng: &mut Pcg32) -> Vec3 {
        let nd = self.delta.len();
        if e < nd {
            let Some((wo, radiance, dist)) = self.delta.emitted(e, x.p, x.n_s) else { return Vec3::ZERO };
            let f = x.eval(wo);
            if f.max_element() <= 0.0 || radiance.max_element() <= 0.0 || light_blocked(self.rt, &self.delta, e, x.p, x.n_g, wo, dist) {
                return Vec3::ZERO;
            }
            return f * radiance / s;
        }
        let (u0, u1, u2) = (uniform(rng), uniform(rng), uniform(rng));
        if e < nd + self.area.len() {
            let a = &self.area[e - nd];
            let (y, n_y, uv) = a.sample_point_uv(u0, u1);
            let d = y - x.p;
            let dist2 = d.length_squared();
            if !(dist2 > 0.0) {
                return Vec3::ZERO;
            }
            let wo = d / dist2.sqrt();
            let cos_y = -wo.dot(n_y);
            if !(cos_y > 0.0) {
                return Vec3::ZERO;
            }
            let le = a.radiance_at(uv);
            let f = x.eval(wo);
            if f.max_element() <= 0.0 || le.max_element() <= 0.0 || self.rt.occluded(x.p, x.n_g, y) {
                return Vec3::ZERO;
            }
            let p_l = s * dist2 / (a.area * cos_y);
            return f * le * (power_heuristic(p_l, x.pdf(wo)) / p_l);
        }
        let Some(se) = &self.env else { return Vec3::ZERO };
        let (wo, pdf) = se.sampler.sample(u0, u1, u2);
        if !(pdf > 0.0) {
            return Vec3::ZERO;
        }
        let le = sanitized(se.env.radiance(wo));
        let f = x.eval(wo);
        if f.max_element() <= 0.0 || le.max_element() <= 0.0 || self.rt.occluded_ray(spawn_ray(x.p, x.n_g, wo), wo, f32::INFINITY) {
            return Vec3::ZERO;
        }
        let p_l = s * pdf;
        f * le * (power_heuristic(p_l, x.pdf(wo)) / p_l)
    }

    /// Emitter sampling at `x` (module docs).
    fn direct(&self, x: &Vertex, rng: &mut Pcg32) -> Vec3 {
        if self.num_emitters == 0 {
            return Vec3::ZERO;
        }
        if self.select_all() {
            (0..self.num_emitters).map(|e| self.sample_emitter(x, e, 1.0, rng)).sum()
        } else {
            let e = ((uniform(rng) * self.num_emitters as f32) as usize).min(self.num_emitters - 1);
            self.sample_emitter(x, e, self.selection(), rng)
        }
    }

    /// Emitter-sampling density (selection included) of the environment toward `w`.
    fn env_pdf(&self, w: Vec3) -> f32 {
        self.env.as_ref().map_or(0.0, |se| self.selection() * se.sampler.pdf(w))
    }

    fn may_continue(&self, depth: u32) -> bool {
        self.opts.max_depth < 0 || (depth as i64) + 1 < self.opts.max_depth as i64
    }

    /// One path from view sample `i` of `view` (a pixel's own sample; module docs).
    pub fn path(&self, view: &ViewSamples, i: usize, rng: &mut Pcg32) -> Vec3 {
        let shape = view.shape_index[i];
        if shape < 0 {
            let Some(se) = &self.env else { return Vec3::ZERO };
            let w = view.width as usize;
            let (_, d) = self.scene.camera.ray((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            return sanitized(se.env.radiance(d));
        }
        let mesh = shape as usize;
        let le = if self.scene_emission { self.area_radiance.at(mesh, view.uv[i]) } else { Vec3::ZERO };
        let mut result = if le != Vec3::ZERO && view.wi[i].dot(view.normal[i]) > 0.0 { le } else { Vec3::ZERO };
        let mut x = self.vertex(
            mesh,
            view.prim_index[i].max(0) as usize,
            view.position[i],
            view.normal[i],
            view.geo_normal[i],
            view.wi[i],
            view.uv[i],
        );
        let mut beta = Vec3::ONE;
        let mut eta = 1.0f32;
        let mut depth = 0u32;
        // Mitsuba's `valid_ray` (`raytrace::mask` module docs): true with an environment, else once a
        // vertex draws a non-null BSDF sample (also the last vertex, as `llvm_ad_rgb` does).
        let mut valid = self.env.is_some() || !self.rt.masks().any();
        loop {
            if !self.may_continue(depth) {
                valid |= x.opacity.is_none_or(|a| uniform(rng) < a);
                break;
            }
            if x.has_smooth() {
                result += beta * self.direct(&x, rng);
            }
            let Some(bs) = x.sample(rng) else {
                valid = true;
                break;
            };
            valid |= !bs.null;
            beta *= bs.weight;
            eta *= bs.eta;
            depth += 1;
            let beta_max = beta.max_element();
            if depth >= self.opts.rr_depth {
                let q = (beta_max * eta * eta).min(0.95);
                if !(uniform(rng) < q) {
                    break;
                }
                beta /= q;
            }
            if !(beta_max > 0.0) || !beta.is_finite() {
                break;
            }
            let Some(si) = self.rt.intersect(spawn_ray(x.p, x.n_g, bs.w), bs.w, 0.0, f32::INFINITY) else {
                if let Some(se) = &self.env {
                    let mis = if bs.delta { 1.0 } else { power_heuristic(bs.pdf, self.env_pdf(bs.w)) };
                    result += beta * sanitized(se.env.radiance(bs.w)) * mis;
                }
                break;
            };
            let le = if self.scene_emission { self.area_radiance.at(si.mesh, si.uv) } else { Vec3::ZERO };
            if le != Vec3::ZERO && si.wi.dot(si.n_s) > 0.0 {
                let mis = match self.area_of_mesh.get(si.mesh).copied().flatten() {
                    Some(k) if !bs.delta => {
                        let d2 = (si.p - x.p).length_squared();
                        let cos_y = si.wi.dot(si.n_g).abs();
                        let p_l = if cos_y > 0.0 { self.selection() * d2 / (self.area[k].area * cos_y) } else { f32::INFINITY };
                        power_heuristic(bs.pdf, p_l)
                    }
                    _ => 1.0,
                };
                result += beta * le * mis;
            }
            x = self.vertex(si.mesh, si.prim, si.p, si.n_s, si.n_g, si.wi, si.uv);
        }
        if result.is_finite() && valid {
            result
        } else {
            Vec3::ZERO
        }
    }
}

/// Mean radiance and variance of the mean at each probe pixel `(x, y)` (column, row from the top) of
/// `view` (whose first `width * height` samples are the camera's hits), `opts.spp` paths each (module
/// docs); `progress(done, total)` is called in paths after every chunk of work, and interruption is
/// checked there (`crate::interrupt`).
///
/// Errors: `InvalidParameter` for bad options, a pixel outside the film, a view without the film's
/// samples, or an unsupported scene (`check_supported`); `Interrupted`.
/// With `lights`, the scene is lit by them alone (`PathTracer::with_lights`); `env`: the environment built
/// beforehand for several calls on one scene (`PathTracer::new_guided`; None: built here).
#[allow(clippy::too_many_arguments)]
pub fn probe_pixels(
    scene: &Scene,
    rt: &RayTracer,
    view: &ViewSamples,
    pixels: &[(u32, u32)],
    opts: &ProbeOptions,
    lights: Option<LightSet>,
    env: Option<Arc<SampledEnvironment>>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<ProbeEstimate>> {
    let tracer = match lights {
        Some(l) => PathTracer::with_lights(scene, rt, l, opts)?,
        None => PathTracer::new_guided(scene, rt, opts, env)?,
    };
    let (w, h) = (view.width, view.height);
    if view.len() < view.num_pixels() || w != scene.camera.width || h != scene.camera.height {
        return Err(Error::invalid(format!(
            "the view samples ({}x{}, {} samples) are not the scene's film ({}x{})",
            w,
            h,
            view.len(),
            scene.camera.width,
            scene.camera.height
        )));
    }
    if let Some((k, &(x, y))) = pixels.iter().enumerate().find(|(_, &(x, y))| x >= w || y >= h) {
        return Err(Error::invalid(format!("probe {k} is pixel (x={x}, y={y}), outside the {w}x{h} film")));
    }
    let blocks = opts.spp.div_ceil(BLOCK) as usize;
    let units = pixels.len() * blocks;
    let total_paths = pixels.len() * opts.spp as usize;
    // Chunks of about 4096 paths between interruption checks and progress calls.
    let chunk = (4096 / BLOCK as usize).max(rayon::current_num_threads() * 2);
    let mut sums: Vec<(DVec3, DVec3)> = Vec::with_capacity(units);
    let mut start = 0usize;
    crate::interrupt::check_now()?;
    while start < units {
        crate::interrupt::check()?;
        let end = (start + chunk).min(units);
        let part: Vec<(DVec3, DVec3)> = (start..end)
            .into_par_iter()
            .map(|unit| {
                let (k, b) = (unit / blocks, (unit % blocks) as u32);
                let (x, y) = pixels[k];
                let i = (y * w + x) as usize;
                let mut rng = stream(opts.seed, STREAM_PATH, ((k as u64) << 32) | b as u64);
                let n = BLOCK.min(opts.spp - b * BLOCK);
                let (mut s1, mut s2) = (DVec3::ZERO, DVec3::ZERO);
                for _ in 0..n {
                    let v = tracer.path(view, i, &mut rng).as_dvec3();
                    s1 += v;
                    s2 += v * v;
                }
                (s1, s2)
            })
            .collect();
        sums.extend(part);
        start = end;
        progress((start / blocks * opts.spp as usize).min(total_paths), total_paths);
    }
    let n = opts.spp as f64;
    Ok(sums
        .chunks(blocks)
        .map(|c| {
            let (s1, s2) = c.iter().fold((DVec3::ZERO, DVec3::ZERO), |a, b| (a.0 + b.0, a.1 + b.1));
            let mean = s1 / n;
            let var = ((s2 - s1 * mean) / (n - 1.0)).max(DVec3::ZERO) / n;
            ProbeEstimate { mean: mean.as_vec3(), variance_of_mean: var.as_vec3() }
        })
        .collect())
}

pub(crate) mod vertex;

#[cfg(test)]
mod tests;
