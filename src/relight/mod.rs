//! Direct-to-indirect transfer (Hašan, Pellacini, Bala, "Direct-to-Indirect Transfer for Cinematic
//! Relighting", SIGGRAPH 2006): the gather cloud's cluster hierarchy and gather image (`hierarchy`) and
//! the 2D Haar wavelets with the paper's coefficient culling (`haar`). The gather cloud itself is
//! `crate::lights::gather` (shared with tensor clustering).
pub mod haar;
pub mod hierarchy;

pub use haar::SparseRow;
pub use hierarchy::{ClusterHierarchy, DEFAULT_K};
