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
//! - `KMEANS_STEPS_PER_DISPATCH` = 2^27 K-means steps (one candidate centroid's distance to a point
//!   and its insertion into the point's list of F nearest, counted F; or one other loop iteration of a
//!   K-means kernel): 0.13 s at 1 G steps/s.
//! - `COLUMN_READS_PER_DISPATCH` = 2^27 column reads of the tensor reconstruction (one RGB sample of a
//!   representative column scaled and added, or one step along a chain of pixel mappings): 0.13 s at
//!   1 G reads/s.
//!
//! Each pass states its unit of work per item and is split into ranges of items within its budget:
//! - columns (`plan_columns`): (view sample, light) pairs, one evaluation and, with exact visibility, one
//!   ray each; clustered shading (`plan_clustered_shading`): `f + 1` evaluations per pair. Lights outer,
//!   samples inner; a view sample's lights are still visited in the same order, so images do not change.
//! - K-means (`plan_kmeans`, `gpu::kmeans`): one item per data point or centroid. `assign` costs its
//!   loop budget per point (`GpuKMeansParams::budget`, its worst case), `assign_chunk` `CHUNK * F`,
//!   `fuzzy_weights` `2 F`, `accumulate`, `grid_count`, `grid_fill` and `update` 1 (`grid_scan` is one
//!   workgroup of at most 2 * 1024 + 8 iterations per thread). Every range is a whole number of
//!   256-thread workgroups but the last, and one row of at most `MAX_GROUPS_X` of them, so the objective
//!   partials (one per workgroup) tile exactly `ceil(n / 256)` slots whatever the split.
//! - tensor reconstruction (`plan_reconstruction`, `gpu::reconstruction`): one item per (target frame,
//!   pixel), costing the frames its mapping chain walks plus `columns * (1 + extras)` reads, `extras`
//!   the most delta-chain samples folded into one pixel.
//! - batched shadow rays (`plan_rays`, `gpu::bvh::OccludedPass`): one ray per query, at most 2^20 queries
//!   per upload.
//!
//! Every item is computed by exactly one invocation of exactly one dispatch, with the same arithmetic
//! in the same order whatever the split, so a split pass gives bit-identical results (tested by forcing
//! a tiny budget through `with_budget`). The row pass is bounded by its output binding (at most 128 MiB
//! of RGB f32 per dispatch: 11.2 M (row, light) threads, one evaluation and at most one ray each), and
//! clustered visibility by `clustered_visibility::PAIRS_PER_DISPATCH` (2^22 rays).
//! A lost device is dropped and recreated on the next call (`GpuContext::shared`).

/// Most light evaluations per dispatch (module docs).
pub const LIGHT_EVALS_PER_DISPATCH: u64 = 1 << 27;
/// Most shadow rays per dispatch (module docs).
pub const RAYS_PER_DISPATCH: u64 = 1 << 24;
/// Most K-means steps per dispatch (module docs).
pub const KMEANS_STEPS_PER_DISPATCH: u64 = 1 << 27;
/// Most column reads of the tensor reconstruction per dispatch (module docs).
pub const COLUMN_READS_PER_DISPATCH: u64 = 1 << 27;
/// Most shadow-ray queries uploaded at once by `OccludedPass` (48 bytes each: 48 MiB).
pub const QUERIES_PER_UPLOAD: u64 = 1 << 20;

/// The budgets in force on this thread: the constants above, or what a test set with [`with_budget`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    pub light_evals: u64,
    pub rays: u64,
    pub kmeans_steps: u64,
    pub column_reads: u64,
}

impl Budget {
    pub const DEFAULT: Budget = Budget {
        light_evals: LIGHT_EVALS_PER_DISPATCH,
        rays: RAYS_PER_DISPATCH,
        kmeans_steps: KMEANS_STEPS_PER_DISPATCH,
        column_reads: COLUMN_READS_PER_DISPATCH,
    };
}

thread_local! {
    static BUDGET: std::cell::Cell<Budget> = const { std::cell::Cell::new(Budget::DEFAULT) };
}

/// The per-dispatch budgets of the passes this thread encodes.
pub fn budget() -> Budget {
    BUDGET.with(|b| b.get())
}

/// Runs `f` with every per-dispatch budget of this thread set to `work` units (tests: a tiny budget
/// splits a small problem into many dispatches, whose results must equal the unsplit ones bit for bit).
#[cfg(test)]
pub fn with_budget<R>(work: u64, f: impl FnOnce() -> R) -> R {
    let old = BUDGET.with(|b| b.replace(Budget { light_evals: work, rays: work, kmeans_steps: work, column_reads: work }));
    let out = f();
    BUDGET.with(|b| b.set(old));
    out
}

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
    item_ranges(samples, per, WORKGROUP_SIZE)
}

/// Ranges (first, count) of `items` items, at most `per` each (at least one workgroup): every range but
/// the last a whole number of `workgroup`-thread workgroups and at most one row of `MAX_GROUPS_X` of
/// them. One range `(0, 0)` when there are no items.
pub fn item_ranges(items: u32, per: u64, workgroup: u32) -> Vec<(u32, u32)> {
    let wg = workgroup.max(1) as u64;
    let cap = (MAX_GROUPS_X as u64) * wg;
    let per = (per / wg * wg).clamp(wg, cap);
    if items as u64 <= per {
        return vec![(0, items)];
    }
    (0..items as u64).step_by(per as usize).map(|a| (a as u32, (per.min(items as u64 - a)) as u32)).collect()
}

/// One dispatch of a pass over items of equal cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ItemDispatch {
    pub first: u32,
    pub count: u32,
    /// Units of work: `count * cost`.
    pub work: u64,
}

/// Dispatches of `items` items of `cost` units each within `budget` units (module docs).
pub fn plan_items(items: u32, cost: u64, budget: u64, workgroup: u32) -> Vec<ItemDispatch> {
    let cost = cost.max(1);
    item_ranges(items, budget / cost, workgroup)
        .into_iter()
        .map(|(first, count)| ItemDispatch { first, count, work: count as u64 * cost })
        .collect()
}

/// A K-means kernel's dispatches: `items` points or centroids of `cost` steps each (module docs),
/// 256-thread workgroups.
pub fn plan_kmeans(items: u32, cost: u64, budget: &Budget) -> Vec<ItemDispatch> {
    plan_items(items, cost, budget.kmeans_steps, crate::gpu::kmeans::WORKGROUP_SIZE)
}

/// The tensor reconstruction's dispatches over `items` (target frame, pixel) pairs of `cost` reads each
/// (module docs), 64-thread workgroups.
pub fn plan_reconstruction(items: u32, cost: u64, budget: &Budget) -> Vec<ItemDispatch> {
    plan_items(items, cost, budget.column_reads, crate::gpu::reconstruction::WORKGROUP_SIZE)
}

/// `OccludedPass`'s dispatches over `queries` shadow-ray queries (one ray each; module docs).
pub fn plan_rays(queries: u32, budget: &Budget) -> Vec<ItemDispatch> {
    plan_items(queries, 1, budget.rays.min(QUERIES_PER_UPLOAD), WORKGROUP_SIZE)
}

/// The dispatches of one column batch: `samples` view samples, `lights` lights, `lights_per_dispatch`
/// at most per dispatch (Mesa's loop cap with rays), `rays` whether each (sample, light) casts an exact
/// ray. Lights outer, samples inner: each sample sees its lights in order.
pub fn plan_columns(samples: u32, lights: u32, lights_per_dispatch: u32, rays: bool) -> Vec<Dispatch> {
    let mut out = Vec::new();
    let step = lights_per_dispatch.max(1);
    for first_light in (0..lights).step_by(step as usize) {
        let num_lights = step.min(lights - first_light);
        let b = budget();
        let mut per = b.light_evals / num_lights as u64;
        if rays {
            per = per.min(b.rays / num_lights as u64);
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
        let per = budget().light_evals / (num_lights as u64 * (f as u64 + 1));
        for (first_sample, num_samples) in sample_ranges(samples, per) {
            let evals = num_samples as u64 * num_lights as u64 * (f as u64 + 1);
            out.push(Dispatch { first_sample, num_samples, first_light, num_lights, evals, rays: 0 });
        }
    }
    out
}

#[cfg(test)]
mod tests;
