//! Where this crate's shading frame differs from Mitsuba 3.9.1's, for the BSDFs whose value depends on it.
//!
//! Every receiver here is shaded in `coordinate_system(n)` (`cpu::ShadingPoint`, the GPU passes, the probes'
//! path tracer). Mitsuba shades in `initialize_sh_frame`'s frame: s = `dp_du` made orthogonal to n, t = n x s,
//! with `dp_du` from the shape's parametrization (`perturb::tangents`: a triangle's uvs, its edges without
//! uvs, a sphere's azimuth). The two frames share n and may differ by a rotation about it. An isotropic BSDF
//! does not see the rotation; an anisotropic one (`roughconductor` or `roughdielectric` with `alpha_u` !=
//! `alpha_v`, `principled` with `anisotropic` > 0) does: its highlight turns. `anisotropic_frame_differs`
//! finds the shapes where that happens, so that results name it as a bias source instead of claiming a
//! target (`manylights.renderers.bias`).
//!
//! | symbol | meaning |
//! |---|---|
//! | n | the shading normal (the face normal at a triangle's centroid here) |
//! | s, t | the frame's tangents: Mitsuba's from `dp_du`, ours from `coordinate_system(n)` |
use super::perturb::tangents;
use crate::lights::coordinate_system;
use crate::scene::{Bsdf, Param, Scene, ShapeKind};
use glam::Vec3;

/// Frames whose first tangents agree to within this cosine (up to sign) count as the same.
const SAME_FRAME: f32 = 0.9999;

/// Whether BSDF `index` of `scene` (through `twosided`, `blendbsdf`, `bumpmap`, `normalmap` and `mask`)
/// has a lobe whose value depends on the rotation of the frame about n.
pub fn anisotropic(scene: &Scene, index: usize) -> bool {
    fn walk(scene: &Scene, i: usize, depth: u32) -> bool {
        if depth > 16 {
            return false;
        }
        let differ = |u: &Param, v: &Param| u != v;
        match scene.bsdfs.get(i) {
            Some(Bsdf::RoughConductor { alpha_u, alpha_v, .. }) | Some(Bsdf::RoughDielectric { alpha_u, alpha_v, .. }) => {
                differ(alpha_u, alpha_v)
            }
            Some(Bsdf::Principled(p)) => match &p.anisotropic {
                Param::Value(v) => v.max_element() > 0.0,
                Param::Texture(_) => true,
            },
            Some(Bsdf::TwoSided { front, back }) => walk(scene, *front, depth + 1) || walk(scene, *back, depth + 1),
            Some(Bsdf::Blend { first, second, .. }) => walk(scene, *first, depth + 1) || walk(scene, *second, depth + 1),
            Some(Bsdf::BumpMap { nested, .. }) | Some(Bsdf::NormalMap { nested, .. }) | Some(Bsdf::Mask { nested, .. }) => {
                walk(scene, *nested, depth + 1)
            }
            _ => false,
        }
    }
    walk(scene, index, 0)
}

/// Whether mesh `m` of `scene` has an anisotropic BSDF (`anisotropic`) and Mitsuba's frame differs from
/// this crate's somewhere on it (module docs): at some triangle's centroid the two first tangents are more
/// than `SAME_FRAME` apart, up to sign. Disks and cylinders are tessellated here with their own uvs, not Mitsuba's
/// analytic parametrization, so an anisotropic BSDF on one always counts.
pub fn anisotropic_frame_differs(scene: &Scene, m: usize) -> bool {
    let Some(mesh) = scene.meshes.get(m) else { return false };
    if !anisotropic(scene, mesh.bsdf) {
        return false;
    }
    if matches!(mesh.kind, ShapeKind::Disk | ShapeKind::Cylinder) {
        return true;
    }
    mesh.indices.iter().enumerate().any(|(prim, tri)| {
        let v = |k: usize| mesh.positions[tri[k] as usize];
        let n_g = (v(1) - v(0)).cross(v(2) - v(0)).normalize_or_zero();
        if n_g == Vec3::ZERO {
            return false;
        }
        let centroid = (v(0) + v(1) + v(2)) / 3.0;
        let n = match mesh.kind {
            ShapeKind::Sphere { center, .. } => (centroid - center).normalize_or_zero(),
            _ => n_g,
        };
        let (dp_du, _) = tangents(mesh, prim, centroid, n_g);
        let ours = coordinate_system(n).0;
        let s = dp_du - n * n.dot(dp_du);
        let s = if s.length_squared() > 0.0 { s.normalize() } else { ours };
        // The lobes depend on (h . s)^2 and (h . t)^2 alone: a half turn (s -> -s) is the same frame.
        s.dot(ours).abs() < SAME_FRAME
    })
}

#[cfg(test)]
mod tests;
