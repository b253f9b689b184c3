//! Test-only scenes built from the test scenes' assets (OBJ/PLY files and the transforms of their XML
//! files), so the ray tracer's tests do not depend on the XML reader. Only geometry is filled in.
use crate::error::Location;
use crate::scene::{Camera, Mesh, Scene, ShapeKind};
use glam::{Mat4, Vec3};
use std::path::PathBuf;

use crate::testing::scene_file;

fn mesh(id: &str, kind: ShapeKind, positions: Vec<Vec3>, indices: Vec<[u32; 3]>, path: &std::path::Path) -> Mesh {
    let mut m = crate::testing::scenes::mesh(id, kind, positions, indices, 0);
    m.loc = Location::new(path, 0);
    m
}

/// An OBJ file (positions and faces only; quads fan-triangulated by tobj) transformed by `to_world`.
pub fn load_obj(rel: &str, to_world: Mat4) -> Mesh {
    let path = scene_file(rel);
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, _) = tobj::load_obj(&path, &opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    for m in &models {
        let base = positions.len() as u32;
        positions.extend(m.mesh.positions.chunks(3).map(|p| to_world.transform_point3(Vec3::new(p[0], p[1], p[2]))));
        indices.extend(m.mesh.indices.chunks(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
    }
    mesh(rel, ShapeKind::Obj, positions, indices, &path)
}

/// A binary little-endian PLY whose vertex properties are all `float` (x, y, z first) and whose faces
/// are `list uchar int`; positions transformed by `to_world`.
pub fn load_ply(rel: &str, to_world: Mat4) -> Mesh {
    let path = scene_file(rel);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let end = bytes.windows(11).position(|w| w == b"end_header\n").expect("PLY header") + 11;
    let header = std::str::from_utf8(&bytes[..end]).expect("PLY header is ASCII");
    assert!(header.contains("binary_little_endian"), "{}: only binary little-endian PLY here", path.display());
    let (mut num_vertices, mut num_faces, mut floats_per_vertex, mut in_vertex) = (0, 0, 0, false);
    for line in header.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["element", "vertex", n] => (num_vertices, in_vertex) = (n.parse().unwrap(), true),
            ["element", "face", n] => (num_faces, in_vertex) = (n.parse().unwrap(), false),
            ["property", "float", _] if in_vertex => floats_per_vertex += 1,
            _ => {}
        }
    }
    let f32_at = |off: usize| f32::from_le_bytes(bytes[off..off + 4].try_into().unwrap());
    let u32_at = |off: usize| u32::from_le_bytes(bytes[off..off + 4].try_into().unwrap());
    let positions: Vec<Vec3> = (0..num_vertices)
        .map(|i| {
            let off = end + i * floats_per_vertex * 4;
            to_world.transform_point3(Vec3::new(f32_at(off), f32_at(off + 4), f32_at(off + 8)))
        })
        .collect();
    let mut off = end + num_vertices * floats_per_vertex * 4;
    let mut indices = Vec::with_capacity(num_faces);
    for _ in 0..num_faces {
        let n = bytes[off] as usize;
        let v: Vec<u32> = (0..n).map(|k| u32_at(off + 1 + 4 * k)).collect();
        for k in 1..n - 1 {
            indices.push([v[0], v[k], v[k + 1]]);
        }
        off += 1 + 4 * n;
    }
    mesh(rel, ShapeKind::Ply, positions, indices, &path)
}

/// An analytic sphere with a coarse octahedron as its "tessellation" (which must never be hit).
pub fn sphere(center: Vec3, radius: f32, flip_normals: bool) -> Mesh {
    let dirs = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let positions = dirs.iter().map(|d| center + *d * radius).collect();
    let indices = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    mesh("sphere", ShapeKind::Sphere { center, radius, flip_normals }, positions, indices, std::path::Path::new("test"))
}

pub fn scene(meshes: Vec<Mesh>) -> Scene {
    let camera = Camera {
        world_from_camera: Mat4::IDENTITY,
        fov_x: 0.7,
        near_clip: 0.01,
        far_clip: 1e4,
        width: 64,
        height: 64,
        principal_point_offset: glam::Vec2::ZERO,
        loc: Location::default(),
    };
    Scene {
        media: Default::default(),
        integrator: None,
        path: PathBuf::from("test"),
        camera,
        meshes,
        bsdfs: Vec::new(),
        textures: Vec::new(),
        emitters: Vec::new(),
    }
}

/// cbox/scene.xml: luminaire (moved down by 0.5), floor, ceiling, back, green and red walls, and the
/// two boxes when `with_boxes`.
pub fn cbox(with_boxes: bool) -> Scene {
    let mut meshes = vec![load_obj("cbox/meshes/cbox_luminaire.obj", Mat4::from_translation(Vec3::new(0.0, -0.5, 0.0)))];
    for name in ["floor", "ceiling", "back", "greenwall", "redwall"] {
        meshes.push(load_obj(&format!("cbox/meshes/cbox_{name}.obj"), Mat4::IDENTITY));
    }
    if with_boxes {
        meshes.push(load_obj("cbox/meshes/cbox_smallbox.obj", Mat4::IDENTITY));
        meshes.push(load_obj("cbox/meshes/cbox_largebox.obj", Mat4::IDENTITY));
    }
    scene(meshes)
}

/// bunny/scene.xml: the Stanford bunny (69451 triangles) and the ground plane, with their transforms.
pub fn bunny() -> Scene {
    let deg = f32::to_radians;
    // Children of <transform> apply in document order: M = last * ... * first.
    let bunny_to_world = Mat4::from_translation(Vec3::new(0.3, 0.0, -0.3))
        * Mat4::from_rotation_x(deg(12.0))
        * Mat4::from_rotation_y(deg(-2.0))
        * Mat4::from_rotation_z(deg(-50.0))
        * Mat4::from_rotation_x(deg(-50.0))
        * Mat4::from_rotation_y(deg(70.0))
        * Mat4::from_rotation_z(deg(130.0))
        * Mat4::from_scale(Vec3::splat(12.0));
    let plane_matrix = Mat4::from_cols_array(&[
        3.38818, -4.06354, 0.0, -1.74958, 4.06354, 3.38818, 0.0, 1.43683, 0.0, 0.0, 5.29076, -0.0120714, 0.0, 0.0, 0.0, 1.0,
    ])
    .transpose(); // the XML matrix is row-major
    let plane_to_world = plane_matrix * Mat4::from_rotation_z(deg(-4.3));
    scene(vec![load_ply("bunny/meshes/bunny.ply", bunny_to_world), load_ply("bunny/meshes/plane.ply", plane_to_world)])
}

/// The cbox with boxes plus three analytic spheres (one with flipped normals).
pub fn cbox_spheres() -> Scene {
    let mut s = cbox(true);
    s.meshes.push(sphere(Vec3::new(150.0, 100.0, 400.0), 90.0, false));
    s.meshes.push(sphere(Vec3::new(420.0, 420.0, 150.0), 60.0, true));
    s.meshes.push(sphere(Vec3::new(300.0, 380.0, 420.0), 25.0, false));
    s
}
