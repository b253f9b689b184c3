//! Relighting on the CPU with a precomputed `Transfer` (Hašan, Pellacini, Bala, SIGGRAPH 2006, Sec. 3.2,
//! 3.3 Eq. 5 and 7, 3.5).
//!
//! For a light set (any `LightSet`: point, spot, directional, oriented points, VPLs):
//! 1. direct irradiance at every gather sample, E_g = sum_j L_j(p_g) max(0, n_g . w_j) V(p_g, j), exact
//!    shadow rays (`lights::animated::irradiance`, no extra clamp on oriented points, as the light matrix;
//!    with masked surfaces the transmittance through them and E_g times the sample's opacity: `masks`
//!    module docs);
//! 2. the gather samples' diffuse outgoing radiance B_g = k_d(g) / pi * E_g (RGB); with `bounces` b > 1,
//!    b - 1 passes of the gather-to-gather transfer add the light bounced among gather samples:
//!    B_{k+1}(h) = k_d(h) / pi * sum_j F_gg^w(h, j) (W B_k)_j, B = B_1 + ... + B_b (the paper's (M + I) g_d,
//!    Eq. 7, with M = K + K^2 + ... built from the one-bounce transfer K; `Multibounce::Gather`), or,
//!    with the photon-mapped M (`Multibounce::Photons`, the paper's 4.3), once:
//!    B = B_1 + k_d / pi * (M_E^w W B_1) (`multibounce::apply`, RGB rows);
//!    B is laid out as the gather image and projected into wavelets: b^w = W B (`haar::forward`, 3 channels);
//! 3. on-the-fly culling of wavelet lights (3.5): light j is skipped when |b^w_j| * ||F_d^w(:, j)|| <
//!    epsilon (`haar::cull_wavelet_lights`; epsilon = 0 keeps all);
//! 4. the sparse products s_i = sum_j F_d^w(i, j) b^w_j over the kept coefficients of each row and the kept
//!    lights (row by row in parallel; the same sum as the paper's image-based accumulation);
//! 4b. glossy pixels (`glossy`): the same sparse product with the glossy rows F_g^w (culled against
//!    their own image norms), times the pixel's glossy colour k_g(i), is added (Eq. 6, 8);
//! 5. indirect radiance L_ind(i) = k_d(i) / pi * s_i, k_d(i) the camera hit's diffuse albedo
//!    (`ViewSamples::albedo`, or a plastic's diffuse colour: `diffuse::albedo`; the transfer module derives
//!    the formula; in a scene with masks every view sample's, times its throughput, summed into its
//!    pixel: `masks`), plus the direct light of the same
//!    set: the light matrix's column sum on the CPU backend (all view samples of each pixel, delta chains
//!    included). Light seen directly (emitters' own radiance) is not added: `LightMatrix::emitted` has it.
//!
//! Output: H * W * 3 float32, row-major pixels, radiance (W/m^2/sr), like the light matrix's images.
//! `relight::gpu` computes the same on the GPU.
use super::haar;
use super::transfer::Transfer;
use crate::error::{Error, Result};
use crate::lights::animated::irradiance;
use crate::lights::LightSet;
use crate::matrix::LightMatrix;
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use crate::view::ViewSamples;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;
use std::time::Instant;

/// Seconds per stage of one relight and what culling kept.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RelightStats {
    /// Shadow maps of the lights (GPU only; 0 on the CPU, which casts exact rays).
    pub seconds_shadow_maps: f64,
    pub seconds_gather_direct: f64,
    /// The gather-to-gather bounce passes (0 work with one bounce).
    pub seconds_bounces: f64,
    pub seconds_wavelet: f64,
    pub seconds_transfer: f64,
    pub seconds_view_direct: f64,
    /// Copying the image back to the host (GPU only).
    pub seconds_readback: f64,
    /// Wavelet lights (non-zero coefficients of b^w) and how many on-the-fly culling removed.
    pub wavelet_lights: usize,
    pub wavelet_lights_culled: usize,
    /// Wavelet lights skipped by on-the-fly culling against the glossy F_g^w's image norms.
    pub wavelet_lights_culled_glossy: usize,
}

/// Checks a light set for relighting: not empty, finite values.
pub fn check_lights(lights: &LightSet) -> Result<()> {
    if lights.is_empty() {
        return Err(Error::invalid("the LightSet is empty: relighting needs at least one light"));
    }
    for j in 0..lights.len() {
        let v = [lights.intensity[j], lights.position[j], lights.direction[j]];
        if v.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid(format!(
                "light {j} has a non-finite intensity {}, position {} or direction {}",
                lights.intensity[j], lights.position[j], lights.direction[j]
            )));
        }
    }
    Ok(())
}

/// Direct irradiance E_g (W/m^2, RGB) at every gather sample of `t` from `lights` (step 1). With masked
/// surfaces, times the sample's opacity (`Transfer::opacity`: what its mask reflects), the shadow rays
/// crossing at most `masks::gather_mask_budget` of them (`masks` module docs).
pub fn gather_irradiance(t: &Transfer, tracer: &RayTracer, lights: &LightSet) -> Result<Vec<Vec3>> {
    let c = &t.cloud;
    let budget = super::masks::gather_mask_budget(t.opts.bounces);
    crate::interrupt::par_map_chunked(c.len(), 256, |g| {
        if c.normal[g] == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let e = irradiance(tracer, lights, c.position[g], c.normal[g], c.geo_normal[g], f32::INFINITY, budget);
        e * t.opacity.get(g).copied().unwrap_or(1.0)
    })
}

/// Outgoing diffuse radiance of the gather samples (n_g * 3, sample order): B = B_1 + ... + B_b with
/// B_1 = k_d / pi E (direct) and B_{k+1} = k_d / pi (F_gg^w W B_k) (module docs, step 2).
pub fn bounce(t: &Transfer, e: &[Vec3]) -> Result<Vec<f32>> {
    let n = t.cloud.len();
    let mut b: Vec<Vec3> = (0..n).map(|g| t.cloud.k_d[g] * FRAC_1_PI * e[g]).collect();
    let mut total = b.clone();
    if !t.photon_rows.is_empty() {
        // The photon-mapped M, applied once: B = B_1 + diag(k_d / pi) M_E^w W B_1 (`multibounce`).
        for (a, v) in total.iter_mut().zip(super::multibounce::apply(t, &b)?) {
            *a += v;
        }
    } else if !t.bounce_rows.is_empty() {
        for _ in 1..t.opts.bounces {
            let flat: Vec<f32> = b.iter().flat_map(|v| v.to_array()).collect();
            let mut bw = t.hierarchy.to_image(&flat, 3);
            haar::forward(&mut bw, t.hierarchy.side(), 3)?;
            b = crate::interrupt::par_map_chunked(n, 256, |h| {
                let row = &t.bounce_rows[h];
                let mut s = Vec3::ZERO;
                for (&j, &f) in row.index.iter().zip(&row.value) {
                    let j = j as usize;
                    s += f * Vec3::new(bw[3 * j], bw[3 * j + 1], bw[3 * j + 2]);
                }
                t.cloud.k_d[h] * t.opacity.get(h).copied().unwrap_or(1.0) * FRAC_1_PI * s
            })?;
            for (a, v) in total.iter_mut().zip(&b) {
                *a += *v;
            }
        }
    }
    Ok(total.into_iter().flat_map(|v| v.to_array()).collect())
}

/// Indirect radiance (H * W * 3) from gather irradiance `e` (steps 2-5 without direct): each row sample's
/// (the camera hits, or with masks every view sample: `masks::row_samples`) times its throughput,
/// summed per pixel.
pub fn indirect(t: &Transfer, view: &ViewSamples, e: &[Vec3], epsilon: f32, stats: &mut RelightStats) -> Result<Vec<f32>> {
    let n = t.cloud.len();
    if e.len() != n {
        return Err(Error::invalid(format!("{} irradiance values for {n} gather samples", e.len())));
    }
    let t0 = Instant::now();
    let b = bounce(t, e)?;
    stats.seconds_bounces = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut bw = t.hierarchy.to_image(&b, 3);
    haar::forward(&mut bw, t.hierarchy.side(), 3)?;
    let kept = haar::cull_wavelet_lights(&bw, 3, &t.image_norms, epsilon)?;
    let mut on = vec![false; n];
    for &j in &kept {
        on[j as usize] = true;
    }
    stats.wavelet_lights = (0..n).filter(|&j| bw[3 * j..3 * j + 3].iter().any(|&v| v != 0.0)).count();
    stats.wavelet_lights_culled = (0..n).filter(|&j| !on[j] && bw[3 * j..3 * j + 3].iter().any(|&v| v != 0.0)).count();
    stats.seconds_wavelet = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let pixels = view.num_pixels();
    let samples = t.rows.len();
    if samples < pixels || samples > view.len() {
        return Err(Error::invalid(format!("{samples} transfer rows for a view of {pixels} pixels and {} samples", view.len())));
    }
    let out = crate::interrupt::par_map_chunked(samples, 256, |i| {
        let row = &t.rows[i];
        let mut s = [0f32; 3];
        for (&j, &f) in row.index.iter().zip(&row.value) {
            let j = j as usize;
            if on[j] {
                for (a, v) in s.iter_mut().zip(&bw[3 * j..3 * j + 3]) {
                    *a += f * v;
                }
            }
        }
        (super::diffuse::albedo(view, i) * FRAC_1_PI * Vec3::from_array(s)).to_array()
    })?;
    let mut out = out;
    // The glossy final gather (Eq. 6, 8): k_g F_g^w b^w added to the glossy pixels.
    stats.wavelet_lights_culled_glossy =
        super::glossy::add_glossy(&t.glossy_rows, &t.glossy_color, &t.glossy_image_norms, &bw, epsilon, &mut out)?;
    if samples > pixels {
        // Every view sample has a row (masks): each one's radiance times its throughput, into its pixel.
        for (i, o) in out.iter_mut().enumerate().take(pixels) {
            *o = (view.throughput_of(i) * Vec3::from_array(*o)).to_array();
        }
        for i in pixels..samples {
            let p = view.pixel_of(i);
            let v = view.throughput_of(i) * Vec3::from_array(out[i]);
            out[p] = (Vec3::from_array(out[p]) + v).to_array();
        }
        out.truncate(pixels);
    }
    stats.seconds_transfer = t1.elapsed().as_secs_f64();
    Ok(out.into_iter().flatten().collect())
}

/// The relit image (H * W * 3): indirect plus direct light of `lights` (module docs).
///
/// Errors: `InvalidParameter` for an empty light set, non-finite light values, a negative or non-finite
/// epsilon, a view of another size than the transfer's; `Interrupted`.
pub fn relight(
    t: &Transfer,
    scene: Arc<Scene>,
    view: Arc<ViewSamples>,
    tracer: Arc<RayTracer>,
    lights: Arc<LightSet>,
    epsilon: f32,
) -> Result<(Vec<f32>, RelightStats)> {
    check_lights(&lights)?;
    if !(epsilon >= 0.0 && epsilon.is_finite()) {
        return Err(Error::invalid(format!("epsilon must be finite and >= 0, got {epsilon}")));
    }
    if (view.width, view.height) != (t.width, t.height) || super::masks::row_samples(&view, tracer.masks().any()) != t.rows.len() {
        return Err(Error::invalid(format!(
            "the view is {}x{} but the transfer was precomputed for {}x{}",
            view.width, view.height, t.width, t.height
        )));
    }
    let mut stats = RelightStats::default();
    let t0 = Instant::now();
    let e = gather_irradiance(t, &tracer, &lights)?;
    stats.seconds_gather_direct = t0.elapsed().as_secs_f64();
    let mut img = indirect(t, &view, &e, epsilon, &mut stats)?;
    let t1 = Instant::now();
    let m = LightMatrix::new_cpu(tracer, scene, view, lights)?;
    let direct = m.column_sum(None, &mut |_, _| {})?;
    for (a, d) in img.iter_mut().zip(&direct) {
        *a += d;
    }
    stats.seconds_view_direct = t1.elapsed().as_secs_f64();
    Ok((img, stats))
}

#[cfg(test)]
mod tests;
