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
