//! Environment (envmap / constant emitters) -> directional lights (Tensor Clustering 2008 Sec. 5: "we
//! convert the map into directional lights by simple uniform stratified sampling"; MRCS 2007 Sec. 4).
//!
//! Strata: the equal-area cylindrical partition of the sphere (`sampling::equal_area_cells`, polar axis
//! world +Y), n cells of solid angle 4 pi / n. Light k is a `Directional` light whose irradiance at
//! normal incidence is the radiance INTEGRATED over its stratum, E_k = int_{Omega_k} L(w) dw (W/m^2),
//! travelling along -c_k where c_k is the stratum's luminance-weighted centroid direction (the cell
//! centre when the stratum is black). The integral is a midpoint rule on a sub-grid of each stratum
//! (uniform in theta, equal-area weights) with 2 to 8 samples per texel angle in each direction (as many
//! as a budget of 3.2e7 lookups per map allows: 8 up to 500k texels, 4 at 2048 x 1024), so every texel
//! the stratum covers contributes. The light directions do not depend on the seed.
//!
//! `env_importance`: strata are allocated by luminance. A fine equal-area grid (16 n cells, at most
//! 2^22) is integrated as above; its cells, in row order, are cut into n runs of equal integrated
//! luminance (a cell on a cut is shared: each side takes its fraction of the cell's integral). Each
//! light carries the exact integral of its run, so the weights stay unbiased and the total is preserved.
//!
//! Power: with the scene's bounding sphere (centre c, radius r) the environment's power is the power
//! through the bounding disk, Phi_env = pi r^2 int_{S^2} L(w) dw; each light's power is E_k pi r^2
//! (`LightSet::power`), so the lights sum to Phi_env.
//!
//! Lookups follow MITSUBA_CONVENTIONS.md: v = env_from_world(d) (d toward the sky),
//! u = atan2(v.x, -v.z) / (2 pi) mod 1, t = acos(v.y) / pi, bilinear with column = u W - 0.5 (wrapping)
//! and row = t (H - 1) (clamped), times `scale`. Several environment emitters add up.
//!
//! A sun: an explicit `directional` emitter is the way to keep a small bright source as one delta light
//! (with `env_importance` a sun painted into the map gets many small strata instead; no detection).
use super::sampling::{equal_area_cells, Cell};
use crate::error::Result;
use crate::lights::LightSet;
use crate::scene::{EnvMap, Scene};
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// One environment emitter, ready for lookups.
#[derive(Debug, Clone)]
enum EnvSource {
    Map { env_from_world: Mat3, width: usize, height: usize, data: Vec<Vec3>, scale: f32 },
    Constant(Vec3),
}

/// The sum of the scene's environment emitters.
#[derive(Debug, Clone)]
pub struct Environment {
    sources: Vec<EnvSource>,
    /// Smallest texel angle (radians) of any map; infinite for constants only.
    texel_angle: f32,
    /// Sub-samples per texel angle in each direction of `integrate_cell`.
    samples_per_texel: f32,
}

/// Budget of radiance lookups for integrating a whole map (sets `samples_per_texel` between
/// `MIN_SAMPLES_PER_TEXEL` and `MAX_SAMPLES_PER_TEXEL` per direction).
const LOOKUP_BUDGET: f32 = 3.2e7;
const MIN_SAMPLES_PER_TEXEL: f32 = 2.0;
const MAX_SAMPLES_PER_TEXEL: f32 = 8.0;

pub(crate) fn luminance(v: Vec3) -> f32 {
    v.element_sum() / 3.0
}

/// Radiance of a lat-long map toward d (world, toward the sky), Mitsuba's lookup.
pub fn envmap_radiance(map: &EnvMap, d: Vec3) -> Vec3 {
    let env_from_world = Mat3::from_mat4(map.world_from_env).inverse();
    lookup(&env_from_world, map.width as usize, map.height as usize, &map.data, map.scale, d)
}

fn lookup(env_from_world: &Mat3, w: usize, h: usize, data: &[Vec3], scale: f32, d: Vec3) -> Vec3 {
    // Not renormalised, as Mitsuba's `direction_to_uv(to_world.inverse() * d)` (same for a rotation).
    let v = *env_from_world * d;
    let u = (v.x.atan2(-v.z) / (2.0 * PI)).rem_euclid(1.0);
    let t = v.y.clamp(-1.0, 1.0).acos() / PI;
    let x = u * w as f32 - 0.5;
    let y = (t * (h - 1) as f32).clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let col = |c: f32| (c as i64).rem_euclid(w as i64) as usize;
    let (c0, c1) = (col(x0), col(x0 + 1.0));
    let r0 = y0 as usize;
    let r1 = (r0 + 1).min(h - 1);
    let at = |r: usize, c: usize| data[r * w + c];
    let top = at(r0, c0) * (1.0 - fx) + at(r0, c1) * fx;
    let bottom = at(r1, c0) * (1.0 - fx) + at(r1, c1) * fx;
    (top * (1.0 - fy) + bottom * fy) * scale
}

impl Environment {
    /// The scene's envmap / constant emitters, or `None` when it has none.
    pub fn from_scene(scene: &Scene) -> Option<Environment> {
        let mut sources = Vec::new();
        let mut texel_angle = f32::INFINITY;
        let mut texels = 0usize;
        for e in &scene.emitters {
            match e {
                crate::scene::Emitter::EnvMap { map, .. } => {
                    let (w, h) = (map.width as usize, map.height as usize);
                    if w == 0 || h == 0 || map.data.len() != w * h {
                        continue;
                    }
                    texel_angle = texel_angle.min(2.0 * PI / w as f32).min(PI / (h.max(2) - 1) as f32);
                    texels = texels.max(w * h);
                    sources.push(EnvSource::Map {
                        env_from_world: Mat3::from_mat4(map.world_from_env).inverse(),
                        width: w,
                        height: h,
                        data: map.data.iter().map(|v| if v.is_finite() { v.max(Vec3::ZERO) } else { Vec3::ZERO }).collect(),
                        scale: if map.scale.is_finite() { map.scale.max(0.0) } else { 0.0 },
                    });
                }
                crate::scene::Emitter::Constant { radiance, .. } => {
                    let r = if radiance.is_finite() { radiance.max(Vec3::ZERO) } else { Vec3::ZERO };
                    sources.push(EnvSource::Constant(r));
                }
                _ => {}
            }
        }
        let samples_per_texel = (LOOKUP_BUDGET / texels.max(1) as f32).sqrt().clamp(MIN_SAMPLES_PER_TEXEL, MAX_SAMPLES_PER_TEXEL).floor();
        (!sources.is_empty()).then_some(Environment { sources, texel_angle, samples_per_texel })
    }

    /// Radiance arriving from direction d (world, toward the sky).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.sources
            .iter()
            .map(|s| match s {
                EnvSource::Constant(l) => *l,
                EnvSource::Map { env_from_world, width, height, data, scale } => lookup(env_from_world, *width, *height, data, *scale, d),
            })
            .sum()
    }

    /// (int_cell L dw, int_cell luminance(L) w dw): the cell's integral and unnormalised centroid.
    pub fn integrate_cell(&self, cell: &Cell) -> (Vec3, Vec3) {
        if self.texel_angle.is_infinite() {
            let l = self.radiance(Vec3::Y);
            let dir = cell.sample(0.5, 0.5);
            return (l * cell.solid_angle(), dir * luminance(l) * cell.solid_angle());
        }
        let step = self.texel_angle / self.samples_per_texel;
        let (theta_a, theta_b) = (cell.z_hi.clamp(-1.0, 1.0).acos(), cell.z_lo.clamp(-1.0, 1.0).acos());
        let m_theta = (((theta_b - theta_a) / step).ceil() as usize).max(1);
        let dphi = cell.phi_hi - cell.phi_lo;
        let (mut sum, mut centroid) = (Vec3::ZERO, Vec3::ZERO);
        for a in 0..m_theta {
            let t0 = theta_a + (theta_b - theta_a) * a as f32 / m_theta as f32;
            let t1 = theta_a + (theta_b - theta_a) * (a + 1) as f32 / m_theta as f32;
            let (z0, z1) = (t0.cos(), t1.cos());
            let sin_max = if t0 <= 0.5 * PI && t1 >= 0.5 * PI { 1.0 } else { t0.sin().max(t1.sin()) };
            let m_phi = ((dphi * sin_max / step).ceil() as usize).max(1);
            let weight = (z0 - z1) * dphi / m_phi as f32;
            let z = 0.5 * (z0 + z1);
            for b in 0..m_phi {
                let phi = cell.phi_lo + dphi * (b as f32 + 0.5) / m_phi as f32;
                let d = super::sampling::sphere_dir(z, phi);
                let l = self.radiance(d) * weight;
                sum += l;
                centroid += d * luminance(l);
            }
        }
        (sum, centroid)
    }

    /// Integrals and centroids of all `cells`, in parallel (deterministic order).
    pub fn integrate_cells(&self, cells: &[Cell]) -> Vec<(Vec3, Vec3)> {
        cells.par_iter().with_min_len(64).map(|c| self.integrate_cell(c)).collect()
    }

    /// `n` directional lights (module docs). The seed is unused (the strata are deterministic).
    pub fn strata_lights(&self, n: usize, importance: bool, _seed: u64, center: Vec3, radius: f32) -> Result<LightSet> {
        let mut set = LightSet::new(center, radius);
        if n == 0 {
            return Ok(set);
        }
        set.try_reserve(n)?;
        let push = |set: &mut LightSet, e: Vec3, centroid: Vec3, fallback: Vec3| -> Result<()> {
            let c = centroid.normalize_or_zero();
            let d = if c == Vec3::ZERO { fallback } else { c };
            set.push_directional(-d, e)
        };
        if !importance {
            let cells = equal_area_cells(n);
            for (cell, (e, centroid)) in cells.iter().zip(self.integrate_cells(&cells)) {
                if e.max_element() > 0.0 {
                    push(&mut set, e, centroid, cell.sample(0.5, 0.5))?;
                    set.set_mis(set.len() - 1, cell.solid_angle(), -1);
                }
            }
            return Ok(set);
        }
        let fine = equal_area_cells((16 * n).min(1 << 22).max(n));
        let integrals = self.integrate_cells(&fine);
        let total: f64 = integrals.iter().map(|(e, _)| luminance(*e) as f64).sum();
        if !(total > 0.0) {
            return Ok(set);
        }
        let share = total / n as f64;
        let (mut e_k, mut c_k, mut cap, mut made) = (Vec3::ZERO, Vec3::ZERO, share, 0usize);
        let mut fallback = fine[0].sample(0.5, 0.5);
        for (cell, (e, centroid)) in fine.iter().zip(&integrals) {
            let mass = luminance(*e) as f64;
            let mut left = mass;
            while left > 0.0 {
                let take = if made + 1 == n { left } else { left.min(cap) };
                let frac = (take / mass) as f32;
                e_k += *e * frac;
                c_k += *centroid * frac;
                fallback = cell.sample(0.5, 0.5);
                cap -= take;
                left -= take;
                if made + 1 < n && cap <= 1e-9 * share {
                    push(&mut set, e_k, c_k, fallback)?;
                    made += 1;
                    (e_k, c_k, cap) = (Vec3::ZERO, Vec3::ZERO, share);
                }
            }
        }
        if e_k.max_element() > 0.0 {
            push(&mut set, e_k, c_k, fallback)?;
        }
        Ok(set)
    }

    /// A sampler of directions for particle emission (`EnvSampler`): 0.9 luminance + 0.1 uniform.
    pub fn sampler(&self) -> EnvSampler {
        self.sampler_guided(None)
    }

    /// `sampler`, or with `factor` (per direction, >= 0: how much a unit of radiance from there adds to what
    /// the camera sees) the defensive mixture `GUIDED_MIX` of the cells' luminance times the factor at their
    /// centres, their luminance, and uniform. Without a cell where both are positive, `sampler`'s mixture.
    pub fn sampler_guided(&self, factor: Option<&dyn Fn(Vec3) -> f64>) -> EnvSampler {
        let cells = equal_area_cells(ENV_SAMPLER_CELLS);
        let integrals = self.integrate_cells(&cells);
        let lum: Vec<f64> = integrals.iter().map(|(e, _)| luminance(*e) as f64).collect();
        let guided: Vec<f64> = match factor {
            Some(f) => cells.iter().zip(&lum).map(|(c, &l)| if l > 0.0 { l * f(c.sample(0.5, 0.5)).max(0.0) } else { 0.0 }).collect(),
            None => Vec::new(),
        };
        let (total, total_guided) = (lum.iter().sum::<f64>(), guided.iter().sum::<f64>());
        let power: Vec3 = integrals.iter().map(|(e, _)| *e).sum();
        let f = cells.len() as f64;
        let mut acc = 0.0;
        let mut cdf = Vec::with_capacity(cells.len());
        let mut prob = Vec::with_capacity(cells.len());
        for (k, &l) in lum.iter().enumerate() {
            let p = if total_guided > 0.0 {
                let [g, w, u] = GUIDED_MIX;
                g * guided[k] / total_guided + w * l / total + u / f
            } else if total > 0.0 {
                0.9 * l / total + 0.1 / f
            } else {
                1.0 / f
            };
            acc += p;
            prob.push(p as f32);
            cdf.push(acc);
        }
        EnvSampler { cdf, prob, integral: power, index: CellIndex::new(cells.len()), cells }
    }
}

/// Cells of the environment samplers' equal-area partition.
pub const ENV_SAMPLER_CELLS: usize = 16_384;
/// A guided sampler's shares: luminance x the guide's factor, luminance, uniform.
pub const GUIDED_MIX: [f64; 3] = [0.6, 0.3, 0.1];

/// Which cell of the equal-area partition into n cells (`sampling::equal_area_cells`) holds a direction.
#[derive(Debug, Clone)]
pub struct CellIndex {
    n: usize,
    /// Index of the first cell of each row (`sampling::equal_area_rows`).
    row_start: Vec<usize>,
}

impl CellIndex {
    pub fn new(n: usize) -> CellIndex {
        let mut row_start = Vec::new();
        let mut above = 0usize;
        for k in super::sampling::equal_area_rows(n) {
            row_start.push(above);
            above += k;
        }
        CellIndex { n, row_start }
    }

    /// The cell holding unit direction `d` (cells of `sampling::sphere_dir`: z = d.y from 1 down, phi =
    /// atan2(d.x, d.z) in [0, 2 pi)); a direction on a cell boundary (measure zero) gets one of its
    /// neighbours. `None` for n = 0.
    pub fn of(&self, d: Vec3) -> Option<usize> {
        let n = self.n;
        if n == 0 {
            return None;
        }
        // Row: the last one whose first cell is at or above the fraction of the sphere above d.
        let above = ((1.0 - d.y.clamp(-1.0, 1.0) as f64) * 0.5 * n as f64).clamp(0.0, (n - 1) as f64);
        let r = self.row_start.partition_point(|&s| s as f64 <= above).saturating_sub(1);
        let start = self.row_start[r];
        let end = self.row_start.get(r + 1).copied().unwrap_or(n);
        let phi = (d.x.atan2(d.z) as f64).rem_euclid(2.0 * std::f64::consts::PI);
        let c = ((phi / (2.0 * std::f64::consts::PI) * (end - start) as f64) as usize).min(end - start - 1);
        Some(start + c)
    }
}

/// Direction sampling over 16,384 equal-area cells, each with a probability (`Environment::sampler`: 0.9
/// luminance + 0.1 uniform; `sampler_guided`: `GUIDED_MIX`), uniform within the cell.
pub struct EnvSampler {
    cells: Vec<Cell>,
    cdf: Vec<f64>,
    prob: Vec<f32>,
    /// int_{S^2} L dw (per channel).
    pub integral: Vec3,
    index: CellIndex,
}

impl EnvSampler {
    /// (direction toward the sky, pdf in solid angle).
    pub fn sample(&self, u0: f32, u1: f32, u2: f32) -> (Vec3, f32) {
        let total = *self.cdf.last().unwrap_or(&1.0);
        let k = self.cdf.partition_point(|&c| c <= u0 as f64 * total).min(self.cells.len() - 1);
        let cell = &self.cells[k];
        (cell.sample(u1, u2), (self.prob[k] as f64 / total) as f32 / cell.solid_angle())
    }

    /// The solid-angle density with which `sample` returns the unit direction `d` (MIS weights): the
    /// probability of the cell holding `d` (`CellIndex::of`) over its solid angle.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let Some(k) = self.index.of(d) else { return 0.0 };
        let total = *self.cdf.last().unwrap_or(&1.0);
        (self.prob[k] as f64 / total) as f32 / self.cells[k].solid_angle()
    }
}
