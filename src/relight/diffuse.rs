//! The diffuse lobe of a receiver of the final gather F_d (Hašan, Pellacini, Bala, SIGGRAPH 2006, Eq. 5:
//! L_ind(i) = f_d(i) sum_g F_d(i, g) B_g, there with a Lambertian f_d = k_d / pi).
//!
//! A plastic's diffuse lobe (Mitsuba's `plastic` and `roughplastic`, `shading::bsdf::eval` with the
//! specular reflectance set to 0) is not Lambertian: f_d(wi, wo) = k_d / (1 - D) t(wi) t(wo) / (eta^2 pi),
//! D the internal diffuse reflectance (times k_d with `nonlinear`), t the Fresnel transmittance of the
//! coating (smooth: 1 - F(cos); rough: Mitsuba's tabulated external transmittance). It factors into an RGB
//! part fixed by the viewer and a scalar part of the direction toward the gather sample, so
//!
//!   f_d(wi, wo) = a(i) / pi * s(i, wo),   a(i) = pi f_d(wi, n),   s(i, wo) = mean_rgb f_d(wi, wo) / mean_rgb f_d(wi, n),
//!
//! exactly (n the shading normal, on the viewer's side): `albedo` is a(i), which `relight` multiplies the
//! row's product by in place of k_d, and the gather bakes s(i, wo) into each F_d(i, g) (`Lobe::factor`).
//! With every coefficient kept, the exact gather and point gather samples, a relit rough-plastic floor then
//! equals the gather samples as VPLs through the light matrix (which evaluates the BSDF exactly) to 1e-7,
//! where the Lambertian k_d / pi was 1.8% off (`tests/relight/test_relight.py`). A diffuse BSDF keeps k_d
//! and s = 1 (its rows are unchanged bit for bit); other kinds (principled, blends, bump-mapped records)
//! keep the Lambertian k_d / pi of `ViewSamples::albedo`.
use crate::shading::bsdf::{eval, FLAG_BLEND, FLAG_BUMP, FLAG_TWOSIDED_OUTER, KIND_PLASTIC, KIND_ROUGHPLASTIC};
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use glam::Vec3;

/// A receiver's non-Lambertian diffuse lobe: the plastic record without its specular part, the viewer's
/// direction (local frame) and mean_rgb f_d(wi, n).
#[derive(Debug, Clone, Copy)]
pub struct Lobe {
    record: GpuBsdf,
    wi: Vec3,
    at_normal: f32,
}

impl Lobe {
    /// The lobe of view sample `i` (record `view.bsdf[i]`, viewer direction `wi` in its shading frame), or
    /// None where it is Lambertian or not a plastic (module docs).
    pub fn of(view: &ViewSamples, i: usize, wi: Vec3) -> Option<Lobe> {
        let b = view.bsdf.get(i).filter(|b| factored(b))?;
        let mut record = *b;
        record.specular = [0.0; 3];
        let at_normal = eval(&record, wi, normal_on_side(wi)).element_sum() / 3.0;
        (at_normal > 0.0 && at_normal.is_finite()).then_some(Lobe { record, wi, at_normal })
    }

    /// s(i, wo) for `wo` (unit, local frame; module docs): 0 where the lobe is 0.
    #[inline]
    pub fn factor(&self, wo: Vec3) -> f32 {
        if wo.z == 0.0 {
            return 0.0;
        }
        let s = eval(&self.record, self.wi, wo).element_sum() / (3.0 * wo.z.abs() * self.at_normal);
        if s.is_finite() {
            s.max(0.0)
        } else {
            0.0
        }
    }

    /// a(i) = pi f_d(wi, n) (RGB).
    pub fn albedo(&self) -> Vec3 {
        eval(&self.record, self.wi, normal_on_side(self.wi)) * std::f32::consts::PI
    }
}

/// Whether record `b` has a diffuse lobe this module factors (a plastic, not blended or bump-mapped).
fn factored(b: &GpuBsdf) -> bool {
    (b.kind == KIND_PLASTIC || b.kind == KIND_ROUGHPLASTIC) && b.flags & (FLAG_BLEND | FLAG_BUMP | FLAG_TWOSIDED_OUTER) == 0
}

/// The shading normal on the side of `wi` (local frame).
fn normal_on_side(wi: Vec3) -> Vec3 {
    if wi.z < 0.0 {
        Vec3::NEG_Z
    } else {
        Vec3::Z
    }
}

/// The albedo a(i) relighting multiplies view sample i's F_d product by (module docs): the plastic lobe's
/// `Lobe::albedo`, else `ViewSamples::albedo`.
pub fn albedo(view: &ViewSamples, i: usize) -> Vec3 {
    if !factored(&view.bsdf[i]) {
        // The common case, on every relight's path: no shading frame to build.
        return view.albedo[i];
    }
    let sp = crate::cpu::ShadingPoint::new(view, i);
    match Lobe::of(view, i, sp.wi_local) {
        Some(lobe) => lobe.albedo(),
        None => view.albedo[i],
    }
}

#[cfg(test)]
mod tests;
