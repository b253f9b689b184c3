//! `<bsdf type="blendbsdf">` (Mitsuba 3.9.1 `src/bsdfs/blendbsdf.cpp`): a weight (float or texture, no
//! default) and exactly two nested BSDFs, in document order.
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};
use crate::scene::types::Bsdf;

impl Builder<'_> {
    /// A `blendbsdf`. A nested `blendbsdf` (also inside a `twosided`) is refused: each surface point
    /// carries at most two BSDF lobes.
    pub(super) fn blendbsdf(&mut self, p: &mut Props) -> Result<Bsdf> {
        if !p.has("weight") {
            return Err(Error::scene(p.loc(), format!("{}: the \"weight\" (float or texture) is required", p.what())));
        }
        let weight = self.unbounded_param(p, "weight", 0.5)?;
        let mut children = Vec::new();
        for r in p.objects()? {
            if r.name.as_deref() == Some("weight") {
                continue;
            }
            self.expect_class(&r, "bsdf", &format!("a child of {}", p.what()))?;
            let i = self.bsdf(r.node)?;
            let inner = match &self.bsdfs[i] {
                Bsdf::TwoSided { front, .. } => *front,
                _ => i,
            };
            if self.is_perturbation(inner) {
                let kind = if matches!(self.bsdfs[inner], Bsdf::BumpMap { .. }) { "bumpmap" } else { "normalmap" };
                return Err(Error::scene(&r.loc, format!("{}: a {kind} inside it is not supported", p.what())));
            }
            if matches!(self.bsdfs[inner], Bsdf::RoughDielectric { .. } | Bsdf::ThinDielectric { .. }) {
                return Err(Error::scene(
                    &r.loc,
                    format!("{}: a roughdielectric or thindielectric inside it is not supported (a blended surface holds no VPL with transmission)", p.what()),
                ));
            }
            if self.is_mask(inner) {
                return Err(Error::scene(
                    &r.loc,
                    format!("{}: a mask inside it is not supported (put the mask around the blendbsdf)", p.what()),
                ));
            }
            if matches!(self.bsdfs[inner], Bsdf::Blend { .. }) {
                return Err(Error::scene(&r.loc, format!("{}: a nested blendbsdf is not supported", p.what())));
            }
            children.push(i);
        }
        match children[..] {
            [first, second] => Ok(Bsdf::Blend { weight, first, second }),
            _ => Err(Error::scene(p.loc(), format!("{}: exactly two nested BSDFs are required, got {}", p.what(), children.len()))),
        }
    }
}
