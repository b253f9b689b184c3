use super::*;

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = crate::testing::scratch_dir("serialized");
    dir.join(name)
}

fn quad(z: f32) -> MeshData {
    MeshData {
        positions: vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(1.0, 1.0, z), Vec3::new(0.1, 1.0 / 3.0, z)],
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

#[test]
fn round_trip_every_sub_mesh_and_precision() {
    let mut bare = quad(2.0);
    bare.normals.clear();
    bare.uvs.clear();
    let meshes = vec![
        SubMesh { name: "a".into(), data: quad(0.0), double: false, colors: vec![] },
        SubMesh { name: "b".into(), data: quad(1.0), double: true, colors: vec![Vec3::ONE; 4] },
        SubMesh { name: String::new(), data: bare.clone(), double: false, colors: vec![] },
    ];
    let p = tmp("three.serialized");
    write_serialized(&p, &meshes).unwrap();
    let loc = Location::default();
    assert_eq!(load_serialized(&p, 0, &loc).unwrap(), quad(0.0));
    assert_eq!(load_serialized(&p, 1, &loc).unwrap(), quad(1.0)); // 1/3 survives f64 -> f32 exactly
    assert_eq!(load_serialized(&p, 2, &loc).unwrap(), bare);
    let e = load_serialized(&p, 3, &loc).unwrap_err().to_string();
    assert!(e.contains("three.serialized") && e.contains("out of range") && e.contains("3 meshes"), "{e}");
    assert!(load_serialized(&p, -1, &loc).unwrap_err().to_string().contains("non-negative"));
}

#[test]
fn version_3_dictionary_uses_u32_offsets() {
    // Two version-3 sub-meshes (no name string), u32 offsets.
    let sub = |z: f32| {
        let mut s = Vec::new();
        s.extend_from_slice(&FLAG_SINGLE.to_le_bytes());
        s.extend_from_slice(&3u64.to_le_bytes());
        s.extend_from_slice(&1u64.to_le_bytes());
        for p in [[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]] {
            p.iter().for_each(|c: &f32| s.extend_from_slice(&c.to_le_bytes()));
        }
        [0u32, 1, 2].iter().for_each(|i| s.extend_from_slice(&i.to_le_bytes()));
        let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut e, &s).unwrap();
        let mut out = vec![0x1C, 0x04, 3, 0];
        out.extend(e.finish().unwrap());
        out
    };
    let (a, b) = (sub(0.0), sub(5.0));
    let mut file = a.clone();
    file.extend(&b);
    file.extend(0u32.to_le_bytes());
    file.extend((a.len() as u32).to_le_bytes());
    file.extend(2u32.to_le_bytes());
    let p = tmp("v3.serialized");
    std::fs::write(&p, file).unwrap();
    let m = load_serialized(&p, 1, &Location::default()).unwrap();
    assert_eq!(m.positions[2], Vec3::new(0.0, 1.0, 5.0));
    assert_eq!(m.indices, vec![[0, 1, 2]]);
}

#[test]
fn bad_files_are_scene_errors_naming_the_file() {
    let p = tmp("good.serialized");
    write_serialized(&p, &[SubMesh { name: "q".into(), data: quad(0.0), double: false, colors: vec![] }]).unwrap();
    let good = std::fs::read(&p).unwrap();
    let mut wrong_version = good.clone();
    wrong_version[2] = 5;
    let mut corrupt = good.clone();
    corrupt[10] ^= 0xFF;
    let cases: [(&str, Vec<u8>, &str); 5] = [
        ("cut.serialized", good[..good.len() / 2].to_vec(), "cannot read"),
        ("magic.serialized", b"ply\nformat".to_vec(), "format id"),
        ("version.serialized", wrong_version, "version 5"),
        ("corrupt.serialized", corrupt, "invalid serialized mesh"),
        ("empty.serialized", Vec::new(), "file ends"),
    ];
    for (name, bytes, what) in cases {
        let p = tmp(name);
        std::fs::write(&p, bytes).unwrap();
        let e = load_serialized(&p, 0, &Location::default()).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, Error::Scene { .. }) && text.contains(name) && text.contains(what), "{text}");
    }
    let e = load_serialized(Path::new("/nonexistent/x.serialized"), 0, &Location::new("s.xml", 3)).unwrap_err();
    assert!(matches!(e, Error::FileNotFound { .. }));
}
