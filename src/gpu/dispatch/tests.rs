use super::*;
use crate::gpu::bvh::RAYS_PER_INVOCATION;
use crate::gpu::clustered_visibility::lights_per_dispatch;
use crate::gpu::columns::MAX_LIGHTS_PER_DISPATCH;

const FULL_HD: u32 = 1920 * 1080;

/// Every (sample, light) pair exactly once, lights in order for every sample, each dispatch within
/// both budgets and a row of workgroups, and only the last range of a light range not a whole number of
/// workgroups.
fn check_plan(plan: &[Dispatch], samples: u32, lights: u32, evals_per_pair: u64) {
    let mut covered = 0u64;
    let mut next_light = 0u32;
    let mut next_sample = 0u32;
    for d in plan {
        assert!(d.evals <= LIGHT_EVALS_PER_DISPATCH, "{d:?}");
        assert!(d.rays <= RAYS_PER_DISPATCH, "{d:?}");
        assert!(d.num_samples <= MAX_GROUPS_X * WORKGROUP_SIZE, "{d:?}");
        assert_eq!(d.evals, d.num_samples as u64 * d.num_lights as u64 * evals_per_pair);
        if d.first_sample == 0 {
            assert_eq!(d.first_light, next_light, "light ranges in order");
            next_light += d.num_lights;
        }
        assert_eq!(d.first_sample, next_sample);
        next_sample = if d.first_sample + d.num_samples == samples { 0 } else { d.first_sample + d.num_samples };
        if next_sample != 0 {
            assert_eq!(d.num_samples % WORKGROUP_SIZE, 0, "{d:?}");
        }
        covered += d.num_samples as u64 * d.num_lights as u64;
    }
    assert_eq!(next_light, lights);
    assert_eq!(covered, samples as u64 * lights as u64);
}

#[test]
fn columns_at_1080p_stay_within_the_budget() {
    // A full batch of lights with shadow maps: 1920 x 1080 x 256 = 531 M evaluations, split in 4.
    let plan = plan_columns(FULL_HD, MAX_LIGHTS_PER_DISPATCH as u32, MAX_LIGHTS_PER_DISPATCH as u32, false);
    check_plan(&plan, FULL_HD, 256, 1);
    assert_eq!(plan.len(), 4);
    assert_eq!(plan[0].num_samples, 524_288);
    // Exact rays: RAYS_PER_INVOCATION lights per dispatch, 2^24 rays at most.
    let plan = plan_columns(FULL_HD, 256, RAYS_PER_INVOCATION, true);
    check_plan(&plan, FULL_HD, 256, 1);
    assert!(plan.iter().all(|d| d.rays > 0));
    // 30 lights: 559,232 samples (a multiple of 64) per dispatch; the last 16 lights: exactly 2^24 rays.
    assert_eq!(plan[0].rays, RAYS_PER_DISPATCH / 30 / 64 * 64 * 30);
    assert_eq!(plan.iter().map(|d| d.rays).max(), Some(RAYS_PER_DISPATCH));
    // Eight ranges of 30 lights in 4 dispatches each, the last 16 lights in 2.
    assert_eq!(plan.len(), 34);
}

#[test]
fn clustered_shading_at_1080p_stays_within_the_budget() {
    // 100k lights clustered to 4,096, F = 8: before, one dispatch held 1920 x 1080 x 4,096 x 9 evaluations.
    for (lights, f) in [(4096u32, 8u32), (100_000, 8), (1000, 1), (3, 16)] {
        let per = lights_per_dispatch(f as usize) as u32;
        let plan = plan_clustered_shading(FULL_HD, lights, per, f);
        check_plan(&plan, FULL_HD, lights, f as u64 + 1);
        let unsplit = FULL_HD as u64 * per.min(lights) as u64 * (f as u64 + 1);
        assert!(plan.len() as u64 >= unsplit.div_ceil(LIGHT_EVALS_PER_DISPATCH));
    }
}

#[test]
fn small_images_are_one_dispatch_per_light_range() {
    assert_eq!(sample_ranges(64 * 64, LIGHT_EVALS_PER_DISPATCH / 256), vec![(0, 4096)]);
    assert_eq!(sample_ranges(0, 10), vec![(0, 0)]);
    assert_eq!(sample_ranges(1000, 100), (0..16).map(|k| (k * 64, if k == 15 { 40 } else { 64 })).collect::<Vec<_>>());
    assert_eq!(plan_columns(4096, 0, 30, true), vec![]);
}

/// Every item exactly once and in order, each dispatch within `budget` and one row of workgroups, and
/// only the last range not a whole number of workgroups.
fn check_items(plan: &[ItemDispatch], items: u32, cost: u64, budget: u64, workgroup: u32) {
    let mut next = 0u32;
    for (k, d) in plan.iter().enumerate() {
        assert_eq!(d.first, next, "ranges in order, without gaps or overlaps");
        assert!(d.work <= budget, "{d:?} over the budget {budget}");
        assert_eq!(d.work, d.count as u64 * cost);
        assert!(d.count <= MAX_GROUPS_X * workgroup, "{d:?}");
        if k + 1 < plan.len() {
            assert_eq!(d.count % workgroup, 0, "{d:?}");
        }
        next += d.count;
    }
    assert_eq!(next, items);
}

#[test]
fn kmeans_at_1080p_stays_within_the_budget() {
    use crate::gpu::kmeans::{num_partials, CHUNK, DEFAULT_BUDGET, WORKGROUP_SIZE as WG};
    let b = Budget::DEFAULT;
    // One point per pixel, every kernel: the grid assignment at its loop budget, an exhaustive chunk at
    // the largest F, the weights, the accumulation; 100k centroids for the per-centroid kernels.
    for (items, cost) in [
        (FULL_HD, DEFAULT_BUDGET as u64),
        (FULL_HD, CHUNK as u64),
        (FULL_HD, CHUNK as u64 * 16),
        (FULL_HD, 2 * 16),
        (FULL_HD, 1),
        (100_000, 1),
    ] {
        let plan = plan_kmeans(items, cost, &b);
        check_items(&plan, items, cost, KMEANS_STEPS_PER_DISPATCH, WG);
        assert!(plan.len() as u64 >= (items as u64 * cost).div_ceil(KMEANS_STEPS_PER_DISPATCH));
    }
    // Before: one assign_chunk dispatch held 1920 x 1080 x 2048 = 4.2 G distance evaluations; now 32.
    assert_eq!(plan_kmeans(FULL_HD, CHUNK as u64, &b).len(), 32);
    assert_eq!(plan_kmeans(FULL_HD, DEFAULT_BUDGET as u64, &b).len(), 386);
    // The objective partials: one per workgroup of the accumulate dispatches, tiling ceil(n / 256) slots
    // also beyond 65,535 workgroups (where one dispatch would need a second row of its grid).
    for n in [FULL_HD, 65_535 * 256 + 1, 40_000_000, 1000, 1] {
        let plan = plan_kmeans(n, 1, &b);
        let mut slot = 0u32;
        for d in &plan {
            assert_eq!(d.first / WG, slot, "a dispatch's first partial follows the previous one's last");
            slot += d.count.div_ceil(WG);
        }
        assert_eq!(slot as usize, num_partials(n as usize));
    }
    assert_eq!(plan_kmeans(65_535 * 256 + 1, 1, &b).len(), 2);
}

#[test]
fn reconstruction_and_shadow_rays_at_1080p_stay_within_the_budget() {
    use crate::gpu::reconstruction::{MAX_BATCH, WORKGROUP_SIZE as WG};
    let b = Budget::DEFAULT;
    // 8 target frames of 1920 x 1080 pixels, a full batch of columns, mapping chains up to 7 frames long
    // and up to 3 delta-chain extras per pixel: 8 x 2.07 M x 1031 reads = 17 G in one dispatch before.
    for (frames, chain, extras) in [(8u32, 7u64, 3u64), (1, 0, 0), (64, 63, 40)] {
        let items = frames * FULL_HD;
        let cost = chain + MAX_BATCH as u64 * (1 + extras);
        let plan = plan_reconstruction(items, cost, &b);
        check_items(&plan, items, cost, COLUMN_READS_PER_DISPATCH, WG);
        assert!(plan.len() as u64 >= (items as u64 * cost).div_ceil(COLUMN_READS_PER_DISPATCH));
    }
    // Shadow-ray batches: 16 rays per pixel, one per query, 2^20 queries per upload (2^24 rays allowed).
    let plan = plan_rays(16 * FULL_HD, &b);
    check_items(&plan, 16 * FULL_HD, 1, RAYS_PER_DISPATCH, WORKGROUP_SIZE);
    assert_eq!(plan.len(), 32);
    assert!(plan.iter().all(|d| d.work <= QUERIES_PER_UPLOAD));
}

#[test]
fn a_tiny_budget_splits_into_single_workgroups() {
    let tiny = with_budget(100, budget);
    assert_eq!(tiny, Budget { light_evals: 100, rays: 100, kmeans_steps: 100, column_reads: 100 });
    assert_eq!(budget(), Budget::DEFAULT, "the hook restores the budget");
    let plan = plan_kmeans(1000, 1, &tiny);
    assert_eq!(plan.iter().map(|d| (d.first, d.count)).collect::<Vec<_>>(), vec![(0, 256), (256, 256), (512, 256), (768, 232)]);
    // A cost above the budget still makes progress: one workgroup per dispatch.
    assert_eq!(plan_kmeans(1000, 24_576, &tiny).len(), 4);
    assert_eq!(plan_rays(0, &tiny), vec![ItemDispatch { first: 0, count: 0, work: 0 }]);
    assert_eq!(with_budget(64 * 30, || plan_columns(640, 30, 30, true)).len(), 10);
}
