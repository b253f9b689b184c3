//! Clustered visibility on the CPU (rayon): the visibility matrix by exact BVH rays
//! (`cpu::light_blocked`, the CPU backend's shadow ray) and shading by Eq. 6/9 with the CPU backend's
//! shading (`cpu::ShadingPoint`, `LightSet::emitted`, `shading::bsdf::eval_records`): the reference of
//! the GPU pass `gpu::clustered_visibility` and the CPU backend's implementation (module docs of
//! `cluster::visibility`).
use super::{seconds, words_per_row, ClusteredImage, ClusteredShading, VisibilityMatrix};
use crate::cpu::{light_blocked, ShadingPoint};
use crate::error::Result;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// View samples per parallel task of the shading.
const SAMPLE_CHUNK: usize = 64;

/// One exact ray per (view cluster with a representative, cluster light): the bit-packed matrix.
pub fn visibility_matrix(tracer: &RayTracer, view: &ViewSamples, job: &ClusteredShading) -> Result<VisibilityMatrix> {
    let lights = &job.lights.lights;
    let (rows, cols) = (job.view_reps.len(), lights.len());
    let words = words_per_row(cols);
    crate::memory::check_host(
        &format!("the visibility matrix: {rows} view clusters x {cols} cluster lights, bit-packed"),
        crate::memory::product(&[rows as u64, words as u64, 4]),
    )?;
    let mut bits = vec![0u32; rows * words];
    // Rows in blocks between interruption checks.
    let rows_per_block = ((1usize << 20) / cols.max(1)).max(1);
    for (b, block) in bits.chunks_mut(rows_per_block * words).enumerate() {
        crate::interrupt::check()?;
        block.par_chunks_mut(words).enumerate().for_each(|(r, row)| {
            let Some(i) = job.view_reps.sample[b * rows_per_block + r] else { return };
            let (p, n_g) = (view.position[i], view.geo_normal[i]);
            for c in 0..cols {
                if ray_visible(tracer, lights, c, p, n_g) {
                    row[c / 32] |= 1 << (c % 32);
                }
            }
        });
    }
    Ok(VisibilityMatrix { rows, cols, bits })
}

/// Whether cluster light c is visible from surface point p (geometric normal n_g): toward its
/// representative's position, or along its reversed direction for a directional light.
pub fn ray_visible(tracer: &RayTracer, lights: &LightSet, c: usize, p: Vec3, n_g: Vec3) -> bool {
    let (wo, dist) = match lights.kind[c] {
        crate::lights::LightKind::Directional => (-lights.direction[c], f32::INFINITY),
        _ => (Vec3::ZERO, 1.0),
    };
    !light_blocked(tracer, lights, c, p, n_g, wo, dist)
}

/// Eq. 6/9 for every view sample with the visibility matrix `vis`: H * W * 3 floats (pixels).
pub fn shade(view: &ViewSamples, job: &ClusteredShading, vis: &VisibilityMatrix) -> Result<Vec<f32>> {
    let m = view.len();
    let lights = &job.lights.lights;
    let f = job.membership.f;
    let words = words_per_row(vis.cols);
    let mut out = vec![0f32; m * 3];
    let samples_per_block = ((1usize << 20) / lights.len().max(1)).max(SAMPLE_CHUNK);
    for (b, block) in out.chunks_mut(samples_per_block * 3).enumerate() {
        crate::interrupt::check()?;
        block.par_chunks_mut(SAMPLE_CHUNK * 3).enumerate().for_each(|(t, dst)| {
            for (e, px) in dst.chunks_exact_mut(3).enumerate() {
                let i = b * samples_per_block + t * SAMPLE_CHUNK + e;
                let sp = ShadingPoint::new(view, i);
                if !sp.surface {
                    continue;
                }
                let ks = &job.membership.clusters[i * f..(i + 1) * f];
                let ws = &job.membership.weights[i * f..(i + 1) * f];
                let mut sum = Vec3::ZERO;
                for c in 0..lights.len() {
                    let Some((wo, radiance, _)) = lights.emitted(c, sp.p, sp.n) else { continue };
                    let local = Vec3::new(wo.dot(sp.s), wo.dot(sp.t), wo.dot(sp.n));
                    let receiver = |w: Vec3| {
                        crate::shading::bsdf::eval_records(&view.bsdf, i, sp.wi_local, Vec3::new(w.dot(sp.s), w.dot(sp.t), w.dot(sp.n)))
                    };
                    let mut v = lights.shade_receiver(c, sp.p, wo, radiance, receiver) * sp.throughput;
                    if !view.bsdf_samples.is_empty() {
                        v *= crate::matrix::glossy::light_weight(view, lights, i, sp.p, sp.wi_local, local, c);
                    }
                    if v == Vec3::ZERO {
                        continue;
                    }
                    let mut visible = 0.0f32;
                    for (&k, &w) in ks.iter().zip(ws) {
                        if vis.bits[k as usize * words + c / 32] >> (c % 32) & 1 == 1 {
                            visible += w;
                        }
                    }
                    sum += v * visible;
                }
                px.copy_from_slice(&sum.to_array());
            }
        });
    }
    Ok(if m == view.num_pixels() { out } else { view.fold(&out, 3) })
}

/// `InvalidParameter` for a view of a scene with masked surfaces: a visibility bit cannot hold their
/// fractional transmittance (the CPU and GPU clustered renders both refuse them).
pub fn refuse_masks(view: &ViewSamples) -> Result<()> {
    if !view.mask_budget.is_empty() {
        return Err(crate::error::Error::invalid(
            "clustered visibility does not support the mask BSDF (opacity cut-outs) yet: a visibility bit cannot hold \
             a masked surface's fractional transmittance",
        ));
    }
    Ok(())
}

/// The whole clustered render on the CPU: visibility matrix, then shading, each timed.
///
/// Errors also: `InvalidParameter` for a view of a scene with masked surfaces (a visibility bit cannot hold
/// their fractional transmittance).
pub fn render(tracer: &RayTracer, view: &ViewSamples, job: &ClusteredShading) -> Result<ClusteredImage> {
    refuse_masks(view)?;
    let t0 = Instant::now();
    let visibility = visibility_matrix(tracer, view, job)?;
    let visibility_seconds = seconds(t0);
    let t1 = Instant::now();
    let image = shade(view, job, &visibility)?;
    Ok(ClusteredImage { image, visibility, rays: job.rays(), gave_up: 0, visibility_seconds, shading_seconds: seconds(t1) })
}
