use super::*;

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = crate::testing::scratch_dir("image");
    dir.join(name)
}

#[test]
fn exr_round_trip_is_exact() {
    let (w, h) = (5u32, 3u32);
    let px: Vec<[f32; 3]> = (0..w * h).map(|i| [i as f32 * 0.1, -(i as f32) * 1e-3, 1e6 + i as f32 * std::f32::consts::PI]).collect();
    let p = tmp("rt.exr");
    write_exr(&p, w, h, &px).unwrap();
    let (w2, h2, back) = read_exr(&p).unwrap();
    assert_eq!((w2, h2), (w, h));
    assert_eq!(back, px);
    assert!(write_exr(&p, 4, 4, &px).is_err());
}

#[test]
fn reads_piz_half_exr_of_shared_scene() {
    // bunny/textures/museum.exr: PIZ-compressed half RGB(A), as in the test scenes.
    let p = crate::testing::scene_file("bunny/textures/museum.exr");
    let (w, h, px) = read_exr(&p).unwrap();
    assert_eq!(px.len(), (w * h) as usize);
    assert!(px.iter().all(|c| c.iter().all(|v| v.is_finite() && *v >= 0.0)));
    let mean: f64 = px.iter().map(|c| c[1] as f64).sum::<f64>() / px.len() as f64;
    assert!(mean > 0.0);
}

#[test]
fn png_write_encodes_srgb() {
    let p = tmp("w.png");
    let px = [[0.0, 0.5, 1.0], [0.21586, 2.0, -1.0], [0.0031308, 0.25, f32::NAN], [1.0, 1.0, 1.0]];
    write_png(&p, 2, 2, &px, 0.0).unwrap();
    let img = image::open(&p).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (2, 2));
    assert_eq!(img.get_pixel(0, 0).0, [0, 188, 255]);
    assert_eq!(img.get_pixel(1, 0).0, [128, 255, 0]);
    assert_eq!(img.get_pixel(0, 1).0, [10, 137, 0]);
    write_png(&p, 2, 2, &px, -1.0).unwrap();
    assert_eq!(image::open(&p).unwrap().to_rgb8().get_pixel(1, 1).0, [188, 188, 188]);
}

#[test]
fn encoded_bytes_equal_the_crates_own_file_writers() {
    // encode_exr / encode_png (what the Python writers write) give the bytes that exr's write_rgb_file
    // and image's save_buffer write for the same pixels.
    let (w, h) = (7u32, 4u32);
    let px: Vec<[f32; 3]> = (0..w * h).map(|i| [i as f32 * 0.05, 0.5, 2.0 - i as f32 * 0.07]).collect();
    let p = tmp("crate.exr");
    exr::prelude::write_rgb_file(&p, w as usize, h as usize, |x, y| {
        let c = px[y * w as usize + x];
        (c[0], c[1], c[2])
    })
    .unwrap();
    let enc = encode_exr(w, h, &px).unwrap();
    assert_eq!(enc, std::fs::read(&p).unwrap());
    assert!(enc.len() > 300);
    let q = tmp("crate.png");
    image::save_buffer(&q, &encode_srgb8_image(&px, 0.5), w, h, image::ColorType::Rgb8).unwrap();
    assert_eq!(encode_png(w, h, &px, 0.5).unwrap(), std::fs::read(&q).unwrap());
    assert!(encode_png(w, h, &px[1..], 0.0).is_err());
}
