use super::*;

#[test]
fn parse_forms_and_errors() {
    assert_eq!(Spectrum::parse(" 0.5 ").unwrap().uniform(), Some(0.5));
    let s = Spectrum::parse("400:0.1, 500:0.2 600:0.3").unwrap();
    assert_eq!((s.wavelengths.clone(), s.values.clone()), (vec![400.0, 500.0, 600.0], vec![0.1, 0.2, 0.3]));
    for (bad, msg) in [
        ("400:0.1", "at least two"),
        ("500:0.1, 400:0.2", "strictly increasing"),
        ("400:0.1, 500", "wavelength:value"),
        ("400:x, 500:1", "\"x\""),
        ("abc", "\"abc\""),
        ("0.1 0.2", "wavelength:value"),
    ] {
        let e = Spectrum::parse(bad).unwrap_err();
        assert!(e.contains(msg), "{bad}: {e}");
    }
}

#[test]
fn values_as_mitsuba_computes_them() {
    // mitsuba 3.9.1 scalar_rgb: diffuse reflectance / area radiance of these spectra (mi.traverse).
    let flat = Spectrum::parse("360:1, 830:1").unwrap();
    let r = flat.to_rgb(SpectrumUse::Reflectance);
    assert!((r - DVec3::ONE).abs().max_element() < 2e-3, "{r}"); // D65-weighted flat = white (clamped)
    let e = Spectrum::parse("0.5").unwrap().to_rgb(SpectrumUse::Emission);
    assert!((e - DVec3::new(0.6023970, 0.4741455, 0.4544580)).abs().max_element() < 1e-6, "{e}");
    assert_eq!(Spectrum::parse("0.5").unwrap().to_rgb(SpectrumUse::Reflectance), DVec3::splat(0.5));
}
