use super::*;
use crate::error::Location;
use crate::scene::ShapeKind;

fn mesh(n_tris: usize) -> Mesh {
    let positions: Vec<Vec3> = (0..n_tris * 3).map(|i| Vec3::new(i as f32, 2.0 * i as f32, -(i as f32))).collect();
    Mesh {
        id: format!("m{n_tris}"),
        kind: ShapeKind::Obj,
        normals: vec![],
        uvs: vec![],
        // Reverse each triangle's corners so the test sees the index order is honoured.
        indices: (0..n_tris as u32).map(|t| [3 * t + 2, 3 * t + 1, 3 * t]).collect(),
        positions,
        face_normals: true,
        bsdf: 0,
        emitter: None,
        loc: Location::default(),
    }
}

#[test]
fn offsets_and_locate() {
    let meshes = vec![mesh(2), mesh(0), mesh(3)];
    let off = triangle_offsets(&meshes).unwrap();
    assert_eq!(off, vec![0, 2, 2, 5]);
    assert_eq!(locate_triangle(&off, 0), Some((0, 0)));
    assert_eq!(locate_triangle(&off, 1), Some((0, 1)));
    // The empty mesh 1 never owns a triangle.
    assert_eq!(locate_triangle(&off, 2), Some((2, 0)));
    assert_eq!(locate_triangle(&off, 4), Some((2, 2)));
    assert_eq!(locate_triangle(&off, 5), None);
    assert_eq!(locate_triangle(&[0], 0), None);
}

#[test]
fn unshared_positions_follow_indices() {
    let meshes = vec![mesh(1), mesh(2)];
    let p = unshared_positions(&meshes).unwrap();
    assert_eq!(p.len(), 9);
    assert_eq!(p[0], [2.0, 4.0, -2.0]);
    assert_eq!(p[2], [0.0, 0.0, 0.0]);
    // Mesh 1, triangle 1, corner 0 = vertex 5.
    assert_eq!(p[6], [5.0, 10.0, -5.0]);
}

#[test]
fn bad_index_is_an_error() {
    let mut m = mesh(1);
    m.indices[0][1] = 7;
    let e = unshared_positions(&[m]).unwrap_err().to_string();
    assert!(e.contains("vertex 7") && e.contains("3 vertices"), "{e}");
}
