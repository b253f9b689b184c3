//! Which hemisphere of the shading frame a BSDF can reflect light from, read from its records alone:
//! what lets a receiver skip a light before the light's emission is evaluated (`cpu::shade_unshadowed`).
//! Exact by construction: the rule is `bsdf::eval`'s own test (`cos_i > 0 && cos_o > 0` after
//! `twosided`'s flip).
use super::bsdf::{FLAG_BLEND, FLAG_BUMP, FLAG_TWOSIDED, FLAG_TWOSIDED_OUTER, KIND_PRINCIPLED, KIND_ROUGHDIELECTRIC};
use super::GpuBsdf;
use glam::Vec3;

/// The side of the shading frame's tangent plane that `wo` must lie on for `eval_records(records, i, wi, wo)`
/// to be non-zero, read from the records alone: `Some(1.0)` where it needs `wo.z > 0`, `Some(-1.0)`
/// where `wo.z < 0` (a `twosided` BSDF seen from its back), `Some(0.0)` where it is 0 for every `wo`
/// (seen from the back of a one-sided BSDF), `None` where no such rule holds (transmission through
/// `roughdielectric` and `principled`, perturbed normals). Exact: `eval` returns 0 for those `wo` by
/// the same comparison, so a caller may skip them unevaluated (`cpu::shade_unshadowed`).
pub fn reflecting_side(records: &[GpuBsdf], i: usize, wi: Vec3) -> Option<f32> {
    let side = |b: &GpuBsdf| -> Option<f32> {
        if b.flags & (FLAG_BUMP | FLAG_TWOSIDED_OUTER) != 0 || b.kind == KIND_PRINCIPLED || b.kind == KIND_ROUGHDIELECTRIC {
            return None;
        }
        // `eval`'s flip and its test `cos_i > 0 && cos_o > 0`.
        let flip = b.flags & FLAG_TWOSIDED != 0 && wi.z < 0.0;
        let cos_i = if flip { -wi.z } else { wi.z };
        Some(if !(cos_i > 0.0) {
            0.0
        } else if flip {
            -1.0
        } else {
            1.0
        })
    };
    let b = &records[i];
    let s0 = side(b)?;
    if b.flags & FLAG_BLEND == 0 {
        return Some(s0);
    }
    // A blend is 0 where both of its BSDFs are (a missing second one is 0 everywhere).
    let s1 = records.get(b.extra[3].to_bits() as usize).map_or(Some(0.0), side)?;
    match (s0, s1) {
        (a, b) if a == b => Some(a),
        (0.0, b) => Some(b),
        (a, 0.0) => Some(a),
        _ => None,
    }
}

#[cfg(test)]
mod tests;
