//! Bitmap loading and texture evaluation as Mitsuba 3.9.1 does them (`src/textures/bitmap.cpp`,
//! `src/textures/checkerboard.cpp`, Dr.Jit 1.5 `include/drjit/texture_impl.h`).
//!
//! Bitmaps: PNG/JPEG through `image`, EXR through `exr` ([`crate::image::io`]), Radiance RGBE
//! ([`crate::image::hdr`]) and PFM ([`crate::image::pfm`]); float formats are recognised by their first
//! bytes (as Mitsuba's `detect_file_format`), whatever the file's extension. Row 0 is the first row of
//! the file (the top of the picture) and is looked up at v = 0: Mitsuba's texture row is `floor(v*H - 1/2)`
//! with no flip (the OBJ loader's `v' = 1 - v` is what makes OBJ files come out upright).
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
/// PNG/JPEG: sRGB decoded to linear unless `raw`; EXR, RGBE (.hdr) and PFM: linear as stored (`raw` has
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

/// RGB texels of interleaved samples with `channels` per pixel (1 or 2: grey replicated).
fn texels<T: Copy>(samples: &[T], channels: usize, f: impl Fn(T) -> f32) -> Vec<Vec3> {
    samples
        .chunks_exact(channels)
        .map(|p| if channels < 3 { Vec3::splat(f(p[0])) } else { Vec3::new(f(p[0]), f(p[1]), f(p[2])) })
        .collect()
}

/// Decodes a PNG or JPEG (`image` crate) after checking its declared size against the texture size
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
        Texture::Bitmap { width, height, data, filter, wrap, to_uv: m, .. } => {
            lookup(*width, *height, data, *filter, *wrap, to_uv(m, uv))
        }
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
mod tests {
    use super::*;
    use glam::Mat3;

    fn bitmap(w: u32, h: u32, data: Vec<Vec3>, filter: FilterType, wrap: WrapMode) -> Texture {
        Texture::Bitmap { width: w, height: h, data, filter, wrap, to_uv: Mat3::IDENTITY, loc: Location::default() }
    }

    #[test]
    fn wrap_modes_match_drjit() {
        let r: Vec<usize> = (-5..9).map(|i| wrap(i, 4, WrapMode::Repeat)).collect();
        assert_eq!(r, vec![3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]);
        let m: Vec<usize> = (-5..9).map(|i| wrap(i, 4, WrapMode::Mirror)).collect();
        assert_eq!(m, vec![3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
        let c: Vec<usize> = (-2..6).map(|i| wrap(i, 4, WrapMode::Clamp)).collect();
        assert_eq!(c, vec![0, 0, 0, 1, 2, 3, 3, 3]);
    }

    #[test]
    fn bilinear_texel_centres_and_rows() {
        // 2x2: row 0 (top) = (0, 1), row 1 = (2, 3) in the red channel.
        let data = (0..4).map(|i| Vec3::splat(i as f32)).collect();
        let t = bitmap(2, 2, data, FilterType::Bilinear, WrapMode::Clamp);
        assert_eq!(eval(&t, Vec2::new(0.25, 0.25)).x, 0.0); // texel centre of (0, 0): v=0 is row 0
        assert_eq!(eval(&t, Vec2::new(0.75, 0.75)).x, 3.0);
        assert_eq!(eval(&t, Vec2::new(0.5, 0.25)).x, 0.5);
        assert_eq!(eval(&t, Vec2::new(0.5, 0.5)).x, 1.5);
        assert_eq!(eval(&t, Vec2::new(0.0, 0.0)).x, 0.0); // clamped
        let t = bitmap(2, 2, (0..4).map(|i| Vec3::splat(i as f32)).collect(), FilterType::Bilinear, WrapMode::Repeat);
        assert_eq!(eval(&t, Vec2::new(0.0, 0.25)).x, 0.5); // halfway between texel 1 (wrapped) and 0
        let t = bitmap(2, 2, (0..4).map(|i| Vec3::splat(i as f32)).collect(), FilterType::Nearest, WrapMode::Repeat);
        assert_eq!(eval(&t, Vec2::new(0.99, 0.01)).x, 1.0);
        assert_eq!(eval(&t, Vec2::new(1.01, 0.51)).x, 2.0);
    }

    #[test]
    fn checkerboard_rule() {
        let t = Texture::Checkerboard { color0: Vec3::splat(0.4), color1: Vec3::splat(0.2), to_uv: Mat3::IDENTITY };
        assert_eq!(eval(&t, Vec2::new(0.25, 0.25)).x, 0.4);
        assert_eq!(eval(&t, Vec2::new(0.75, 0.25)).x, 0.2);
        assert_eq!(eval(&t, Vec2::new(0.75, 0.75)).x, 0.4);
        assert_eq!(eval(&t, Vec2::new(-0.25, 0.25)).x, 0.2);
        assert_eq!(eval(&t, Vec2::new(0.5, 0.5)).x, 0.4); // > 0.5 is strict
        assert_eq!(eval_1(&t, Vec2::new(0.25, 0.25)), 0.2); // Mitsuba's inverted eval_1
        let scaled = Texture::Checkerboard {
            color0: Vec3::X,
            color1: Vec3::Y,
            to_uv: Mat3::from_scale(Vec2::new(4.0, 4.0)),
        };
        assert_eq!(eval(&scaled, Vec2::new(0.2, 0.05)), Vec3::Y); // uv' = (0.8, 0.2)
    }

    #[test]
    fn half_rounding() {
        assert_eq!(round_to_half(1.0), 1.0);
        assert_eq!(round_to_half(1.0 + 1.0 / 2048.0), 1.0); // tie to even
        assert_eq!(round_to_half(1.0 + 3.0 / 2048.0), 1.0 + 2.0 / 1024.0);
        assert_eq!(round_to_half(0.1), 0.099975586);
        assert_eq!(round_to_half(-3.0e-6), -2.9802322e-6); // subnormal half: 50 * 2^-24
        assert_eq!(round_to_half(70000.0), f32::INFINITY);
    }

    #[test]
    fn srgb_curve() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        assert!((srgb_to_linear(0.5) - 0.21404114).abs() < 1e-7);
        for i in 0..=100 {
            let x = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(x)) - x).abs() < 1e-6);
        }
    }
}

/// Texture lookups against values printed by mitsuba 3.9.1 (scalar_rgb, `mi.load_dict` of a `bitmap`
/// texture, `tex.eval(si)` with `si.uv` set).
#[cfg(test)]
mod mitsuba_tests {
    use super::*;
    use glam::Mat3;

    const UVS: [[f32; 2]; 9] = [[0.10000000149011612, 0.20000000298023224], [0.5, 0.5], [0.9136999845504761, 0.042100001126527786], [0.0, 0.0], [1.0, 1.0], [-0.30000001192092896, 1.7000000476837158], [0.3333300054073334, 0.666670024394989], [0.9990000128746033, 0.0010000000474974513], [2.5999999046325684, -1.2000000476837158]];
    #[rustfmt::skip]
    const SMALL_PNG: [(&str, &str, [[f32; 3]; 9]); 6] = [
        ("bilinear", "repeat", [[0.03260252624750137, 0.1856197863817215, 0.3840978741645813], [0.34142130613327026, 0.39328643679618835, 0.09070300310850143], [0.13123542070388794, 0.4173920750617981, 0.3402618169784546], [0.19762378931045532, 0.2524685263633728, 0.3913253843784332], [0.19762378931045532, 0.2524685263633728, 0.3913253843784332], [0.20934097468852997, 0.12432949990034103, 0.4703649580478668], [0.5256116390228271, 0.4004656970500946, 0.1970415860414505], [0.19614195823669434, 0.2545692026615143, 0.39081913232803345], [0.12447448819875717, 0.14302986860275269, 0.5244898200035095]]),
        ("bilinear", "mirror", [[0.013013657182455063, 0.14686645567417145, 0.42210152745246887], [0.34142130613327026, 0.39328643679618835, 0.09070300310850143], [0.15896087884902954, 0.5906191468238831, 0.018500234931707382], [0.0, 0.10461656004190445, 0.46778392791748047], [0.04091515764594078, 0.2961381673812866, 0.8631570339202881], [0.09454897791147232, 0.3921365439891815, 0.39738985896110535], [0.5256116390228271, 0.4004656970500946, 0.1970415860414505], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.12447448819875717, 0.14302986860275269, 0.5244898200035095]]),
        ("bilinear", "clamp", [[0.013013657182455063, 0.14686645567417145, 0.42210152745246887], [0.34142130613327026, 0.39328643679618835, 0.09070300310850143], [0.15896087884902954, 0.5906191468238831, 0.018500234931707382], [0.0, 0.10461656004190445, 0.46778392791748047], [0.04091515764594078, 0.2961381673812866, 0.8631570339202881], [0.5906191468238831, 0.01850023679435253, 0.21586041152477264], [0.5256116390228271, 0.4004656970500946, 0.1970415860414505], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253]]),
        ("nearest", "repeat", [[0.0, 0.10461656004190445, 0.46778392791748047], [0.4286905825138092, 0.0030352699104696512, 0.13013656437397003], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.0, 0.10461656004190445, 0.46778392791748047], [0.0, 0.10461656004190445, 0.46778392791748047], [0.0069953990168869495, 0.15896087884902954, 0.5906191468238831], [0.8631570339202881, 0.06847819685935974, 0.3762621283531189], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.0069953990168869495, 0.15896087884902954, 0.5906191468238831]]),
        ("nearest", "mirror", [[0.0, 0.10461656004190445, 0.46778392791748047], [0.4286905825138092, 0.0030352699104696512, 0.13013656437397003], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.0, 0.10461656004190445, 0.46778392791748047], [0.04091515764594078, 0.2961381673812866, 0.8631570339202881], [0.01850023679435253, 0.21586041152477264, 0.708375871181488], [0.8631570339202881, 0.06847819685935974, 0.3762621283531189], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.0069953990168869495, 0.15896087884902954, 0.5906191468238831]]),
        ("nearest", "clamp", [[0.0, 0.10461656004190445, 0.46778392791748047], [0.4286905825138092, 0.0030352699104696512, 0.13013656437397003], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.0, 0.10461656004190445, 0.46778392791748047], [0.04091515764594078, 0.2961381673812866, 0.8631570339202881], [0.5906191468238831, 0.01850023679435253, 0.21586041152477264], [0.8631570339202881, 0.06847819685935974, 0.3762621283531189], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253], [0.15896087884902954, 0.5906191468238831, 0.01850023679435253]]),
    ];
    #[rustfmt::skip]
    const VEACH_JPEGS: [(&str, &str, &str, [[f32; 3]; 9]); 6] = [
        ("landscape-with-a-lake.jpg", "nearest", "repeat", [[0.13286840915679932, 0.15292619168758392, 0.10461656004190445], [0.020288566127419472, 0.03310472518205643, 0.03310472518205643], [0.7379103899002075, 0.7304607629776001, 0.7156935930252075], [0.4452013671398163, 0.5149178504943848, 0.5906191468238831], [0.4452013671398163, 0.5149178504943848, 0.5906191468238831], [0.03433976694941521, 0.05951123312115669, 0.04970654472708702], [0.06124606728553772, 0.10461656004190445, 0.25415199995040894], [0.7304607629776001, 0.679542601108551, 0.6375971436500549], [0.04970654472708702, 0.0781874731183052, 0.005605378188192844]]),
        ("landscape-with-a-lake.jpg", "nearest", "mirror", [[0.13286840915679932, 0.15292619168758392, 0.10461656004190445], [0.020288566127419472, 0.03310472518205643, 0.03310472518205643], [0.7379103899002075, 0.7304607629776001, 0.7156935930252075], [0.4452013671398163, 0.5149178504943848, 0.5906191468238831], [0.2086368203163147, 0.19461779296398163, 0.016807397827506065], [0.01599631831049919, 0.04518616944551468, 0.07421360909938812], [0.06124606728553772, 0.10461656004190445, 0.25415199995040894], [0.7304607629776001, 0.679542601108551, 0.6375971436500549], [0.04970654472708702, 0.0781874731183052, 0.005605378188192844]]),
        ("Good Textures_005844.jpg", "bilinear", "repeat", [[0.7312988042831421, 0.4890705645084381, 0.24119335412979126], [0.690300464630127, 0.45083674788475037, 0.18133051693439484], [0.8365128040313721, 0.6012924909591675, 0.3159295320510864], [0.7308147549629211, 0.5266641974449158, 0.2480948120355606], [0.7308147549629211, 0.5266641974449158, 0.2480948120355606], [0.7124953269958496, 0.4954540729522705, 0.23135803639888763], [0.698967695236206, 0.4816040098667145, 0.22372762858867645], [0.8796449303627014, 0.6479090452194214, 0.3614248037338257], [0.7103438377380371, 0.49350297451019287, 0.2316156029701233]]),
        ("Good Textures_005844.jpg", "bilinear", "mirror", [[0.7312988042831421, 0.4890705645084381, 0.24119335412979126], [0.690300464630127, 0.45083674788475037, 0.18133051693439484], [0.8365128040313721, 0.6012924909591675, 0.3159295320510864], [0.6307573318481445, 0.42326778173446655, 0.15592651069164276], [0.7835376262664795, 0.5711251497268677, 0.2917705774307251], [0.7386627197265625, 0.5095043778419495, 0.2446683943271637], [0.698967695236206, 0.4816040098667145, 0.22372762858867645], [0.8796449303627014, 0.6479090452194214, 0.3614248037338257], [0.7103438377380371, 0.49350297451019287, 0.2316156029701233]]),
        ("cherry-wood-texture.jpg", "bilinear", "repeat", [[0.2662619650363922, 0.054484978318214417, 0.016026750206947327], [0.30119964480400085, 0.06863830238580704, 0.022637544199824333], [0.23853734135627747, 0.043861646205186844, 0.011693742126226425], [0.38294917345046997, 0.10754469782114029, 0.04134001210331917], [0.38294917345046997, 0.10754469782114029, 0.04134001210331917], [0.307739794254303, 0.07890844345092773, 0.026984935626387596], [0.4114795923233032, 0.12163028866052628, 0.04941504821181297], [0.4581429362297058, 0.14680345356464386, 0.05583877116441727], [0.3260525166988373, 0.0805678442120552, 0.02857099287211895]]),
        ("cherry-wood-texture.jpg", "bilinear", "mirror", [[0.2662619650363922, 0.054484978318214417, 0.016026750206947327], [0.30119964480400085, 0.06863830238580704, 0.022637544199824333], [0.23853734135627747, 0.043861646205186844, 0.011693742126226425], [0.31854674220085144, 0.0781874731183052, 0.025186840444803238], [0.5271154642105103, 0.17464739084243774, 0.08021987229585648], [0.43967148661613464, 0.13014812767505646, 0.05287059023976326], [0.4114795923233032, 0.12163028866052628, 0.04941504821181297], [0.4581429362297058, 0.14680345356464386, 0.05583877116441727], [0.3260525166988373, 0.0805678442120552, 0.02857099287211895]]),
    ];

    fn filter_of(s: &str) -> FilterType {
        if s == "nearest" { FilterType::Nearest } else { FilterType::Bilinear }
    }

    fn wrap_of(s: &str) -> WrapMode {
        match s {
            "repeat" => WrapMode::Repeat,
            "mirror" => WrapMode::Mirror,
            _ => WrapMode::Clamp,
        }
    }

    fn texture(path: &Path, filter: FilterType, wrap: WrapMode, to_uv: Mat3) -> Texture {
        let (width, height, data) = load_bitmap(path, &Location::default(), false).unwrap();
        Texture::Bitmap { width, height, data, filter, wrap, to_uv, loc: Location::default() }
    }

    /// The 4x3 8-bit PNG given to mitsuba: byte (x, y, c) = (37x + 101y + 91c) mod 256.
    fn small_png() -> std::path::PathBuf {
        let dir = crate::testing::scratch_dir("tex");
        let path = dir.join("small.png");
        let img = image::RgbImage::from_fn(4, 3, |x, y| {
            image::Rgb(std::array::from_fn(|c| ((x * 37 + y * 101 + c as u32 * 91) % 256) as u8))
        });
        img.save(&path).unwrap();
        path
    }

    #[test]
    fn png_lookups_match_mitsuba() {
        // Mitsuba's rational sRGB approximation differs from the exact curve by <= 3.6e-7.
        const TOL: f32 = 1e-6;
        let path = small_png();
        for (filter, wrap, expect) in SMALL_PNG {
            let t = texture(&path, filter_of(filter), wrap_of(wrap), Mat3::IDENTITY);
            for (uv, want) in UVS.iter().zip(expect) {
                let got = eval(&t, Vec2::from_array(*uv));
                let err = (got - Vec3::from_array(want)).abs().max_element();
                assert!(err < TOL, "{filter}/{wrap} uv {uv:?}: {got} vs {want:?}");
            }
        }
        // to_uv = translate(0.1, 0.2) * scale(2, 3), bilinear repeat, and eval_1 (luminance).
        let m = Mat3::from_translation(Vec2::new(0.1, 0.2)) * Mat3::from_scale(Vec2::new(2.0, 3.0));
        let t = texture(&path, FilterType::Bilinear, WrapMode::Repeat, m);
        let got = eval(&t, Vec2::new(0.3, 0.4));
        assert!((got - Vec3::new(0.37700400, 0.13962762, 0.11880385)).abs().max_element() < TOL, "{got}");
        assert!((eval_1(&t, Vec2::new(0.3, 0.4)) - 0.18860786).abs() < TOL);
    }

    #[test]
    fn srgb_table_matches_mitsuba() {
        // Mitsuba's decoded 8-bit values at 0, 10, 50, 128, 200, 255 (nearest lookups of a ramp PNG).
        let want = [(0, 0.0), (10, 0.00303527), (50, 0.031895995), (128, 0.21586041), (200, 0.57758075), (255, 1.0)];
        let table = byte_table(false);
        for (b, v) in want {
            assert!((table[b] - v).abs() < 4e-7, "{b}: {} vs {v}", table[b]);
        }
        assert_eq!(byte_table(true)[200], 0.78431380); // raw: b * (1/255) in f32
    }

    #[test]
    fn veach_ajar_jpegs_match_mitsuba() {
        // The JPEG decoders differ (zune-jpeg here, libjpeg in Mitsuba): up to 4 codes on 8-bit values,
        // measured over whole images, so lookups are compared with a tolerance of a few codes.
        const TOL: f32 = 0.025;
        let root = crate::scene::mesh::shared_dir().join("scenes/veach-ajar/textures");
        let mut worst = 0.0f32;
        for (name, filter, wrap, expect) in VEACH_JPEGS {
            let t = texture(&root.join(name), filter_of(filter), wrap_of(wrap), Mat3::IDENTITY);
            for (uv, want) in UVS.iter().zip(expect) {
                let got = eval(&t, Vec2::from_array(*uv));
                let err = (got - Vec3::from_array(want)).abs().max_element();
                worst = worst.max(err);
                assert!(err < TOL, "{name} {wrap} uv {uv:?}: {got} vs {want:?}");
            }
        }
        println!("worst JPEG lookup difference: {worst}");
        let (w, h, _) = load_bitmap(&root.join("Good Textures_005844.jpg"), &Location::default(), false).unwrap();
        assert_eq!((w, h), (2000, 3008));
    }

    #[test]
    fn veach_ajar_checkerboard_matches_mitsuba() {
        // color0 0.8, color1 0.2, to_uv scale(20, 80); mitsuba 3.9.1 eval (and eval_1 for the first 8).
        let t = Texture::Checkerboard {
            color0: Vec3::splat(0.8),
            color1: Vec3::splat(0.2),
            to_uv: Mat3::from_scale(Vec2::new(20.0, 80.0)),
        };
        let uvs = UVS[..8].iter().map(|u| Vec2::from_array(*u))
            .chain([Vec2::new(0.01, 0.01), Vec2::new(0.026, 0.003), Vec2::new(0.026, 0.0068)]);
        let want = [0.8, 0.8, 0.8, 0.8, 0.8, 0.8, 0.2, 0.2, 0.2, 0.2, 0.8];
        for (k, (uv, w)) in uvs.zip(want).enumerate() {
            assert_eq!(eval(&t, uv), Vec3::splat(w), "uv {uv}");
            if k < 8 {
                assert!((eval_1(&t, uv) - (1.0 - w)).abs() < 1e-6, "eval_1 at {uv}");
            }
        }
    }

    #[test]
    fn missing_bitmap_is_file_not_found() {
        let e = load_bitmap(Path::new("/nonexistent.png"), &Location::new("s.xml", 7), false).unwrap_err();
        assert!(matches!(e, Error::FileNotFound { .. }) && e.to_string().starts_with("s.xml:7"), "{e}");
    }
}
