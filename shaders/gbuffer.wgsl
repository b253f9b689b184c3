// G-buffer visibility pass: writes `global triangle id + 1` (0 = background) at every pixel centre.
// Driven by `src/gpu/gbuffer.rs` (GBufferPass). Camera model: Mitsuba's perspective sensor, reverse-Z
// depth d = A + B / z_camera (1 at near_clip, 0 at far_clip), compare "greater".

// Keep in sync with `GBufferUniforms` in src/gpu/gbuffer.rs (160 bytes).
struct GBufferUniforms {
    clip_from_world: mat4x4<f32>,
    // xyz: camera left axis, w: tan(fov_x / 2).
    left_tan_x: vec4<f32>,
    // xyz: camera up axis, w: tan(fov_y / 2) = tan_x * H / W.
    up_tan_y: vec4<f32>,
    // xyz: camera forward axis, w: near_clip.
    forward_near: vec4<f32>,
    // xyz: camera origin, w: far_clip (may be +inf).
    origin_far: vec4<f32>,
    // x: film width, y: film height (pixels), z: depth A, w: depth B.
    film_depth: vec4<f32>,
    // xy: principal point offset (film units, as Mitsuba's principal_point_offset_x/y); zw: 0.
    principal_point: vec4<f32>,
}

// Keep in sync with `SphereUniforms` in src/gpu/gbuffer.rs (one per analytic sphere, 256-byte stride).
struct SphereUniforms {
    // xyz: world-space centre, w: radius.
    center_radius: vec4<f32>,
    // x: factor enlarging the tessellation about the centre so that it encloses the sphere.
    scale: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: GBufferUniforms;
@group(0) @binding(1) var<uniform> sphere: SphereUniforms;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat, either) triangle_id: u32,
}

// Triangles: unshared vertices, so vertex_index / 3 is the global triangle id.
@vertex
fn vs_triangles(@builtin(vertex_index) vertex_index: u32, @location(0) position: vec3<f32>) -> VertexOut {
    var out: VertexOut;
    out.clip = camera.clip_from_world * vec4<f32>(position, 1.0);
    out.triangle_id = vertex_index / 3u;
    return out;
}

@fragment
fn fs_triangles(in: VertexOut) -> @location(0) u32 {
    return in.triangle_id + 1u;
}

// Analytic spheres: the tessellation, enlarged to enclose the sphere, only selects candidate pixels;
// each fragment intersects the exact sphere along its camera ray and writes that hit's depth.
@vertex
fn vs_sphere(@builtin(vertex_index) vertex_index: u32, @location(0) position: vec3<f32>) -> VertexOut {
    let c = sphere.center_radius.xyz;
    let p = c + (position - c) * sphere.scale.x;
    var out: VertexOut;
    out.clip = camera.clip_from_world * vec4<f32>(p, 1.0);
    out.triangle_id = vertex_index / 3u;
    return out;
}

// Mitsuba's primary ray direction through film position `pixel` (pixels, row 0 at the top).
fn camera_ray_dir(pixel: vec2<f32>) -> vec3<f32> {
    let film = camera.film_depth.xy;
    let ndc = vec2<f32>(1.0) - 2.0 * (pixel / film + camera.principal_point.xy);
    let local = vec3<f32>(ndc.x * camera.left_tan_x.w, ndc.y * camera.up_tan_y.w, 1.0);
    let d = local.x * camera.left_tan_x.xyz + local.y * camera.up_tan_y.xyz + camera.forward_near.xyz;
    return normalize(d);
}

struct SphereOut {
    @location(0) id: u32,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_sphere(in: VertexOut) -> SphereOut {
    let d = camera_ray_dir(in.clip.xy);
    let o = camera.origin_far.xyz;
    let c = sphere.center_radius.xyz;
    let r = sphere.center_radius.w;
    // As Mitsuba: move the origin to the plane through the centre orthogonal to the ray, then solve.
    let plane_t = dot(c - o, d);
    let q = o + plane_t * d - c;
    let disc = r * r - dot(q, q);
    if (disc < 0.0) {
        discard;
    }
    let h = sqrt(disc);
    // Camera-space depth of a point at distance t along d: t * dot(d, forward).
    let cos_d = dot(d, camera.forward_near.xyz);
    let near = camera.forward_near.w;
    let far = camera.origin_far.w;
    var z = (plane_t - h) * cos_d;
    if (z < near) {
        z = (plane_t + h) * cos_d;
    }
    if (z < near || z > far) {
        discard;
    }
    var out: SphereOut;
    out.id = in.triangle_id + 1u;
    out.depth = camera.film_depth.z + camera.film_depth.w / z;
    return out;
}
