use super::*;

#[test]
fn gbuffer_wgsl_validates() {
    let module = validate_wgsl("gbuffer.wgsl", GBUFFER).unwrap();
    let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
    for name in ["vs_triangles", "fs_triangles", "vs_sphere", "fs_sphere"] {
        assert!(entries.contains(&name), "missing entry point {name}: {entries:?}");
    }
}

#[test]
fn broken_wgsl_is_an_error() {
    let e = validate_wgsl("bad", "fn f() -> u32 { return 1.0; }").unwrap_err().to_string();
    assert!(e.contains("bad"), "{e}");
}

/// `is_nan_f32` of `shaders/common/bsdf.wgsl`, bit for bit.
fn is_nan_bits(x: f32) -> bool {
    (x.to_bits() & 0x7fff_ffff) > 0x7f80_0000
}

#[test]
fn nan_checks_test_the_bits() {
    for x in [f32::NAN, -f32::NAN, f32::from_bits(0x7f80_0001), f32::from_bits(0xffc0_0000)] {
        assert!(is_nan_bits(x), "{x:?}");
    }
    for x in [0.0, -0.0, 1.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, f32::MIN_POSITIVE, 1e-45] {
        assert!(!is_nan_bits(x), "{x}");
    }
    let wgsl = include_str!("../../../shaders/common/bsdf.wgsl");
    assert!(wgsl.contains("return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;"));
}

/// No pass relies on NaN comparing false inside a negation (`!(x > 0.0)`), which a compiler that assumes
/// no NaN may fold: such tests go through `positive` / `greater` (bit tests).
#[test]
fn no_negated_float_comparison_is_left() {
    for (name, src) in [("columns", COLUMNS), ("rows", ROWS), ("clustered_visibility", CLUSTERED_VISIBILITY), ("bsdf_eval", BSDF_EVAL)] {
        for (k, _) in src.match_indices("!(") {
            let line_start = src[..k].rfind('\n').map_or(0, |i| i + 1);
            if src[line_start..k].contains("//") {
                continue;
            }
            let inner: String = src[k + 2..].chars().take_while(|&c| c != '{').collect();
            let head = inner.split(")").next().unwrap_or("");
            assert!(!(head.contains(" > ") || head.contains(" < ") || head.contains(" >= ") || head.contains(" <= ")), "{name}: !({head}");
        }
    }
}
