//! The CPU backend of the light matrix: columns, weighted column sums, rows and elements computed in Rust,
//! in parallel with rayon, with an exact shadow ray per test through the scene BVH (Hašan, Pellacini,
//! Bala, "Matrix Row-Column Sampling for the Many-Light Problem", SIGGRAPH 2007, Sec. 3: A(i, j) is light
//! j's unoccluded contribution to view sample i times its visibility).
//!
//! Shading is the same as the GPU's `shaders/columns.wgsl` and the exact oracle (`matrix::oracle`), which
//! calls `shade` here: for a surface view sample i with shading normal n (Mitsuba's frame
//! `coordinate_system(n)`), `(wo, L, dist) = LightSet::emitted(j, p, n)`,
//! `A(i, j) = bsdf_i(wi_local, wo_local) * L * throughput_i * V(i, j)`, where the BSDF includes the cosine
//! and V is one exact ray with Mitsuba's offsets: `RayTracer::occluded(p, n_g, q)` (`spawn_ray_to`) toward
//! a light at a finite distance, `spawn_ray(p, n_g, wo)` unbounded toward a directional one. Elements
//! whose unshadowed value is 0 (lights behind the surface, outside a spot's cone, a zero BSDF) cast no
//! ray. A pixel's row is the sum of its samples (its camera hit, then its delta-chain samples in order).
//!
//! Shadow rays go in packets of up to 16 (`RayTracer::occluded_packet`): the elements of a group (16
//! consecutive pixels of a column or a weighted sum, or 16 lights of a row, neighbours in space) are shaded
//! unshadowed first, then the rays of the lit ones are traced together, through Embree's 16-wide packets
//! where the build has the `embree` feature and the scene no analytic sphere (`raytrace::embree`: 2-3x the
//! rays per second of one ray at a time on the benchmark's batches), else one at a time through the
//! library's 8-wide BVH (`raytrace::bvh`, 8 child boxes per node per ray). In a scene with masked surfaces
//! every element takes `shade` (transmittance, one ray walk at a time).
//!
//! Work layout (timed side by side with the GPU by `python -m manylights.bench backends`; docs/validation/backends.md):
//! - `weighted_sum(J, w)` (the reconstruction of clustered renderers): lights in blocks, each block
//!   parallel over pixel chunks; within a chunk light by light, PACKET neighbouring pixels at a time (a
//!   piece of a column: coherent rays), each pixel adding its lights in the block's order (no atomics,
//!   no per-column buffers), so the result does not depend on threads.
//! - `columns(J)`: column by column, each parallel over pixel chunks.
//! - `rows(I)`: parallel over (row, light chunk); a row's lights in `spatial_order` (neighbours in space
//!   together, so a packet's rays leave the view sample in similar directions), each element written at
//!   its light's place; a pixel's delta-chain samples add into its row.
//! Interruption (`crate::interrupt`) is checked between blocks; progress after each block.
//!
//! Symbols: m = view samples (pixels + delta-chain samples), n = lights, i a view sample, j a light,
//! p position, n shading normal, n_g geometric normal, wi direction to the viewer, wo direction to the
//! light, L the light's emitted radiance (or irradiance factor) at p, V visibility.
pub mod shadow_rays;
mod spatial_order;

pub use spatial_order::spatial_order;

use crate::error::Result;
use crate::lights::{coordinate_system, LightSet};
use crate::matrix::backend::{Backend, DeviceInfo};
use crate::matrix::rows::{RowOptions, RowTimings, TimedRows};
use crate::matrix::VisibilityStats;
use crate::raytrace::{spawn_ray, spawn_ray_to, RayTracer, PACKET};
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Elements (sample-light pairs) per block between interruption checks and progress reports.
const ELEMENTS_PER_BLOCK: usize = 1 << 20;
/// Pixels per parallel task of `weighted_sum` and `columns`.
const PIXEL_CHUNK: usize = 256;
/// Lights per parallel task of `rows`.
const LIGHT_CHUNK: usize = 1024;

/// A view sample prepared for shading: its frame and the direction to the viewer in it.
#[derive(Debug, Clone, Copy)]
pub struct ShadingPoint {
    pub p: Vec3,
    pub n: Vec3,
    pub n_g: Vec3,
    /// Tangents of Mitsuba's `Frame3f(n)`.
    pub s: Vec3,
    pub t: Vec3,
    /// `wi` in the local frame.
    pub wi_local: Vec3,
    /// RGB throughput of the sample's delta chain (1 for a camera hit).
    pub throughput: Vec3,
    /// False for background samples (no surface): every element is 0.
    pub surface: bool,
    /// Which side of the tangent plane the BSDF reflects light from (`hemisphere::reflecting_side`): 1 above,
    /// -1 below, 0 neither; NaN where it may from both (transmission, perturbed normals).
    pub side: f32,
}

impl ShadingPoint {
    /// View sample `i` of `view`.
    pub fn new(view: &ViewSamples, i: usize) -> ShadingPoint {
        let n = view.normal[i];
        let (s, t) = coordinate_system(n);
        let wi = view.wi[i];
        let wi_local = Vec3::new(wi.dot(s), wi.dot(t), wi.dot(n));
        ShadingPoint {
            p: view.position[i],
            n,
            n_g: view.geo_normal[i],
            s,
            t,
            wi_local,
            throughput: view.throughput_of(i),
            surface: view.shape_index[i] >= 0,
            side: crate::shading::hemisphere::reflecting_side(&view.bsdf, i, wi_local).unwrap_or(f32::NAN),
        }
    }

    /// Whether the BSDF may reflect light arriving from world direction `wo` (false only where it is 0
    /// for certain: `side`).
    #[inline]
    pub fn may_reflect(&self, wo: Vec3) -> bool {
        let z = wo.dot(self.n);
        if self.side == 1.0 {
            z > 0.0
        } else if self.side == -1.0 {
            z < 0.0
        } else {
            self.side != 0.0
        }
    }

    /// `v` (world space) in the sample's shading frame (s, t, n).
    pub fn local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// What shading one element found: its value and whether a shadow ray was cast / was unblocked.
#[derive(Debug, Clone, Copy, Default)]
pub struct Shaded {
    pub value: Vec3,
    /// A shadow ray was cast (the unshadowed value was not 0).
    pub tested: bool,
    /// The ray was unblocked (then `value` is the unshadowed value).
    pub lit: bool,
}

/// Light j's unshadowed contribution to view sample i (prepared as `sp`): (value, wo, distance as
/// `LightSet::emitted` gives them); None where it is 0 (then `shade` casts no ray).
#[inline]
pub fn shade_unshadowed(view: &ViewSamples, lights: &LightSet, sp: &ShadingPoint, i: usize, j: usize) -> Option<(Vec3, Vec3, f32)> {
    if !sp.surface {
        return None;
    }
    let toward = lights.toward(j, sp.p)?;
    // A receiver that reflects nothing from wo's side gives 0 (its BSDF alone is evaluated there, except
    // across a virtual spherical light's cap): the light's emission is never evaluated.
    if !sp.may_reflect(toward.0) && !(lights.vsl_radius[j] > 0.0) {
        return None;
    }
    let (wo, radiance, dist) = lights.emitted_toward(j, sp.p, sp.n, toward)?;
    let wo_local = sp.local(wo);
    let receiver = |w: Vec3| crate::shading::bsdf::eval_records(&view.bsdf, i, sp.wi_local, sp.local(w));
    let mut f = lights.shade_receiver(j, sp.p, wo, radiance, receiver) * sp.throughput;
    if f == Vec3::ZERO {
        // Nothing reaches the receiver's eye from wo (its BSDF is 0 there, or the radiance or the
        // throughput is): no MIS weight, no ray.
        return None;
    }
    if !view.bsdf_samples.is_empty() {
        f *= crate::matrix::glossy::light_weight(view, lights, i, sp.p, sp.wi_local, wo_local, j);
    }
    if let Some(&valid) = view.mask_valid.get(i) {
        // Mitsuba's `valid_ray` factor of a masked sample: direct light only (`raytrace::mask`).
        if valid < 1.0 && lights.kind[j] != crate::lights::LightKind::Vpl {
            f *= crate::raytrace::mask::direct_factor(view, lights, i, sp.p, sp.wi_local, wo_local, j);
        }
    }
    (f != Vec3::ZERO).then_some((f, wo, dist))
}

/// Light j's contribution to view sample i (prepared as `sp`) with exact visibility (module docs).
#[inline]
pub fn shade(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, sp: &ShadingPoint, i: usize, j: usize) -> Shaded {
    let Some((f, wo, dist)) = shade_unshadowed(view, lights, sp, i, j) else {
        return Shaded::default();
    };
    let (v, crossed) = visibility_crossed(tracer, view, lights, i, j, sp.p, sp.n_g, wo, dist);
    if v == 0.0 {
        return Shaded { value: Vec3::ZERO, tested: true, lit: false };
    }
    let mut value = if v == 1.0 { f } else { f * v };
    if crossed && !view.bsdf_samples.is_empty() {
        // Through a mask only Mitsuba's BSDF sampling reaches the light (weight 1), and the glossy
        // BSDF rays (`matrix::glossy::bsdf_image`) stop at masks: the light column carries it all.
        let w = crate::matrix::glossy::light_weight(view, lights, i, sp.p, sp.wi_local, sp.local(wo), j);
        if w > 0.0 {
            value /= w;
        }
    }
    Shaded { value, tested: true, lit: true }
}

/// Whether light j, seen from surface point `p` (geometric normal `n_g`) in direction `wo` at distance
/// `dist` (as `LightSet::emitted` returns them), is blocked: one exact shadow ray with Mitsuba's offsets
/// toward a light at a finite distance, an unbounded one toward a directional light (module docs).
#[inline]
pub fn light_blocked(tracer: &RayTracer, lights: &LightSet, j: usize, p: Vec3, n_g: Vec3, wo: Vec3, dist: f32) -> bool {
    let (o, d, t_max) = light_ray(lights, j, p, n_g, wo, dist);
    tracer.occluded_ray(o, d, t_max)
}

/// The shadow ray `(o, d, t_max)` that [`light_blocked`] traces (module docs): `spawn_ray_to` the light's
/// position at a finite distance, `(spawn_ray(p, n_g, wo), wo, inf)` toward a directional light.
#[inline(always)]
pub fn light_ray(lights: &LightSet, j: usize, p: Vec3, n_g: Vec3, wo: Vec3, dist: f32) -> (Vec3, Vec3, f32) {
    if dist.is_finite() {
        spawn_ray_to(p, n_g, lights.position[j])
    } else {
        (spawn_ray(p, n_g, wo), wo, f32::INFINITY)
    }
}

/// Visibility of light j from view sample i at surface point `p` (geometric normal `n_g`; the sample's
/// own point, or a cluster representative's) toward `wo` at distance `dist` (as `LightSet::emitted`
/// returns them), and whether the ray crossed a masked surface: 0 or 1 (`light_blocked`, never crossed),
/// or in a scene with masked surfaces (the view has `mask_budget`) the expected transmittance of
/// [`mask_visibility_at`] with the sample's budget.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn visibility_crossed(
    tracer: &RayTracer,
    view: &ViewSamples,
    lights: &LightSet,
    i: usize,
    j: usize,
    p: Vec3,
    n_g: Vec3,
    wo: Vec3,
    dist: f32,
) -> (f32, bool) {
    match view.mask_budget.get(i) {
        Some(&budget) => mask_visibility_at(tracer, lights, j, p, n_g, wo, dist, budget),
        None => (!light_blocked(tracer, lights, j, p, n_g, wo, dist) as u8 as f32, false),
    }
}

/// Expected visibility of light j from surface point `p` (geometric normal `n_g`, any path vertex) in a
/// scene with masked surfaces (`crate::raytrace::mask`), and whether the shadow ray crossed a masked
/// surface: the product of (1 - opacity) over the masked surfaces crossed, at most `budget` of them (a view
/// sample's `ViewSamples::mask_budget`), for lights BSDF sampling can reach (area light samples,
/// environment strata, VPLs); 0 or 1 for point and spot lights and directional emitters, which masks block
/// as any surface (Mitsuba's `ray_test`). A VPL of depth d (`LightSet::vpl_depth`) crosses d fewer: its
/// path back to the light has d more vertices, the last of which samples the light (Mitsuba's depth: view
/// sample at k, VPL vertex at k + 1 + j after j null events, the light sampled at k + j + d while
/// k + j + d + 1 < max_depth, i.e. j <= budget - d), so none reaches a sample whose budget is below d.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn mask_visibility_at(
    tracer: &RayTracer,
    lights: &LightSet,
    j: usize,
    p: Vec3,
    n_g: Vec3,
    wo: Vec3,
    dist: f32,
    budget: u32,
) -> (f32, bool) {
    use crate::lights::LightKind;
    let budget = match lights.kind[j] {
        LightKind::OrientedPoint => budget,
        LightKind::Vpl => match budget.checked_sub(lights.vpl_depth[j].max(1)) {
            Some(b) => b,
            None => return (0.0, false),
        },
        LightKind::Directional if tracer.masks().directional_is_environment => budget,
        LightKind::Directional | LightKind::Point | LightKind::Spot => 0,
    };
    let q = dist.is_finite().then(|| lights.position[j]);
    tracer.mask_transmittance_crossed(p, n_g, q, wo, budget)
}

/// A row block's output shared by the tasks that write disjoint lights of it (`CpuBackend::rows`).
#[derive(Clone, Copy)]
struct SharedOut(*mut f32);
// SAFETY: the tasks write disjoint elements (`CpuBackend::put_row_elements`' contract).
unsafe impl Send for SharedOut {}
unsafe impl Sync for SharedOut {}

impl SharedOut {
    /// Row k of a block of rows of n lights (RGB).
    fn row(self, k: usize, n: usize) -> *mut f32 {
        // SAFETY (of the callers): k < the block's rows.
        unsafe { self.0.add(k * n * 3) }
    }
}

/// The CPU backend of one light matrix (module docs).
pub struct CpuBackend {
    tracer: Arc<RayTracer>,
    view: Arc<ViewSamples>,
    lights: Arc<LightSet>,
    /// Every view sample prepared (`ShadingPoint::new`).
    points: Vec<ShadingPoint>,
    /// The lights in the order rows trace them ([`spatial_order`]).
    light_order: Vec<u32>,
    shadow_tests: AtomicU64,
}

impl CpuBackend {
    /// The backend over `view` and `lights` with the scene's ray tracer.
    pub fn new(tracer: Arc<RayTracer>, view: Arc<ViewSamples>, lights: Arc<LightSet>) -> Result<CpuBackend> {
        let m = view.len();
        crate::memory::check_host(
            &format!("the CPU backend's shading points: {m} view samples x {} bytes", std::mem::size_of::<ShadingPoint>()),
            crate::memory::product(&[m as u64, std::mem::size_of::<ShadingPoint>() as u64]),
        )?;
        let points = (0..m).into_par_iter().with_min_len(1024).map(|i| ShadingPoint::new(&view, i)).collect();
        if u32::try_from(lights.len()).is_err() {
            // `spatial_order` and the rows' disjoint writes index lights as u32.
            return Err(crate::error::Error::invalid(format!("{} lights: the CPU backend takes at most 2^32 - 1", lights.len())));
        }
        let light_order = spatial_order(&lights);
        Ok(CpuBackend { tracer, view, lights, points, light_order, shadow_tests: AtomicU64::new(0) })
    }

    /// Element (sample i, light j), counting its shadow test.
    #[inline]
    fn element_counted(&self, i: usize, j: usize, tests: &mut u64) -> Vec3 {
        let s = shade(&self.tracer, &self.view, &self.lights, &self.points[i], i, j);
        *tests += s.tested as u64;
        s.value
    }

    /// Elements `(i_k, j_k)` of up to [`PACKET`] pairs into `out[k]`, returning the shadow tests: each
    /// element's unshadowed value first (`shade_unshadowed`), then the binary shadow rays of the lit ones
    /// as one packet (`RayTracer::occluded_packet`); in a scene with masked surfaces element by element
    /// (`shade`: transmittance). The values equal `shade`'s wherever the packet answers as `occluded_ray`.
    #[inline]
    fn elements(&self, pairs: &[(usize, usize)], out: &mut [Vec3]) -> u64 {
        if !self.view.mask_budget.is_empty() {
            let mut t = 0;
            for (k, &(i, j)) in pairs.iter().enumerate() {
                out[k] = self.element_counted(i, j, &mut t);
            }
            return t;
        }
        let (mut o, mut d, mut t_max) = ([Vec3::ZERO; PACKET], [Vec3::ZERO; PACKET], [0f32; PACKET]);
        let (mut slot, mut value) = ([0usize; PACKET], [Vec3::ZERO; PACKET]);
        let mut r = 0;
        for (k, &(i, j)) in pairs.iter().enumerate() {
            out[k] = Vec3::ZERO;
            let sp = &self.points[i];
            let Some((f, wo, dist)) = shade_unshadowed(&self.view, &self.lights, sp, i, j) else {
                continue;
            };
            (o[r], d[r], t_max[r]) = light_ray(&self.lights, j, sp.p, sp.n_g, wo, dist);
            (slot[r], value[r]) = (k, f);
            r += 1;
        }
        let mut blocked = [false; PACKET];
        self.tracer.occluded_packet(&o[..r], &d[..r], &t_max[..r], &mut blocked[..r]);
        for q in 0..r {
            if !blocked[q] {
                out[slot[q]] = value[q];
            }
        }
        r as u64
    }

    /// Column j at the view samples `first + k`, k < `dst.len() / 3`, written over `dst` (RGB each),
    /// [`PACKET`] at a time (`elements`). Returns the shadow tests.
    fn put_column(&self, dst: &mut [f32], first: usize, j: usize) -> u64 {
        let mut t = 0;
        let (mut pairs, mut v) = ([(0, 0); PACKET], [Vec3::ZERO; PACKET]);
        for (g, group) in dst.chunks_mut(3 * PACKET).enumerate() {
            let n = group.len() / 3;
            for (k, p) in pairs.iter_mut().enumerate().take(n) {
                *p = (first + g * PACKET + k, j);
            }
            t += self.elements(&pairs[..n], &mut v[..n]);
            for (px, value) in group.chunks_exact_mut(3).zip(&v) {
                px.copy_from_slice(&value.to_array());
            }
        }
        t
    }

    /// Light matrix row `i` at the lights `light_order[positions]`, [`PACKET`] at a time (`elements`), into
    /// `row` (n * 3 floats, light j at `3 j`): written over, or added to what it holds where `accumulate` (a
    /// pixel's later delta-chain samples). Lights in `light_order` are neighbours in space, so a packet's rays
    /// leave the view sample in similar directions (docs/validation/backends.md). Writing first matters for a
    /// freshly allocated output: a read before the first write maps the kernel's shared zero page, and each
    /// write after it then takes a copy-on-write fault with a TLB shoot-down across the threads, a large
    /// share of `rows`' time on outputs of tens of MB (docs/validation/backends.md). Returns the shadow tests.
    ///
    /// # Safety
    /// `row` points to n * 3 floats that no other thread reads or writes at the lights of `positions`.
    unsafe fn put_row_elements(&self, row: *mut f32, positions: std::ops::Range<usize>, i: usize, accumulate: bool) -> u64 {
        let mut t = 0;
        let (mut pairs, mut v) = ([(0, 0); PACKET], [Vec3::ZERO; PACKET]);
        for g in positions.clone().step_by(PACKET) {
            let n = PACKET.min(positions.end - g);
            for (k, p) in pairs.iter_mut().enumerate().take(n) {
                *p = (i, self.light_order[g + k] as usize);
            }
            t += self.elements(&pairs[..n], &mut v[..n]);
            for (&(_, j), value) in pairs[..n].iter().zip(&v) {
                let px = std::slice::from_raw_parts_mut(row.add(3 * j), 3);
                if accumulate {
                    px[0] += value.x;
                    px[1] += value.y;
                    px[2] += value.z;
                } else {
                    px.copy_from_slice(&value.to_array());
                }
            }
        }
        t
    }

    /// Per-sample values `m * 3` folded into pixels (`width * height * 3`).
    fn fold(&self, per_sample: Vec<f32>) -> Vec<f32> {
        if self.view.len() == self.view.num_pixels() {
            per_sample
        } else {
            self.view.fold(&per_sample, 3)
        }
    }
}

impl Backend for CpuBackend {
    fn info(&self) -> DeviceInfo {
        DeviceInfo { shadow_rays: self.tracer.packet_kernel(), ..DeviceInfo::cpu() }
    }

    fn columns(&self, js: &[usize]) -> Result<Vec<f32>> {
        let m = self.view.len();
        let pixels = self.view.num_pixels();
        crate::memory::check_host(
            &format!("columns: {} columns x {m} view samples x RGB float32", js.len()),
            crate::memory::product(&[js.len() as u64, m as u64, 12]),
        )?;
        let mut out = vec![0f32; js.len() * pixels * 3];
        // Columns per block so that a block holds about ELEMENTS_PER_BLOCK elements.
        let per_block = (ELEMENTS_PER_BLOCK / m.max(1)).max(1);
        // Per-sample columns of a view with delta-chain samples, folded into pixels after each block.
        let mut samples = if m == pixels { Vec::new() } else { vec![0f32; per_block.min(js.len()) * m * 3] };
        for (block, dst) in js.chunks(per_block).zip(out.chunks_mut(per_block * pixels * 3)) {
            crate::interrupt::check()?;
            let data = if m == pixels { &mut *dst } else { &mut samples[..block.len() * m * 3] };
            // Fill column by column (a column's pixel chunks in parallel).
            let mut total = 0u64;
            for (k, &j) in block.iter().enumerate() {
                let col = &mut data[k * m * 3..(k + 1) * m * 3];
                total +=
                    col.par_chunks_mut(PIXEL_CHUNK * 3).enumerate().map(|(c, dst)| self.put_column(dst, c * PIXEL_CHUNK, j)).sum::<u64>();
            }
            self.shadow_tests.fetch_add(total, Ordering::Relaxed);
            if m != pixels {
                for (column, folded) in samples.chunks_exact(m * 3).zip(dst.chunks_exact_mut(pixels * 3)) {
                    folded.copy_from_slice(&self.view.fold(column, 3));
                }
            }
        }
        Ok(out)
    }

    fn weighted_sum(&self, js: &[usize], weights: &[[f32; 3]], progress: &mut dyn FnMut(usize, usize)) -> Result<Vec<f32>> {
        let m = self.view.len();
        let mut acc = vec![0f32; m * 3];
        let per_block = (ELEMENTS_PER_BLOCK / m.max(1)).max(1);
        let mut done = 0;
        for (block, w) in js.chunks(per_block).zip(weights.chunks(per_block)) {
            crate::interrupt::check()?;
            let tests: u64 = acc
                .par_chunks_mut(PIXEL_CHUNK * 3)
                .enumerate()
                .map(|(c, dst)| {
                    // Light by light, each over the chunk's pixels PACKET at a time: a packet is a piece of
                    // a column (neighbouring pixels toward one light, coherent rays), and each pixel still
                    // adds its lights in the block's order.
                    let first = c * PIXEL_CHUNK;
                    let count = dst.len() / 3;
                    let mut sum = [Vec3::ZERO; PIXEL_CHUNK];
                    for (e, px) in dst.chunks_exact(3).enumerate() {
                        sum[e] = Vec3::from_array([px[0], px[1], px[2]]);
                    }
                    let mut t = 0u64;
                    let (mut pairs, mut v) = ([(0, 0); PACKET], [Vec3::ZERO; PACKET]);
                    for (&j, wk) in block.iter().zip(w) {
                        let wk = Vec3::from_array(*wk);
                        for g in (0..count).step_by(PACKET) {
                            let n = PACKET.min(count - g);
                            for (k, pair) in pairs.iter_mut().enumerate().take(n) {
                                *pair = (first + g + k, j);
                            }
                            t += self.elements(&pairs[..n], &mut v[..n]);
                            for (k, value) in v.iter().enumerate().take(n) {
                                if self.points[first + g + k].surface {
                                    sum[g + k] += *value * wk;
                                }
                            }
                        }
                    }
                    for (px, s) in dst.chunks_exact_mut(3).zip(&sum) {
                        px.copy_from_slice(&s.to_array());
                    }
                    t
                })
                .sum();
            self.shadow_tests.fetch_add(tests, Ordering::Relaxed);
            done += block.len();
            progress(done, js.len());
        }
        Ok(self.fold(acc))
    }

    fn rows(&self, is: &[usize], _opts: &RowOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<TimedRows> {
        let n = self.lights.len();
        let r = is.len();
        let mut timings = RowTimings::default();
        crate::memory::check_host(
            &format!("rows: {r} rows x {n} lights x RGB float32"),
            crate::memory::product(&[r as u64, n as u64, 12]),
        )?;
        let t0 = Instant::now();
        let mut out = vec![0f32; r * n * 3];
        if n == 0 {
            return Ok((out, timings));
        }
        let rows_per_block = (ELEMENTS_PER_BLOCK / n).max(1);
        let mut done = 0;
        for (b, block) in out.chunks_mut(rows_per_block * n * 3).enumerate() {
            crate::interrupt::check()?;
            let first = b * rows_per_block;
            let rows_here = block.len() / (n * 3);
            let base = SharedOut(block.as_mut_ptr());
            let chunks = n.div_ceil(LIGHT_CHUNK);
            let tests: u64 = (0..rows_here * chunks)
                .into_par_iter()
                .map(|task| {
                    let (k, c) = (task / chunks, task % chunks);
                    let positions = c * LIGHT_CHUNK..((c + 1) * LIGHT_CHUNK).min(n);
                    let pixel = is[first + k];
                    let mut t = 0u64;
                    for (s, i) in self.view.samples_of_pixel(pixel).enumerate() {
                        // SAFETY: `light_order` is a permutation of 0..n, so the tasks of row k write disjoint
                        // elements of its n * 3 floats, and rows are disjoint; `block` outlives the tasks.
                        t += unsafe { self.put_row_elements(base.row(k, n), positions.clone(), i, s > 0) };
                    }
                    t
                })
                .sum();
            self.shadow_tests.fetch_add(tests, Ordering::Relaxed);
            done += block.len() / (n * 3);
            progress(done, r);
        }
        timings.evaluation = t0.elapsed().as_secs_f64();
        timings.batches = r.div_ceil(rows_per_block);
        Ok((out, timings))
    }

    fn tracer(&self) -> Result<Arc<RayTracer>> {
        Ok(self.tracer.clone())
    }

    fn visibility_stats(&self) -> Result<VisibilityStats> {
        let t = self.shadow_tests.load(Ordering::Relaxed);
        Ok(VisibilityStats { shadow_tests: t, ray_casts: t, gave_up: 0 })
    }

    fn reset_visibility_stats(&self) {
        self.shadow_tests.store(0, Ordering::Relaxed);
    }

    fn clustered_shading(&self, job: &crate::cluster::visibility::ClusteredShading) -> Result<crate::cluster::visibility::ClusteredImage> {
        crate::cluster::visibility::cpu::render(&self.tracer, &self.view, job)
    }
}

#[cfg(test)]
mod tests;
