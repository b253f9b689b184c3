//! Memory checks made before allocating what a user's request sizes (rows, columns, shadow maps,
//! image resolution, light counts): a request that cannot fit is refused with `Error::OutOfMemory`
//! (Python `MemoryError`) naming the request and the limit, instead of an abort or an OOM kill.
//!
//! Host memory available = `MemAvailable` of `/proc/meminfo`, lowered to the cgroup's remaining
//! allowance (`memory.max - memory.current`, cgroup v2, or `memory.limit_in_bytes - memory.usage_in_bytes`,
//! v1) where a container sets one, to the room left under the address-space and data-segment limits
//! (`ulimit -v` / `ulimit -d`: RLIMIT_AS less `VmSize`, RLIMIT_DATA less `VmData`), and to `MANYLIGHTS_MEMORY_LIMIT` (bytes, or with a K/M/G/T suffix
//! in powers of 1024: `8G`) when the user sets it, e.g. to keep room for other work on a shared
//! machine. On systems without `/proc/meminfo` only that variable bounds the host check (the adapter's
//! limits still apply). GPU allocations are checked against the adapter's limits
//! (`max_buffer_size`, texture dimensions and layers); on a software adapter (lavapipe, llvmpipe) GPU
//! memory is host memory, so they are also checked against the host; on hardware adapters an
//! allocation the driver refuses is caught by an out-of-memory error scope (`crate::gpu::alloc`, the one path
//! every GPU allocation takes).
use crate::error::{Error, Result};

/// Host bytes per light of a `LightSet` (kind, five Vec3, intensity, two angles, an 80-byte BSDF, a
/// 4-corner patch, a VSL radius, the glossy-MIS measure and emitter index) plus its cached power.
pub const HOST_BYTES_PER_LIGHT: u64 = 4 + 6 * 12 + 8 + 80 + 48 + 4 + 8 + 12;
/// Host bytes per view sample: the G-buffer ids and readback, `ViewSamples` (positions, normals, wi,
/// uv, albedo, indices, an 80-byte BSDF) and the GPU upload's staging copy (64 + 80 bytes).
pub const HOST_BYTES_PER_VIEW_SAMPLE: u64 = 8 + 4 * 12 + 8 + 12 + 8 + 80 + 144;

/// Refuse the host memory of the view samples of a `width` x `height` film when it does not fit (the CPU
/// backend's G-buffer).
pub fn check_view_samples_host(width: u32, height: u32) -> Result<()> {
    let m = width as u64 * height as u64;
    check_host(&format!("view samples of a {width}x{height} film"), product(&[m, HOST_BYTES_PER_VIEW_SAMPLE]))
}

/// Refuse a film of `width x height` view samples that cannot fit in host memory (software adapters:
/// with its G-buffer textures).
pub fn check_view_samples(ctx: &crate::gpu::GpuContext, width: u32, height: u32) -> Result<()> {
    let m = width as u64 * height as u64;
    check_view_samples_host(width, height)?;
    check_gpu(ctx, &format!("the G-buffer of a {width}x{height} film"), product(&[m, 16]), false)
}

/// Bytes of host memory a new allocation may take now (None when unknown); an invalid
/// `MANYLIGHTS_MEMORY_LIMIT` is an error.
pub fn available_host_bytes() -> Result<Option<u64>> {
    let system = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| meminfo_field(&m, "MemAvailable:"));
    let mut avail = match (system, cgroup_remaining()) {
        (Some(a), Some(c)) => Some(a.min(c)),
        (a, c) => a.or(c),
    };
    if let Some(r) = rlimit_remaining() {
        avail = Some(avail.map_or(r, |a| a.min(r)));
    }
    if let Ok(v) = std::env::var("MANYLIGHTS_MEMORY_LIMIT") {
        let limit = parse_bytes(&v)
            .ok_or_else(|| Error::invalid(format!("MANYLIGHTS_MEMORY_LIMIT must be a byte count such as 2000000000 or 2G, got {v:?}")))?;
        avail = Some(avail.map_or(limit, |a| a.min(limit)));
    }
    if let Some(limit) = THREAD_LIMIT.with(|l| l.get()) {
        avail = Some(avail.map_or(limit, |a| a.min(limit)));
    }
    Ok(avail)
}

thread_local! {
    static THREAD_LIMIT: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` with this thread's host-memory checks bounded by `bytes` as well (as if
/// `MANYLIGHTS_MEMORY_LIMIT` were at most `bytes`, for this thread only; nested calls keep the smaller
/// bound; the previous bound is restored afterwards, also when `f` panics). The fuzz entry points
/// (`crate::fuzzing`) use it to hold the loaders to the fuzzer's memory limit; work that `f` hands to
/// other threads is not bounded by it.
pub fn with_thread_limit<T>(bytes: u64, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<u64>);
    impl Drop for Restore {
        fn drop(&mut self) {
            THREAD_LIMIT.with(|l| l.set(self.0));
        }
    }
    let previous = THREAD_LIMIT.with(|l| l.get());
    let _restore = Restore(previous);
    THREAD_LIMIT.with(|l| l.set(Some(previous.map_or(bytes, |p| p.min(bytes)))));
    f()
}

/// "123", "64K", "2M", "8G", "1T" (powers of 1024; a trailing "B"/"iB" is allowed).
pub(crate) fn parse_bytes(s: &str) -> Option<u64> {
    let t = s.trim().trim_end_matches(['B', 'b']).trim_end_matches('i');
    let (num, mult) = match t.chars().last()? {
        'k' | 'K' => (&t[..t.len() - 1], 1u64 << 10),
        'm' | 'M' => (&t[..t.len() - 1], 1 << 20),
        'g' | 'G' => (&t[..t.len() - 1], 1 << 30),
        't' | 'T' => (&t[..t.len() - 1], 1 << 40),
        _ => (t, 1),
    };
    let v: f64 = num.trim().parse().ok()?;
    (v.is_finite() && v >= 0.0).then(|| (v * mult as f64) as u64)
}

/// A `/proc/meminfo` field in bytes (the file gives kB).
fn meminfo_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line[key.len()..].trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kb.saturating_mul(1024))
}

fn read_u64(path: &str) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// Room left under the process's address-space and data-segment limits (`ulimit -v`, RLIMIT_AS, against
/// `VmSize`; `ulimit -d`, RLIMIT_DATA, against `VmData`), the smaller; None when neither is set. An
/// allocation past either fails, and Rust aborts the process on a failed allocation.
pub fn rlimit_remaining() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    rlimit_room(&limits, &status)
}

/// `rlimit_remaining` from the texts of `/proc/self/limits` and `/proc/self/status`.
fn rlimit_room(limits: &str, status: &str) -> Option<u64> {
    let soft = |name: &str| -> Option<u64> {
        let line = limits.lines().find(|l| l.starts_with(name))?;
        line[name.len()..].split_whitespace().next()?.parse().ok() // "unlimited" -> None
    };
    let room = |limit: Option<u64>, used: &str| limit.map(|l| l.saturating_sub(meminfo_field(status, used).unwrap_or(0)));
    match (room(soft("Max address space"), "VmSize:"), room(soft("Max data size"), "VmData:")) {
        (Some(a), Some(d)) => Some(a.min(d)),
        (a, d) => a.or(d),
    }
}

/// Memory left under the process's cgroup limit (None without a limit).
fn cgroup_remaining() -> Option<u64> {
    // cgroup v2: the process's own group from /proc/self/cgroup ("0::/path").
    if let Ok(cg) = std::fs::read_to_string("/proc/self/cgroup") {
        for line in cg.lines() {
            if let Some(path) = line.strip_prefix("0::") {
                let dir = format!("/sys/fs/cgroup{}", path.trim_end_matches('/'));
                if let (Some(max), Some(cur)) = (read_u64(&format!("{dir}/memory.max")), read_u64(&format!("{dir}/memory.current"))) {
                    return Some(max.saturating_sub(cur));
                }
            }
        }
    }
    let (max, cur) = (read_u64("/sys/fs/cgroup/memory/memory.limit_in_bytes")?, read_u64("/sys/fs/cgroup/memory/memory.usage_in_bytes")?);
    // v1 reports "no limit" as a huge number.
    (max < 1 << 60).then(|| max.saturating_sub(cur))
}

/// Human-readable bytes ("1.07 GB").
pub fn fmt_bytes(b: u128) -> String {
    let b = b as f64;
    if b >= 1e9 {
        format!("{:.2} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{b:.0} bytes")
    }
}

/// `count_a * count_b * ... * elem_bytes` without overflow.
pub fn product(factors: &[u64]) -> u128 {
    factors.iter().fold(1u128, |a, &f| a.saturating_mul(f as u128))
}

/// Refuse `what` needing `bytes` of host memory when more than is available (`available_host_bytes`)
/// or more than the address space can hold.
pub fn check_host(what: &str, bytes: u128) -> Result<()> {
    check_host_against(what, bytes, available_host_bytes()?)
}

fn check_host_against(what: &str, bytes: u128, available: Option<u64>) -> Result<()> {
    if bytes > isize::MAX as u128 {
        return Err(Error::OutOfMemory(format!("{what} needs {} of host memory, more than this process can address", fmt_bytes(bytes))));
    }
    if let Some(avail) = available {
        if bytes > avail as u128 {
            return Err(Error::OutOfMemory(format!(
                "{what} needs {} of host memory but only {} is available (MemAvailable, cgroup limit, \
                 address-space and data limits (ulimit -v / -d), MANYLIGHTS_MEMORY_LIMIT); request less",
                fmt_bytes(bytes),
                fmt_bytes(avail as u128)
            )));
        }
    }
    Ok(())
}

/// Refuse a GPU allocation of `bytes` for `what` above the adapter's `max_buffer_size` (when `buffer`)
/// or, on a software adapter, above the available host memory.
pub fn check_gpu(ctx: &crate::gpu::GpuContext, what: &str, bytes: u128, buffer: bool) -> Result<()> {
    if buffer && bytes > ctx.limits.max_buffer_size as u128 {
        return Err(Error::OutOfMemory(format!(
            "{what} needs a GPU buffer of {}, above the adapter's max_buffer_size of {}",
            fmt_bytes(bytes),
            fmt_bytes(ctx.limits.max_buffer_size as u128)
        )));
    }
    if ctx.summary.is_software {
        check_host(&format!("{what} (GPU memory of the software adapter {})", ctx.summary.name), bytes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
