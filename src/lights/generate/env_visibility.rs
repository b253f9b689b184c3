//! Environment strata allocated by what the camera sees of them (`GenerateOptions::env_visibility`,
//! Python `generate_lights(env_visibility=True)`): a room lit through a window gets its strata in the
//! window.
//!
//! The uniform strata (`environment`) spend their lights evenly over the sphere, and an environment seen
//! through an opening is mostly hidden: in a room lit through a window, 65,536 equal-area strata left the
//! image 1.5% off (every stratum's one direction is a hard shadow where the true light is a penumbra of the
//! stratum's width), while most strata lit nothing the camera sees. The quadrature itself stays that of
//! MRCS 2007 Sec. 4 and Tensor Clustering 2008 Sec. 5 (one directional light per stratum, carrying the
//! radiance integrated over it, at the stratum's luminance-weighted centroid); only the partition changes:
//!
//! 1. A coarse equal-area partition of C = clamp(n / 16, 8, 4096) cells (`sampling::equal_area_cells`).
//! 2. Each cell's importance I_c: the pilot view's (`pilot_view`) contribution of `PROBES_PER_CELL`
//!    directional lights at stratified, jittered directions of the cell, each carrying a share of the
//!    cell's integral -- exact visibility, the receivers' BSDFs and cosines: I_c estimates what cell c adds
//!    to the image.
//! 3. n_c = b + extra_c lights per cell with radiance: a floor b = max(1, floor(`UNIFORM_SHARE` n / C'))
//!    (C' the cells with radiance: no cell is coarser than 1 / `UNIFORM_SHARE` times its uniform stratum,
//!    so a direction the pilot missed still gets lights), and the rest by largest remainders in proportion
//!    to I_c^(2/3): with a stratum's error about its contribution times its width, sum_c I_c^2 / n_c^2 is
//!    least there (Lagrange).
//! 4. Cell c is cut into n_c equal-area sub-cells (rows of the cylindrical map, as many as make them about
//!    square in angle; each row's height in z proportional to its cells), and each sub-cell is a stratum
//!    as in `environment`: its integral, its centroid, its solid angle as the glossy MIS measure
//!    (`matrix::glossy` finds the density of an escaping BSDF ray at the nearest stratum direction).
//!
//! The strata partition the sphere, so the lights' irradiances sum to the environment's integral (up to
//! the midpoint rule of `Environment::integrate_cell`) whatever the pilot measured: the pilot moves error,
//! it cannot add bias beyond that of the quadrature. The pilot's jitter comes from `seed` (stream
//! `STREAM_ENV_PILOT`, per cell): the same seed gives the same lights. Without a surface in the pilot view,
//! or for n < `MIN_LIGHTS`, the uniform strata are returned.
//!
//! | symbol | name here |
//! |---|---|
//! | n, C, C' | lights requested, coarse cells, coarse cells with radiance |
//! | I_c | a coarse cell's pilot contribution (`importance`) |
//! | b, n_c | the floor per cell, the strata of cell c (`allocate`) |
use super::environment::Environment;
use super::pilot_view::PilotView;
use super::sampling::{equal_area_cells, stream, uniform, Cell, STREAM_ENV_PILOT};
use crate::error::Result;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use glam::Vec3;

/// Pilot view samples (about this many pixel centres with the camera's aspect).
pub const VIEW_SAMPLES: usize = 1024;
/// Directions per coarse cell in the pilot (a 2 x 2 stratified, jittered grid).
pub const PROBES_PER_CELL: usize = 4;
/// Share of the lights spread evenly over the cells with radiance (the floor b).
pub const UNIFORM_SHARE: f64 = 0.25;
/// Below this many lights the uniform strata are returned (too few to allocate).
pub const MIN_LIGHTS: usize = 128;
/// Coarse cells: n / CELLS_PER_LIGHTS, clamped to [MIN_CELLS, MAX_CELLS].
const CELLS_PER_LIGHTS: usize = 16;
const MIN_CELLS: usize = 8;
const MAX_CELLS: usize = 4096;

/// About `n` directional lights over `env`, allocated by the pilot view of `scene` (module docs).
///
/// Errors: what the pilot view's ray casting and `LightSet` pushes raise; `Interrupted`.
pub fn visibility_strata_lights(env: &Environment, scene: &Scene, n: usize, seed: u64, center: Vec3, radius: f32) -> Result<LightSet> {
    if n < MIN_LIGHTS {
        return env.strata_lights(n, false, seed, center, radius);
    }
    let rt = RayTracer::new(scene)?;
    let pilot = PilotView::new(scene, &rt, VIEW_SAMPLES)?;
    if pilot.len() == 0 {
        return env.strata_lights(n, false, seed, center, radius);
    }
    let cells = equal_area_cells((n / CELLS_PER_LIGHTS).clamp(MIN_CELLS, MAX_CELLS));
    let integrals = env.integrate_cells(&cells);
    let importance = importance(&pilot, &rt, &cells, &integrals, seed, center, radius)?;
    let counts = allocate(n, &integrals.iter().map(|(e, _)| e.max_element() > 0.0).collect::<Vec<_>>(), &importance);
    let subcells: Vec<Cell> = cells.iter().zip(&counts).flat_map(|(c, &k)| split_cell(c, k)).collect();
    let sub_integrals = env.integrate_cells(&subcells);
    let mut set = LightSet::new(center, radius);
    set.try_reserve(subcells.len())?;
    for (cell, (e, centroid)) in subcells.iter().zip(sub_integrals) {
        if e.max_element() > 0.0 {
            let c = centroid.normalize_or_zero();
            let d = if c == Vec3::ZERO { cell.sample(0.5, 0.5) } else { c };
            set.push_directional(-d, e)?;
            set.set_mis(set.len() - 1, cell.solid_angle(), -1);
        }
    }
    Ok(set)
}

/// Coarse cells of the guide of the probes' environment sampling (`camera_factor`).
pub const GUIDE_CELLS: usize = 256;

/// Per direction, what a unit of the environment's radiance from there adds to the pilot view (module docs,
/// 2, on `GUIDE_CELLS` coarse cells: I_c over the luminance of the cell's integral), for the probes' path
/// tracer to sample the environment by (`Environment::sampler_guided`): in a room lit through a window its
/// samples go to the window. `None` without a surface in the pilot view or without a cell the pilot sees.
///
/// Errors: the pilot view's; `Interrupted`.
pub fn camera_factor(env: &Environment, scene: &Scene, rt: &RayTracer, seed: u64) -> Result<Option<CameraFactor>> {
    let pilot = PilotView::new(scene, rt, VIEW_SAMPLES)?;
    if pilot.len() == 0 {
        return Ok(None);
    }
    let (center, radius) = crate::lights::scene_sphere(scene);
    let cells = equal_area_cells(GUIDE_CELLS);
    let integrals = env.integrate_cells(&cells);
    let importance = importance(&pilot, rt, &cells, &integrals, seed, center, radius)?;
    let factor: Vec<f64> = importance
        .iter()
        .zip(&integrals)
        .map(|(&i, (e, _))| {
            let l = super::environment::luminance(*e) as f64;
            if l > 0.0 {
                i / l
            } else {
                0.0
            }
        })
        .collect();
    if !factor.iter().any(|&f| f > 0.0) {
        return Ok(None);
    }
    Ok(Some(CameraFactor { index: super::environment::CellIndex::new(cells.len()), factor }))
}

/// `camera_factor`'s result: per coarse cell, what a unit of radiance from there adds to the pilot view
/// over the cell's luminance. A function of the scene alone (and the pilot's seed): the probes' path tracer
/// builds it once per scene (`pathtrace::SampledEnvironment`, the Python `Scene`'s cache).
#[derive(Debug, Clone)]
pub struct CameraFactor {
    index: super::environment::CellIndex,
    factor: Vec<f64>,
}

impl CameraFactor {
    /// The factor of direction `d` (0 outside every cell).
    pub fn of(&self, d: Vec3) -> f64 {
        self.index.of(d).map_or(0.0, |c| self.factor[c])
    }
}

/// I_c of every coarse cell (module docs, 2): 0 for cells without radiance.
fn importance(
    pilot: &PilotView,
    rt: &RayTracer,
    cells: &[Cell],
    integrals: &[(Vec3, Vec3)],
    seed: u64,
    center: Vec3,
    radius: f32,
) -> Result<Vec<f64>> {
    let side = (PROBES_PER_CELL as f64).sqrt().round() as usize;
    let mut probes = LightSet::new(center, radius);
    probes.try_reserve(cells.len() * PROBES_PER_CELL)?;
    let mut owner = Vec::with_capacity(cells.len() * PROBES_PER_CELL);
    for (c, (cell, (e, _))) in cells.iter().zip(integrals).enumerate() {
        if !(e.max_element() > 0.0) {
            continue;
        }
        let mut rng = stream(seed, STREAM_ENV_PILOT, c as u64);
        for k in 0..side * side {
            let u1 = ((k / side) as f32 + uniform(&mut rng)) / side as f32;
            let u2 = ((k % side) as f32 + uniform(&mut rng)) / side as f32;
            probes.push_directional(-cell.sample(u1, u2), *e / (side * side) as f32)?;
            owner.push(c);
        }
    }
    let per_probe = crate::interrupt::par_map_chunked(probes.len(), 1024, |j| pilot.contribution(rt, &probes, j))?;
    let mut out = vec![0.0f64; cells.len()];
    for (c, v) in owner.into_iter().zip(per_probe) {
        out[c] += v.max(0.0);
    }
    Ok(out)
}

/// n_c per coarse cell (module docs, 3): the floor for every cell with radiance, the rest by largest
/// remainders of I_c^(2/3) (evenly over the cells with radiance when the pilot saw none of them). The
/// counts sum to n when n >= the cells with radiance, to one per such cell otherwise.
pub fn allocate(n: usize, lit: &[bool], importance: &[f64]) -> Vec<usize> {
    let lit_cells = lit.iter().filter(|&&l| l).count();
    let mut counts = vec![0usize; lit.len()];
    if lit_cells == 0 {
        return counts;
    }
    let floor = ((UNIFORM_SHARE * n as f64 / lit_cells as f64).floor() as usize).max(1);
    let rest = n.saturating_sub(floor * lit_cells);
    let weight: Vec<f64> =
        lit.iter().zip(importance).map(|(&l, &i)| if l && i > 0.0 && i.is_finite() { i.powf(2.0 / 3.0) } else { 0.0 }).collect();
    let total: f64 = weight.iter().sum();
    let share: Vec<f64> = if total > 0.0 {
        weight.iter().map(|w| rest as f64 * w / total).collect()
    } else {
        lit.iter().map(|&l| if l { rest as f64 / lit_cells as f64 } else { 0.0 }).collect()
    };
    let mut given = 0usize;
    for (c, &l) in lit.iter().enumerate() {
        if l {
            counts[c] = floor + share[c].floor() as usize;
            given += share[c].floor() as usize;
        }
    }
    // Largest remainders, ties by cell index (deterministic).
    let mut order: Vec<usize> = (0..lit.len()).filter(|&c| lit[c]).collect();
    order.sort_by(|&a, &b| (share[b] - share[b].floor()).total_cmp(&(share[a] - share[a].floor())).then(a.cmp(&b)));
    for &c in order.iter().take(rest.saturating_sub(given)) {
        counts[c] += 1;
    }
    counts
}

/// `cell` cut into `k` sub-cells of equal solid angle (module docs, 4), row by row from its top.
pub fn split_cell(cell: &Cell, k: usize) -> Vec<Cell> {
    if k <= 1 {
        return if k == 1 { vec![*cell] } else { Vec::new() };
    }
    let z_mid = 0.5 * (cell.z_lo + cell.z_hi);
    let sin = (1.0 - z_mid * z_mid).max(0.0).sqrt().max(1e-3);
    let (height, width) = ((cell.z_hi - cell.z_lo) / sin, sin * (cell.phi_hi - cell.phi_lo));
    let rows = ((k as f32 * height / width.max(1e-9)).sqrt().round() as usize).clamp(1, k);
    let mut out = Vec::with_capacity(k);
    let mut above = 0usize;
    for r in 0..rows {
        let m = k / rows + usize::from(r < k % rows);
        let z_hi = cell.z_hi - (cell.z_hi - cell.z_lo) * above as f32 / k as f32;
        let z_lo = if r + 1 == rows { cell.z_lo } else { cell.z_hi - (cell.z_hi - cell.z_lo) * (above + m) as f32 / k as f32 };
        let dphi = (cell.phi_hi - cell.phi_lo) / m as f32;
        for c in 0..m {
            let phi_lo = cell.phi_lo + dphi * c as f32;
            let phi_hi = if c + 1 == m { cell.phi_hi } else { phi_lo + dphi };
            out.push(Cell { z_lo, z_hi, phi_lo, phi_hi });
        }
        above += m;
    }
    out
}

#[cfg(test)]
mod tests;
