use super::*;

#[test]
fn options_are_checked() {
    assert!(GlossyOptions::default().check().is_ok());
    assert!(GlossyOptions::off().check().is_ok());
    for r in [-0.1f32, 1.5, f32::NAN] {
        let e = GlossyOptions { roughness: r, ..Default::default() }.check().unwrap_err().to_string();
        assert!(e.contains("glossy_roughness must be in [0, 1]"), "{e}");
    }
    let e = GlossyOptions { bsdf_samples: 0, ..Default::default() }.check().unwrap_err().to_string();
    assert!(e.contains("bsdf_samples"), "{e}");
}
