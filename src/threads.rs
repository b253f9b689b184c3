//! The CPU backend's worker threads: rayon's global pool, started once when the Python module is imported.
//!
//! Rayon starts its global pool on first use and panics when it cannot (a `PanicException` in Python), and
//! after one failed start it never tries again. Under an address-space limit (`ulimit -v`) that a GPU driver
//! or other libraries have nearly used up, a worker's stack cannot be mapped and the start fails. So the pool
//! is started at import, when the least address space is in use, with as many threads as can be started: the
//! requested count (`RAYON_NUM_THREADS`, else every core) first, halved while a trial start of that many
//! threads fails (trials only under such a limit, so an unlimited import spawns no extra threads). Only when not even one thread starts does the import fail, with `MemoryError`.

use crate::error::{Error, Result};
use std::sync::{Arc, RwLock};

/// Whether `n` threads with the default stack size (as rayon's workers get) can exist at once: all are
/// started, each waits until this function lets them go, then all are joined (also those started before
/// one failed to start).
pub fn trial(n: usize) -> bool {
    let gate = Arc::new(RwLock::new(()));
    let hold = gate.write().unwrap_or_else(|e| e.into_inner());
    let mut handles = Vec::with_capacity(n);
    let mut all = true;
    for _ in 0..n {
        let g = gate.clone();
        match std::thread::Builder::new().spawn(move || drop(g.read())) {
            Ok(h) => handles.push(h),
            Err(_) => {
                all = false;
                break;
            }
        }
    }
    drop(hold);
    handles.into_iter().fold(all, |ok, h| h.join().is_ok() && ok)
}

/// Start rayon's global pool (module docs). Returns the number of worker threads.
///
/// Errors: `OutOfMemory` when not even one worker thread can be started.
pub fn start_global_pool() -> Result<usize> {
    let wanted = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    let mut n = wanted;
    // Trials only under an address-space or data limit: without one the start does not run out of room.
    let limited = crate::memory::rlimit_remaining().is_some();
    while limited && n > 1 && !trial(n) {
        n /= 2;
    }
    match rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
        Ok(()) => Ok(n),
        Err(e) if e.to_string().contains("already been initialized") => Ok(rayon::current_num_threads()),
        Err(e) => Err(Error::OutOfMemory(format!(
            "the CPU backend could not start {n} worker thread(s) ({e}); the address-space limit (ulimit -v) or \
             the process limit (ulimit -u) leaves no room for their stacks: raise the limit"
        ))),
    }
}

#[cfg(test)]
mod tests;
