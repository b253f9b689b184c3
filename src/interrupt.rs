//! Cooperative interruption of long calls (Ctrl-C in Python).
//!
//! Long core loops call [`check`] between units of work (GPU batches, CPU chunks) and return
//! `Error::Interrupted` when it says so. The check itself is pluggable: the Python bindings install one
//! (`py::signals`) that briefly re-acquires the GIL and runs Python's signal handlers
//! (`PyErr_CheckSignals`), so a SIGINT raises `KeyboardInterrupt` within about [`CHECK_INTERVAL`] plus
//! one unit of work. Without an installed checker (Rust tests, other embedders) `check` is a no-op.
//!
//! Rules that keep the check cheap and correct:
//! - Only the thread that started the call checks: rayon worker threads never do (CPython runs signal
//!   handlers on the main thread only, and acquiring the GIL from a worker would only add contention).
//!   CPU work therefore runs in chunks from the calling thread ([`par_map_chunked`]).
//! - A check runs the Python handlers at most once per [`CHECK_INTERVAL`] per thread.
//! - GPU waits block on a helper thread while the calling thread checks ([`wait_gpu`]), so that a
//!   long batch does not block the check; work already submitted finishes on its own (later submissions queue behind it), so an interrupted
//!   `LightMatrix` stays usable and its next call gives the complete result.
use crate::error::{Error, Result};
use std::cell::Cell;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Least time between two runs of the installed checker on one thread.
pub const CHECK_INTERVAL: Duration = Duration::from_millis(50);
/// Longest wait for a GPU answer between two checks.
pub const GPU_POLL_TIMEOUT: Duration = Duration::from_millis(100);

static CHECKER: OnceLock<fn() -> bool> = OnceLock::new();

thread_local! {
    static LAST_CHECK: Cell<Option<Instant>> = const { Cell::new(None) };
}

/// Install the process-wide checker (returns true when the current call must stop). The first
/// installation wins.
pub fn set_checker(f: fn() -> bool) {
    let _ = CHECKER.set(f);
}

/// `Err(Error::Interrupted)` when the installed checker asks to stop; throttled to one real check per
/// `CHECK_INTERVAL` per thread; a no-op on rayon worker threads and without a checker.
pub fn check() -> Result<()> {
    let Some(f) = CHECKER.get() else { return Ok(()) };
    if rayon::current_thread_index().is_some() {
        return Ok(());
    }
    let now = Instant::now();
    let due = LAST_CHECK.with(|t| match t.get() {
        Some(last) if now.duration_since(last) < CHECK_INTERVAL => false,
        _ => {
            t.set(Some(now));
            true
        }
    });
    if due && f() {
        return Err(Error::Interrupted);
    }
    Ok(())
}

/// `check` without the throttle (at the start and end of a call).
pub fn check_now() -> Result<()> {
    LAST_CHECK.with(|t| t.set(None));
    check()
}

/// `(0..n).into_par_iter().map(f).collect()` in chunks of `chunk` items, checking for interruption
/// between chunks (from the calling thread).
pub fn par_map_chunked<T: Send>(n: usize, chunk: usize, f: impl Fn(usize) -> T + Sync) -> Result<Vec<T>> {
    use rayon::prelude::*;
    let chunk = chunk.max(1);
    let mut out = Vec::with_capacity(n);
    let mut start = 0;
    while start < n {
        check()?;
        let end = (start + chunk).min(n);
        out.par_extend((start..end).into_par_iter().with_min_len(64).map(&f));
        start = end;
    }
    Ok(out)
}

/// Whether a checker is installed (Python): only then do waits need to be interruptible.
pub fn enabled() -> bool {
    CHECKER.get().is_some()
}

/// Wait for `submission` (None: everything submitted so far) on `device`, checking for interruption
/// every `GPU_POLL_TIMEOUT`. An interrupted wait leaves the work running on the GPU.
///
/// The blocking wait runs on a short-lived helper thread and this thread waits for its answer with a
/// timeout: wgpu 30.0.1's own poll timeout (`PollType::Wait { timeout: Some(..) }`) can trip an
/// assertion in `Device::maintain` when another thread's poll or submit retires the awaited
/// submission meanwhile (gfx-rs/wgpu#9958), so it is not used. Without a checker the wait is direct.
pub fn wait_gpu(device: &wgpu::Device, submission: Option<wgpu::SubmissionIndex>, what: &str) -> Result<()> {
    let blocking = |device: &wgpu::Device, submission| {
        device.poll(wgpu::PollType::Wait { submission_index: submission, timeout: None }).map(|_| ()).map_err(|e| e.to_string())
    };
    if !enabled() || rayon::current_thread_index().is_some() {
        return blocking(device, submission).map_err(|e| Error::Gpu(format!("waiting for {what} failed: {e}")));
    }
    check()?;
    let (tx, rx) = std::sync::mpsc::channel();
    let dev = device.clone();
    std::thread::Builder::new()
        .name("manylights-gpu-wait".into())
        .spawn(move || {
            let _ = tx.send(blocking(&dev, submission));
        })
        .map_err(|e| Error::Gpu(format!("could not start a thread to wait for {what}: {e}")))?;
    loop {
        match rx.recv_timeout(GPU_POLL_TIMEOUT) {
            Ok(Ok(())) => return Ok(()),
            Ok(Err(e)) => return Err(Error::Gpu(format!("waiting for {what} failed: {e}"))),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => check()?,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(Error::Gpu(format!("the thread waiting for {what} ended without an answer")))
            }
        }
    }
}

#[cfg(test)]
mod tests;
