//! Test-only helpers shared by the unit tests of every module: where the shared scenes are, and
//! (`scenes`) hand-made scene builders and CPU-cast view samples.
use std::path::{Path, PathBuf};

/// Where the shared scenes are: `$MANYLIGHTS_SHARED`, then `<manifest>/../shared` (CI: `shared/` beside
/// the checkout); the folder must contain `scenes/`.
pub fn shared_dir() -> PathBuf {
    let candidates = [
        std::env::var("MANYLIGHTS_SHARED").ok().map(PathBuf::from),
        Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared")),
    ];
    candidates
        .into_iter()
        .flatten()
        .find(|d| d.join("scenes").is_dir())
        .expect("shared scenes not found: set MANYLIGHTS_SHARED to the folder holding scenes/")
}

pub mod scenes;

/// Monte Carlo mean and standard error (per channel) of `m` sample weights; `None` is a zero weight.
pub fn mean_and_std_err(m: usize, mut weight: impl FnMut() -> Option<glam::DVec3>) -> (glam::DVec3, glam::DVec3) {
    let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for _ in 0..m {
        if let Some(w) = weight() {
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / m as f64;
    let err = ((sum2 / m as f64 - mean * mean) / m as f64).max(glam::DVec3::ZERO).powf(0.5);
    (mean, err)
}
