use super::*;

fn tmp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let dir = crate::testing::scratch_dir("hdr");
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A flat (not run-length encoded) RGBE file of 2x1 pixels.
fn flat_file(pixels: &[[u8; 4]]) -> Vec<u8> {
    let mut b = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
    pixels.iter().for_each(|p| b.extend_from_slice(p));
    b
}

#[test]
fn decodes_rgbe_as_mitsuba() {
    // (r, g, b) * 2^(e - 136): e = 129 -> 2^-7; e = 0 -> black.
    let p = tmp("flat.hdr", &flat_file(&[[128, 64, 1, 129], [200, 200, 200, 0]]));
    let (w, h, px) = read_hdr(&p).unwrap();
    assert_eq!((w, h), (2, 1));
    assert_eq!(px, vec![[1.0, 0.5, 1.0 / 128.0], [0.0, 0.0, 0.0]]);
}

#[test]
fn reads_mitsubas_signature() {
    // mitsuba 3.9.1 `mi.Bitmap(np.ones((1, 1, 3))).write("a.hdr")`, verbatim.
    let p = tmp("mitsuba.hdr", b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\x80\x80\x80\x81");
    assert_eq!(read_hdr(&p).unwrap(), (1, 1, vec![[1.0, 1.0, 1.0]]));
}

#[test]
fn truncated_and_foreign_files_name_the_file() {
    let full = flat_file(&[[128, 64, 1, 129], [1, 2, 3, 130]]);
    let p = tmp("cut.hdr", &full[..full.len() - 3]);
    let e = read_hdr(&p).unwrap_err();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("cut.hdr"), "{e}");
    let p = tmp("xyz.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x80\x80\x80\x81");
    let e = read_hdr(&p).unwrap_err();
    assert!(e.to_string().contains("xyz.hdr"), "{e}");
    let p = tmp("png.hdr", b"\x89PNG\r\n\x1a\n");
    assert!(read_hdr(&p).unwrap_err().to_string().contains("png.hdr"));
    assert!(matches!(read_hdr(Path::new("/nonexistent/a.hdr")), Err(Error::Io { .. })));
}

#[test]
fn huge_declared_size_is_refused_before_allocating() {
    // Fuzzing finding: the decoder allocated width * height * 12 bytes from the header, and
    // 10^6 x 10^6 pixels (12 TB) aborted the process. Sizes over the cap (2^28 pixels) are now
    // errors naming the file and the size, before the decoder allocates; so are sizes under the cap
    // whose pixels need more memory than the memory policy allows.
    for (w, h) in [(1_000_000u64, 1_000_000u64), ((1 << 28) + 1, 1), (16385, 16384)] {
        let p = tmp("huge.hdr", format!("#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n\x7f\x7f\x7f\x01").as_bytes());
        let e = read_hdr(&p).unwrap_err().to_string();
        assert!(e.contains("huge.hdr") && e.contains(&format!("{w}x{h}")) && e.contains("larger than supported"), "{e}");
    }
    // 1000 x 1000 pixels (12 MB of f32 RGB) under a 10 MiB memory bound.
    let p = tmp("big.hdr", b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1000 +X 1000\n\x7f\x7f\x7f\x01");
    let e = crate::memory::with_thread_limit(10 << 20, || read_hdr(&p)).unwrap_err();
    assert!(matches!(e, Error::OutOfMemory(_)), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("big.hdr\" (Radiance RGBE (.hdr) image of 1000x1000 pixels) needs 12.0 MB") && msg.contains("10.5 MB is available"),
        "{msg}"
    );
}
