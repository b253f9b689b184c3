//! Texture size policy: how large an image the readers (`crate::scene::texture::load_bitmap` and the
//! EXR, RGBE, PFM, PNG, JPEG, BMP, PNM and TGA readers under it) decode.
//!
//! Image headers declare their size, and a file of a few hundred bytes can declare a huge image: the
//! decoders allocate from the header and fill what the data does not cover (fuzzing findings:
//! a 300-byte EXR asking for 10^15 bytes and a 61-byte RGBE file asking for 12 TB aborted the process; a
//! 556-byte progressive JPEG declaring 2039x65016 pixels took 2.2 GB and 5 s,
//! `fuzz/corpus/jpg/finding-oom-decoded-size`). So every reader reads the header first and calls
//! [`check`] before decoding, which refuses:
//!
//! - more than [`MAX_PIXELS`] pixels (16384^2, as a GPU texture dimension limit of 16384 implies), with
//!   `Error::Io` naming the file and the declared size;
//! - more host memory than the memory policy allows (`crate::memory::check_host`: `MemAvailable`,
//!   the cgroup limit and `MANYLIGHTS_MEMORY_LIMIT`, the rule every other large allocation follows),
//!   with `Error::OutOfMemory` (Python `MemoryError`) naming the file, the declared size, the bytes
//!   needed and the limit. The bytes counted are an upper bound of what the reader holds at once while
//!   decoding: the decoder's output, its working memory (JPEG: [`jpeg_working_bytes`]) and the
//!   returned linear RGB texels ([`TEXEL_BYTES`] each).
//!
//! The `image` crate's decoders (PNG, JPEG, BMP, PNM, TGA) are also given [`decoder_limits`]: its `max_alloc` is the
//! decoder's share of the checked bytes (in place of the crate's default 512 MiB, which refused valid
//! textures over 512 MiB and let a 398 MB JPEG decode), so a decoder that honours the limit never
//! allocates more than the policy counted for it.
use crate::error::{Error, Result};
use std::path::Path;

/// The most pixels an image may declare: 16384 x 16384 = 2^28.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Bytes of one returned texel: linear RGB as three `f32`.
pub const TEXEL_BYTES: u64 = 12;

/// Bytes an `image`-crate decoder may use besides its output (row buffers, headers, metadata).
pub const DECODER_OVERHEAD_BYTES: u64 = 16 << 20;

/// Refuses, before decoding, a `what` (e.g. "JPEG image") of `width x height` pixels of the file
/// `path` that declares more than [`MAX_PIXELS`] pixels (`Error::Io`) or whose decoding needs more host
/// memory than the memory policy allows (`Error::OutOfMemory`): `bytes_per_pixel` for each pixel
/// (everything held at once per pixel: decoder output, returned texels) plus `extra_bytes`.
pub fn check(path: &Path, what: &str, width: u64, height: u64, bytes_per_pixel: u64, extra_bytes: u64) -> Result<()> {
    let pixels = width as u128 * height as u128;
    if pixels > MAX_PIXELS as u128 {
        return Err(Error::io(
            path,
            format!("{what} of {width}x{height} pixels is larger than supported (at most {MAX_PIXELS} pixels, 16384x16384)"),
        ));
    }
    let bytes = crate::memory::product(&[width, height, bytes_per_pixel]).saturating_add(extra_bytes as u128);
    crate::memory::check_host(&format!("decoding \"{}\" ({what} of {width}x{height} pixels)", path.display()), bytes)
}

/// Working memory of the JPEG decoder (`zune-jpeg`) for an image of `width x height`: progressive and
/// non-interleaved files keep every DCT coefficient until the last scan, an `i16` per sample of up to 4
/// components, over the image rounded up to whole MCUs (at most 32 pixels wide and high).
pub fn jpeg_working_bytes(width: u64, height: u64) -> u64 {
    let round = |v: u64| v.div_ceil(32).saturating_mul(32);
    round(width).saturating_mul(round(height)).saturating_mul(4 * 2)
}

/// `image` crate limits for a decoder allowed `decoder_bytes` in all (its output included): no
/// dimension limit of its own ([`check`] bounds the pixel count), `max_alloc = decoder_bytes`.
pub fn decoder_limits(decoder_bytes: u64) -> image::Limits {
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(decoder_bytes);
    limits
}

#[cfg(test)]
mod tests;
