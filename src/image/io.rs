//! EXR and PNG input/output.
//!
//! - [`read_exr`]: the first valid layer of an OpenEXR file (any compression the `exr` crate reads, PIZ
//!   included; half, float or uint channels), channels R, G, B (A ignored) or a single Y channel
//!   replicated to RGB. Linear, as stored.
//! - [`write_exr`] / [`encode_exr`]: float32 RGB, lossless (to a file, or to bytes).
//! - [`write_png`] / [`encode_png`]: 8-bit sRGB: `value * 2^exposure`, exact sRGB encoding curve, clamped to [0, 1],
//!   rounded to nearest.
use crate::error::{Error, Result};
use exr::prelude::*;
use std::path::Path;

/// The most channel samples of an EXR layer read (2^30), besides the texture size policy
/// (`crate::image::size_policy`: at most 16384^2 pixels and what host memory allows). The `exr` crate
/// allocates a layer's samples from its header before reading them, and aborts the process when that
/// fails (found by fuzzing: a 300-byte file asking for 10^15 bytes).
const MAX_EXR_SAMPLES: u64 = 1 << 30;

/// Reads an EXR file: (width, height, linear RGB pixels, row 0 = top).
///
/// Errors: `Io` naming the file when it cannot be read, has neither R, G, B nor Y channels, or has a
/// layer of more than 16384^2 pixels or 2^30 samples; `OutOfMemory` naming the file and the layer size
/// when decoding a layer needs more host memory than the memory policy allows (`size_policy::check`).
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| Error::io(path, e))?;
    // Every layer is checked (the one read is the first valid one): its stored samples, three f32
    // channel copies and the returned pixels are held at once.
    for h in &meta.headers {
        let (w, ht, c) = (h.layer_size.width() as u64, h.layer_size.height() as u64, h.channels.list.len() as u64);
        crate::image::size_policy::check(path, "EXR layer", w, ht, 0, 0)?;
        if (w * ht).saturating_mul(c) > MAX_EXR_SAMPLES {
            return Err(Error::io(path, format!("EXR layer of {w}x{ht} pixels and {c} channels is larger than supported (2^30 samples)")));
        }
        let stored: u64 = h.channels.list.iter().map(|ch| ch.sample_type.bytes_per_sample() as u64).sum();
        crate::image::size_policy::check(path, "EXR layer", w, ht, stored + 2 * crate::image::size_policy::TEXEL_BYTES, 0)?;
    }
    let image = read_first_flat_layer_from_file(path).map_err(|e| Error::io(path, e))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let channel = |name: &str| -> Option<Vec<f32>> {
        layer.channel_data.list.iter().find(|c| c.name.to_string() == name).map(|c| c.sample_data.values_as_f32().collect())
    };
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    let pixels: Vec<[f32; 3]> = if let (Some(r), Some(g), Some(b)) = (channel("R"), channel("G"), channel("B")) {
        r.iter().zip(&g).zip(&b).map(|((r, g), b)| [*r, *g, *b]).collect()
    } else if let Some(y) = channel("Y") {
        y.iter().map(|&y| [y, y, y]).collect()
    } else {
        return Err(Error::io(path, format!("EXR has channels {names:?}; expected R, G, B or Y")));
    };
    if pixels.len() != w * h {
        return Err(Error::io(path, format!("EXR has {} samples for {w}x{h} pixels", pixels.len())));
    }
    Ok((w as u32, h as u32, pixels))
}

fn check_len(path: &Path, w: u32, h: u32, n: usize) -> Result<()> {
    if n != w as usize * h as usize {
        return Err(Error::invalid(format!("{}: image of {w}x{h} needs {} pixels, got {n}", path.display(), w as usize * h as usize)));
    }
    Ok(())
}

/// Float32 RGB pixels (row 0 = top) encoded as an EXR file's bytes (the `exr` crate's default encoding,
/// as `write_rgb_file` writes it).
pub fn encode_exr(width: u32, height: u32, pixels: &[[f32; 3]]) -> Result<Vec<u8>> {
    check_len(Path::new("<exr>"), width, height, pixels.len())?;
    let w = width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * w + x];
        (p[0], p[1], p[2])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_channels((w, height as usize), channels)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| Error::invalid(format!("cannot encode an EXR image of {width}x{height}: {e}")))?;
    Ok(out.into_inner())
}

/// Writes float32 RGB pixels (row 0 = top) to an EXR file (encoded in memory, then written; any write
/// error is returned).
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]]) -> Result<()> {
    check_len(path, width, height, pixels.len())?;
    let bytes = encode_exr(width, height, pixels)?;
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

/// 8-bit sRGB code of a linear value.
pub fn encode_srgb8(linear: f32) -> u8 {
    let v = crate::scene::texture::linear_to_srgb(linear.max(0.0)).clamp(0.0, 1.0);
    (v * 255.0).round() as u8 // NaN maps to 0
}

/// Linear RGB pixels as 8-bit sRGB bytes (RGBRGB...) after scaling by `2^exposure` (PNG and video frames).
pub fn encode_srgb8_image(pixels: &[[f32; 3]], exposure: f32) -> Vec<u8> {
    let scale = exposure.exp2();
    pixels.iter().flat_map(|p| p.map(|c| encode_srgb8(c * scale))).collect()
}

/// Linear RGB pixels as the bytes of an 8-bit sRGB PNG after scaling by `2^exposure` (the `image`
/// crate's default PNG encoder, as `image::save_buffer` writes it).
pub fn encode_png(width: u32, height: u32, pixels: &[[f32; 3]], exposure: f32) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    check_len(Path::new("<png>"), width, height, pixels.len())?;
    let bytes = encode_srgb8_image(pixels, exposure);
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&bytes, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::invalid(format!("cannot encode a PNG image of {width}x{height}: {e}")))?;
    Ok(out)
}

/// Writes linear RGB pixels as an 8-bit sRGB PNG after scaling by `2^exposure` (encoded in memory, then
/// written; any write error is returned).
pub fn write_png(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]], exposure: f32) -> Result<()> {
    check_len(path, width, height, pixels.len())?;
    let bytes = encode_png(width, height, pixels, exposure)?;
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests;
