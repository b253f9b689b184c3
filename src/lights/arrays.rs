//! LightSets made by users: from arrays (one entry per light), subsets and concatenation.
//!
//! `LightSet::from_arrays` checks every light and stores it in the same canonical form as the
//! generated sets (fields a kind does not use are 0), without renormalising the given unit vectors, so
//! that the arrays of a generated set rebuild it bit for bit. Required per kind (others are ignored):
//! - point (0): position, intensity (W/sr)
//! - spot (1): position, direction (unit axis), intensity (W/sr), cutoff_angle in (0, pi],
//!   beam_width in [0, cutoff_angle] (radians)
//!   (the arrays hold no projected texture: such spots are untextured, so a scene's textured spot
//!   comes back from its arrays without its texture; subsets and `concat` keep it)
//! - directional (2): direction (unit, the direction light travels), intensity = irradiance (W/m^2)
//! - oriented point (3): position, normal (unit), intensity I0 along the normal (W/sr); optional patch
//!   (4 corners of the planar convex piece of emitter it stands for, `lights::patch`; all zero = none,
//!   the default)
//! - VPL (4): position, normal n_s (unit), geo_normal n_g (unit), incident (unit), intensity = flux
//!   Phi (W), bsdf; optional vsl_radius (m, finite and >= 0: a virtual spherical light, `lights::vsl`;
//!   0 = a point VPL, the default; ignored for other kinds); optional vpl_depth (>= 1, the bounce it was
//!   stored at, `LightSet::vpl_depth`; 1 by default; ignored for other kinds)
//!
//! Unit vectors must have length 1 within `UNIT_TOL`; positions finite; intensities finite, >= 0 and at most
//! `MAX_INTENSITY` (so that contributions stay finite in float32).
use super::{LightKind, LightSet};
use crate::error::{Error, Result};
use crate::shading::GpuBsdf;
use glam::Vec3;

/// Largest accepted | |v| - 1 | of a unit vector.
pub const UNIT_TOL: f32 = 1e-4;

/// Per-light arrays (length n each where present) for `LightSet::from_arrays`.
#[derive(Debug, Default, Clone)]
pub struct LightArrays {
    /// `LightKind as i32` per light.
    pub kind: Vec<i32>,
    pub position: Option<Vec<Vec3>>,
    pub direction: Option<Vec<Vec3>>,
    pub normal: Option<Vec<Vec3>>,
    pub geo_normal: Option<Vec<Vec3>>,
    pub incident: Option<Vec<Vec3>>,
    pub intensity: Vec<Vec3>,
    pub cutoff_angle: Option<Vec<f32>>,
    pub beam_width: Option<Vec<f32>>,
    pub bsdf: Option<Vec<GpuBsdf>>,
    /// Oriented points' patches (4 corners each); None = no patches.
    pub patch: Option<Vec<[Vec3; 4]>>,
    /// VPLs' virtual-spherical-light radii (m, >= 0; 0 = a point VPL); None = all point VPLs.
    pub vsl_radius: Option<Vec<f32>>,
    /// VPLs' depths (>= 1, `LightSet::vpl_depth`; ignored for other kinds); None = 1 for every VPL.
    pub vpl_depth: Option<Vec<u32>>,
}

/// Light kind from its integer code.
pub fn kind_from_i32(j: usize, k: i32) -> Result<LightKind> {
    Ok(match k {
        0 => LightKind::Point,
        1 => LightKind::Spot,
        2 => LightKind::Directional,
        3 => LightKind::OrientedPoint,
        4 => LightKind::Vpl,
        _ => {
            return Err(Error::invalid(format!(
                "kind[{j}] = {k} is not a light kind (0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL)"
            )))
        }
    })
}

fn kind_name(k: LightKind) -> &'static str {
    match k {
        LightKind::Point => "point",
        LightKind::Spot => "spot",
        LightKind::Directional => "directional",
        LightKind::OrientedPoint => "oriented point",
        LightKind::Vpl => "VPL",
    }
}

fn need<'a, T>(name: &str, arr: &'a Option<Vec<T>>, j: usize, kind: LightKind) -> Result<&'a T> {
    arr.as_ref()
        .map(|a| &a[j])
        .ok_or_else(|| Error::invalid(format!("{name} is required for {} lights (light {j} is one)", kind_name(kind))))
}

/// The largest intensity component accepted (W/sr, W/m^2 or W): 1e30 leaves eight orders of magnitude of
/// float32's range (3.4e38) for the BSDF, cosine and 1/d^2 factors of a contribution and for sums of columns.
pub const MAX_INTENSITY: f32 = 1e30;

fn finite(name: &str, j: usize, v: Vec3) -> Result<Vec3> {
    if !v.is_finite() {
        return Err(Error::invalid(format!("{name}[{j}] must be finite, got {:?}", v.to_array())));
    }
    Ok(v)
}

fn unit(name: &str, j: usize, v: Vec3) -> Result<Vec3> {
    finite(name, j, v)?;
    let len = v.length();
    if !((len - 1.0).abs() <= UNIT_TOL) {
        return Err(Error::invalid(format!(
            "{name}[{j}] must be a unit vector (|v| = 1 within {UNIT_TOL}), got {:?} of length {len}",
            v.to_array()
        )));
    }
    Ok(v)
}

impl LightSet {
    /// A set from per-light arrays (module docs) for the scene whose bounding sphere is
    /// (`scene_center`, `scene_radius`); `vpl_clamp` bounds the VPL geometry term (inf = none).
    ///
    /// Errors: `InvalidParameter` naming the array, the light index, the expected and the actual value
    /// (array lengths other than n, unknown kinds, non-finite values, negative intensities, non-unit
    /// vectors, bad spot angles, a VPL without a BSDF, a patch with non-finite corners or zero area, a NaN, infinite or
    /// negative vsl_radius, a VPL depth of 0).
    pub fn from_arrays(a: &LightArrays, scene_center: Vec3, scene_radius: f32, vpl_clamp: f32) -> Result<LightSet> {
        let n = a.kind.len();
        let lens: [(&str, Option<usize>); 13] = [
            ("vsl_radius", a.vsl_radius.as_ref().map(Vec::len)),
            ("vpl_depth", a.vpl_depth.as_ref().map(Vec::len)),
            ("patch", a.patch.as_ref().map(Vec::len)),
            ("position", a.position.as_ref().map(Vec::len)),
            ("direction", a.direction.as_ref().map(Vec::len)),
            ("normal", a.normal.as_ref().map(Vec::len)),
            ("geo_normal", a.geo_normal.as_ref().map(Vec::len)),
            ("incident", a.incident.as_ref().map(Vec::len)),
            ("intensity", Some(a.intensity.len())),
            ("cutoff_angle", a.cutoff_angle.as_ref().map(Vec::len)),
            ("beam_width", a.beam_width.as_ref().map(Vec::len)),
            ("bsdf", a.bsdf.as_ref().map(Vec::len)),
            ("kind", Some(n)),
        ];
        for (name, len) in lens {
            if let Some(len) = len {
                if len != n {
                    return Err(Error::invalid(format!("{name} must have one entry per light (n = {n} from kind), got {len}")));
                }
            }
        }
        if !(vpl_clamp > 0.0) {
            return Err(Error::invalid(format!("vpl_clamp must be > 0 (inf for none), got {vpl_clamp}")));
        }
        if !(scene_center.is_finite() && scene_radius.is_finite() && scene_radius >= 0.0) {
            return Err(Error::invalid(format!("the scene sphere must be finite, got centre {scene_center:?}, radius {scene_radius}")));
        }
        let mut set = LightSet::new(scene_center, scene_radius);
        set.vpl_clamp = vpl_clamp;
        for j in 0..n {
            let kind = kind_from_i32(j, a.kind[j])?;
            let intensity = finite("intensity", j, a.intensity[j])?;
            if intensity.min_element() < 0.0 {
                return Err(Error::invalid(format!("intensity[{j}] must be >= 0, got {:?}", intensity.to_array())));
            }
            if intensity.max_element() > MAX_INTENSITY {
                return Err(Error::invalid(format!(
                    "intensity[{j}] = {:?} is above {MAX_INTENSITY:e}: a contribution (intensity times BSDF and geometry \
                     terms, float32) could overflow to inf; scale the lights (or the scene's units) down",
                    intensity.to_array()
                )));
            }
            let (mut position, mut direction, mut normal, mut geo, mut incident) =
                (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            let (mut cutoff, mut beam) = (0.0f32, 0.0f32);
            let mut bsdf: GpuBsdf = bytemuck::Zeroable::zeroed();
            if kind != LightKind::Directional {
                position = finite("position", j, *need("position", &a.position, j, kind)?)?;
            }
            match kind {
                LightKind::Point => {}
                LightKind::Spot | LightKind::Directional => {
                    direction = unit("direction", j, *need("direction", &a.direction, j, kind)?)?;
                }
                LightKind::OrientedPoint => {
                    normal = unit("normal", j, *need("normal", &a.normal, j, kind)?)?;
                    geo = normal;
                }
                LightKind::Vpl => {
                    normal = unit("normal", j, *need("normal", &a.normal, j, kind)?)?;
                    geo = unit("geo_normal", j, *need("geo_normal", &a.geo_normal, j, kind)?)?;
                    incident = unit("incident", j, *need("incident", &a.incident, j, kind)?)?;
                    bsdf = *need("bsdf", &a.bsdf, j, kind)?;
                    let words: [u32; 20] = bytemuck::cast(bsdf);
                    let floats_ok = words.iter().enumerate().all(|(w, &b)| w == 3 || w == 7 || f32::from_bits(b).is_finite());
                    if bsdf.kind == crate::shading::bsdf::KIND_NONE || !floats_ok {
                        return Err(Error::invalid(format!("bsdf[{j}] is not a valid BSDF (kind {}, finite values required)", bsdf.kind)));
                    }
                }
            }
            if kind == LightKind::Spot {
                cutoff = *need("cutoff_angle", &a.cutoff_angle, j, kind)?;
                beam = *need("beam_width", &a.beam_width, j, kind)?;
                if !(cutoff > 0.0 && cutoff <= std::f32::consts::PI) {
                    return Err(Error::invalid(format!("cutoff_angle[{j}] must be in (0, pi] radians, got {cutoff}")));
                }
                if !(beam >= 0.0 && beam <= cutoff) {
                    return Err(Error::invalid(format!("beam_width[{j}] must be in [0, cutoff_angle = {cutoff}] radians, got {beam}")));
                }
            }
            set.push(kind, position, direction, intensity, cutoff, beam);
            set.normal[j] = normal;
            set.geo_normal[j] = geo;
            set.incident[j] = incident;
            set.bsdf[j] = bsdf;
            if let Some(patches) = &a.patch {
                let c = patches[j];
                super::patch::check(j, &c)?;
                if kind == LightKind::OrientedPoint {
                    set.patch[j] = c;
                }
            }
            if let Some(radii) = &a.vsl_radius {
                let r = radii[j];
                if !(r >= 0.0 && r.is_finite()) {
                    return Err(Error::invalid(format!("vsl_radius[{j}] must be finite and >= 0 (m; 0 = a point VPL), got {r}")));
                }
                if kind == LightKind::Vpl {
                    set.vsl_radius[j] = r;
                }
            }
            if let Some(depths) = &a.vpl_depth {
                if kind == LightKind::Vpl {
                    set.set_vpl_depth(j, depths[j]).map_err(|_| {
                        Error::invalid(format!("vpl_depth[{j}] must be >= 1 for a VPL (its bounce from the light), got {}", depths[j]))
                    })?;
                }
            }
        }
        Ok(set)
    }

    /// The lights `idx` (any order, repeats allowed) as a new set of the same scene.
    pub fn select(&self, idx: &[usize]) -> Result<LightSet> {
        let n = self.len();
        if let Some((k, &j)) = idx.iter().enumerate().find(|(_, &j)| j >= n) {
            return Err(Error::invalid(format!("light index {j} (at position {k}) is out of range for {n} lights")));
        }
        crate::memory::check_host(
            &format!("a LightSet of {} selected lights", idx.len()),
            crate::memory::product(&[idx.len() as u64, crate::memory::HOST_BYTES_PER_LIGHT]),
        )?;
        let mut out = LightSet::new(self.scene_center, self.scene_radius);
        out.vpl_clamp = self.vpl_clamp;
        out.kind = idx.iter().map(|&j| self.kind[j]).collect();
        out.position = idx.iter().map(|&j| self.position[j]).collect();
        out.direction = idx.iter().map(|&j| self.direction[j]).collect();
        out.intensity = idx.iter().map(|&j| self.intensity[j]).collect();
        out.normal = idx.iter().map(|&j| self.normal[j]).collect();
        out.geo_normal = idx.iter().map(|&j| self.geo_normal[j]).collect();
        out.incident = idx.iter().map(|&j| self.incident[j]).collect();
        out.bsdf = idx.iter().map(|&j| self.bsdf[j]).collect();
        out.cutoff_angle = idx.iter().map(|&j| self.cutoff_angle[j]).collect();
        out.beam_width = idx.iter().map(|&j| self.beam_width[j]).collect();
        out.spot_texture = idx.iter().map(|&j| self.spot_texture[j].clone()).collect();
        out.patch = idx.iter().map(|&j| self.patch[j]).collect();
        // A subset no longer covers its emitters with equal-area strata: no glossy MIS for its lights.
        out.mis_measure = vec![0.0; idx.len()];
        out.mis_mesh = vec![-1; idx.len()];
        out.vsl_radius = idx.iter().map(|&j| self.vsl_radius[j]).collect();
        out.vpl_depth = idx.iter().map(|&j| self.vpl_depth[j]).collect();
        Ok(out)
    }

    /// All lights of `sets`, in order. The sets must belong to one scene (equal bounding spheres) and,
    /// among those holding VPLs, have one `vpl_clamp`.
    pub fn concat(sets: &[&LightSet]) -> Result<LightSet> {
        let Some(first) = sets.first() else {
            return Err(Error::invalid("concat needs at least one LightSet, got 0"));
        };
        let mut clamp: Option<f32> = None;
        for (k, s) in sets.iter().enumerate() {
            if s.scene_center != first.scene_center || s.scene_radius != first.scene_radius {
                return Err(Error::invalid(format!(
                    "LightSet {k} belongs to another scene (bounding sphere centre {:?}, radius {}; set 0: {:?}, {})",
                    s.scene_center.to_array(),
                    s.scene_radius,
                    first.scene_center.to_array(),
                    first.scene_radius
                )));
            }
            if s.kind.contains(&LightKind::Vpl) {
                match clamp {
                    Some(c) if c != s.vpl_clamp => {
                        return Err(Error::invalid(format!(
                            "LightSet {k} has VPLs with vpl_clamp {} but an earlier set's VPLs have {c}",
                            s.vpl_clamp
                        )))
                    }
                    _ => clamp = Some(s.vpl_clamp),
                }
            }
        }
        let mut out = LightSet::new(first.scene_center, first.scene_radius);
        out.vpl_clamp = clamp.unwrap_or(first.vpl_clamp);
        for s in sets {
            out.extend(s)?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
