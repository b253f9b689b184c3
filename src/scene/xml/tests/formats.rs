//! Image formats (EXR, Radiance RGBE, PFM) for environment maps and bitmap textures, and Mitsuba's
//! padding of tiny environment maps, against mitsuba 3.9.1 (scalar_rgb): `mi.traverse(envmap)["data"]`
//! shapes and `envmap.eval(si)` values printed by `mi.load_dict({"type": "envmap", ...})`.
#![allow(clippy::excessive_precision, clippy::type_complexity)]
use crate::error::Error;
use crate::lights::generate::environment::envmap_radiance;
use crate::scene::xml::*;
use crate::scene::{Emitter, Texture};
use glam::Vec3;
use std::path::PathBuf;

fn dir(test: &str) -> PathBuf {
    crate::testing::scratch_dir(&format!("formats-{test}"))
}

/// Dyadic texels (exact in EXR, RGBE and PFM): texel (x, y), channel c = ((5x + 3y + 7c) mod 16 + 1) / 16.
fn texels(w: u32, h: u32) -> Vec<[f32; 3]> {
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            std::array::from_fn(|c| ((x * 5 + y * 3 + c as u32 * 7) % 16 + 1) as f32 / 16.0)
        })
        .collect()
}

fn write_hdr(path: &std::path::Path, w: u32, h: u32, px: &[[f32; 3]]) {
    let rgb: Vec<image::Rgb<f32>> = px.iter().map(|p| image::Rgb(*p)).collect();
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    image::codecs::hdr::HdrEncoder::new(f).encode(&rgb, w as usize, h as usize).unwrap();
}

/// Writes the map in `ext`'s format.
fn write_map(path: &std::path::Path, w: u32, h: u32, px: &[[f32; 3]]) {
    match path.extension().unwrap().to_str().unwrap() {
        "exr" => crate::image::write_exr(path, w, h, px).unwrap(),
        "hdr" => write_hdr(path, w, h, px),
        "pfm" => crate::image::write_pfm(path, w, h, px).unwrap(),
        e => panic!("{e}"),
    }
}

fn load(d: &std::path::Path, body: &str) -> Result<Scene> {
    let xml = format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" \
         value=\"8\"/><integer name=\"height\" value=\"8\"/></film></sensor>\n<shape type=\"rectangle\"/>\n{body}\n</scene>\n"
    );
    let p = d.join("scene.xml");
    std::fs::write(&p, xml).unwrap();
    load_scene(&p, &LoadOptions::default())
}

const DIRS: [[f32; 3]; 10] = [
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
    [0.3, 0.5, -0.8],
    [-0.6, -0.2, 0.4],
    [0.9, 0.1, 0.2],
    [0.05, 0.99, 0.1],
];

/// (width, height) of the file, Mitsuba's data tensor (H, W + 2) and `eval` toward each of `DIRS`.
#[rustfmt::skip]
const MITSUBA_EVAL: [((u32, u32), (u32, u32), [[f32; 3]; 10]); 4] = [
    ((1, 1), (3, 4), [[0.0625, 0.5, 0.9375]; 10]),
    ((7, 1), (3, 9), [[0.5, 0.4375, 0.875], [0.5, 0.4375, 0.875], [0.453125, 0.640625, 0.328125], [0.546875, 0.234375, 0.421875], [1.0, 0.4375, 0.875], [0.5, 0.4375, 0.875], [0.1502619981765747, 0.48746258020401, 0.92496258020401], [0.3421609103679657, 0.6847459673881531, 0.2171609103679657], [0.5292549729347229, 0.47313910722732544, 0.4042549729347229], [0.8385804295539856, 0.2760803699493408, 0.7135803699493408]]),
    ((7, 2), (3, 9), [[0.5, 0.4375, 0.875], [0.1875, 0.625, 0.5625], [0.640625, 0.828125, 0.515625], [0.734375, 0.421875, 0.609375], [0.1875, 0.625, 0.0625], [0.1875, 0.625, 0.5625], [0.20806975662708282, 0.6117616891860962, 0.45282435417175293], [0.5296608805656433, 0.8722460269927979, 0.4046609103679657], [0.7038582563400269, 0.6477423906326294, 0.5788582563400269], [0.8173922896385193, 0.28950387239456177, 0.6923922896385193]]),
    ((1, 4), (4, 4), [[0.0625, 0.5, 0.9375], [0.625, 0.0625, 0.5], [0.34375, 0.78125, 0.21875], [0.34375, 0.78125, 0.21875], [0.34375, 0.78125, 0.21875], [0.34375, 0.78125, 0.21875], [0.24894869327545166, 0.6864486932754517, 0.1295555979013443], [0.39219170808792114, 0.8296917080879211, 0.26719170808792114], [0.3244050145149231, 0.7619049549102783, 0.1994050145149231], [0.08263520896434784, 0.520135223865509, 0.8502473831176758]]),
];

#[test]
fn tiny_envmaps_in_every_format_match_mitsuba_eval() {
    // f32 lookups (atan2/acos, bilinear weights) against Mitsuba's: a few ulp at values <= 1.
    const TOL: f32 = 2e-6;
    let d = dir("tiny-env");
    for ((w, h), (mh, mw2), want) in MITSUBA_EVAL {
        let px = texels(w, h);
        for ext in ["exr", "hdr", "pfm"] {
            let name = format!("env_{w}x{h}.{ext}");
            write_map(&d.join(&name), w, h, &px);
            let s = load(&d, &format!("<emitter type=\"envmap\"><string name=\"filename\" value=\"{name}\"/></emitter>")).unwrap();
            let Emitter::EnvMap { map, .. } = &s.emitters[0] else { panic!("not an envmap") };
            // Mitsuba's tensor is the padded map plus one halo column on each side.
            assert_eq!((map.height, map.width + 2), (mh, mw2), "{name}");
            for (k, (dir, want)) in DIRS.iter().zip(want).enumerate() {
                if k < 2 && w > 1 {
                    // Exactly at a pole u is undefined: atan2(+-0, +-0) picks a seam side by the signs of
                    // zeros, which differ between Mitsuba's transform and ours.
                    continue;
                }
                let got = envmap_radiance(map, Vec3::from_array(*dir).normalize());
                let err = (got - Vec3::from_array(want)).abs().max_element();
                assert!(err < TOL, "{name} toward {dir:?}: {got} vs Mitsuba {want:?}");
            }
        }
    }
}

#[test]
fn the_same_map_as_exr_hdr_and_pfm_loads_to_the_same_texels() {
    let d = dir("same-texels");
    let (w, h) = (5u32, 3u32);
    // Non-dyadic values over a wide range: EXR and PFM keep them exactly, RGBE to its 8-bit mantissa
    // (truncated by the writer, as Mitsuba's writer does: error < 2^-7 of the pixel's largest channel).
    let px: Vec<[f32; 3]> = (0..w * h).map(|i| [0.013 * (i + 1) as f32, 3.7 * i as f32, 1000.0 / (i + 1) as f32]).collect();
    let mut loaded = Vec::new();
    for ext in ["exr", "hdr", "pfm"] {
        let name = format!("tex.{ext}");
        write_map(&d.join(&name), w, h, &px);
        let body = format!(
            "<bsdf type=\"diffuse\" id=\"b\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"{name}\"/></texture></bsdf>\n\
             <shape type=\"cube\"><ref id=\"b\"/></shape>"
        );
        let s = load(&d, &body).unwrap();
        let Texture::Bitmap { width, height, data, .. } = &s.textures[0] else { panic!() };
        assert_eq!((*width, *height), (w, h), "{name}");
        loaded.push(data.clone());
    }
    let exact: Vec<Vec3> = px.iter().map(|p| Vec3::from_array(*p)).collect();
    assert_eq!(loaded[0], exact, "EXR");
    assert_eq!(loaded[2], exact, "PFM");
    for (a, b) in loaded[1].iter().zip(&exact) {
        assert!((*a - *b).abs().max_element() <= b.max_element() / 128.0, "RGBE {a} vs {b}");
    }
}

#[test]
fn formats_are_recognised_by_content_not_extension() {
    let d = dir("magic");
    let px = texels(3, 2);
    write_map(&d.join("a.pfm"), 3, 2, &px);
    std::fs::rename(d.join("a.pfm"), d.join("a.png")).unwrap(); // a PFM named .png, as Mitsuba reads it
    let s = load(&d, "<emitter type=\"envmap\"><string name=\"filename\" value=\"a.png\"/></emitter>").unwrap();
    let Emitter::EnvMap { map, .. } = &s.emitters[0] else { panic!() };
    assert_eq!(map.data[..3], px[..3].iter().map(|p| Vec3::from_array(*p)).collect::<Vec<_>>()[..]);
}

#[test]
fn truncated_maps_are_scene_errors_naming_file_and_line() {
    let d = dir("truncated");
    for ext in ["exr", "hdr", "pfm"] {
        let name = format!("cut.{ext}");
        write_map(&d.join(&name), 16, 8, &texels(16, 8));
        let bytes = std::fs::read(d.join(&name)).unwrap();
        std::fs::write(d.join(&name), &bytes[..bytes.len() / 2]).unwrap();
        let e = load(&d, &format!("<emitter type=\"envmap\"><string name=\"filename\" value=\"{name}\"/></emitter>")).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, Error::Scene { .. }), "{text}");
        assert!(text.contains("scene.xml:4") && text.contains(&name), "{text}");
    }
}

#[test]
fn instances_compose_transforms_and_name_meshes() {
    let d = dir("instances");
    let body = r#"<shape type="shapegroup" id="g">
  <shape type="rectangle" id="r"><transform name="to_world"><translate x="1"/></transform></shape>
</shape>
<shape type="instance" id="a"><ref id="g"/><transform name="to_world"><scale value="2"/></transform></shape>
<shape type="instance"><ref id="g"/><transform name="to_world"><rotate z="1" angle="90"/></transform></shape>"#;
    let s = load(&d, body).unwrap();
    // The top-level rectangle of `load`, then one mesh per instance; the group itself adds nothing.
    let ids: Vec<&str> = s.meshes.iter().map(|m| m.id.as_str()).collect();
    assert_eq!(ids, ["shape_0", "a/r", "instance_2/r"]);
    let rect = crate::scene::mesh::rectangle().positions;
    for (p, q) in rect.iter().zip(&s.meshes[1].positions) {
        assert!((*q - (*p + Vec3::X) * 2.0).length() < 1e-6, "{q} vs 2 ({p} + x)");
        // instance * shape
    }
    for (p, q) in rect.iter().zip(&s.meshes[2].positions) {
        let want = Vec3::new(-p.y, p.x + 1.0, p.z);
        assert!((*q - want).length() < 1e-6, "{q} vs {want}");
    }
}

#[test]
fn new_shapes_refuse_bad_input_with_file_and_line() {
    let d = dir("bad-shapes");
    let cases = [
        (r#"<shape type="cylinder"><point name="p0" value="1, 1, 1"/><point name="p1" value="1, 1, 1"/></shape>"#, "must differ"),
        (r#"<shape type="serialized"><string name="filename" value="none.serialized"/></shape>"#, "file not found"),
        (r#"<shape type="serialized"><integer name="shape_index" value="0"/></shape>"#, "missing <string name=\"filename\">"),
        (r#"<shape type="instance"><ref id="nope"/></shape>"#, "nope"),
        (r#"<shape type="rectangle" id="q"/><shape type="instance"><ref id="q"/></shape>"#, "only a shapegroup"),
        (r#"<shape type="shapegroup" id="g"><shape type="instance"/></shape>"#, "nested instancing"),
        (r#"<shape type="shapegroup" id="g"><bsdf type="diffuse"/></shape>"#, "can only hold shapes"),
    ];
    for (body, what) in cases {
        let e = load(&d, body).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("scene.xml:4") && text.contains(what), "{body}: {text}");
    }
    // A corrupt serialized file: an error naming that file.
    std::fs::write(d.join("bad.serialized"), b"\x1c\x04\x04\x00garbage").unwrap();
    let e = load(&d, r#"<shape type="serialized"><string name="filename" value="bad.serialized"/></shape>"#).unwrap_err();
    assert!(matches!(e, Error::Scene { .. }) && e.to_string().contains("bad.serialized"), "{e}");
}

/// mitsuba 3.9.1 `bitmap` texture (`raw`, bilinear) `eval` of tiny PFM maps written by `mi.Bitmap(...).write`:
/// Mitsuba pads maps smaller than 2 texels to 2 by replication, which changes no lookup; here they are
/// used as they are.
#[rustfmt::skip]
const MITSUBA_TINY_TEXTURES: [((u32, u32), &str, [[f32; 3]; 7]); 9] = [
    ((1, 1), "repeat", [[0.0625, 0.5, 0.9375000596046448], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9374999403953552]]),
    ((1, 1), "mirror", [[0.0625, 0.5, 0.9375000596046448], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9374999403953552]]),
    ((1, 1), "clamp", [[0.0625, 0.5, 0.9375000596046448], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9374999403953552]]),
    ((7, 1), "repeat", [[0.125, 0.5624999403953552, 0.7999999523162842], [1.0, 0.4375, 0.875], [0.9287497997283936, 0.3762500286102295, 0.8137500286102295], [0.5, 0.4375, 0.875], [0.4374999403953552, 0.4750000834465027, 0.3124999403953552], [0.5061249732971191, 0.43662500381469727, 0.8741250038146973], [0.518750786781311, 0.6562497019767761, 0.39375078678131104]]),
    ((7, 1), "mirror", [[0.125, 0.5624999403953552, 0.7999999523162842], [1.0, 0.4375, 0.875], [0.9375, 0.3750000298023224, 0.8124999403953552], [0.0625, 0.5, 0.9375], [0.5625000596046448, 0.3999998867511749, 0.4375000596046448], [0.9375, 0.375, 0.8125], [0.518750786781311, 0.6562497019767761, 0.39375078678131104]]),
    ((7, 1), "clamp", [[0.125, 0.5624999403953552, 0.7999999523162842], [1.0, 0.4375, 0.875], [0.9375, 0.3750000298023224, 0.8124999403953552], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.9375, 0.375, 0.8125], [0.9375000596046448, 0.375, 0.8125]]),
    ((1, 5), "repeat", [[0.15625, 0.59375, 0.53125], [0.4375, 0.875, 0.3125], [0.2874999940395355, 0.42500001192092896, 0.8624999523162842], [0.4375, 0.375, 0.8125], [0.625, 0.0625, 0.5], [0.4375, 0.875, 0.3125], [0.71875, 0.15625, 0.59375]]),
    ((1, 5), "mirror", [[0.15625, 0.59375, 0.53125], [0.4375, 0.875, 0.3125], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.25, 0.6875, 0.125], [0.4375, 0.875, 0.3125], [0.71875, 0.15625, 0.59375]]),
    ((1, 5), "clamp", [[0.15625, 0.59375, 0.53125], [0.4375, 0.875, 0.3125], [0.0625, 0.5, 0.9375], [0.0625, 0.5, 0.9375], [0.8125, 0.25, 0.6875], [0.4375, 0.875, 0.3125], [0.0625, 0.5, 0.9375]]),
];

#[test]
fn tiny_textures_match_mitsuba_eval() {
    use crate::scene::texture::eval;
    const UVS: [[f32; 2]; 7] = [[0.1, 0.2], [0.5, 0.5], [0.93, 0.04], [0.0, 0.0], [-0.3, 1.7], [0.999, 0.5], [2.6, -1.2]];
    let d = dir("tiny-tex");
    for ((w, h), wrap, want) in MITSUBA_TINY_TEXTURES {
        let name = format!("tex_{w}x{h}.pfm");
        write_map(&d.join(&name), w, h, &texels(w, h));
        let body = format!(
            "<bsdf type=\"diffuse\" id=\"b\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" \
             value=\"{name}\"/><string name=\"wrap_mode\" value=\"{wrap}\"/><boolean name=\"raw\" value=\"true\"/></texture></bsdf>\n\
             <shape type=\"cube\"><ref id=\"b\"/></shape>"
        );
        let s = load(&d, &body).unwrap();
        for (uv, want) in UVS.iter().zip(want) {
            let got = eval(&s.textures[0], glam::Vec2::from_array(*uv));
            assert!((got - Vec3::from_array(want)).abs().max_element() < 1e-6, "{name} {wrap} uv {uv:?}: {got} vs {want:?}");
        }
    }
}
