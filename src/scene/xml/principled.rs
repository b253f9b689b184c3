//! `<bsdf type="principled">` (Mitsuba 3.9.1 `src/bsdfs/principled.cpp`): parameters, defaults and the
//! eta / specular rule.
use super::parse::Value;
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};
use crate::scene::principled::Principled;
use crate::scene::types::Bsdf;
use crate::shading::principled::principled_eta;

impl Builder<'_> {
    /// A `principled` BSDF. Mitsuba's sampling rates (`*_sampling_rate`) only change its sampling and
    /// are accepted and ignored. Both `eta` and `specular` given is an error, as in Mitsuba.
    pub(super) fn principled(&mut self, p: &mut Props) -> Result<Bsdf> {
        p.ignore(&["main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate"]);
        // Mitsuba's get_flag: given, and not the float 0.
        let has_spec_trans =
            p.has("spec_trans") && !p.node.props.iter().any(|q| q.name == "spec_trans" && matches!(q.value, Value::Float(v) if v == 0.0));
        let base_color = self.param(p, "base_color", 0.5)?;
        let mut scalar = |s: &mut Self, name: &str, default: f32| s.unbounded_param(p, name, default);
        let roughness = scalar(self, "roughness", 0.5)?;
        let anisotropic = scalar(self, "anisotropic", 0.0)?;
        let metallic = scalar(self, "metallic", 0.0)?;
        let spec_tint = scalar(self, "spec_tint", 0.0)?;
        let spec_trans = scalar(self, "spec_trans", 0.0)?;
        let sheen = scalar(self, "sheen", 0.0)?;
        let sheen_tint = scalar(self, "sheen_tint", 0.0)?;
        let clearcoat = scalar(self, "clearcoat", 0.0)?;
        let clearcoat_gloss = scalar(self, "clearcoat_gloss", 0.0)?;
        let flatness = scalar(self, "flatness", 0.0)?;
        let eta = p.opt_float("eta")?.map(|v| v as f32);
        let specular = p.opt_float("specular")?.map(|v| v as f32);
        if eta.is_some() && specular.is_some() {
            return Err(Error::scene(p.loc(), format!("{}: give either \"eta\" or \"specular\", not both", p.what())));
        }
        let eta = principled_eta(eta, specular, has_spec_trans);
        if !(eta.is_finite() && eta > 0.0) {
            return Err(Error::scene(p.loc(), format!("{}: invalid index of refraction {eta} (from eta / specular)", p.what())));
        }
        Ok(Bsdf::Principled(Box::new(Principled {
            base_color,
            roughness,
            anisotropic,
            metallic,
            spec_tint,
            spec_trans,
            sheen,
            sheen_tint,
            clearcoat,
            clearcoat_gloss,
            flatness,
            eta,
        })))
    }
}
