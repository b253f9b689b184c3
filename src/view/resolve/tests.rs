use super::*;
use crate::testing::view_scenes::*;

#[test]
fn triangle_hit_barycentrics() {
    let p = [DVec3::new(0.0, 0.0, 5.0), DVec3::new(2.0, 0.0, 5.0), DVec3::new(0.0, 2.0, 5.0)];
    let (t, b1, b2) = intersect_triangle(DVec3::new(0.5, 0.25, 0.0), DVec3::Z, p, 100.0).unwrap();
    assert!((t - 5.0).abs() < 1e-12 && (b1 - 0.25).abs() < 1e-12 && (b2 - 0.125).abs() < 1e-12);
    assert!(intersect_triangle(DVec3::new(1.5, 1.5, 0.0), DVec3::Z, p, 100.0).is_none());
    assert!(intersect_triangle(DVec3::new(0.5, 0.25, 0.0), DVec3::Z, p, 4.0).is_none());
}

#[test]
fn sphere_roots() {
    let c = DVec3::new(0.0, 0.0, 10.0);
    assert!((intersect_sphere(DVec3::ZERO, DVec3::Z, c, 2.0, 100.0).unwrap() - 8.0).abs() < 1e-12);
    // Origin inside: far root.
    assert!((intersect_sphere(DVec3::new(0.0, 0.0, 9.0), DVec3::Z, c, 2.0, 100.0).unwrap() - 3.0).abs() < 1e-12);
    assert!(intersect_sphere(DVec3::ZERO, DVec3::X, c, 2.0, 100.0).is_none());
    assert!(intersect_sphere(DVec3::ZERO, DVec3::Z, c, 2.0, 7.0).is_none());
}

/// (columns, rows) covered by mesh `m` in a visibility buffer.
pub(crate) fn covered(scene: &Scene, ids: &[u32], m: u32) -> (Vec<u32>, Vec<u32>) {
    let w = scene.camera.width;
    let mut cols = vec![];
    let mut rows = vec![];
    for (i, &id) in ids.iter().enumerate() {
        // Markers are 2 triangles each: global ids 1-2 (mesh 0), 3-4 (mesh 1).
        if id != 0 && (id - 1) / 2 == m {
            cols.push(i as u32 % w);
            rows.push(i as u32 / w);
        }
    }
    (cols, rows)
}

#[test]
fn camera_orientation_left_is_column_zero() {
    // Marker on the camera's left (+x of its frame) must land in the left half of the image,
    // the one above it in the top half.
    let scene = marker_scene();
    let ids = cast_visibility_cpu(&scene).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (cols, rows) = covered(&scene, &ids, 0);
    assert!(cols.len() > 10, "{}", cols.len());
    assert!(cols.iter().all(|&x| x < w / 2) && rows.iter().all(|&y| y > h / 4 && y < 3 * h / 4));
    let (cols, rows) = covered(&scene, &ids, 1);
    assert!(cols.len() > 10, "{}", cols.len());
    assert!(rows.iter().all(|&y| y < h / 2) && cols.iter().all(|&x| x > w / 4 && x < 3 * w / 4));
}

#[test]
fn another_camera_resolves_like_a_scene_with_that_camera() {
    // The `_for` variants through a camera of another film size give, bit for bit, what the scene
    // with that camera swapped in gives (the importance-VPL pilot view uses them instead of a copy
    // of the scene); spheres (the analytic resolve) and triangles both.
    for scene in [sphere_scene(false), marker_scene()] {
        let tracer = crate::raytrace::RayTracer::new(&scene).unwrap();
        let mut cam = scene.camera.clone();
        (cam.width, cam.height) = (cam.width / 3 + 1, cam.height / 2 + 1);
        let mut swapped = scene.clone();
        swapped.camera = cam.clone();
        let ids = cast_visibility_traced_for(&scene, &cam, &tracer).unwrap();
        assert_eq!(ids, cast_visibility_traced(&swapped, &tracer).unwrap());
        assert!(ids.iter().any(|&i| i != 0) && ids.len() == (cam.width * cam.height) as usize);
        let chains = ChainOptions::default();
        let a = resolve_view_samples_for(&scene, &cam, &ids, &chains).unwrap();
        let b = resolve_view_samples_with(&swapped, &ids, &chains).unwrap();
        assert_eq!((a.width, a.height, a.len()), (b.width, b.height, b.len()));
        assert_eq!((&a.position, &a.normal, &a.wi, &a.uv, &a.shape_index), (&b.position, &b.normal, &b.wi, &b.uv, &b.shape_index));
        // A buffer of the scene's own film size is refused for the other camera.
        assert!(resolve_view_samples_for(&scene, &cam, &vec![0; (scene.camera.width * scene.camera.height) as usize], &chains).is_err());
    }
}

#[test]
fn resolve_sphere_uv_and_normal() {
    let scene = sphere_scene(false);
    let v = view_samples_cpu_reference(&scene).unwrap();
    let c = Vec3::new(0.0, 0.0, 0.0);
    let mut hits = 0;
    for i in 0..v.len() {
        if v.shape_index[i] != 0 {
            continue;
        }
        hits += 1;
        let local = (v.position[i] - c) / 1.0;
        assert!((local.length() - 1.0).abs() < 1e-6);
        assert!((v.normal[i] - local).length() < 1e-5);
        let phi = local.y.atan2(local.x).rem_euclid(2.0 * std::f32::consts::PI);
        assert!((v.uv[i].x - phi / (2.0 * std::f32::consts::PI)).abs() < 1e-4, "{} {}", v.uv[i].x, phi);
        assert!((v.uv[i].y - local.z.clamp(-1.0, 1.0).acos() / std::f32::consts::PI).abs() < 1e-4);
        // Facing the camera: wi and n agree in sign.
        assert!(v.wi[i].dot(v.normal[i]) > 0.0);
    }
    assert!(hits > 100, "{hits}");
    let flipped = view_samples_cpu_reference(&sphere_scene(true)).unwrap();
    for i in 0..v.len() {
        if v.shape_index[i] == 0 {
            assert_eq!(flipped.normal[i], -v.normal[i]);
        }
    }
}

#[test]
fn textured_albedo_follows_uv() {
    use crate::scene::{Bsdf, Param, Texture};
    // Checkerboard on the back wall (uv (0,0) at its lower-left corner, 2x2 checks).
    let mut scene = cornell_scene(64, 48, 1.0, 0.05);
    let (c0, c1) = (Vec3::new(0.9, 0.1, 0.1), Vec3::new(0.1, 0.1, 0.9));
    scene.textures = vec![Texture::Checkerboard { color0: c0, color1: c1, to_uv: glam::Mat3::IDENTITY }];
    scene.bsdfs.push(Bsdf::Diffuse { reflectance: Param::Texture(0) });
    scene.meshes[0].bsdf = scene.bsdfs.len() - 1;
    let v = view_samples_cpu_reference(&scene).unwrap();
    let (mut n0, mut n1) = (0, 0);
    for i in 0..v.len() {
        if v.shape_index[i] != 0 {
            continue;
        }
        let uv = v.uv[i];
        // Mitsuba's checkerboard: color0 where both or neither coordinate is in the upper half.
        let expect = if (uv.x.fract() > 0.5) == (uv.y.fract() > 0.5) { c0 } else { c1 };
        assert_eq!(v.albedo[i], expect, "pixel {i} uv {uv}");
        assert_eq!(v.bsdf[i].kind, crate::shading::bsdf::KIND_DIFFUSE);
        if expect == c0 {
            n0 += 1
        } else {
            n1 += 1
        }
    }
    assert!(n0 > 50 && n1 > 50, "{n0} {n1}");
    // Two-sided red wall: albedo of the nested diffuse, two-sided flag set.
    let left = v.shape_index.iter().position(|&s| s == 3).unwrap();
    assert_eq!(v.albedo[left], Vec3::new(0.6, 0.1, 0.1));
    assert_ne!(v.bsdf[left].flags & crate::shading::bsdf::FLAG_TWOSIDED, 0);
}

#[test]
fn resolve_errors() {
    let scene = cornell_scene(32, 24, 1.0, 0.05);
    assert!(resolve_view_samples(&scene, &[0, 1]).is_err());
    let mut ids = vec![0u32; 32 * 24];
    ids[5] = 1_000_000;
    assert!(resolve_view_samples(&scene, &ids).is_err());
    let mut bad = scene.clone();
    bad.meshes[0].bsdf = 99;
    let e = view_samples_cpu_reference(&bad).unwrap_err().to_string();
    assert!(e.contains("BSDF 99") && e.contains("\"back\""), "{e}");
}
