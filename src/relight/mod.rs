//! Direct-to-indirect transfer (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic
//! Relighting", SIGGRAPH 2006): the gather cloud's cluster hierarchy and gather image (`hierarchy`),
//! the 2D Haar wavelets with the paper's coefficient culling (`haar`), the diffuse final-gather transfer
//! F_d (`transfer`), the glossy final gather F_g (`glossy`), the photon-mapped multi-bounce matrix M
//! (`multibounce`) and relighting on the CPU (`relight`). The gather cloud itself is
//! `crate::lights::gather` (shared with tensor clustering).
pub mod glossy;
pub mod haar;
pub mod hierarchy;
pub mod multibounce;
#[allow(clippy::module_inception)]
pub mod relight;
pub mod transfer;

pub use haar::SparseRow;
pub use hierarchy::{ClusterHierarchy, DEFAULT_K};
pub use multibounce::Multibounce;
pub use transfer::{Transfer, TransferOptions};
