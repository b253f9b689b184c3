use super::*;

#[test]
fn relight_wgsl_validates_and_layouts_match() {
    let module = crate::gpu::shaders::assert_struct_sizes("relight.wgsl", shaders::RELIGHT, &[("RelightParams", 32)]);
    assert_eq!(std::mem::size_of::<RelightParams>(), 32);
    let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
    for name in ["haar_level", "cull", "product", "product_rgb", "finish_bounce", "combine", "combine_glossy"] {
        assert!(entries.contains(&name), "missing entry point {name}: {entries:?}");
    }
    // Every read_write global is in WRITABLE and vice versa (the layouts' access modes).
    for (_, var) in module.global_variables.iter() {
        let (Some(binding), naga::AddressSpace::Storage { access }) = (&var.binding, var.space) else { continue };
        let writable = access.contains(naga::StorageAccess::STORE);
        assert_eq!(writable, WRITABLE.contains(&binding.binding), "binding {}", binding.binding);
    }
}
