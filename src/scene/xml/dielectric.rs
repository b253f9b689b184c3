//! `<bsdf type="roughdielectric">` and `<bsdf type="thindielectric">` (Mitsuba 3.9.1
//! `src/bsdfs/roughdielectric.cpp`, `src/bsdfs/thindielectric.cpp`), with Mitsuba's defaults: `int_ior`
//! "bk7", `ext_ior` "air" (a float or a named material), `distribution` "beckmann", `alpha` 0.1 or
//! `alpha_u` + `alpha_v` (floats or textures), `specular_reflectance` and `specular_transmittance` 1
//! (colours or textures). `sample_visible` only changes sampling (`props::IGNORED`).
//!
//! Refused where Mitsuba would compute nonsense or clamp silently: an IOR that is not finite and > 0
//! (Mitsuba refuses negative ones), equal `int_ior` and `ext_ior` for `roughdielectric` (as Mitsuba), a
//! constant `alpha` that is negative or not finite (Mitsuba clamps it to 1e-4).
use super::parse::Value;
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};
use crate::scene::types::{Bsdf, Param};

impl Builder<'_> {
    /// An IOR property of a dielectric: finite and > 0 (the error names the property's element).
    fn positive_ior(&self, p: &mut Props, name: &str, default: &str) -> Result<f32> {
        let v = self.ior(p, name, default)?;
        if !(v.is_finite() && v > 0.0) {
            let loc = p.prop(name).map_or(p.loc(), |q| &q.loc);
            return Err(Error::scene(loc, format!("{}: {name} must be finite and > 0, got {v}", p.what())));
        }
        Ok(v)
    }

    /// A roughness parameter: a texture, or a constant that must be finite and >= 0.
    fn roughness(&mut self, p: &mut Props, name: &str) -> Result<Param> {
        let v = self.unbounded_param(p, name, 0.1)?;
        if let (Param::Value(c), Some(prop)) = (v, p.prop(name)) {
            if !(c.is_finite() && c.min_element() >= 0.0) {
                let shown = match &prop.value {
                    Value::Float(f) => f.to_string(),
                    _ => format!("{c}"),
                };
                return Err(Error::scene(&prop.loc, format!("{}: {name} must be finite and >= 0, got {shown}", p.what())));
            }
        }
        Ok(v)
    }

    /// A `roughdielectric`.
    pub(super) fn roughdielectric(&mut self, p: &mut Props) -> Result<Bsdf> {
        let specular_reflectance = self.param(p, "specular_reflectance", 1.0)?;
        let specular_transmittance = self.param(p, "specular_transmittance", 1.0)?;
        let int_ior = self.positive_ior(p, "int_ior", "bk7")?;
        let ext_ior = self.positive_ior(p, "ext_ior", "air")?;
        if int_ior == ext_ior {
            return Err(Error::scene(p.loc(), format!("{}: int_ior and ext_ior must differ, both are {int_ior}", p.what())));
        }
        let distribution = self.distribution(p)?;
        let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
            if !(p.has("alpha_u") && p.has("alpha_v")) {
                return Err(Error::scene(p.loc(), format!("{}: both alpha_u and alpha_v must be given", p.what())));
            }
            if p.has("alpha") {
                return Err(Error::scene(p.loc(), format!("{}: give either alpha or alpha_u/alpha_v, not both", p.what())));
            }
            (self.roughness(p, "alpha_u")?, self.roughness(p, "alpha_v")?)
        } else {
            let a = self.roughness(p, "alpha")?;
            (a, a)
        };
        Ok(Bsdf::RoughDielectric { distribution, alpha_u, alpha_v, int_ior, ext_ior, specular_reflectance, specular_transmittance })
    }

    /// A `thindielectric`.
    pub(super) fn thindielectric(&mut self, p: &mut Props) -> Result<Bsdf> {
        let int_ior = self.positive_ior(p, "int_ior", "bk7")?;
        let ext_ior = self.positive_ior(p, "ext_ior", "air")?;
        let specular_reflectance = self.param(p, "specular_reflectance", 1.0)?;
        let specular_transmittance = self.param(p, "specular_transmittance", 1.0)?;
        Ok(Bsdf::ThinDielectric { int_ior, ext_ior, specular_reflectance, specular_transmittance })
    }
}
