//! The exact shadow rays of a batch of light-matrix elements, as `shade` casts them, and the ray tracer
//! alone on them: what `python -m manylights.bench backends --peer mitsuba` hands to Mitsuba's
//! `Scene::ray_test` so that both tracers answer the same visibility queries, and times side by side.
//!
//! For element (i, j) with a non-zero unshadowed value (`shade_unshadowed`), the ray is the one
//! `light_blocked` traces (`light_ray`): toward a light at a finite distance `spawn_ray_to(p, n_g, q)` (origin offset
//! along n_g, unit direction, `t_max = |q - o| (1 - SHADOW_EPSILON)`), toward a directional light
//! `(spawn_ray(p, n_g, wo), wo, inf)`. Elements whose unshadowed value is 0 cast no ray and are left out.
//! A batch names pixels; a pixel's elements are those of each of its view samples (its camera hit, then
//! its delta-chain samples, `ViewSamples::samples_of_pixel`), as its row and its columns sum them.
//!
//! Symbols: i a view sample, j a light, p / n_g the sample's position and geometric normal, q the light's
//! position, wo the direction to the light, o / d / t_max the ray.
use super::{shade_unshadowed, ShadingPoint};
use crate::error::{Error, Result};
use crate::lights::LightSet;
use crate::raytrace::{RayTracer, PACKET};
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// The order of a batch's elements: light by light (columns, the lights in the order given), or view sample
/// by view sample (rows, each view sample's lights in the order `CpuBackend::rows` traces them:
/// `spatial_order`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    Columns,
    Rows,
}

/// Shadow rays of a batch (struct of arrays) with the element each belongs to.
#[derive(Debug, Default)]
pub struct ShadowRays {
    pub origin: Vec<Vec3>,
    pub direction: Vec<Vec3>,
    pub t_max: Vec<f32>,
    /// The view sample of each ray (a pixel's own sample has the pixel's index; delta-chain samples come
    /// after the W x H pixels) and the pixel it belongs to.
    pub view: Vec<u32>,
    pub pixel: Vec<u32>,
    pub light: Vec<u32>,
    /// Elements of the batch, with and without a ray: the pixels' view samples x the lights.
    pub elements: u64,
    /// Seconds to set the rays up (unshadowed shading included: it decides which elements cast one).
    pub seconds: f64,
}

/// The shadow ray of element (i, j) (view sample i prepared as `sp`), None where it casts none (module
/// docs), or with `every` where its view sample has no surface (a background sample) or lies at the
/// light's point.
fn ray(view: &ViewSamples, lights: &LightSet, sp: &ShadingPoint, i: usize, j: usize, every: bool) -> Option<(Vec3, Vec3, f32)> {
    let (wo, dist) = if every {
        let (wo, _, dist) = lights.toward(j, sp.p).filter(|_| sp.surface)?;
        (wo, dist)
    } else {
        let (_, wo, dist) = shade_unshadowed(view, lights, sp, i, j)?;
        (wo, dist)
    };
    Some(super::light_ray(lights, j, sp.p, sp.n_g, wo, dist))
}

/// The shadow rays of the elements of pixels `views` x lights `lights_idx`, in `order`, each pixel's view
/// samples in turn (module docs): those `shade` casts,
/// or with `every` one for every element of a surface view sample, lit or not, toward the same point of
/// the light (the rays a renderer that shaded nothing first would trace; those `shade` casts among them,
/// unchanged).
///
/// Errors: an index out of range (view sample or light), more than 2^31 elements.
pub fn shadow_rays(
    view: &ViewSamples,
    lights: &LightSet,
    views: &[usize],
    lights_idx: &[usize],
    order: Order,
    every: bool,
) -> Result<ShadowRays> {
    let (m, n) = (view.num_pixels(), lights.len());
    if let Some(&i) = views.iter().find(|&&i| i >= m) {
        return Err(Error::invalid(format!("pixel index {i} out of range (m = {m} pixels)")));
    }
    if let Some(&j) = lights_idx.iter().find(|&&j| j >= n) {
        return Err(Error::invalid(format!("light index {j} out of range (n = {n})")));
    }
    if views.len() as u64 * lights_idx.len() as u64 > 1 << 31 {
        return Err(Error::invalid(format!("{} elements in one batch: at most 2^31", views.len() as u64 * lights_idx.len() as u64)));
    }
    // (view sample, pixel) of every pixel's samples, in pixel order.
    let samples: Vec<(usize, usize)> = views.iter().flat_map(|&p| view.samples_of_pixel(p).map(move |i| (i, p))).collect();
    let elements = samples.len() as u64 * lights_idx.len() as u64;
    if elements > 1 << 31 {
        return Err(Error::invalid(format!("{elements} elements in one batch: at most 2^31")));
    }
    let t = Instant::now();
    // Each sample prepared once, not once per light.
    let points: Vec<ShadingPoint> = samples.par_iter().map(|&(i, _)| ShadingPoint::new(view, i)).collect();
    let element = |k: usize, j: usize| {
        let (i, p) = samples[k];
        ray(view, lights, &points[k], i, j, every).map(|(o, d, tm)| (i as u32, p as u32, j as u32, o, d, tm))
    };
    let found: Vec<Vec<(u32, u32, u32, Vec3, Vec3, f32)>> = match order {
        Order::Columns => lights_idx.par_iter().map(|&j| (0..samples.len()).filter_map(|k| element(k, j)).collect()).collect(),
        Order::Rows => {
            // A row's lights in the order `CpuBackend::rows` traces them (`spatial_order`).
            let mut rank = vec![0u32; n];
            for (r, &j) in super::spatial_order(lights).iter().enumerate() {
                rank[j as usize] = r as u32;
            }
            let mut row_lights = lights_idx.to_vec();
            row_lights.sort_by_key(|&j| rank[j]);
            (0..samples.len()).into_par_iter().map(|k| row_lights.iter().filter_map(|&j| element(k, j)).collect()).collect()
        }
    };
    let mut out = ShadowRays { elements, ..Default::default() };
    for (i, p, j, o, d, tm) in found.into_iter().flatten() {
        out.view.push(i);
        out.pixel.push(p);
        out.light.push(j);
        out.origin.push(o);
        out.direction.push(d);
        out.t_max.push(tm);
    }
    out.seconds = t.elapsed().as_secs_f64();
    Ok(out)
}

/// Whether each ray `(o, d, t_max)` is blocked, traced by `tracer` in parallel in packets of consecutive
/// rays (`RayTracer::occluded_packet`: the backend's traversal and triangle tests alone), with the seconds
/// the tracing took.
///
/// Errors: arrays of different lengths.
pub fn trace(tracer: &RayTracer, origin: &[Vec3], direction: &[Vec3], t_max: &[f32]) -> Result<(Vec<bool>, f64)> {
    if origin.len() != direction.len() || origin.len() != t_max.len() {
        return Err(Error::invalid(format!(
            "origin, direction and t_max must have one entry per ray, got {}, {} and {}",
            origin.len(),
            direction.len(),
            t_max.len()
        )));
    }
    let t = Instant::now();
    let mut blocked = vec![false; origin.len()];
    blocked.par_chunks_mut(PACKET).enumerate().with_min_len(16).for_each(|(c, out)| {
        let a = c * PACKET;
        let b = a + out.len();
        tracer.occluded_packet(&origin[a..b], &direction[a..b], &t_max[a..b], out);
    });
    Ok((blocked, t.elapsed().as_secs_f64()))
}

#[cfg(test)]
mod tests;
