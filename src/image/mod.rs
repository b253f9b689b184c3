//! Image files and image comparisons: EXR/PNG reading and writing (`io`), Radiance RGBE (`hdr`) and PFM
//! (`pfm`) input, the texture size policy all readers apply before decoding (`size_policy`), Mitsuba's
//! bitmap padding (`pad`) and error metrics (`metrics`).
//!
//! Anti-aliasing from a 3x deep framebuffer (`antialias`).
//!
//! Images are row-major `[f32; 3]` linear RGB with row 0 at the top, `width * height` pixels.
pub mod antialias;
pub mod hdr;
pub mod io;
pub mod metrics;
pub mod pad;
pub mod pfm;
pub mod size_policy;

pub use hdr::read_hdr;
pub use io::{encode_exr, encode_png, encode_srgb8_image, read_exr, write_exr, write_png};
pub use metrics::{fraction_within, mae, max_abs_error, mse, relative_l2, relative_mse, rmse};
pub use pfm::{read_pfm, write_pfm};
