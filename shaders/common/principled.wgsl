// Mitsuba 3.9.1's `principled` BSDF (radiance mode); twin of src/shading/principled.rs (field use
// documented there). Needs common/bsdf.wgsl (bsdf_microfacet_d, bsdf_smith_g1, bsdf_fresnel); called
// by bsdf_eval for BSDF_KIND_PRINCIPLED.

const BSDF_KIND_PRINCIPLED: u32 = 6u;

// drjit's lerp(a, b, t) = fmadd(b, t, fnmadd(a, t, a)).
fn pr_lerp(a: f32, b: f32, t: f32) -> f32 {
    return fma(b, t, fma(-a, t, a));
}

fn pr_lerp3(a: vec3<f32>, b: vec3<f32>, t: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(pr_lerp(a.x, b.x, t.x), pr_lerp(a.y, b.y, t.y), pr_lerp(a.z, b.z, t.z));
}

// Mitsuba's luminance weights.
fn pr_luminance(c: vec3<f32>) -> f32 {
    return c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169;
}

fn pr_schlick_weight(cos_i: f32) -> f32 {
    let m = clamp(1.0 - cos_i, 0.0, 1.0);
    return (m * m) * (m * m) * m;
}

fn pr_calc_schlick(r0: vec3<f32>, cos_theta_i: f32, eta: f32) -> vec3<f32> {
    let outside = cos_theta_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let eta_it = select(rcp_eta, eta, outside);
    let eta_ti = select(eta, rcp_eta, outside);
    let cos_theta_t_sqr = fma(-fma(-cos_theta_i, cos_theta_i, 1.0), eta_ti * eta_ti, 1.0);
    let cos_theta_t = sqrt(max(cos_theta_t_sqr, 0.0));
    let w = select(pr_schlick_weight(cos_theta_t), pr_schlick_weight(abs(cos_theta_i)), eta_it > 1.0);
    return pr_lerp3(vec3<f32>(w), vec3<f32>(1.0), r0);
}

fn pr_gtr1_d(alpha: f32, m: vec3<f32>) -> f32 {
    let cos_theta = m.z;
    let alpha2 = alpha * alpha;
    let result = (alpha2 - 1.0) / (BSDF_PI * log(alpha2) * (1.0 + (alpha2 - 1.0) * cos_theta * cos_theta));
    return select(0.0, result, result * cos_theta > 1e-20);
}

fn pr_smith_ggx1(v: vec3<f32>, wh: vec3<f32>, alpha: f32) -> f32 {
    let alpha_2 = alpha * alpha;
    let cos_theta = abs(v.z);
    let cos_theta_2 = cos_theta * cos_theta;
    let tan_theta_2 = (1.0 - cos_theta_2) / cos_theta_2;
    var result = 2.0 / (1.0 + sqrt(1.0 + alpha_2 * tan_theta_2));
    if v.z == 1.0 {
        result = 1.0;
    }
    if dot(v, wh) * v.z <= 0.0 {
        result = 0.0;
    }
    return result;
}

// x times the sign (bit) of y, as drjit's mulsign.
fn pr_mulsign(x: vec3<f32>, y: f32) -> vec3<f32> {
    return select(x, -x, (bitcast<u32>(y) & 0x80000000u) != 0u);
}

// f(wi, wo) |cos theta_o| of a principled record (wi, wo local; twosided already applied by the caller).
fn bsdf_principled_eval(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let base = b.diffuse;
    let metallic = b.specular.x;
    let spec_tint = b.specular.y;
    let spec_trans = b.specular.z;
    let eta = b.eta.x;
    let sheen = b.eta.y;
    let sheen_tint = b.eta.z;
    let clearcoat = b.k.x;
    let clearcoat_gloss = b.k.y;
    let flatness = b.k.z;
    let roughness = b.extra.x;
    let cos_theta_i = wi.z;
    if cos_theta_i == 0.0 {
        return vec3<f32>(0.0);
    }
    let brdf = (1.0 - metallic) * (1.0 - spec_trans);
    let bsdf = (1.0 - metallic) * spec_trans;
    let cos_theta_o = wo.z;
    let reflect = cos_theta_i * cos_theta_o > 0.0;
    let refract = cos_theta_i * cos_theta_o < 0.0;
    let front_side = cos_theta_i > 0.0;
    let inv_eta = 1.0 / eta;
    let eta_path = select(inv_eta, eta, front_side);
    let inv_eta_path = select(eta, inv_eta, front_side);
    var wh = normalize(wi + wo * select(eta_path, 1.0, reflect));
    wh = pr_mulsign(wh, wh.z);
    let wi_h = dot(wi, wh);
    let f_dielectric = bsdf_fresnel(wi_h, eta);
    let m = pr_mulsign(wh, cos_theta_i);
    let reflection_compatible = dot(wi, m) > 0.0 && dot(wo, m) > 0.0;
    let refraction_compatible = dot(wi, m) > 0.0 && dot(wo, -m) > 0.0;
    let spec_reflect_active = reflect && reflection_compatible && f_dielectric > 0.0;
    let clearcoat_active = clearcoat > 0.0 && reflect && reflection_compatible && front_side;
    let spec_trans_active = bsdf > 0.0 && refract && refraction_compatible && f_dielectric < 1.0;
    let diffuse_active = brdf > 0.0 && reflect && front_side;
    let sheen_active = sheen > 0.0 && reflect && 1.0 - metallic > 0.0 && front_side;
    let d = bsdf_microfacet_d(true, b.alpha_u, b.alpha_v, wh);
    let g = bsdf_smith_g1(true, b.alpha_u, b.alpha_v, wi, wh) * bsdf_smith_g1(true, b.alpha_u, b.alpha_v, wo, wh);
    let lum = pr_luminance(base);
    let c_tint = select(vec3<f32>(1.0), base / lum, lum > 0.0);
    var value = vec3<f32>(0.0);
    if spec_reflect_active {
        var f: vec3<f32>;
        if front_side {
            let eta_it = select(1.0 / eta, eta, wi_h >= 0.0);
            var f_schlick = vec3<f32>(0.0);
            if metallic != 0.0 {
                f_schlick += metallic * pr_calc_schlick(base, wi_h, eta);
            }
            if spec_tint != 0.0 {
                let r = (eta_it - 1.0) / (eta_it + 1.0);
                f_schlick += (1.0 - metallic) * spec_tint * pr_calc_schlick(c_tint * (r * r), wi_h, eta);
            }
            f = vec3<f32>((1.0 - metallic) * (1.0 - spec_tint) * f_dielectric) + f_schlick;
        } else {
            f = vec3<f32>(bsdf * f_dielectric);
        }
        value += f * (d * g / (4.0 * abs(cos_theta_i)));
    }
    if spec_trans_active {
        let scale = inv_eta_path * inv_eta_path;
        let wo_h = dot(wo, wh);
        let denom = wi_h + eta_path * wo_h;
        let t = (scale * (1.0 - f_dielectric) * d * g * eta_path * eta_path * wi_h * wo_h) / (cos_theta_i * (denom * denom));
        value += sqrt(base) * bsdf * abs(t);
    }
    if clearcoat_active {
        let fcc = pr_calc_schlick(vec3<f32>(0.04), wi_h, eta).x;
        let dcc = pr_gtr1_d(pr_lerp(0.1, 0.001, clearcoat_gloss), wh);
        let gcc = pr_smith_ggx1(wi, wh, 0.25) * pr_smith_ggx1(wo, wh, 0.25);
        value += vec3<f32>((clearcoat * 0.25) * fcc * dcc * gcc * abs(cos_theta_o));
    }
    if diffuse_active {
        let fo = pr_schlick_weight(abs(cos_theta_o));
        let fi = pr_schlick_weight(abs(cos_theta_i));
        let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
        let cos_theta_d = dot(wh, wo);
        let rr = 2.0 * roughness * (cos_theta_d * cos_theta_d);
        let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
        var lobe = f_diff + f_retro;
        if flatness != 0.0 {
            let fss90 = rr / 2.0;
            let fss = pr_lerp(1.0, fss90, fo) * pr_lerp(1.0, fss90, fi);
            let f_ss = 1.25 * (fss * (1.0 / (abs(cos_theta_o) + abs(cos_theta_i)) - 0.5) + 0.5);
            lobe = pr_lerp(f_diff + f_retro, f_ss, flatness);
        }
        value += brdf * abs(cos_theta_o) * base * BSDF_INV_PI * lobe;
        if sheen_active {
            let fd = pr_schlick_weight(abs(cos_theta_d));
            let c_sheen = pr_lerp3(vec3<f32>(1.0), c_tint, vec3<f32>(sheen_tint));
            value += sheen * (1.0 - metallic) * fd * c_sheen * abs(cos_theta_o);
        }
    }
    return value;
}
