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
