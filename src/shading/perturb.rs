//! Perturbed shading frames of Mitsuba 3.9.1's `bumpmap` and `normalmap` (`src/bsdfs/bumpmap.cpp`,
//! `src/bsdfs/normalmap.cpp`, `src/bsdfs/normalmap_helpers.h`): the Rust reference, twin of
//! `bsdf_perturbed_eval` in `shaders/common/bsdf.wgsl`.
//!
//! Geometry (per surface point, [`world_normal`]): Mitsuba's `dp_du`, `dp_dv` ([`tangents`]: from the
//! triangle's uvs, `p1 - p0` / `p2 - p0` without uvs, `coordinate_system(n_g)` for a degenerate uv
//! triangle; a sphere's analytic ones) and
//! - bumpmap: `g = scale * eval_1_grad(height, uv)` (`scene::texture::eval_1_grad`),
//!   `dp_du' = dp_du + n_s (g.x - n_s . dp_du)`, `dp_dv' = dp_dv + n_s (g.y - n_s . dp_dv)`,
//!   `n' = normalize(dp_du' x dp_dv')`, negated when `n' . n_g < 0`;
//! - normalmap: `n' = normalize(2 c - 1)` of the bilinear RGB texel `c`, in Mitsuba's shading frame
//!   (s = `dp_du` made orthogonal to `n_s`, t = n_s x s).
//!
//! The BSDF record ([`GpuBsdf`], resolved from the nested BSDF) carries `n'` in the local frame of the
//! unperturbed shading normal (`coordinate_system(n_s)`) with `FLAG_BUMP`; evaluation ([`eval`]) does
//! what Mitsuba's wrappers do with local `wi`, `wo` (z = n_s):
//! 1. `flip_invalid_normals`: when `wi.z * (wi . n') <= 0`, `n' = (-n'.x, -n'.y, n'.z)`;
//! 2. 0 unless `wo.z * (wo . n') > 0`;
//! 3. the nested BSDF at `wi`, `wo` in the frame `coordinate_system(n')`;
//! 4. times the shadowing term of Estevez et al. 2019, `2 / (1 + sqrt(1 + a2 tan^2(wo)))` with
//!    `a2 = min(tan^2(n') / 8, 1)` (`use_shadowing_function`).
//!
//! A `twosided` around the wrapper (`FLAG_TWOSIDED_OUTER`) flips `wi.z`, `wo.z` first (as Mitsuba's
//! `twosided` does before calling the wrapper); a `twosided` inside it keeps `FLAG_TWOSIDED` and flips
//! in the perturbed frame. Sampling ([`sample`], [`pdf`]) wraps the nested sampler the same way.
//!
//! Where `n'` is kept (fields the kind never reads): `k` for plastics, `extra[1..4]` for the others
//! (blends are refused inside wrappers on load).
//!
//! Deviations: the perturbed frame's tangent is `coordinate_system(n')`, not Mitsuba's (from `dp_du`), so
//! an anisotropic nested BSDF may differ by a rotation about `n'` (as everywhere in this crate); disks and
//! cylinders are tessellated here, so their `dp_du`, `dp_dv` come from the tessellation's uvs.
use super::bsdf::{eval as eval_record, FLAG_BUMP, FLAG_TWOSIDED_OUTER, KIND_PLASTIC, KIND_ROUGHPLASTIC};
use super::GpuBsdf;
use crate::lights::coordinate_system;
use crate::lights::generate::sampling::{pdf_bsdf, sample_bsdf, BsdfSample};
use crate::scene::{Bsdf, Mesh, Scene, ShapeKind};
use glam::{Vec2, Vec3};

/// The perturbed normal `n'` kept in record `b` (local frame of the unperturbed shading normal).
pub fn normal(b: &GpuBsdf) -> Vec3 {
    if b.kind == KIND_PLASTIC || b.kind == KIND_ROUGHPLASTIC {
        Vec3::from_array(b.k)
    } else {
        Vec3::new(b.extra[1], b.extra[2], b.extra[3])
    }
}

/// Stores the perturbed normal `n` (unit, local frame of the unperturbed shading normal) in `b` and
/// sets `FLAG_BUMP`.
pub fn set_normal(b: &mut GpuBsdf, n: Vec3) {
    if b.kind == KIND_PLASTIC || b.kind == KIND_ROUGHPLASTIC {
        b.k = n.to_array();
    } else {
        b.extra[1..4].copy_from_slice(&n.to_array());
    }
    b.flags |= FLAG_BUMP;
}

/// Mitsuba's `Frame3f::tan_theta_2`.
fn tan_theta_2(v: Vec3) -> f32 {
    let c2 = v.z * v.z;
    (1.0 - c2).max(0.0) / c2
}

/// Mitsuba's `eval_shadow_terminator(n', wo)` (Estevez et al. 2019), both local to the unperturbed frame.
pub fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan_theta_2(n)).min(1.0);
    2.0 / (1.0 + (1.0 + alpha2 * tan_theta_2(wo)).sqrt())
}

/// `flip_invalid_normals`: `n'` mirrored about the unperturbed normal when `wi` sees it from the other side.
fn flipped(n: Vec3, wi: Vec3) -> Vec3 {
    if wi.z * wi.dot(n) <= 0.0 {
        Vec3::new(-n.x, -n.y, n.z)
    } else {
        n
    }
}

fn local(n: Vec3, v: Vec3) -> Vec3 {
    let (s, t) = coordinate_system(n);
    Vec3::new(v.dot(s), v.dot(t), v.dot(n))
}

fn world(n: Vec3, v: Vec3) -> Vec3 {
    let (s, t) = coordinate_system(n);
    s * v.x + t * v.y + n * v.z
}

/// The record without its wrapper flags, `wi`, `wo` after an outer `twosided` flip, and whether that
/// flip happened.
fn unwrap(b: &GpuBsdf, mut wi: Vec3, mut wo: Vec3) -> (GpuBsdf, Vec3, Vec3, bool) {
    let flip = b.flags & FLAG_TWOSIDED_OUTER != 0 && wi.z < 0.0;
    if flip {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    let mut inner = *b;
    inner.flags &= !(FLAG_BUMP | FLAG_TWOSIDED_OUTER);
    (inner, wi, wo, flip)
}

/// `bsdf::eval` of a record with `FLAG_BUMP` or `FLAG_TWOSIDED_OUTER` (module docs).
pub fn eval(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> Vec3 {
    let (inner, wi, wo, _) = unwrap(b, wi, wo);
    if b.flags & FLAG_BUMP == 0 {
        return eval_record(&inner, wi, wo);
    }
    let n = flipped(normal(b), wi);
    if !(wo.z * wo.dot(n) > 0.0) {
        return Vec3::ZERO;
    }
    eval_record(&inner, local(n, wi), local(n, wo)) * shadow_terminator(n, wo)
}

/// A VPL's BSDF (particle tracing's adjoint direction): light arrives along local `incident` and leaves
/// toward `out`. Mitsuba's path tracer evaluates the wrappers with `wi = out`, `wo = incident`, which for
/// them is not `eval(incident, out)`; returned in the convention of `eval(incident, out)` (f |out.z|,
/// which callers correct with their shading-normal factors): `eval(out, incident) |out.z| / |incident.z|`.
/// Records without a perturbation: `bsdf::eval(incident, out)` (their BSDFs are reciprocal).
pub fn adjoint_eval(b: &GpuBsdf, incident: Vec3, out: Vec3) -> Vec3 {
    if b.flags & FLAG_BUMP == 0 {
        return eval_record(b, incident, out);
    }
    if incident.z == 0.0 {
        return Vec3::ZERO;
    }
    eval(b, out, incident) * (out.z.abs() / incident.z.abs())
}

/// `sampling::sample_bsdf` of a record with `FLAG_BUMP` or `FLAG_TWOSIDED_OUTER`: the nested BSDF
/// sampled in the perturbed frame, refused when the direction changes side between the frames, the
/// weight times the shadowing term (Mitsuba's `sample` of the wrappers).
pub fn sample(b: &GpuBsdf, wi: Vec3, rng: &mut rand_pcg::Pcg32) -> Option<BsdfSample> {
    let (inner, wi, _, flip) = unwrap(b, wi, Vec3::Z);
    let mut s = if b.flags & FLAG_BUMP == 0 {
        sample_bsdf(&inner, wi, rng)?
    } else {
        let n = flipped(normal(b), wi);
        let mut s = sample_bsdf(&inner, local(n, wi), rng)?;
        let wo = world(n, s.wo);
        if !(s.wo.z * wo.z > 0.0) {
            return None;
        }
        s.weight *= shadow_terminator(n, wo);
        s.wo = wo;
        s
    };
    if flip {
        s.wo.z = -s.wo.z;
    }
    Some(s)
}

/// `sampling::pdf_bsdf` of a record with `FLAG_BUMP` or `FLAG_TWOSIDED_OUTER`.
pub fn pdf(b: &GpuBsdf, wi: Vec3, wo: Vec3) -> f32 {
    let (inner, wi, wo, _) = unwrap(b, wi, wo);
    if b.flags & FLAG_BUMP == 0 {
        return pdf_bsdf(&inner, wi, wo);
    }
    let n = flipped(normal(b), wi);
    if !(wo.z * wo.dot(n) > 0.0) {
        return 0.0;
    }
    pdf_bsdf(&inner, local(n, wi), local(n, wo))
}

/// Mitsuba's `dp_du`, `dp_dv` at a point of triangle `prim` of `mesh` (or of its sphere, at `p`), world
/// space (module docs).
pub fn tangents(mesh: &Mesh, prim: usize, p: Vec3, n_g: Vec3) -> (Vec3, Vec3) {
    use std::f32::consts::PI;
    if let ShapeKind::Sphere { center, radius, .. } = mesh.kind {
        // sphere.cpp: local point on the unit sphere (the local frame is the world's here).
        let l = ((p - center) / radius).normalize_or_zero();
        let dp_du = Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI * radius);
        let rd = (l.x * l.x + l.y * l.y).sqrt();
        let dp_dv = if rd == 0.0 { Vec3::X } else { Vec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd) };
        return (dp_du, dp_dv * (PI * radius));
    }
    let Some(tri) = mesh.indices.get(prim) else { return coordinate_system(n_g) };
    let v = |k: usize| mesh.positions[tri[k] as usize];
    let (dp0, dp1) = (v(1) - v(0), v(2) - v(0));
    if mesh.uvs.is_empty() {
        return (dp0, dp1);
    }
    let t = |k: usize| mesh.uvs[tri[k] as usize];
    let (duv0, duv1): (Vec2, Vec2) = (t(1) - t(0), t(2) - t(0));
    let det = duv0.x.mul_add(duv1.y, -(duv0.y * duv1.x));
    if det == 0.0 {
        return coordinate_system(n_g);
    }
    let inv = 1.0 / det;
    ((dp0 * duv1.y - dp1 * duv0.y) * inv, (dp1 * duv0.x - dp0 * duv1.x) * inv)
}

/// The bumpmap or normalmap wrapping mesh `m`'s BSDF (directly or inside a `twosided`), if any.
pub fn wrapper(scene: &Scene, m: usize) -> Option<&Bsdf> {
    let i = scene.meshes.get(m)?.bsdf;
    let b = match scene.bsdfs.get(i)? {
        Bsdf::TwoSided { front, .. } => scene.bsdfs.get(*front)?,
        b => b,
    };
    matches!(b, Bsdf::BumpMap { .. } | Bsdf::NormalMap { .. }).then_some(b)
}

/// The perturbed shading normal `n'` (world space, unit, before `flip_invalid_normals`) at a point of
/// mesh `m` (triangle `prim`, position `p`, geometric normal `n_g`, shading normal `n_s`, uv), or `None`
/// when its BSDF has no bumpmap / normalmap (module docs).
pub fn world_normal(scene: &Scene, m: usize, prim: usize, p: Vec3, n_g: Vec3, n_s: Vec3, uv: Vec2) -> Option<Vec3> {
    let mesh = &scene.meshes[m];
    let (dp_du, dp_dv) = tangents(mesh, prim, p, n_g);
    match wrapper(scene, m)? {
        Bsdf::BumpMap { texture, scale, .. } => {
            let g = crate::scene::texture::eval_1_grad(&scene.textures[*texture], uv) * *scale;
            let du = n_s * (g.x - n_s.dot(dp_du)) + dp_du;
            let dv = n_s * (g.y - n_s.dot(dp_dv)) + dp_dv;
            let n = du.cross(dv).normalize();
            Some(if n_g.dot(n) < 0.0 { -n } else { n })
        }
        Bsdf::NormalMap { texture, .. } => {
            let c = crate::scene::texture::eval(&scene.textures[*texture], uv) * 2.0 - Vec3::ONE;
            // Mitsuba's shading frame (`initialize_sh_frame`): s from dp_du, t = n x s.
            let s = if dp_du == Vec3::ZERO { coordinate_system(n_s).0 } else { (dp_du - n_s * n_s.dot(dp_du)).normalize() };
            let t = n_s.cross(s);
            Some((s * c.x + t * c.y + n_s * c.z).normalize())
        }
        _ => None,
    }
}

/// Puts the perturbation of mesh `m`'s BSDF at a surface point into its resolved `records` (module
/// docs; nothing when the BSDF has no bumpmap / normalmap). Arguments as [`world_normal`].
#[allow(clippy::too_many_arguments)]
pub fn apply(scene: &Scene, m: usize, prim: usize, p: Vec3, n_g: Vec3, n_s: Vec3, uv: Vec2, records: &mut [&mut GpuBsdf]) {
    let Some(n) = world_normal(scene, m, prim, p, n_g, n_s, uv) else { return };
    let (s, t) = coordinate_system(n_s);
    let mut l = Vec3::new(n.dot(s), n.dot(t), n.dot(n_s));
    if !l.is_finite() {
        // Degenerate tangents (dp_du' parallel to dp_dv'): no perturbed frame; the unperturbed one is kept.
        l = Vec3::Z;
    }
    for r in records.iter_mut() {
        set_normal(r, l);
    }
}

#[cfg(test)]
mod tests;
