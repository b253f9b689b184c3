//! Ctrl-C for long native calls: the checker behind `crate::interrupt::check`, the GIL-releasing call
//! wrapper that turns an interruption into the pending Python exception, and the progress callback.
//!
//! `install()` (module init) registers `checker`: on the thread that started a call it re-acquires the
//! GIL for a moment and runs `PyErr_CheckSignals` (pyo3 `Python::check_signals`); a raised exception
//! (KeyboardInterrupt, or whatever a user's SIGINT handler raises) is kept in a thread-local slot and
//! the core call returns `Error::Interrupted`, which `errors.rs` turns back into that exception.
use crate::error::Result;
use pyo3::prelude::*;
use std::cell::RefCell;

thread_local! {
    static PENDING: RefCell<Option<PyErr>> = const { RefCell::new(None) };
}

fn set_pending(e: PyErr) {
    PENDING.with(|p| {
        let mut p = p.borrow_mut();
        if p.is_none() {
            *p = Some(e);
        }
    });
}

/// The exception kept by the last interrupted check on this thread (taken out).
pub fn take_pending() -> Option<PyErr> {
    PENDING.with(|p| p.borrow_mut().take())
}

fn has_pending() -> bool {
    PENDING.with(|p| p.borrow().is_some())
}

/// True when the current native call must stop: a pending exception, or a Python signal handler
/// raised one now.
fn checker() -> bool {
    if has_pending() {
        return true;
    }
    Python::attach(|py| match py.check_signals() {
        Ok(()) => false,
        Err(e) => {
            set_pending(e);
            true
        }
    })
}

/// Register `checker` with `crate::interrupt`.
pub fn install() {
    crate::interrupt::set_checker(checker);
}

/// Run `f` with the GIL released; Ctrl-C during it raises `KeyboardInterrupt` (via `Error::Interrupted`)
/// as soon as `f` next checks. A signal that arrives in the last stretch of a call that completes is
/// raised here too, not left for a later call.
pub fn detach<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T> + Send) -> PyResult<T> {
    drop(take_pending());
    let r = py.detach(f);
    match r {
        Ok(v) => match take_pending() {
            Some(e) => Err(e),
            None => Ok(v),
        },
        Err(e) => Err(e.into()),
    }
}

/// A Rust progress callback that forwards (done, total) to an optional Python callable. Ordinary
/// exceptions from it are ignored (progress display must not abort GPU work); KeyboardInterrupt,
/// SystemExit and signals arriving meanwhile stop the call at its next check.
pub fn progress_callback(progress: Option<Py<PyAny>>) -> impl FnMut(usize, usize) {
    move |done: usize, total: usize| {
        Python::attach(|py| {
            if let Some(p) = &progress {
                if let Err(e) = p.call1(py, (done, total)) {
                    if !e.is_instance_of::<pyo3::exceptions::PyException>(py) {
                        set_pending(e);
                    }
                }
            }
            if let Err(e) = py.check_signals() {
                set_pending(e);
            }
        });
    }
}
