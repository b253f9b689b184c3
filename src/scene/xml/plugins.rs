//! Stage 2 of loading: object nodes -> `Bsdf`, `Texture`, `Emitter` here, `Mesh` in `shapes.rs`, `Camera`
//! in `sensor.rs` (the `Builder` they all extend), with the defaults of Mitsuba 3.9.1's plugins
//! (`src/bsdfs/*.cpp`, `src/textures/*.cpp`, `src/emitters/*.cpp`, `src/shapes/*.cpp`,
//! `src/sensors/perspective.cpp`, `src/render/sensor.cpp`).
//!
//! BSDFs and textures are built once per node (memoised by node index), so shapes sharing a `<ref>` share
//! one `Scene::bsdfs` entry. Deviations from Mitsuba:
//! - a sphere whose `to_world` has a non-uniform scale or shear is an error (Mitsuba only warns);
//! - shapes without a BSDF share one default `diffuse` (reflectance 0.5) entry;
//! - emissive parameters (`intensity`, `irradiance`) must be constant (no textures); an area emitter's
//!   `radiance` may be a texture.
use super::materials;
use super::parse::{Document, Value};
use super::props::{ObjectRef, Props};
use crate::error::{Error, Location, Result};
use crate::scene::texture;
use crate::scene::transform;
use crate::scene::types::*;
use glam::{DMat4, DVec3, Vec3};
use std::collections::HashMap;
use std::path::PathBuf;

/// Film size when the file gives none (Mitsuba's `hdrfilm` defaults).
pub(super) const DEFAULT_FILM_SIZE: (i64, i64) = (768, 576);

/// Everything built so far.
pub struct Builder<'a> {
    pub doc: &'a Document,
    pub size_override: Option<(u32, u32)>,
    pub bsdfs: Vec<Bsdf>,
    pub textures: Vec<Texture>,
    pub meshes: Vec<Mesh>,
    /// Top-level emitters in document order.
    pub emitters: Vec<Emitter>,
    /// Area emitters of shapes, in shape order (`Emitter::Area::mesh` is set).
    pub area_emitters: Vec<Emitter>,
    bsdf_memo: HashMap<usize, usize>,
    texture_memo: HashMap<usize, usize>,
    /// The image file of each bitmap texture (by texture index), for messages.
    texture_paths: HashMap<usize, PathBuf>,
    pub(super) default_bsdf: Option<usize>,
    /// Area emitter nodes already attached to a shape (node -> where).
    pub(super) attached: HashMap<usize, Location>,
    /// Things Mitsuba only warns about (`Scene::warnings`).
    pub warnings: Vec<String>,
    /// How `<medium>`s are taken (`LoadOptions::media`).
    pub media_policy: super::MediaPolicy,
    /// Media built so far (shared by reference: one entry per node).
    pub media: Vec<crate::scene::Medium>,
    medium_memo: HashMap<usize, usize>,
    /// (mesh index, interior, exterior) of every shape with a medium.
    pub shape_media: Vec<(usize, Option<usize>, Option<usize>)>,
}

/// An emitted value `v` of property `name`, refused with the property's file and line unless every channel is
/// finite and >= 0 as float32 (a NaN, negative or overflowing radiance would otherwise drop the emitter, or
/// reach the light set's checks without a location).
pub(super) fn emitted_value(p: &mut Props, name: &str, v: Vec3) -> Result<Vec3> {
    if v.is_finite() && v.min_element() >= 0.0 {
        return Ok(v);
    }
    let loc = p.loc_of(name);
    Err(Error::scene(&loc, format!("{}: {name} must be finite and >= 0 in every channel (float32), got {:?}", p.what(), v.to_array())))
}

/// Refuse an emitter texture with NaN, infinite or negative texels (radiance must be finite and >= 0;
/// reading them as 0 would silently change the lighting): the error names the file, how many texels are
/// bad and the first one (index in row-major order and its value).
fn check_emitter_texels(what: &str, path: &std::path::Path, loc: &Location, data: &[glam::Vec3]) -> Result<()> {
    let bad = |t: &glam::Vec3| !(t.is_finite() && t.min_element() >= 0.0);
    let count = data.iter().filter(|t| bad(t)).count();
    if let Some((i, t)) = data.iter().enumerate().find(|(_, t)| bad(t)) {
        return Err(Error::scene(
            loc,
            format!(
                "{what} {}: {count} of {} texels are NaN, infinite or negative (the first: texel {i} = {:?}); an \
                 emitter's radiance must be finite and >= 0: fix the image",
                path.display(),
                data.len(),
                t.to_array()
            ),
        ));
    }
    Ok(())
}

pub(super) fn unknown_plugin(p: &Props) -> Error {
    Error::scene(p.loc(), format!("unsupported {} plugin type=\"{}\"", p.node.class, p.node.plugin))
}

impl<'a> Builder<'a> {
    pub fn new(doc: &'a Document, size_override: Option<(u32, u32)>) -> Self {
        Builder {
            doc,
            size_override,
            bsdfs: Vec::new(),
            textures: Vec::new(),
            meshes: Vec::new(),
            emitters: Vec::new(),
            area_emitters: Vec::new(),
            bsdf_memo: HashMap::new(),
            texture_memo: HashMap::new(),
            texture_paths: HashMap::new(),
            default_bsdf: None,
            attached: HashMap::new(),
            warnings: Vec::new(),
            media_policy: super::MediaPolicy::default(),
            media: Vec::new(),
            medium_memo: HashMap::new(),
            shape_media: Vec::new(),
        }
    }

    /// A `<medium type="homogeneous">` (Mitsuba 3.9.1 `src/media/homogeneous.cpp`): `sigma_t` (default 1)
    /// and `albedo` (default 0.75) as a `<float>`, an `<rgb>` in [0, 1] (Mitsuba's RGB variants refuse
    /// others: "Invalid RGB reflectance value") or a `<spectrum>`, times `scale` (default 1);
    /// `sample_emitted` and a `<phase>` (isotropic, hg) are accepted (they only matter for scattering, which
    /// is not modelled). Memoised per node (media shared by `<ref>` are one medium).
    /// Errors: other medium types, volume-textured coefficients, negative or non-finite values.
    pub fn medium(&mut self, node: usize) -> Result<usize> {
        if let Some(&i) = self.medium_memo.get(&node) {
            return Ok(i);
        }
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        if p.node.plugin != "homogeneous" {
            return Err(Error::scene(
                &loc,
                format!("unsupported medium plugin type=\"{}\" (only \"homogeneous\" media are supported)", p.node.plugin),
            ));
        }
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            match (n.class.as_str(), n.plugin.as_str()) {
                ("phase", "isotropic" | "hg") => {
                    let mut q = Props::new(self.doc, r.node);
                    if n.plugin == "hg" {
                        q.float("g", 0.8)?;
                    }
                    q.finish()?;
                }
                (class, plugin) => {
                    let what = r.name.as_deref().map(|x| format!(" (\"{x}\")")).unwrap_or_default();
                    return Err(Error::scene(
                        &r.loc,
                        format!(
                            "unsupported <{class} type=\"{plugin}\">{what} inside a homogeneous medium (give sigma_t and albedo as \
                             <float>, <rgb> or <spectrum>; phase functions: isotropic, hg)"
                        ),
                    ));
                }
            }
        }
        let coefficient = |p: &mut Props, name: &str, default: f32| -> Result<Vec3> {
            let ploc = p.node.props.iter().find(|q| q.name == name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
            let is_rgb = p.node.props.iter().any(|q| q.name == name && matches!(q.value, super::parse::Value::Rgb(_)));
            let v = p.color_prop(name)?.unwrap_or(Vec3::splat(default));
            if !v.is_finite() || v.min_element() < 0.0 || (is_rgb && v.max_element() > 1.0) {
                let range =
                    if is_rgb { "in [0, 1] (Mitsuba's RGB variants refuse other <rgb> values; use scale)" } else { "finite and >= 0" };
                return Err(Error::scene(&ploc, format!("medium {name} = {:?} must be {range}", v.to_array())));
            }
            Ok(v)
        };
        let sigma_t = coefficient(&mut p, "sigma_t", 1.0)?;
        let albedo = coefficient(&mut p, "albedo", 0.75)?;
        let scale = p.float("scale", 1.0)?;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(Error::scene(&loc, format!("medium scale = {scale} must be finite and >= 0")));
        }
        p.bool("sample_emitted", true)?;
        p.finish()?;
        self.media.push(crate::scene::Medium { sigma_t: sigma_t * scale as f32, albedo, loc });
        let i = self.media.len() - 1;
        self.medium_memo.insert(node, i);
        Ok(i)
    }

    /// A file named by a plugin: searched in the `<path>` directories, then the scene's directory.
    fn resolve_file(&self, name: &str, loc: &Location) -> Result<PathBuf> {
        let p = PathBuf::from(name);
        if p.is_absolute() {
            return if p.is_file() { Ok(p) } else { Err(Error::FileNotFound { loc: loc.clone(), path: p }) };
        }
        for dir in &self.doc.search_dirs {
            let c = dir.join(&p);
            if c.is_file() {
                return Ok(c);
            }
        }
        let fallback = self.doc.search_dirs.last().cloned().unwrap_or_default().join(&p);
        Err(Error::FileNotFound { loc: loc.clone(), path: fallback })
    }

    pub(super) fn filename(&self, p: &mut Props, what: &str) -> Result<(PathBuf, Location)> {
        let Some((name, loc)) = p.string("filename")? else {
            return Err(Error::scene(p.loc(), format!("{what}: missing <string name=\"filename\">")));
        };
        Ok((self.resolve_file(name, loc)?, loc.clone()))
    }

    pub(super) fn expect_class(&self, r: &ObjectRef, class: &str, role: &str) -> Result<()> {
        let n = &self.doc.nodes[r.node];
        if n.class != class {
            return Err(Error::scene(&r.loc, format!("{role} must be a <{class}>, got <{} type=\"{}\">", n.class, n.plugin)));
        }
        Ok(())
    }

    // ---- textures ----

    /// Index into `textures` of a `<texture>` node.
    pub fn texture(&mut self, node: usize) -> Result<usize> {
        if let Some(&i) = self.texture_memo.get(&node) {
            return Ok(i);
        }
        let mut p = Props::new(self.doc, node);
        let to_uv = transform::to_uv_matrix(&p.transform("to_uv")?.unwrap_or(DMat4::IDENTITY));
        let mut file = None;
        let tex = match p.node.plugin.as_str() {
            "bitmap" => {
                let (path, loc) = self.filename(&mut p, "bitmap texture")?;
                file = Some(path.clone());
                let filter = match p.string("filter_type")? {
                    None | Some(("bilinear", _)) => FilterType::Bilinear,
                    Some(("nearest", _)) => FilterType::Nearest,
                    Some((v, l)) => {
                        return Err(Error::scene(l, format!("invalid filter_type \"{v}\", must be \"nearest\" or \"bilinear\"")));
                    }
                };
                let wrap = match p.string("wrap_mode")? {
                    None | Some(("repeat", _)) => WrapMode::Repeat,
                    Some(("mirror", _)) => WrapMode::Mirror,
                    Some(("clamp", _)) => WrapMode::Clamp,
                    Some((v, l)) => {
                        return Err(Error::scene(l, format!("invalid wrap_mode \"{v}\", must be \"repeat\", \"mirror\" or \"clamp\"")));
                    }
                };
                let raw = p.bool("raw", false)?;
                p.ignore(&["format"]);
                let (width, height, data) = texture::load_bitmap(&path, &loc, raw)?;
                Texture::Bitmap { width, height, data, filter, wrap, to_uv, loc }
            }
            "checkerboard" => {
                let color0 = self.constant_color(&mut p, "color0", 0.4)?;
                let color1 = self.constant_color(&mut p, "color1", 0.2)?;
                Texture::Checkerboard { color0, color1, to_uv }
            }
            _ => return Err(unknown_plugin(&p)),
        };
        p.finish()?;
        self.textures.push(tex);
        let i = self.textures.len() - 1;
        self.texture_memo.insert(node, i);
        if let Some(f) = file {
            self.texture_paths.insert(i, f);
        }
        Ok(i)
    }

    /// The image file of bitmap texture `t` (empty for other textures).
    pub(super) fn texture_path(&self, t: usize) -> PathBuf {
        self.texture_paths.get(&t).cloned().unwrap_or_default()
    }

    /// Refuse an emitter's bitmap texture with NaN, infinite or negative texels (`check_emitter_texels`).
    pub(super) fn check_emitter_texture(&self, t: usize, what: &str) -> Result<()> {
        if let Texture::Bitmap { data, loc, .. } = &self.textures[t] {
            let path = self.texture_paths.get(&t).cloned().unwrap_or_default();
            check_emitter_texels(what, &path, loc, data)?;
        }
        Ok(())
    }

    /// A reflectance parameter: constant, or a nested / referenced texture. Like Mitsuba's
    /// `get_texture`, an `<rgb>` value must lie in [0, 1].
    pub(super) fn param(&mut self, p: &mut Props, name: &str, default: f32) -> Result<Param> {
        let v = self.unbounded_param(p, name, default)?;
        if let (Param::Value(c), Some(prop)) = (v, p.prop(name)) {
            if matches!(prop.value, Value::Rgb(_)) && !(c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                return Err(Error::scene(
                    &prop.loc,
                    format!("invalid RGB reflectance {name}=[{}, {}, {}] in {}: must be in [0, 1]", c.x, c.y, c.z, p.what()),
                ));
            }
        }
        Ok(v)
    }

    /// A parameter without range check (Mitsuba's `get_unbounded_texture`: roughness, eta, k).
    pub(super) fn unbounded_param(&mut self, p: &mut Props, name: &str, default: f32) -> Result<Param> {
        if let Some(r) = p.named_object(name)? {
            self.expect_class(&r, "texture", &format!("\"{name}\" of {}", p.what()))?;
            return Ok(Param::Texture(self.texture(r.node)?));
        }
        Ok(Param::Value(p.color_prop(name)?.unwrap_or(Vec3::splat(default))))
    }

    /// A colour that must be constant (emitters, checkerboard colours, conductor eta and k).
    fn constant_color(&mut self, p: &mut Props, name: &str, default: f32) -> Result<Vec3> {
        if let Some(r) = p.named_object(name)? {
            return Err(Error::scene(
                &r.loc,
                format!("\"{name}\" of {} must be a constant colour (textures are not supported here)", p.what()),
            ));
        }
        Ok(p.color_prop(name)?.unwrap_or(Vec3::splat(default)))
    }

    /// An emitter's constant colour `name` (`intensity`, `irradiance`, a `constant`'s `radiance`): finite and
    /// >= 0 in every channel as float32 (`emitted_value`).
    fn emitted_color(&mut self, p: &mut Props, name: &str, default: f32) -> Result<Vec3> {
        let v = self.constant_color(p, name, default)?;
        emitted_value(p, name, v)
    }

    // ---- BSDFs ----

    pub(super) fn ior(&self, p: &mut Props, name: &str, default: &str) -> Result<f32> {
        if let Some(prop) = p.prop(name) {
            return match &prop.value {
                Value::Float(v) => Ok(*v as f32),
                Value::Int(v) => Ok(*v as f32),
                Value::Str(s) => materials::lookup_ior(s).ok_or_else(|| {
                    Error::scene(&prop.loc, format!("unknown IOR name {name}=\"{s}\"; valid names: {}", materials::ior_names()))
                }),
                other => Err(Error::scene(&prop.loc, format!("{name} must be a <float> or <string>, got <{}>", other.type_name()))),
            };
        }
        Ok(materials::lookup_ior(default).unwrap_or(1.0))
    }

    pub(super) fn distribution(&self, p: &mut Props) -> Result<MicrofacetDistribution> {
        match p.string("distribution")? {
            None => Ok(MicrofacetDistribution::Beckmann),
            Some((v, l)) => match v.to_lowercase().as_str() {
                "beckmann" => Ok(MicrofacetDistribution::Beckmann),
                "ggx" => Ok(MicrofacetDistribution::Ggx),
                _ => Err(Error::scene(l, format!("invalid distribution \"{v}\", must be \"beckmann\" or \"ggx\""))),
            },
        }
    }

    /// eta and k of a conductor: `eta`/`k` or a `material` preset (default "none": eta 0, k 1).
    fn complex_ior(&mut self, p: &mut Props) -> Result<(Vec3, Vec3)> {
        match p.string("material")? {
            Some((m, l)) if m != "none" => {
                if p.has("eta") || p.has("k") {
                    return Err(Error::scene(l, format!("material=\"{m}\": specify either (eta, k) or material, not both")));
                }
                materials::conductor(m).ok_or_else(|| {
                    Error::scene(l, format!("unknown conductor material \"{m}\"; valid names: {}", materials::conductor_names()))
                })
            }
            _ => Ok((self.constant_color(p, "eta", 0.0)?, self.constant_color(p, "k", 1.0)?)),
        }
    }

    /// Index into `bsdfs` of a `<bsdf>` node.
    pub fn bsdf(&mut self, node: usize) -> Result<usize> {
        if let Some(&i) = self.bsdf_memo.get(&node) {
            return Ok(i);
        }
        let mut p = Props::new(self.doc, node);
        let bsdf = match p.node.plugin.as_str() {
            "diffuse" => Bsdf::Diffuse { reflectance: self.param(&mut p, "reflectance", 0.5)? },
            "twosided" => {
                let children = p.objects()?;
                let mut inner = Vec::new();
                for r in &children {
                    self.expect_class(r, "bsdf", "a child of twosided")?;
                    let i = self.bsdf(r.node)?;
                    if let Bsdf::RoughDielectric { .. } | Bsdf::ThinDielectric { .. } = self.bsdfs[i] {
                        // Mitsuba's twosided: "Only materials without a transmission component can be nested!"
                        return Err(Error::scene(
                            &r.loc,
                            format!("{}: a nested BSDF with transmission (roughdielectric, thindielectric) is not allowed (it is two-sided already)", p.what()),
                        ));
                    }
                    inner.push(i);
                }
                match inner[..] {
                    [front] => Bsdf::TwoSided { front, back: front },
                    [front, back] => Bsdf::TwoSided { front, back },
                    [] => return Err(Error::scene(p.loc(), "twosided: a nested BSDF is required")),
                    _ => return Err(Error::scene(p.loc(), format!("twosided: at most two nested BSDFs, got {}", inner.len()))),
                }
            }
            kind @ ("plastic" | "roughplastic") => {
                let int_ior = self.ior(&mut p, "int_ior", "polypropylene")?;
                let ext_ior = self.ior(&mut p, "ext_ior", "air")?;
                if int_ior < 0.0 || ext_ior < 0.0 || int_ior == ext_ior {
                    return Err(Error::scene(
                        p.loc(),
                        format!("{kind}: int_ior ({int_ior}) and ext_ior ({ext_ior}) must be positive and differ"),
                    ));
                }
                let diffuse_reflectance = self.param(&mut p, "diffuse_reflectance", 0.5)?;
                let specular_reflectance = self.param(&mut p, "specular_reflectance", 1.0)?;
                let nonlinear = p.bool("nonlinear", false)?;
                if kind == "plastic" {
                    Bsdf::Plastic { diffuse_reflectance, specular_reflectance, int_ior, ext_ior, nonlinear }
                } else {
                    let distribution = self.distribution(&mut p)?;
                    if p.has("alpha_u") || p.has("alpha_v") {
                        return Err(Error::scene(p.loc(), "roughplastic does not support anisotropic roughness (alpha_u/alpha_v)"));
                    }
                    let alpha = p.float("alpha", 0.1)? as f32;
                    Bsdf::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, alpha, int_ior, ext_ior, nonlinear }
                }
            }
            "conductor" => {
                let (eta, k) = self.complex_ior(&mut p)?;
                let specular_reflectance = self.param(&mut p, "specular_reflectance", 1.0)?;
                Bsdf::Conductor { eta, k, specular_reflectance }
            }
            "roughconductor" => {
                let (eta, k) = self.complex_ior(&mut p)?;
                let distribution = self.distribution(&mut p)?;
                let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
                    if !(p.has("alpha_u") && p.has("alpha_v")) {
                        return Err(Error::scene(p.loc(), "roughconductor: both alpha_u and alpha_v must be given"));
                    }
                    if p.has("alpha") {
                        return Err(Error::scene(p.loc(), "roughconductor: give either alpha or alpha_u/alpha_v, not both"));
                    }
                    (self.unbounded_param(&mut p, "alpha_u", 0.1)?, self.unbounded_param(&mut p, "alpha_v", 0.1)?)
                } else {
                    let a = self.unbounded_param(&mut p, "alpha", 0.1)?;
                    (a, a)
                };
                let specular_reflectance = self.param(&mut p, "specular_reflectance", 1.0)?;
                Bsdf::RoughConductor { distribution, alpha_u, alpha_v, eta, k, specular_reflectance }
            }
            "dielectric" => {
                let int_ior = self.ior(&mut p, "int_ior", "bk7")?;
                let ext_ior = self.ior(&mut p, "ext_ior", "air")?;
                if int_ior < 0.0 || ext_ior < 0.0 || int_ior == ext_ior {
                    return Err(Error::scene(
                        p.loc(),
                        format!("dielectric: int_ior ({int_ior}) and ext_ior ({ext_ior}) must be positive and differ"),
                    ));
                }
                for n in ["specular_reflectance", "specular_transmittance"] {
                    if let Param::Value(v) = self.param(&mut p, n, 1.0)? {
                        if v != Vec3::ONE {
                            return Err(Error::scene(p.loc(), format!("dielectric: {n} other than 1 is not supported")));
                        }
                    } else {
                        return Err(Error::scene(p.loc(), format!("dielectric: a textured {n} is not supported")));
                    }
                }
                Bsdf::Dielectric { int_ior, ext_ior }
            }
            "roughdielectric" => self.roughdielectric(&mut p)?,
            "thindielectric" => self.thindielectric(&mut p)?,
            "principled" => self.principled(&mut p)?,
            "blendbsdf" => self.blendbsdf(&mut p)?,
            "bumpmap" | "normalmap" => self.perturbation(&mut p)?,
            "mask" => self.mask(&mut p)?,
            _ => return Err(unknown_plugin(&p)),
        };
        p.finish()?;
        self.bsdfs.push(bsdf);
        let i = self.bsdfs.len() - 1;
        self.bsdf_memo.insert(node, i);
        Ok(i)
    }

    // ---- emitters ----

    /// Builds a top-level, non-area `<emitter>` into `emitters`.
    pub fn emitter(&mut self, node: usize) -> Result<()> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        let to_world = p.transform("to_world")?;
        let e = match p.node.plugin.as_str() {
            "point" => {
                let position = match (p.vector("position")?, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(Error::scene(&loc, "point: give either position or to_world, not both"));
                    }
                    (Some(v), None) => v.as_vec3(),
                    (None, m) => m.unwrap_or(DMat4::IDENTITY).w_axis.truncate().as_vec3(),
                };
                Emitter::Point { position, intensity: self.emitted_color(&mut p, "intensity", 1.0)?, loc }
            }
            "spot" => {
                // Mitsuba requires a spatially varying projected texture (a bitmap or checkerboard).
                let texture = match self.unbounded_param(&mut p, "texture", 1.0)? {
                    Param::Texture(t) => {
                        self.check_emitter_texture(t, "spot texture")?;
                        Some(t)
                    }
                    Param::Value(_) if p.has("texture") => {
                        return Err(Error::scene(&loc, "spot: \"texture\" must be spatially varying (a bitmap or checkerboard texture)"));
                    }
                    Param::Value(_) => None,
                };
                let intensity = self.emitted_color(&mut p, "intensity", 1.0)?;
                let cutoff = p.float("cutoff_angle", 20.0)?;
                // Mitsuba accepts a beam wider than the cutoff: every direction inside the cutoff is then in the
                // beam (falloff 1), which is the beam at the cutoff here.
                let beam = p.float("beam_width", cutoff * 0.75)?.min(cutoff);
                Emitter::Spot {
                    world_from_light: transform::to_f32(&to_world.unwrap_or(DMat4::IDENTITY)),
                    intensity,
                    cutoff_angle: (cutoff as f32).to_radians(),
                    beam_width: (beam as f32).to_radians(),
                    texture,
                    loc,
                }
            }
            "directional" => {
                let direction = match (p.vector("direction")?, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(Error::scene(&loc, "directional: give either direction or to_world, not both"));
                    }
                    (Some(d), None) => d,
                    (None, m) => m.unwrap_or(DMat4::IDENTITY).transform_vector3(DVec3::Z),
                };
                if direction.length_squared() == 0.0 {
                    return Err(Error::scene(&loc, "directional: direction must not be zero"));
                }
                let irradiance = self.emitted_color(&mut p, "irradiance", 1.0)?;
                Emitter::Directional { direction: direction.normalize().as_vec3(), irradiance, loc }
            }
            "envmap" => {
                let (path, floc) = self.filename(&mut p, "envmap")?;
                let scale = p.float("scale", 1.0)? as f32;
                let (w, h, data) = texture::load_bitmap(&path, &floc, false)?;
                check_emitter_texels("envmap", &path, &floc, &data)?;
                // Mitsuba pads every environment map to at least 2 x 3 texels (`crate::image::pad`).
                let (width, height, data) = crate::image::pad::pad_to(w, h, data, 2, 3);
                // Mitsuba looks up `to_world.inverse() * d`; keep the matrix whose inverse that is.
                let env_t = p.affine("to_world")?.unwrap_or(transform::Affine::IDENTITY);
                let world_from_env = DMat4::from_mat3(env_t.inverse_linear().inverse()).as_mat4();
                Emitter::EnvMap { map: EnvMap { width, height, data, scale, world_from_env }, loc }
            }
            "constant" => Emitter::Constant { radiance: self.emitted_color(&mut p, "radiance", 1.0)?, loc },
            _ => return Err(unknown_plugin(&p)),
        };
        p.finish()?;
        self.emitters.push(e);
        Ok(())
    }
}
