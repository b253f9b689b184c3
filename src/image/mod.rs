//! Image files and image comparisons: EXR/PNG reading and writing (`io`) and error metrics (`metrics`).
//!
//! Images are row-major `[f32; 3]` linear RGB with row 0 at the top, `width * height` pixels.
pub mod io;
pub mod metrics;

pub use io::{read_exr, write_exr, write_png};
pub use metrics::{fraction_within, mae, max_abs_error, mse, relative_l2, relative_mse, rmse};
