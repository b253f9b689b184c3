use super::*;

#[test]
fn pixel_cap_and_memory_policy() {
    let p = Path::new("dir/t.jpg");
    let e = check(p, "JPEG image", 16385, 16384, 1, 0).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "dir/t.jpg: JPEG image of 16385x16384 pixels is larger than supported (at most 268435456 pixels, 16384x16384)"
    );
    let e = check(p, "PNG image", u32::MAX as u64, u32::MAX as u64, 20, 0).unwrap_err().to_string();
    assert!(e.contains("4294967295x4294967295 pixels is larger than supported"), "{e}");
    // Under a 1 MiB bound, 300x300 pixels of 12 bytes (1.08 MB) are refused, 200x200 (480 kB) pass.
    crate::memory::with_thread_limit(1 << 20, || {
        assert!(check(p, "PNG image", 200, 200, 12, 0).is_ok());
        let e = check(p, "PNG image", 300, 300, 12, 0).unwrap_err();
        assert!(matches!(e, Error::OutOfMemory(_)), "{e:?}");
        assert_eq!(
            e.to_string(),
            "decoding \"dir/t.jpg\" (PNG image of 300x300 pixels) needs 1.1 MB of host memory but only 1.0 MB \
                 is available (MemAvailable, cgroup limit, address-space and data limits (ulimit -v / -d), \
                 MANYLIGHTS_MEMORY_LIMIT); request less"
        );
        // The extra bytes count too.
        assert!(check(p, "PNG image", 200, 200, 12, 600_000).is_err());
    });
}

#[test]
fn jpeg_working_memory_rounds_to_mcus() {
    assert_eq!(jpeg_working_bytes(1, 1), 32 * 32 * 8);
    assert_eq!(jpeg_working_bytes(2039, 65016), 2048 * 65024 * 8);
    assert_eq!(jpeg_working_bytes(u64::MAX, 2), u64::MAX);
    assert_eq!(decoder_limits(1000).max_alloc, Some(1000));
    assert_eq!(decoder_limits(1000).max_image_width, None);
}

// --- The policy as `texture::load_bitmap` applies it, for every format it reads. ---

use crate::error::Location;
use crate::scene::texture::load_bitmap;
use std::path::PathBuf;

fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = crate::testing::scratch_dir("size-policy");
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A PNG (8-bit RGB) declaring `w x h` whose data is one empty deflate stream (the header reads).
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let chunk = |b: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
        let body = [kind, data].concat();
        b.extend_from_slice(&(data.len() as u32).to_be_bytes());
        b.extend_from_slice(&body);
        b.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut b = b"\x89PNG\r\n\x1a\n".to_vec();
    chunk(&mut b, b"IHDR", &[&w.to_be_bytes()[..], &h.to_be_bytes(), &[8, 2, 0, 0, 0]].concat());
    chunk(&mut b, b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(&mut b, b"IEND", b"");
    b
}

fn crc32(data: &[u8]) -> u32 {
    let mut h = flate2::Crc::new();
    h.update(data);
    h.sum()
}

/// An 8x8 baseline JPEG (the `image` crate's encoder) whose SOF0 header is changed to `w x h`.
fn jpeg_declaring(w: u16, h: u16) -> Vec<u8> {
    let img = image::RgbImage::from_fn(8, 8, |x, y| image::Rgb([(x * 30) as u8, (y * 30) as u8, 128]));
    let mut b = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut b, 90).encode_image(&img).unwrap();
    let sof = b.windows(2).position(|m| m == [0xFF, 0xC0]).unwrap();
    b[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    b[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    b
}

/// A 4x4 float EXR whose data window is changed to `w x h`.
fn exr_declaring(w: i32, h: i32) -> Vec<u8> {
    let p = tmp("small.exr", b"");
    crate::image::write_exr(&p, 4, 4, &[[0.5; 3]; 16]).unwrap();
    let mut b = std::fs::read(&p).unwrap();
    let attr = b"dataWindow\0box2i\0";
    let i = b.windows(attr.len()).position(|m| m == attr).unwrap() + attr.len() + 4;
    for (k, v) in [0, 0, w - 1, h - 1].into_iter().enumerate() {
        b[i + 4 * k..i + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    b
}

fn hdr_declaring(w: u32, h: u32) -> Vec<u8> {
    format!("#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n\x7f\x7f\x7f\x01").into_bytes()
}

/// A 24-bit uncompressed BMP declaring `w x h` (bottom-up) with 4 bytes of pixel data.
fn bmp_declaring(w: i32, h: i32) -> Vec<u8> {
    let mut b = b"BM".to_vec();
    for v in [58u32, 0, 54] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&40u32.to_le_bytes());
    b.extend_from_slice(&w.to_le_bytes());
    b.extend_from_slice(&h.to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&24u16.to_le_bytes());
    b.extend_from_slice(&[0; 24]); // no compression, sizes, resolution, palette counts
    b.extend_from_slice(&[1, 2, 3, 0]);
    b
}

/// An uncompressed 24-bit TGA declaring `w x h` with 3 bytes of pixel data.
fn tga_declaring(w: u16, h: u16) -> Vec<u8> {
    let mut b = vec![0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    b.extend_from_slice(&w.to_le_bytes());
    b.extend_from_slice(&h.to_le_bytes());
    b.extend_from_slice(&[24, 0x20, 1, 2, 3]);
    b
}

fn load_err(name: &str, bytes: &[u8]) -> Error {
    let loc = Location::new("s.xml", 3);
    load_bitmap(&tmp(name, bytes), &loc, false).map(|(w, h, _)| (w, h)).unwrap_err()
}

#[test]
fn huge_declared_sizes_are_refused_for_every_format() {
    // A tiny file of each format declaring 60000 x 60000 pixels: an error naming the scene line, the
    // file and the size, before anything of that size is allocated.
    let cases: [(&str, Vec<u8>, &str); 8] = [
        ("huge.png", png_header(60000, 60000), "PNG image of 60000x60000 pixels is larger than supported"),
        ("huge.bmp", bmp_declaring(60000, 60000), "BMP image of 60000x60000 pixels is larger than supported"),
        ("huge.tga", tga_declaring(60000, 60000), "TGA image of 60000x60000 pixels is larger than supported"),
        ("huge.ppm", b"P6\n60000 60000\n255\n\x01\x02\x03".to_vec(), "PNM image of 60000x60000 pixels is larger than supported"),
        ("huge.jpg", jpeg_declaring(60000, 60000), "JPEG image of 60000x60000 pixels is larger than supported"),
        ("huge.exr", exr_declaring(60000, 60000), "EXR layer of 60000x60000 pixels is larger than supported"),
        ("huge.hdr", hdr_declaring(60000, 60000), "Radiance RGBE (.hdr) image of 60000x60000 pixels is larger than supported"),
        // PFM: the data must be in the file, which is checked first.
        ("huge.pfm", b"PF\n60000 60000\n-1\n\0\0\0\0".to_vec(), "60000x60000x3 floats need 43200000000 bytes of data"),
    ];
    for (name, bytes, want) in cases {
        let e = load_err(name, &bytes);
        let msg = e.to_string();
        assert!(matches!(e, Error::Scene { .. }), "{name}: {e:?}");
        assert!(msg.starts_with("s.xml:3: cannot read image: ") && msg.contains(name) && msg.contains(want), "{name}: {msg}");
        if !name.ends_with(".pfm") {
            assert!(msg.ends_with("(at most 268435456 pixels, 16384x16384)"), "{msg}");
        }
    }
}

#[test]
fn declared_sizes_over_the_memory_policy_are_refused() {
    // Under a 64 MiB bound, 4000 x 4000 pixels (16 M) fit no format: the error is OutOfMemory
    // (Python MemoryError) naming the scene line, the file, the size, the bytes and the bound.
    let limit = 64u64 << 20;
    let cases: [(&str, Vec<u8>, &str); 5] = [
        // 16e6 * (3 bytes decoded + 12 returned) + 16 MiB decoder overhead
        ("big.png", png_header(4000, 4000), "(PNG image of 4000x4000 pixels) needs 256.8 MB"),
        ("big.bmp", bmp_declaring(4000, -4000), "(BMP image of 4000x4000 pixels) needs 256.8 MB"),
        // 16e6 * (3 + 12) + 16e6 * 8 (coefficients) + 16 MiB
        ("big.jpg", jpeg_declaring(4000, 4000), "(JPEG image of 4000x4000 pixels) needs 384.8 MB"),
        // 16e6 * (3 float channels = 12 stored + 12 channel copies + 12 returned)
        ("big.exr", exr_declaring(4000, 4000), "(EXR layer of 4000x4000 pixels) needs 576.0 MB"),
        ("big.hdr", hdr_declaring(4000, 4000), "(Radiance RGBE (.hdr) image of 4000x4000 pixels) needs 192.0 MB"),
    ];
    for (name, bytes, want) in cases {
        let e = crate::memory::with_thread_limit(limit, || load_err(name, &bytes));
        let msg = e.to_string();
        assert!(matches!(e, Error::OutOfMemory(_)), "{name}: {e:?}");
        assert!(msg.starts_with("s.xml:3: decoding \"") && msg.contains(name) && msg.contains(want), "{name}: {msg}");
        assert!(msg.contains("of host memory but only 67.1 MB is available"), "{msg}");
    }
    // PFM: a 300 x 300 grey file (360 kB) and its texels (1.08 MB) under 1 MiB; it loads under 2 MiB.
    let mut pfm = b"Pf\n300 300\n-1\n".to_vec();
    pfm.extend((0..90_000).flat_map(|i| (i as f32 * 0.25).to_le_bytes()));
    let e = crate::memory::with_thread_limit(1 << 20, || load_err("big.pfm", &pfm));
    let msg = e.to_string();
    assert!(matches!(e, Error::OutOfMemory(_)) && msg.contains("(PFM image of 300x300 pixels) needs 1.4 MB"), "{msg}");
    let p = tmp("big.pfm", &pfm);
    let (w, h, px) = crate::memory::with_thread_limit(2 << 20, || load_bitmap(&p, &Location::default(), false)).unwrap();
    assert_eq!((w, h, px[0], px[300 * 300 - 1]), (300, 300, glam::Vec3::splat(299.0 * 300.0 * 0.25), glam::Vec3::splat(299.0 * 0.25)));
}

#[test]
fn normal_images_load_bit_exactly() {
    // 8- and 16-bit PNGs of every channel layout: texel = sRGB(code / max) (16-bit: rounded to half),
    // grey replicated, alpha dropped; the same values as converting with `to_rgb8` / `to_rgb16`.
    let srgb8 = |b: u8| crate::scene::texture::srgb_to_linear(b as f32 * (1.0f32 / 255.0));
    let codes8: Vec<u8> = (0..6 * 4).map(|i| (i * 37 % 256) as u8).collect();
    let codes16: Vec<u16> = (0..6 * 4).map(|i| (i * 9973 % 65536) as u16).collect();
    for (channels, color) in [
        (1, image::ExtendedColorType::L8),
        (2, image::ExtendedColorType::La8),
        (3, image::ExtendedColorType::Rgb8),
        (4, image::ExtendedColorType::Rgba8),
    ] {
        let p = tmp(&format!("c{channels}.png"), b"");
        image::save_buffer(&p, &codes8[..6 * channels], 3, 2, color).unwrap();
        let (w, h, px) = load_bitmap(&p, &Location::default(), false).unwrap();
        assert_eq!((w, h), (3, 2));
        for (i, t) in px.iter().enumerate() {
            let s = &codes8[i * channels..];
            let want = if channels < 3 { [srgb8(s[0]); 3] } else { [srgb8(s[0]), srgb8(s[1]), srgb8(s[2])] };
            assert_eq!(t.to_array(), want, "{channels} channels, texel {i}");
        }
    }
    let half = |c: u16| crate::scene::texture::round_to_half(crate::scene::texture::srgb_to_linear(c as f32 / 65535.0));
    for (channels, color) in
        [(1, image::ColorType::L16), (2, image::ColorType::La16), (3, image::ColorType::Rgb16), (4, image::ColorType::Rgba16)]
    {
        let p = tmp(&format!("s{channels}.png"), b"");
        let bytes: Vec<u8> = codes16[..6 * channels].iter().flat_map(|c| c.to_ne_bytes()).collect();
        image::save_buffer(&p, &bytes, 3, 2, color).unwrap();
        let (_, _, px) = load_bitmap(&p, &Location::default(), false).unwrap();
        for (i, t) in px.iter().enumerate() {
            let s = &codes16[i * channels..];
            let want = if channels < 3 { [half(s[0]); 3] } else { [half(s[0]), half(s[1]), half(s[2])] };
            assert_eq!(t.to_array(), want, "16-bit, {channels} channels, texel {i}");
        }
    }
    // A JPEG: the texels are exactly the decoded bytes through the sRGB table.
    let p = tmp("ok.jpg", &jpeg_declaring(8, 8));
    let (w, h, px) = load_bitmap(&p, &Location::default(), false).unwrap();
    let rgb = image::open(&p).unwrap().to_rgb8();
    assert_eq!((w, h), (8, 8));
    let want: Vec<[f32; 3]> = rgb.pixels().map(|q| q.0.map(srgb8)).collect();
    assert_eq!(px.iter().map(|t| t.to_array()).collect::<Vec<_>>(), want);
}

#[test]
fn bmp_ppm_tga_texels_equal_the_png_of_the_same_pixels() {
    // The same 8-bit pixels written as PNG, BMP, PPM and TGA (the `image` crate's encoders; RGB, grey and
    // RGBA where the format has them) load to the same texels, sRGB-decoded or raw. Mitsuba 3.9.1's
    // Bitmap gives these formats' 8-bit pixels the PNG's values too (checked with a 4x3 image: texel
    // (95, 130, 194) evaluates to (0.114435, 0.223228, 0.53948), raw (0.372549, 0.509804, 0.760784)).
    let (w, h) = (5u32, 3u32);
    let rgb: Vec<u8> = (0..w * h * 4).map(|i| (i * 53 % 256) as u8).collect();
    let layouts = [(1, image::ExtendedColorType::L8), (3, image::ExtendedColorType::Rgb8), (4, image::ExtendedColorType::Rgba8)];
    for (channels, color) in layouts {
        let px = &rgb[..(w * h) as usize * channels];
        let png = tmp(&format!("same{channels}.png"), b"");
        image::save_buffer(&png, px, w, h, color).unwrap();
        for raw in [false, true] {
            let (_, _, want) = load_bitmap(&png, &Location::default(), raw).unwrap();
            let first = if channels == 1 { [rgb[0]; 3] } else { [rgb[0], rgb[1], rgb[2]] };
            let code =
                |b: u8| if raw { b as f32 * (1.0f32 / 255.0) } else { crate::scene::texture::srgb_to_linear(b as f32 * (1.0f32 / 255.0)) };
            assert_eq!(want[0].to_array(), first.map(code));
            for ext in ["bmp", "ppm", "tga"] {
                // PPM holds RGB or grey only (grey as PGM), BMP no alpha from this encoder.
                if (ext == "ppm" || ext == "bmp") && channels == 4 {
                    continue;
                }
                let p = tmp(&format!("same{channels}.{ext}"), b"");
                image::save_buffer(&p, px, w, h, color).unwrap();
                let (gw, gh, got) = load_bitmap(&p, &Location::default(), raw).unwrap();
                assert_eq!((gw, gh), (w, h), "{ext}");
                assert_eq!(got, want, "{ext}, {channels} channels, raw {raw}");
            }
        }
    }
    // The encoder above writes RLE-compressed TGA (and bottom-up BMP); an uncompressed TGA reads the same.
    let p = tmp("flat.tga", b"");
    let img = image::RgbImage::from_raw(w, h, rgb[..(w * h * 3) as usize].to_vec()).unwrap();
    let mut bytes = Vec::new();
    image::codecs::tga::TgaEncoder::new(&mut bytes).disable_rle().encode(img.as_raw(), w, h, image::ExtendedColorType::Rgb8).unwrap();
    assert_eq!(bytes[2], 2, "uncompressed true-colour TGA");
    std::fs::write(&p, &bytes).unwrap();
    let (_, _, got) = load_bitmap(&p, &Location::default(), false).unwrap();
    let png = tmp("same3.png", b"");
    image::save_buffer(&png, img.as_raw(), w, h, image::ExtendedColorType::Rgb8).unwrap();
    assert_eq!(got, load_bitmap(&png, &Location::default(), false).unwrap().2);
}
