//! Hand-built scenes for G-buffer tests (no XML loader needed): a Cornell-like box at two scales, a
//! tessellated analytic sphere, and a marker on the camera's left.
use crate::scene::{Bsdf, Camera, Mesh, Param, Scene, ShapeKind};
use glam::{Mat4, Vec2, Vec3};

pub use crate::testing::scenes::{camera, lookat as look_at, mesh};

/// Quad p0 p1 p2 p3 (in order around it) as two triangles, with uv (0,0) (1,0) (1,1) (0,1).
pub fn quad(id: &str, p: [Vec3; 4], bsdf: usize) -> Mesh {
    let mut m = mesh(id, ShapeKind::Rectangle, p.to_vec(), vec![[0, 1, 2], [2, 3, 0]], bsdf);
    m.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    m
}

/// UV-sphere tessellation with shared vertices and smooth normals (rings x segments).
pub fn sphere_mesh(id: &str, center: Vec3, radius: f32, flip_normals: bool, bsdf: usize) -> Mesh {
    let (rings, segments) = (24u32, 48u32);
    let mut positions = vec![];
    let mut normals = vec![];
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            positions.push(center + n * radius);
            normals.push(if flip_normals { -n } else { n });
        }
    }
    let mut indices = vec![];
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (r * row + s, r * row + s + 1, (r + 1) * row + s + 1, (r + 1) * row + s);
            if r != 0 {
                indices.push([a, b, c]);
            }
            if r != rings - 1 {
                indices.push([a, c, d]);
            }
        }
    }
    let mut m = mesh(id, ShapeKind::Sphere { center, radius, flip_normals }, positions, indices, bsdf);
    m.normals = normals;
    m.face_normals = false;
    m
}

fn bsdfs() -> Vec<Bsdf> {
    vec![
        Bsdf::Diffuse { reflectance: Param::Value(Vec3::new(0.8, 0.8, 0.8)) },
        Bsdf::Diffuse { reflectance: Param::Value(Vec3::new(0.6, 0.1, 0.1)) },
        Bsdf::TwoSided { front: 1, back: 1 },
    ]
}

fn scene(camera: Camera, meshes: Vec<Mesh>) -> Scene {
    Scene {
        media: Default::default(),
        path: "test_scene.xml".into(),
        integrator: None,
        camera,
        meshes,
        bsdfs: bsdfs(),
        textures: vec![],
        emitters: vec![],
    }
}

/// Open box [-1,1]^3 (back, floor, ceiling, left, right walls) with a tilted smooth-shaded block and
/// a poster `gap` in front of the back wall, all scaled by `s` about the origin then shifted so that
/// at `s = 278` the coordinates look like Mitsuba's cbox (0..556). Camera on +z looking at the box.
pub fn cornell_scene(w: u32, h: u32, s: f32, gap: f32) -> Scene {
    let shift = if s > 10.0 { Vec3::new(278.0, 273.0, 279.0) } else { Vec3::ZERO };
    let t = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * s + shift;
    let mut meshes = vec![
        quad("back", [t(-1., -1., -1.), t(1., -1., -1.), t(1., 1., -1.), t(-1., 1., -1.)], 0),
        quad("floor", [t(-1., -1., 1.), t(1., -1., 1.), t(1., -1., -1.), t(-1., -1., -1.)], 0),
        quad("ceiling", [t(-1., 1., -1.), t(1., 1., -1.), t(1., 1., 1.), t(-1., 1., 1.)], 0),
        quad("left", [t(-1., -1., 1.), t(-1., -1., -1.), t(-1., 1., -1.), t(-1., 1., 1.)], 2),
        quad("right", [t(1., -1., -1.), t(1., -1., 1.), t(1., 1., 1.), t(1., 1., -1.)], 1),
    ];
    // A poster just in front of the back wall: depth precision at `gap` (units of the scene).
    let z = -1.0 + gap / s;
    meshes.push(quad("poster", [t(-0.5, 0.2, z), t(0.1, 0.2, z), t(0.1, 0.8, z), t(-0.5, 0.8, z)], 1));
    // A tilted block with per-vertex (smooth) normals: 5 faces of a rotated box.
    let rot = Mat4::from_rotation_y(0.4) * Mat4::from_rotation_x(0.15);
    let c = |x: f32, y: f32, z: f32| {
        let p = rot.transform_point3(Vec3::new(x, y, z) * 0.3) + Vec3::new(0.3, -0.55, 0.1);
        t(p.x, p.y, p.z)
    };
    let corners = [
        c(-1., -1., -1.),
        c(1., -1., -1.),
        c(1., 1., -1.),
        c(-1., 1., -1.),
        c(-1., -1., 1.),
        c(1., -1., 1.),
        c(1., 1., 1.),
        c(-1., 1., 1.),
    ];
    let center = corners.iter().copied().sum::<Vec3>() / 8.0;
    let mut block = mesh(
        "block",
        ShapeKind::Obj,
        corners.to_vec(),
        vec![[4, 5, 6], [6, 7, 4], [1, 0, 3], [3, 2, 1], [5, 1, 2], [2, 6, 5], [0, 4, 7], [7, 3, 0], [7, 6, 2], [2, 3, 7]],
        0,
    );
    block.normals = corners.iter().map(|p| (*p - center).normalize()).collect();
    block.face_normals = false;
    meshes.push(block);
    // Slightly off-axis so that box edges do not line up with rows or columns of pixel centres.
    let origin = t(0.0123, 0.0371, 3.6);
    let target = t(-0.0217, 0.0089, 0.0);
    let near = if s > 10.0 { 10.0 } else { 0.01 };
    let far = if s > 10.0 { 2800.0 } else { 1e4 };
    scene(camera(look_at(origin, target, Vec3::Y), 39.3, near, far, w, h), meshes)
}

/// An analytic sphere (radius 1 at the origin) over a floor, seen from above-front; non-square film.
pub fn sphere_scene(flip_normals: bool) -> Scene {
    let meshes = vec![
        sphere_mesh("sphere", Vec3::ZERO, 1.0, flip_normals, 0),
        quad("floor", [Vec3::new(-4., -1., 4.), Vec3::new(4., -1., 4.), Vec3::new(4., -1., -4.), Vec3::new(-4., -1., -4.)], 1),
    ];
    let cam = camera(look_at(Vec3::new(0.7, 1.2, 3.5), Vec3::ZERO, Vec3::Y), 50.0, 0.01, 1e4, 80, 52);
    scene(cam, meshes)
}

/// Camera at the origin with the identity frame (left = +x, up = +y, forward = +z): mesh 0 is a small
/// quad at x in [1, 2], z = 5 (on the camera's left), mesh 1 one at y in [1, 2] (above). 48x32 film.
pub fn marker_scene() -> Scene {
    let meshes = vec![
        quad("left_marker", [Vec3::new(1., -0.5, 5.), Vec3::new(2., -0.5, 5.), Vec3::new(2., 0.5, 5.), Vec3::new(1., 0.5, 5.)], 0),
        quad("up_marker", [Vec3::new(-0.5, 1., 5.), Vec3::new(0.5, 1., 5.), Vec3::new(0.5, 2., 5.), Vec3::new(-0.5, 2., 5.)], 0),
    ];
    scene(camera(Mat4::IDENTITY, 60.0, 0.01, 1e4, 48, 32), meshes)
}
