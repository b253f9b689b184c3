//! Portable float map (`.pfm`) input and output, as Mitsuba 3.9.1's `Bitmap::read_pfm` / `write_pfm`.
//!
//! Format: `PF` (RGB) or `Pf` (grey, replicated to RGB here), whitespace, width, height and a scale
//! whose sign gives the byte order (negative: little-endian) and whose magnitude multiplies every value,
//! one whitespace byte, then `width * height * channels` float32 values with the BOTTOM row first
//! (Mitsuba flips them so that row 0 is the top). The `image` crate has no PFM codec (its `pnm`
//! module reads PBM/PGM/PPM/PAM only), so the few lines of this format are read here.
use crate::error::{Error, Result};
use std::path::Path;

/// Reads a PFM file: (width, height, linear RGB pixels, row 0 = top).
///
/// Errors: `Io` naming the file for a missing file, a bad header, non-positive or overflowing size, a
/// zero or non-finite scale, fewer data bytes than the header announces, or more than 16384^2 pixels;
/// `OutOfMemory` naming the file and its size when the file and its pixels need more host memory than
/// the memory policy allows (`crate::image::size_policy`).
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let header = parse_header(&bytes).map_err(|msg| Error::io(path, format!("invalid PFM file: {msg}")))?;
    // The header's size is known to be backed by data; the file stays in memory while the pixels fill.
    crate::image::size_policy::check(path, "PFM image", header.width as u64, header.height as u64, 12, bytes.len() as u64)?;
    Ok(decode(&bytes, &header))
}

/// A PFM header whose size the data covers.
struct Header {
    channels: usize,
    width: u32,
    height: u32,
    scale: f32,
    data_start: usize,
}

fn parse_header(bytes: &[u8]) -> std::result::Result<Header, String> {
    let channels = match bytes.get(..2) {
        Some(b"PF") => 3usize,
        Some(b"Pf") => 1usize,
        _ => return Err("does not start with \"PF\" or \"Pf\"".into()),
    };
    // Three whitespace-separated tokens, then exactly one whitespace byte before the data.
    let mut pos = 2;
    let mut token = |what: &str| -> std::result::Result<String, String> {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() && pos - start < 64 {
            pos += 1;
        }
        if start == pos {
            return Err(format!("header ends before the {what}"));
        }
        Ok(String::from_utf8_lossy(&bytes[start..pos]).into_owned())
    };
    let (ws, hs, ss) = (token("width")?, token("height")?, token("scale")?);
    let parse_dim = |s: &str, what: &str| -> std::result::Result<u32, String> {
        match s.parse::<u32>() {
            Ok(v) if v > 0 => Ok(v),
            _ => Err(format!("{what} \"{s}\" is not a positive integer")),
        }
    };
    let (w, h) = (parse_dim(&ws, "width")?, parse_dim(&hs, "height")?);
    let scale: f32 = ss.parse().map_err(|_| format!("scale \"{ss}\" is not a number"))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(format!("scale {scale} must be non-zero and finite (its sign gives the byte order)"));
    }
    let data = bytes.get(pos + 1..).unwrap_or(&[]);
    let count = (w as usize).checked_mul(h as usize).and_then(|n| n.checked_mul(channels));
    let need = count.and_then(|n| n.checked_mul(4)).ok_or_else(|| format!("size {w}x{h} is too large"))?;
    if data.len() < need {
        return Err(format!("{w}x{h}x{channels} floats need {need} bytes of data, the file has {}", data.len()));
    }
    Ok(Header { channels, width: w, height: h, scale, data_start: pos + 1 })
}

/// The pixels of a file whose header [`parse_header`] accepted (row 0 = top).
fn decode(bytes: &[u8], header: &Header) -> (u32, u32, Vec<[f32; 3]>) {
    let Header { channels, width: w, height: h, scale, data_start } = *header;
    let data = &bytes[data_start..];
    let little = scale < 0.0;
    let k = scale.abs();
    let value = |i: usize| {
        let b: [u8; 4] = data[4 * i..4 * i + 4].try_into().unwrap_or_default();
        let v = if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
        if k != 1.0 {
            v * k
        } else {
            v
        }
    };
    let (wu, hu) = (w as usize, h as usize);
    let mut pixels = Vec::with_capacity(wu * hu);
    for row in 0..hu {
        let file_row = hu - 1 - row; // bottom row first in the file
        for x in 0..wu {
            let i = (file_row * wu + x) * channels;
            pixels.push(if channels == 3 { [value(i), value(i + 1), value(i + 2)] } else { [value(i); 3] });
        }
    }
    (w, h, pixels)
}

/// Writes float32 RGB pixels (row 0 = top) as a little-endian PFM file, as Mitsuba writes them.
///
/// Errors: `InvalidParameter` when `pixels.len() != width * height`; `Io` when writing fails.
pub fn write_pfm(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]]) -> Result<()> {
    if pixels.len() != width as usize * height as usize || width == 0 || height == 0 {
        return Err(Error::invalid(format!(
            "{}: image of {width}x{height} needs {} pixels, got {}",
            path.display(),
            width as usize * height as usize,
            pixels.len()
        )));
    }
    let mut out = format!("PF\n{width} {height}\n-1\n").into_bytes();
    for row in pixels.chunks(width as usize).rev() {
        for p in row {
            p.iter().for_each(|c| out.extend_from_slice(&c.to_le_bytes()));
        }
    }
    std::fs::write(path, out).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests;
