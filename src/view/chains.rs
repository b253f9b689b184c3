//! Delta BSDF chains: what a pixel sees through mirrors, glass and smooth plastic's specular layer.
//!
//! A camera ray that hits a delta BSDF (`conductor`, `dielectric`, the specular layer of `plastic`) is
//! continued deterministically along every delta lobe to the first surface with a non-delta BSDF, as
//! the expectation of Mitsuba 3's `path` integrator (`src/integrators/path.cpp`) computes it:
//! - `conductor` (one-sided; `twosided` flips the side): the mirror direction about the shading normal,
//!   weight `specular_reflectance * fresnel_conductor(cos_theta_i, eta + i k)`.
//! - `dielectric`: both branches of Mitsuba's `dielectric.cpp` `sample` (the reflected one with the
//!   Fresnel reflectance R, the refracted one with `(1 - R) * eta_ti^2`, radiance mode: the solid-angle
//!   compression when crossing the interface); total internal reflection keeps only the reflection.
//!   `specular_reflectance` / `specular_transmittance` are 1 (the loader keeps no other value).
//! - `thindielectric` (both sides, `thindielectric.cpp`): the mirror branch with the slab's reflectance
//!   R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R) (R = fresnel(|cos_theta_i|, eta)) times
//!   `specular_reflectance`, and the straight-through branch (`-wi`, Mitsuba's null transmission, no eta^2
//!   scaling) with 1 - R' times `specular_transmittance`. Its transmission is a null lobe, yet Mitsuba's
//!   `path` integrator tests shadow rays with `ray_test`, which any surface blocks: a light behind a
//!   thin pane reaches a view sample only through these chains, never through a shadow ray.
//! - `plastic` (one-sided): the specular branch `specular_reflectance * F(cos_theta_i, eta)`; the
//!   plastic surface itself stays a view sample for its diffuse lobe.
//! Directions are built in the shading frame (reflection: `2 (wi . n_s) n_s - wi`; refraction:
//! Mitsuba's `refract(wi, cos_theta_t, eta_ti)`), rays leave with Mitsuba's `spawn_ray` offsets and are
//! traced with the CPU `RayTracer`. Every branch multiplies its RGB throughput by the weight.
//!
//! Path depth follows Mitsuba's `max_depth` (`ChainOptions::max_depth`, -1 = unlimited): a vertex reached
//! after k delta bounces adds its emission (an area emitter seen from its front, or the environment when
//! the branch escapes) when `k < max_depth`, and becomes a view sample (a row of direct light: emitter
//! sampling) when `k + 1 < max_depth`, exactly the conditions of `path.cpp` (`active_next = depth + 1 <
//! max_depth`, emission at every intersection reached). So at `max_depth = 2` a mirror shows the
//! emitters it reflects but no lit walls, as Mitsuba's image does.
//!
//! Bounds (deviations from Mitsuba's unbounded expectation, each a bias of at most the dropped
//! throughput times the radiance it would have carried): a branch stops after `max_bounces` delta
//! bounces (also with `max_depth = -1`), a branch whose throughput falls below `min_throughput` (all
//! channels) is dropped, and a pixel keeps at most `max_samples_per_pixel` extra samples (the later ones
//! are dropped). `ChainStats` counts all three. Russian roulette is not needed (the sum is exact).
//!
//! Media (`Scene::media`, present when the scene's integrator is `volpath`/`volpathmis`): each branch
//! tracks the medium it travels in as Mitsuba's `volpath` does (the camera is in none; leaving a shape
//! with media enters its `exterior` on the side of the geometric normal, else its `interior`; leaving
//! any other shape keeps the medium) and multiplies its throughput by the Beer-Lambert transmittance
//! `exp(-sigma_t t)` of every segment (an escaping branch inside a medium with sigma_t > 0 carries 0).
//! That is the expectation of `volpath` for absorbing media (albedo 0); in-scattering is not modelled.
//! The direct light of a view sample reached inside a medium is not attenuated (`ChainStats::in_medium`
//! counts them): exact when its lights are outside the medium's closed boundary, which blocks their shadow
//! rays anyway (Mitsuba's shadow rays pass only null BSDFs).
//!
//! Masked surfaces (`mask`, semantics and measurements in `crate::raytrace::mask`): a vertex on a masked
//! surface of opacity a (at its uv) is a view sample of the nested BSDF with throughput times a, and the
//! chain continues straight through (`-wi`, Mitsuba's null lobe) with throughput times 1 - a, one delta
//! bounce deeper; a mask around a BSDF with delta lobes (conductor, dielectric, thindielectric, plastic's
//! coating) also follows those lobes with throughput times a (its own sample, if any, times a as above).
//! Each sample records `ViewSamples::mask_budget` (max_depth - 2 - k: how many masked
//! surfaces its shadow rays toward area and environment lights and VPLs may cross; unlimited for
//! max_depth -1) and a masked sample reached from the camera through null events only records
//! `ViewSamples::mask_valid` (Mitsuba's `valid_ray` factor P_valid on its direct light).
//!
//! Emission at the camera's own hit (k = 0) is `matrix::emitted`'s; this module collects k >= 1.
use crate::error::{Error, Result};
use crate::lights::generate::environment::Environment;
use crate::raytrace::mask::Masks;
use crate::raytrace::{spawn_ray, RayTracer};
use crate::scene::{Bsdf, Scene};
use crate::shading::bsdf::{fresnel, fresnel_conductor, KIND_NONE, KIND_SMOOTH};
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// How delta chains are followed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainOptions {
    /// Mitsuba's `path` `max_depth`: -1 = unlimited, else >= 2 (2 = direct light only).
    pub max_depth: i32,
    /// Most delta bounces along one branch (bounds `max_depth = -1`).
    pub max_bounces: u32,
    /// A branch whose throughput is below this in every channel is dropped.
    pub min_throughput: f32,
    /// Most extra view samples per pixel.
    pub max_samples_per_pixel: usize,
}

impl Default for ChainOptions {
    fn default() -> Self {
        ChainOptions { max_depth: -1, max_bounces: 8, min_throughput: 1e-3, max_samples_per_pixel: 32 }
    }
}

impl ChainOptions {
    /// Options with Mitsuba's `max_depth` and the default bounds.
    ///
    /// Errors: `InvalidParameter` unless `max_depth == -1` or `max_depth >= 2`.
    pub fn with_max_depth(max_depth: i64) -> Result<ChainOptions> {
        if max_depth != -1 && max_depth < 2 {
            return Err(Error::invalid(format!(
                "max_depth must be -1 (unlimited) or >= 2 (Mitsuba's path depth; 2 = direct light only), got {max_depth}"
            )));
        }
        Ok(ChainOptions { max_depth: max_depth.min(i32::MAX as i64) as i32, ..Default::default() })
    }

    fn check(&self) -> Result<()> {
        if self.max_depth != -1 && self.max_depth < 2 {
            return Err(Error::invalid(format!("max_depth must be -1 or >= 2, got {}", self.max_depth)));
        }
        if !(self.min_throughput.is_finite() && self.min_throughput >= 0.0) {
            return Err(Error::invalid(format!("min_throughput must be finite and >= 0, got {}", self.min_throughput)));
        }
        Ok(())
    }

    /// Whether emission at a vertex after k delta bounces counts (`k < max_depth`).
    fn emits(&self, k: u32) -> bool {
        self.max_depth < 0 || (k as i64) < self.max_depth as i64
    }

    /// Whether a vertex after k delta bounces samples emitters (`k + 1 < max_depth`).
    fn samples(&self, k: u32) -> bool {
        self.max_depth < 0 || (k as i64) + 1 < self.max_depth as i64
    }

    /// How many masked surfaces a shadow ray of a vertex after k bounces may cross: j with
    /// k + 1 + j < max_depth (`crate::raytrace::mask`); `u32::MAX` for max_depth -1.
    pub fn mask_budget(&self, k: u32) -> u32 {
        if self.max_depth < 0 {
            u32::MAX
        } else {
            (self.max_depth as i64 - 2 - k as i64).clamp(0, u32::MAX as i64 - 1) as u32
        }
    }
}

/// What `trace_chains` did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChainStats {
    /// Extra view samples added.
    pub extra_samples: usize,
    /// Branches dropped below `min_throughput`.
    pub dropped_throughput: usize,
    /// Branches stopped by `max_bounces`.
    pub dropped_bounces: usize,
    /// Samples dropped by `max_samples_per_pixel`.
    pub dropped_samples: usize,
    /// Extra samples reached inside a medium (their direct light is not attenuated; module docs).
    pub in_medium: usize,
}

/// The delta lobes of a BSDF.
#[derive(Debug, Clone, Copy)]
enum Delta {
    Conductor { eta: Vec3, k: Vec3, specular: Vec3 },
    Dielectric { eta: f32 },
    Plastic { eta: f32, specular: Vec3 },
    Thin { eta: f32, specular: Vec3, transmittance: Vec3 },
}

/// The lobes a chain follows at a vertex: a masked surface's null lobe (straight through with weight
/// 1 - opacity) and the delta lobes of its BSDF (the nested one's for a mask, weighted by the opacity), with
/// its two-sidedness.
#[derive(Debug, Clone, Copy)]
struct Lobes {
    /// The opacity a of a masked surface.
    null: Option<f32>,
    delta: Option<(Delta, bool)>,
}

impl Lobes {
    /// The branches (outgoing world direction, RGB weight, whether it is the null lobe) at a point with
    /// shading normal `n` seen along `wi` (`branches`).
    fn branches(&self, wi: Vec3, n: Vec3) -> Vec<(Vec3, Vec3, bool)> {
        let a = self.null.unwrap_or(1.0);
        let mut out: Vec<(Vec3, Vec3, bool)> = Vec::new();
        if a < 1.0 {
            out.push((-wi, Vec3::splat(1.0 - a), true));
        }
        if let Some((d, twosided)) = self.delta {
            if a > 0.0 {
                out.extend(branches(d, twosided, wi, n).into_iter().map(|(w, t)| (w, t * a, false)));
            }
        }
        out
    }
}

/// The delta lobes of scene BSDF `index` (resolved at the point as `b`), with its two-sidedness.
fn delta_of(bsdfs: &[Bsdf], index: usize, b: &GpuBsdf, twosided: bool) -> Option<(Delta, bool)> {
    match bsdfs.get(index)? {
        Bsdf::TwoSided { front, .. } if *front != index => delta_of(bsdfs, *front, b, true),
        Bsdf::Mask { nested, .. } if *nested != index => delta_of(bsdfs, *nested, b, twosided),
        Bsdf::Conductor { eta, k, .. } => Some((Delta::Conductor { eta: *eta, k: *k, specular: Vec3::from(b.specular) }, twosided)),
        Bsdf::Dielectric { int_ior, ext_ior } => Some((Delta::Dielectric { eta: int_ior / ext_ior }, twosided)),
        Bsdf::ThinDielectric { int_ior, ext_ior, .. } => {
            Some((Delta::Thin { eta: int_ior / ext_ior, specular: Vec3::from(b.specular), transmittance: Vec3::from(b.k) }, twosided))
        }
        Bsdf::Plastic { int_ior, ext_ior, .. } => {
            let specular = Vec3::from(b.specular);
            (specular != Vec3::ZERO).then_some((Delta::Plastic { eta: int_ior / ext_ior, specular }, twosided))
        }
        _ => None,
    }
}

/// Mitsuba's dielectric `fresnel(cos_theta_i, eta)`: (R, cos_theta_t, eta_ti); cos_theta_t has the
/// opposite sign of cos_theta_i.
fn fresnel_full(cos_theta_i: f32, eta: f32) -> (f32, f32, f32) {
    let eta_ti = if cos_theta_i >= 0.0 { 1.0 / eta } else { eta };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let ct = cos_theta_t_sqr.max(0.0).sqrt();
    let cos_theta_t = if cos_theta_i >= 0.0 { -ct } else { ct };
    (fresnel(cos_theta_i, eta), cos_theta_t, eta_ti)
}

/// The delta branches (outgoing world direction, RGB weight) at a point with shading normal `n` seen
/// along `wi` (unit, pointing away from the surface toward the previous vertex).
fn branches(delta: Delta, twosided: bool, wi: Vec3, n: Vec3) -> Vec<(Vec3, Vec3)> {
    let cos_i = wi.dot(n);
    let reflect = |n: Vec3, c: f32| (2.0 * c * n - wi).normalize();
    match delta {
        Delta::Conductor { .. } | Delta::Plastic { .. } => {
            // One-sided; `twosided` evaluates the back side as the front with the normal flipped.
            let (n, c) = if twosided && cos_i < 0.0 { (-n, -cos_i) } else { (n, cos_i) };
            if c <= 0.0 {
                return Vec::new();
            }
            let w = match delta {
                Delta::Conductor { eta, k, specular } => {
                    specular
                        * Vec3::new(fresnel_conductor(c, eta.x, k.x), fresnel_conductor(c, eta.y, k.y), fresnel_conductor(c, eta.z, k.z))
                }
                Delta::Plastic { eta, specular } => specular * fresnel(c, eta),
                Delta::Dielectric { .. } | Delta::Thin { .. } => unreachable!(),
            };
            vec![(reflect(n, c), w)]
        }
        Delta::Thin { eta, specular, transmittance } => {
            let r = fresnel(cos_i.abs(), eta);
            let r = r * (2.0 / (1.0 + r));
            let mut out = Vec::with_capacity(2);
            if r > 0.0 && specular != Vec3::ZERO {
                out.push((reflect(n, cos_i), specular * r));
            }
            if r < 1.0 && transmittance != Vec3::ZERO {
                out.push((-wi, transmittance * (1.0 - r)));
            }
            out
        }
        Delta::Dielectric { eta } => {
            let (r, cos_t, eta_ti) = fresnel_full(cos_i, eta);
            let mut out = Vec::with_capacity(2);
            if r > 0.0 {
                out.push((reflect(n, cos_i), Vec3::splat(r)));
            }
            if r < 1.0 {
                // Mitsuba's refract(wi, cos_theta_t, eta_ti) = (-eta_ti wi.xy, cos_theta_t) in the frame of n.
                let t = (-eta_ti * (wi - cos_i * n) + cos_t * n).normalize();
                out.push((t, Vec3::splat((1.0 - r) * eta_ti * eta_ti)));
            }
            out
        }
    }
}

/// A delta vertex: position, geometric and shading normals, direction back along the incoming ray, its
/// mesh and the medium the incoming ray travelled in.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    p: Vec3,
    n_g: Vec3,
    n_s: Vec3,
    wi: Vec3,
    mesh: usize,
    medium: Option<usize>,
}

/// One extra view sample.
#[derive(Debug, Clone, Copy)]
struct Extra {
    position: Vec3,
    normal: Vec3,
    geo_normal: Vec3,
    wi: Vec3,
    uv: Vec2,
    shape_index: i32,
    prim_index: i32,
    bsdf: GpuBsdf,
    throughput: Vec3,
    /// `ViewSamples::mask_budget` and `ViewSamples::mask_valid` of the sample.
    mask_budget: u32,
    mask_valid: f32,
    mask_opacity: f32,
}

struct Tracer<'a> {
    scene: &'a Scene,
    rt: &'a RayTracer,
    env: Option<Environment>,
    area: crate::matrix::emitted::AreaRadiance<'a>,
    opts: ChainOptions,
    masks: &'a Masks,
}

/// The result of one pixel.
#[derive(Default)]
struct PixelChains {
    extras: Vec<Extra>,
    emitted: Vec3,
    stats: ChainStats,
}

impl Tracer<'_> {
    /// Follow the delta lobes at a vertex reached after `k` delta bounces.
    #[allow(clippy::too_many_arguments)]
    fn follow(&self, out: &mut PixelChains, v: Vertex, lobes: Lobes, throughput: Vec3, k: u32, all_null: bool) {
        let Vertex { p, n_g, n_s, wi, mesh: from, medium } = v;
        for (wo, w, null) in lobes.branches(wi, n_s) {
            // Reached from the camera through null events only (Mitsuba's `valid_ray` still false).
            let all_null = all_null && null;
            let mut tp = throughput * w;
            let medium = self.scene.media.after(medium, from, wo, n_g);
            let k1 = k + 1;
            if !self.opts.emits(k1) {
                continue;
            }
            if tp.max_element() < self.opts.min_throughput || !tp.is_finite() {
                out.stats.dropped_throughput += 1;
                continue;
            }
            if k1 > self.opts.max_bounces {
                out.stats.dropped_bounces += 1;
                continue;
            }
            let o = spawn_ray(p, n_g, wo);
            let Some(si) = self.rt.intersect(o, wo, 0.0, f32::INFINITY) else {
                if let Some(env) = &self.env {
                    out.emitted +=
                        tp * self.scene.media.transmittance(medium, f32::INFINITY) * crate::matrix::emitted::sanitized(env.radiance(wo));
                }
                continue;
            };
            if medium.is_some() {
                tp *= self.scene.media.transmittance(medium, (si.p - o).length());
            }
            let l = self.area.at(si.mesh, si.uv);
            if l != Vec3::ZERO && si.wi.dot(si.n_s) > 0.0 {
                out.emitted += tp * l;
            }
            let mesh = &self.scene.meshes[si.mesh];
            let mut bsdf = crate::shading::bsdf::resolve(&self.scene.bsdfs, &self.scene.textures, mesh.bsdf, si.uv);
            crate::shading::perturb::apply(self.scene, si.mesh, si.prim, si.p, si.n_g, si.n_s, si.uv, &mut [&mut bsdf]);
            let opacity = self.masks.opacity(si.mesh, si.uv);
            if bsdf.kind != KIND_SMOOTH && bsdf.kind != KIND_NONE && self.opts.samples(k1) && opacity != Some(0.0) {
                if out.extras.len() < self.opts.max_samples_per_pixel {
                    let (throughput, mask_valid) = match opacity {
                        Some(a) => (tp * a, if all_null { self.valid_probability(si.p, si.n_g, si.wi, a, k1) } else { 1.0 }),
                        None => (tp, 1.0),
                    };
                    out.stats.in_medium += medium.is_some() as usize;
                    out.extras.push(Extra {
                        position: si.p,
                        normal: si.n_s,
                        geo_normal: si.n_g,
                        wi: si.wi,
                        uv: si.uv,
                        shape_index: si.mesh as i32,
                        prim_index: si.prim as i32,
                        bsdf,
                        throughput,
                        mask_budget: self.opts.mask_budget(k1),
                        mask_valid,
                        mask_opacity: opacity.unwrap_or(1.0),
                    });
                } else {
                    out.stats.dropped_samples += 1;
                }
            }
            if let Some(d) = vertex_delta(self.scene, self.masks, si.mesh, &bsdf, si.uv) {
                let next = Vertex { p: si.p, n_g: si.n_g, n_s: si.n_s, wi: si.wi, mesh: si.mesh, medium };
                self.follow(out, next, d, tp, k1, all_null);
            }
        }
    }

    /// Mitsuba's `valid_ray` factor (`crate::raytrace::mask` module docs) of an active masked vertex
    /// of opacity `a` at depth `k`, reached from the camera through null events only: a + (1 - a) P_next.
    fn valid_probability(&self, p: Vec3, n_g: Vec3, wi: Vec3, a: f32, k: u32) -> f32 {
        if self.masks.environment {
            return 1.0;
        }
        let (mut p, mut n_g, mut k) = (p, n_g, k);
        let d = -wi;
        // Product of the null probabilities so far, and the valid probability accumulated.
        let (mut null, mut valid) = (1.0 - a, a);
        for _ in 0..=self.opts.max_bounces {
            if null <= 0.0 {
                break;
            }
            let Some(si) = self.rt.intersect(spawn_ray(p, n_g, d), d, 0.0, f32::INFINITY) else {
                break;
            };
            k += 1;
            if !self.opts.samples(k) {
                // The last vertex: Mitsuba's vectorised loop still draws its BSDF sample (module docs).
                valid += null * self.masks.opacity(si.mesh, si.uv).unwrap_or(1.0);
                break;
            }
            match self.masks.opacity(si.mesh, si.uv) {
                Some(b) => {
                    valid += null * b;
                    null *= 1.0 - b;
                }
                None => {
                    valid += null;
                    break;
                }
            }
            (p, n_g) = (si.p, si.n_g);
        }
        valid.min(1.0)
    }
}

/// The lobes at a vertex of mesh `mesh` (BSDF resolved there as `b`, at `uv`): a masked surface's null
/// lobe and `delta_of` its BSDF (the nested one's delta lobes for a mask), None when it has neither.
fn vertex_delta(scene: &Scene, masks: &Masks, mesh: usize, b: &GpuBsdf, uv: Vec2) -> Option<Lobes> {
    let lobes = Lobes { null: masks.opacity(mesh, uv), delta: delta_of(&scene.bsdfs, scene.meshes.get(mesh)?.bsdf, b, false) };
    (lobes.null.is_some() || lobes.delta.is_some()).then_some(lobes)
}

/// Whether any BSDF of the scene has a delta lobe or a null lobe (`mask`; then `trace_chains` has work to do).
pub fn scene_has_delta(scene: &Scene) -> bool {
    crate::raytrace::mask::scene_has_masks(scene)
        || scene.bsdfs.iter().any(|b| match b {
            Bsdf::Conductor { .. } | Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } => true,
            Bsdf::Plastic { specular_reflectance, .. } => {
                !matches!(specular_reflectance, crate::scene::Param::Value(v) if *v == Vec3::ZERO)
            }
            _ => false,
        })
}

/// Appends to `view` (whose samples are exactly its `width * height` camera hits) the extra samples
/// reached through delta chains from every pixel, and sets `chain_emitted` and `throughput` (module
/// docs). A scene without delta BSDFs leaves `view` unchanged.
///
/// Errors: `InvalidParameter` for bad options or a view that already has extra samples; `Scene` errors
/// of `RayTracer::new` (invalid meshes).
pub fn trace_chains(scene: &Scene, view: &mut ViewSamples, opts: &ChainOptions) -> Result<ChainStats> {
    opts.check()?;
    let m = view.num_pixels();
    if view.len() != m || !view.extra_pixel.is_empty() {
        return Err(Error::invalid(format!("trace_chains needs the {m} camera samples only, got {}", view.len())));
    }
    if !scene_has_delta(scene) {
        return Ok(ChainStats::default());
    }
    let masks = Masks::new(scene);
    if masks.any() {
        view.mask_budget = vec![opts.mask_budget(0); m];
        view.mask_valid = vec![1.0; m];
        view.mask_opacity = vec![1.0; m];
        view.mask_emitter_pdf = crate::raytrace::mask::emitter_area_pdfs(scene);
    }
    let starts: Vec<(usize, Lobes)> = (0..m)
        .filter_map(|i| {
            let s = view.shape_index[i];
            if s < 0 {
                return None;
            }
            vertex_delta(scene, &masks, s as usize, &view.bsdf[i], view.uv[i]).map(|d| (i, d))
        })
        .collect();
    if starts.is_empty() {
        return Ok(ChainStats::default());
    }
    let rt = RayTracer::new(scene)?;
    let tracer = Tracer {
        scene,
        rt: &rt,
        env: Environment::from_scene(scene),
        area: crate::matrix::emitted::AreaRadiance::new(scene),
        opts: *opts,
        masks: &masks,
    };
    let results: Vec<(usize, PixelChains, Option<(f32, f32)>)> = starts
        .par_iter()
        .with_min_len(16)
        .map(|&(i, d)| {
            let mut out = PixelChains::default();
            let v = Vertex {
                p: view.position[i],
                n_g: view.geo_normal[i],
                n_s: view.normal[i],
                wi: view.wi[i],
                mesh: view.shape_index[i] as usize,
                medium: None,
            };
            tracer.follow(&mut out, v, d, Vec3::ONE, 0, true);
            // A masked camera hit: its own sample is weighted by the opacity (module docs).
            let own = d.null.map(|opacity| {
                let valid = if opts.samples(0) { tracer.valid_probability(v.p, v.n_g, v.wi, opacity, 0) } else { 1.0 };
                (opacity, valid)
            });
            (i, out, own)
        })
        .collect();
    let mut stats = ChainStats::default();
    view.throughput = vec![Vec3::ONE; m];
    view.chain_emitted = vec![Vec3::ZERO; m];
    for (i, r, own) in results {
        if let Some((opacity, valid)) = own {
            view.throughput[i] = Vec3::splat(opacity);
            view.mask_valid[i] = valid;
            view.mask_opacity[i] = opacity;
        }
        view.chain_emitted[i] = r.emitted;
        stats.dropped_throughput += r.stats.dropped_throughput;
        stats.dropped_bounces += r.stats.dropped_bounces;
        stats.dropped_samples += r.stats.dropped_samples;
        stats.in_medium += r.stats.in_medium;
        stats.extra_samples += r.extras.len();
        for e in r.extras {
            view.position.push(e.position);
            view.normal.push(e.normal);
            view.geo_normal.push(e.geo_normal);
            view.wi.push(e.wi);
            view.uv.push(e.uv);
            view.albedo.push(Vec3::from(e.bsdf.diffuse));
            view.shape_index.push(e.shape_index);
            view.prim_index.push(e.prim_index);
            view.bsdf.push(e.bsdf);
            view.throughput.push(e.throughput);
            if masks.any() {
                view.mask_budget.push(e.mask_budget);
                view.mask_valid.push(e.mask_valid);
                view.mask_opacity.push(e.mask_opacity);
            }
            view.extra_pixel.push(i as u32);
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests;
