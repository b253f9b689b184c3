//! What light j sends to a receiver point p: the direction toward it (`LightSet::toward`), its radiance
//! factor F (`LightSet::emitted`, `emitted_toward`; the `lights` module docs define F per kind) and what the
//! receiver's BSDF makes of it (`LightSet::shade_receiver`). CPU twin of `light_emitted` and `light_shade`
//! in `shaders/common/light.wgsl`.
//!
//! | here | meaning |
//! |---|---|
//! | `p`, `n` | receiver position and shading normal |
//! | `wo`, `dist2`, `dist` | unit direction from p toward the light's point, its squared distance, distance |
//! | `radiance` | the radiance factor F |
use super::{coordinate_system, patch, spot_falloff, vsl, LightKind, LightSet};
use glam::Vec3;

impl LightSet {
    /// What a receiver at `p` reflects from light j, given what `emitted(j, p, n)` returned (`wo`,
    /// `radiance`) and `receiver(w)` = its `bsdf_eval` toward world direction w (f_r |w . n|):
    /// `receiver(wo) * radiance`, except for a virtual spherical light, whose cap is integrated against
    /// the receiver's lobe (`vsl::cap_shade`). Every shading site uses it (CPU twin of `light_shade`).
    #[inline]
    pub fn shade_receiver(&self, j: usize, p: Vec3, wo: Vec3, radiance: Vec3, receiver: impl Fn(Vec3) -> Vec3) -> Vec3 {
        if self.vsl_radius[j] > 0.0 {
            vsl::cap_shade(self, j, p, wo, receiver)
        } else {
            receiver(wo) * radiance
        }
    }

    /// What light j sends to point p whose shading normal is `n` (used only by the VPL clamp):
    /// (wo, unit direction from p toward the light; radiance factor F (module docs); distance to the
    /// light, infinite for directional). `None` when it sends nothing (outside a spot cone, behind an
    /// oriented point or VPL, or p at the light's position). `toward` then `emitted_toward`.
    #[inline]
    pub fn emitted(&self, j: usize, p: Vec3, n: Vec3) -> Option<(Vec3, Vec3, f32)> {
        self.emitted_toward(j, p, n, self.toward(j, p)?)
    }

    /// The direction `emitted` returns, before any of the light's emission is evaluated: (wo, unit
    /// direction from p toward the light's point; squared distance; distance), both infinite for a
    /// directional light. The point is the light's position, or for a light with a patch the point of
    /// its emitter's surface beneath it (`patch::surface_point`). `None` where p is at that point. A
    /// receiver can be tested against wo first (`cpu::shade_unshadowed`): its BSDF is evaluated at wo
    /// alone except for a virtual spherical light (`shade_receiver`).
    #[inline]
    pub fn toward(&self, j: usize, p: Vec3) -> Option<(Vec3, f32, f32)> {
        let kind = self.kind[j];
        if kind == LightKind::Directional {
            return Some((-self.direction[j], f32::INFINITY, f32::INFINITY));
        }
        let c = &self.patch[j];
        let target = if kind == LightKind::OrientedPoint && !patch::is_none(c) {
            patch::surface_point(c, self.position[j], self.normal[j])
        } else {
            self.position[j]
        };
        let d = target - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let dist = dist2.sqrt();
        Some((d / dist, dist2, dist))
    }

    /// `emitted` from `toward(j, p)`'s answer.
    #[inline]
    pub fn emitted_toward(&self, j: usize, p: Vec3, n: Vec3, toward: (Vec3, f32, f32)) -> Option<(Vec3, Vec3, f32)> {
        let kind = self.kind[j];
        let (wo, dist2, dist) = toward;
        if kind == LightKind::Directional {
            return Some((wo, self.intensity[j], f32::INFINITY));
        }
        let inv_d2 = 1.0 / dist2;
        let radiance = match kind {
            LightKind::Point | LightKind::Directional => self.intensity[j] * inv_d2,
            LightKind::Spot => {
                let falloff = spot_falloff(-wo.dot(self.direction[j]), self.cutoff_angle[j], self.beam_width[j]);
                if falloff <= 0.0 {
                    return None;
                }
                match &self.spot_texture[j] {
                    Some(t) => self.intensity[j] * t.eval_world(-wo, self.direction[j]) * (falloff * inv_d2),
                    None => self.intensity[j] * (falloff * inv_d2),
                }
            }
            LightKind::OrientedPoint => {
                let c = &self.patch[j];
                if !patch::is_none(c) {
                    return patch::surface_emitted_toward(c, self.normal[j], self.intensity[j], p, n, wo, dist2, dist);
                }
                let cos = -wo.dot(self.normal[j]);
                if !(cos > 0.0) {
                    return None;
                }
                if patch::is_near(c, p) {
                    patch::near_field(c, self.intensity[j], p, n, wo)?
                } else {
                    self.intensity[j] * (cos * inv_d2)
                }
            }
            LightKind::Vpl => {
                let (n_s, n_g, incident) = (self.normal[j], self.geo_normal[j], self.incident[j]);
                let w = -wo;
                let (cos_g_out, cos_g_in) = (w.dot(n_g), incident.dot(n_g));
                if !(cos_g_out * cos_g_in > 0.0) {
                    return None;
                }
                let (s, t) = coordinate_system(n_s);
                let local = |v: Vec3| Vec3::new(v.dot(s), v.dot(t), v.dot(n_s));
                let (wi_local, wo_local) = (local(incident), local(w));
                if wo_local.z == 0.0 {
                    return None;
                }
                // eval = f |w . n_s|; I(w) = Phi f |w . n_g|.
                let f_cos = crate::shading::perturb::adjoint_eval(&self.bsdf[j], wi_local, wo_local);
                let intensity = self.intensity[j] * f_cos * (cos_g_out.abs() / wo_local.z.abs());
                let r = self.vsl_radius[j];
                if r > 0.0 {
                    return Some((wo, vsl::spread(intensity, cos_g_out.abs(), wo.dot(n).abs(), dist2, r)?, dist));
                }
                let g = cos_g_out.abs() * wo.dot(n).abs() * inv_d2;
                let clamp = if g > self.vpl_clamp { self.vpl_clamp / g } else { 1.0 };
                intensity * (inv_d2 * clamp)
            }
        };
        Some((wo, radiance, dist))
    }
}
