//! The geometry term of direct-to-indirect transfer (Hašan, Pellacini, Bala 2006, Sec. 3.2, 4.3): F_d(i, g) / A_g
//! of a gather sample seen from a view sample, as a point or as a patch (the point-to-disc form factor), its
//! visibility, and the tangent-plane cull of the hierarchical gather (module docs of `transfer`).
use crate::cpu::ShadingPoint;
use crate::raytrace::RayTracer;
use glam::Vec3;

/// F_d(i, g) / A_g for a view sample (`sp`, its BSDF flags) and an emitter at `q` with normals
/// (`n_s`, `n_g`): the clamped geometry term times visibility (module docs); the bool says whether a
/// shadow ray was cast.
#[inline]
pub fn geometry(tracer: &RayTracer, sp: &ShadingPoint, twosided: bool, q: Vec3, n_s: Vec3, n_g: Vec3, clamp: f32) -> (f32, bool) {
    geometry_patch(tracer, sp, twosided, q, n_s, n_g, clamp, 0.0, None)
}

/// `geometry` for an emitter that is a patch of area `area` (m^2) rather than a point, in the near field:
/// G = cos_g cos_i / (d^2 + area / pi), the point-to-disc form factor of a disc of that area facing the
/// receiver (Wallace, Elmquist, Haines, "A Ray Tracing Algorithm for Progressive Radiosity", 1989), so
/// A G <= pi cos_g cos_i stays bounded where the point's 1/d^2 spikes; the same as the point form beyond
/// a few patch sizes (relative change area / (pi d^2)). `area` = 0 is `geometry`. `masks`: None, V is one
/// exact shadow ray (`RayTracer::occluded`); Some(j) in a scene with masked surfaces, V is the
/// transmittance prod(1 - a) through at most j of them (`RayTracer::mask_transmittance`; module docs).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn geometry_patch(
    tracer: &RayTracer,
    sp: &ShadingPoint,
    twosided: bool,
    q: Vec3,
    n_s: Vec3,
    n_g: Vec3,
    clamp: f32,
    area: f32,
    masks: Option<u32>,
) -> (f32, bool) {
    if !sp.surface {
        return (0.0, false);
    }
    let d = q - sp.p;
    let dist2 = d.length_squared();
    if dist2.is_nan() || dist2 <= 0.0 {
        return (0.0, false);
    }
    let wo = d / dist2.sqrt();
    let (mut cos_v, mut cos_i) = (sp.wi_local.z, wo.dot(sp.n));
    if twosided && cos_v < 0.0 {
        (cos_v, cos_i) = (-cos_v, -cos_i);
    }
    let cos_g = -wo.dot(n_g);
    if !(cos_v > 0.0 && cos_i > 0.0 && cos_g > 0.0 && -wo.dot(n_s) > 0.0) {
        return (0.0, false);
    }
    let g = (cos_g * cos_i / (dist2 + area * std::f32::consts::FRAC_1_PI)).min(clamp);
    match masks {
        Some(budget) => (g * tracer.mask_transmittance(sp.p, sp.n_g, Some(q), wo, budget), true),
        None if tracer.occluded(sp.p, sp.n_g, q) => (0.0, true),
        None => (g, true),
    }
}

/// Whether the box [lo, hi] lies wholly behind the plane through `p` with normal `side_n` (its corner
/// farthest along `side_n` is not in front): the hierarchical gather culls such clusters (4.3).
#[inline]
pub(crate) fn behind_tangent_plane(lo: Vec3, hi: Vec3, p: Vec3, side_n: Vec3) -> bool {
    let far = Vec3::new(
        if side_n.x >= 0.0 { hi.x } else { lo.x },
        if side_n.y >= 0.0 { hi.y } else { lo.y },
        if side_n.z >= 0.0 { hi.z } else { lo.z },
    );
    (far - p).dot(side_n) <= 0.0
}
