//! Radiance RGBE (`.hdr`, `.rgbe`) input, as Mitsuba 3.9.1's `Bitmap::read_rgbe` reads it.
//!
//! Decoding is the `image` crate's (feature `hdr`): header `#?...` (any program name: Mitsuba writes
//! `#?RGBE`, Radiance `#?RADIANCE`), `FORMAT=32-bit_rle_rgbe`, a
//! `-Y h +X w` resolution line, flat or run-length encoded scanlines. Each texel is
//! `(r, g, b) * 2^(e - 136)` (0 when `e == 0`), the same conversion as Mitsuba's `rgbe_to_float`, so
//! texels are bit-identical to Mitsuba's. Row 0 is the first scanline (the top of the picture).
//!
//! Deviation: `FORMAT=32-bit_rle_xyze` files (Mitsuba converts XYZ to RGB) are refused with an error
//! naming the file; so are the rotated/flipped resolution lines (`+Y`, `-X` ...), as in Mitsuba.
use crate::error::{Error, Result};
use std::path::Path;

/// Reads a Radiance RGBE file: (width, height, linear RGB pixels, row 0 = top).
///
/// Errors: `Io` naming the file when it cannot be opened, is truncated, is not an RGBE file or
/// declares more than 16384^2 pixels; `OutOfMemory` naming the file and its size when its pixels need
/// more host memory than the memory policy allows (`crate::image::size_policy`).
pub fn read_hdr(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = std::io::BufReader::new(file);
    // Mitsuba accepts any first line starting with "#?" (and writes "#?RGBE"); `image`'s strict mode
    // wants "#?RADIANCE", so check the two bytes here and let the non-strict decoder skip the line.
    let mut magic = [0u8; 2];
    std::io::Read::read_exact(&mut reader, &mut magic).map_err(|e| Error::io(path, format!("not a Radiance RGBE (.hdr) file: {e}")))?;
    if &magic != b"#?" {
        return Err(Error::io(path, "not a Radiance RGBE (.hdr) file: it does not start with \"#?\""));
    }
    let decoder = image::codecs::hdr::HdrDecoder::new_nonstrict(reader)
        .map_err(|e| Error::io(path, format!("invalid Radiance RGBE (.hdr) file: {e}")))?;
    // The header's size is checked before anything is allocated (texture size policy): the decoder
    // allocates width * height * 12 bytes from it, and a 61-byte file declaring 10^6 x 10^6 pixels made
    // the allocation fail, which aborts the process (fuzzing finding, fuzz/corpus/hdr/finding-huge-size).
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    crate::image::size_policy::check(path, "Radiance RGBE (.hdr) image", w as u64, h as u64, 12, 0)?;
    let n = w as usize * h as usize;
    // Decoded straight into the returned pixels (no second full-size copy).
    let mut pixels = vec![[0.0f32; 3]; n];
    image::ImageDecoder::read_image(decoder, bytemuck::cast_slice_mut(&mut pixels))
        .map_err(|e| Error::io(path, format!("invalid Radiance RGBE (.hdr) file: {e}")))?;
    Ok((w, h, pixels))
}

#[cfg(test)]
mod tests {
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
        assert!(msg.contains("big.hdr\" (Radiance RGBE (.hdr) image of 1000x1000 pixels) needs 12.0 MB") && msg.contains("10.5 MB is available"), "{msg}");
    }
}
