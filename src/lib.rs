//! manylights: many-light rendering research core (Rust), with Python bindings behind the `python` feature.
pub mod error;
pub mod gpu;
pub mod raytrace;
pub mod scene;
pub mod shading;
pub mod view;

#[cfg(feature = "python")]
pub mod py;
