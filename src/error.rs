//! Errors of the core. Every fallible core function returns [`Result`]; `src/py/` maps the variants to
//! Python exceptions (ValueError, FileNotFoundError, OSError, GpuUnavailableError, GpuError).
//! Messages say which file, which line and which value, and what was expected.
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Where in a scene file something came from: file and 1-based line (0 when unknown).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Location {
    pub file: PathBuf,
    pub line: u32,
}

impl Location {
    pub fn new(file: impl AsRef<Path>, line: u32) -> Self {
        Location { file: file.as_ref().to_path_buf(), line }
    }
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}", self.file.display(), self.line)
        } else {
            write!(f, "{}", self.file.display())
        }
    }
}

#[derive(Debug, Error)]
pub enum Error {
    /// A scene file (XML, mesh, texture) is malformed or asks for something unsupported.
    #[error("{loc}: {msg}")]
    Scene { loc: Location, msg: String },
    /// A file that a scene names does not exist.
    #[error("{loc}: file not found: {path}")]
    FileNotFound { loc: Location, path: PathBuf },
    /// Reading or writing a file failed.
    #[error("{path}: {msg}")]
    Io { path: PathBuf, msg: String },
    /// An argument has a wrong value or shape ("positions must have shape (N, 3), got (128, 4)").
    #[error("{0}")]
    InvalidParameter(String),
    /// No GPU adapter could be created; the message says what to install.
    #[error("{0}")]
    GpuUnavailable(String),
    /// A GPU operation failed (device lost, out of memory, validation).
    #[error("GPU error: {0}")]
    Gpu(String),
    /// The call was interrupted (Ctrl-C; `crate::interrupt`); Python raises the pending
    /// `KeyboardInterrupt`.
    #[error("interrupted")]
    Interrupted,
    /// A request would not fit in host or GPU memory; the message names the request and the limit.
    #[error("{0}")]
    OutOfMemory(String),
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn scene(loc: &Location, msg: impl Into<String>) -> Self {
        Error::Scene { loc: loc.clone(), msg: msg.into() }
    }
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::InvalidParameter(msg.into())
    }
    pub fn io(path: impl AsRef<Path>, err: impl std::fmt::Display) -> Self {
        Error::Io { path: path.as_ref().to_path_buf(), msg: err.to_string() }
    }
}
