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
mod tests;
