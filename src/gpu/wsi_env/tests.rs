use super::*;

#[test]
fn probe_failure_conditions() {
    assert!(wayland_probe_would_fail(None, None));
    assert!(wayland_probe_would_fail(Some("run/user"), Some("wayland-0")));
    assert!(!wayland_probe_would_fail(Some("/run/user/0"), None));
    assert!(!wayland_probe_would_fail(None, Some("/tmp/wayland-0")));
}
