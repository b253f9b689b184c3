//! The parameters of Mitsuba 3.9.1's `principled` BSDF as loaded (`src/bsdfs/principled.cpp`); evaluated
//! by `crate::shading::principled`. Every parameter but `eta` may be a texture (scalar ones are read
//! with Mitsuba's `eval_1`).
use super::types::Param;

#[derive(Debug, Clone, PartialEq)]
pub struct Principled {
    /// RGB, default 0.5.
    pub base_color: Param,
    /// Default 0.5.
    pub roughness: Param,
    pub anisotropic: Param,
    pub metallic: Param,
    pub spec_tint: Param,
    pub spec_trans: Param,
    pub sheen: Param,
    pub sheen_tint: Param,
    pub clearcoat: Param,
    pub clearcoat_gloss: Param,
    pub flatness: Param,
    /// Relative IOR, from `eta` or `specular` (`crate::shading::principled::principled_eta`).
    pub eta: f32,
}

impl Principled {
    /// The scalar parameters by Mitsuba name.
    pub fn scalars(&self) -> [(&'static str, &Param); 10] {
        [
            ("roughness", &self.roughness),
            ("anisotropic", &self.anisotropic),
            ("metallic", &self.metallic),
            ("spec_tint", &self.spec_tint),
            ("spec_trans", &self.spec_trans),
            ("sheen", &self.sheen),
            ("sheen_tint", &self.sheen_tint),
            ("clearcoat", &self.clearcoat),
            ("clearcoat_gloss", &self.clearcoat_gloss),
            ("flatness", &self.flatness),
        ]
    }
}
