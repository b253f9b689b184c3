use super::*;

fn write(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let dir = crate::testing::scratch_dir("ply");
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

const ASCII: &str = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nproperty float s\nproperty float t\nproperty uchar red\nelement face 1\n\
property list uchar int vertex_index\nend_header\n0 0 0 0 0 255\n1 0 0 1 0 0\n1 1 0 1 1 0\n0 1 0 0 0.25 7\n4 0 1 2 3\n";

#[test]
fn ascii_quad_with_st() {
    let p = write("a.ply", ASCII.as_bytes());
    let d = load_ply(&p, &Location::default()).unwrap();
    assert_eq!(d.positions, vec![Vec3::ZERO, Vec3::X, Vec3::new(1., 1., 0.), Vec3::Y]);
    assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(d.uvs[3], Vec2::new(0.0, 0.25)); // not flipped
    assert!(d.normals.is_empty());
}

fn binary(big_endian: bool) -> Vec<u8> {
    let enc = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
    let mut b = format!(
        "ply\nformat {enc} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\nproperty float texture_u\nproperty float texture_v\n\
property double quality\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n"
    )
    .into_bytes();
    let f = |b: &mut Vec<u8>, v: f32| b.extend(if big_endian { v.to_be_bytes() } else { v.to_le_bytes() });
    for (i, p) in [[0., 0., 0.], [2., 0., 0.], [0., 3., 0.]].iter().enumerate() {
        for &c in p {
            f(&mut b, c);
        }
        for c in [0., 0., 1.] {
            f(&mut b, c);
        }
        f(&mut b, i as f32 * 0.5);
        f(&mut b, 0.125);
        b.extend(if big_endian { 9.0f64.to_be_bytes() } else { 9.0f64.to_le_bytes() });
    }
    b.push(3);
    for i in [0u32, 1, 2] {
        b.extend(if big_endian { i.to_be_bytes() } else { i.to_le_bytes() });
    }
    b
}

#[test]
fn binary_both_endians() {
    for big in [false, true] {
        let p = write(if big { "be.ply" } else { "le.ply" }, &binary(big));
        let d = load_ply(&p, &Location::default()).unwrap();
        assert_eq!(d.positions, vec![Vec3::ZERO, Vec3::new(2., 0., 0.), Vec3::new(0., 3., 0.)], "big={big}");
        assert_eq!(d.normals, vec![Vec3::Z; 3]);
        assert_eq!(d.uvs, vec![Vec2::new(0., 0.125), Vec2::new(0.5, 0.125), Vec2::new(1.0, 0.125)]);
        assert_eq!(d.indices, vec![[0, 1, 2]]);
    }
}

#[test]
fn malformed_files_are_errors() {
    let p = write("bad.ply", ASCII.replace("1 1 0 1 1 0", "1 x 0 1 1 0").as_bytes());
    let e = load_ply(&p, &Location::default()).unwrap_err().to_string();
    assert!(e.contains("bad.ply") && e.contains("invalid PLY"), "{e}");
    let noz = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n";
    let p = write("noz.ply", noz.as_bytes());
    let e = load_ply(&p, &Location::default()).unwrap_err().to_string();
    assert!(e.contains("no \"z\""), "{e}");
    let p = write("line.ply", ASCII.replace("4 0 1 2 3", "2 0 1").as_bytes());
    let e = load_ply(&p, &Location::default()).unwrap_err().to_string();
    assert!(e.contains("face 0 has 2 indices"), "{e}");
    let e = load_ply(Path::new("/nonexistent.ply"), &Location::default()).unwrap_err();
    assert!(matches!(e, Error::FileNotFound { .. }));
}
