//! BSDF evaluation exactly as Mitsuba 3.9.1 (RGB variants) computes `bsdf.eval(ctx, si, wo)`: the Rust
//! reference, twin of `shaders/common/bsdf.wgsl` (`bsdf_eval`).
//!
//! Implemented (Mitsuba sources: `src/bsdfs/{diffuse,twosided,plastic,roughplastic,roughconductor}.cpp`,
//! `include/mitsuba/render/{microfacet,fresnel}.h`):
//! - `diffuse`: R / pi * cos_theta_o, one-sided.
//! - `twosided` (one child for both sides): wi below the surface flips both wi.z and wo.z.
//! - `plastic` (smooth): its eval is the diffuse lobe only, which is all a point light can reach:
//!   R / (1 - (nonlinear ? R Fdr_int : Fdr_int)) * cos_theta_o / pi / eta^2 * (1 - F(wi)) (1 - F(wo)).
//! - `roughplastic`: specular F D G / (4 cos_theta_i) * specular_reflectance, plus the diffuse lobe with
//!   Mitsuba's 64-entry external transmittance table (linear interpolation `lerp_gather`) and internal
//!   reflectance, computed in `bsdf_tables`.
//! - `roughconductor`: D G / (4 cos_theta_i) * F_conductor(dot(wi, H), eta + i k) * specular_reflectance.
//! - `roughdielectric` (both sides, `src/bsdfs/roughdielectric.cpp`): with eta = int_ior / ext_ior seen from
//!   the front (cos_theta_i > 0), 1 / eta from the back, and h the half vector normalize(wi + wo) for
//!   reflection, normalize(wi + eta wo) for transmission, flipped into the upper hemisphere:
//!   reflection F D G / (4 |cos_theta_i|) * specular_reflectance; transmission
//!   |s (1 - F) D G eta^2 (wi.h)(wo.h) / (cos_theta_i (wi.h + eta wo.h)^2)| * specular_transmittance with
//!   F = fresnel(wi.h, int_ior / ext_ior) and s = 1 / eta^2 (Mitsuba's `TransportMode::Radiance`, what
//!   `eval` gives a camera path; `roughdielectric_eval(.., false)` is the importance-mode value, s = 1).
//! - `conductor`, `dielectric`, `thindielectric` (smooth): 0 (delta lobes; no contribution from point
//!   lights; `view::chains` follows them).
//! - `blendbsdf`: two records (`resolve_records`, `eval_records`): (1 - w) f_0 + w f_1.
//! - `principled`: `shading::principled` (its own field table; reflection from both sides and
//!   transmission, not only the upper hemisphere).
//! - `bumpmap`, `normalmap`: the nested BSDF's record with the perturbed normal (`FLAG_BUMP`, evaluated
//!   by `shading::perturb`).
//!
//! `GpuBsdf` field use per kind (`eta_s` = int_ior / ext_ior):
//! | kind | diffuse | specular | eta | k | alpha_u, alpha_v | extra |
//! |---|---|---|---|---|---|---|
//! | DIFFUSE | reflectance | - | - | - | - | - |
//! | PLASTIC | diffuse_reflectance | specular_reflectance | (eta_s, 1/eta_s^2, 0) | - | - | [Fdr_int, Fdr_ext, 0, 0] |
//! | ROUGHPLASTIC | diffuse_reflectance | specular_reflectance | (eta_s, 1/eta_s^2, 0) | - | alpha | [internal_reflectance, bits(table offset), 0, 0] |
//! | ROUGHCONDUCTOR | - | specular_reflectance | eta | k | alpha_u, alpha_v | - |
//! | ROUGHDIELECTRIC | - | specular_reflectance | (eta_s, 1/eta_s, 0) | specular_transmittance | alpha_u, alpha_v | - |
//! | SMOOTH | - | conductor: specular_reflectance | conductor: eta; dielectric: (eta_s, 0, 0) | conductor: k | - | - |
//! | SMOOTH + FLAG_THIN | - | specular_reflectance | (eta_s, 0, 0) | specular_transmittance | - | - |
//! Alphas are clamped to >= 1e-4 as Mitsuba's `MicrofacetDistribution::configure` does.
//!
//! Roughplastic tables: the GPU reads its transmittance from a separate table buffer (one 64-entry table
//! per roughplastic of the scene, `roughplastic_table_buffer`), at the offset stored as bits in
//! `extra[1]`; WGSL including `bsdf.wgsl` must define `fn bsdf_table(i: u32) -> f32` returning that
//! buffer's element i. The Rust `eval` reads the same values from the memo in `bsdf_tables`.
//!
//! Deviations: a `twosided` whose back BSDF differs from its front resolves to the front for both sides
//! (no shared scene has one). Textures are evaluated with `scene::texture` (scalar parameters as Mitsuba's `eval_1`).
use super::bsdf_tables::{roughplastic_tables, TABLE_RES};
use super::GpuBsdf;
use crate::scene::texture::{eval_param, eval_param_1};
use crate::scene::{Bsdf, MicrofacetDistribution, Param, Texture};
use glam::{Vec2, Vec3};

/// Black: evaluates to 0.
pub const KIND_NONE: u32 = 0;
pub const KIND_DIFFUSE: u32 = 1;
pub const KIND_ROUGHPLASTIC: u32 = 2;
/// Smooth plastic: eval = its diffuse lobe.
pub const KIND_PLASTIC: u32 = 3;
pub const KIND_ROUGHCONDUCTOR: u32 = 4;
/// Smooth conductor or dielectric: eval = 0.
pub const KIND_SMOOTH: u32 = 5;
/// Mitsuba's `principled` (`shading::principled`, fields documented there).
pub const KIND_PRINCIPLED: u32 = 6;
/// Mitsuba's `roughdielectric`: glossy reflection and transmission, both sides.
pub const KIND_ROUGHDIELECTRIC: u32 = 7;

/// Wrapped in `twosided`.
pub const FLAG_TWOSIDED: u32 = 1;
/// Plastics' `nonlinear`.
pub const FLAG_NONLINEAR: u32 = 2;
/// GGX (else Beckmann).
pub const FLAG_GGX: u32 = 4;
/// First record of a `blendbsdf`: `extra[2]` = weight w of the second record, `extra[3]` = its index
/// (bits) in the same record array; eval = (1 - w) f_this + w f_second (`eval_records`).
pub const FLAG_BLEND: u32 = 8;
/// A `bumpmap` / `normalmap` wraps this record: its perturbed normal is stored in it
/// (`shading::perturb`, which evaluates it).
pub const FLAG_BUMP: u32 = 16;
/// A `twosided` around a `bumpmap` / `normalmap`: flips before the perturbation (`shading::perturb`).
pub const FLAG_TWOSIDED_OUTER: u32 = 32;
/// A `KIND_SMOOTH` record from `thindielectric` (delta reflection and straight transmission).
pub const FLAG_THIN: u32 = 64;

const INV_PI: f32 = std::f32::consts::FRAC_1_PI;

/// Resolve scene BSDF `index` at texture coordinate `uv` (textures evaluated there).
pub fn resolve(bsdfs: &[Bsdf], textures: &[Texture], index: usize, uv: Vec2) -> GpuBsdf {
    let mut b = GpuBsdf {
        diffuse: [0.0; 3],
        kind: KIND_NONE,
        specular: [0.0; 3],
        flags: 0,
        eta: [0.0; 3],
        alpha_u: 0.0,
        k: [0.0; 3],
        alpha_v: 0.0,
        extra: [0.0; 4],
    };
    let Some(bsdf) = bsdfs.get(index) else { return b };
    let rgb = |p: &Param| eval_param(textures, p, uv).to_array();
    match bsdf {
        Bsdf::Diffuse { reflectance } => {
            b.kind = KIND_DIFFUSE;
            b.diffuse = rgb(reflectance);
        }
        Bsdf::TwoSided { front, .. } => {
            if *front != index {
                b = resolve(bsdfs, textures, *front, uv);
            }
            let wraps = matches!(bsdfs.get(*front), Some(Bsdf::BumpMap { .. } | Bsdf::NormalMap { .. }));
            b.flags |= if wraps { FLAG_TWOSIDED_OUTER } else { FLAG_TWOSIDED };
        }
        Bsdf::Mask { nested, .. } => {
            // The nested BSDF; the opacity weights the view sample (`view::chains::mask_opacity`).
            if *nested != index {
                b = resolve(bsdfs, textures, *nested, uv);
            }
        }
        Bsdf::BumpMap { nested, .. } | Bsdf::NormalMap { nested, .. } => {
            // The nested BSDF; the perturbed normal is added where the geometry is known (`perturb::apply`).
            if *nested != index {
                b = resolve(bsdfs, textures, *nested, uv);
            }
        }
        Bsdf::Plastic { diffuse_reflectance, specular_reflectance, int_ior, ext_ior, nonlinear } => {
            let eta = int_ior / ext_ior;
            b.kind = KIND_PLASTIC;
            b.diffuse = rgb(diffuse_reflectance);
            b.specular = rgb(specular_reflectance);
            b.flags = if *nonlinear { FLAG_NONLINEAR } else { 0 };
            b.eta = [eta, 1.0 / (eta * eta), 0.0];
            b.extra = [fresnel_diffuse_reflectance(1.0 / eta), fresnel_diffuse_reflectance(eta), 0.0, 0.0];
        }
        Bsdf::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, alpha, int_ior, ext_ior, nonlinear } => {
            let eta = int_ior / ext_ior;
            let ggx = *distribution == MicrofacetDistribution::Ggx;
            let alpha = alpha.max(1e-4);
            b.kind = KIND_ROUGHPLASTIC;
            b.diffuse = rgb(diffuse_reflectance);
            b.specular = rgb(specular_reflectance);
            b.flags = if *nonlinear { FLAG_NONLINEAR } else { 0 } | if ggx { FLAG_GGX } else { 0 };
            b.eta = [eta, 1.0 / (eta * eta), 0.0];
            b.alpha_u = alpha;
            b.alpha_v = alpha;
            let offset = (TABLE_RES * roughplastic_slot(bsdfs, index)) as u32;
            b.extra = [roughplastic_tables(ggx, alpha, eta).internal_reflectance, f32::from_bits(offset), 0.0, 0.0];
        }
        Bsdf::RoughConductor { distribution, alpha_u, alpha_v, eta, k, specular_reflectance } => {
            b.kind = KIND_ROUGHCONDUCTOR;
            b.flags = if *distribution == MicrofacetDistribution::Ggx { FLAG_GGX } else { 0 };
            b.specular = rgb(specular_reflectance);
            b.eta = eta.to_array();
            b.k = k.to_array();
            b.alpha_u = eval_param_1(textures, alpha_u, uv).max(1e-4);
            b.alpha_v = eval_param_1(textures, alpha_v, uv).max(1e-4);
        }
        Bsdf::Conductor { eta, k, specular_reflectance } => {
            b.kind = KIND_SMOOTH;
            b.specular = rgb(specular_reflectance);
            b.eta = eta.to_array();
            b.k = k.to_array();
        }
        Bsdf::Dielectric { int_ior, ext_ior } => {
            b.kind = KIND_SMOOTH;
            b.eta = [int_ior / ext_ior, 0.0, 0.0];
        }
        Bsdf::RoughDielectric { distribution, alpha_u, alpha_v, int_ior, ext_ior, specular_reflectance, specular_transmittance } => {
            b.kind = KIND_ROUGHDIELECTRIC;
            b.flags = if *distribution == MicrofacetDistribution::Ggx { FLAG_GGX } else { 0 };
            b.specular = rgb(specular_reflectance);
            b.k = rgb(specular_transmittance);
            // Mitsuba: m_inv_eta = rcp(m_eta).
            let eta = int_ior / ext_ior;
            b.eta = [eta, 1.0 / eta, 0.0];
            b.alpha_u = eval_param_1(textures, alpha_u, uv).max(1e-4);
            b.alpha_v = eval_param_1(textures, alpha_v, uv).max(1e-4);
        }
        Bsdf::ThinDielectric { int_ior, ext_ior, specular_reflectance, specular_transmittance } => {
            b.kind = KIND_SMOOTH;
            b.flags = FLAG_THIN;
            b.specular = rgb(specular_reflectance);
            b.k = rgb(specular_transmittance);
            b.eta = [int_ior / ext_ior, 0.0, 0.0];
        }
        Bsdf::Blend { .. } => {
            b = resolve_records(bsdfs, textures, index, uv).0;
        }
        Bsdf::Principled(p) => {
            let f = |q: &Param| eval_param_1(textures, q, uv);
            let roughness = f(&p.roughness);
            b.kind = KIND_PRINCIPLED;
            b.diffuse = rgb(&p.base_color);
            b.specular = [f(&p.metallic), f(&p.spec_tint), f(&p.spec_trans)];
            b.eta = [p.eta, f(&p.sheen), f(&p.sheen_tint)];
            b.k = [f(&p.clearcoat), f(&p.clearcoat_gloss), f(&p.flatness)];
            (b.alpha_u, b.alpha_v) = super::principled::dist_params(f(&p.anisotropic), roughness);
            b.extra = [roughness, 0.0, 0.0, 0.0];
        }
    }
    b
}

/// Resolve scene BSDF `index` at `uv` into its records: one, or two for a `blendbsdf` (also inside a
/// `twosided`, whose flag both get). The first then has `FLAG_BLEND` and the weight in `extra[2]`; the
/// caller stores the second in the same record array and its index as bits in `extra[3]` (`link_blend`).
/// `resolve` alone returns only the first record.
pub fn resolve_records(bsdfs: &[Bsdf], textures: &[Texture], index: usize, uv: Vec2) -> (GpuBsdf, Option<GpuBsdf>) {
    match bsdfs.get(index) {
        Some(Bsdf::Blend { weight, first, second }) => {
            let w = eval_param_1(textures, weight, uv).max(0.0).min(1.0);
            let mut a = resolve(bsdfs, textures, *first, uv);
            let b = resolve(bsdfs, textures, *second, uv);
            a.flags |= FLAG_BLEND;
            a.extra[2] = w;
            a.extra[3] = f32::from_bits(u32::MAX);
            (a, Some(b))
        }
        Some(Bsdf::TwoSided { front, .. }) if *front != index && matches!(bsdfs.get(*front), Some(Bsdf::Blend { .. })) => {
            let (mut a, b) = resolve_records(bsdfs, textures, *front, uv);
            a.flags |= FLAG_TWOSIDED;
            (
                a,
                b.map(|mut b| {
                    b.flags |= FLAG_TWOSIDED;
                    b
                }),
            )
        }
        _ => (resolve(bsdfs, textures, index, uv), None),
    }
}

/// Points a blend's first record at its second record, stored at `second_index` of the same array.
pub fn link_blend(first: &mut GpuBsdf, second_index: usize) {
    first.extra[3] = f32::from_bits(second_index as u32);
}

/// `eval` of record `i` of a record array, following a blend to its second record (Mitsuba's
/// `blendbsdf`: val_0 (1 - w) + val_1 w).
pub fn eval_records(records: &[GpuBsdf], i: usize, wi: Vec3, wo: Vec3) -> Vec3 {
    let b = &records[i];
    let v0 = eval(b, wi, wo);
    if b.flags & FLAG_BLEND == 0 {
        return v0;
    }
    let w = b.extra[2];
    let v1 = records.get(b.extra[3].to_bits() as usize).map_or(Vec3::ZERO, |s| eval(s, wi, wo));
    v0 * (1.0 - w) + v1 * w
}

/// Position of roughplastic `index` among the scene's roughplastics (its table's slot).
fn roughplastic_slot(bsdfs: &[Bsdf], index: usize) -> usize {
    bsdfs[..index].iter().filter(|b| matches!(b, Bsdf::RoughPlastic { .. })).count()
}

/// The table buffer the GPU reads roughplastic transmittance from: 64 f32 per roughplastic of `bsdfs`, in
/// order (offsets as `resolve` stores them). Never empty (one 0 when there is no roughplastic), so it
/// can always be bound.
pub fn roughplastic_table_buffer(bsdfs: &[Bsdf]) -> Vec<f32> {
    let mut out = Vec::new();
    for b in bsdfs {
        if let Bsdf::RoughPlastic { distribution, alpha, int_ior, ext_ior, .. } = b {
            let t = roughplastic_tables(*distribution == MicrofacetDistribution::Ggx, alpha.max(1e-4), int_ior / ext_ior);
            out.extend_from_slice(&t.external_transmittance);
        }
    }
    if out.is_empty() {
        out.push(0.0);
    }
    out
}

/// Mitsuba's `eval` in the local shading frame: wi toward the viewer, wo toward the light (unit, z =
/// shading normal). Returns f(wi, wo) |cos theta_o| (0 wherever Mitsuba gives 0). One record only: a
/// blend's first record evaluates its own lobe (`eval_records` adds the second).
pub fn eval(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> Vec3 {
    if b.flags & (FLAG_BUMP | FLAG_TWOSIDED_OUTER) != 0 {
        return super::perturb::eval(b, wi, wo);
    }
    if b.kind == KIND_PRINCIPLED {
        return super::principled::eval(b, wi, wo);
    }
    if b.kind == KIND_ROUGHDIELECTRIC {
        return roughdielectric_eval(b, wi, wo, true);
    }
    let (mut wi, mut wo) = (wi, wo);
    if b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    let (cos_i, cos_o) = (wi.z, wo.z);
    if !(cos_i > 0.0 && cos_o > 0.0) {
        return Vec3::ZERO;
    }
    let diffuse = Vec3::from_array(b.diffuse);
    let specular = Vec3::from_array(b.specular);
    let nonlinear = b.flags & FLAG_NONLINEAR != 0;
    match b.kind {
        KIND_DIFFUSE => diffuse * INV_PI * cos_o,
        KIND_PLASTIC => {
            let (eta, inv_eta_2, fdr_int) = (b.eta[0], b.eta[1], b.extra[0]);
            let f_i = fresnel(cos_i, eta);
            let f_o = fresnel(cos_o, eta);
            let diff = diffuse / (Vec3::ONE - if nonlinear { diffuse * fdr_int } else { Vec3::splat(fdr_int) });
            diff * (INV_PI * cos_o * inv_eta_2 * (1.0 - f_i) * (1.0 - f_o))
        }
        KIND_ROUGHPLASTIC => {
            let (eta, inv_eta_2, internal) = (b.eta[0], b.eta[1], b.extra[0]);
            let ggx = b.flags & FLAG_GGX != 0;
            let h = (wo + wi).normalize();
            let d = microfacet_d(ggx, b.alpha_u, b.alpha_v, h);
            let f = fresnel(wi.dot(h), eta);
            let g = smith_g1(ggx, b.alpha_u, b.alpha_v, wi, h) * smith_g1(ggx, b.alpha_u, b.alpha_v, wo, h);
            let spec = specular * (f * d * g / (4.0 * cos_i));
            let table = &roughplastic_tables(ggx, b.alpha_u, eta).external_transmittance;
            let t_i = lerp_gather(table, cos_i);
            let t_o = lerp_gather(table, cos_o);
            let diff = diffuse / (Vec3::ONE - if nonlinear { diffuse * internal } else { Vec3::splat(internal) });
            spec + diff * (INV_PI * inv_eta_2 * cos_o * t_i * t_o)
        }
        KIND_ROUGHCONDUCTOR => {
            let ggx = b.flags & FLAG_GGX != 0;
            let h = (wo + wi).normalize();
            let d = microfacet_d(ggx, b.alpha_u, b.alpha_v, h);
            if d == 0.0 {
                return Vec3::ZERO;
            }
            let g = smith_g1(ggx, b.alpha_u, b.alpha_v, wi, h) * smith_g1(ggx, b.alpha_u, b.alpha_v, wo, h);
            let value = d * g / (4.0 * cos_i);
            let c = wi.dot(h);
            let f = Vec3::new(
                fresnel_conductor(c, b.eta[0], b.k[0]),
                fresnel_conductor(c, b.eta[1], b.k[1]),
                fresnel_conductor(c, b.eta[2], b.k[2]),
            );
            f * (Vec3::splat(value) * specular)
        }
        _ => Vec3::ZERO,
    }
}

/// Mitsuba's `roughdielectric` `eval` (module docs) for a `KIND_ROUGHDIELECTRIC` record, in
/// `TransportMode::Radiance` when `radiance` (the camera's paths), else `Importance` (particles). Both
/// sides; 0 at cos_theta_i = 0.
pub fn roughdielectric_eval(b: &GpuBsdf, wi: Vec3, wo: Vec3, radiance: bool) -> Vec3 {
    let (cos_i, cos_o) = (wi.z, wo.z);
    if cos_i == 0.0 {
        return Vec3::ZERO;
    }
    let reflect = cos_i * cos_o > 0.0;
    let (eta, inv_eta) = if cos_i > 0.0 { (b.eta[0], b.eta[1]) } else { (b.eta[1], b.eta[0]) };
    let m = (wi + wo * if reflect { 1.0 } else { eta }).normalize();
    let m = if m.z.is_sign_negative() { -m } else { m };
    let ggx = b.flags & FLAG_GGX != 0;
    let d = microfacet_d(ggx, b.alpha_u, b.alpha_v, m);
    let (wi_m, wo_m) = (wi.dot(m), wo.dot(m));
    let f = fresnel_fused(wi_m, b.eta[0]);
    let g = smith_g1(ggx, b.alpha_u, b.alpha_v, wi, m) * smith_g1(ggx, b.alpha_u, b.alpha_v, wo, m);
    if reflect {
        Vec3::from_array(b.specular) * (f * d * g / (4.0 * cos_i.abs()))
    } else {
        let scale = if radiance { inv_eta * inv_eta } else { 1.0 };
        let denom = wi_m + eta * wo_m;
        let value = ((scale * (1.0 - f) * d * g * eta * eta * wi_m * wo_m) / (cos_i * (denom * denom))).abs();
        Vec3::from_array(b.k) * value
    }
}

/// Mitsuba's `lerp_gather` over a 64-entry table.
fn lerp_gather(table: &[f32; TABLE_RES], x: f32) -> f32 {
    let x = x * (TABLE_RES - 1) as f32;
    let index = (x as u32).min(TABLE_RES as u32 - 2) as usize;
    let (v0, v1, t) = (table[index], table[index + 1], x - index as f32);
    v1.mul_add(t, (-v0).mul_add(t, v0))
}

/// `MicrofacetDistribution::eval` (D).
pub fn microfacet_d(ggx: bool, alpha_u: f32, alpha_v: f32, m: Vec3) -> f32 {
    let alpha_uv = alpha_u * alpha_v;
    let cos_theta_2 = m.z * m.z;
    let sx = m.x / alpha_u;
    let sy = m.y / alpha_v;
    let result = if ggx {
        let s = sx * sx + sy * sy + m.z * m.z;
        1.0 / (std::f32::consts::PI * alpha_uv * s * s)
    } else {
        (-(sx * sx + sy * sy) / cos_theta_2).exp() / (std::f32::consts::PI * alpha_uv * cos_theta_2 * cos_theta_2)
    };
    if result * m.z > 1e-20 {
        result
    } else {
        0.0
    }
}

/// `MicrofacetDistribution::smith_g1`.
pub(crate) fn smith_g1(ggx: bool, alpha_u: f32, alpha_v: f32, v: Vec3, m: Vec3) -> f32 {
    let xy_alpha_2 = (alpha_u * v.x).powi(2) + (alpha_v * v.y).powi(2);
    let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
    let mut result = if ggx {
        2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt())
    } else {
        let a = 1.0 / tan_theta_alpha_2.sqrt();
        let a_sqr = a * a;
        if a >= 1.6 {
            1.0
        } else {
            (3.535 * a + 2.181 * a_sqr) / (1.0 + 2.276 * a + 2.577 * a_sqr)
        }
    };
    if xy_alpha_2 == 0.0 {
        result = 1.0;
    }
    if v.dot(m) * v.z <= 0.0 {
        result = 0.0;
    }
    result
}

/// Mitsuba's dielectric `fresnel` (reflectance only).
pub fn fresnel(cos_theta_i: f32, eta: f32) -> f32 {
    let (eta_it, eta_ti) = if cos_theta_i >= 0.0 { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let ci = cos_theta_i.abs();
    let ct = cos_theta_t_sqr.max(0.0).sqrt();
    if eta == 1.0 {
        return 0.0;
    }
    if ci == 0.0 {
        return 1.0;
    }
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    0.5 * (a_s * a_s + a_p * a_p)
}

/// Mitsuba's dielectric `fresnel` (reflectance) with its fused multiply-adds (`dr::fmadd`/`fnmadd` are
/// FMAs in Mitsuba's builds): near total internal reflection, where cos_theta_t^2 cancels, the unfused
/// `fresnel` differs from Mitsuba by far more than rounding (1 - F of 6e-4 against 0).
pub fn fresnel_fused(cos_theta_i: f32, eta: f32) -> f32 {
    let rcp_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if cos_theta_i >= 0.0 { (eta, rcp_eta) } else { (rcp_eta, eta) };
    let cos_theta_t_sqr = (-(-cos_theta_i).mul_add(cos_theta_i, 1.0)).mul_add(eta_ti * eta_ti, 1.0);
    let ci = cos_theta_i.abs();
    let ct = cos_theta_t_sqr.max(0.0).sqrt();
    if eta == 1.0 {
        return 0.0;
    }
    if ci == 0.0 {
        return 1.0;
    }
    let a_s = (-eta_it).mul_add(ct, ci) / eta_it.mul_add(ct, ci);
    let a_p = (-eta_it).mul_add(ci, ct) / eta_it.mul_add(ci, ct);
    0.5 * (a_s * a_s + a_p * a_p)
}

/// Mitsuba's `fresnel_conductor` for one channel (complex IOR eta + i k).
pub fn fresnel_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let cos_theta_i_2 = cos_theta_i * cos_theta_i;
    let sin_theta_i_2 = 1.0 - cos_theta_i_2;
    let sin_theta_i_4 = sin_theta_i_2 * sin_theta_i_2;
    let temp_1 = eta * eta - k * k - sin_theta_i_2;
    let a_2_pb_2 = (temp_1 * temp_1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a_2_pb_2 + temp_1)).max(0.0).sqrt();
    let term_1 = a_2_pb_2 + cos_theta_i_2;
    let term_2 = 2.0 * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a_2_pb_2 * cos_theta_i_2 + sin_theta_i_4;
    let term_4 = term_2 * sin_theta_i_2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    0.5 * (r_s + r_p)
}

/// Mitsuba's `fresnel_diffuse_reflectance` (Egan-Hilgeman for eta < 1, d'Eon-Irving otherwise).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv_eta = 1.0 / eta;
    if eta < 1.0 {
        0.0636f32.mul_add(inv_eta, eta.mul_add(eta.mul_add(-1.4399, 0.7099), 0.6681))
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0f32, |acc, &ci| acc.mul_add(inv_eta, ci))
    }
}

/// BSDF parameter sets of the shared scenes (plus roughplastics), shared by the CPU and GPU tests:
/// (name, scene BSDF list, index to resolve).
#[cfg(test)]
pub(crate) fn test_sets() -> Vec<(&'static str, Vec<Bsdf>, usize)> {
    use MicrofacetDistribution::{Beckmann, Ggx};
    let v = |r: f32, g: f32, b: f32| Param::Value(Vec3::new(r, g, b));
    let two = |b: Bsdf| (vec![b, Bsdf::TwoSided { front: 0, back: 0 }], 1);
    let (eta, k) = (Vec3::new(1.65746, 0.880369, 0.521229), Vec3::new(9.22387, 6.26952, 4.837));
    let rc = |distribution, a: f32| Bsdf::RoughConductor {
        distribution,
        alpha_u: Param::Value(Vec3::splat(a)),
        alpha_v: Param::Value(Vec3::splat(a)),
        eta,
        k,
        specular_reflectance: v(1.0, 1.0, 1.0),
    };
    let rp = |distribution, alpha, nonlinear| Bsdf::RoughPlastic {
        diffuse_reflectance: v(0.940, 0.271, 0.361),
        specular_reflectance: v(1.0, 1.0, 1.0),
        distribution,
        alpha,
        int_ior: 1.9,
        ext_ior: 1.000277,
        nonlinear,
    };
    let mut sets = vec![
        ("diffuse", vec![Bsdf::Diffuse { reflectance: v(0.725, 0.71, 0.68) }], 0),
        (
            "plastic",
            vec![Bsdf::Plastic {
                diffuse_reflectance: v(0.940, 0.271, 0.361),
                specular_reflectance: v(1.0, 1.0, 1.0),
                int_ior: 1.9,
                ext_ior: 1.000277,
                nonlinear: false,
            }],
            0,
        ),
        ("roughplastic_ggx", vec![rp(Ggx, 0.1, false)], 0),
        ("roughplastic_beckmann_nonlinear", vec![rp(Beckmann, 0.3, true)], 0),
        ("roughconductor_beckmann", vec![rc(Beckmann, 0.25)], 0),
    ];
    let (b, i) = two(Bsdf::Diffuse { reflectance: v(0.2, 0.25, 0.7) });
    sets.push(("twosided_diffuse", b, i));
    let (b, i) = two(rc(Ggx, 0.1));
    sets.push(("twosided_roughconductor_ggx", b, i));
    let (b, i) = two(rc(Ggx, 0.15));
    sets.push(("twosided_roughconductor_ggx_015", b, i));
    // Two roughplastics in one scene: the second one's table sits at offset 64.
    sets.push(("roughplastic_second_table", vec![rp(Ggx, 0.3, false), rp(Beckmann, 0.1, false)], 1));
    let s = |x: f32| Param::Value(Vec3::splat(x));
    let principled = |metallic: f32, spec_trans: f32, clearcoat: f32, sheen: f32| {
        Bsdf::Principled(Box::new(crate::scene::principled::Principled {
            base_color: v(0.8, 0.5, 0.2),
            roughness: s(0.4),
            anisotropic: s(0.3),
            metallic: s(metallic),
            spec_tint: s(0.2),
            spec_trans: s(spec_trans),
            sheen: s(sheen),
            sheen_tint: s(0.5),
            clearcoat: s(clearcoat),
            clearcoat_gloss: s(0.3),
            flatness: s(0.2),
            eta: 1.5,
        }))
    };
    sets.push(("principled_metallic_sheen", vec![principled(0.6, 0.0, 0.0, 0.8)], 0));
    sets.push(("principled_clearcoat", vec![principled(0.0, 0.0, 0.9, 0.0)], 0));
    sets.push(("principled_spec_trans", vec![principled(0.1, 0.7, 0.3, 0.0)], 0));
    // blendbsdf: diffuse + rough conductor with weight 0.3; twosided(blend(principled, roughplastic)).
    sets.push((
        "blend_diffuse_roughconductor",
        vec![Bsdf::Diffuse { reflectance: v(0.2, 0.6, 0.3) }, rc(Ggx, 0.2), Bsdf::Blend { weight: s(0.3), first: 0, second: 1 }],
        2,
    ));
    sets.push((
        "twosided_blend_principled_roughplastic",
        vec![
            principled(0.3, 0.0, 0.5, 0.5),
            rp(Ggx, 0.2, false),
            Bsdf::Blend { weight: s(0.6), first: 0, second: 1 },
            Bsdf::TwoSided { front: 2, back: 2 },
        ],
        3,
    ));
    sets
}

/// Uniform directions on the sphere from a fixed LCG (tests only).
#[cfg(test)]
pub(crate) fn random_directions(n: usize, seed: u64) -> Vec<Vec3> {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 40) as f32) / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let z = 2.0 * next() - 1.0;
            let phi = 2.0 * std::f32::consts::PI * next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

#[cfg(test)]
mod tests;
