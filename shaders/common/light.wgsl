// Delta lights (point, spot, directional) as Mitsuba 3.9.1 evaluates them; twin of src/lights/mod.rs.
// Needs nothing else; used by shaders/columns.wgsl.

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

// Keep in sync with `GpuLight` in src/gpu/columns.rs (64 bytes).
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
    cutoff_angle: f32,
    cos_beam: f32,
    // 1 / (cutoff_angle - beam_width), 0 when they are equal.
    inv_transition: f32,
    // 1 when the light's shadow map is a cube (6 layers), 0 for one layer.
    is_cube: u32,
}

// What a light sends to p: wo (unit, toward the light), radiance factor, distance (1e30 for directional).
struct Emitted {
    wo: vec3<f32>,
    dist: f32,
    radiance: vec3<f32>,
    valid: bool,
}

// Mitsuba's spot falloff_curve for cos(theta).
fn spot_falloff(l: Light, cos_theta: f32) -> f32 {
    if !(cos_theta > l.cos_cutoff) {
        return 0.0;
    }
    if cos_theta >= l.cos_beam {
        return 1.0;
    }
    return (l.cutoff_angle - acos(clamp(cos_theta, -1.0, 1.0))) * l.inv_transition;
}

fn light_emitted(l: Light, p: vec3<f32>) -> Emitted {
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
    if !(dist2 > 0.0) {
        return e;
    }
    e.dist = sqrt(dist2);
    e.wo = d / e.dist;
    var scale = 1.0 / dist2;
    if l.kind == LIGHT_SPOT {
        let falloff = spot_falloff(l, -dot(e.wo, l.direction));
        if falloff <= 0.0 {
            return e;
        }
        scale = scale * falloff;
    }
    e.radiance = l.intensity * scale;
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
