// BSDF evaluation as Mitsuba 3.9.1 (RGB) does; twin of src/shading/bsdf.rs (field use per kind documented
// there). No entry points. Needs common/principled.wgsl (bsdf_principled_eval) after it, and the including
// module must define `fn bsdf_record(i: u32) -> Bsdf` (record i of the array the evaluated BSDFs come from:
// a blendbsdf's second record). The including module must define `fn bsdf_table(i: u32) -> f32` returning
// element i of `shading::bsdf::roughplastic_table_buffer` (roughplastic transmittance tables).

// NaN-proof comparisons for every pass that includes this file. A compiler allowed to assume no NaN
// (Metal's fast math, an aggressive driver) may fold `!(x > 0.0)` into `x <= 0.0`, which is false for
// NaN; these test the bits, which no such assumption can fold away. `positive(x)`: x > 0 and not NaN.
fn is_nan_f32(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}
fn positive(x: f32) -> bool {
    return x > 0.0 && !is_nan_f32(x);
}
// a > b, false when either is NaN.
fn greater(a: f32, b: f32) -> bool {
    return a > b && !is_nan_f32(a) && !is_nan_f32(b);
}

// Keep in sync with `GpuBsdf` in src/shading/mod.rs (80 bytes).
struct Bsdf {
    diffuse: vec3<f32>,
    kind: u32,
    specular: vec3<f32>,
    flags: u32,
    eta: vec3<f32>,
    alpha_u: f32,
    k: vec3<f32>,
    alpha_v: f32,
    extra: vec4<f32>,
}

const BSDF_KIND_DIFFUSE: u32 = 1u;
const BSDF_KIND_ROUGHPLASTIC: u32 = 2u;
const BSDF_KIND_PLASTIC: u32 = 3u;
const BSDF_KIND_ROUGHCONDUCTOR: u32 = 4u;
const BSDF_KIND_ROUGHDIELECTRIC: u32 = 7u;
const BSDF_FLAG_TWOSIDED: u32 = 1u;
const BSDF_FLAG_NONLINEAR: u32 = 2u;
const BSDF_FLAG_GGX: u32 = 4u;
const BSDF_FLAG_BLEND: u32 = 8u;
const BSDF_FLAG_BUMP: u32 = 16u;
const BSDF_FLAG_TWOSIDED_OUTER: u32 = 32u;
const BSDF_TABLE_RES: u32 = 64u;
const BSDF_PI: f32 = 3.14159265358979;
const BSDF_INV_PI: f32 = 0.318309886183791;

// Microfacet distribution D (Beckmann or GGX), zero where D cos(theta_m) <= 1e-20.
fn bsdf_microfacet_d(ggx: bool, alpha_u: f32, alpha_v: f32, m: vec3<f32>) -> f32 {
    let alpha_uv = alpha_u * alpha_v;
    let cos_theta_2 = m.z * m.z;
    let sx = m.x / alpha_u;
    let sy = m.y / alpha_v;
    var result: f32;
    if ggx {
        let s = sx * sx + sy * sy + m.z * m.z;
        result = 1.0 / (BSDF_PI * alpha_uv * s * s);
    } else {
        result = exp(-(sx * sx + sy * sy) / cos_theta_2) / (BSDF_PI * alpha_uv * cos_theta_2 * cos_theta_2);
    }
    return select(0.0, result, result * m.z > 1e-20);
}

// Smith's G1 (Beckmann: Mitsuba's rational approximation).
fn bsdf_smith_g1(ggx: bool, alpha_u: f32, alpha_v: f32, v: vec3<f32>, m: vec3<f32>) -> f32 {
    let ax = alpha_u * v.x;
    let ay = alpha_v * v.y;
    let xy_alpha_2 = ax * ax + ay * ay;
    let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
    var result: f32;
    if ggx {
        result = 2.0 / (1.0 + sqrt(1.0 + tan_theta_alpha_2));
    } else {
        let a = 1.0 / sqrt(tan_theta_alpha_2);
        let a_sqr = a * a;
        result = select((3.535 * a + 2.181 * a_sqr) / (1.0 + 2.276 * a + 2.577 * a_sqr), 1.0, a >= 1.6);
    }
    if xy_alpha_2 == 0.0 {
        result = 1.0;
    }
    if dot(v, m) * v.z <= 0.0 {
        result = 0.0;
    }
    return result;
}

// Dielectric Fresnel reflectance.
fn bsdf_fresnel(cos_theta_i: f32, eta: f32) -> f32 {
    let outside = cos_theta_i >= 0.0;
    let eta_it = select(1.0 / eta, eta, outside);
    let eta_ti = select(eta, 1.0 / eta, outside);
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let ci = abs(cos_theta_i);
    let ct = sqrt(max(cos_theta_t_sqr, 0.0));
    if eta == 1.0 {
        return 0.0;
    }
    if ci == 0.0 {
        return 1.0;
    }
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    return 0.5 * (a_s * a_s + a_p * a_p);
}

// Dielectric Fresnel reflectance with Mitsuba's multiply-adds (twin of `shading::bsdf::fresnel_fused`).
fn bsdf_fresnel_fused(cos_theta_i: f32, eta: f32) -> f32 {
    let outside = cos_theta_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let eta_it = select(rcp_eta, eta, outside);
    let eta_ti = select(eta, rcp_eta, outside);
    let cos_theta_t_sqr = fma(-fma(-cos_theta_i, cos_theta_i, 1.0), eta_ti * eta_ti, 1.0);
    let ci = abs(cos_theta_i);
    let ct = sqrt(max(cos_theta_t_sqr, 0.0));
    if eta == 1.0 {
        return 0.0;
    }
    if ci == 0.0 {
        return 1.0;
    }
    let a_s = fma(-eta_it, ct, ci) / fma(eta_it, ct, ci);
    let a_p = fma(-eta_it, ci, ct) / fma(eta_it, ci, ct);
    return 0.5 * (a_s * a_s + a_p * a_p);
}

// Conductor Fresnel reflectance per channel (complex IOR eta + i k).
fn bsdf_fresnel_conductor(cos_theta_i: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let cos_theta_i_2 = cos_theta_i * cos_theta_i;
    let sin_theta_i_2 = 1.0 - cos_theta_i_2;
    let sin_theta_i_4 = sin_theta_i_2 * sin_theta_i_2;
    let temp_1 = eta * eta - k * k - sin_theta_i_2;
    let a_2_pb_2 = sqrt(max(temp_1 * temp_1 + 4.0 * k * k * eta * eta, vec3<f32>(0.0)));
    let a = sqrt(max(0.5 * (a_2_pb_2 + temp_1), vec3<f32>(0.0)));
    let term_1 = a_2_pb_2 + cos_theta_i_2;
    let term_2 = 2.0 * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a_2_pb_2 * cos_theta_i_2 + sin_theta_i_4;
    let term_4 = term_2 * sin_theta_i_2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    return 0.5 * (r_s + r_p);
}

// Mitsuba's roughdielectric eval in radiance mode (reflection and transmission, both sides; twin of
// `shading::bsdf::roughdielectric_eval(.., true)`): eta = (eta, 1/eta) in b.eta.xy, specular_transmittance in b.k.
fn bsdf_roughdielectric_eval(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let cos_i = wi.z;
    let cos_o = wo.z;
    if cos_i == 0.0 {
        return vec3<f32>(0.0);
    }
    let reflect = cos_i * cos_o > 0.0;
    let front = cos_i > 0.0;
    let eta = select(b.eta.y, b.eta.x, front);
    let inv_eta = select(b.eta.x, b.eta.y, front);
    var m = normalize(wi + wo * select(eta, 1.0, reflect));
    if (bitcast<u32>(m.z) & 0x80000000u) != 0u {
        m = -m;
    }
    let ggx = (b.flags & BSDF_FLAG_GGX) != 0u;
    let d = bsdf_microfacet_d(ggx, b.alpha_u, b.alpha_v, m);
    let wi_m = dot(wi, m);
    let wo_m = dot(wo, m);
    let f = bsdf_fresnel_fused(wi_m, b.eta.x);
    let g = bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wi, m) * bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wo, m);
    if reflect {
        return b.specular * (f * d * g / (4.0 * abs(cos_i)));
    }
    let denom = wi_m + eta * wo_m;
    let value = abs((inv_eta * inv_eta * (1.0 - f) * d * g * eta * eta * wi_m * wo_m) / (cos_i * (denom * denom)));
    return b.k * value;
}

// Mitsuba's lerp_gather over the 64-entry table starting at `offset`.
fn bsdf_lerp_gather(offset: u32, x_in: f32) -> f32 {
    let x = x_in * f32(BSDF_TABLE_RES - 1u);
    let index = min(u32(x), BSDF_TABLE_RES - 2u);
    let v0 = bsdf_table(offset + index);
    let v1 = bsdf_table(offset + index + 1u);
    let t = x - f32(index);
    return fma(v1, t, fma(-v0, t, v0));
}

// f(wi, wo) |cos theta_o| in the local shading frame (wi toward the viewer, wo toward the light); a
// blendbsdf's first record adds its second, bsdf_record(bits of extra.w), with weight extra.z.
fn bsdf_eval(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let v0 = bsdf_eval_lobe(b, wi, wo);
    if (b.flags & BSDF_FLAG_BLEND) == 0u {
        return v0;
    }
    let w = b.extra.z;
    let v1 = bsdf_eval_lobe(bsdf_record(bitcast<u32>(b.extra.w)), wi, wo);
    return v0 * (1.0 - w) + v1 * w;
}

// Mitsuba's coordinate_system(n): the s and t axes completing unit n (twin of `lights::coordinate_system`).
fn bsdf_frame_s(n: vec3<f32>) -> vec3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
}

fn bsdf_frame_t(n: vec3<f32>) -> vec3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sign + n.y * n.y * a, -n.y);
}

// The perturbed normal of a bumpmap / normalmap record (`shading::perturb::normal`).
fn bsdf_bump_normal(b: Bsdf) -> vec3<f32> {
    if b.kind == BSDF_KIND_PLASTIC || b.kind == BSDF_KIND_ROUGHPLASTIC {
        return b.k;
    }
    return b.extra.yzw;
}

fn bsdf_tan_theta_2(v: vec3<f32>) -> f32 {
    let c2 = v.z * v.z;
    return max(1.0 - c2, 0.0) / c2;
}

// One record's lobe; a bumpmap / normalmap record (or a twosided around one) as `shading::perturb::eval`.
fn bsdf_eval_lobe(b: Bsdf, wi_in: vec3<f32>, wo_in: vec3<f32>) -> vec3<f32> {
    if (b.flags & (BSDF_FLAG_BUMP | BSDF_FLAG_TWOSIDED_OUTER)) == 0u {
        return bsdf_eval_plain(b, wi_in, wo_in);
    }
    var wi = wi_in;
    var wo = wo_in;
    if (b.flags & BSDF_FLAG_TWOSIDED_OUTER) != 0u && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    var inner = b;
    inner.flags = b.flags & ~(BSDF_FLAG_BUMP | BSDF_FLAG_TWOSIDED_OUTER);
    if (b.flags & BSDF_FLAG_BUMP) == 0u {
        return bsdf_eval_plain(inner, wi, wo);
    }
    var n = bsdf_bump_normal(b);
    if wi.z * dot(wi, n) <= 0.0 {
        n = vec3<f32>(-n.x, -n.y, n.z);
    }
    if !positive(wo.z * dot(wo, n)) {
        return vec3<f32>(0.0);
    }
    let s = bsdf_frame_s(n);
    let t = bsdf_frame_t(n);
    let wi_p = vec3<f32>(dot(wi, s), dot(wi, t), dot(wi, n));
    let wo_p = vec3<f32>(dot(wo, s), dot(wo, t), dot(wo, n));
    let alpha2 = min(0.125 * bsdf_tan_theta_2(n), 1.0);
    let shadow = 2.0 / (1.0 + sqrt(1.0 + alpha2 * bsdf_tan_theta_2(wo)));
    return bsdf_eval_plain(inner, wi_p, wo_p) * shadow;
}

// A VPL's BSDF, light arriving along `incident` and leaving toward `out` (`shading::perturb::adjoint_eval`).
fn bsdf_adjoint_eval(b: Bsdf, incident: vec3<f32>, out: vec3<f32>) -> vec3<f32> {
    if (b.flags & BSDF_FLAG_BUMP) == 0u {
        return bsdf_eval(b, incident, out);
    }
    if incident.z == 0.0 {
        return vec3<f32>(0.0);
    }
    return bsdf_eval_lobe(b, out, incident) * (abs(out.z) / abs(incident.z));
}

// One record's lobe without a perturbation.
fn bsdf_eval_plain(b: Bsdf, wi_in: vec3<f32>, wo_in: vec3<f32>) -> vec3<f32> {
    var wi = wi_in;
    var wo = wo_in;
    if (b.flags & BSDF_FLAG_TWOSIDED) != 0u && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if b.kind == BSDF_KIND_PRINCIPLED {
        return bsdf_principled_eval(b, wi, wo);
    }
    if b.kind == BSDF_KIND_ROUGHDIELECTRIC {
        return bsdf_roughdielectric_eval(b, wi, wo);
    }
    let cos_i = wi.z;
    let cos_o = wo.z;
    if !(positive(cos_i) && positive(cos_o)) {
        return vec3<f32>(0.0);
    }
    let nonlinear = (b.flags & BSDF_FLAG_NONLINEAR) != 0u;
    let ggx = (b.flags & BSDF_FLAG_GGX) != 0u;
    switch b.kind {
        case BSDF_KIND_DIFFUSE: {
            return b.diffuse * BSDF_INV_PI * cos_o;
        }
        case BSDF_KIND_PLASTIC: {
            let f_i = bsdf_fresnel(cos_i, b.eta.x);
            let f_o = bsdf_fresnel(cos_o, b.eta.x);
            let fdr_int = b.extra.x;
            let diff = b.diffuse / (vec3<f32>(1.0) - select(vec3<f32>(fdr_int), b.diffuse * fdr_int, nonlinear));
            return diff * (BSDF_INV_PI * cos_o * b.eta.y * (1.0 - f_i) * (1.0 - f_o));
        }
        case BSDF_KIND_ROUGHPLASTIC: {
            let h = normalize(wo + wi);
            let d = bsdf_microfacet_d(ggx, b.alpha_u, b.alpha_v, h);
            let f = bsdf_fresnel(dot(wi, h), b.eta.x);
            let g = bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wi, h) * bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wo, h);
            let spec = b.specular * (f * d * g / (4.0 * cos_i));
            let offset = bitcast<u32>(b.extra.y);
            let t_i = bsdf_lerp_gather(offset, cos_i);
            let t_o = bsdf_lerp_gather(offset, cos_o);
            let internal = b.extra.x;
            let diff = b.diffuse / (vec3<f32>(1.0) - select(vec3<f32>(internal), b.diffuse * internal, nonlinear));
            return spec + diff * (BSDF_INV_PI * b.eta.y * cos_o * t_i * t_o);
        }
        case BSDF_KIND_ROUGHCONDUCTOR: {
            let h = normalize(wo + wi);
            let d = bsdf_microfacet_d(ggx, b.alpha_u, b.alpha_v, h);
            if d == 0.0 {
                return vec3<f32>(0.0);
            }
            let g = bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wi, h) * bsdf_smith_g1(ggx, b.alpha_u, b.alpha_v, wo, h);
            let value = d * g / (4.0 * cos_i);
            return bsdf_fresnel_conductor(dot(wi, h), b.eta, b.k) * (vec3<f32>(value) * b.specular);
        }
        default: {
            return vec3<f32>(0.0);
        }
    }
}
