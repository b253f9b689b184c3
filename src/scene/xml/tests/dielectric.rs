//! `roughdielectric` and `thindielectric`: Mitsuba 3.9.1's defaults, named IORs, textures, version 0.6
//! names, and the refusals with file and line.
use crate::scene::xml::*;
use crate::scene::{Bsdf, MicrofacetDistribution, Param};
use glam::Vec3;

fn load_body(test: &str, version: &str, body: &str) -> Result<Scene> {
    let dir = crate::testing::scratch_dir(&format!("xml-diel-{test}"));
    let text = format!(
        "<scene version=\"{version}\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>\
         <integer name=\"height\" value=\"8\"/></film></sensor>\n{body}\n</scene>\n"
    );
    let p = dir.join("scene.xml");
    std::fs::write(&p, text).unwrap();
    load_scene(&p, &LoadOptions::default())
}

fn bsdf(test: &str, version: &str, inner: &str) -> Bsdf {
    let s = load_body(test, version, &format!("<shape type=\"rectangle\">{inner}</shape>")).unwrap_or_else(|e| panic!("{test}: {e}"));
    s.bsdfs[s.meshes[0].bsdf].clone()
}

fn err(test: &str, inner: &str, words: &[&str]) {
    let e = load_body(test, "3.0.0", &format!("<shape type=\"rectangle\">{inner}</shape>")).expect_err("expected an error");
    let text = e.to_string();
    for w in ["scene.xml:3"].iter().chain(words) {
        assert!(text.contains(w), "{test}: {text:?} lacks {w:?}");
    }
}

#[test]
fn defaults_and_parameters() {
    let bk7 = 1.5046;
    let air = 1.000277;
    let one = Param::Value(Vec3::ONE);
    assert_eq!(
        bsdf("rd-default", "3.0.0", "<bsdf type=\"roughdielectric\"/>"),
        Bsdf::RoughDielectric {
            distribution: MicrofacetDistribution::Beckmann,
            alpha_u: Param::Value(Vec3::splat(0.1)),
            alpha_v: Param::Value(Vec3::splat(0.1)),
            int_ior: bk7,
            ext_ior: air,
            specular_reflectance: one,
            specular_transmittance: one,
        }
    );
    let b = bsdf(
        "rd-full",
        "3.0.0",
        "<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"GGX\"/><float name=\"alpha_u\" value=\"0.05\"/>\
         <float name=\"alpha_v\" value=\"0.3\"/><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1.2\"/>\
         <rgb name=\"specular_transmittance\" value=\"0.5, 0.6, 0.7\"/><boolean name=\"sample_visible\" value=\"false\"/></bsdf>",
    );
    let Bsdf::RoughDielectric { distribution, alpha_u, alpha_v, int_ior, ext_ior, specular_transmittance, .. } = b else { panic!("{b:?}") };
    assert_eq!(distribution, MicrofacetDistribution::Ggx);
    assert_eq!((alpha_u, alpha_v), (Param::Value(Vec3::splat(0.05)), Param::Value(Vec3::splat(0.3))));
    assert_eq!((int_ior, ext_ior), (1.3330, 1.2));
    assert_eq!(specular_transmittance, Param::Value(Vec3::new(0.5, 0.6, 0.7)));
    // A textured roughness (Mitsuba's get_unbounded_texture).
    let b = bsdf(
        "rd-tex",
        "3.0.0",
        "<bsdf type=\"roughdielectric\"><texture name=\"alpha\" type=\"checkerboard\"><rgb name=\"color0\" value=\"0.1\"/>\
         <rgb name=\"color1\" value=\"0.4\"/></texture></bsdf>",
    );
    assert!(matches!(b, Bsdf::RoughDielectric { alpha_u: Param::Texture(0), alpha_v: Param::Texture(0), .. }), "{b:?}");
    assert_eq!(
        bsdf("td-default", "3.0.0", "<bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"1.6\"/></bsdf>"),
        Bsdf::ThinDielectric { int_ior: 1.6, ext_ior: air, specular_reflectance: one, specular_transmittance: one }
    );
}

#[test]
fn version_0_6_names() {
    // Mitsuba 0.6 spells the parameters in camelCase; the upgrader maps them as Mitsuba 3 does.
    let b = bsdf(
        "rd-06",
        "0.6.0",
        "<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alphaU\" value=\"0.2\"/>\
         <float name=\"alphaV\" value=\"0.4\"/><float name=\"intIOR\" value=\"1.7\"/><string name=\"extIOR\" value=\"air\"/>\
         <spectrum name=\"specularTransmittance\" value=\"0.5\"/></bsdf>",
    );
    let Bsdf::RoughDielectric { alpha_u, alpha_v, int_ior, ext_ior, specular_transmittance, .. } = b else { panic!("{b:?}") };
    assert_eq!((alpha_u, alpha_v), (Param::Value(Vec3::splat(0.2)), Param::Value(Vec3::splat(0.4))));
    assert_eq!((int_ior, ext_ior), (1.7, 1.000277));
    let Param::Value(t) = specular_transmittance else { panic!() };
    assert!((t - Vec3::splat(0.5)).abs().max_element() < 1e-6, "{t}");
    let b = bsdf("td-06", "0.6.0", "<bsdf type=\"thindielectric\"><float name=\"intIOR\" value=\"1.33\"/></bsdf>");
    assert!(matches!(b, Bsdf::ThinDielectric { int_ior, .. } if int_ior == 1.33), "{b:?}");
}

#[test]
fn refusals_name_file_line_and_value() {
    err("dist", "<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"phong\"/></bsdf>", &["phong", "beckmann"]);
    err("alpha", "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"-0.5\"/></bsdf>", &["alpha", "-0.5"]);
    err("ior0", "<bsdf type=\"roughdielectric\"><float name=\"int_ior\" value=\"0\"/></bsdf>", &["int_ior", "got 0"]);
    err(
        "same",
        "<bsdf type=\"roughdielectric\"><float name=\"int_ior\" value=\"1\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>",
        &["differ"],
    );
    err(
        "both",
        "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.1\"/><float name=\"alpha_u\" value=\"0.1\"/></bsdf>",
        &["alpha_v"],
    );
    err("thin-neg", "<bsdf type=\"thindielectric\"><float name=\"ext_ior\" value=\"-2\"/></bsdf>", &["ext_ior", "-2"]);
    err("thin-unused", "<bsdf type=\"thindielectric\"><float name=\"alpha\" value=\"0.1\"/></bsdf>", &["alpha"]);
    err("two", "<bsdf type=\"twosided\"><bsdf type=\"thindielectric\"/></bsdf>", &["twosided", "transmission"]);
    err(
        "blend",
        "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\"/><bsdf type=\"roughdielectric\"/></bsdf>",
        &["blendbsdf", "roughdielectric"],
    );
}
