//! Keeps window-system probing from printing stray errors in headless use.
//!
//! wgpu enables every available surface extension on its Vulkan instance, `VK_KHR_wayland_surface`
//! included. Mesa's implicit `VK_LAYER_MESA_device_select` layer (installed with mesa-vulkan-drivers)
//! then calls `wl_display_connect(NULL)` in `vkCreateInstance` to find the compositor's GPU, and
//! libwayland-client prints "error: XDG_RUNTIME_DIR is invalid or not set in the environment." to
//! stderr when that variable is unset or relative (once per instance: twice per process here). The
//! layer only reorders physical devices, and `GpuContext` ranks adapters itself, so where no Wayland
//! connection is possible anyway (XDG_RUNTIME_DIR unset or relative, WAYLAND_DISPLAY not an absolute
//! socket path) and the user has not configured the layer (`MESA_VK_DEVICE_SELECT`, `NODEVICE_SELECT`
//! unset), `quiet_device_select` sets `NODEVICE_SELECT=1`, the layer's own off switch (its manifest's
//! `disable_environment`), before the first instance is created. Nothing changes in a Wayland or X11
//! session.
use std::sync::Once;

/// Whether the device-select layer would try (and noisily fail) to reach a Wayland compositor.
pub fn wayland_probe_would_fail(xdg_runtime_dir: Option<&str>, wayland_display: Option<&str>) -> bool {
    let runtime_ok = xdg_runtime_dir.is_some_and(|d| d.starts_with('/'));
    let absolute_socket = wayland_display.is_some_and(|d| d.starts_with('/'));
    !runtime_ok && !absolute_socket
}

/// Set `NODEVICE_SELECT=1` when `wayland_probe_would_fail` and the user has not configured the layer.
/// Runs once per process; call it before any wgpu instance exists (module import, `GpuContext::new`).
pub fn quiet_device_select() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let var = |k: &str| std::env::var(k).ok();
        let configured = var("MESA_VK_DEVICE_SELECT").is_some() || std::env::var_os("NODEVICE_SELECT").is_some();
        if !configured && wayland_probe_would_fail(var("XDG_RUNTIME_DIR").as_deref(), var("WAYLAND_DISPLAY").as_deref()) {
            std::env::set_var("NODEVICE_SELECT", "1");
        }
    });
}

#[cfg(test)]
mod tests;
