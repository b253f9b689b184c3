use super::*;
use crate::testing::scene_file;

fn parse(s: &str) -> Result<MeshData> {
    parse_obj(s, Path::new("mem.obj"))
}

#[test]
fn face_forms_and_dedup() {
    let src = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0.25\nvn 0 0 1\n\
                   f 1/1/1 2/2/1 3/2/1\nf 1/1/1 3/2/1 4/1/1\n";
    let d = parse(src).unwrap();
    assert_eq!(d.positions.len(), 4);
    assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(d.uvs[1], Vec2::new(1.0, 0.75)); // v flipped
    assert_eq!(d.uvs[0], Vec2::new(0.0, 1.0));
    assert_eq!(d.normals, vec![Vec3::Z; 4]);

    // v only, quad: fan.
    let d = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(d.normals.is_empty() && d.uvs.is_empty());

    // v//vn, pentagon; the same position with two normals gives two vertices.
    let d =
        parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0 0\nvn 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//1 4//1 5//1\nf 1//2 2//2 3//2\n").unwrap();
    assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [5, 6, 7]]);
    assert_eq!(d.positions.len(), 8);
    assert_eq!(d.normals[5], Vec3::Y);
    assert_eq!(d.positions[5], Vec3::ZERO);

    // v/vt, tabs and CRLF, comment at the end of a face, unreferenced vertex dropped.
    let d = parse("v 9 9 9\r\nv\t0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvt 0.5 0.5\r\nf 2/1\t3/1 4/1 # c\r\n").unwrap();
    assert_eq!(d.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
    assert_eq!(d.uvs, vec![Vec2::splat(0.5); 3]);
}

/// Binary files renamed .obj and empty files are errors naming the file (Mitsuba fails on them too),
/// not empty meshes; a file with vertices but no faces still loads.
#[test]
fn binary_and_empty_files_are_errors() {
    let dir = crate::testing::scratch_dir("obj");
    let loc = Location::new(Path::new("scene.xml"), 7);
    for (name, bytes, want) in [
        ("png.obj", &b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR"[..], "binary data at byte 8"),
        ("empty.obj", &b""[..], "no vertices"),
        ("comments.obj", &b"# nothing\n\n"[..], "no vertices"),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        let e = load_obj(&p, &loc).unwrap_err().to_string();
        assert!(e.starts_with("scene.xml:7:") && e.contains(name) && e.contains(want), "{e}");
    }
    let p = dir.join("points.obj");
    std::fs::write(&p, "v 0 0 0\nv\t1 0 0\n").unwrap();
    assert!(load_obj(&p, &loc).unwrap().indices.is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn negative_indices() {
    let d = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf -3/-1 -2/-1 -1/-1\n").unwrap();
    assert_eq!(d.indices, vec![[0, 1, 2]]);
    assert_eq!(d.positions[2], Vec3::new(1., 1., 0.));
}

#[test]
fn errors_name_file_and_line() {
    let e = parse("v 0 0 0\nv 1 x 0\n").unwrap_err().to_string();
    assert!(e.starts_with("mem.obj:2:") && e.contains("v 1 x 0"), "{e}");
    let e = parse("v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err().to_string();
    assert!(e.starts_with("mem.obj:3:") && e.contains("invalid vertex 3"), "{e}");
    let e = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1/4 2/1 3/1\n").unwrap_err().to_string();
    assert!(e.starts_with("mem.obj:5:") && e.contains("texture coordinate 4"), "{e}");
    let e = parse("v 0 0 nan\n").unwrap_err().to_string();
    assert!(e.starts_with("mem.obj:1:") && e.contains("vertex 1") && e.contains("NaN"), "{e}");
    let e = parse("v 0 0 0\nf 1/a 1 1\n").unwrap_err().to_string();
    assert!(e.starts_with("mem.obj:2:") && e.contains("\"a\""), "{e}");
    let e = load_obj(Path::new("/nonexistent/x.obj"), &Location::new("s.xml", 4)).unwrap_err();
    assert!(matches!(e, Error::FileNotFound { .. }), "{e}");
}

#[test]
fn cbox_smallbox_matches_mitsuba() {
    // Values dumped from mitsuba 3.9.1 (scalar_rgb, identity to_world).
    let p = scene_file("cbox/meshes/cbox_smallbox.obj");
    let d = load_obj(&p, &Location::default()).unwrap();
    assert_eq!((d.positions.len(), d.indices.len()), (24, 12));
    assert_eq!(d.positions[0], Vec3::new(130.0, 165.0, 65.0));
    assert_eq!(d.positions[7], Vec3::new(240.0, 0.0, 272.0));
    assert_eq!(d.positions[23], Vec3::new(130.0, 0.0, 65.0));
    assert_eq!(d.indices[11], [20, 22, 23]);
    assert_eq!(d.normals[7], Vec3::new(0.953400, 0.0, 0.301709)); // file normal, normalised later
    assert_eq!(d.indices[0], [0, 1, 2]);
    assert!(d.uvs.is_empty());
}
