//! Hand-made scenes for unit tests (no files, no XML reader): meshes, Mitsuba's lookat, cameras, and
//! view samples cast on the CPU so that GPU tests do not depend on the G-buffer pass.
use crate::error::Location;
use crate::matrix::reference::CpuReference;
use crate::scene::{Camera, Mesh, Scene, ShapeKind};
use crate::shading::bsdf::resolve;
use crate::view::ViewSamples;
use glam::{Mat3, Mat4, Vec2, Vec3};

/// Mitsuba's lookat: columns (left, up', dir, origin).
pub fn lookat(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let dir = (target - origin).normalize();
    let left = up.cross(dir).normalize();
    let up2 = dir.cross(left);
    Mat4::from_cols(left.extend(0.0), up2.extend(0.0), dir.extend(0.0), origin.extend(1.0))
}

/// A perspective camera (horizontal field of view in degrees).
pub fn camera(world_from_camera: Mat4, fov_x_deg: f32, near: f32, far: f32, w: u32, h: u32) -> Camera {
    Camera {
        world_from_camera,
        fov_x: fov_x_deg.to_radians(),
        near_clip: near,
        far_clip: far,
        width: w,
        height: h,
        principal_point_offset: glam::Vec2::ZERO,
        loc: Location::default(),
    }
}

/// A square image looking from `origin` at `target` (50 degrees, y up).
pub fn square_camera(size: u32, origin: Vec3, target: Vec3) -> Camera {
    camera(lookat(origin, target, Vec3::Y), 50.0, 0.01, 100.0, size, size)
}

/// A mesh of positions and triangles (no normals or uvs), face normals, no emitter.
pub fn mesh(id: &str, kind: ShapeKind, positions: Vec<Vec3>, indices: Vec<[u32; 3]>, bsdf: usize) -> Mesh {
    Mesh {
        id: id.to_string(),
        kind,
        positions,
        normals: vec![],
        uvs: vec![],
        indices,
        face_normals: true,
        bsdf,
        emitter: None,
        loc: Location::default(),
    }
}

/// The parallelogram p0, p0 + u, p0 + u + v, p0 + v (normal u x v) as two triangles.
pub fn quad(p0: Vec3, u: Vec3, v: Vec3, bsdf: usize, id: &str) -> Mesh {
    let mut m = mesh(id, ShapeKind::Rectangle, vec![p0, p0 + u, p0 + u + v, p0 + v], vec![[0, 1, 2], [0, 2, 3]], bsdf);
    m.normals = vec![u.cross(v).normalize(); 4];
    m
}

/// A box with outward faces, half sizes `h`, rotated by `rot` about its centre.
pub fn oriented_box(center: Vec3, h: Vec3, rot: Mat3, bsdf: usize) -> Mesh {
    let axes = [rot * Vec3::X, rot * Vec3::Y, rot * Vec3::Z];
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for s in [1.0f32, -1.0] {
            let (eb, ec) = (axes[b] * (2.0 * h[b]), axes[c] * (2.0 * h[c]));
            let (u, v) = if s > 0.0 { (eb, ec) } else { (ec, eb) };
            let p0 = center + axes[a] * (s * h[a]) - axes[b] * h[b] - axes[c] * h[c];
            let base = positions.len() as u32;
            positions.extend([p0, p0 + u, p0 + u + v, p0 + v]);
            normals.extend([axes[a] * s; 4]);
            indices.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        }
    }
    let mut m = mesh("occluder", ShapeKind::Cube, positions, indices, bsdf);
    m.normals = normals;
    m
}

/// View samples by casting the camera's pixel-centre rays against all triangles on the CPU (BSDFs
/// resolved from the scene at uv 0; shading normal = the first vertex normal of the hit triangle).
pub fn cast_view(scene: &Scene) -> ViewSamples {
    let reference = CpuReference::new(scene);
    let owners: Vec<(usize, usize)> =
        scene.meshes.iter().enumerate().flat_map(|(s, m)| (0..m.indices.len()).map(move |p| (s, p))).collect();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut v = ViewSamples { width: w, height: h, ..Default::default() };
    for y in 0..h {
        for x in 0..w {
            let (o, d) = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            let (pos, n, ng, shape, prim, bsdf) = match reference.intersect(o, d, f32::INFINITY) {
                Some((t, k)) => {
                    let (s, p) = owners[k];
                    let mesh = &scene.meshes[s];
                    let [p0, p1, p2] = mesh.indices[p].map(|i| mesh.positions[i as usize]);
                    let ng = (p1 - p0).cross(p2 - p0).normalize();
                    (
                        o + d * t,
                        mesh.normals[mesh.indices[p][0] as usize],
                        ng,
                        s as i32,
                        p as i32,
                        resolve(&scene.bsdfs, &scene.textures, mesh.bsdf, Vec2::ZERO),
                    )
                }
                None => (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, -1, -1, bytemuck::Zeroable::zeroed()),
            };
            v.position.push(pos);
            v.normal.push(n);
            v.geo_normal.push(ng);
            v.wi.push(-d);
            v.shape_index.push(shape);
            v.prim_index.push(prim);
            v.albedo.push(Vec3::from_array(bsdf.diffuse));
            v.bsdf.push(bsdf);
            v.uv.push(Vec2::ZERO);
        }
    }
    crate::view::resolve::append_blend_records(scene, &mut v);
    v
}
