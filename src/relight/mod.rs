//! Direct-to-indirect transfer (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic
//! Relighting", SIGGRAPH 2006): the gather cloud's cluster hierarchy and gather image (`hierarchy`),
//! the 2D Haar wavelets with the paper's coefficient culling (`haar`), the diffuse final-gather transfer
//! F_d (`transfer`), the glossy final gather F_g (`glossy`), the photon-mapped multi-bounce matrix M
//! (`multibounce`) and relighting on the CPU (`relight`) or the GPU (`gpu`). The gather cloud itself is
//! `crate::lights::gather` (shared with tensor clustering).
//!
//! The paper's symbols (its Table 1) in the code (`Transfer` fields unless named otherwise; n_v = pixels
//! of the camera's film, n_g = gather samples):
//! | paper | here | type, size | meaning |
//! |---|---|---|---|
//! | v_i | `relight::indirect` output | RGB, n_v | indirect radiance of the pixels (W/m^2/sr) |
//! | g_d | B_1 = k_d(g) / pi E_g (`relight::gather_irradiance`) | RGB, n_g | direct diffuse radiance of the gather samples |
//! | k_d | `ViewSamples::albedo` | RGB, n_v | diffuse coefficients (the Lambertian BRDF k_d / pi) |
//! | k_g | `glossy_color` | RGB, n_v | glossy coefficients: the glossy lobe's colour at its peak, unit mean (`glossy`) |
//! | F_d^w | `rows`, `image_norms` | scalar, n_v x n_g | diffuse final gather A_g min(G, clamp) V, Haar-culled (`transfer`) |
//! | F_g^w | `glossy_rows`, `glossy_image_norms` | scalar, n_v x n_g | glossy final gather, the viewer's glossy BRDF baked in (`glossy`) |
//! | M^w | `photon_rows` (photons) | RGB, n_g x n_g | multi-bounce irradiance transfer M_E; M = diag(k_d / pi) M_E (`multibounce`) |
//! | M (alternative) | `bounce_rows` (gather) | scalar, n_g x n_g | one-bounce gather-to-gather F_gg; M = K + ... + K^(b-1), K = diag(k_d / pi) F_gg |
//! | W | `haar::forward` on the gather image (`hierarchy`) | n_g x n_g | orthonormal 2D Haar projection |
pub mod diffuse;
mod form_factor;
pub mod glossy;
pub mod gpu;
pub mod haar;
pub mod hierarchy;
pub mod masks;
pub mod multibounce;
#[allow(clippy::module_inception)]
pub mod relight;
pub mod store;
pub mod transfer;

pub use haar::SparseRow;
pub use hierarchy::{ClusterHierarchy, DEFAULT_K};
pub use multibounce::Multibounce;
pub use transfer::{Transfer, TransferOptions};
