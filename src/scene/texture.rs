//! Bitmap loading and texture evaluation as Mitsuba 3.9.1 does them (`src/textures/bitmap.cpp`,
//! `src/textures/checkerboard.cpp`, Dr.Jit 1.5 `include/drjit/texture_impl.h`).
//!
//! Bitmaps: PNG/JPEG/BMP/PPM/TGA through `image`, EXR through `exr` ([`crate::image::io`]), Radiance RGBE
//! ([`crate::image::hdr`]) and PFM ([`crate::image::pfm`]); float formats are recognised by their first
//! bytes (as Mitsuba's `detect_file_format`), whatever the file's extension. Row 0 is the first row of
//! the file (the top of the picture) and is looked up at v = 0: Mitsuba's texture row is `floor(v*H - 1/2)`
//! with no flip (the OBJ loader's `v' = 1 - v` is what makes OBJ files come out upright).
//! BMP and PPM are recognised by their first bytes (`BM`, `P1`-`P7`), TGA (which has no signature) by its
//! `.tga` extension; Mitsuba also finds TGA files by their header, and reads only binary 8/16-bit PPM (`P6`),
//! where the `image` crate reads every PNM variant (PBM/PGM/PPM/PAM, ASCII or binary). 8-bit BMP, PPM
//! and TGA texels are decoded as Mitsuba's Bitmap does for them: like an 8-bit PNG (sRGB unless `raw`;
//! palette and grey images give the same RGB values).
//! Storage follows Mitsuba's `format="auto"`: 8-bit images keep their bytes and are decoded per texel
//! (`b / 255`, then sRGB to linear unless `raw`) *before* interpolation, which is what decoding at load
//! time and interpolating linear values gives; 16-bit PNGs are linearised and rounded to half floats;
//! EXR half and float channels are used as stored. Alpha is dropped, Y (grey) is replicated to RGB.
//!
//! Lookup (Dr.Jit `tex_eval`): `uv = to_uv * (u, v, 1)`; bilinear: `x = u*W - 1/2`, `i = floor(x)`,
//! weights `(1 - (x - i), x - i)`, texels `i` and `i + 1` wrapped; nearest: `floor(u*W)` wrapped. Wrap
//! modes: repeat (Euclidean modulo), mirror (period 2W, edge texel repeated: -1 -> 0, W -> W-1), clamp.
//!
//! Checkerboard: `frac(uv) > 1/2` per axis; `color0` where both tests agree, `color1` otherwise (so
//! `color0` covers [0, 1/2]^2). Mitsuba's `eval_1` (scalar lookups) inverts this and returns the colours'
//! channel means: see [`eval_1`].
//!
//! Deviation: the sRGB curve is the exact piecewise formula (evaluated in f64, rounded to f32); Dr.Jit
//! uses a rational approximation of it. They differ by at most 3.6e-7 (37 ulp) on the 256 8-bit values
//! (test `srgb_table_matches_mitsuba`). JPEGs are decoded by zune-jpeg (through `image`), Mitsuba uses
//! libjpeg: decoded bytes differ by up to 4 codes (veach-ajar: 24% / 0.8% / 0.6% of the bytes of the
//! three textures differ, mean 0.33 / 0.009 / 0.007 codes); PNG and EXR texels are identical. Images smaller than 2x2 are used as they are: Mitsuba pads
//! them to 2x2 by replicating the last column/row, which changes no lookup (test `tiny_textures_match_mitsuba_eval`;
//! environment maps are padded, `crate::image::pad`).
use crate::error::{Error, Location, Result};
use crate::scene::types::{FilterType, Param, Texture, WrapMode};
use glam::{Vec2, Vec3};
use std::path::Path;

/// Loads a bitmap as linear RGB: (width, height, texels row-major, row 0 = top of the file).
///
/// PNG/JPEG/BMP/PPM/TGA: sRGB decoded to linear unless `raw`; EXR, RGBE (.hdr) and PFM: linear as stored (`raw` has
/// no effect). Every format's declared size is checked before decoding (texture size policy,
/// [`crate::image::size_policy`]).
/// Errors: `FileNotFound`; `Scene` for unreadable or unsupported images and images of more than
/// 16384^2 pixels (naming the file and the size); `OutOfMemory` (naming the scene location, the file,
/// its size and the memory limit) when decoding it needs more host memory than the memory policy allows.
pub fn load_bitmap(path: &Path, loc: &Location, raw: bool) -> Result<(u32, u32, Vec<Vec3>)> {
    if !path.exists() {
        return Err(Error::FileNotFound { loc: loc.clone(), path: path.to_path_buf() });
    }
    let at_loc = |e: Error| match e {
        Error::OutOfMemory(msg) => Error::OutOfMemory(format!("{loc}: {msg}")),
        e => Error::scene(loc, format!("cannot read image: {e}")),
    };
    // Float formats, recognised by their first bytes as Mitsuba's `Bitmap::detect_file_format` does.
    let float_reader: Option<FloatReader> = match magic(path)? {
        [0x76, 0x2f, 0x31, 0x01, ..] => Some(crate::image::io::read_exr),
        [b'#', b'?', ..] => Some(crate::image::hdr::read_hdr),
        [b'P', b'F' | b'f', ..] => Some(crate::image::pfm::read_pfm),
        _ => None,
    };
    if let Some(read) = float_reader {
        let (w, h, px) = read(path).map_err(at_loc)?;
        return Ok((w, h, px.into_iter().map(Vec3::from_array).collect()));
    }
    let img = decode_with_policy(path, loc, at_loc)?;
    let (w, h) = (img.width(), img.height());
    use image::DynamicImage as D;
    let table = byte_table(raw);
    let byte = |c: u8| table[c as usize];
    // 16-bit: Mitsuba stores these as half floats after linearisation.
    let short = |c: u16| {
        let x = c as f32 / 65535.0;
        round_to_half(if raw { x } else { srgb_to_linear(x) })
    };
    // Straight from the decoded buffer (no converted copy); grey (+ alpha) is replicated to RGB and
    // alpha dropped, as `to_rgb8` / `to_rgb16` do.
    let data = match &img {
        D::ImageLuma8(b) => texels(b.as_raw(), 1, byte),
        D::ImageLumaA8(b) => texels(b.as_raw(), 2, byte),
        D::ImageRgb8(b) => texels(b.as_raw(), 3, byte),
        D::ImageRgba8(b) => texels(b.as_raw(), 4, byte),
        D::ImageLuma16(b) => texels(b.as_raw(), 1, short),
        D::ImageLumaA16(b) => texels(b.as_raw(), 2, short),
        D::ImageRgb16(b) => texels(b.as_raw(), 3, short),
        D::ImageRgba16(b) => texels(b.as_raw(), 4, short),
        D::ImageRgb32F(b) => texels(b.as_raw(), 3, |c| c),
        D::ImageRgba32F(b) => texels(b.as_raw(), 4, |c| c),
        _ => texels(img.to_rgb16().as_raw(), 3, short),
    };
    Ok((w, h, data))
}

/// Colour channels of a bitmap file, alpha not counted (1 for grey images, 3 for RGB); float formats
/// (EXR, RGBE, PFM) count as 3, the RGB they are read as. Reads the header only.
/// Errors: `FileNotFound`; `Scene` (at `loc`) for an unreadable header.
pub fn bitmap_channels(path: &Path, loc: &Location) -> Result<u8> {
    if !path.exists() {
        return Err(Error::FileNotFound { loc: loc.clone(), path: path.to_path_buf() });
    }
    if matches!(magic(path)?, [0x76, 0x2f, 0x31, 0x01, ..] | [b'#', b'?', ..] | [b'P', b'F' | b'f', ..]) {
        return Ok(3);
    }
    use image::ImageDecoder;
    let bad = |e: image::ImageError| Error::scene(loc, format!("cannot decode image \"{}\": {e}", path.display()));
    let mut reader =
        image::ImageReader::open(path).map_err(|e| Error::io(path, e))?.with_guessed_format().map_err(|e| Error::io(path, e))?;
    reader.limits(crate::image::size_policy::decoder_limits(crate::image::size_policy::DECODER_OVERHEAD_BYTES));
    let color = reader.into_decoder().map_err(bad)?.color_type();
    Ok(color.channel_count() - u8::from(color.has_alpha()))
}

/// RGB texels of interleaved samples with `channels` per pixel (1 or 2: grey replicated).
fn texels<T: Copy>(samples: &[T], channels: usize, f: impl Fn(T) -> f32) -> Vec<Vec3> {
    samples.chunks_exact(channels).map(|p| if channels < 3 { Vec3::splat(f(p[0])) } else { Vec3::new(f(p[0]), f(p[1]), f(p[2])) }).collect()
}

/// Decodes a PNG, JPEG, BMP, PNM or TGA (`image` crate) after checking its declared size against the texture size
/// policy: the decoder's output, its working memory and the returned texels must fit; the decoder is
/// limited (`max_alloc`) to its share. Errors: `Io` when the file cannot be opened, the policy's errors
/// through `at_loc`, `Scene` for decoding errors.
fn decode_with_policy(path: &Path, loc: &Location, at_loc: impl Fn(Error) -> Error) -> Result<image::DynamicImage> {
    use crate::image::size_policy as policy;
    use image::{ImageDecoder, ImageFormat};
    let open = |limits: image::Limits| -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
        let mut reader =
            image::ImageReader::open(path).map_err(|e| Error::io(path, e))?.with_guessed_format().map_err(|e| Error::io(path, e))?;
        reader.limits(limits);
        Ok(reader)
    };
    let bad = |e: image::ImageError| Error::scene(loc, format!("cannot decode image \"{}\": {e}", path.display()));
    // The header only (the JPEG decoder reads the file's bytes, not the image).
    let reader = open(policy::decoder_limits(policy::DECODER_OVERHEAD_BYTES))?;
    let format = reader.format();
    let header = reader.into_decoder().map_err(bad)?;
    let ((w, h), output) = (header.dimensions(), header.color_type().bytes_per_pixel() as u64);
    drop(header);
    let (w, h) = (w as u64, h as u64);
    let working = match format {
        Some(ImageFormat::Jpeg) => policy::jpeg_working_bytes(w, h),
        _ => 0,
    } + policy::DECODER_OVERHEAD_BYTES;
    let what = match format {
        Some(ImageFormat::Png) => "PNG image".to_string(),
        Some(ImageFormat::Jpeg) => "JPEG image".to_string(),
        Some(ImageFormat::Bmp) => "BMP image".to_string(),
        Some(ImageFormat::Pnm) => "PNM image".to_string(),
        Some(ImageFormat::Tga) => "TGA image".to_string(),
        Some(f) => format!("{f:?} image"),
        None => "image".to_string(),
    };
    policy::check(path, &what, w, h, output + policy::TEXEL_BYTES, working).map_err(at_loc)?;
    open(policy::decoder_limits(w * h * output + working))?.decode().map_err(bad)
}

type FloatReader = fn(&Path) -> Result<(u32, u32, Vec<[f32; 3]>)>;

/// The first 4 bytes of a file (fewer when it is shorter).
fn magic(path: &Path) -> Result<[u8; 4]> {
    use std::io::Read;
    let mut head = [0u8; 4];
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut n = 0;
    while n < 4 {
        match f.read(&mut head[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(Error::io(path, e)),
        }
    }
    Ok(head)
}

/// The exact sRGB decoding curve (IEC 61966-2-1), evaluated in f64.
pub fn srgb_to_linear(x: f32) -> f32 {
    let x = x as f64;
    (if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) }) as f32
}

/// The exact sRGB encoding curve (inverse of [`srgb_to_linear`]), evaluated in f64.
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = x as f64;
    (if x <= 0.0031308 { x * 12.92 } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }) as f32
}

/// Linear value of each 8-bit code as Dr.Jit decodes it: `b * (1/255)` in f32, then sRGB unless `raw`.
fn byte_table(raw: bool) -> [f32; 256] {
    std::array::from_fn(|b| {
        let x = b as f32 * (1.0f32 / 255.0);
        if raw {
            x
        } else {
            srgb_to_linear(x)
        }
    })
}

/// Rounds an f32 to the nearest IEEE half value (ties to even), returned as f32.
pub fn round_to_half(x: f32) -> f32 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let a = x.abs();
    if a >= 65520.0 {
        return f32::INFINITY.copysign(x);
    }
    // Spacing of halves around a: 2^(e-10) for normal halves (e >= -14), 2^-24 for subnormals.
    let e = a.log2().floor().max(-14.0) as i32;
    let step = 2f32.powi(e - 10);
    let q = a / step; // exact: division by a power of two
    let f = q.floor();
    let r = match (q - f).partial_cmp(&0.5) {
        Some(std::cmp::Ordering::Less) => f,
        Some(std::cmp::Ordering::Greater) => f + 1.0,
        _ => f + (f % 2.0), // tie: to even
    };
    (r * step).copysign(x)
}

/// Dr.Jit's `tex_wrap`: maps an integer texel coordinate into [0, res).
fn wrap(i: i64, res: i64, mode: WrapMode) -> usize {
    let m = match mode {
        WrapMode::Clamp => i.clamp(0, res - 1),
        WrapMode::Repeat => i.rem_euclid(res),
        WrapMode::Mirror => {
            let m = i.rem_euclid(2 * res);
            if m < res {
                m
            } else {
                2 * res - 1 - m
            }
        }
    };
    m as usize
}

fn to_uv(m: &glam::Mat3, uv: Vec2) -> Vec2 {
    m.transform_point2(uv)
}

/// Bilinear or nearest lookup of a bitmap at a (transformed) uv.
fn lookup(width: u32, height: u32, data: &[Vec3], filter: FilterType, wrap_mode: WrapMode, uv: Vec2) -> Vec3 {
    let (w, h) = (width as i64, height as i64);
    let texel = |x: i64, y: i64| data[wrap(y, h, wrap_mode) * width as usize + wrap(x, w, wrap_mode)];
    match filter {
        FilterType::Nearest => {
            let (x, y) = ((uv.x * width as f32).floor(), (uv.y * height as f32).floor());
            texel(x as i64, y as i64)
        }
        FilterType::Bilinear => {
            let px = uv.x * width as f32 - 0.5;
            let py = uv.y * height as f32 - 0.5;
            let (fx, fy) = (px.floor(), py.floor());
            let (wx1, wy1) = (px - fx, py - fy);
            let (wx0, wy0) = (1.0 - wx1, 1.0 - wy1);
            let (ix, iy) = (fx as i64, fy as i64);
            // Corner order and weight products as in Dr.Jit's tex_eval.
            let mut out = Vec3::ZERO;
            out += texel(ix, iy) * (wx0 * wy0);
            out += texel(ix + 1, iy) * (wx1 * wy0);
            out += texel(ix, iy + 1) * (wx0 * wy1);
            out += texel(ix + 1, iy + 1) * (wx1 * wy1);
            out
        }
    }
}

/// `true` where Mitsuba's checkerboard `eval` picks `color0`.
fn checker_is_color0(uv: Vec2) -> bool {
    (uv.x - uv.x.floor() > 0.5) == (uv.y - uv.y.floor() > 0.5)
}

/// Evaluates an RGB texture at a surface uv (Mitsuba's `Texture::eval` in RGB variants).
pub fn eval(tex: &Texture, uv: Vec2) -> Vec3 {
    match tex {
        Texture::Bitmap { width, height, data, filter, wrap, to_uv: m, .. } => lookup(*width, *height, data, *filter, *wrap, to_uv(m, uv)),
        Texture::Checkerboard { color0, color1, to_uv: m } => {
            if checker_is_color0(to_uv(m, uv)) {
                *color0
            } else {
                *color1
            }
        }
    }
}

/// Mitsuba's luminance weights (`include/mitsuba/core/spectrum.h`).
pub fn luminance(c: Vec3) -> f32 {
    c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169
}

/// Evaluates a texture as a scalar, as Mitsuba's `eval_1` does (used for textured scalar parameters such
/// as roughness): a bitmap gives the luminance of its RGB lookup (grey images: the value); a checkerboard
/// gives the *mean* of `color1`'s channels where `eval` gives `color0`, and vice versa (Mitsuba 3.9.1's
/// `Checkerboard::eval_1` uses the opposite mask to `eval`; reproduced, not fixed).
pub fn eval_1(tex: &Texture, uv: Vec2) -> f32 {
    match tex {
        Texture::Bitmap { .. } => luminance(eval(tex, uv)),
        Texture::Checkerboard { color0, color1, to_uv: m } => {
            let c = if checker_is_color0(to_uv(m, uv)) { *color1 } else { *color0 };
            (c.x + c.y + c.z) / 3.0
        }
    }
}

/// Mitsuba 3.9.1's `eval_1_grad` of a texture at `uv` (`bitmap.cpp`): the derivative of the scalar
/// value (a texel's luminance) with respect to (u, v). Bilinear bitmaps: the bilinear patch's partial
/// derivatives in texel units, `df/dx = w0.y (f10 - f00) + w1.y (f11 - f01)`,
/// `df/dy = w0.x (f01 - f00) + w1.x (f11 - f10)`, through the transpose of `to_uv`'s linear part, times
/// the resolution; nearest-filtered bitmaps: 0. Checkerboards: 0 (Mitsuba implements no gradient for
/// them; the loader refuses them in a bumpmap).
pub fn eval_1_grad(tex: &Texture, uv: Vec2) -> Vec2 {
    let Texture::Bitmap { width, height, data, filter: FilterType::Bilinear, wrap: mode, to_uv: m, .. } = tex else {
        return Vec2::ZERO;
    };
    let uv = to_uv(m, uv);
    let (w, h) = (*width as i64, *height as i64);
    let f = |x: i64, y: i64| luminance(data[wrap(y, h, *mode) * *width as usize + wrap(x, w, *mode)]);
    let p = Vec2::new(uv.x.mul_add(*width as f32, -0.5), uv.y.mul_add(*height as f32, -0.5));
    let i = p.floor();
    let w1 = p - i;
    let w0 = Vec2::ONE - w1;
    let (ix, iy) = (i.x as i64, i.y as i64);
    let (f00, f10, f01, f11) = (f(ix, iy), f(ix + 1, iy), f(ix, iy + 1), f(ix + 1, iy + 1));
    let dx = w0.y.mul_add(f10 - f00, w1.y * (f11 - f01));
    let dy = w0.x.mul_add(f01 - f00, w1.x * (f11 - f10));
    let (du, dv) = (m.x_axis.x * dx + m.x_axis.y * dy, m.y_axis.x * dx + m.y_axis.y * dy);
    Vec2::new(*width as f32 * du, *height as f32 * dv)
}

/// Evaluates an RGB parameter: its value, or `eval` of `textures[i]`.
pub fn eval_param(textures: &[Texture], p: &Param, uv: Vec2) -> Vec3 {
    match p {
        Param::Value(v) => *v,
        Param::Texture(i) => eval(&textures[*i], uv),
    }
}

/// Evaluates a scalar parameter as Mitsuba does: a value's first channel, or `eval_1` of the texture.
pub fn eval_param_1(textures: &[Texture], p: &Param, uv: Vec2) -> f32 {
    match p {
        Param::Value(v) => v.x,
        Param::Texture(i) => eval_1(&textures[*i], uv),
    }
}

#[cfg(test)]
mod tests;
