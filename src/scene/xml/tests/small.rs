//! Small hand-written scenes: parameters, includes, references, defaults, and every refusal.
// Reference numbers are pasted verbatim from Mitsuba's printouts (f32 values printed as f64).
#![allow(clippy::excessive_precision)]
use crate::error::Error;
use crate::scene::xml::*;
use crate::scene::{Bsdf, Emitter, MicrofacetDistribution, Param, ShapeKind};
use glam::Vec3;
use std::path::PathBuf;

/// A fresh directory with the given files; returns the path of the first one.
fn write(test: &str, files: &[(&str, &str)]) -> PathBuf {
    let dir = crate::testing::scratch_dir(&format!("xml-{test}"));
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    dir.join(files[0].0)
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film></sensor>"#;

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n")
}

fn load_str(test: &str, body: &str) -> Result<Scene> {
    let path = write(test, &[("scene.xml", &scene(body))]);
    load_scene(&path, &LoadOptions::default())
}

fn load_with(test: &str, body: &str, params: &[(&str, &str)]) -> Result<Scene> {
    let path = write(test, &[("scene.xml", &scene(body))]);
    let params = params.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    load_scene(&path, &LoadOptions { params, size: None, ..Default::default() })
}

/// Asserts a `Scene` error at `scene.xml:<line>` whose message contains every `words`.
fn assert_err(r: Result<Scene>, line: u32, words: &[&str]) {
    let e = r.expect_err("expected an error");
    let text = e.to_string();
    match &e {
        Error::Scene { loc, .. } | Error::FileNotFound { loc, .. } => {
            assert_eq!(loc.line, line, "{text}");
            assert!(loc.file.ends_with("scene.xml"), "{text}");
        }
        _ => panic!("unexpected error kind: {text}"),
    }
    for w in words {
        assert!(text.contains(w), "{text:?} lacks {w:?}");
    }
}

const RECT: &str = r#"<shape type="rectangle"/>"#;

#[test]
fn defaults_and_parameters_everywhere() {
    let body = r#"<default name="kind" value="diffuse"/>
<default name="r" value="0.25"/>
<shape type="rectangle"><bsdf type="$kind"><rgb name="reflectance" value="$r, 0.5, $r"/></bsdf></shape>"#;
    let s = load_str("defaults", body).unwrap();
    assert_eq!(s.bsdfs[0], Bsdf::Diffuse { reflectance: Param::Value(Vec3::new(0.25, 0.5, 0.25)) });
    let s = load_with("override", body, &[("r", "0.75")]).unwrap();
    assert_eq!(s.bsdfs[0], Bsdf::Diffuse { reflectance: Param::Value(Vec3::new(0.75, 0.5, 0.75)) });
    // Like Mitsuba: a parameter no attribute uses is an error; an undeclared $name too.
    let e = load_with("unused", body, &[("nothere", "3")]).unwrap_err().to_string();
    assert!(e.contains("$nothere=3") && e.contains("unused"), "{e}");
    assert_err(load_str("undef", "<shape type=\"$shape\"/>"), 4, &["undefined parameter $shape"]);
    // A parameter given to load_scene but not declared is fine when used.
    let s = load_with("undeclared", "<shape type=\"$shape\"/>", &[("shape", "disk")]).unwrap();
    assert_eq!(s.meshes[0].kind, ShapeKind::Disk);
    // `opts.size` replaces the film size.
    let path = write("size", &[("scene.xml", &scene(RECT))]);
    let s = load_scene(&path, &LoadOptions { params: vec![], size: Some((10, 20)), ..Default::default() }).unwrap();
    assert_eq!((s.camera.width, s.camera.height), (10, 20));
}

#[test]
fn include_with_own_defaults_and_nesting() {
    let main = scene(
        r#"<include filename="inc/a.xml"/>
<shape type="rectangle"><ref id="m"/></shape>"#,
    );
    let a = r#"<scene version="3.0.0"><default name="q" value="0.7"/><include filename="b.xml"/></scene>"#;
    let b = r#"<scene version="3.0.0"><bsdf type="diffuse" id="m"><float name="reflectance" value="$q"/></bsdf></scene>"#;
    let path = write("include", &[("scene.xml", &main), ("inc/a.xml", a), ("inc/b.xml", b)]);
    let s = load_scene(&path, &LoadOptions::default()).unwrap();
    assert_eq!(s.bsdfs[0], Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.7)) });
    let main = scene(r#"<include filename="missing.xml"/>"#);
    let path = write("include-missing", &[("scene.xml", &main)]);
    match load_scene(&path, &LoadOptions::default()).unwrap_err() {
        Error::FileNotFound { loc, path } => {
            assert_eq!(loc.line, 4);
            assert!(path.ends_with("missing.xml"));
        }
        e => panic!("{e}"),
    }
}

#[test]
fn references_before_declaration_named_and_shared() {
    let body = r#"<shape type="rectangle"><ref id="two"/></shape>
<shape type="rectangle"><ref name="bsdf" id="two"/></shape>
<shape type="disk"><ref id="plain"/></shape>
<bsdf type="twosided" id="two"><ref id="plain"/><bsdf type="diffuse"><ref name="reflectance" id="tex"/></bsdf></bsdf>
<bsdf type="diffuse" id="plain"/>
<texture type="checkerboard" id="tex"><transform name="to_uv"><scale value="2"/><translate x="0.5"/></transform></texture>
<bsdf type="roughplastic" id="unused"/>"#;
    let s = load_str("refs", body).unwrap();
    assert_eq!(s.meshes[0].bsdf, s.meshes[1].bsdf);
    assert_eq!(s.bsdfs.len(), 3, "{:?}", s.bsdfs); // plain, inner diffuse, twosided; `unused` dropped
    let Bsdf::TwoSided { front, back } = s.bsdfs[s.meshes[0].bsdf] else { panic!() };
    assert_eq!(front, s.meshes[2].bsdf);
    assert_eq!(s.bsdfs[front], Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) });
    assert_eq!(s.bsdfs[back], Bsdf::Diffuse { reflectance: Param::Texture(0) });
    let crate::scene::Texture::Checkerboard { color0, color1, to_uv } = &s.textures[0] else { panic!() };
    assert_eq!((*color0, *color1), (Vec3::splat(0.4), Vec3::splat(0.2)));
    assert_eq!(to_uv.transform_point2(glam::Vec2::new(1.0, 1.0)), glam::Vec2::new(2.5, 2.0));
    assert_err(load_str("badref", "<shape type=\"rectangle\"><ref id=\"nope\"/></shape>"), 4, &["\"nope\""]);
}

#[test]
fn mitsuba_defaults() {
    let body = r#"<shape type="rectangle"/>
<shape type="rectangle"><bsdf type="roughplastic"/></shape>
<shape type="rectangle"><bsdf type="roughconductor"/></shape>
<shape type="rectangle"><bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.3"/></bsdf></shape>
<shape type="rectangle"><bsdf type="dielectric"><string name="ext_ior" value="water"/></bsdf></shape>
<shape type="rectangle"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
<emitter type="spot"/>
<emitter type="point"><transform name="to_world"><translate value="1 2 3"/></transform><spectrum name="intensity" value="5"/></emitter>
<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>
<emitter type="constant"><rgb name="radiance" value="0.1 0.2 0.3"/></emitter>"#;
    let s = load_str("defaults-mitsuba", body).unwrap();
    assert_eq!(s.bsdfs[0], Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) });
    assert_eq!(
        s.bsdfs[1],
        Bsdf::RoughPlastic {
            diffuse_reflectance: Param::Value(Vec3::splat(0.5)),
            specular_reflectance: Param::Value(Vec3::ONE),
            distribution: MicrofacetDistribution::Beckmann,
            alpha: 0.1,
            int_ior: 1.49,
            ext_ior: 1.000277,
            nonlinear: false,
        }
    );
    let a = Param::Value(Vec3::splat(0.1));
    assert_eq!(
        s.bsdfs[2],
        Bsdf::RoughConductor {
            distribution: MicrofacetDistribution::Beckmann,
            alpha_u: a,
            alpha_v: a,
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            specular_reflectance: Param::Value(Vec3::ONE),
        }
    );
    match &s.bsdfs[3] {
        Bsdf::RoughConductor { alpha_u, alpha_v, eta, k, .. } => {
            assert_eq!((*alpha_u, *alpha_v), (Param::Value(Vec3::splat(0.2)), Param::Value(Vec3::splat(0.3))));
            // mitsuba 3.9.1 scalar_rgb, material "Cu".
            assert_eq!(*eta, Vec3::new(0.20100547, 0.9237495, 1.1022154));
            assert_eq!(*k, Vec3::new(3.9132621, 2.4530451, 2.1420898));
        }
        b => panic!("{b:?}"),
    }
    assert_eq!(s.bsdfs[4], Bsdf::Dielectric { int_ior: 1.5046, ext_ior: 1.3330 });
    match &s.bsdfs[5] {
        Bsdf::Conductor { eta, k, .. } => {
            assert_eq!((*eta, *k), (Vec3::new(0.14303598, 0.37530708, 1.4420453), Vec3::new(3.982997, 2.3855565, 1.6033592)));
        }
        b => panic!("{b:?}"),
    }
    match &s.emitters[0] {
        Emitter::Spot { cutoff_angle, beam_width, intensity, .. } => {
            assert_eq!((*cutoff_angle, *beam_width, *intensity), (20f32.to_radians(), 15f32.to_radians(), Vec3::ONE));
        }
        e => panic!("{e:?}"),
    }
    match &s.emitters[1] {
        Emitter::Point { position, intensity, .. } => {
            // A uniform spectrum as emission is 5 * xyz_to_srgb(1, 1, 1) (mitsuba 3.9.1: [6.02397, 4.74146, 4.54458]).
            assert_eq!(*position, Vec3::new(1.0, 2.0, 3.0));
            assert!((*intensity - Vec3::new(6.02397, 4.74146, 4.54458)).abs().max_element() < 1e-5, "{intensity}");
        }
        e => panic!("{e:?}"),
    }
    match &s.emitters[2] {
        Emitter::Directional { direction, .. } => assert!((*direction - Vec3::NEG_Y).length() < 1e-7, "{direction}"),
        e => panic!("{e:?}"),
    }
    assert!(matches!(s.emitters[3], Emitter::Constant { radiance, .. } if radiance == Vec3::new(0.1, 0.2, 0.3)));
}

#[test]
fn field_of_view_like_mitsuba() {
    // x_fov from mitsuba 3.9.1 (`mi.traverse(sensor)["x_fov"]`).
    let cases: &[(&str, u32, u32, f32)] = &[
        ("", 768, 576, 38.18484115600586), // no fov: 50 mm on the diagonal
        ("", 300, 400, 29.10546112060547),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="y"/>"#, 768, 576, 39.32012176513672),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="y"/>"#, 300, 400, 22.725830078125),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="diagonal"/>"#, 768, 576, 24.197582244873047),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="diagonal"/>"#, 300, 400, 18.266523361206055),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="larger"/>"#, 768, 576, 30.0),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="larger"/>"#, 300, 400, 22.725830078125),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="smaller"/>"#, 768, 576, 39.32012176513672),
        (r#"<float name="fov" value="30"/><string name="fov_axis" value="smaller"/>"#, 300, 400, 30.0),
        (r#"<string name="focal_length" value="35mm"/>"#, 768, 576, 52.62254333496094),
        (r#"<string name="focal_length" value="35mm"/>"#, 300, 400, 40.695274353027344),
    ];
    for (i, (props, w, h, expected)) in cases.iter().enumerate() {
        let text = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\">{props}<film type=\"hdrfilm\"><integer name=\"width\" value=\"{w}\"/><integer name=\"height\" value=\"{h}\"/></film></sensor>{RECT}</scene>"
        );
        let path = write(&format!("fov{i}"), &[("scene.xml", &text)]);
        let s = load_scene(&path, &LoadOptions::default()).unwrap();
        assert!((s.camera.fov_x.to_degrees() - expected).abs() < 2e-5, "case {i}: {} vs {expected}", s.camera.fov_x.to_degrees());
    }
    // No film: Mitsuba's 768x576.
    let path = write("nofilm", &[("scene.xml", &format!("<scene version=\"3.0.0\"><sensor type=\"perspective\"/>{RECT}</scene>"))]);
    let s = load_scene(&path, &LoadOptions::default()).unwrap();
    assert_eq!((s.camera.width, s.camera.height), (768, 576));
}

#[test]
fn spheres() {
    let body = r#"<shape type="sphere"><transform name="to_world"><scale value="2"/><translate x="1"/></transform><float name="radius" value="0.5"/><point name="center" value="0, 1, 0"/></shape>
<shape type="sphere"><boolean name="flip_normals" value="true"/></shape>"#;
    let s = load_str("spheres", body).unwrap();
    // to_world * T(center) * S(radius): center (1, 2, 0), radius 1.
    assert_eq!(s.meshes[0].kind, ShapeKind::Sphere { center: Vec3::new(1.0, 2.0, 0.0), radius: 1.0, flip_normals: false });
    assert_eq!(s.meshes[1].kind, ShapeKind::Sphere { center: Vec3::ZERO, radius: 1.0, flip_normals: true });
    let (lo, hi) = s.meshes[0].positions.iter().fold((Vec3::splat(9.0), Vec3::splat(-9.0)), |(a, b), p| (a.min(*p), b.max(*p)));
    assert!((lo - Vec3::new(0.0, 1.0, -1.0)).abs().max_element() < 1e-2 && (hi - Vec3::new(2.0, 3.0, 1.0)).abs().max_element() < 1e-2);
    assert_err(
        load_str("sphere-scale", "<shape type=\"sphere\">\n<transform name=\"to_world\"><scale x=\"1\" y=\"2\"/></transform></shape>"),
        4,
        &["sphere", "uniform scale", "1.000000, 2.000000"],
    );
}

#[test]
fn meshes_from_search_paths() {
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let text = scene(
        r#"<path value="data"/>
<shape type="obj"><string name="filename" value="quad.obj"/><transform name="to_world"><translate z="2"/></transform></shape>"#,
    );
    let path = write("path", &[("scene.xml", &text), ("data/quad.obj", obj)]);
    let s = load_scene(&path, &LoadOptions::default()).unwrap();
    assert_eq!(s.meshes[0].indices.len(), 2);
    assert!(s.meshes[0].positions.iter().all(|p| p.z == 2.0));
    assert_eq!(s.meshes[0].kind, ShapeKind::Obj);
}

#[test]
fn errors_deep_in_a_large_file_and_in_an_include_name_their_own_line() {
    // Three thousand shapes, one per line, then a refused plugin: the line comes from the newline index.
    let shapes: String = (0..3000).map(|k| format!("<shape type=\"rectangle\"><!-- {k} --></shape>\n")).collect();
    assert_err(load_str("deep", &format!("{shapes}<bsdf type=\"hair\"/>")), 3004, &["\"hair\""]);
    // An include's error names the included file's line, and lines after the include are the outer file's.
    let inner = "<scene version=\"3.0.0\">\n\n<bsdf type=\"diffuse\" id=\"a\"/>\n</scene>\n";
    let outer = scene("<include filename=\"inner.xml\"/>\n\n\n<bsdf type=\"hair\"/>");
    let path = write("include-lines", &[("scene.xml", &outer), ("inner.xml", inner)]);
    assert_err(load_scene(&path, &LoadOptions::default()), 7, &["\"hair\""]);
    let bad_inner = "<scene version=\"3.0.0\">\n\n\n<bsdf type=\"hair\"/>\n</scene>\n";
    let path = write("include-lines-inner", &[("scene.xml", &scene("<include filename=\"inner.xml\"/>")), ("inner.xml", bad_inner)]);
    let e = load_scene(&path, &LoadOptions::default()).expect_err("hair is refused").to_string();
    assert!(e.contains("inner.xml:4"), "{e}");
}

#[test]
fn refusals_name_file_and_line() {
    assert_err(load_str("malformed", "<shape type=\"rectangle\">\n</shap>"), 5, &["malformed XML"]);
    assert_err(load_str("hair", "<bsdf type=\"hair\"/>"), 4, &["bsdf", "\"hair\""]);
    assert_err(load_str("curve", "<shape type=\"bsplinecurve\"/>"), 4, &["shape", "\"bsplinecurve\""]);
    assert_err(load_str("projector", &format!("{RECT}\n<emitter type=\"projector\"/>")), 5, &["emitter", "\"projector\""]);
    assert_err(
        load_str("serialized", "<shape type=\"serialized\"><string name=\"filename\" value=\"a.serialized\"/></shape>"),
        4,
        &["a.serialized", "not found"],
    );
    assert_err(
        load_str("missing-mesh", "<shape type=\"ply\">\n  <string name=\"filename\" value=\"nope.ply\"/></shape>"),
        5,
        &["nope.ply", "not found"],
    );
    assert_err(
        load_str(
            "missing-tex",
            "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\n<string name=\"filename\" value=\"t x.png\"/></texture></bsdf></shape>",
        ),
        5,
        &["t x.png"],
    );
    assert_err(load_str("noshapes", "<emitter type=\"constant\"/>"), 0, &["no shapes"]);
    assert_err(
        load_str("spectral", &format!("{RECT}\n<emitter type=\"point\"><spectrum name=\"intensity\" value=\"700:1, 400:2\"/></emitter>")),
        5,
        &["\"700:1, 400:2\"", "strictly increasing"],
    );
    assert_err(
        load_str("unref", "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n<float name=\"foo\" value=\"1\"/></bsdf></shape>"),
        5,
        &["foo", "diffuse"],
    );
    assert_err(
        load_str("badrgb", "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1 0.2\"/></bsdf></shape>"),
        4,
        &["0.1 0.2"],
    );
    assert_err(
        load_str("ior", "<shape type=\"rectangle\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"glas\"/></bsdf></shape>"),
        4,
        &["\"glas\"", "bk7"],
    );
    assert_err(
        load_str(
            "range",
            "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1.5, -0.2, 0.3\"/></bsdf></shape>",
        ),
        5,
        &["[1.5, -0.2, 0.3]", "[0, 1]"],
    );
    assert_err(
        load_str("twice", "<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>\n<float name=\"radius\" value=\"2\"/></shape>"),
        5,
        &["\"radius\" is given twice"],
    );
    assert_err(
        load_str("disk-fn", "<shape type=\"disk\"><boolean name=\"face_normals\" value=\"true\"/></shape>"),
        4,
        &["face_normals", "disk"],
    );
    assert!(load_str("rect-fn", "<shape type=\"rectangle\"><boolean name=\"face_normals\" value=\"true\"/></shape>").is_ok());
    assert_err(
        load_str(
            "shared-area",
            "<shape type=\"rectangle\"><emitter type=\"area\" id=\"a\"/></shape>\n<shape type=\"rectangle\"><ref id=\"a\"/></shape>",
        ),
        5,
        &["already attached"],
    );
    let zero = "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"0\"/></film></sensor><shape type=\"rectangle\"/></scene>";
    let path = write("zero", &[("scene.xml", zero)]);
    assert_err(load_scene(&path, &LoadOptions::default()), 2, &["0x576"]);
    let scaled = "<scene version=\"3.0.0\">\n\n<sensor type=\"perspective\"><transform name=\"to_world\"><scale value=\"2\"/></transform></sensor><shape type=\"rectangle\"/></scene>";
    let path = write("scaled", &[("scene.xml", scaled)]);
    assert_err(load_scene(&path, &LoadOptions::default()), 3, &["scale", "camera"]);
    let nosensor = "<scene version=\"3.0.0\"><shape type=\"rectangle\"/></scene>";
    let path = write("nosensor", &[("scene.xml", nosensor)]);
    assert_err(load_scene(&path, &LoadOptions::default()), 0, &["sensor"]);
    let noversion = "<scene><shape type=\"rectangle\"/></scene>";
    let path = write("noversion", &[("scene.xml", noversion)]);
    assert_err(load_scene(&path, &LoadOptions::default()), 1, &["version"]);
}

#[test]
fn the_integrator_and_its_path_depth() {
    let depth = |body: &str, params: &[(&str, &str)]| {
        let s = load_with("integrator", &format!("{RECT}\n{body}"), params).unwrap();
        s.integrator.map(|i| (i.plugin, i.max_depth, i.loc.line))
    };
    assert_eq!(depth("", &[]), None); // Mitsuba's default (path, -1) is the caller's to apply
    let path = r#"<default name="d" value="6"/>
<integrator type="path"><integer name="max_depth" value="$d"/><integer name="rr_depth" value="3"/></integrator>"#;
    assert_eq!(depth(path, &[]), Some(("path".into(), Some(6), 6)));
    assert_eq!(depth(path, &[("d", "3")]), Some(("path".into(), Some(3), 6)));
    assert_eq!(depth(r#"<integrator type="volpath"/>"#, &[]), Some(("volpath".into(), Some(-1), 5)));
    assert_eq!(
        depth(r#"<integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>"#, &[]),
        Some(("direct".into(), Some(2), 5))
    );
    assert_eq!(
        depth(r#"<integrator type="aov"><string name="aovs" value="nn:sh_normal"/></integrator>"#, &[]),
        Some(("aov".into(), None, 5))
    );
    // Only the first top-level integrator counts (Mitsuba renders with the first).
    assert_eq!(depth("<integrator type=\"direct\"/>\n<integrator type=\"path\"/>", &[]), Some(("direct".into(), Some(2), 5)));
    let bad = |test: &str, body: &str| load_str(test, &format!("{RECT}\n{body}"));
    assert_err(bad("int-depth", r#"<integrator type="path"><integer name="max_depth" value="-2"/></integrator>"#), 5, &["max_depth", "-2"]);
    assert_err(
        bad("float-depth", r#"<integrator type="path"><float name="max_depth" value="3"/></integrator>"#),
        5,
        &["max_depth", "<integer>"],
    );
    assert_err(
        bad("undef-depth", r#"<integrator type="path"><integer name="max_depth" value="$d"/></integrator>"#),
        5,
        &["undefined parameter $d"],
    );
}

/// Mitsuba 0.6 film properties as Mitsuba 3.9.1 takes them: `banner` (any type) ignored, the crop window
/// (`cropOffsetX` ... upgraded to `crop_offset_x` ...) kept, `gamma` refused (Mitsuba refuses it too).
#[test]
fn version_06_film_properties() {
    let film = |extra: &str| {
        format!(
            "<scene version=\"0.6.0\">\n<shape type=\"sphere\"/>\n<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>\n\
             <film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"6\"/>\n{extra}</film></sensor>\n</scene>\n"
        )
    };
    let load06 = |test: &str, extra: &str, size: Option<(u32, u32)>| {
        let path = write(test, &[("scene.xml", &film(extra))]);
        load_scene(&path, &LoadOptions { params: vec![], size, ..Default::default() })
    };
    for banner in [r#"<boolean name="banner" value="false"/>"#, r#"<string name="banner" value="xyz"/>"#] {
        let s = load06("film06-banner", banner, None).unwrap();
        assert_eq!((s.camera.width, s.camera.height), (8, 6));
    }
    let crop = r#"<integer name="cropOffsetX" value="3"/><integer name="cropOffsetY" value="1"/>
<integer name="cropWidth" value="4"/><integer name="cropHeight" value="2"/><boolean name="banner" value="true"/>"#;
    let s = load06("film06-crop", crop, None).unwrap();
    assert_eq!((s.camera.width, s.camera.height), (4, 2));
    // Mitsuba 3.9.1 `sensor.sample_ray` at crop positions (0.5, 0.5) and (3.5, 1.5), which are the full
    // film's (3.5, 1.5) and (6.5, 2.5).
    for ((px, py), want) in [((0.5, 0.5), [0.0450326, 0.135098, 0.989808]), ((3.5, 1.5), [-0.221597, 0.0443193, 0.974131])] {
        let (_, d) = s.camera.ray(px, py);
        assert!((d - Vec3::from(want)).abs().max_element() < 2e-6, "crop ({px}, {py}): {d}, Mitsuba {want:?}");
    }
    // A size override keeps the window's share of the film (the same rays at the same relative positions).
    let big = load06("film06-crop-size", crop, Some((8, 4))).unwrap();
    assert_eq!((big.camera.width, big.camera.height), (8, 4));
    assert!((big.camera.ray(1.0, 1.0).1 - s.camera.ray(0.5, 0.5).1).abs().max_element() < 1e-6);
    assert_err(load06("film06-crop-bad", r#"<integer name="cropWidth" value="9"/>"#, None), 4, &["invalid crop window", "9x6", "8x6 film"]);
    assert_err(
        load06("film06-gamma", r#"<float name="gamma" value="2.2"/>"#, None),
        5,
        &["\"gamma\"", "ldrfilm", "Mitsuba 3.9.1 refuses it"],
    );
    // Other Mitsuba 0.6 film properties that Mitsuba 3.9.1 refuses are refused here too.
    assert_err(load06("film06-hq", r#"<boolean name="highQualityEdges" value="true"/>"#, None), 5, &["high_quality_edges"]);
}

#[test]
fn a_spot_beam_wider_than_its_cutoff_is_the_beam_at_the_cutoff() {
    // Mitsuba accepts it: every direction inside the cutoff is in the beam (falloff 1), so the image is that
    // of beam_width = cutoff_angle (a pixel-centre Mitsuba render of such a spot matched to 2e-7).
    let s = load_str(
        "spot-wide-beam",
        r#"<shape type="rectangle"/><emitter type="spot"><float name="cutoff_angle" value="25"/><float name="beam_width" value="30"/></emitter>"#,
    )
    .unwrap();
    match &s.emitters[0] {
        Emitter::Spot { cutoff_angle, beam_width, .. } => assert_eq!(*beam_width, *cutoff_angle),
        e => panic!("{e:?}"),
    }
    for cos in [1.0f32, 0.95, 24.9f32.to_radians().cos()] {
        assert_eq!(crate::lights::spot_falloff(cos, 25f32.to_radians(), 25f32.to_radians()), 1.0);
    }
    assert_eq!(crate::lights::spot_falloff(25.1f32.to_radians().cos(), 25f32.to_radians(), 25f32.to_radians()), 0.0);
}
