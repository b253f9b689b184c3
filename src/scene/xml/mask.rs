//! `<bsdf type="mask">` (Mitsuba 3.9.1 `src/bsdfs/mask.cpp`): an opacity (float or texture, default 0.5,
//! read with `eval_1` and clipped to [0, 1] by Mitsuba) and exactly one nested BSDF. The surface is the
//! nested BSDF weighted by the opacity plus a straight-through null lobe weighted by 1 - opacity
//! (`crate::view::chains`, `crate::raytrace::mask`).
//!
//! Where it may sit: at the top of a shape's BSDF, or inside a `twosided` (the leaf idiom
//! `<bsdf type="twosided"><bsdf type="mask">...`). A mask inside a `blendbsdf`, `bumpmap`, `normalmap` or
//! another mask is refused. A nested BSDF with delta lobes (conductor, dielectric, thindielectric, smooth
//! plastic's coating) is followed by the delta chains along its lobes times the opacity and along the null
//! lobe times 1 - opacity (`crate::view::chains`). A constant opacity outside [0, 1] is refused (Mitsuba would clip it silently); a textured one is
//! clipped as Mitsuba does.
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};
use crate::scene::types::{Bsdf, Param};
use glam::Vec3;

impl Builder<'_> {
    /// Whether BSDF `i` is a mask, or a twosided around one.
    pub(super) fn is_mask(&self, i: usize) -> bool {
        match self.bsdfs[i] {
            Bsdf::Mask { .. } => true,
            Bsdf::TwoSided { front, .. } => front != i && matches!(self.bsdfs[front], Bsdf::Mask { .. }),
            _ => false,
        }
    }

    /// A `mask`.
    pub(super) fn mask(&mut self, p: &mut Props) -> Result<Bsdf> {
        let what = p.what();
        let opacity = self.unbounded_param(p, "opacity", 0.5)?;
        if let Param::Value(v) = opacity {
            let loc = p.loc_of("opacity");
            if !(v.min_element() >= 0.0 && v.max_element() <= 1.0) {
                return Err(Error::scene(&loc, format!("{what}: opacity must be in [0, 1], got {}", v.x.min(v.min_element()))));
            }
            if v != Vec3::splat(v.x) {
                return Err(Error::scene(&loc, format!("{what}: opacity must be one value (a float), got [{}, {}, {}]", v.x, v.y, v.z)));
            }
        }
        let mut nested = None;
        for r in p.objects()? {
            if r.name.as_deref() == Some("opacity") {
                continue;
            }
            self.expect_class(&r, "bsdf", &format!("a child of {what}"))?;
            if nested.is_some() {
                return Err(Error::scene(&r.loc, format!("{what}: only a single nested BSDF can be given")));
            }
            nested = Some(r);
        }
        let Some(r) = nested else {
            return Err(Error::scene(p.loc(), format!("{what}: exactly one nested BSDF is required, got none")));
        };
        let n = self.bsdf(r.node)?;
        let inner = match self.bsdfs[n] {
            Bsdf::TwoSided { front, .. } => front,
            _ => n,
        };
        if self.is_mask(inner) {
            return Err(Error::scene(&r.loc, format!("{what}: a mask inside a mask is not supported")));
        }
        Ok(Bsdf::Mask { opacity, nested: n })
    }
}
