// Point-like lights: point, spot, directional (as Mitsuba 3.9.1 evaluates them), oriented points (area
// light samples) and VPLs; twin of `LightSet::emitted` in src/lights/mod.rs (formulas documented there).
// Needs common/bsdf.wgsl and a `spot_textures: array<f32>` binding (a VPL's BSDF is evaluated with bsdf_eval); used by shaders/columns.wgsl.

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
const LIGHT_ORIENTED_POINT: u32 = 3u;
const LIGHT_VPL: u32 = 4u;

// Keep in sync with `GpuLight` in src/gpu/columns.rs (256 bytes).
struct Light {
    position: vec3<f32>,
    kind: u32,
    // Spot axis, or the travel direction of a directional light (unit).
    direction: vec3<f32>,
    // First layer of this light's shadow map(s) in the batch's depth array (6 for a cube).
    first_layer: u32,
    // I (W/sr) or E (W/m^2).
    intensity: vec3<f32>,
    cos_cutoff: f32,
    // Spot: cutoff angle (radians); VPL: its virtual-spherical-light radius (m; 0 = a point VPL).
    cutoff_angle: f32,
    cos_beam: f32,
    // 1 / (cutoff_angle - beam_width), 0 when they are equal.
    inv_transition: f32,
    // 1 when the light's shadow map is a cube (6 layers), 0 for one layer.
    is_cube: u32,
    // Oriented point: emission normal; VPL: shading normal n_s.
    normal: vec3<f32>,
    // VPL geometry-term clamp (1/m^2; a huge value = none).
    clamp: f32,
    // VPL: geometric normal n_g.
    geo_normal: vec3<f32>,
    // Spot: offset of its projected texture's record in `spot_textures` (SPOT_NO_TEXTURE: none); a
    // textured spot's local x and y axes are in `normal` and `geo_normal`.
    tex_offset: u32,
    // VPL: unit direction toward where its particle came from.
    incident: vec3<f32>,
    // Textured spot: tan(cutoff_angle).
    tan_cutoff: f32,
    // VPL: the BSDF at its hit (zero for other kinds).
    bsdf: Bsdf,
    // Oriented point: its patch's 4 corners (xyz; all zero = none), src/lights/patch.rs.
    patch_corners: array<vec4<f32>, 4>,
}

const SPOT_NO_TEXTURE: u32 = 0xffffffffu;

// Dr.Jit's tex_wrap (twin of `wrap` in src/scene/texture.rs): 0 repeat, 1 mirror, 2 clamp.
fn spot_tex_wrap(i: i32, res: i32, mode: u32) -> i32 {
    if mode == 2u {
        return clamp(i, 0, res - 1);
    }
    if mode == 1u {
        let m = ((i % (2 * res)) + 2 * res) % (2 * res);
        return select(2 * res - 1 - m, m, m < res);
    }
    return ((i % res) + res) % res;
}

// The texels a bitmap lookup at uv reads and their weights (Mitsuba's bilinear filter: texel centres at
// half-integers; nearest: the texel under uv, weight 1), wrapped by `spot_tex_wrap`; shared by the spot
// textures and the mask opacities (`mask.wgsl`), which fetch the texels from their own buffers.
struct TexTaps {
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
    w: vec4<f32>,
}

fn tex_taps(uv: vec2<f32>, w: i32, h: i32, mode: u32, nearest: bool) -> TexTaps {
    let wf = f32(w);
    let hf = f32(h);
    if nearest {
        let x = spot_tex_wrap(i32(floor(uv.x * wf)), w, mode);
        let y = spot_tex_wrap(i32(floor(uv.y * hf)), h, mode);
        return TexTaps(x, x, y, y, vec4<f32>(1.0, 0.0, 0.0, 0.0));
    }
    let px = uv.x * wf - 0.5;
    let py = uv.y * hf - 0.5;
    let fx = floor(px);
    let fy = floor(py);
    let wx1 = px - fx;
    let wy1 = py - fy;
    let wx0 = 1.0 - wx1;
    let wy0 = 1.0 - wy1;
    let ix = i32(fx);
    let iy = i32(fy);
    return TexTaps(spot_tex_wrap(ix, w, mode), spot_tex_wrap(ix + 1, w, mode), spot_tex_wrap(iy, h, mode),
                   spot_tex_wrap(iy + 1, h, mode), vec4<f32>(wx0 * wy0, wx1 * wy0, wx0 * wy1, wx1 * wy1));
}

fn spot_texel(o: u32, w: i32, x: i32, y: i32) -> vec3<f32> {
    let k = o + 16u + 3u * u32(y * w + x);
    return vec3<f32>(spot_textures[k], spot_textures[k + 1u], spot_textures[k + 2u]);
}

// A spot's projected texture (src/lights/spot_texture.rs, record layout there) toward the world
// direction v leaving the light: Mitsuba's direction_to_uv, then the bitmap / checkerboard lookup of
// `crate::scene::texture::eval`.
fn spot_texture_eval(l: Light, v: vec3<f32>) -> vec3<f32> {
    let o = l.tex_offset;
    let z = dot(v, l.direction) * l.tan_cutoff;
    let uv0 = vec2<f32>(0.5 + 0.5 * dot(v, l.normal) / z, 0.5 + 0.5 * dot(v, l.geo_normal) / z);
    let c0 = vec2<f32>(spot_textures[o + 4u], spot_textures[o + 5u]);
    let c1 = vec2<f32>(spot_textures[o + 7u], spot_textures[o + 8u]);
    let c2 = vec2<f32>(spot_textures[o + 10u], spot_textures[o + 11u]);
    let uv = c0 * uv0.x + c1 * uv0.y + c2;
    let wf = spot_textures[o];
    if wf == 0.0 {
        // Checkerboard: color0 where both fractional parts agree on > 1/2.
        let a = (uv.x - floor(uv.x)) > 0.5;
        let b = (uv.y - floor(uv.y)) > 0.5;
        return spot_texel(o, 1, select(1, 0, a == b), 0);
    }
    let w = i32(wf);
    let h = i32(spot_textures[o + 1u]);
    let t = tex_taps(uv, w, h, u32(spot_textures[o + 2u]), spot_textures[o + 3u] != 0.0);
    return spot_texel(o, w, t.x0, t.y0) * t.w.x + spot_texel(o, w, t.x1, t.y0) * t.w.y
        + spot_texel(o, w, t.x0, t.y1) * t.w.z + spot_texel(o, w, t.x1, t.y1) * t.w.w;
}

// ---- Patches of oriented points: the near field without 1 / d^2 (twin of src/lights/patch.rs) ----

const PATCH_NEAR_FIELD_RADII: f32 = 8.0;

// Whether p is within PATCH_NEAR_FIELD_RADII patch radii of the patch's centre (false without a patch).
fn patch_is_near(l: Light, p: vec3<f32>) -> bool {
    let c0 = l.patch_corners[0].xyz;
    let c1 = l.patch_corners[1].xyz;
    let c2 = l.patch_corners[2].xyz;
    let c3 = l.patch_corners[3].xyz;
    let centre = (c0 + c1 + c2 + c3) * 0.25;
    let d0 = c0 - centre;
    let d1 = c1 - centre;
    let d2 = c2 - centre;
    let d3 = c3 - centre;
    let r2 = max(max(max(dot(d0, d0), dot(d1, d1)), dot(d2, d2)), dot(d3, d3));
    let dp = p - centre;
    return r2 > 0.0 && dot(dp, dp) < r2 * (PATCH_NEAR_FIELD_RADII * PATCH_NEAR_FIELD_RADII);
}

// Whether an oriented point has a patch (not all four corners zero).
fn patch_present(l: Light) -> bool {
    return any(l.patch_corners[0].xyz != vec3<f32>(0.0)) || any(l.patch_corners[1].xyz != vec3<f32>(0.0))
        || any(l.patch_corners[2].xyz != vec3<f32>(0.0)) || any(l.patch_corners[3].xyz != vec3<f32>(0.0));
}

// atan(z) for z in [0, 1] (Cephes atanf), as `atan_unit` in patch.rs.
fn atan_unit(z: f32) -> f32 {
    var base = 0.0;
    var x = z;
    if z > 0.41421357 {
        base = 0.78539816339745;
        x = (z - 1.0) / (z + 1.0);
    }
    let x2 = x * x;
    return base + ((((8.0537445e-2 * x2 - 1.3877686e-1) * x2 + 1.9977711e-1) * x2 - 3.333295e-1) * x2 * x + x);
}

// The angle between unit vectors a and b.
fn angle_between(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let y = length(a - b);
    let x = length(a + b);
    var half: f32;
    if y <= x {
        half = atan_unit(y / x);
    } else {
        half = 1.57079632679490 - atan_unit(x / y);
    }
    return 2.0 * half;
}

// (projected solid angle, area) of the part of l's patch above the plane through p with normal n.
fn patch_clipped(l: Light, p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    var v: array<vec3<f32>, 5>;
    var k = 0u;
    for (var i = 0u; i < 4u; i++) {
        let a = l.patch_corners[i].xyz - p;
        let b = l.patch_corners[(i + 1u) % 4u].xyz - p;
        let ha = dot(n, a);
        let hb = dot(n, b);
        if ha >= 0.0 {
            v[k] = a;
            k += 1u;
        }
        if (ha >= 0.0) != (hb >= 0.0) {
            let t = ha / (ha - hb);
            v[k] = a + (b - a) * t;
            k += 1u;
        }
    }
    var psa = 0.0;
    var cross_sum = vec3<f32>(0.0);
    for (var i = 0u; i < k; i++) {
        let a = v[i];
        let b = v[(i + 1u) % k];
        let g = cross(a, b);
        cross_sum += g;
        let gl = length(g);
        let la = length(a);
        let lb = length(b);
        if gl > 0.0 && la > 0.0 && lb > 0.0 {
            psa += angle_between(a / la, b / lb) * (dot(n, g) / gl);
        }
    }
    return vec2<f32>(0.5 * abs(psa), 0.5 * length(cross_sum));
}

// ---- Virtual spherical lights (twin of src/lights/vsl.rs, formulas there) ----

// atan(z) for z >= 0.
fn atan_pos(z: f32) -> f32 {
    if z <= 1.0 {
        return atan_unit(z);
    }
    return 1.57079632679490 - atan_unit(1.0 / z);
}

// Projected solid angle of a spherical cap (half-angle sigma as sin^2 sigma) whose axis makes angle theta
// (cos_theta in [0, 1]) with the normal, clipped by the horizon.
fn cap_projected_solid_angle(cos_theta: f32, sin2_sigma: f32) -> f32 {
    let c = clamp(cos_theta, 0.0, 1.0);
    let s = clamp(sin2_sigma, 0.0, 1.0);
    if c * c > s {
        return 3.14159265358979 * s * c;
    }
    if s >= 1.0 {
        return 1.57079632679490 * (1.0 + c);
    }
    let sin_theta = sqrt(max(1.0 - c * c, 0.0));
    let x = sqrt(max(1.0 / s - 1.0, 0.0));
    let y = clamp(-x * c / sin_theta, -1.0, 1.0);
    let t = sin_theta * sqrt(max(1.0 - y * y, 0.0));
    return max((c * acos_precise(y) - x * t) * s + atan_pos(t / x), 0.0);
}

// The VSL radiance factor of a VPL with centre intensity `intensity` (cosine cos_light > 0 included),
// radius r, at squared distance dist2 from a receiver whose |cos| toward the centre is cos_receiver > 0.
fn vsl_spread(intensity: vec3<f32>, cos_light: f32, cos_receiver: f32, dist2: f32, r: f32) -> vec3<f32> {
    let r2 = r * r;
    let s = min(r2 / dist2, 1.0);
    let omega = 2.0 * 3.14159265358979 * s / (1.0 + sqrt(1.0 - s));
    let psa_y = cap_projected_solid_angle(cos_light, s);
    let psa_x = cap_projected_solid_angle(cos_receiver, s);
    return intensity * (psa_y * psa_x / (omega * 3.14159265358979 * r2 * cos_light * cos_receiver));
}

// The receiver's lobe integrated over a VSL's cap (twin of `vsl::cap_shade`): l a VPL with radius > 0 whose
// centre lies along wo from p; the receiver's frame (fs, ft, n), wi_local and BSDF b.
const VSL_CAP_SAMPLES: u32 = 4u;

fn vsl_cap_shade(l: Light, p: vec3<f32>, wo: vec3<f32>, fs: vec3<f32>, ft: vec3<f32>, n: vec3<f32>, wi_local: vec3<f32>, b: Bsdf) -> vec3<f32> {
    let r = l.cutoff_angle;
    let dp = l.position - p;
    let s = min(r * r / dot(dp, dp), 1.0);
    let one_minus_cos = s / (1.0 + sqrt(1.0 - s));
    let ta = coordinate_system_s(wo);
    let tb = coordinate_system_t(wo);
    let vs = coordinate_system_s(l.normal);
    let vt = coordinate_system_t(l.normal);
    let wi_v = vec3<f32>(dot(l.incident, vs), dot(l.incident, vt), dot(l.incident, l.normal));
    let cos_g_in = dot(l.incident, l.geo_normal);
    let k = f32(VSL_CAP_SAMPLES);
    var sum = vec3<f32>(0.0);
    for (var a = 0u; a < VSL_CAP_SAMPLES; a++) {
        let z = 1.0 - one_minus_cos * ((f32(a) + 0.5) / k);
        let rr = sqrt(max(1.0 - z * z, 0.0));
        for (var c = 0u; c < VSL_CAP_SAMPLES; c++) {
            let phi = 6.28318530717959 * ((f32(c) + 0.5) / k);
            let w = ta * (rr * cos(phi)) + tb * (rr * sin(phi)) + wo * z;
            let out = -w;
            let cos_g_out = dot(out, l.geo_normal);
            let out_local = vec3<f32>(dot(out, vs), dot(out, vt), dot(out, l.normal));
            if !positive(cos_g_out * cos_g_in) || out_local.z == 0.0 {
                continue;
            }
            let f_cos = bsdf_adjoint_eval(l.bsdf, wi_v, out_local);
            let w_local = vec3<f32>(dot(w, fs), dot(w, ft), dot(w, n));
            sum += bsdf_eval(b, wi_local, w_local) * f_cos * (abs(cos_g_out) / abs(out_local.z));
        }
    }
    return l.intensity * sum * (2.0 * one_minus_cos / (k * k * r * r));
}

// What a receiver (frame fs, ft, n; wi_local; BSDF b) at p reflects from l, given e = light_emitted(l, p, n)
// (valid): bsdf_eval toward e.wo times e.radiance, or a VSL's cap integrated against the receiver's lobe.
// Twin of `LightSet::shade_receiver`.
fn light_shade(l: Light, p: vec3<f32>, e: Emitted, fs: vec3<f32>, ft: vec3<f32>, n: vec3<f32>, wi_local: vec3<f32>, b: Bsdf) -> vec3<f32> {
    if l.kind == LIGHT_VPL && l.cutoff_angle > 0.0 {
        return vsl_cap_shade(l, p, e.wo, fs, ft, n, wi_local, b);
    }
    let wo_local = vec3<f32>(dot(e.wo, fs), dot(e.wo, ft), dot(e.wo, n));
    return bsdf_eval(b, wi_local, wo_local) * e.radiance;
}

// What a light sends to p: wo (unit, toward the light), radiance factor, distance (1e30 for directional).
struct Emitted {
    wo: vec3<f32>,
    dist: f32,
    radiance: vec3<f32>,
    valid: bool,
}

// acos to ~2 ulp (the Cephes single-precision algorithm, as Dr.Jit's `acos`): drivers' built-in acos may
// be far coarser (Mesa lavapipe: ~1e-5 rad), which near a spot's cutoff, where the falloff is a
// difference of two close angles, made GPU columns differ from the CPU backend's (libm) by up to 7e-4
// relative. Arguments in [-1, 1].
fn acos_precise(x: f32) -> f32 {
    let a = abs(x);
    var asin_arg: f32;
    var z: f32;
    if a > 0.5 {
        z = 0.5 * (1.0 - a);
        asin_arg = sqrt(z);
    } else {
        z = a * a;
        asin_arg = a;
    }
    // asin(asin_arg) for asin_arg in [0, 0.5] (z = asin_arg^2).
    let p = (((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z + 7.4953002686e-2) * z + 1.6666752422e-1;
    let s = asin_arg + asin_arg * z * p;
    if a > 0.5 {
        // acos(|x|) = 2 asin(sqrt((1 - |x|) / 2)).
        let r = 2.0 * s;
        return select(r, 3.14159265358979 - r, x < 0.0);
    }
    return 1.57079632679490 - select(s, -s, x < 0.0);
}

// Mitsuba's spot falloff_curve for cos(theta).
fn spot_falloff(l: Light, cos_theta: f32) -> f32 {
    if !greater(cos_theta, l.cos_cutoff) {
        return 0.0;
    }
    if cos_theta >= l.cos_beam {
        return 1.0;
    }
    return (l.cutoff_angle - acos_precise(clamp(cos_theta, -1.0, 1.0))) * l.inv_transition;
}

// What light l sends to p (receiver shading normal n, used by the VPL clamp).
fn light_emitted(l: Light, p: vec3<f32>, n: vec3<f32>) -> Emitted {
    var e: Emitted;
    e.valid = false;
    if l.kind == LIGHT_DIRECTIONAL {
        e.wo = -l.direction;
        e.dist = 1e30;
        e.radiance = l.intensity;
        e.valid = true;
        return e;
    }
    let d = l.position - p;
    let dist2 = dot(d, d);
    if !positive(dist2) {
        return e;
    }
    e.dist = sqrt(dist2);
    e.wo = d / e.dist;
    let inv_d2 = 1.0 / dist2;
    if l.kind == LIGHT_SPOT {
        let falloff = spot_falloff(l, -dot(e.wo, l.direction));
        if falloff <= 0.0 {
            return e;
        }
        var intensity = l.intensity;
        if l.tex_offset != SPOT_NO_TEXTURE {
            intensity = intensity * spot_texture_eval(l, -e.wo);
        }
        e.radiance = intensity * (falloff * inv_d2);
    } else if l.kind == LIGHT_ORIENTED_POINT {
        var inv = inv_d2;
        if patch_present(l) {
            // Shaded from the emitter's surface point beneath the light (`patch::surface_emitted`): the light
            // sits offset above its surface for its visibility only.
            let surface = l.position - l.normal * dot(l.position - l.patch_corners[0].xyz, l.normal);
            let ds = surface - p;
            let ds2 = dot(ds, ds);
            if !positive(ds2) {
                return e;
            }
            e.dist = sqrt(ds2);
            e.wo = ds / e.dist;
            inv = 1.0 / ds2;
        }
        let cos_theta = -dot(e.wo, l.normal);
        if !positive(cos_theta) {
            return e;
        }
        if patch_is_near(l, p) {
            // The side of the receiver's plane the light is on (`patch::receiver_side`): a twosided
            // receiver lit from below its normal clips the patch to that side.
            let cos_n = dot(e.wo, n);
            if !(positive(cos_n) || positive(-cos_n)) {
                return e;
            }
            let side = select(-n, n, cos_n > 0.0);
            let cos_r = abs(cos_n);
            let pa = patch_clipped(l, p, side);
            if !(positive(pa.x) && positive(pa.y)) {
                return e;
            }
            e.radiance = l.intensity * (pa.x / (pa.y * cos_r));
        } else {
            e.radiance = l.intensity * (cos_theta * inv);
        }
    } else if l.kind == LIGHT_VPL {
        // I(w) = Phi f(incident, w) |w . n_g|, then the geometry-term clamp min(1, clamp / G).
        let w = -e.wo;
        let cos_g_out = dot(w, l.geo_normal);
        if !positive(cos_g_out * dot(l.incident, l.geo_normal)) {
            return e;
        }
        let fs = coordinate_system_s(l.normal);
        let ft = coordinate_system_t(l.normal);
        let wi_local = vec3<f32>(dot(l.incident, fs), dot(l.incident, ft), dot(l.incident, l.normal));
        let wo_local = vec3<f32>(dot(w, fs), dot(w, ft), dot(w, l.normal));
        if wo_local.z == 0.0 {
            return e;
        }
        let f_cos = bsdf_adjoint_eval(l.bsdf, wi_local, wo_local);
        let intensity = l.intensity * f_cos * (abs(cos_g_out) / abs(wo_local.z));
        if l.cutoff_angle > 0.0 {
            let cos_r = abs(dot(e.wo, n));
            if !positive(cos_r) {
                return e;
            }
            e.radiance = vsl_spread(intensity, abs(cos_g_out), cos_r, dist2, l.cutoff_angle);
            e.valid = true;
            return e;
        }
        let g = abs(cos_g_out) * abs(dot(e.wo, n)) * inv_d2;
        let scale = select(1.0, l.clamp / g, g > l.clamp);
        e.radiance = intensity * (inv_d2 * scale);
    } else {
        e.radiance = l.intensity * inv_d2;
    }
    e.valid = true;
    return e;
}

// Mitsuba's coordinate_system(n) (Duff et al. 2017, branchless ONB): returns (s, t); frame = (s, t, n).
// copysign(1, n.z): the sign bit decides, so -0.0 gives -1 as in Mitsuba.
fn copysign_one(x: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(x) & 0x80000000u) != 0u);
}

fn coordinate_system_s(n: vec3<f32>) -> vec3<f32> {
    let sgn = copysign_one(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
}

fn coordinate_system_t(n: vec3<f32>) -> vec3<f32> {
    let sgn = copysign_one(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sgn + n.y * n.y * a, -n.y);
}
