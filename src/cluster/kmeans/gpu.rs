//! K-means and fuzzy membership on the GPU (Alg. 1-2): the driver of the passes in `crate::gpu::kmeans`.
//! Everything between the upload and the final read-back stays on the GPU; the host reads one float per
//! 256 points per iteration (the objective partials) to record the objective and test convergence.
use super::fuzzy::{check_centroids, check_f, FuzzyMembership};
use super::{check_params, check_points, initial_indices, KMeansParams, KMeansResult, KMeansTimings};
use crate::error::Result;
use crate::gpu::kmeans::KMeansBuffers;
use crate::gpu::GpuContext;
use std::time::Instant;

const INADMISSIBLE: u32 = 0x8000_0000;

/// [`super::kmeans_cpu`] on the GPU: same initial centroids, same order of candidates, same fixed-point
/// reduction (module docs of `crate::cluster::kmeans` for the precision). With `use_grid` the assignment
/// searches the grid over the centroids (built on the GPU each iteration); the result equals the
/// exhaustive one.
///
/// Errors: as [`super::kmeans_cpu`]; `OutOfMemory` when a buffer exceeds the device's binding limit;
/// `Gpu` errors of the device; `Interrupted` on Ctrl-C (checked between iterations).
pub fn kmeans_gpu(ctx: &GpuContext, points: &[[f32; 3]], normals: &[[f32; 3]], p: &KMeansParams) -> Result<KMeansResult> {
    kmeans_gpu_with_budget(ctx, points, normals, p, None)
}

/// [`kmeans_gpu`] with the grid search's loop budget overridden (tests force the exhaustive fallback).
pub(crate) fn kmeans_gpu_with_budget(
    ctx: &GpuContext,
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    p: &KMeansParams,
    budget: Option<u32>,
) -> Result<KMeansResult> {
    let t0 = Instant::now();
    let normals = check_points(points, normals, p.cos_threshold, "kmeans")?;
    check_params(points.len(), p)?;
    let initial = initial_indices(points.len(), p.k, p.seed);
    let c0: Vec<[f32; 3]> = initial.iter().map(|&i| points[i as usize]).collect();
    let n0: Vec<[f32; 3]> = initial.iter().map(|&i| normals[i as usize]).collect();
    let mut bufs = KMeansBuffers::new(ctx, points, &normals, &c0, &n0, 1, p.cos_threshold, p.use_grid)?;
    if let Some(b) = budget {
        bufs.params.budget = b;
    }
    let setup_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let mut objective = Vec::new();
    let mut iterations = 0;
    let mut pending_update = false;
    loop {
        crate::interrupt::check()?;
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kmeans_gpu::iteration") });
        if pending_update {
            bufs.encode_update(ctx, &mut enc)?;
        }
        bufs.encode_assign(ctx, &mut enc)?;
        bufs.encode_accumulate(ctx, &mut enc, objective.len() < p.max_iterations)?;
        ctx.queue.submit(Some(enc.finish()));
        objective.push(bufs.read_objective(ctx)?);
        let t = objective.len() - 1;
        let converged = t > 0 && p.tolerance > 0.0 && objective[t - 1] - objective[t] <= p.tolerance * objective[t - 1];
        if t == p.max_iterations || converged {
            break;
        }
        pending_update = true;
        iterations += 1;
    }
    let iterations_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let (centroids, centroid_normals) = bufs.read_centroids(ctx)?;
    let (idx, _) = bufs.read_lists(ctx)?;
    let assignment = idx.iter().map(|&i| i & !INADMISSIBLE).collect();
    let readback_s = t2.elapsed().as_secs_f64();
    Ok(KMeansResult {
        centroids,
        centroid_normals,
        assignment,
        objective,
        iterations,
        initial,
        timings: KMeansTimings { setup_s, iterations_s, readback_s, total_s: t0.elapsed().as_secs_f64() },
        device: "gpu",
    })
}

/// [`super::fuzzy_membership`] on the GPU (Alg. 2 with the grid when `use_grid`; Eq. 10 weights by the
/// `fuzzy_weights` kernel). Same order of candidates as the CPU; weights agree to float rounding.
///
/// Errors: as [`super::fuzzy_membership`]; `OutOfMemory` / `Gpu` from the device.
#[allow(clippy::too_many_arguments)]
pub fn fuzzy_membership_gpu(
    ctx: &GpuContext,
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    centroids: &[[f32; 3]],
    centroid_normals: &[[f32; 3]],
    f: usize,
    cos_threshold: Option<f32>,
    use_grid: bool,
) -> Result<FuzzyMembership> {
    fuzzy_membership_gpu_with_budget(ctx, points, normals, centroids, centroid_normals, f, cos_threshold, use_grid, None)
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn fuzzy_membership_gpu_with_budget(
    ctx: &GpuContext,
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    centroids: &[[f32; 3]],
    centroid_normals: &[[f32; 3]],
    f: usize,
    cos_threshold: Option<f32>,
    use_grid: bool,
    budget: Option<u32>,
) -> Result<FuzzyMembership> {
    let normals = check_points(points, normals, cos_threshold, "fuzzy membership")?;
    let cn = check_centroids(centroids, centroid_normals, cos_threshold)?;
    check_f(f, centroids.len())?;
    let mut bufs = KMeansBuffers::new(ctx, points, &normals, centroids, &cn, f, cos_threshold, use_grid)?;
    if let Some(b) = budget {
        bufs.params.budget = b;
    }
    let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("fuzzy_membership_gpu") });
    bufs.encode_assign(ctx, &mut enc)?;
    bufs.encode_weights(ctx, &mut enc)?;
    ctx.queue.submit(Some(enc.finish()));
    let (idx, d2) = bufs.read_lists(ctx)?;
    let weights: Vec<f32> = ctx.read_buffer(&bufs.weights, 0, idx.len())?;
    Ok(FuzzyMembership {
        f,
        clusters: idx.iter().map(|&i| i & !INADMISSIBLE).collect(),
        admissible: idx.iter().map(|&i| i & INADMISSIBLE == 0).collect(),
        weights,
        distances2: d2,
    })
}
