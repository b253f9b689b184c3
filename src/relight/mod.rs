//! Direct-to-indirect transfer (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic
//! Relighting", SIGGRAPH 2006): the gather cloud's cluster hierarchy and gather image (`hierarchy`),
//! the 2D Haar wavelets with the paper's coefficient culling (`haar`), the diffuse final-gather transfer
//! F_d (`transfer`) and relighting on the CPU (`relight`) or the GPU (`gpu`). The gather cloud itself is
//! `crate::lights::gather` (shared with tensor clustering).
pub mod gpu;
pub mod haar;
pub mod hierarchy;
#[allow(clippy::module_inception)]
pub mod relight;
pub mod transfer;

pub use haar::SparseRow;
pub use hierarchy::{ClusterHierarchy, DEFAULT_K};
pub use transfer::{Transfer, TransferOptions};
