//! manylights: many-light rendering research core (Rust), with Python bindings behind the `python` feature.
//!
//! Tests: the tests of `foo` are `#[cfg(test)] mod tests;` in `foo/tests.rs` (`dir/tests.rs` for `dir/mod.rs`; topics in `tests/*.rs`).
pub mod baselines;
pub mod cluster;
pub mod cpu;
pub mod error;
#[doc(hidden)]
pub mod fuzzing;
pub mod gpu;
pub mod image;
pub mod interrupt;
pub mod lights;
pub mod matrix;
pub mod memory;
pub mod pathtrace;
pub mod raytrace;
pub mod relight;
pub mod scene;
pub mod shading;
#[cfg(test)]
pub(crate) mod testing;
pub mod threads;
pub mod view;

#[cfg(feature = "python")]
pub mod py;
