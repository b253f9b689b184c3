//! Clustered visibility on the CPU (rayon): the visibility matrix by exact rays (`cpu::light_ray`, traced in
//! packets, `RayTracer::occluded_packet`; one at a time through masked surfaces,
//! `cpu::visibility_crossed`: the CPU backend's shadow ray)
//! and shading by Eq. 6/9 with the CPU backend's unshadowed elements (`cpu::shade_unshadowed`): the reference of
//! the GPU pass `gpu::clustered_visibility` and the CPU backend's implementation (module docs of
//! `cluster::visibility`).
use super::{seconds, words_per_row, ClusteredImage, ClusteredShading, VisibilityMatrix};
use crate::cpu::{shade_unshadowed, visibility_crossed, ShadingPoint};
use crate::error::Result;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// View samples per parallel task of the shading.
const SAMPLE_CHUNK: usize = 64;

/// One exact ray per (view cluster with a representative, cluster light): the bit-packed matrix, and in a
/// scene with masked surfaces the transmittance and crossing of every entry (module docs of
/// `cluster::visibility`).
pub fn visibility_matrix(tracer: &RayTracer, view: &ViewSamples, job: &ClusteredShading) -> Result<VisibilityMatrix> {
    let lights = &job.lights.lights;
    let (rows, cols) = (job.view_reps.len(), lights.len());
    let words = words_per_row(cols);
    let masked = !view.mask_budget.is_empty();
    let bytes = crate::memory::product(&[rows as u64, words as u64, 4])
        + if masked { crate::memory::product(&[rows as u64, cols as u64, 5]) } else { 0 };
    crate::memory::check_host(&format!("the visibility matrix: {rows} view clusters x {cols} cluster lights"), bytes)?;
    let mut out = VisibilityMatrix {
        rows,
        cols,
        bits: vec![0u32; rows * words],
        transmittance: if masked { vec![0f32; rows * cols] } else { Vec::new() },
        crossed: if masked { vec![0u32; rows * words] } else { Vec::new() },
    };
    // Rows in blocks between interruption checks.
    let rows_per_block = ((1usize << 20) / cols.max(1)).max(1);
    for first in (0..rows).step_by(rows_per_block) {
        crate::interrupt::check()?;
        let block: Vec<Vec<(f32, bool)>> = (first..rows.min(first + rows_per_block))
            .into_par_iter()
            .map(|k| match job.view_reps.sample[k] {
                Some(i) if masked => (0..cols).map(|c| entry(tracer, view, lights, i, c)).collect(),
                Some(i) => row_in_packets(tracer, view, lights, i),
                None => Vec::new(),
            })
            .collect();
        for (k, row) in (first..).zip(block) {
            for (c, (v, crossed)) in row.into_iter().enumerate() {
                let (word, bit) = (k * words + c / 32, 1u32 << (c % 32));
                if v > 0.0 {
                    out.bits[word] |= bit;
                }
                if masked {
                    out.transmittance[k * cols + c] = v;
                    if crossed {
                        out.crossed[word] |= bit;
                    }
                }
            }
        }
    }
    Ok(out)
}

/// V of cluster light c from view sample i (a representative) and whether its ray crossed a masked
/// surface (`cpu::visibility_crossed`, as the light matrix's element (i, c) has it). Rays toward the light's
/// position, or along its reversed direction for a directional light.
pub fn entry(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, i: usize, c: usize) -> (f32, bool) {
    let (wo, dist) = toward(lights, c);
    visibility_crossed(tracer, view, lights, i, c, view.position[i], view.geo_normal[i], wo, dist)
}

/// What `entry` hands `visibility_crossed` for cluster light c: (wo, distance), wo read only for a
/// directional light.
fn toward(lights: &LightSet, c: usize) -> (Vec3, f32) {
    match lights.kind[c] {
        crate::lights::LightKind::Directional => (-lights.direction[c], f32::INFINITY),
        _ => (Vec3::ZERO, 1.0),
    }
}

/// `entry` for every cluster light of representative i in a scene without masked surfaces: the same rays
/// (`cpu::light_ray`), traced [`crate::raytrace::PACKET`] at a time (`RayTracer::occluded_packet`).
fn row_in_packets(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet, i: usize) -> Vec<(f32, bool)> {
    let (p, n_g) = (view.position[i], view.geo_normal[i]);
    let cols = lights.len();
    let (mut o, mut d, mut t_max) = (Vec::with_capacity(cols), Vec::with_capacity(cols), Vec::with_capacity(cols));
    for c in 0..cols {
        let (wo, dist) = toward(lights, c);
        let (oc, dc, tc) = crate::cpu::light_ray(lights, c, p, n_g, wo, dist);
        o.push(oc);
        d.push(dc);
        t_max.push(tc);
    }
    let mut blocked = vec![false; cols];
    tracer.occluded_packet(&o, &d, &t_max, &mut blocked);
    blocked.into_iter().map(|b| (!b as u8 as f32, false)).collect()
}

/// Eq. 6/9 for every view sample with the visibility matrix `vis`: H * W * 3 floats (pixels). The light's
/// value at a sample is the light matrix's unshadowed element (`cpu::shade_unshadowed`); in a masked scene
/// an entry whose ray crossed a mask counts without the glossy light weight, as `cpu::shade` does.
pub fn shade(view: &ViewSamples, job: &ClusteredShading, vis: &VisibilityMatrix) -> Result<Vec<f32>> {
    let m = view.len();
    let lights = &job.lights.lights;
    let f = job.membership.f;
    let glossy = !view.bsdf_samples.is_empty();
    let mut out = vec![0f32; m * 3];
    let samples_per_block = ((1usize << 20) / lights.len().max(1)).max(SAMPLE_CHUNK);
    for (b, block) in out.chunks_mut(samples_per_block * 3).enumerate() {
        crate::interrupt::check()?;
        block.par_chunks_mut(SAMPLE_CHUNK * 3).enumerate().for_each(|(t, dst)| {
            for (e, px) in dst.chunks_exact_mut(3).enumerate() {
                let i = b * samples_per_block + t * SAMPLE_CHUNK + e;
                let sp = ShadingPoint::new(view, i);
                let ks = &job.membership.clusters[i * f..(i + 1) * f];
                let ws = &job.membership.weights[i * f..(i + 1) * f];
                let mut sum = Vec3::ZERO;
                for c in 0..lights.len() {
                    let Some((v, wo, _)) = shade_unshadowed(view, lights, &sp, i, c) else { continue };
                    let (mut visible, mut through_mask) = (0.0f32, 0.0f32);
                    for (&k, &w) in ks.iter().zip(ws) {
                        match vis.value(k as usize, c) {
                            (value, true) if glossy => through_mask += w * value,
                            (value, _) => visible += w * value,
                        }
                    }
                    if through_mask > 0.0 {
                        let w = crate::matrix::glossy::light_weight(view, lights, i, sp.p, sp.wi_local, sp.local(wo), c);
                        if w > 0.0 {
                            through_mask /= w;
                        }
                    }
                    sum += v * (visible + through_mask);
                }
                px.copy_from_slice(&sum.to_array());
            }
        });
    }
    Ok(if m == view.num_pixels() { out } else { view.fold(&out, 3) })
}

/// The whole clustered render on the CPU: visibility matrix, then shading, each timed.
///
/// Errors: what `visibility_matrix` and `shade` raise (host memory, `Interrupted`).
pub fn render(tracer: &RayTracer, view: &ViewSamples, job: &ClusteredShading) -> Result<ClusteredImage> {
    let t0 = Instant::now();
    let visibility = visibility_matrix(tracer, view, job)?;
    let visibility_seconds = seconds(t0);
    let t1 = Instant::now();
    let image = shade(view, job, &visibility)?;
    Ok(ClusteredImage { image, visibility, rays: job.rays(), gave_up: 0, visibility_seconds, shading_seconds: seconds(t1) })
}
