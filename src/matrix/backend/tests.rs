use super::*;

#[test]
fn device_names_parse_and_bad_ones_are_refused() {
    assert_eq!(Device::parse("auto").unwrap(), Device::Auto);
    assert_eq!(Device::parse(" GPU ").unwrap(), Device::Gpu);
    assert_eq!(Device::parse("cpu").unwrap(), Device::Cpu);
    let e = Device::parse("cuda").unwrap_err().to_string();
    assert!(e.contains("'auto', 'gpu' or 'cpu'") && e.contains("cuda"), "{e}");
    // Explicit choices are never replaced by the environment.
    assert_eq!(Device::Cpu.with_env().unwrap(), Device::Cpu);
    assert_eq!(Device::Gpu.with_env().unwrap(), Device::Gpu);
}

#[test]
fn cpu_info_names_the_backend() {
    let i = DeviceInfo::cpu();
    assert_eq!(i.kind, "cpu");
    assert_eq!(i.backend, "rayon");
    assert!(i.threads >= 1 && !i.name.is_empty());
}
