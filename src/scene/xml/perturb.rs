//! `<bsdf type="bumpmap">` and `<bsdf type="normalmap">` (Mitsuba 3.9.1 `src/bsdfs/bumpmap.cpp`,
//! `src/bsdfs/normalmap.cpp`): one nested BSDF whose shading frame is perturbed
//! (`crate::shading::perturb`).
//!
//! bumpmap: exactly one nested `<bsdf>` and one nested `<texture>` (any name; a bitmap: Mitsuba 3.9.1
//! implements the texture gradient `eval_1_grad` for bitmaps only), `scale` (default 1).
//! normalmap: exactly one nested `<bsdf>` and the texture named `normalmap` (a bitmap with 3 channels and
//! `raw=true`; Mitsuba's RGB variants would decode a non-raw image as sRGB, which silently bends the
//! normals, and its spectral variants refuse it: here it is refused).
//! `flip_invalid_normals` and `use_shadowing_function` are accepted at their default (true) only.
//!
//! Where they may sit: at the top of a shape's BSDF, or inside a `twosided`. A perturbation inside
//! another one, a `blendbsdf` inside one or one inside a `blendbsdf` is refused (each surface point
//! carries one perturbed frame in its BSDF record), and so is a nested BSDF with a delta lobe
//! (conductor, dielectric, smooth plastic: the delta chains of `crate::view::chains` reflect about the
//! unperturbed normal).
use super::parse::Value;
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};
use crate::scene::types::{Bsdf, Texture};

impl Builder<'_> {
    /// Whether BSDF `i` is a bumpmap or normalmap.
    pub(super) fn is_perturbation(&self, i: usize) -> bool {
        matches!(self.bsdfs[i], Bsdf::BumpMap { .. } | Bsdf::NormalMap { .. })
    }

    /// A `bumpmap` or `normalmap` (`p.node.plugin`).
    pub(super) fn perturbation(&mut self, p: &mut Props) -> Result<Bsdf> {
        let what = p.what();
        let plugin = p.node.plugin.clone();
        let texture_ref = if plugin == "normalmap" { p.named_object("normalmap")? } else { None };
        let mut nested = None;
        let mut texture = texture_ref.clone();
        for r in p.objects()? {
            let class = self.doc.nodes[r.node].class.as_str();
            match class {
                "bsdf" if nested.is_some() => {
                    return Err(Error::scene(&r.loc, format!("{what}: only a single nested BSDF can be given")));
                }
                "bsdf" => nested = Some(r),
                "texture" if plugin == "normalmap" => {
                    if r.name.as_deref() != Some("normalmap") {
                        return Err(Error::scene(
                            &r.loc,
                            format!(
                                "{what}: the normal map texture must be named \"normalmap\", got {:?}",
                                r.name.as_deref().unwrap_or("")
                            ),
                        ));
                    }
                }
                "texture" if texture.is_some() => {
                    return Err(Error::scene(&r.loc, format!("{what}: only a single nested texture can be given")));
                }
                "texture" => texture = Some(r),
                other => {
                    return Err(Error::scene(
                        &r.loc,
                        format!("{what}: unsupported <{other} type=\"{}\"> inside it", self.doc.nodes[r.node].plugin),
                    ));
                }
            }
        }
        let Some(nested) = nested else {
            return Err(Error::scene(p.loc(), format!("{what}: exactly one nested BSDF is required, got none")));
        };
        let Some(tex) = texture else {
            let need = if plugin == "normalmap" {
                "a nested <texture name=\"normalmap\" type=\"bitmap\"> (raw=true)"
            } else {
                "a nested height <texture> (a bitmap)"
            };
            return Err(Error::scene(p.loc(), format!("{what}: {need} is required, got none")));
        };
        for flag in ["flip_invalid_normals", "use_shadowing_function"] {
            if !p.bool(flag, true)? {
                return Err(Error::scene(p.loc(), format!("{what}: {flag}=false is not supported (only Mitsuba's default, true)")));
            }
        }
        let scale = if plugin == "bumpmap" {
            let s = p.float("scale", 1.0)?;
            if !s.is_finite() {
                return Err(Error::scene(p.loc(), format!("{what}: scale = {s} must be finite")));
            }
            s as f32
        } else {
            0.0
        };
        // The texture: a bitmap; for a normal map raw with 3 channels.
        let tnode = &self.doc.nodes[tex.node];
        if tnode.plugin != "bitmap" {
            let why = if plugin == "bumpmap" {
                "Mitsuba 3.9.1 takes height gradients (eval_1_grad) of bitmaps only"
            } else {
                "the normals are read from a bitmap"
            };
            return Err(Error::scene(
                &tex.loc,
                format!("{what}: the texture must be a bitmap, got <texture type=\"{}\"> ({why})", tnode.plugin),
            ));
        }
        if plugin == "normalmap" {
            let raw = tnode.props.iter().find(|q| q.name == "raw");
            if !matches!(raw.map(|q| &q.value), Some(Value::Bool(true))) {
                let got = match raw.map(|q| &q.value) {
                    Some(Value::Bool(b)) => format!("raw = {b}"),
                    Some(v) => format!("raw as a <{}>", v.type_name()),
                    None => "no raw property (default false)".to_string(),
                };
                return Err(Error::scene(
                    raw.map(|q| &q.loc).unwrap_or(&tex.loc),
                    format!(
                        "{what}: the normal map bitmap needs <boolean name=\"raw\" value=\"true\"> (its texels are \
                         directions, not sRGB colours), got {got}"
                    ),
                ));
            }
        }
        let t = self.texture(tex.node)?;
        if plugin == "normalmap" {
            let path = self.texture_path(t);
            let channels = crate::scene::texture::bitmap_channels(&path, &tex.loc)?;
            if channels != 3 {
                return Err(Error::scene(
                    &tex.loc,
                    format!(
                        "{what}: the normal map {} has {channels} channel(s); it needs 3 (RGB = (n + 1) / 2; Mitsuba's \
                         eval_3 refuses other channel counts)",
                        path.display()
                    ),
                ));
            }
        }
        debug_assert!(matches!(self.textures[t], Texture::Bitmap { .. }));
        let n = self.bsdf(nested.node)?;
        let inner = match self.bsdfs[n] {
            Bsdf::TwoSided { front, .. } => front,
            _ => n,
        };
        if self.is_perturbation(inner) || matches!(self.bsdfs[inner], Bsdf::Blend { .. }) {
            let kind = if matches!(self.bsdfs[inner], Bsdf::Blend { .. }) { "a blendbsdf" } else { "a bumpmap or normalmap" };
            return Err(Error::scene(&nested.loc, format!("{what}: {kind} inside it is not supported")));
        }
        if self.is_mask(inner) {
            return Err(Error::scene(&nested.loc, format!("{what}: a mask inside it is not supported (put the mask around the {plugin})")));
        }
        if let Bsdf::RoughDielectric { .. } | Bsdf::ThinDielectric { .. } = self.bsdfs[inner] {
            return Err(Error::scene(
                &nested.loc,
                format!("{what}: a nested roughdielectric or thindielectric is not supported (perturbed transmission)"),
            ));
        }
        if let Bsdf::Conductor { .. } | Bsdf::Dielectric { .. } | Bsdf::Plastic { .. } = self.bsdfs[inner] {
            return Err(Error::scene(
                &nested.loc,
                format!(
                    "{what}: a nested BSDF with a delta lobe (conductor, dielectric, plastic) is not supported (the \
                     camera's delta chains do not bend at perturbed normals); use a rough variant"
                ),
            ));
        }
        Ok(if plugin == "bumpmap" { Bsdf::BumpMap { texture: t, scale, nested: n } } else { Bsdf::NormalMap { texture: t, nested: n } })
    }
}
