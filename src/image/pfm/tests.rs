use super::*;

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = crate::testing::scratch_dir("pfm");
    dir.join(name)
}

#[test]
fn round_trip_and_row_order() {
    let px: Vec<[f32; 3]> = (0..6).map(|i| [i as f32, -0.5 * i as f32, 1e30]).collect();
    let p = tmp("rt.pfm");
    write_pfm(&p, 3, 2, &px).unwrap();
    // The file holds the bottom row (pixels 3..6) first.
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(&bytes[..10], b"PF\n3 2\n-1\n");
    assert_eq!(f32::from_le_bytes(bytes[10..14].try_into().unwrap()), 3.0);
    assert_eq!(read_pfm(&p).unwrap(), (3, 2, px));
}

#[test]
fn big_endian_grey_and_scale() {
    // Pf, 2x1, scale +2 (big-endian): values 1.5 and -4 are multiplied by 2.
    let mut b = b"Pf 2 1 2.0\n".to_vec();
    b.extend_from_slice(&1.5f32.to_be_bytes());
    b.extend_from_slice(&(-4f32).to_be_bytes());
    let p = tmp("grey.pfm");
    std::fs::write(&p, b).unwrap();
    assert_eq!(read_pfm(&p).unwrap(), (2, 1, vec![[3.0; 3], [-8.0; 3]]));
}

#[test]
fn bad_files_name_the_file_and_the_problem() {
    let cases: [(&str, &[u8], &str); 6] = [
        ("trunc.pfm", b"PF\n2 2\n-1\n\0\0\0\0", "need 48 bytes"),
        ("magic.pfm", b"P6\n2 2\n255\n", "does not start"),
        ("zero.pfm", b"PF\n0 2\n-1\n", "width \"0\""),
        ("scale.pfm", b"PF\n1 1\n0\n\0\0\0\0\0\0\0\0\0\0\0\0", "scale 0"),
        ("short.pfm", b"PF\n1", "before the height"),
        ("huge.pfm", b"PF\n4294967295 4294967295\n-1\n", "too large"),
    ];
    for (name, bytes, what) in cases {
        let p = tmp(name);
        std::fs::write(&p, bytes).unwrap();
        let e = read_pfm(&p).unwrap_err();
        assert!(matches!(e, Error::Io { .. }) && e.to_string().contains(name) && e.to_string().contains(what), "{e}");
    }
    assert!(write_pfm(&tmp("x.pfm"), 2, 2, &[[0.0; 3]]).is_err());
}
