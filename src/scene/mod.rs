//! Scenes read from Mitsuba 3 XML: meshes in world space, BSDFs, textures, emitters and the camera.
//!
//! `types` is the data model every other module reads; `xml` parses files into it; `mesh` loads OBJ/PLY
//! and builds the built-in shapes; `texture` loads bitmaps and evaluates textures as Mitsuba does;
//! `transform` parses `<transform>` children. Conventions: `docs/development/mitsuba-conventions.md`.
pub mod animation;
pub mod mesh;
pub mod principled;
pub mod texture;
pub mod transform;
pub mod types;
pub mod xml;

pub use types::*;
pub use xml::{load_scene, LoadOptions, MediaPolicy};
