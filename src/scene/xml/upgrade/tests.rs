use super::*;

#[test]
fn camel_case_as_mitsuba() {
    for (a, b) in [
        ("toWorld", "to_world"),
        ("intIOR", "int_ior"),
        ("extIOR", "ext_ior"),
        ("diffuseReflectance", "diffuse_reflectance"),
        ("fovAxis", "fov_axis"),
        ("sampleCount", "sample_count"),
        ("filename", "filename"),
        ("to_world", "to_world"),
        ("UV", "UV"),
        ("aBCdE", "a_bcd_e"),
    ] {
        assert_eq!(camel_to_snake(a), b, "{a}");
    }
}

#[test]
fn versions() {
    let l = Location::new("s.xml", 1);
    assert_eq!(parse_version("0.6.0", &l).unwrap(), (0, 6, 0));
    assert!(needs_upgrade((1, 9, 9)) && !needs_upgrade((2, 0, 0)) && !needs_upgrade((3, 0, 0)));
    for bad in ["0.6", "a.b.c", "3.0.0.1", ""] {
        let e = parse_version(bad, &l).unwrap_err().to_string();
        assert!(e.contains("s.xml:1") && e.contains("invalid version"), "{e}");
    }
}
