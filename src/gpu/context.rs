//! Headless GPU device creation.
//!
//! Prefers a hardware adapter (discrete, then integrated, then virtual, then one of unknown type, GL
//! ones of unknown type last among those) and falls back to a software one (lavapipe over Vulkan,
//! llvmpipe over GL/EGL; any adapter whose name says it is software ranks as a CPU one, whatever type it
//! reports). An OpenGL adapter gets a device but runs none of the passes (`GL_UNVALIDATED` in `unmet`).
//! Overrides, read once per context:
//! - `MANYLIGHTS_ADAPTER=hardware|software|<substring of the adapter name>`
//! - `WGPU_BACKEND=vulkan|gl|metal|dx12` (wgpu's own variable) restricts the backends tried (read once per
//!   process: one wgpu instance serves every device).
//! - `MANYLIGHTS_GPU_LIMITS` lowers the adapter's limits (`gpu::needs`, a diagnostic and test hook).
//!
//! The device is given the adapter's own limits (read from the adapter, never assumed) where the passes
//! need more than WebGPU's downlevel defaults; every pass's needs (`gpu::needs::PASSES`) are then checked
//! against them and the unmet ones kept in `unmet` (`device="auto"` then runs on the CPU, `"gpu"` is
//! refused, naming the pass and the limit).
//!
//! Device loss: a lost device (driver reset, OS timeout, `device_lost` callback) marks the context
//! lost; `shared()` drops a lost context and creates a new one on the next call. Light matrices made on
//! the old device keep failing with `GpuError`; new ones use the new device.
//!
//! Errors outside the guarded allocations (`gpu::alloc`): a pipeline the driver refuses, a dispatch or a
//! submission that fails validation go to the device's uncaptured-error handler, which keeps them (wgpu's
//! default handler panics); the next `wait` (every readback waits) returns them as `GpuError`.
//!
//! See `docs/development/wgpu-headless.md` for what software adapters can and cannot do (loop limit of
//! 65,535 iterations per invocation on Mesa 22.3, 128 MiB per storage binding).
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Uncaptured device errors kept between two `wait`s (the first ones; later ones are usually their echoes).
const MAX_KEPT_ERRORS: usize = 8;

/// What `manylights.device_info()` reports.
#[derive(Debug, Clone)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub is_software: bool,
    /// Whether every adapter found is a software one.
    pub only_software: bool,
    /// Every adapter found, "name (backend, type)", best first.
    pub adapters: String,
}

/// A device and its queue, plus what was chosen. Cheap to clone (Arc inside wgpu types).
#[derive(Clone)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: wgpu::Adapter,
    pub summary: AdapterSummary,
    pub limits: wgpu::Limits,
    /// The passes' needs the device's limits do not meet (`gpu::needs::unmet`); empty when all run.
    pub unmet: Vec<String>,
    /// Set by the device-lost callback (or `mark_lost`).
    lost: Arc<AtomicBool>,
    /// Errors no error scope caught (pipeline creation, dispatch encoding, submission), kept by the device's
    /// uncaptured-error handler instead of wgpu's default, which panics; `wait` turns them into `Err`.
    errors: Arc<Mutex<Vec<String>>>,
}

/// The install hint given when no adapter exists.
pub const INSTALL_HINT: &str = "no GPU adapter found. Install a software Vulkan driver \
(Debian/Ubuntu: `apt-get install mesa-vulkan-drivers libvulkan1`) or a Vulkan, Metal or DX12 driver for your GPU \
(OpenGL adapters are found but run none of the GPU passes); MANYLIGHTS_ADAPTER and WGPU_BACKEND select among \
adapters";

/// Why an OpenGL adapter runs none of the passes (kept in `GpuContext::unmet`: `device="auto"` takes the CPU,
/// `"gpu"` is refused with it).
pub const GL_UNVALIDATED: &str = "OpenGL: the GPU passes are not validated on it (on Mesa's llvmpipe over EGL the \
columns pass does not compile, WGSL's `textureLoad` from depth textures having no GLSL form, and the fuzzy K-means \
returned wrongly ordered candidates without an error); use a Vulkan, Metal or DX12 adapter";

fn is_software(info: &wgpu::AdapterInfo) -> bool {
    let name = info.name.to_lowercase();
    info.device_type == wgpu::DeviceType::Cpu
        || name.contains("llvmpipe")
        || name.contains("lavapipe")
        || name.contains("swiftshader")
        || name.contains("software")
}

/// Lower is better (module docs).
pub fn rank(info: &wgpu::AdapterInfo) -> i32 {
    let type_rank = match info.device_type {
        _ if is_software(info) => 5,
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        // GL reports most drivers as "Other": below every adapter of a known hardware type.
        wgpu::DeviceType::Other if info.backend == wgpu::Backend::Gl => 4,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 5,
    };
    // Among software adapters prefer Vulkan (lavapipe: fully compliant, float32 blending) over GL.
    let backend_rank = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    type_rank * 10 + backend_rank
}

/// Address space a GPU driver reserves while it creates a device and compiles the passes' shaders: about
/// 1.9 GB measured with NVIDIA's Vulkan driver 580 (an H200), about 1.5 GB with Mesa's lavapipe. Under a
/// tighter `ulimit -v` / `ulimit -d` the drivers do not fail cleanly: NVIDIA's shader compiler aborts the
/// process ("LLVM ERROR: out of memory"), lavapipe crashes (SIGSEGV). So no device is created then.
pub const DRIVER_ADDRESS_SPACE: u64 = 2 << 30;

/// Refuse to create a device when the process's address-space or data limit leaves less room than a driver
/// reserves (`DRIVER_ADDRESS_SPACE`; `room`: `memory::rlimit_remaining`, None without a limit). The error is
/// `GpuUnavailable`, so `device="auto"` falls back to the CPU with this reason.
pub fn check_driver_room(room: Option<u64>) -> Result<()> {
    match room {
        Some(r) if r < DRIVER_ADDRESS_SPACE => Err(Error::GpuUnavailable(format!(
            "the address-space or data limit (ulimit -v / -d) leaves {} of room, and a GPU driver reserves about {} \
             while it creates a device and compiles shaders (it aborts the process when it cannot); raise the limit \
             or use device=\"cpu\"",
            crate::memory::fmt_bytes(r as u128),
            crate::memory::fmt_bytes(DRIVER_ADDRESS_SPACE as u128)
        ))),
        _ => Ok(()),
    }
}

impl GpuContext {
    /// Create a new device, choosing an adapter as described in the module docs.
    pub fn new() -> Result<GpuContext> {
        let overrides = std::env::var(crate::gpu::needs::LIMITS_ENV).ok();
        GpuContext::with_limits(overrides.as_deref())
    }

    /// `new`, with the adapter's limits lowered by `overrides` (the syntax of `MANYLIGHTS_GPU_LIMITS`,
    /// `gpu::needs`) instead of that variable.
    pub fn with_limits(overrides: Option<&str>) -> Result<GpuContext> {
        crate::gpu::wsi_env::quiet_device_select();
        check_driver_room(crate::memory::rlimit_remaining())?;
        // One instance per process: wgpu numbers devices per instance, and the passes' caches tell
        // devices apart by that number, so devices of two instances would be taken for one another.
        static INSTANCE: std::sync::OnceLock<wgpu::Instance> = std::sync::OnceLock::new();
        let instance = INSTANCE.get_or_init(|| {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
            wgpu::Instance::new(desc)
        });
        let mut adapters = pollster::block_on(instance.enumerate_adapters(desc_backends()));
        if adapters.is_empty() {
            return Err(Error::GpuUnavailable(INSTALL_HINT.to_string()));
        }
        let choice = std::env::var("MANYLIGHTS_ADAPTER").unwrap_or_default().to_lowercase();
        adapters.sort_by_key(|a| rank(&a.get_info()));
        let only_software = adapters.iter().all(|a| is_software(&a.get_info()));
        let all_names = names(&adapters);
        let adapter = match choice.as_str() {
            "" | "auto" | "hardware" => {
                if choice == "hardware" && adapters.iter().all(|a| is_software(&a.get_info())) {
                    return Err(Error::GpuUnavailable(format!(
                        "MANYLIGHTS_ADAPTER=hardware but only software adapters exist: {}",
                        names(&adapters)
                    )));
                }
                adapters.remove(0)
            }
            "software" => {
                let i = adapters.iter().position(|a| is_software(&a.get_info())).ok_or_else(|| {
                    Error::GpuUnavailable(format!(
                        "MANYLIGHTS_ADAPTER=software but no software adapter exists ({}); install \
                         mesa-vulkan-drivers",
                        names(&adapters)
                    ))
                })?;
                adapters.remove(i)
            }
            name => {
                let i = adapters.iter().position(|a| a.get_info().name.to_lowercase().contains(name)).ok_or_else(|| {
                    Error::GpuUnavailable(format!("MANYLIGHTS_ADAPTER={name:?} matches no adapter; found: {}", names(&adapters)))
                })?;
                adapters.remove(i)
            }
        };
        let info = adapter.get_info();
        let adapter_limits = crate::gpu::needs::apply_override(adapter.limits(), overrides)?;
        // Ask for the adapter's own limits where we need more than the defaults (storage size, layers).
        let mut limits = wgpu::Limits::downlevel_defaults();
        limits.max_storage_buffer_binding_size = adapter_limits.max_storage_buffer_binding_size;
        limits.max_buffer_size = adapter_limits.max_buffer_size;
        limits.max_texture_array_layers = adapter_limits.max_texture_array_layers;
        limits.max_texture_dimension_2d = adapter_limits.max_texture_dimension_2d;
        limits.max_storage_buffers_per_shader_stage = adapter_limits.max_storage_buffers_per_shader_stage.min(16);
        limits.max_compute_workgroup_storage_size = adapter_limits.max_compute_workgroup_storage_size;
        limits.max_compute_invocations_per_workgroup = adapter_limits.max_compute_invocations_per_workgroup;
        limits.max_compute_workgroup_size_x = adapter_limits.max_compute_workgroup_size_x;
        limits.max_compute_workgroup_size_y = adapter_limits.max_compute_workgroup_size_y;
        limits.max_compute_workgroups_per_dimension = adapter_limits.max_compute_workgroups_per_dimension;
        limits.max_storage_textures_per_shader_stage = adapter_limits.max_storage_textures_per_shader_stage;
        limits.max_color_attachments = adapter_limits.max_color_attachments;
        limits.max_color_attachment_bytes_per_sample = adapter_limits.max_color_attachment_bytes_per_sample;
        limits.max_compute_workgroup_size_z = adapter_limits.max_compute_workgroup_size_z;
        limits.max_uniform_buffers_per_shader_stage = adapter_limits.max_uniform_buffers_per_shader_stage;
        limits.max_sampled_textures_per_shader_stage = adapter_limits.max_sampled_textures_per_shader_stage;
        limits.max_bindings_per_bind_group = adapter_limits.max_bindings_per_bind_group;
        // Never more than the adapter (or the override) allows, whatever the defaults above say.
        let limits = limits.or_worse_values_from(&adapter_limits);
        let mut unmet = crate::gpu::needs::unmet(&limits);
        if info.backend == wgpu::Backend::Gl {
            unmet.push(GL_UNVALIDATED.to_string());
        }
        let mut features = wgpu::Features::empty();
        for f in [wgpu::Features::FLOAT32_FILTERABLE, wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES] {
            if adapter.features().contains(f) {
                features |= f;
            }
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("manylights::GpuContext::device"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| Error::GpuUnavailable(format!("adapter {:?} refused a device: {e}", info.name)))?;
        let summary = AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend).to_lowercase(),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            is_software: is_software(&info),
            only_software,
            adapters: all_names,
        };
        let lost = Arc::new(AtomicBool::new(false));
        let flag = lost.clone();
        device.set_device_lost_callback(move |_reason, _message| flag.store(true, Ordering::SeqCst));
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut v = sink.lock().unwrap_or_else(|p| p.into_inner());
            if v.len() < MAX_KEPT_ERRORS {
                v.push(e.to_string());
            }
        }));
        Ok(GpuContext { device, queue, adapter, summary, limits, unmet, lost, errors })
    }

    /// The process-wide shared context, created on first use and again after a loss (module docs).
    /// Errors are not cached, so a user who installs a driver can retry in the same process.
    pub fn shared() -> Result<Arc<GpuContext>> {
        static CTX: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);
        let mut slot = CTX.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = slot.as_ref().filter(|c| !c.is_lost()) {
            return Ok(c.clone());
        }
        *slot = None;
        let ctx = Arc::new(GpuContext::new()?);
        *slot = Some(ctx.clone());
        Ok(ctx)
    }

    /// Whether the device was lost (then `shared()` makes a new one).
    pub fn is_lost(&self) -> bool {
        self.lost.load(Ordering::SeqCst)
    }

    /// Marks the device lost, as the device-lost callback does: a test hook that simulates a loss (and
    /// makes `shared()` read `MANYLIGHTS_GPU_LIMITS` / `MANYLIGHTS_ADAPTER` afresh). Work on it still runs.
    pub fn mark_lost(&self) {
        self.lost.store(true, Ordering::SeqCst);
    }

    /// `Err(GpuUnavailable)` naming the passes this device cannot run and the limits, Ok when all can.
    pub fn check_needs(&self) -> Result<()> {
        if self.unmet.is_empty() {
            return Ok(());
        }
        Err(Error::GpuUnavailable(format!(
            "the GPU adapter {:?} cannot run every GPU pass: {}; use device=\"cpu\" (device=\"auto\" does, unless \
             MANYLIGHTS_ADAPTER or MANYLIGHTS_DEVICE asks for this adapter)",
            self.summary.name,
            self.unmet.join("; ")
        )))
    }

    /// Wait for all submitted work; turn a lost device, and any error the device reported outside an error
    /// scope since the last wait (`errors`), into an error. Interruptible (`crate::interrupt::wait_gpu`):
    /// `Error::Interrupted` leaves the work running.
    pub fn wait(&self) -> Result<()> {
        crate::interrupt::wait_gpu(&self.device, None, "the device").inspect_err(|e| {
            if matches!(e, Error::Gpu(m) if m.contains("lost") || m.contains("Lost")) {
                self.mark_lost();
            }
        })?;
        self.take_errors()
    }

    /// `Err(Gpu)` listing the errors the device reported outside any error scope since the last call (and
    /// forgetting them), Ok when there were none.
    pub fn take_errors(&self) -> Result<()> {
        let errors = std::mem::take(&mut *self.errors.lock().unwrap_or_else(|p| p.into_inner()));
        if errors.is_empty() {
            return Ok(());
        }
        Err(Error::Gpu(format!("the GPU device reported {} error(s) outside a guarded call: {}", errors.len(), errors.join("; "))))
    }

    /// Copy a storage buffer back to the host (the buffer needs COPY_SRC usage).
    pub fn read_buffer<T: bytemuck::Pod>(&self, src: &wgpu::Buffer, offset: u64, count: usize) -> Result<Vec<T>> {
        let mut out = Vec::with_capacity(count);
        self.read_buffer_into(src, offset, count, &mut out)?;
        Ok(out)
    }

    /// `read_buffer`, appending to `out` straight from the mapped staging buffer (one host copy).
    pub fn read_buffer_into<T: bytemuck::Pod>(&self, src: &wgpu::Buffer, offset: u64, count: usize, out: &mut Vec<T>) -> Result<()> {
        let size = (count * std::mem::size_of::<T>()) as u64;
        if size == 0 {
            return Ok(());
        }
        let staging = crate::gpu::alloc::buffer(
            &self.device,
            &wgpu::BufferDescriptor {
                label: Some("GpuContext::read_buffer::staging"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        )?;
        let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GpuContext::read_buffer") });
        enc.copy_buffer_to_buffer(src, offset, &staging, 0, size);
        self.queue.submit(Some(enc.finish()));
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| Error::Gpu(format!("buffer map callback lost: {e}")))?
            .map_err(|e| Error::Gpu(format!("mapping a buffer for readback failed: {e}")))?;
        let data = slice.get_mapped_range().map_err(|e| Error::Gpu(format!("reading a mapped buffer failed: {e:?}")))?;
        out.extend_from_slice(bytemuck::cast_slice::<u8, T>(&data));
        drop(data);
        staging.unmap();
        Ok(())
    }
}

fn desc_backends() -> wgpu::Backends {
    wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())
}

fn names(adapters: &[wgpu::Adapter]) -> String {
    adapters
        .iter()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests;
