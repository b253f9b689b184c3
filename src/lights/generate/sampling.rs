//! Sampling helpers of light generation: seeded streams, equal-area strata of the sphere, warps
//! (cosine hemisphere, cone, triangle) and BSDF sampling for particle tracing.
//!
//! BSDF sampling (`sample_bsdf`) returns `eval(wi, wo) / pdf(wo)` for the lobes `shading::bsdf::eval`
//! evaluates, with pdfs that are exact densities of what is drawn (so the weights are unbiased):
//! - diffuse: cosine hemisphere (weight = reflectance).
//! - roughplastic / roughconductor: a mixture of sampling D(h) cos(theta_h) (isotropic alpha =
//!   sqrt(alpha_u alpha_v), the reflected direction; pdf D cos_h / (4 |wo . h|)) and the cosine
//!   hemisphere; the mixture pdf is used for every sample (one-sample MIS), so anisotropic alphas stay
//!   unbiased even though the proposal is isotropic.
//! - plastic (smooth): the delta reflection with probability F s / (F s + (1 - F) d) (s, d: mean specular
//!   and diffuse reflectance), weight F specular / prob; else the diffuse lobe, cosine sampled.
//! - smooth conductor: delta reflection, weight = Fresnel(eta + i k) * specular_reflectance.
//! - smooth dielectric: reflect with probability F, else refract; weight 1 (importance transport: no
//!   1/eta^2 radiance scaling for particles).
//! - roughdielectric (both sides): a microfacet normal h with density D(h) cos(theta_h) (isotropic alpha
//!   = sqrt(alpha_u alpha_v), upper hemisphere; wi . h must have the sign of wi.z), then reflection about h with probability
//!   F(wi . h), else refraction through h; pdf D cos_h F / (4 |wo . h|) or D cos_h (1 - F) eta^2 |wo . h|
//!   / (wi . h + eta wo . h)^2, weight = importance-mode eval / pdf (`bsdf::roughdielectric_eval`).
//! - thindielectric: reflect with probability R' = 2R / (1 + R), weight specular_reflectance, else pass
//!   straight through, weight specular_transmittance (Mitsuba's `sample` with both lobes).
//! - bumpmap / normalmap records: `shading::perturb::sample` (the nested BSDF in the perturbed frame).
//! - principled: `shading::principled::sample` (a mixture with an exact pdf; reflection from both
//!   sides and glossy transmission, importance-mode weights).
use crate::shading::bsdf::{
    eval, fresnel, fresnel_conductor, microfacet_d, FLAG_BUMP, FLAG_GGX, FLAG_TWOSIDED, FLAG_TWOSIDED_OUTER, KIND_DIFFUSE, KIND_PLASTIC,
    KIND_PRINCIPLED, KIND_ROUGHCONDUCTOR, KIND_ROUGHDIELECTRIC, KIND_ROUGHPLASTIC, KIND_SMOOTH,
};
use crate::shading::GpuBsdf;
use glam::{Vec2, Vec3};
use rand::RngExt;
use rand_pcg::Pcg32;
use std::f32::consts::PI;

/// Stream families (so area, environment, particles and the particle pilot never share numbers).
pub const STREAM_AREA: u64 = 1;
pub const STREAM_ENV: u64 = 2;
pub const STREAM_PILOT: u64 = 3;
pub const STREAM_PARTICLE: u64 = 4;
/// BSDF samples of glossy view samples (`matrix::glossy`).
pub const STREAM_GLOSSY: u64 = 5;
/// Pilot candidates and acceptance decisions of VPL importance sampling (`vpl_importance`).
pub const STREAM_IMPORTANCE_PILOT: u64 = 8;
pub const STREAM_ACCEPT: u64 = 9;
/// Pilot directions of visibility-allocated environment strata (`env_visibility`), per coarse cell.
pub const STREAM_ENV_PILOT: u64 = 11;

/// SplitMix64 finaliser: decorrelates seeds.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// The random stream `index` of family `family` for `seed`.
pub fn stream(seed: u64, family: u64, index: u64) -> Pcg32 {
    let state = mix(seed ^ mix(family.wrapping_mul(0x9e3779b97f4a7c15)));
    Pcg32::new(state, mix(index ^ (family << 56)))
}

/// A uniform f32 in [0, 1).
pub fn uniform(rng: &mut Pcg32) -> f32 {
    rng.random::<f32>()
}

/// Cells per row of an equal-area partition of the sphere into n cells (rows of the cylindrical
/// equal-area map z = cos(theta), phi): about sqrt(n / 2) rows; row r has `rows[r]` cells of equal
/// solid angle 4 pi / n, spanning z in [z_r - 2 rows[r] / n, z_r] from z = 1 down.
pub fn equal_area_rows(n: usize) -> Vec<usize> {
    if n == 0 {
        return Vec::new();
    }
    let num_rows = ((n as f64 / 2.0).sqrt().round() as usize).clamp(1, n);
    (0..num_rows).map(|r| n / num_rows + usize::from(r < n % num_rows)).collect()
}

/// One cell of `equal_area_rows`: z in [z_lo, z_hi], phi in [phi_lo, phi_hi].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub z_lo: f32,
    pub z_hi: f32,
    pub phi_lo: f32,
    pub phi_hi: f32,
}

/// All cells of the equal-area partition into n cells, row by row from z = 1.
pub fn equal_area_cells(n: usize) -> Vec<Cell> {
    let rows = equal_area_rows(n);
    let mut cells = Vec::with_capacity(n);
    let mut above = 0usize;
    for &k in &rows {
        let z_hi = 1.0 - 2.0 * (above as f64 / n as f64);
        let z_lo = 1.0 - 2.0 * ((above + k) as f64 / n as f64);
        for c in 0..k {
            cells.push(Cell {
                z_lo: z_lo as f32,
                z_hi: z_hi as f32,
                phi_lo: (2.0 * std::f64::consts::PI * c as f64 / k as f64) as f32,
                phi_hi: (2.0 * std::f64::consts::PI * (c + 1) as f64 / k as f64) as f32,
            });
        }
        above += k;
    }
    cells
}

/// Direction of (z, phi) about the polar axis `Y` (x = r sin phi, z-axis = r cos phi).
pub fn sphere_dir(z: f32, phi: f32) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.sin(), z, r * phi.cos())
}

impl Cell {
    /// A point of the cell for (u1, u2) in [0,1)^2, uniform in solid angle.
    pub fn sample(&self, u1: f32, u2: f32) -> Vec3 {
        sphere_dir(self.z_hi + (self.z_lo - self.z_hi) * u1, self.phi_lo + (self.phi_hi - self.phi_lo) * u2)
    }
    pub fn solid_angle(&self) -> f32 {
        (self.z_hi - self.z_lo) * (self.phi_hi - self.phi_lo)
    }
}

/// Uniform direction on the sphere.
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    sphere_dir(1.0 - 2.0 * u1, 2.0 * PI * u2)
}

/// Cosine-weighted direction about +z (local), pdf z / pi.
pub fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

/// Uniform direction in the cone of half-angle acos(cos_max) about +z, pdf 1 / (2 pi (1 - cos_max)).
pub fn uniform_cone(u1: f32, u2: f32, cos_max: f32) -> Vec3 {
    let z = 1.0 - u1 * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Barycentrics (b1, b2) uniform on a triangle.
pub fn uniform_triangle(u1: f32, u2: f32) -> Vec2 {
    let s = u1.sqrt();
    Vec2::new(u2 * s, 1.0 - s)
}

/// A frame (s, t, n) about unit n: maps a local vector to world.
pub fn to_world(n: Vec3, v: Vec3) -> Vec3 {
    let (s, t) = super::super::coordinate_system(n);
    s * v.x + t * v.y + n * v.z
}

/// World vector to the frame of `coordinate_system(n)`.
pub fn to_local(n: Vec3, v: Vec3) -> Vec3 {
    let (s, t) = super::super::coordinate_system(n);
    Vec3::new(v.dot(s), v.dot(t), v.dot(n))
}

/// BSDF kinds without a non-delta lobe a VPL can sit on. `roughdielectric` counts as such: a particle
/// scatters through it (`sample_bsdf`) but leaves no VPL there (a VPL emits on its incident side only,
/// and a VPL's BSDF is evaluated reciprocally, which its transmission is not).
pub fn has_smooth_lobe_only(b: &GpuBsdf) -> bool {
    !matches!(b.kind, KIND_DIFFUSE | KIND_PLASTIC | KIND_ROUGHPLASTIC | KIND_ROUGHCONDUCTOR | KIND_PRINCIPLED)
}

/// A sampled continuation: local direction, weight (eval / pdf or the delta weight), delta lobe?
pub struct BsdfSample {
    pub wo: Vec3,
    pub weight: Vec3,
    pub delta: bool,
}

fn mean(v: [f32; 3]) -> f32 {
    (v[0] + v[1] + v[2]) / 3.0
}

/// Microfacet normal with density D(h) cos(theta_h) for an isotropic alpha (GGX or Beckmann).
pub(crate) fn sample_microfacet(ggx: bool, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let tan2 = if ggx { alpha * alpha * u1 / (1.0 - u1).max(1e-12) } else { -alpha * alpha * (1.0 - u1).max(1e-12).ln() };
    let cos = 1.0 / (1.0 + tan2).sqrt();
    // sin = tan cos, not sqrt(1 - cos^2), which cancels in f32 near the lobe's centre for small alpha
    // (cos within a few ulps of 1 at alpha = 0.005: sin quantized to steps of ~3e-4 rad).
    let sin = tan2.sqrt() * cos;
    let phi = 2.0 * PI * u2;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

pub(crate) fn reflect(wi: Vec3, h: Vec3) -> Vec3 {
    2.0 * wi.dot(h) * h - wi
}

/// Samples the BSDF for a particle arriving from local `wi` (toward where it came from). `None` when
/// the particle is absorbed (black BSDF, back side of a one-sided BSDF, zero weight).
pub fn sample_bsdf(b: &GpuBsdf, wi_in: Vec3, rng: &mut Pcg32) -> Option<BsdfSample> {
    if b.flags & (FLAG_BUMP | FLAG_TWOSIDED_OUTER) != 0 {
        return crate::shading::perturb::sample(b, wi_in, rng);
    }
    let (u0, u1, u2) = (uniform(rng), uniform(rng), uniform(rng));
    if b.kind == KIND_PRINCIPLED {
        let (wo, weight) = crate::shading::principled::sample(b, wi_in, u0, u1, u2)?;
        return Some(BsdfSample { wo, weight, delta: false });
    }
    if b.kind == KIND_ROUGHDIELECTRIC {
        return sample_roughdielectric(b, wi_in, u0, u1, u2);
    }
    if b.kind == KIND_SMOOTH && b.flags & crate::shading::bsdf::FLAG_THIN != 0 {
        let r = fresnel(wi_in.z.abs(), b.eta[0]);
        let r = r * (2.0 / (1.0 + r));
        let (wo, weight) =
            if u0 < r { (Vec3::new(-wi_in.x, -wi_in.y, wi_in.z), Vec3::from_array(b.specular)) } else { (-wi_in, Vec3::from_array(b.k)) };
        return (weight.max_element() > 0.0).then_some(BsdfSample { wo, weight, delta: true });
    }
    if b.kind == KIND_SMOOTH && is_dielectric(b) {
        let eta = b.eta[0];
        let f = fresnel(wi_in.z, eta);
        if u0 < f {
            return Some(BsdfSample { wo: Vec3::new(-wi_in.x, -wi_in.y, wi_in.z), weight: Vec3::ONE, delta: true });
        }
        let eta_ti = if wi_in.z >= 0.0 { 1.0 / eta } else { eta };
        let cos_t2 = 1.0 - (1.0 - wi_in.z * wi_in.z) * eta_ti * eta_ti;
        if cos_t2 <= 0.0 {
            return None;
        }
        let cos_t = -cos_t2.sqrt().copysign(wi_in.z);
        let wo = Vec3::new(-wi_in.x * eta_ti, -wi_in.y * eta_ti, cos_t).normalize();
        return Some(BsdfSample { wo, weight: Vec3::ONE, delta: true });
    }
    let mut wi = wi_in;
    let flip = b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0;
    if flip {
        wi.z = -wi.z;
    }
    if !(wi.z > 0.0) {
        return None;
    }
    let specular = Vec3::from_array(b.specular);
    let mut s = match b.kind {
        KIND_DIFFUSE => BsdfSample { wo: cosine_hemisphere(u1, u2), weight: Vec3::from_array(b.diffuse), delta: false },
        KIND_PLASTIC => {
            let f = fresnel(wi.z, b.eta[0]);
            let (sm, dm) = (f * mean(b.specular), (1.0 - f) * mean(b.diffuse));
            let p_spec = if sm + dm > 0.0 { sm / (sm + dm) } else { 0.0 };
            if u0 < p_spec {
                BsdfSample { wo: Vec3::new(-wi.x, -wi.y, wi.z), weight: specular * (f / p_spec), delta: true }
            } else {
                let wo = cosine_hemisphere(u1, u2);
                let pdf = (1.0 - p_spec) * wo.z / PI;
                if !(pdf > 0.0) {
                    return None;
                }
                BsdfSample { wo, weight: eval(b, wi, wo) / pdf, delta: false }
            }
        }
        KIND_ROUGHPLASTIC | KIND_ROUGHCONDUCTOR => {
            let ggx = b.flags & FLAG_GGX != 0;
            let alpha = (b.alpha_u * b.alpha_v).sqrt();
            let p_spec = rough_specular_probability(b, wi);
            let wo = if u0 < p_spec { reflect(wi, sample_microfacet(ggx, alpha, u1, u2)) } else { cosine_hemisphere(u1, u2) };
            if !(wo.z > 0.0) {
                return None;
            }
            let h = (wi + wo).normalize();
            let pdf_spec = microfacet_d(ggx, alpha, alpha, h) * h.z / (4.0 * wo.dot(h).abs());
            let pdf = p_spec * pdf_spec + (1.0 - p_spec) * wo.z / PI;
            if !(pdf > 0.0) {
                return None;
            }
            BsdfSample { wo, weight: eval(b, wi, wo) / pdf, delta: false }
        }
        KIND_SMOOTH => {
            let c = wi.z;
            let f = Vec3::new(
                fresnel_conductor(c, b.eta[0], b.k[0]),
                fresnel_conductor(c, b.eta[1], b.k[1]),
                fresnel_conductor(c, b.eta[2], b.k[2]),
            );
            BsdfSample { wo: Vec3::new(-wi.x, -wi.y, wi.z), weight: f * specular, delta: true }
        }
        _ => return None,
    };
    if flip {
        s.wo.z = -s.wo.z;
    }
    if !(s.weight.is_finite() && s.weight.max_element() > 0.0) {
        return None;
    }
    Some(s)
}

/// The solid-angle density with which `sample_bsdf(b, wi_in, .)` returns the local direction `wo_in`
/// among its non-delta samples (the MIS weights of a path tracer, `crate::pathtrace`): the same
/// mixtures as `sample_bsdf` (module docs), 0 where it never samples (delta-only BSDFs, the wrong
/// hemisphere, the back of a one-sided BSDF). For `plastic` the density of the diffuse branch times its
/// probability (1 - p_spec); the delta branch has no density. Principled BSDFs are not covered (0).
pub fn pdf_bsdf(b: &GpuBsdf, wi_in: Vec3, wo_in: Vec3) -> f32 {
    if b.flags & (FLAG_BUMP | FLAG_TWOSIDED_OUTER) != 0 {
        return crate::shading::perturb::pdf(b, wi_in, wo_in);
    }
    if b.kind == KIND_ROUGHDIELECTRIC {
        return pdf_roughdielectric(b, wi_in, wo_in);
    }
    let (mut wi, mut wo) = (wi_in, wo_in);
    if b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if !(wi.z > 0.0 && wo.z > 0.0) {
        return 0.0;
    }
    match b.kind {
        KIND_DIFFUSE => wo.z / PI,
        KIND_PLASTIC => {
            let f = fresnel(wi.z, b.eta[0]);
            let (sm, dm) = (f * mean(b.specular), (1.0 - f) * mean(b.diffuse));
            let p_spec = if sm + dm > 0.0 { sm / (sm + dm) } else { 0.0 };
            (1.0 - p_spec) * wo.z / PI
        }
        KIND_ROUGHPLASTIC | KIND_ROUGHCONDUCTOR => {
            let ggx = b.flags & FLAG_GGX != 0;
            let alpha = (b.alpha_u * b.alpha_v).sqrt();
            let p_spec = rough_specular_probability(b, wi);
            let h = (wi + wo).normalize();
            let pdf_spec = microfacet_d(ggx, alpha, alpha, h) * h.z / (4.0 * wo.dot(h).abs());
            p_spec * pdf_spec + (1.0 - p_spec) * wo.z / PI
        }
        _ => 0.0,
    }
}

/// `sample_bsdf` for a `roughdielectric` record (module docs); importance-mode weights.
fn sample_roughdielectric(b: &GpuBsdf, wi: Vec3, u0: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    if wi.z == 0.0 {
        return None;
    }
    let ggx = b.flags & FLAG_GGX != 0;
    let alpha = (b.alpha_u * b.alpha_v).sqrt();
    // Upper hemisphere, as Mitsuba samples m for mulsign(wi, cos_theta_i); wi must face it.
    let h = sample_microfacet(ggx, alpha, u1, u2);
    let wi_h = wi.dot(h);
    if !(wi_h * wi.z > 0.0) {
        return None;
    }
    let f = fresnel(wi_h, b.eta[0]);
    let reflected = u0 < f;
    let wo = if reflected {
        reflect(wi, h)
    } else {
        // Refraction through h (Mitsuba's `refract(wi, m, cos_theta_t, eta_ti)`).
        let eta_ti = if wi_h >= 0.0 { 1.0 / b.eta[0] } else { b.eta[0] };
        let cos_t2 = 1.0 - (1.0 - wi_h * wi_h) * eta_ti * eta_ti;
        if cos_t2 <= 0.0 {
            return None;
        }
        let cos_t = -cos_t2.sqrt().copysign(wi_h);
        (h * (wi_h * eta_ti + cos_t) - wi * eta_ti).normalize()
    };
    // A branch that lands on the other lobe's side is rejected (as Mitsuba does), so that every direction
    // has one proposal and `pdf_roughdielectric` is its density.
    if (wo.z * wi.z > 0.0) != reflected {
        return None;
    }
    let pdf = pdf_roughdielectric(b, wi, wo);
    if !(pdf > 0.0) {
        return None;
    }
    let weight = crate::shading::bsdf::roughdielectric_eval(b, wi, wo, false) / pdf;
    (weight.is_finite() && weight.max_element() > 0.0).then_some(BsdfSample { wo, weight, delta: false })
}

/// The density of `sample_roughdielectric`'s direction wo (solid angle).
pub fn pdf_roughdielectric(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z == 0.0 || wo.z == 0.0 {
        return 0.0;
    }
    let ggx = b.flags & FLAG_GGX != 0;
    let alpha = (b.alpha_u * b.alpha_v).sqrt();
    let reflect = wi.z * wo.z > 0.0;
    let eta = if wi.z > 0.0 { b.eta[0] } else { b.eta[1] };
    let mut h = (wi + wo * if reflect { 1.0 } else { eta }).normalize();
    if h.z < 0.0 {
        h = -h;
    }
    let (wi_h, wo_h) = (wi.dot(h), wo.dot(h));
    // h must face wi (as sampled), and wo must be on the side of h the lobe sends it to.
    if !(wi_h * wi.z > 0.0) || (reflect && wo_h * wi_h <= 0.0) || (!reflect && wo_h * wi_h >= 0.0) {
        return 0.0;
    }
    let d = microfacet_d(ggx, alpha, alpha, h) * h.z;
    let f = fresnel(wi_h, b.eta[0]);
    if reflect {
        d * f / (4.0 * wo_h.abs())
    } else {
        let denom = wi_h + eta * wo_h;
        d * (1.0 - f) * eta * eta * wo_h.abs() / (denom * denom)
    }
}

/// A smooth BSDF resolved from `dielectric` (eta = (int/ext, 0, 0), no specular or k).
pub fn is_dielectric(b: &GpuBsdf) -> bool {
    b.flags & crate::shading::bsdf::FLAG_THIN == 0
        && b.kind == KIND_SMOOTH
        && b.specular == [0.0; 3]
        && b.k == [0.0; 3]
        && b.eta[1] == 0.0
        && b.eta[2] == 0.0
}

#[cfg(test)]
mod tests;

/// Probability that `sample_bsdf` samples the specular (microfacet) lobe of a rough plastic or rough conductor
/// record at incident direction `wi` (local frame); `pdf_bsdf` mixes the lobes' densities with it.
fn rough_specular_probability(b: &GpuBsdf, wi: Vec3) -> f32 {
    if b.kind == KIND_ROUGHCONDUCTOR {
        0.9
    } else {
        let f = fresnel(wi.z, b.eta[0]);
        let (sm, dm) = (f * mean(b.specular), (1.0 - f) * mean(b.diffuse));
        if sm + dm > 0.0 {
            (sm / (sm + dm)).clamp(0.1, 0.9)
        } else {
            0.5
        }
    }
}
