// Masked surfaces (Mitsuba's `mask` BSDF): the WGSL twin of src/raytrace/mask.rs
// (`RayTracer::mask_transmittance_crossed`, `direct_factor`, with `cpu::mask_visibility_at`'s choice
// of which lights cross masks) over the mask table of src/gpu/mask.rs (layout there). Needs, declared by
// the including module, `masks: array<u32>` (storage, read), and common/bsdf.wgsl, common/light.wgsl,
// common/bvh.wgsl, common/view_sample.wgsl and common/visibility.wgsl (its ray counters).

// Keep in sync with src/gpu/mask.rs.
const MASK_NONE: u32 = 0xffffffffu;
const MASK_CONSTANT: u32 = 0xffffffffu;
const MASK_MESH_HEADER: u32 = 4u;
const MASK_TEXTURE_HEADER: u32 = 16u;
const MASK_MAX_CROSSINGS: u32 = 1024u;
const MASK_PI: f32 = 3.14159265358979;

fn mask_f(k: u32) -> f32 {
    return bitcast<f32>(masks[k]);
}

fn mask_texel(o: u32, w: i32, x: i32, y: i32) -> vec3<f32> {
    let k = o + MASK_TEXTURE_HEADER + 3u * u32(y * w + x);
    return vec3<f32>(mask_f(k), mask_f(k + 1u), mask_f(k + 2u));
}

// Mitsuba's `eval_1` of the texture record at o at surface uv (`scene::texture::eval_1`): a bitmap's
// luminance after its bilinear or nearest lookup, a checkerboard's stored channel means.
fn mask_texture_eval_1(o: u32, uv_in: vec2<f32>) -> f32 {
    let c0 = vec2<f32>(mask_f(o + 5u), mask_f(o + 6u));
    let c1 = vec2<f32>(mask_f(o + 8u), mask_f(o + 9u));
    let c2 = vec2<f32>(mask_f(o + 11u), mask_f(o + 12u));
    let uv = c0 * uv_in.x + c1 * uv_in.y + c2;
    if masks[o] == 1u {
        // Checkerboard: `eval` picks color0 where both fractional parts agree on > 1/2.
        let a = (uv.x - floor(uv.x)) > 0.5;
        let b = (uv.y - floor(uv.y)) > 0.5;
        return select(mask_f(o + MASK_TEXTURE_HEADER + 1u), mask_f(o + MASK_TEXTURE_HEADER), a == b);
    }
    let w = i32(masks[o + 1u]);
    let t = tex_taps(uv, w, i32(masks[o + 2u]), masks[o + 3u], masks[o + 4u] != 0u);
    let c = mask_texel(o, w, t.x0, t.y0) * t.w.x + mask_texel(o, w, t.x1, t.y0) * t.w.y
        + mask_texel(o, w, t.x0, t.y1) * t.w.z + mask_texel(o, w, t.x1, t.y1) * t.w.w;
    return c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169;
}

// A masked surface hit by a shadow ray: where it was hit, its geometric normal and its opacity.
struct MaskHit {
    p: vec3<f32>,
    n_g: vec3<f32>,
    opacity: f32,
}

// The surface of closest hit `hit` (status BVH_BLOCKED) on o + t d, whose primitive is masked
// (`RayTracer::intersect`'s position, normal and uv; `raytrace::mask::eval_opacity`).
fn mask_hit(hit: BvhHit, o: vec3<f32>, d: vec3<f32>) -> MaskHit {
    let prim = bvh_prims[hit.prim];
    let rec = prim.mask;
    var out: MaskHit;
    var uv = vec2<f32>(hit.b1, hit.b2);
    if prim.kind == PRIM_SPHERE {
        let local = normalize(o + d * hit.t - prim.v0);
        out.p = prim.v0 + local * prim.v1.x;
        out.n_g = local;
        let theta = acos(clamp(local.z, -1.0, 1.0));
        var phi = atan2(local.y, local.x);
        if phi < 0.0 {
            phi = phi + 2.0 * MASK_PI;
        }
        uv = vec2<f32>(phi * (0.5 / MASK_PI), theta * (1.0 / MASK_PI));
    } else {
        let b0 = 1.0 - hit.b1 - hit.b2;
        out.p = prim.v0 * b0 + prim.v1 * hit.b1 + prim.v2 * hit.b2;
        out.n_g = normalize(cross(prim.v1 - prim.v0, prim.v2 - prim.v0));
        if masks[rec + 2u] != 0u {
            let k = rec + MASK_MESH_HEADER + 6u * prim.index;
            let uv0 = vec2<f32>(mask_f(k), mask_f(k + 1u));
            let uv1 = vec2<f32>(mask_f(k + 2u), mask_f(k + 3u));
            let uv2 = vec2<f32>(mask_f(k + 4u), mask_f(k + 5u));
            uv = uv0 * b0 + uv1 * hit.b1 + uv2 * hit.b2;
        }
    }
    let source = masks[rec];
    if source == MASK_CONSTANT {
        out.opacity = mask_f(rec + 1u);
    } else {
        let a = mask_texture_eval_1(source, uv);
        out.opacity = select(clamp(a, 0.0, 1.0), 0.0, is_nan_f32(a));
    }
    return out;
}

// The mask budget of view sample s (its shadow rays cross at most this many masked surfaces).
fn mask_budget(s: ViewSample) -> u32 {
    return s.flags >> VIEW_MASK_BUDGET_SHIFT;
}

// The depth d of VPL l (src/gpu/mask.rs `light_fields`: 1 + d in its mask field), 0 for other lights.
fn mask_vpl_depth(l: Light) -> u32 {
    let w = l.patch_corners[2].w;
    return select(0u, u32(w + 0.5) - 1u, w > 1.5);
}

// Whether VPL l cannot light view sample s at all in a scene with masked surfaces: the sample's budget
// is below the VPL's depth, so the VPL's path back to the light would pass Mitsuba's max_depth
// (src/cpu/mod.rs `mask_visibility_at`).
fn mask_vpl_out_of_depth(s: ViewSample, l: Light) -> bool {
    return (s.flags & VIEW_FLAG_MASKS) != 0u && mask_budget(s) < mask_vpl_depth(l);
}

// How many masked surfaces the shadow ray from view sample s toward light l may cross
// (src/cpu/mod.rs `mask_visibility_at`; src/gpu/mask.rs `light_fields`): 0 for lights whose rays masks
// block, the sample's budget less its depth for a VPL (0 when out of depth: `mask_vpl_out_of_depth`),
// else the budget.
fn mask_light_budget(s: ViewSample, l: Light) -> u32 {
    let kind = l.patch_corners[2].w;
    let budget = mask_budget(s);
    if kind == 0.0 {
        return 0u;
    }
    let depth = mask_vpl_depth(l);
    return select(0u, budget - depth, budget >= depth);
}

// Expected transmittance of the shadow ray from surface point p (geometric normal n_g) toward light l
// (direction wo; unbounded for a directional light) that may cross `budget` masked surfaces, and 1 in
// y when it crossed one (`RayTracer::mask_transmittance_crossed`): prod(1 - opacity) over the masked
// surfaces crossed, 0 past an opaque surface or more than `budget` masked ones. Each crossing continues
// from the hit with Mitsuba's offsets. `fallback` when the BVH step budget runs out (counted).
fn mask_transmittance(p: vec3<f32>, n_g: vec3<f32>, l: Light, wo: vec3<f32>, budget: u32, fallback: f32) -> vec2<f32> {
    count_rays = count_rays + 1u;
    let finite = l.kind != LIGHT_DIRECTIONAL;
    var o = offset_p(p, n_g, wo);
    var dir = wo;
    var t_max = BVH_T_INF;
    if finite {
        o = offset_p(p, n_g, l.position - p);
        let d = l.position - o;
        let dist = length(d);
        dir = d / dist;
        t_max = dist * (1.0 - SHADOW_EPSILON);
    }
    var tr = 1.0;
    var left = budget;
    for (var k = 0u; k < MASK_MAX_CROSSINGS; k = k + 1u) {
        let hit = trace_closest(o, dir, t_max);
        if hit.status == BVH_GAVE_UP {
            count_gave_up = count_gave_up + 1u;
            return vec2<f32>(fallback, 0.0);
        }
        if hit.status == BVH_FREE {
            return vec2<f32>(tr, select(0.0, 1.0, left != budget));
        }
        if bvh_prims[hit.prim].mask == MASK_NONE || left == 0u {
            return vec2<f32>(0.0);
        }
        let h = mask_hit(hit, o, dir);
        left = left - 1u;
        tr = tr * (1.0 - h.opacity);
        if tr <= 0.0 {
            return vec2<f32>(0.0);
        }
        if finite {
            o = offset_p(h.p, h.n_g, l.position - h.p);
            let d = l.position - o;
            let dist = length(d);
            dir = d / dist;
            t_max = dist * (1.0 - SHADOW_EPSILON);
        } else {
            o = offset_p(h.p, h.n_g, dir);
        }
    }
    return vec2<f32>(0.0);
}

fn mask_mean(v: vec3<f32>) -> f32 {
    return (v.x + v.y + v.z) / 3.0;
}

// `pdf_roughdielectric` of lights::generate::sampling: the microfacet lobe's reflection or refraction
// density toward wo.
fn mask_pdf_roughdielectric(b: Bsdf, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if wi.z == 0.0 || wo.z == 0.0 {
        return 0.0;
    }
    let ggx = (b.flags & BSDF_FLAG_GGX) != 0u;
    let alpha = sqrt(b.alpha_u * b.alpha_v);
    let reflect = wi.z * wo.z > 0.0;
    let eta = select(b.eta.y, b.eta.x, wi.z > 0.0);
    var h = normalize(wi + wo * select(eta, 1.0, reflect));
    if h.z < 0.0 {
        h = -h;
    }
    let wi_h = dot(wi, h);
    let wo_h = dot(wo, h);
    if !positive(wi_h * wi.z) || (reflect && wo_h * wi_h <= 0.0) || (!reflect && wo_h * wi_h >= 0.0) {
        return 0.0;
    }
    let d = bsdf_microfacet_d(ggx, alpha, alpha, h) * h.z;
    let f = bsdf_fresnel(wi_h, b.eta.x);
    if reflect {
        return d * f / (4.0 * abs(wo_h));
    }
    let denom = wi_h + eta * wo_h;
    return d * (1.0 - f) * eta * eta * abs(wo_h) / (denom * denom);
}

// The density with which this crate's BSDF sampling returns wo (`lights::generate::sampling::pdf_bsdf`)
// for the records a mask can hold (bump and normal maps inside a mask are refused by the loader);
// principled records are 0, as there.
fn mask_pdf_bsdf(b: Bsdf, wi_in: vec3<f32>, wo_in: vec3<f32>) -> f32 {
    if b.kind == BSDF_KIND_ROUGHDIELECTRIC {
        return mask_pdf_roughdielectric(b, wi_in, wo_in);
    }
    var wi = wi_in;
    var wo = wo_in;
    if (b.flags & BSDF_FLAG_TWOSIDED) != 0u && wi.z < 0.0 {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if !(positive(wi.z) && positive(wo.z)) {
        return 0.0;
    }
    if b.kind == BSDF_KIND_DIFFUSE {
        return wo.z / MASK_PI;
    }
    if b.kind == BSDF_KIND_PLASTIC {
        let f = bsdf_fresnel(wi.z, b.eta.x);
        let sm = f * mask_mean(b.specular);
        let dm = (1.0 - f) * mask_mean(b.diffuse);
        let p_spec = select(0.0, sm / (sm + dm), sm + dm > 0.0);
        return (1.0 - p_spec) * wo.z / MASK_PI;
    }
    if b.kind == BSDF_KIND_ROUGHPLASTIC || b.kind == BSDF_KIND_ROUGHCONDUCTOR {
        let ggx = (b.flags & BSDF_FLAG_GGX) != 0u;
        let alpha = sqrt(b.alpha_u * b.alpha_v);
        var p_spec = 0.9;
        if b.kind != BSDF_KIND_ROUGHCONDUCTOR {
            let f = bsdf_fresnel(wi.z, b.eta.x);
            let sm = f * mask_mean(b.specular);
            let dm = (1.0 - f) * mask_mean(b.diffuse);
            p_spec = select(0.5, clamp(sm / (sm + dm), 0.1, 0.9), sm + dm > 0.0);
        }
        let h = normalize(wi + wo);
        let pdf_spec = bsdf_microfacet_d(ggx, alpha, alpha, h) * h.z / (4.0 * abs(dot(wo, h)));
        return p_spec * pdf_spec + (1.0 - p_spec) * wo.z / MASK_PI;
    }
    return 0.0;
}

// The factor on light l's direct contribution to masked view sample s (record b) whose P_valid is below
// 1 (`raytrace::mask::direct_factor`): P + (1 - P) w_B, w_B the power heuristic of BSDF sampling against
// Mitsuba's emitter sampling for an area light sample (its mesh's area density in patch_corners[1].w),
// 0 for every other light.
fn mask_direct_factor(s: ViewSample, b: Bsdf, l: Light, wi_local: vec3<f32>, wo_local: vec3<f32>) -> f32 {
    let valid = s.mask_valid;
    var w_b = 0.0;
    if l.kind == LIGHT_ORIENTED_POINT {
        let pa = l.patch_corners[1].w;
        let d = l.position - s.position;
        let dist2 = dot(d, d);
        let cos_l = -dot(d, l.normal) / sqrt(dist2);
        if pa > 0.0 && cos_l > 0.0 {
            let p_l = pa * dist2 / cos_l;
            let p_b = s.mask_opacity * mask_pdf_bsdf(b, wi_local, wo_local);
            let b2 = p_b * p_b;
            let l2 = p_l * p_l;
            if b2 + l2 > 0.0 {
                let q = b2 / (b2 + l2);
                if !is_nan_f32(q) && abs(q) <= 3.4e38 {
                    w_b = q;
                }
            }
        }
    }
    return valid + (1.0 - valid) * w_b;
}
