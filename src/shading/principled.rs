//! Mitsuba 3.9.1's `principled` BSDF (Disney principled, Burley 2012/2015; `src/bsdfs/principled.cpp`,
//! `src/bsdfs/principledhelpers.h`), evaluated exactly as its `eval` does in RGB variants: the Rust
//! reference, twin of `shaders/common/principled.wgsl` (`bsdf_principled_eval`).
//!
//! Lobes (wi toward the viewer, wo toward the light, local frame): main GGX specular reflection with the
//! principled Fresnel (dielectric Fresnel blended with Schlick metallic and spec-tint terms), GGX
//! specular transmission weighted by `(1 - metallic) spec_trans` and `sqrt(base_color)` (radiance mode:
//! times `1 / eta_path^2`), the GTR1 clearcoat (`alpha = lerp(0.1, 0.001, clearcoat_gloss)`, Schlick
//! Fresnel with R0 = 0.04, separable Smith GGX with alpha 0.25), the Burley diffuse with retro-reflection
//! (and the Hanrahan-Krueger fake subsurface blended by `flatness`), and sheen. Back side (wi.z < 0):
//! only specular reflection (`bsdf * F_dielectric`) and transmission.
//!
//! `GpuBsdf` field use for `KIND_PRINCIPLED` (parameters evaluated at the surface uv, scalar textures as
//! Mitsuba's `eval_1`):
//! | field | value |
//! |---|---|
//! | diffuse | base_color |
//! | specular | (metallic, spec_tint, spec_trans) |
//! | eta | (eta, sheen, sheen_tint) |
//! | k | (clearcoat, clearcoat_gloss, flatness) |
//! | alpha_u, alpha_v | `calc_dist_params(anisotropic, roughness)` (>= 0.001) |
//! | extra | (roughness, 0, 0, 0) |
//! Mitsuba's `has_*` flags only gate lobes whose weight is then 0, so the values alone decide (checked
//! against `bsdf.eval` with and without each parameter given). `eta` comes from `eta`, else from
//! `specular` (`2 / (1 - sqrt(0.08 specular)) - 1`), with Mitsuba's fix-ups when `spec_trans` is given
//! (eta 1 -> 1.001, specular 0 -> 1e-3), see `principled_eta`.
//!
//! Sampling for particle tracing (`sample`) is not Mitsuba's: Mitsuba chooses lobes with a Fresnel
//! computed at the sampled microfacet, so its `pdf` is not the exact density of its samples. Here a
//! fixed mixture (per wi) of the cosine hemisphere, GGX reflection, GGX transmission and GTR1 clearcoat
//! proposals is used, each sample weighted by `eval / mixture pdf` (one-sample MIS), which is unbiased.
use super::bsdf::{fresnel, microfacet_d, smith_g1, FLAG_TWOSIDED};
use super::GpuBsdf;
use crate::scene::texture::luminance;
use glam::Vec3;
use std::f32::consts::PI;

const INV_PI: f32 = std::f32::consts::FRAC_1_PI;

/// Mitsuba's relative IOR of a principled BSDF: `eta` if given, else from `specular` (default 0.5);
/// `has_spec_trans`: the file gives `spec_trans` (and not as the float 0).
pub fn principled_eta(eta: Option<f32>, specular: Option<f32>, has_spec_trans: bool) -> f32 {
    match eta {
        Some(e) => {
            if has_spec_trans && e == 1.0 {
                1.001
            } else {
                e
            }
        }
        None => {
            let mut s = specular.unwrap_or(0.5);
            if has_spec_trans && s == 0.0 {
                s = 1e-3;
            }
            2.0 * (1.0 / (1.0 - (0.08 * s).sqrt())) - 1.0
        }
    }
}

/// Mitsuba's `calc_dist_params`: GGX (alpha_u, alpha_v) from anisotropic and roughness.
pub fn dist_params(anisotropic: f32, roughness: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    if anisotropic == 0.0 {
        let a = r2.max(0.001);
        return (a, a);
    }
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// drjit's `lerp(a, b, t)` = fmadd(b, t, fnmadd(a, t, a)).
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    b.mul_add(t, (-a).mul_add(t, a))
}

fn lerp3(a: Vec3, b: Vec3, t: Vec3) -> Vec3 {
    Vec3::new(lerp(a.x, b.x, t.x), lerp(a.y, b.y, t.y), lerp(a.z, b.z, t.z))
}

/// x with the sign bit of y applied (drjit `mulsign`).
fn mulsign(x: Vec3, y: f32) -> Vec3 {
    if y.is_sign_negative() {
        -x
    } else {
        x
    }
}

fn schlick_weight(cos_i: f32) -> f32 {
    let m = (1.0 - cos_i).clamp(0.0, 1.0);
    (m * m) * (m * m) * m
}

/// `calc_schlick` for an RGB R0 (a scalar R0 is splat).
fn calc_schlick(r0: Vec3, cos_theta_i: f32, eta: f32) -> Vec3 {
    let outside = cos_theta_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if outside { (eta, rcp_eta) } else { (rcp_eta, eta) };
    let cos_theta_t_sqr = (-(-cos_theta_i).mul_add(cos_theta_i, 1.0)).mul_add(eta_ti * eta_ti, 1.0);
    let cos_theta_t = cos_theta_t_sqr.max(0.0).sqrt();
    let w = if eta_it > 1.0 { schlick_weight(cos_theta_i.abs()) } else { schlick_weight(cos_theta_t) };
    lerp3(Vec3::splat(w), Vec3::ONE, r0)
}

fn schlick_r0_eta(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// GTR1 `eval`.
fn gtr1_d(alpha: f32, m: Vec3) -> f32 {
    let cos_theta = m.z;
    let alpha2 = alpha * alpha;
    let result = (alpha2 - 1.0) / (PI * alpha2.ln() * (1.0 + (alpha2 - 1.0) * cos_theta * cos_theta));
    if result * cos_theta > 1e-20 {
        result
    } else {
        0.0
    }
}

fn smith_ggx1(v: Vec3, wh: Vec3, alpha: f32) -> f32 {
    let alpha_2 = alpha * alpha;
    let cos_theta = v.z.abs();
    let cos_theta_2 = cos_theta * cos_theta;
    let tan_theta_2 = (1.0 - cos_theta_2) / cos_theta_2;
    let mut result = 2.0 / (1.0 + (1.0 + alpha_2 * tan_theta_2).sqrt());
    if v.z == 1.0 {
        result = 1.0;
    }
    if v.dot(wh) * v.z <= 0.0 {
        result = 0.0;
    }
    result
}

fn clearcoat_alpha(gloss: f32) -> f32 {
    lerp(0.1, 0.001, gloss)
}

/// Parameters unpacked from the GPU record.
struct Params {
    base: Vec3,
    metallic: f32,
    spec_tint: f32,
    spec_trans: f32,
    eta: f32,
    sheen: f32,
    sheen_tint: f32,
    clearcoat: f32,
    clearcoat_gloss: f32,
    flatness: f32,
    roughness: f32,
}

fn params(b: &GpuBsdf) -> Params {
    Params {
        base: Vec3::from_array(b.diffuse),
        metallic: b.specular[0],
        spec_tint: b.specular[1],
        spec_trans: b.specular[2],
        eta: b.eta[0],
        sheen: b.eta[1],
        sheen_tint: b.eta[2],
        clearcoat: b.k[0],
        clearcoat_gloss: b.k[1],
        flatness: b.k[2],
        roughness: b.extra[0],
    }
}

/// Mitsuba's `eval` in radiance mode (what a camera path sees): f(wi, wo) |cos theta_o|.
pub fn eval(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> Vec3 {
    eval_mode(b, wi, wo, true)
}

/// `eval` in radiance (`radiance = true`) or importance transport mode (particles: the transmission
/// lobe without the 1 / eta_path^2 factor). A `twosided` wrapper mirrors both directions when wi is
/// below the surface, as Mitsuba's `twosided` does.
pub fn eval_mode(b: &GpuBsdf, wi: Vec3, wo: Vec3, radiance: bool) -> Vec3 {
    let (mut wi, mut wo) = (wi, wo);
    if b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    let p = params(b);
    let cos_theta_i = wi.z;
    if cos_theta_i == 0.0 {
        return Vec3::ZERO;
    }
    let brdf = (1.0 - p.metallic) * (1.0 - p.spec_trans);
    let bsdf = (1.0 - p.metallic) * p.spec_trans;
    let cos_theta_o = wo.z;
    let reflect = cos_theta_i * cos_theta_o > 0.0;
    let refract = cos_theta_i * cos_theta_o < 0.0;
    let front_side = cos_theta_i > 0.0;
    let inv_eta = 1.0 / p.eta;
    let eta_path = if front_side { p.eta } else { inv_eta };
    let inv_eta_path = if front_side { inv_eta } else { p.eta };
    let (ax, ay) = (b.alpha_u, b.alpha_v);
    let wh = (wi + wo * if reflect { 1.0 } else { eta_path }).normalize();
    let wh = mulsign(wh, wh.z);
    let wi_h = wi.dot(wh);
    let f_dielectric = fresnel(wi_h, p.eta);
    let m = mulsign(wh, cos_theta_i);
    let reflection_compatible = wi.dot(m) > 0.0 && wo.dot(m) > 0.0;
    let refraction_compatible = wi.dot(m) > 0.0 && wo.dot(-m) > 0.0;
    let spec_reflect_active = reflect && reflection_compatible && f_dielectric > 0.0;
    let clearcoat_active = p.clearcoat > 0.0 && reflect && reflection_compatible && front_side;
    let spec_trans_active = bsdf > 0.0 && refract && refraction_compatible && f_dielectric < 1.0;
    let diffuse_active = brdf > 0.0 && reflect && front_side;
    let sheen_active = p.sheen > 0.0 && reflect && 1.0 - p.metallic > 0.0 && front_side;
    let d = microfacet_d(true, ax, ay, wh);
    let g = smith_g1(true, ax, ay, wi, wh) * smith_g1(true, ax, ay, wo, wh);
    let mut value = Vec3::ZERO;
    if spec_reflect_active {
        let lum = luminance(p.base);
        let f = principled_fresnel(f_dielectric, &p, lum, wi_h, front_side, bsdf);
        value += f * (d * g / (4.0 * cos_theta_i.abs()));
    }
    if spec_trans_active {
        let scale = if radiance { inv_eta_path * inv_eta_path } else { 1.0 };
        let wo_h = wo.dot(wh);
        let denom = wi_h + eta_path * wo_h;
        let t = (scale * (1.0 - f_dielectric) * d * g * eta_path * eta_path * wi_h * wo_h) / (cos_theta_i * (denom * denom));
        value += Vec3::new(p.base.x.sqrt(), p.base.y.sqrt(), p.base.z.sqrt()) * bsdf * t.abs();
    }
    if clearcoat_active {
        let fcc = calc_schlick(Vec3::splat(0.04), wi_h, p.eta).x;
        let dcc = gtr1_d(clearcoat_alpha(p.clearcoat_gloss), wh);
        let gcc = smith_ggx1(wi, wh, 0.25) * smith_ggx1(wo, wh, 0.25);
        value += Vec3::splat((p.clearcoat * 0.25) * fcc * dcc * gcc * cos_theta_o.abs());
    }
    if diffuse_active {
        let fo = schlick_weight(cos_theta_o.abs());
        let fi = schlick_weight(cos_theta_i.abs());
        let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
        let cos_theta_d = wh.dot(wo);
        let rr = 2.0 * p.roughness * (cos_theta_d * cos_theta_d);
        let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
        let fss90 = rr / 2.0;
        let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
        let f_ss = 1.25 * (fss * (1.0 / (cos_theta_o.abs() + cos_theta_i.abs()) - 0.5) + 0.5);
        let lobe = if p.flatness != 0.0 { lerp(f_diff + f_retro, f_ss, p.flatness) } else { f_diff + f_retro };
        value += brdf * cos_theta_o.abs() * p.base * INV_PI * lobe;
        if sheen_active {
            let fd = schlick_weight(cos_theta_d.abs());
            let lum = luminance(p.base);
            let c_tint = if lum > 0.0 { p.base / lum } else { Vec3::ONE };
            let c_sheen = lerp3(Vec3::ONE, c_tint, Vec3::splat(p.sheen_tint));
            value += p.sheen * (1.0 - p.metallic) * fd * c_sheen * cos_theta_o.abs();
        }
    }
    value
}

/// `principled_fresnel` (has_metallic / has_spec_tint implied by non-zero values).
fn principled_fresnel(f_dielectric: f32, p: &Params, lum: f32, cos_theta_i: f32, front_side: bool, bsdf: f32) -> Vec3 {
    if !front_side {
        return Vec3::splat(bsdf * f_dielectric);
    }
    let eta_it = if cos_theta_i >= 0.0 { p.eta } else { 1.0 / p.eta };
    let mut f_schlick = Vec3::ZERO;
    if p.metallic != 0.0 {
        f_schlick += p.metallic * calc_schlick(p.base, cos_theta_i, p.eta);
    }
    if p.spec_tint != 0.0 {
        let c_tint = if lum > 0.0 { p.base / lum } else { Vec3::ONE };
        let f0 = c_tint * schlick_r0_eta(eta_it);
        f_schlick += (1.0 - p.metallic) * p.spec_tint * calc_schlick(f0, cos_theta_i, p.eta);
    }
    Vec3::splat((1.0 - p.metallic) * (1.0 - p.spec_tint) * f_dielectric) + f_schlick
}

/// True when the BSDF reflects and transmits from its back side too (spec_trans > 0, not fully
/// metallic): a particle arriving from below continues, and a VPL may sit there.
pub fn has_back_side(b: &GpuBsdf) -> bool {
    (1.0 - b.specular[0]) * b.specular[2] > 0.0
}

/// Mixture probabilities (diffuse, specular reflection, transmission, clearcoat) for local wi with
/// wi.z != 0 (after the twosided mirror): fixed per wi, so the mixture pdf is exact.
fn lobe_probabilities(p: &Params, cos_theta_i: f32) -> [f32; 4] {
    let brdf = (1.0 - p.metallic) * (1.0 - p.spec_trans);
    let bsdf = (1.0 - p.metallic) * p.spec_trans;
    let f = fresnel(cos_theta_i, p.eta);
    let probs = if cos_theta_i > 0.0 {
        [brdf, 1.0 - bsdf * (1.0 - f), bsdf * (1.0 - f), 0.25 * p.clearcoat]
    } else {
        [0.0, f, if bsdf > 0.0 { 1.0 - f } else { 0.0 }, 0.0]
    };
    let total: f32 = probs.iter().sum();
    if total > 0.0 {
        probs.map(|x| x / total)
    } else {
        [0.0, 1.0, 0.0, 0.0]
    }
}

/// GGX normal with density D(m) cos(theta_m) for an isotropic alpha.
fn sample_ggx(alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let tan2 = alpha * alpha * u1 / (1.0 - u1).max(1e-12);
    let cos = 1.0 / (1.0 + tan2).sqrt();
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// GTR1 normal with density D(m) cos(theta_m) (Mitsuba's `GTR1Isotropic::sample`).
fn sample_gtr1(alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let (sin_phi, cos_phi) = (2.0 * PI * u1).sin_cos();
    let alpha2 = alpha * alpha;
    let cos_theta2 = (1.0 - alpha2.powf(1.0 - u2)) / (1.0 - alpha2);
    let sin_theta = (1.0 - cos_theta2).max(0.0).sqrt();
    Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta2.max(0.0).sqrt())
}

/// Density of `sample`'s proposal for local wo, in the mirrored frame where wi.z > 0 (`eta_p`: relative
/// IOR of the far side, `alpha`: the isotropic GGX proposal alpha).
fn mixture_pdf(p: &Params, probs: &[f32; 4], wi: Vec3, wo: Vec3, eta_p: f32, alpha: f32) -> f32 {
    if wo.z > 0.0 {
        let h = (wi + wo).normalize();
        if !(wi.dot(h) > 0.0) {
            return 0.0;
        }
        let jac = 1.0 / (4.0 * wo.dot(h).abs());
        let spec = microfacet_d(true, alpha, alpha, h) * h.z * jac;
        let cc = if probs[3] > 0.0 { gtr1_d(clearcoat_alpha(p.clearcoat_gloss), h) * h.z * jac } else { 0.0 };
        probs[0] * wo.z * INV_PI + probs[1] * spec + probs[3] * cc
    } else if wo.z < 0.0 && probs[2] > 0.0 {
        let mut h = (wi + wo * eta_p).normalize();
        if h.z < 0.0 {
            h = -h;
        }
        let (wi_h, wo_h) = (wi.dot(h), wo.dot(h));
        if !(wi_h > 0.0 && wo_h < 0.0) {
            return 0.0;
        }
        let denom = wi_h + eta_p * wo_h;
        probs[2] * microfacet_d(true, alpha, alpha, h) * h.z * (eta_p * eta_p * wo_h.abs() / (denom * denom))
    } else {
        0.0
    }
}

/// Samples wo for a particle arriving from local `wi` (toward where it came from) with uniforms u0 (lobe
/// choice), u1, u2: (wo, eval_importance(wi, wo) / pdf(wo)), or None when the particle is absorbed.
pub fn sample(b: &GpuBsdf, wi_in: Vec3, u0: f32, u1: f32, u2: f32) -> Option<(Vec3, Vec3)> {
    let p = params(b);
    let mut wi = wi_in;
    if b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0 {
        wi.z = -wi.z;
    }
    if wi.z == 0.0 {
        return None;
    }
    let probs = lobe_probabilities(&p, wi.z);
    // Mirrored frame: wi above.
    let side = if wi.z > 0.0 { 1.0 } else { -1.0 };
    let mirror = |v: Vec3| Vec3::new(v.x, v.y, v.z * side);
    let wi_m = mirror(wi);
    let eta_p = if wi.z > 0.0 { p.eta } else { 1.0 / p.eta };
    let alpha = (b.alpha_u * b.alpha_v).sqrt();
    let (c0, c1, c2) = (probs[0], probs[0] + probs[1], probs[0] + probs[1] + probs[2]);
    let wo_m = if u0 < c0 {
        crate::lights::generate::sampling::cosine_hemisphere(u1, u2)
    } else if u0 < c1 || u0 >= c2 {
        let h = if u0 < c1 { sample_ggx(alpha, u1, u2) } else { sample_gtr1(clearcoat_alpha(p.clearcoat_gloss), u1, u2) };
        let c = wi_m.dot(h);
        let wo = 2.0 * c * h - wi_m;
        // Each proposal keeps to its hemisphere, where `mixture_pdf` counts it.
        if !(c > 0.0 && wo.z > 0.0) {
            return None;
        }
        wo
    } else {
        let h = sample_ggx(alpha, u1, u2);
        let c = wi_m.dot(h);
        let cos_t2 = 1.0 - (1.0 - c * c) / (eta_p * eta_p);
        if !(c > 0.0 && cos_t2 > 0.0) {
            return None;
        }
        let wo = (h * (c / eta_p - cos_t2.sqrt()) - wi_m / eta_p).normalize();
        if !(wo.z < 0.0) {
            return None;
        }
        wo
    };
    let pdf = mixture_pdf(&p, &probs, wi_m, wo_m, eta_p, alpha);
    if !(pdf > 0.0) || wo_m.z == 0.0 {
        return None;
    }
    let mut wo = mirror(wo_m);
    let mut wi_eval = wi;
    if wi_in.z < 0.0 && b.flags & FLAG_TWOSIDED != 0 {
        wo.z = -wo.z;
        wi_eval = wi_in;
    }
    let weight = eval_mode(b, wi_eval, wo, false) / pdf;
    if !(weight.is_finite() && weight.max_element() > 0.0) {
        return None;
    }
    Some((wo, weight))
}

#[cfg(test)]
mod tests;
