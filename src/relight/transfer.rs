//! The diffuse final-gather transfer F_d of direct-to-indirect relighting (Hašan, Pellacini, Bala,
//! "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006, Sec. 3.2-3.3 Eq. 5, 4.3).
//!
//! View samples: the camera hit of every pixel (`ViewSamples`, pixel centres), one per pixel; the extra
//! samples of delta chains (mirrors, glass) get no indirect light (their direct light still comes from the
//! light matrix in `relight`), except in a scene with masked surfaces (below), where every view sample has
//! a row. Gather samples: a `GatherCloud` of n_g = 4^k samples with its
//! `ClusterHierarchy` (the gather image).
//!
//! Each gather sample g is a diffuse emitter of outgoing radiance B_g (RGB, W/m^2/sr) over its area A_g,
//! on the front side of its geometric normal, placed where the light set's VPL of that sample would be
//! (`offset_p(p_g, n_g, n_g)`, as `lights::animated` places gather samples turned into VPLs). For a view
//! sample i (position p, shading normal n, direction to the viewer wi) and wo = (q_g - p) / d the
//! direction toward g, d the distance:
//!
//!   F_d(i, g) = A_g * min(G, clamp) * V(i, g),   G = cos_g * cos_i / (d^2 + A_g / pi)  (`NearField::Disc`),
//!
//! the point-to-disc form factor of a disc of the sample's area facing the receiver (Wallace, Elmquist,
//! Haines 1989): bounded by pi cos_g cos_i / A_g near the sample, within A_g / (pi d^2) of the point's
//! G = cos_g * cos_i / d^2 (`NearField::Point`, exactly the light matrix's VPL) beyond it. The paper clamps
//! F_d instead (4.3, `clamp`, still available); the disc needs no scene-dependent bound: on the bundled
//! cbox lit by a spot at 128x128 the point form's corner spikes make 24% relative L2 against Mitsuba
//! (78% of the squared error in 0.1% of the pixels), the disc 10.6%.
//!
//! cos_g = -wo . n_g(g) > 0 (front side; also -wo . n_s(g) > 0 as the VPL's Lambertian BSDF needs),
//! cos_i = |wo . n| with wo on the same side of n as wi (the diffuse BSDF's `cos theta_o > 0` after a
//! two-sided flip), V one exact shadow ray through the BVH (`RayTracer::occluded`, Mitsuba's offsets; the
//! transmittance through masked surfaces in a scene with masks, below),
//! clamp the geometry-term bound (1/m^2; infinite = none; the paper's "clamp F_d at 0.1", 4.3, in the units
//! of the light set's `vpl_clamp`). F_d is scalar (no colour); the indirect radiance of view sample i is
//!
//!   L_ind(i) = k_d(i) / pi * sum_g F_d(i, g) B_g      (Eq. 5, with the Lambertian BRDF k_d / pi),
//!
//! k_d(i) the view sample's diffuse albedo. With B_g = k_d(g) / pi * E_g (E_g the direct irradiance at g)
//! this is exactly the sum over VPLs of flux Phi_g = E_g A_g and albedo k_d(g) that the light matrix
//! evaluates (`LightSet::emitted`, `cpu::shade`) for a diffuse view sample. A plastic's diffuse lobe is
//! not Lambertian: its scalar dependence on wo is baked into F_d(i, g) and k_d(i) becomes its colour
//! (`diffuse` module), which keeps the identity for plastic receivers too.
//!
//! Hierarchical gather (4.3): from view sample i, the quad-tree is descended from the root; a cluster
//! whose bounding box lies wholly behind the view sample's tangent plane is culled; a cluster with
//! s^2 / d^2 <= `threshold` (s its bounding-box diagonal, d the distance from p to its box centre) or a
//! single sample gets one link: F_d(i, r) for a representative member r (chosen at random per cluster,
//! from the seed), and every member g gets F_d(i, r) A_g / A_r; otherwise its four children are visited.
//! `threshold` = 0 descends to every sample: the exact gather (n_g shadow rays per view sample).
//!
//! Multiple bounces (3.2 Eq. 2): with `bounces` b > 1 and `Multibounce::Photons` (the default; the
//! measurements behind it are in the `multibounce` module docs) the paper's photon-mapped M
//! (`multibounce` module); with `Multibounce::Gather` the same
//! hierarchical gather runs from every gather sample h with k_d(h) > 0 as a receiver (its surface point,
//! shading normal and geometric normal, lit from the front side), giving the gather-to-gather transfer
//! F_gg(h, g) = A_g min(G, clamp) V(h, g); its rows are compressed the same way to
//! `multibounce_coefficients` (the paper's 40 for M). Relighting applies K = diag(k_d / pi) F_gg b - 1
//! times to the gather samples' radiance, so M = K + ... + K^(b-1) (exact visibility, no photon noise).
//!
//! Glossy view samples (3.3 Eq. 6, 4.3): with `glossy` (default on) the pixels whose BSDF has a glossy
//! lobe also get a row of the glossy final gather F_g (`glossy` module), the view direction's BSDF baked
//! in; relighting adds k_g(i) F_g^w b^w.
//!
//! Masked surfaces (Mitsuba's `mask`): every view sample gets a row and the segments carry the
//! transmittance through the masks within Mitsuba's depth (`masks` module).
//!
//! Compression (3.3, 4.3): each row F_d(i, .) is laid out as the gather image, projected by the 2D Haar
//! transform (`haar::forward`) and culled to its `coefficients` most important coefficients
//! (`haar::cull_area_weighted`). Rows are computed in parallel (rayon), with interruption checks.
pub(crate) use super::form_factor::behind_tangent_plane;
pub use super::form_factor::{geometry, geometry_patch};
use super::haar::{self, SparseRow};
use super::hierarchy::ClusterHierarchy;
use super::masks::{gather_mask_budget, gather_opacity, receives_indirect, row_samples, view_mask_budget};
use crate::cpu::ShadingPoint;
use crate::error::{Error, Result};
use crate::lights::gather::{GatherCloud, GatherOptions};
use crate::raytrace::{offset_p, RayTracer};
use crate::scene::Scene;
use crate::shading::bsdf::FLAG_TWOSIDED;
use crate::view::ViewSamples;
use glam::Vec3;
use std::time::Instant;

/// Kept wavelet coefficients per F_d row when none are given (the paper's 100).
pub const DEFAULT_COEFFICIENTS: usize = 100;
/// Solid-angle threshold s^2 / d^2 when none is given: on the 32x32 test box with 4^6 gather samples it
/// casts 3.5x fewer shadow rays than the exact gather for a relative L2 change of 0.04% (against
/// Mitsuba: 2.76% vs 2.72%; tests/relight/test_relight.py).
pub const DEFAULT_THRESHOLD: f32 = 0.03;
/// Receivers per parallel task.
const ROW_CHUNK: usize = 16;
/// Receivers between interruption checks and progress reports.
const ROW_BLOCK: usize = 256;
/// Wavelet coefficients kept per gather-to-gather row when none are given (the paper's 40 for M).
pub const DEFAULT_MULTIBOUNCE_COEFFICIENTS: usize = 40;
pub use super::multibounce::Multibounce;

/// What `Transfer::new` computes.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferOptions {
    /// n_g, a power of 4.
    pub gather: usize,
    /// Wavelet coefficients kept per row (1 ..= n_g).
    pub coefficients: usize,
    /// Seeds the gather cloud and the clusters' representatives.
    pub seed: u64,
    /// Eq. 9's K of the hierarchy.
    pub k_weight: f32,
    /// Solid-angle threshold of the hierarchical gather (>= 0; 0 = exact per-sample gather).
    pub threshold: f32,
    /// Bound on the geometry term G (1/m^2, > 0; infinite = no clamp).
    pub clamp: f32,
    /// Diffuse bounces of indirect light (>= 1): 1 = F_d only; b > 1 adds b - 1 passes of the
    /// gather-to-gather transfer before the final gather (module docs).
    pub bounces: u32,
    /// Wavelet coefficients kept per gather-to-gather row (1 ..= n_g; used when bounces > 1).
    pub multibounce_coefficients: usize,
    /// How M is computed when bounces > 1 (`multibounce` module docs).
    pub multibounce: Multibounce,
    /// Photons shot from each gather sample (`Multibounce::Photons`).
    pub photons_per_sample: usize,
    /// K of the K-nearest photon queries (`Multibounce::Photons`).
    pub photon_neighbours: usize,
    /// Compute the glossy final gather F_g for glossy pixels (`glossy` module docs).
    pub glossy: bool,
    /// How a gather sample's geometry term behaves near the receiver (`NearField`).
    pub near_field: NearField,
}

/// The geometry term of a gather sample seen by a receiver (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NearField {
    /// The sample is a disc of its area A_g facing the receiver: G = cos_g cos_i / (d^2 + A_g / pi)
    /// (`geometry_patch`), bounded where a point's 1/d^2 spikes (corners, contact).
    #[default]
    Disc,
    /// The sample is a point: G = cos_g cos_i / d^2, exactly the VPL of the light matrix.
    Point,
}

impl NearField {
    /// "disc" or "point".
    pub fn parse(name: &str) -> Result<NearField> {
        match name {
            "disc" => Ok(NearField::Disc),
            "point" => Ok(NearField::Point),
            _ => Err(Error::invalid(format!("near_field must be \"disc\" or \"point\", got {name:?}"))),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            NearField::Disc => "disc",
            NearField::Point => "point",
        }
    }
    /// The patch area `geometry_patch` takes for a sample of area `area`: itself (disc) or 0 (point).
    #[inline]
    pub fn patch_area(self, area: f32) -> f32 {
        match self {
            NearField::Disc => area,
            NearField::Point => 0.0,
        }
    }
}

impl Default for TransferOptions {
    fn default() -> Self {
        TransferOptions {
            gather: 4usize.pow(7),
            coefficients: DEFAULT_COEFFICIENTS,
            seed: 0,
            k_weight: super::hierarchy::DEFAULT_K,
            threshold: DEFAULT_THRESHOLD,
            clamp: f32::INFINITY,
            bounces: 1,
            multibounce_coefficients: DEFAULT_MULTIBOUNCE_COEFFICIENTS,
            multibounce: Multibounce::Photons,
            photons_per_sample: super::multibounce::DEFAULT_PHOTONS_PER_SAMPLE,
            photon_neighbours: super::multibounce::DEFAULT_PHOTON_NEIGHBOURS,
            glossy: true,
            near_field: NearField::Disc,
        }
    }
}

/// The precomputed final-gather transfer of one scene and camera (module docs).
#[derive(Debug, Clone)]
pub struct Transfer {
    pub opts: TransferOptions,
    pub cloud: GatherCloud,
    pub hierarchy: ClusterHierarchy,
    /// Where each gather sample emits from (its VPL position).
    pub emit_position: Vec<Vec3>,
    /// Each gather sample's emitting shading normal (its shading normal, or the geometric one when they
    /// disagree in side), as the VPL takes it.
    pub emit_normal: Vec<Vec3>,
    pub width: u32,
    pub height: u32,
    /// One culled wavelet row per pixel (row-major pixels; empty for background), 1 channel.
    pub rows: Vec<SparseRow>,
    /// 2-norm of every column of the culled F_d^w (the wavelet lights' image norms, Sec. 3.5).
    pub image_norms: Vec<f32>,
    /// One culled wavelet row per gather sample of the gather-to-gather transfer F_gg (empty when
    /// `bounces` = 1; an empty row for samples with k_d = 0), 1 channel.
    pub bounce_rows: Vec<SparseRow>,
    /// One culled wavelet row per gather sample of the photon-mapped M_E (`multibounce`; 3 channels:
    /// RGB values per index; empty unless bounces > 1 with `Multibounce::Photons`; an empty row for
    /// samples with k_d = 0).
    pub photon_rows: Vec<SparseRow>,
    /// Photons deposited for `photon_rows`.
    pub photons: u64,
    /// One culled wavelet row of the glossy final gather F_g per pixel (`glossy`; 1 channel; empty
    /// rows for pixels that are not glossy; no rows at all when no pixel is glossy or `glossy` is off).
    pub glossy_rows: Vec<SparseRow>,
    /// Each pixel's glossy coefficient k_g (RGB, unit mean; 0 for pixels that are not glossy), one per
    /// `glossy_rows` row.
    pub glossy_color: Vec<Vec3>,
    /// 2-norm of every column of the culled F_g^w (empty without glossy rows).
    pub glossy_image_norms: Vec<f32>,
    /// Glossy pixels.
    pub glossy_pixels: usize,
    /// Each gather sample's opacity (`gather_opacity`; empty without masked surfaces): the gather sample
    /// reflects opacity x k_d.
    pub opacity: Vec<f32>,
    /// Shadow rays cast by the precomputation.
    pub shadow_rays: u64,
    /// Links (cluster evaluations) made by the hierarchical gather.
    pub links: u64,
    /// Seconds: gather cloud, hierarchy, rows.
    pub seconds_cloud: f64,
    pub seconds_hierarchy: f64,
    pub seconds_rows: f64,
    pub seconds_bounce_rows: f64,
    pub seconds_glossy_rows: f64,
}

/// A deterministic random member index in 0..size for cluster (depth, c).
fn representative(seed: u64, depth: u32, c: usize, size: usize) -> usize {
    let mut x = seed ^ ((depth as u64) << 56) ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^= x >> 31;
    (x % size as u64) as usize
}

impl Transfer {
    /// Samples the gather cloud on `scene`, builds its hierarchy and computes the culled F_d^w rows of
    /// the camera hits of `view` (module docs).
    ///
    /// Errors: `InvalidParameter` for n_g not a power of 4, coefficients outside 1 ..= n_g, a negative or
    /// non-finite threshold, a clamp that is not > 0; what `GatherCloud::new` and the hierarchy raise;
    /// `Interrupted`.
    pub fn new(
        scene: &Scene,
        view: &ViewSamples,
        tracer: &RayTracer,
        opts: &TransferOptions,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Transfer> {
        crate::lights::gather::gather_levels(opts.gather)?;
        if !(1..=opts.gather).contains(&opts.coefficients) {
            return Err(Error::invalid(format!(
                "final_gather_coefficients must be in 1 ..= gather ({}), got {}",
                opts.gather, opts.coefficients
            )));
        }
        if !(opts.threshold >= 0.0 && opts.threshold.is_finite()) {
            return Err(Error::invalid(format!("threshold must be finite and >= 0, got {}", opts.threshold)));
        }
        if opts.bounces < 1 || opts.bounces > 64 {
            return Err(Error::invalid(format!("bounces must be in 1 ..= 64, got {}", opts.bounces)));
        }
        if opts.bounces > 1 && !(1..=opts.gather).contains(&opts.multibounce_coefficients) {
            return Err(Error::invalid(format!(
                "multibounce_coefficients must be in 1 ..= gather ({}), got {}",
                opts.gather, opts.multibounce_coefficients
            )));
        }
        super::multibounce::check_options(opts)?;
        if opts.clamp.is_nan() || opts.clamp <= 0.0 {
            return Err(Error::invalid(format!("clamp must be > 0 (or infinite for no clamp), got {}", opts.clamp)));
        }
        let t0 = Instant::now();
        let cloud = GatherCloud::new(scene, &GatherOptions { n: opts.gather, seed: opts.seed, include_emitters: true })?;
        let seconds_cloud = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let hierarchy = ClusterHierarchy::of_cloud(&cloud, opts.k_weight)?;
        let seconds_hierarchy = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let n = cloud.len();
        let emit_position: Vec<Vec3> = (0..n).map(|g| offset_p(cloud.position[g], cloud.geo_normal[g], cloud.geo_normal[g])).collect();
        let emit_normal: Vec<Vec3> =
            (0..n).map(|g| if cloud.normal[g].dot(cloud.geo_normal[g]) > 0.0 { cloud.normal[g] } else { cloud.geo_normal[g] }).collect();
        // Bounds of every cluster's emitting points, per depth (Morton order).
        let levels = hierarchy.levels;
        let bounds: Vec<Vec<(Vec3, Vec3)>> = (0..=levels).map(|d| hierarchy.cluster_bounds(d, &emit_position)).collect();
        let masked = tracer.masks().any();
        let opacity = gather_opacity(tracer.masks(), &cloud);
        let pixels = row_samples(view, masked);
        let ctx = RowContext {
            cloud: &cloud,
            hierarchy: &hierarchy,
            bounds: &bounds,
            emit_position: &emit_position,
            emit_normal: &emit_normal,
            opts,
        };
        // Progress counts the pixels' rows, then the gather samples' rows of the bounce pass.
        let total = pixels + if opts.bounces > 1 { n } else { 0 };
        let (rows, mut shadow_rays, mut links) = ctx.rows(
            tracer,
            pixels,
            opts.coefficients,
            |i| {
                let mut sp = ShadingPoint::new(view, i);
                sp.surface &= receives_indirect(view, masked, i);
                let lobe = super::diffuse::Lobe::of(view, i, sp.wi_local);
                Receiver { sp, twosided: view.bsdf[i].flags & FLAG_TWOSIDED != 0, masks: view_mask_budget(view, masked, i), lobe }
            },
            &mut |d, _| progress(d, total),
        )?;
        let seconds_rows = t2.elapsed().as_secs_f64();
        let t3 = Instant::now();
        let photon = opts.bounces > 1 && opts.multibounce == Multibounce::Photons;
        let (photon_rows, photons) = if photon {
            let r = super::multibounce::photon_rows(scene, tracer, &cloud, &hierarchy, &emit_position, &emit_normal, opts, &mut |d, _| {
                progress(pixels + d, total)
            })?;
            (r.rows, r.photons)
        } else {
            (Vec::new(), 0)
        };
        let bounce_rows = if opts.bounces > 1 && !photon {
            // Each gather sample as a receiver: its surface point, lit from its front side; through masks
            // the one more bounce costs one more unit of depth.
            let budget = masked.then(|| gather_mask_budget(opts.bounces).saturating_sub(1));
            let (r, rays, l) = ctx.rows(
                tracer,
                n,
                opts.multibounce_coefficients,
                |h| {
                    let (nn, ng) = (emit_normal[h], cloud.geo_normal[h]);
                    let (s, t) = crate::lights::coordinate_system(nn);
                    let sp = ShadingPoint {
                        p: cloud.position[h],
                        n: nn,
                        n_g: ng,
                        s,
                        t,
                        wi_local: Vec3::Z,
                        throughput: Vec3::ONE,
                        surface: nn != Vec3::ZERO && cloud.k_d[h].max_element() > 0.0,
                        side: f32::NAN,
                    };
                    Receiver { sp, twosided: false, masks: budget, lobe: None }
                },
                &mut |d, _| progress(pixels + d, total),
            )?;
            shadow_rays += rays;
            links += l;
            r
        } else {
            Vec::new()
        };
        let seconds_bounce_rows = t3.elapsed().as_secs_f64();
        let t4 = Instant::now();
        // The glossy rows report no progress of their own (their time is `seconds_glossy_rows`): their
        // count is known only here, after the caller sized its progress display.
        let glossy = if opts.glossy {
            super::glossy::glossy_rows(view, pixels, tracer, &cloud, &hierarchy, &emit_position, &emit_normal, opts, &mut |_, _| {})?
        } else {
            super::glossy::GlossyRows { rows: Vec::new(), color: Vec::new(), pixels: 0, shadow_rays: 0, links: 0 }
        };
        shadow_rays += glossy.shadow_rays;
        links += glossy.links;
        let glossy_image_norms = if glossy.rows.is_empty() { Vec::new() } else { haar::column_norms(&glossy.rows, n, 1)? };
        let seconds_glossy_rows = t4.elapsed().as_secs_f64();
        let image_norms = haar::column_norms(&rows, n, 1)?;
        Ok(Transfer {
            opts: opts.clone(),
            cloud,
            hierarchy,
            emit_position,
            emit_normal,
            width: view.width,
            height: view.height,
            rows,
            image_norms,
            shadow_rays,
            links,
            seconds_cloud,
            seconds_hierarchy,
            seconds_rows,
            bounce_rows,
            seconds_bounce_rows,
            photon_rows,
            photons,
            glossy_rows: glossy.rows,
            glossy_color: glossy.color,
            glossy_image_norms,
            glossy_pixels: glossy.pixels,
            seconds_glossy_rows,
            opacity,
        })
    }

    /// Wavelet coefficients kept, over all final-gather rows.
    pub fn coefficients_kept(&self) -> usize {
        self.rows.iter().map(|r| r.index.len()).sum()
    }

    /// Wavelet coefficients kept, over all gather-to-gather rows.
    pub fn bounce_coefficients_kept(&self) -> usize {
        self.bounce_rows.iter().map(|r| r.index.len()).sum()
    }

    /// Wavelet coefficients kept, over all photon-mapped M rows (3 values each).
    pub fn photon_coefficients_kept(&self) -> usize {
        self.photon_rows.iter().map(|r| r.index.len()).sum()
    }

    /// Wavelet coefficients kept, over all glossy final-gather rows.
    pub fn glossy_coefficients_kept(&self) -> usize {
        self.glossy_rows.iter().map(|r| r.index.len()).sum()
    }

    /// Bytes of the culled rows of all matrices (a u32 index and an f32 value per coefficient and
    /// channel).
    pub fn bytes(&self) -> usize {
        (self.coefficients_kept() + self.bounce_coefficients_kept() + self.glossy_coefficients_kept()) * 8
            + self.photon_coefficients_kept() * 16
    }
}

/// A receiver of the final gather: its shading point, two-sidedness, the masks its segments may cross
/// (`geometry_patch`) and its diffuse lobe when that is not Lambertian (`diffuse::Lobe`).
struct Receiver {
    sp: ShadingPoint,
    twosided: bool,
    masks: Option<u32>,
    lobe: Option<super::diffuse::Lobe>,
}

struct RowContext<'a> {
    cloud: &'a GatherCloud,
    hierarchy: &'a ClusterHierarchy,
    bounds: &'a [Vec<(Vec3, Vec3)>],
    emit_position: &'a [Vec3],
    emit_normal: &'a [Vec3],
    opts: &'a TransferOptions,
}

impl RowContext<'_> {
    /// Culled wavelet rows (`keep` coefficients each) of `count` receivers, `receiver(i)` giving each one;
    /// returns (rows, rays, links). Parallel, in blocks with
    /// interruption checks and `progress(done, count)` after each.
    fn rows(
        &self,
        tracer: &RayTracer,
        count: usize,
        keep: usize,
        receiver: impl Fn(usize) -> Receiver + Sync,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<(Vec<SparseRow>, u64, u64)> {
        let n = self.cloud.len();
        let side = self.hierarchy.side();
        let mut rows = Vec::with_capacity(count);
        let (mut shadow_rays, mut links) = (0u64, 0u64);
        let mut start = 0;
        while start < count {
            let end = (start + ROW_BLOCK).min(count);
            let part = crate::interrupt::par_map_chunked(end - start, ROW_CHUNK, |k| -> Result<(SparseRow, u64, u64)> {
                let rec = receiver(start + k);
                if !rec.sp.surface {
                    return Ok((SparseRow::default(), 0, 0));
                }
                let mut dense = vec![0f32; n];
                let (rays, l) = self.gather(tracer, &rec, &mut dense);
                let mut image = self.hierarchy.to_image(&dense, 1);
                haar::forward(&mut image, side, 1)?;
                Ok((haar::cull_area_weighted(&image, side, 1, keep)?, rays, l))
            })?;
            for r in part {
                let (row, rays, l) = r?;
                rows.push(row);
                shadow_rays += rays;
                links += l;
            }
            start = end;
            progress(start, count);
        }
        Ok((rows, shadow_rays, links))
    }

    /// Fills the dense row F_d(i, .) (sample order) by the hierarchical gather; returns (rays, links).
    fn gather(&self, tracer: &RayTracer, rec: &Receiver, dense: &mut [f32]) -> (u64, u64) {
        let Receiver { sp, twosided, masks, lobe } = rec;
        let (sp, twosided, masks) = (sp, *twosided, *masks);
        // The side of the tangent plane light may come from (module docs: two-sided flip).
        let side_n = if twosided && sp.wi_local.z < 0.0 { -sp.n } else { sp.n };
        let (mut rays, mut links) = (0u64, 0u64);
        let mut stack = vec![(0u32, 0usize)];
        while let Some((depth, c)) = stack.pop() {
            let (lo, hi) = self.bounds[depth as usize][c];
            if behind_tangent_plane(lo, hi, sp.p, side_n) {
                continue;
            }
            let members = self.hierarchy.cluster(depth, c);
            let s2 = (hi - lo).length_squared();
            let d2 = ((lo + hi) * 0.5 - sp.p).length_squared();
            let leaf = depth == self.hierarchy.levels;
            if !leaf && s2 > self.opts.threshold * d2 {
                for child in 0..4 {
                    stack.push((depth + 1, 4 * c + child));
                }
                continue;
            }
            let r = if members.len() == 1 {
                members[0] as usize
            } else {
                members[representative(self.opts.seed, depth, c, members.len())] as usize
            };
            let area = self.opts.near_field.patch_area(self.cloud.area[r]);
            let (g, tested) = geometry_patch(
                tracer,
                sp,
                twosided,
                self.emit_position[r],
                self.emit_normal[r],
                self.cloud.geo_normal[r],
                self.opts.clamp,
                area,
                masks,
            );
            rays += tested as u64;
            links += 1;
            // A plastic receiver's diffuse lobe toward the representative (`diffuse::Lobe::factor`).
            let g = match lobe {
                Some(lobe) if g > 0.0 => g * lobe.factor(sp.local((self.emit_position[r] - sp.p).normalize())),
                _ => g,
            };
            if g > 0.0 {
                for &m in members {
                    dense[m as usize] = g * self.cloud.area[m as usize];
                }
            }
        }
        (rays, links)
    }
}

#[cfg(test)]
mod tests;
