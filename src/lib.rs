//! manylights: many-light rendering research core (Rust), with Python bindings behind the `python` feature.
pub mod error;
pub mod gpu;
pub mod image;
pub mod scene;
pub mod shading;

#[cfg(feature = "python")]
pub mod py;
