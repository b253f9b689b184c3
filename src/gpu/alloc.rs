//! The one guarded path every GPU allocation takes (`buffer`, `buffer_init`, `texture`).
//!
//! Each request is first checked against the device's limits (read from the device, which was given the
//! adapter's own limits, never assumed):
//! - a buffer above `max_buffer_size`;
//! - a storage buffer bound whole (`buffer`, `buffer_init`) above `max_storage_buffer_binding_size`
//!   (buffers bound in ranges use `buffer_ranged`, which skips this check);
//! - a texture wider or taller than `max_texture_dimension_2d` or with more layers than
//!   `max_texture_array_layers`;
//! - any request above the GPU memory budget `MANYLIGHTS_GPU_MEMORY_LIMIT` (bytes, or with a K/M/G/T
//!   suffix in powers of 1024: `2G`), when the user sets it (on hardware, wgpu cannot tell how much
//!   memory the GPU has left; the budget keeps room for other work, and lets a test make any request
//!   too big).
//!
//! A request that fails a check is refused with `Error::OutOfMemory` (Python `MemoryError`) naming the
//! buffer, its bytes and the limit, before anything is created. Then the object is created inside an
//! out-of-memory and a validation error scope (thread-local in wgpu, so concurrent callers do not see
//! each other's errors): an allocation the driver refuses becomes `Error::OutOfMemory`, a validation
//! error `Error::Gpu`, both naming the request, instead of reaching wgpu's default handler (a panic,
//! `PanicException` in Python). The device stays usable afterwards. `buffer_init` creates the buffer
//! mapped, and copies the contents only once creation succeeded.
//!
//! Whole-`LightMatrix` requests are estimated before any of their buffers are made
//! (`crate::matrix::gpu::estimate_gpu_bytes`) and refused the same way when the total is above the
//! budget or a single binding above the limits.
use crate::error::{Error, Result};
use crate::memory::fmt_bytes;

/// The environment variable of the GPU memory budget (module docs).
pub const GPU_MEMORY_LIMIT_ENV: &str = "MANYLIGHTS_GPU_MEMORY_LIMIT";

/// The budget `MANYLIGHTS_GPU_MEMORY_LIMIT` sets, None when unset or empty.
///
/// Errors: `InvalidParameter` for a value that is not a byte count.
pub fn budget() -> Result<Option<u64>> {
    match std::env::var(GPU_MEMORY_LIMIT_ENV) {
        Ok(v) if !v.trim().is_empty() => crate::memory::parse_bytes(&v)
            .map(Some)
            .ok_or_else(|| Error::invalid(format!("{GPU_MEMORY_LIMIT_ENV} must be a byte count such as 2000000000 or 2G, got {v:?}"))),
        _ => Ok(None),
    }
}

/// "81920 bytes", or "1610612736 bytes (1.61 GB)" from a megabyte on.
fn size_text(bytes: u128) -> String {
    if bytes >= 1_000_000 {
        format!("{bytes} bytes ({})", fmt_bytes(bytes))
    } else {
        format!("{bytes} bytes")
    }
}

/// Refuse `bytes` for `what` above the budget (module docs).
pub fn check_budget(what: &str, bytes: u128) -> Result<()> {
    if let Some(limit) = budget()? {
        if bytes > limit as u128 {
            return Err(Error::OutOfMemory(format!(
                "{what} needs {} of GPU memory, above the budget {GPU_MEMORY_LIMIT_ENV} of {}",
                size_text(bytes),
                size_text(limit as u128)
            )));
        }
    }
    Ok(())
}

/// Refuse a buffer of `bytes` for `what` on a device with `limits` (module docs); `whole_binding`: it is
/// bound whole as a storage buffer.
pub fn check_buffer(limits: &wgpu::Limits, what: &str, bytes: u128, whole_binding: bool) -> Result<()> {
    if bytes > limits.max_buffer_size as u128 {
        return Err(Error::OutOfMemory(format!(
            "{what} needs a GPU buffer of {}, above the adapter's max_buffer_size of {} bytes",
            size_text(bytes),
            limits.max_buffer_size
        )));
    }
    if whole_binding && bytes > limits.max_storage_buffer_binding_size as u128 {
        return Err(Error::OutOfMemory(format!(
            "{what} needs a storage binding of {}, above the adapter's max_storage_buffer_binding_size of {} bytes",
            size_text(bytes),
            limits.max_storage_buffer_binding_size
        )));
    }
    check_budget(what, bytes)
}

/// Bytes of a texture (all layers and mips of level 0 only; 4 bytes per texel for formats without a
/// copy size, such as combined depth-stencil).
pub fn texture_bytes(desc: &wgpu::TextureDescriptor) -> u128 {
    let texel =
        desc.format.block_copy_size(None).or_else(|| desc.format.block_copy_size(Some(wgpu::TextureAspect::DepthOnly))).unwrap_or(4);
    crate::memory::product(&[desc.size.width as u64, desc.size.height as u64, desc.size.depth_or_array_layers as u64, texel as u64])
}

/// Run `create` inside out-of-memory and validation error scopes (module docs).
fn scoped<T>(device: &wgpu::Device, what: &str, bytes: u128, create: impl FnOnce() -> T) -> Result<T> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let value = create();
    let oom_err = pollster::block_on(oom.pop());
    let val_err = pollster::block_on(validation.pop());
    if let Some(e) = oom_err {
        return Err(Error::OutOfMemory(format!("the GPU could not allocate {what} ({}): {e}", size_text(bytes))));
    }
    if let Some(e) = val_err {
        return Err(Error::Gpu(format!("allocating {what} ({bytes} bytes) failed: {e}")));
    }
    Ok(value)
}

fn label_of(label: Option<&str>) -> &str {
    label.unwrap_or("an unlabelled GPU buffer")
}

/// `device.create_buffer(desc)` through the guarded path; a STORAGE buffer is checked as bound whole.
pub fn buffer(device: &wgpu::Device, desc: &wgpu::BufferDescriptor) -> Result<wgpu::Buffer> {
    let what = label_of(desc.label);
    check_buffer(&device.limits(), what, desc.size as u128, desc.usage.contains(wgpu::BufferUsages::STORAGE))?;
    scoped(device, what, desc.size as u128, || device.create_buffer(desc))
}

/// `buffer` for a storage buffer bound in ranges, each within the binding limit (only `max_buffer_size`
/// and the budget apply to the whole).
pub fn buffer_ranged(device: &wgpu::Device, desc: &wgpu::BufferDescriptor) -> Result<wgpu::Buffer> {
    let what = label_of(desc.label);
    check_buffer(&device.limits(), what, desc.size as u128, false)?;
    scoped(device, what, desc.size as u128, || device.create_buffer(desc))
}

/// A buffer holding `contents` (padded to 4 bytes, at least 4), as `wgpu::util::DeviceExt::create_buffer_init`
/// makes it, through the guarded path: created mapped, filled only when creation succeeded.
pub fn buffer_init(device: &wgpu::Device, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> Result<wgpu::Buffer> {
    let align = wgpu::COPY_BUFFER_ALIGNMENT;
    let size = (contents.len() as u64).div_ceil(align).max(1) * align;
    check_buffer(&device.limits(), label, size as u128, usage.contains(wgpu::BufferUsages::STORAGE))?;
    let desc = wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: true };
    let buf = scoped(device, label, size as u128, || device.create_buffer(&desc))?;
    {
        let mut view = buf
            .get_mapped_range_mut(..)
            .map_err(|e| Error::Gpu(format!("writing {label} ({size} bytes) into its mapped buffer failed: {e:?}")))?;
        view.slice(..contents.len()).copy_from_slice(contents);
    }
    buf.unmap();
    Ok(buf)
}

/// `device.create_texture(desc)` through the guarded path (dimensions, layers, budget, error scopes).
pub fn texture(device: &wgpu::Device, desc: &wgpu::TextureDescriptor) -> Result<wgpu::Texture> {
    let what = desc.label.unwrap_or("an unlabelled GPU texture");
    let limits = device.limits();
    let bytes = texture_bytes(desc);
    let (w, h, layers) = (desc.size.width, desc.size.height, desc.size.depth_or_array_layers);
    if desc.dimension == wgpu::TextureDimension::D2 {
        if w.max(h) > limits.max_texture_dimension_2d {
            return Err(Error::OutOfMemory(format!(
                "{what} is {w}x{h} texels, above the adapter's max_texture_dimension_2d of {}",
                limits.max_texture_dimension_2d
            )));
        }
        if layers > limits.max_texture_array_layers {
            return Err(Error::OutOfMemory(format!(
                "{what} has {layers} layers, above the adapter's max_texture_array_layers of {}",
                limits.max_texture_array_layers
            )));
        }
    }
    check_budget(what, bytes)?;
    scoped(device, what, bytes, || device.create_texture(desc))
}

#[cfg(test)]
mod tests;
