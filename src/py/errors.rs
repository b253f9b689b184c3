//! Core errors -> Python exceptions.
use crate::error::Error;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError, PyKeyboardInterrupt, PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;

create_exception!(manylights, ManyLightsError, PyException, "Base class of manylights' own exceptions.");
create_exception!(manylights, GpuUnavailableError, ManyLightsError, "No GPU adapter (hardware or software) could be created.");
create_exception!(manylights, GpuError, ManyLightsError, "A GPU operation failed.");
create_exception!(manylights, SceneError, ManyLightsError, "A scene file is malformed or unsupported (message names file and line).");

impl From<Error> for PyErr {
    fn from(e: Error) -> PyErr {
        let msg = e.to_string();
        match e {
            Error::Scene { .. } => SceneError::new_err(msg),
            Error::FileNotFound { .. } => PyFileNotFoundError::new_err(msg),
            Error::Io { .. } => PyOSError::new_err(msg),
            Error::InvalidParameter(_) => PyValueError::new_err(msg),
            Error::GpuUnavailable(_) => GpuUnavailableError::new_err(msg),
            Error::Gpu(_) => GpuError::new_err(msg),
            // The exception Python's signal handler raised (normally KeyboardInterrupt), kept by
            // `signals::checker`.
            Error::Interrupted => super::signals::take_pending().unwrap_or_else(|| PyKeyboardInterrupt::new_err(())),
            Error::OutOfMemory(_) => PyMemoryError::new_err(msg),
        }
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ManyLightsError", py.get_type::<ManyLightsError>())?;
    m.add("GpuUnavailableError", py.get_type::<GpuUnavailableError>())?;
    m.add("GpuError", py.get_type::<GpuError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    Ok(())
}
