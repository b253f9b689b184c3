//! G-buffer tests: the GPU visibility buffer against a brute-force CPU ray cast at every pixel centre.
use super::*;
use crate::gpu::scene_buffers::{locate_triangle, triangle_offsets};
use crate::testing::view_scenes::*;
use crate::view::resolve::{cast_visibility_cpu, intersect_triangle_plane, view_samples_cpu_reference};
use glam::{DVec3, Vec3};

/// Share of pixels allowed to see another surface than the CPU caster (pixel centres on edges).
const MAX_MISMATCH_FRACTION: f64 = 1e-3;
/// Positions of the same surface must agree within this fraction of the scene diagonal.
const POSITION_TOLERANCE: f32 = 1e-5;

fn ctx() -> Arc<GpuContext> {
    crate::testing::gpu_context()
}

struct Comparison {
    pixels: usize,
    /// Pixels whose shape differs (background counts as a shape).
    shape_mismatches: usize,
    /// Pixels on the same shape but another triangle (non-sphere shapes).
    prim_mismatches: usize,
    /// Max |p_gpu - p_cpu| over pixels on the same shape, relative to the scene diagonal.
    max_position_error: f32,
    max_normal_error: f32,
    /// Max distance of a GPU-resolved position from its pixel's camera ray, relative to the diagonal.
    max_ray_distance: f32,
}

fn compare(scene: &Scene, gpu: &ViewSamples, cpu: &ViewSamples) -> Comparison {
    let diag = scene.diagonal();
    let mut c = Comparison {
        pixels: gpu.len(),
        shape_mismatches: 0,
        prim_mismatches: 0,
        max_position_error: 0.0,
        max_normal_error: 0.0,
        max_ray_distance: 0.0,
    };
    let w = scene.camera.width;
    assert_eq!(gpu.len(), cpu.len());
    for i in 0..gpu.len() {
        let (s, r) = (gpu.shape_index[i], cpu.shape_index[i]);
        if s != r {
            c.shape_mismatches += 1;
            continue;
        }
        if s < 0 {
            assert_eq!(gpu.prim_index[i], -1);
            assert_eq!(gpu.position[i], Vec3::ZERO);
            continue;
        }
        let is_sphere = matches!(scene.meshes[s as usize].kind, ShapeKind::Sphere { .. });
        if !is_sphere && gpu.prim_index[i] != cpu.prim_index[i] {
            c.prim_mismatches += 1;
        }
        c.max_position_error = c.max_position_error.max((gpu.position[i] - cpu.position[i]).length() / diag);
        c.max_normal_error = c.max_normal_error.max((gpu.geo_normal[i] - cpu.geo_normal[i]).length());
        let (o, d) = scene.camera.ray((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
        let (o, d, p) = (o.as_dvec3(), d.as_dvec3(), gpu.position[i].as_dvec3());
        let off_ray = (p - o - d * (p - o).dot(d)).length() as f32 / diag;
        c.max_ray_distance = c.max_ray_distance.max(off_ray);
        assert_eq!(gpu.wi[i], cpu.wi[i]);
        assert_eq!(gpu.albedo[i], cpu.albedo[i]);
    }
    c
}

/// Every triangle the GPU reports must really be under the pixel centre (up to edge slack): the ray
/// meets its plane with barycentrics >= -`slack` at the reference's distance.
fn assert_gpu_hits_are_real(scene: &Scene, gpu_ids: &[u32], cpu_ids: &[u32]) {
    let offsets = triangle_offsets(&scene.meshes).unwrap();
    let w = scene.camera.width;
    let slack = 1e-3;
    for (i, (&g, &r)) in gpu_ids.iter().zip(cpu_ids).enumerate() {
        if g == r || g == 0 || r == 0 {
            continue;
        }
        let (m, prim) = locate_triangle(&offsets, g - 1).unwrap();
        let mesh = &scene.meshes[m];
        if matches!(mesh.kind, ShapeKind::Sphere { .. }) {
            continue;
        }
        let (rm, rprim) = locate_triangle(&offsets, r - 1).unwrap();
        let (o, d) = scene.camera.ray((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
        let (o, d) = (o.as_dvec3(), d.as_dvec3());
        let corners = |m: usize, prim: u32| -> [DVec3; 3] {
            let t = scene.meshes[m].indices[prim as usize];
            t.map(|v| scene.meshes[m].positions[v as usize].as_dvec3())
        };
        let p = corners(m, prim);
        let (t, b1, b2) = intersect_triangle_plane(o, d, p[0], p[1], p[2]).unwrap();
        let q = corners(rm, rprim);
        let (t_ref, _, _) = intersect_triangle_plane(o, d, q[0], q[1], q[2]).unwrap();
        assert!(
            b1 >= -slack && b2 >= -slack && b1 + b2 <= 1.0 + slack,
            "pixel {i}: GPU triangle {prim} of {:?} misses the ray (b = {b1}, {b2})",
            mesh.id
        );
        assert!((t - t_ref).abs() <= 1e-4 * t_ref, "pixel {i}: GPU hit at t {t}, reference {t_ref}");
    }
}

fn check_scene(name: &str, scene: &Scene) -> Comparison {
    let ctx = ctx();
    let gpu_ids = render_visibility(&ctx, scene).unwrap();
    let cpu_ids = cast_visibility_cpu(scene).unwrap();
    assert_gpu_hits_are_real(scene, &gpu_ids, &cpu_ids);
    let gpu = crate::view::resolve::resolve_view_samples(scene, &gpu_ids).unwrap();
    let cpu = view_samples_cpu_reference(scene).unwrap();
    let c = compare(scene, &gpu, &cpu);
    eprintln!(
        "{name} ({}, {}x{}): {} pixels, {} shape and {} triangle mismatches, max position error {:.2e} x diag, \
         max geo normal error {:.2e}, max distance from the camera ray {:.2e} x diag",
        ctx.summary.backend,
        scene.camera.width,
        scene.camera.height,
        c.pixels,
        c.shape_mismatches,
        c.prim_mismatches,
        c.max_position_error,
        c.max_normal_error,
        c.max_ray_distance
    );
    let allowed = (c.pixels as f64 * MAX_MISMATCH_FRACTION).ceil() as usize;
    assert!(c.shape_mismatches + c.prim_mismatches <= allowed, "{name}: too many mismatches (allowed {allowed})");
    assert!(c.max_position_error <= POSITION_TOLERANCE, "{name}: position error {}", c.max_position_error);
    assert!(c.max_normal_error <= 1e-5, "{name}: normal error {}", c.max_normal_error);
    assert!(c.max_ray_distance <= POSITION_TOLERANCE, "{name}: off the ray by {}", c.max_ray_distance);
    c
}

#[test]
fn uniform_sizes() {
    assert_eq!(std::mem::size_of::<GBufferUniforms>(), 160);
    assert_eq!(std::mem::size_of::<SphereUniforms>(), 32);
}

#[test]
fn projection_matches_mitsuba_rays() {
    // A point on Mitsuba's ray through film position (px, py) must project back to (px, py).
    let scene = cornell_scene(97, 61, 278.0, 0.01);
    let cam = &scene.camera;
    let u = GBufferUniforms::new(cam);
    let m = glam::Mat4::from_cols_array_2d(&u.clip_from_world).as_dmat4();
    let (a, b) = reverse_z(cam.near_clip as f64, cam.far_clip as f64);
    let forward = cam.world_from_camera.z_axis.truncate().as_dvec3();
    let mut worst: f64 = 0.0;
    for &(px, py) in &[(0.5f32, 0.5f32), (96.5, 0.5), (0.5, 60.5), (48.5, 30.5), (10.25, 50.75)] {
        let (o, d) = cam.ray(px, py);
        for t in [0.0f64, 500.0, 2000.0] {
            let p = o.as_dvec3() + d.as_dvec3() * t;
            let clip = m * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let fx = (ndc.x + 1.0) * 0.5 * cam.width as f64;
            let fy = (1.0 - ndc.y) * 0.5 * cam.height as f64;
            worst = worst.max((fx - px as f64).abs()).max((fy - py as f64).abs());
            let z = (p - cam.origin().as_dvec3()).dot(forward);
            // f32 matrix entries at world coordinates ~1000: z is off by ~1e-4 units (1e-5 at near = 10).
            let depth = a + b / z;
            assert!((ndc.z - depth).abs() <= 1e-5 * depth, "depth {} vs {depth}", ndc.z);
        }
    }
    assert!(worst < 1e-3, "projection off by {worst} pixels");
    // Near plane -> 1, far plane -> 0.
    assert!((a + b / cam.near_clip as f64 - 1.0).abs() < 1e-12 && (a + b / cam.far_clip as f64).abs() < 1e-12);
}

#[test]
fn camera_validation() {
    let mut scene = marker_scene();
    scene.camera.near_clip = 0.0;
    assert!(render_view_samples(&ctx(), &scene).is_err());
    let mut scene = marker_scene();
    scene.camera.width = 20000;
    assert!(render_view_samples(&ctx(), &scene).unwrap_err().to_string().contains("20000x32"));
}

#[test]
fn orientation_on_gpu() {
    let scene = marker_scene();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let ids = render_visibility(&ctx(), &scene).unwrap();
    let (cols, rows) = crate::view::resolve::tests::covered(&scene, &ids, 0);
    assert!(cols.len() > 10 && cols.iter().all(|&x| x < w / 2), "left marker in columns {cols:?}");
    assert!(rows.iter().all(|&y| y > h / 4 && y < 3 * h / 4));
    let (cols, rows) = crate::view::resolve::tests::covered(&scene, &ids, 1);
    assert!(rows.len() > 10 && rows.iter().all(|&y| y < h / 2), "up marker in rows {rows:?}");
    assert!(cols.iter().all(|&x| x > w / 4 && x < 3 * w / 4));
    assert_eq!(ids, cast_visibility_cpu(&scene).unwrap());
}

#[test]
fn cornell_unit_scale_matches_ray_cast() {
    check_scene("cornell unit", &cornell_scene(160, 100, 1.0, 2e-4));
}

#[test]
fn cornell_cbox_scale_depth_precision() {
    // Coordinates ~0..556, near_clip 10, camera ~1000 units away; the poster floats 0.01 units in
    // front of the back wall (8e-6 of its distance): it must win everywhere it covers.
    let scene = cornell_scene(128, 128, 278.0, 0.01);
    check_scene("cornell cbox scale", &scene);
    let v = render_view_samples(&ctx(), &scene).unwrap();
    let poster = scene.meshes.iter().position(|m| m.id == "poster").unwrap() as i32;
    let back = scene.meshes.iter().position(|m| m.id == "back").unwrap() as i32;
    let n_poster = v.shape_index.iter().filter(|&&s| s == poster).count();
    // The poster spans 0.3 x 0.3 of the box face: about 500 pixels at 128^2; none of its interior
    // may show the wall.
    assert!(n_poster > 400, "poster covers {n_poster} pixels");
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let around = [i - 1, i + 1, i - w, i + w];
            if around.iter().all(|&j| v.shape_index[j] == poster) {
                assert_ne!(v.shape_index[i], back, "wall bleeds through the poster at ({x}, {y})");
            }
        }
    }
}

#[test]
fn analytic_sphere_non_square_film() {
    let scene = sphere_scene(false);
    assert_ne!(scene.camera.width, scene.camera.height);
    check_scene("sphere 80x52", &scene);
    let v = render_view_samples(&ctx(), &scene).unwrap();
    let background = v.shape_index.iter().filter(|&&s| s == -1).count();
    let sphere = v.shape_index.iter().filter(|&&s| s == 0).count();
    assert!(background > 100 && sphere > 500, "background {background}, sphere {sphere}");
    for i in 0..v.len() {
        if v.shape_index[i] == -1 {
            assert_eq!((v.prim_index[i], v.normal[i], v.albedo[i]), (-1, Vec3::ZERO, Vec3::ZERO));
        } else if v.shape_index[i] == 0 {
            // On the exact sphere, not on its tessellation.
            assert!((v.position[i].length() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn sphere_enlargement_encloses() {
    let m = sphere_mesh("s", Vec3::new(1.0, 2.0, 3.0), 2.0, false, 0);
    let s = sphere_enlargement(&m, Vec3::new(1.0, 2.0, 3.0), 2.0);
    // 48 segments: cos(pi / 48) ~ 0.99786 at the equator; the polar caps need a bit more.
    assert!(s > 1.0 / (std::f32::consts::PI / 48.0).cos() && s < 1.02, "{s}");
}

/// Dump scenes for `tests/mitsuba_check_gbuffer.py` (run with `MANYLIGHTS_GBUFFER_DUMP=<dir> cargo test
/// --release -- --ignored dump_scenes_for_mitsuba`): per scene a folder with `view.bin` (per pixel 12
/// little-endian f32: position, normal, geo_normal, uv, shape_index), `camera.txt` (world_from_camera
/// row-major, fov_x in degrees, near, far, width, height) and one OBJ per mesh (`<index>.obj`, uv v
/// flipped back to the file convention) or `<index>.sphere` (centre, radius).
#[test]
#[ignore]
fn dump_scenes_for_mitsuba() {
    use std::fmt::Write;
    let root = std::env::var("MANYLIGHTS_GBUFFER_DUMP")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| std::env::temp_dir().join("gbuffer_dump"));
    for (name, scene) in [("sphere", sphere_scene(false)), ("cornell_cbox", cornell_scene(128, 96, 278.0, 0.01))] {
        let dir = root.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        let v = render_view_samples(&ctx(), &scene).unwrap();
        let mut out: Vec<f32> = Vec::with_capacity(v.len() * 12);
        for i in 0..v.len() {
            out.extend(v.position[i].to_array());
            out.extend(v.normal[i].to_array());
            out.extend(v.geo_normal[i].to_array());
            out.extend(v.uv[i].to_array());
            out.push(v.shape_index[i] as f32);
        }
        std::fs::write(dir.join("view.bin"), bytemuck::cast_slice(&out)).unwrap();
        let c = &scene.camera;
        let m = c.world_from_camera.transpose().to_cols_array();
        let mut cam: String = m.iter().map(|x| format!("{x:.9e} ")).collect();
        writeln!(cam, "\n{} {} {} {} {}", c.fov_x.to_degrees(), c.near_clip, c.far_clip, c.width, c.height).unwrap();
        std::fs::write(dir.join("camera.txt"), cam).unwrap();
        for (k, mesh) in scene.meshes.iter().enumerate() {
            if let ShapeKind::Sphere { center, radius, .. } = mesh.kind {
                std::fs::write(dir.join(format!("{k}.sphere")), format!("{} {} {} {}", center.x, center.y, center.z, radius)).unwrap();
                continue;
            }
            let mut obj = String::new();
            for p in &mesh.positions {
                writeln!(obj, "v {:.9e} {:.9e} {:.9e}", p.x, p.y, p.z).unwrap();
            }
            for t in &mesh.uvs {
                writeln!(obj, "vt {:.9e} {:.9e}", t.x, 1.0 - t.y).unwrap();
            }
            for n in &mesh.normals {
                writeln!(obj, "vn {:.9e} {:.9e} {:.9e}", n.x, n.y, n.z).unwrap();
            }
            for f in &mesh.indices {
                let corner = |v: u32| match (mesh.uvs.is_empty(), mesh.normals.is_empty()) {
                    (true, true) => format!("{}", v + 1),
                    (false, true) => format!("{0}/{0}", v + 1),
                    (true, false) => format!("{0}//{0}", v + 1),
                    (false, false) => format!("{0}/{0}/{0}", v + 1),
                };
                writeln!(obj, "f {} {} {}", corner(f[0]), corner(f[1]), corner(f[2])).unwrap();
            }
            std::fs::write(dir.join(format!("{k}.obj")), obj).unwrap();
        }
    }
}

#[test]
fn shared_geometry() {
    let ctx = ctx();
    let scene = sphere_scene(false);
    let geometry = SceneGeometry::upload(&ctx.device, &scene).unwrap();
    let a = render_view_samples_with_geometry(&ctx, &scene, &geometry).unwrap();
    let b = render_view_samples(&ctx, &scene).unwrap();
    assert_eq!((a.position, a.shape_index, a.prim_index), (b.position, b.shape_index, b.prim_index));
    assert!(render_view_samples_with_geometry(&ctx, &marker_scene(), &geometry).is_err());
}

#[test]
fn clip_range_is_mitsubas() {
    // The markers lie at z = 5 in the camera frame: visible iff near_clip <= 5 <= far_clip.
    let ctx = ctx();
    for (near, far, visible) in [(0.01, 4.99, false), (0.01, 5.01, true), (4.99, 1e4, true), (5.01, 1e4, false)] {
        let mut scene = marker_scene();
        scene.camera.near_clip = near;
        scene.camera.far_clip = far;
        let ids = render_visibility(&ctx, &scene).unwrap();
        let n = ids.iter().filter(|&&id| id != 0).count();
        assert_eq!(n > 0, visible, "near {near} far {far}: {n} pixels");
        assert_eq!(ids, cast_visibility_cpu(&scene).unwrap(), "near {near} far {far}");
    }
    // Infinite far clip.
    let mut scene = marker_scene();
    scene.camera.far_clip = f32::INFINITY;
    assert_eq!(render_visibility(&ctx, &scene).unwrap(), cast_visibility_cpu(&marker_scene()).unwrap());
}

#[test]
fn empty_scene_and_empty_meshes() {
    let ctx = ctx();
    let mut scene = marker_scene();
    let meshes = std::mem::take(&mut scene.meshes);
    let v = render_view_samples(&ctx, &scene).unwrap();
    assert_eq!(v.len(), 48 * 32);
    assert!(v.shape_index.iter().all(|&s| s == -1) && v.prim_index.iter().all(|&s| s == -1));
    // An empty mesh between two others must not shift the shape indices.
    let mut empty = meshes[0].clone();
    empty.indices.clear();
    scene.meshes = vec![meshes[0].clone(), empty, meshes[1].clone()];
    let v = render_view_samples(&ctx, &scene).unwrap();
    let count = |s: i32| v.shape_index.iter().filter(|&&x| x == s).count();
    assert!(count(0) > 10 && count(1) == 0 && count(2) > 10, "{} {} {}", count(0), count(1), count(2));
}

/// Timing on a larger frame (`cargo test --release -- --ignored timing_large_frame --nocapture`).
#[test]
#[ignore]
fn timing_large_frame() {
    let ctx = ctx();
    let mut scene = cornell_scene(1024, 768, 278.0, 0.01);
    // ~110k extra triangles: dense spheres drawn as plain meshes, plus one analytic sphere.
    for k in 0..50 {
        let c = Vec3::new(100.0 + 8.0 * k as f32, 60.0, 300.0);
        let mut m = sphere_mesh("dense", c, 20.0, false, 0);
        m.kind = ShapeKind::Obj;
        scene.meshes.push(m);
    }
    scene.meshes.push(sphere_mesh("analytic", Vec3::new(300.0, 300.0, 200.0), 60.0, false, 0));
    let tris: usize = scene.meshes.iter().map(|m| m.indices.len()).sum();
    let _ = render_view_samples(&ctx, &scene).unwrap();
    let t0 = std::time::Instant::now();
    let ids = render_visibility(&ctx, &scene).unwrap();
    let t1 = std::time::Instant::now();
    let v = crate::view::resolve::resolve_view_samples(&scene, &ids).unwrap();
    let t2 = std::time::Instant::now();
    eprintln!(
        "{}x{}, {tris} triangles ({}): visibility {:.1} ms, resolve {:.1} ms, {} background",
        scene.camera.width,
        scene.camera.height,
        ctx.summary.backend,
        (t1 - t0).as_secs_f64() * 1e3,
        (t2 - t1).as_secs_f64() * 1e3,
        v.shape_index.iter().filter(|&&s| s < 0).count()
    );
}
