// Glossy MIS: the light-strategy weight w_L of a glossy view sample, the WGSL twin of
// src/matrix/glossy.rs (`light_weight`, `strategy_pdf`, `bsdf_pdf`). Needs common/bsdf.wgsl (and its
// `bsdf_record`, which a blendbsdf's second record comes from) and common/light.wgsl. A light's sampling
// measure (`LightSet::mis_measure`: stratum area or solid angle, 0 = no MIS) travels in patch_corners[0].w;
// a view sample's n_B in `ViewSample::bsdf_samples`.

// p_B(wo) of one rough lobe (roughplastic / roughconductor / principled record): D(h) cos_h / (4 |wo . h|) (0 where it
// samples nothing). Twin of `bsdf_pdf` in glossy.rs.
fn glossy_lobe_pdf(b: Bsdf, wi_in: vec3<f32>, wo_in: vec3<f32>) -> f32 {
    var wi = wi_in;
    var wo = wo_in;
    if (b.flags & BSDF_FLAG_TWOSIDED) != 0u && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if !(positive(wi.z) && positive(wo.z)) {
        return 0.0;
    }
    let alpha = sqrt(b.alpha_u * b.alpha_v);
    let h = normalize(wi + wo);
    let ggx = (b.flags & BSDF_FLAG_GGX) != 0u || b.kind == BSDF_KIND_PRINCIPLED;
    return bsdf_microfacet_d(ggx, alpha, alpha, h) * h.z / (4.0 * abs(dot(wo, h)));
}

// Whether the BSDF strategy samples record b's lobe (`lobe_alpha` in glossy.rs): roughplastic, roughconductor,
// principled (its GGX specular lobe).
fn glossy_is_rough(b: Bsdf) -> bool {
    return b.kind == BSDF_KIND_ROUGHPLASTIC || b.kind == BSDF_KIND_ROUGHCONDUCTOR || b.kind == BSDF_KIND_PRINCIPLED;
}

// p_B(wo): the density of the BSDF strategy (`strategy_pdf` in glossy.rs): one rough record's lobe pdf; for a
// blendbsdf the mixture of its rough records' lobe pdfs, weighted by their blend weights (1 - w, w)
// renormalised over the rough ones (0 when neither is rough).
fn glossy_bsdf_pdf(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (b.flags & BSDF_FLAG_BLEND) == 0u {
        return glossy_lobe_pdf(b, wi, wo);
    }
    let w = b.extra.z;
    let b1 = bsdf_record(bitcast<u32>(b.extra.w));
    let p0 = select(0.0, 1.0 - w, glossy_is_rough(b) && 1.0 - w > 0.0);
    let p1 = select(0.0, w, glossy_is_rough(b1) && w > 0.0);
    let total = p0 + p1;
    if !positive(total) {
        return 0.0;
    }
    var pdf = 0.0;
    if p0 > 0.0 {
        pdf = pdf + (p0 / total) * glossy_lobe_pdf(b, wi, wo);
    }
    if p1 > 0.0 {
        pdf = pdf + (p1 / total) * glossy_lobe_pdf(b1, wi, wo);
    }
    return pdf;
}

// w_L = q_L^2 / (q_L^2 + (n_B p_B)^2) of light l at a view sample at p with n_B BSDF samples (1 when n_B = 0
// or the light has no MIS measure).
fn glossy_light_weight(b: Bsdf, n_b: u32, l: Light, p: vec3<f32>, wi_local: vec3<f32>, wo_local: vec3<f32>) -> f32 {
    let measure = l.patch_corners[0].w;
    if n_b == 0u || !positive(measure) {
        return 1.0;
    }
    var q = 0.0;
    if l.kind == LIGHT_DIRECTIONAL {
        q = 1.0 / measure;
    } else if l.kind == LIGHT_ORIENTED_POINT {
        let d = l.position - p;
        let dist2 = dot(d, d);
        let cos_l = -dot(d, l.normal) / sqrt(dist2);
        if !positive(cos_l) {
            return 1.0;
        }
        q = dist2 / (measure * cos_l);
    } else {
        return 1.0;
    }
    let pb = f32(n_b) * glossy_bsdf_pdf(b, wi_local, wo_local);
    // The power heuristic (exponent 2), as `power_heuristic` in glossy.rs.
    let q2 = q * q;
    let sum = q2 + pb * pb;
    return select(0.0, q2 / sum, sum > 0.0);
}
