//! Animations: one [`Scene`] per frame with the same topology (Hašan, Velázquez-Armendáriz, Pellacini,
//! Bala, "Tensor Clustering for Rendering Many-Light Animations", EGSR 2008, Sec. 4.2: the tensor A is
//! m x n x f, so every frame must have the same pixels, the same lights and the same surfaces).
//!
//! Frames come from one Mitsuba XML loaded with different `<default>` parameters (as
//! `mitsuba.load_file(path, **params)` animates) or from one file per frame. Between frames the camera,
//! transforms, light positions and mesh vertices may change; what may not (checked by
//! [`check_topology`], each error naming the frame, the shape or emitter and its file and line):
//! - the film size (the m pixels),
//! - the number of shapes and, per shape, its id, its kind (analytic sphere or triangle mesh), its
//!   triangle count, its vertex count and its connectivity (the triangles' vertex indices): lights tied
//!   to a surface point (shape, triangle, barycentrics) must denote the same point in every frame,
//! - the number of emitters and each emitter's type (light j of frame k is "the same" light in every
//!   frame).
use crate::error::{Error, Location, Result};
use crate::scene::{Emitter, Scene, ShapeKind};

/// Emitter type name as in the XML (`point`, `spot`, ...).
pub fn emitter_type(e: &Emitter) -> &'static str {
    match e {
        Emitter::Point { .. } => "point",
        Emitter::Spot { .. } => "spot",
        Emitter::Directional { .. } => "directional",
        Emitter::Area { .. } => "area",
        Emitter::EnvMap { .. } => "envmap",
        Emitter::Constant { .. } => "constant",
    }
}

fn shape_kind(k: &ShapeKind) -> &'static str {
    match k {
        ShapeKind::Sphere { .. } => "sphere",
        _ => "mesh",
    }
}

/// Checks that every frame has frame 0's topology (module docs). `frames[k]` is frame k.
///
/// Errors: `Error::InvalidParameter` for no frames or a different film size, `Error::Scene` (located at
/// the shape or emitter in frame k's file) for a different shape or emitter structure.
pub fn check_topology(frames: &[&Scene]) -> Result<()> {
    let first = *frames.first().ok_or_else(|| Error::invalid("an animation needs at least one frame, got 0"))?;
    let (w0, h0) = (first.camera.width, first.camera.height);
    for (k, s) in frames.iter().enumerate().skip(1) {
        let (w, h) = (s.camera.width, s.camera.height);
        if (w, h) != (w0, h0) {
            return Err(Error::invalid(format!(
                "frame {k} ({}): film is {w}x{h} but frame 0's is {w0}x{h0} (every frame needs the same size; pass size=(W, H))",
                s.path.display()
            )));
        }
        if s.meshes.len() != first.meshes.len() {
            return Err(Error::scene(
                &Location::new(&s.path, 0),
                format!(
                    "frame {k}: the scene has {} shapes but frame 0 has {} (shapes may move or deform, not appear or vanish)",
                    s.meshes.len(),
                    first.meshes.len()
                ),
            ));
        }
        for (i, (a, b)) in first.meshes.iter().zip(&s.meshes).enumerate() {
            let what = format!("frame {k}: shape {i} '{}'", b.id);
            if a.id != b.id {
                return Err(Error::scene(&b.loc, format!("{what} is shape '{}' in frame 0 (shapes must keep their order and ids)", a.id)));
            }
            if shape_kind(&a.kind) != shape_kind(&b.kind) {
                return Err(Error::scene(&b.loc, format!("{what} is a {} but a {} in frame 0", shape_kind(&b.kind), shape_kind(&a.kind))));
            }
            if a.indices.len() != b.indices.len() {
                return Err(Error::scene(
                    &b.loc,
                    format!(
                        "{what} has {} triangles but {} in frame 0 (meshes may deform, not change topology)",
                        b.indices.len(),
                        a.indices.len()
                    ),
                ));
            }
            if a.positions.len() != b.positions.len() {
                return Err(Error::scene(
                    &b.loc,
                    format!(
                        "{what} has {} vertices but {} in frame 0 (meshes may deform, not change topology)",
                        b.positions.len(),
                        a.positions.len()
                    ),
                ));
            }
            if let Some(t) = a.indices.iter().zip(&b.indices).position(|(x, y)| x != y) {
                return Err(Error::scene(
                    &b.loc,
                    format!(
                        "{what}: triangle {t} has vertices {:?} but {:?} in frame 0 (same triangle count, different connectivity)",
                        b.indices[t], a.indices[t]
                    ),
                ));
            }
        }
        if s.emitters.len() != first.emitters.len() {
            return Err(Error::scene(
                &Location::new(&s.path, 0),
                format!("frame {k}: the scene has {} emitters but frame 0 has {}", s.emitters.len(), first.emitters.len()),
            ));
        }
        for (e, (a, b)) in first.emitters.iter().zip(&s.emitters).enumerate() {
            if emitter_type(a) != emitter_type(b) {
                return Err(Error::scene(
                    emitter_loc(b),
                    format!("frame {k}: emitter {e} is a '{}' but a '{}' in frame 0", emitter_type(b), emitter_type(a)),
                ));
            }
        }
    }
    Ok(())
}

fn emitter_loc(e: &Emitter) -> &Location {
    match e {
        Emitter::Point { loc, .. }
        | Emitter::Spot { loc, .. }
        | Emitter::Directional { loc, .. }
        | Emitter::Area { loc, .. }
        | Emitter::EnvMap { loc, .. }
        | Emitter::Constant { loc, .. } => loc,
    }
}

#[cfg(test)]
mod tests;
