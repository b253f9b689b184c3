//! How much work one GPU dispatch may hold.
//!
//! An operating system resets a GPU whose work runs too long in one go (Windows' TDR: about 2 s;
//! Linux drivers and macOS have similar watchdogs), and the device is then lost. Dispatches are
//! therefore bounded by a stated budget of work, not only by Mesa's loop cap of 65,535 iterations per
//! invocation (which bounds the work per thread, not per dispatch):
//! - `LIGHT_EVALS_PER_DISPATCH` = 2^27 light evaluations (one view sample shaded by one light: emission,
//!   BSDF, a shadow-map lookup or interpolated visibility). At a pessimistic 0.2 G evaluations/s
//!   (a small integrated GPU) that is 0.67 s; a discrete GPU takes tens of milliseconds.
//! - `RAYS_PER_DISPATCH` = 2^24 exact shadow rays (each at most `bvh::MAX_RAY_STEPS` traversal steps):
//!   0.17 s at 100 M rays/s.
//!
//! The column pass (`plan_columns`) and clustered shading (`plan_clustered_shading`) split their view
//! samples into ranges that keep each dispatch within both budgets; a view sample's lights are still
//! visited in the same order, so images do not change. The row pass is bounded by its output binding
//! (at most 128 MiB of RGB f32 per dispatch: 11.2 M (row, light) threads, one evaluation and at most one
//! ray each), and clustered visibility by `clustered_visibility::PAIRS_PER_DISPATCH` (2^22 rays).
//! A lost device is dropped and recreated on the next call (`GpuContext::shared`).

/// Most light evaluations per dispatch (module docs).
pub const LIGHT_EVALS_PER_DISPATCH: u64 = 1 << 27;
/// Most shadow rays per dispatch (module docs).
pub const RAYS_PER_DISPATCH: u64 = 1 << 24;
/// Threads per workgroup of the passes split here (`columns.wgsl`, `clustered_visibility.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;
/// Most workgroups along x of one dispatch (WebGPU's guaranteed `max_compute_workgroups_per_dimension`).
pub const MAX_GROUPS_X: u32 = 65_535;

/// One dispatch of a pass over view samples and lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dispatch {
    pub first_sample: u32,
    pub num_samples: u32,
    pub first_light: u32,
    pub num_lights: u32,
    /// Light evaluations (`num_samples * num_lights`).
    pub evals: u64,
    /// Shadow rays (0 when visibility comes from shadow maps or a precomputed matrix).
    pub rays: u64,
}

/// Ranges of `samples` view samples of at most `per` each: every range but the last holds a multiple
/// of `WORKGROUP_SIZE` samples and fits one row of workgroups, so a dispatch of exactly its samples has
/// no thread past its range except in the last (where the sample count ends it).
pub fn sample_ranges(samples: u32, per: u64) -> Vec<(u32, u32)> {
    let wg = WORKGROUP_SIZE as u64;
    let cap = (MAX_GROUPS_X as u64) * wg;
    let per = (per / wg * wg).clamp(wg, cap);
    if samples as u64 <= per {
        return vec![(0, samples)];
    }
    (0..samples as u64).step_by(per as usize).map(|a| (a as u32, (per.min(samples as u64 - a)) as u32)).collect()
}

/// The dispatches of one column batch: `samples` view samples, `lights` lights, `lights_per_dispatch`
/// at most per dispatch (Mesa's loop cap with rays), `rays` whether each (sample, light) casts an exact
/// ray. Lights outer, samples inner: each sample sees its lights in order.
pub fn plan_columns(samples: u32, lights: u32, lights_per_dispatch: u32, rays: bool) -> Vec<Dispatch> {
    let mut out = Vec::new();
    let step = lights_per_dispatch.max(1);
    for first_light in (0..lights).step_by(step as usize) {
        let num_lights = step.min(lights - first_light);
        let mut per = LIGHT_EVALS_PER_DISPATCH / num_lights as u64;
        if rays {
            per = per.min(RAYS_PER_DISPATCH / num_lights as u64);
        }
        for (first_sample, num_samples) in sample_ranges(samples, per) {
            let evals = num_samples as u64 * num_lights as u64;
            out.push(Dispatch { first_sample, num_samples, first_light, num_lights, evals, rays: if rays { evals } else { 0 } });
        }
    }
    out
}

/// The shading dispatches of clustered visibility: `samples` view samples, `lights` cluster lights in
/// ranges of `lights_per_dispatch` (`clustered_visibility::lights_per_dispatch`, Mesa's loop cap), each
/// sample's `f` view clusters' visibility interpolated per light (counted as `f + 1` evaluations).
pub fn plan_clustered_shading(samples: u32, lights: u32, lights_per_dispatch: u32, f: u32) -> Vec<Dispatch> {
    let mut out = Vec::new();
    let step = lights_per_dispatch.max(1);
    for first_light in (0..lights).step_by(step as usize) {
        let num_lights = step.min(lights - first_light);
        let per = LIGHT_EVALS_PER_DISPATCH / (num_lights as u64 * (f as u64 + 1));
        for (first_sample, num_samples) in sample_ranges(samples, per) {
            let evals = num_samples as u64 * num_lights as u64 * (f as u64 + 1);
            out.push(Dispatch { first_sample, num_samples, first_light, num_lights, evals, rays: 0 });
        }
    }
    out
}

#[cfg(test)]
mod tests;
