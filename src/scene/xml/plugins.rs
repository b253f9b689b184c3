//! Stage 2 of loading: object nodes -> `Bsdf`, `Texture`, `Mesh`, `Emitter`, `Camera`, with the
//! defaults of Mitsuba 3.9.1's plugins (`src/bsdfs/*.cpp`, `src/textures/*.cpp`, `src/emitters/*.cpp`,
//! `src/shapes/*.cpp`, `src/sensors/perspective.cpp`, `src/render/sensor.cpp`).
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
use crate::scene::transform;
use crate::scene::types::*;
use crate::scene::{mesh, texture};
use glam::{DMat4, DVec3, Mat4, Vec3};
use std::collections::HashMap;
use std::path::PathBuf;

/// Film size when the file gives none (Mitsuba's `hdrfilm` defaults).
const DEFAULT_FILM_SIZE: (i64, i64) = (768, 576);

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
    default_bsdf: Option<usize>,
    /// Area emitter nodes already attached to a shape (node -> where).
    attached: HashMap<usize, Location>,
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

fn unknown_plugin(p: &Props) -> Error {
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

    fn filename(&self, p: &mut Props, what: &str) -> Result<(PathBuf, Location)> {
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
    fn check_emitter_texture(&self, t: usize, what: &str) -> Result<()> {
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

    /// A colour that must be constant (emitters, checkerboard colours).
    fn constant_color(&mut self, p: &mut Props, name: &str, default: f32) -> Result<Vec3> {
        if let Some(r) = p.named_object(name)? {
            return Err(Error::scene(
                &r.loc,
                format!("\"{name}\" of {} must be a constant colour (textures are not supported here)", p.what()),
            ));
        }
        Ok(p.color_prop(name)?.unwrap_or(Vec3::splat(default)))
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

    // ---- shapes ----

    /// Builds one top-level `<shape>` into `meshes` (and its area emitter into `area_emitters`);
    /// `shapegroup` and `instance` are handled in `instancing.rs`.
    pub fn shape(&mut self, node: usize) -> Result<()> {
        match self.doc.nodes[node].plugin.as_str() {
            "shapegroup" => self.shapegroup(node),
            "instance" => self.instance(node),
            _ => self.shape_in(node, &transform::Affine::IDENTITY, None),
        }
    }

    /// Builds a shape placed by `outer * to_world`; `instance` names the instance it belongs to (its
    /// mesh id becomes `"<instance>/<shape id>"`).
    pub(super) fn shape_in(&mut self, node: usize, outer: &transform::Affine, instance: Option<&str>) -> Result<()> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        let k = self.meshes.len();
        let to_world_affine = *outer * p.affine("to_world")?.unwrap_or(transform::Affine::IDENTITY);
        let to_world = to_world_affine.matrix;
        let flip_normals = p.bool("flip_normals", false)?;
        let plugin = p.node.plugin.as_str();
        // Mitsuba 3.9.1 meshes (these read face_normals); sphere and disk are analytic there.
        let is_mesh = matches!(plugin, "obj" | "ply" | "cube" | "rectangle" | "serialized");
        let face_normals = if is_mesh { p.bool("face_normals", false)? } else { false };
        let (kind, data, world_from_local) = match plugin {
            "obj" | "ply" => {
                let (path, floc) = self.filename(&mut p, &format!("{plugin} shape"))?;
                let mut data = if plugin == "obj" { mesh::load_obj(&path, &floc)? } else { mesh::load_ply(&path, &floc)? };
                // `load_*` apply Mitsuba's default (OBJ: flip, PLY: no flip); undo/apply on request.
                let default_flip = plugin == "obj";
                if p.bool("flip_tex_coords", default_flip)? != default_flip {
                    data.uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                }
                let kind = if plugin == "obj" { ShapeKind::Obj } else { ShapeKind::Ply };
                (kind, data, to_world)
            }
            "rectangle" => (ShapeKind::Rectangle, mesh::rectangle(), to_world),
            "cube" => (ShapeKind::Cube, mesh::cube(), to_world),
            "disk" => (ShapeKind::Disk, mesh::disk(), to_world),
            "sphere" => {
                let center = p.vector("center")?.unwrap_or(DVec3::ZERO);
                let radius = p.float("radius", 1.0)?;
                let m = to_world * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
                let cols = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate()];
                let l = cols.map(|c| c.length());
                let uniform = (l[1] - l[0]).abs() <= 1e-5 * l[0] && (l[2] - l[0]).abs() <= 1e-5 * l[0];
                let orthogonal = (0..3).all(|i| cols[i].dot(cols[(i + 1) % 3]).abs() <= 1e-5 * l[0] * l[0]);
                if !(uniform && orthogonal) || l[0] == 0.0 {
                    return Err(Error::scene(
                        &loc,
                        format!(
                            "sphere: to_world must be a similarity (uniform scale, no shear); axis lengths {:.6}, {:.6}, {:.6}",
                            l[0], l[1], l[2]
                        ),
                    ));
                }
                let mirrored = glam::DMat3::from_mat4(m).determinant() < 0.0;
                let kind = ShapeKind::Sphere {
                    center: m.w_axis.truncate().as_vec3(),
                    radius: l[0] as f32,
                    flip_normals: flip_normals != mirrored,
                };
                (kind, mesh::sphere(), m)
            }
            "serialized" => {
                let (path, floc) = self.filename(&mut p, "serialized shape")?;
                let (shape_index, _) = p.int("shape_index", 0)?;
                (ShapeKind::Serialized, mesh::load_serialized(&path, shape_index, &floc)?, to_world)
            }
            "cylinder" => {
                let radius = p.float("radius", 1.0)?;
                let p0 = p.vector("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = p.vector("p1")?.unwrap_or(DVec3::Z);
                let m = mesh::cylinder_to_world(to_world, p0, p1, radius)
                    .ok_or_else(|| Error::scene(&loc, format!("cylinder: p0 {p0} and p1 {p1} must differ")))?;
                let mut data = mesh::cylinder();
                if glam::DMat3::from_mat4(m).determinant() < 0.0 {
                    // A mirroring to_world: Mitsuba flips its normals back outward (cylinder.cpp, `S[0][0] <= 0`).
                    data.indices.iter_mut().for_each(|t| t.swap(1, 2));
                }
                (ShapeKind::Cylinder, data, m)
            }
            _ => return Err(unknown_plugin(&p)),
        };
        // Children: one BSDF and at most one area emitter.
        let mut bsdf = None;
        let mut emitter_node = None;
        let (mut interior, mut exterior) = (None, None);
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            match n.class.as_str() {
                "medium" if self.media_policy == super::MediaPolicy::Follow => {
                    let slot = match r.name.as_deref() {
                        Some("interior") => &mut interior,
                        Some("exterior") => &mut exterior,
                        other => {
                            return Err(Error::scene(
                                &r.loc,
                                format!("a medium inside a shape must be named \"interior\" or \"exterior\", got {other:?}"),
                            ))
                        }
                    };
                    if slot.is_some() {
                        return Err(Error::scene(
                            &r.loc,
                            format!("only a single {} medium can be given per shape", r.name.as_deref().unwrap_or("")),
                        ));
                    }
                    *slot = Some(self.medium(r.node)?);
                }
                "bsdf" if bsdf.is_none() => bsdf = Some(self.bsdf(r.node)?),
                "bsdf" => return Err(Error::scene(&r.loc, "only a single BSDF can be given per shape")),
                "emitter" if emitter_node.is_none() => emitter_node = Some(r),
                "emitter" => return Err(Error::scene(&r.loc, "only a single emitter can be given per shape")),
                other => {
                    return Err(Error::scene(&r.loc, format!("unsupported <{other} type=\"{}\"> inside a shape", n.plugin)));
                }
            }
        }
        let id = p.node.id.clone().unwrap_or_else(|| format!("shape_{k}"));
        let id = match instance {
            Some(inst) => format!("{inst}/{id}"),
            None => id,
        };
        p.finish()?;
        let bsdf = match bsdf {
            Some(b) => b,
            None => *self.default_bsdf.get_or_insert_with(|| {
                self.bsdfs.push(Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) });
                self.bsdfs.len() - 1
            }),
        };
        // Normals as Mitsuba transforms them (`transform::Affine`); the sphere's and the cylinder's
        // tessellations are ours, placed by their own matrix (radius, p0/p1 folded in): its inverse transpose.
        let normal_from_local = match kind {
            ShapeKind::Sphere { .. } | ShapeKind::Cylinder => glam::DMat3::from_mat4(world_from_local).inverse().transpose(),
            _ => glam::DMat3::from_mat4(to_world_affine.inverse_transpose),
        };
        let world_from_local: Mat4 = transform::to_f32(&world_from_local);
        let (positions, normals, uvs, indices) =
            mesh::finalize_with_normal_matrix(data, world_from_local, normal_from_local.as_mat3(), face_normals, flip_normals, &loc)?;
        if indices.is_empty() {
            if let Some(r) = &emitter_node {
                // Mitsuba fails too ("DiscreteDistribution: no probability mass found").
                return Err(Error::scene(
                    &r.loc,
                    format!("area emitter on a degenerate shape \"{id}\" ({loc}): all its triangles have zero area"),
                ));
            }
            self.warnings.push(format!("{loc}: shape \"{id}\": all triangles have zero area; the shape adds nothing (as in Mitsuba)"));
        }
        let emitter = match emitter_node {
            Some(r) => {
                let e = self.area_emitter(&r, k)?;
                self.area_emitters.push(e);
                Some(self.area_emitters.len() - 1)
            }
            None => None,
        };
        if interior.is_some() || exterior.is_some() {
            self.shape_media.push((self.meshes.len(), interior, exterior));
        }
        self.meshes.push(Mesh { id, kind, positions, normals, uvs, indices, face_normals, bsdf, emitter, loc });
        Ok(())
    }

    fn area_emitter(&mut self, r: &ObjectRef, mesh: usize) -> Result<Emitter> {
        let mut p = Props::new(self.doc, r.node);
        if p.node.plugin != "area" {
            return Err(Error::scene(&r.loc, format!("a shape's emitter must be type=\"area\", got \"{}\"", p.node.plugin)));
        }
        if let Some(prev) = self.attached.insert(r.node, r.loc.clone()) {
            return Err(Error::scene(&r.loc, format!("area emitter already attached to another shape at {prev}")));
        }
        if p.has("to_world") {
            return Err(Error::scene(p.loc(), "area emitter: a to_world transform is not allowed (the shape's applies)"));
        }
        let (radiance, texture) = match self.unbounded_param(&mut p, "radiance", 1.0)? {
            Param::Value(v) => (v, None),
            Param::Texture(t) => {
                self.check_emitter_texture(t, "area emitter radiance texture")?;
                (Vec3::ONE, Some(t))
            }
        };
        let loc = p.loc().clone();
        p.finish()?;
        Ok(Emitter::Area { mesh, radiance, texture, loc })
    }

    /// True if this top-level emitter node was attached to a shape.
    pub fn is_attached(&self, node: usize) -> bool {
        self.attached.contains_key(&node)
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
                Emitter::Point { position, intensity: self.constant_color(&mut p, "intensity", 1.0)?, loc }
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
                let intensity = self.constant_color(&mut p, "intensity", 1.0)?;
                let cutoff = p.float("cutoff_angle", 20.0)?;
                let beam = p.float("beam_width", cutoff * 0.75)?;
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
                let irradiance = self.constant_color(&mut p, "irradiance", 1.0)?;
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
            "constant" => Emitter::Constant { radiance: self.constant_color(&mut p, "radiance", 1.0)?, loc },
            _ => return Err(unknown_plugin(&p)),
        };
        p.finish()?;
        self.emitters.push(e);
        Ok(())
    }

    // ---- sensor ----

    /// The camera of a `<sensor type="perspective">` node.
    pub fn sensor(&mut self, node: usize) -> Result<Camera> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        if p.node.plugin != "perspective" {
            return Err(unknown_plugin(&p));
        }
        let mut film = None;
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            match n.class.as_str() {
                "film" if film.is_none() => film = Some(r.node),
                "film" => return Err(Error::scene(&r.loc, "only a single film can be given per sensor")),
                "sampler" => {}
                other => return Err(Error::scene(&r.loc, format!("unsupported <{other} type=\"{}\"> inside a sensor", n.plugin))),
            }
        }
        let f = self.film(film, &loc)?;
        let aspect = f.full.0 as f64 / f.full.1 as f64;
        let mut fov_x = parse_fov(&mut p, aspect)?;
        let near_clip = p.float("near_clip", 1e-2)?;
        let far_clip = p.float("far_clip", 1e4)?;
        if near_clip <= 0.0 || near_clip >= far_clip {
            return Err(Error::scene(&loc, format!("near_clip ({near_clip}) must be > 0 and < far_clip ({far_clip})")));
        }
        let mut offset = glam::DVec2::new(p.float("principal_point_offset_x", 0.0)?, p.float("principal_point_offset_y", 0.0)?);
        if !offset.is_finite() {
            return Err(Error::scene(&loc, format!("principal_point_offset {offset} must be finite")));
        }
        if let Some((ox, oy, cw, ch)) = f.crop {
            // The crop window as a camera of its own: the ray through crop position (px, py) is the full
            // film's ray through (px + ox, py + oy) (Mitsuba's `sample_ray` with a crop window). A film of
            // cw/W the width (tan(fov/2) scaled by it) whose principal point is shifted to match.
            let (w, h) = (f.full.0 as f64, f.full.1 as f64);
            let (cw, ch) = (cw as f64, ch as f64);
            fov_x = 2.0 * ((fov_x.to_radians() * 0.5).tan() * cw / w).atan().to_degrees();
            offset = glam::DVec2::new(
                0.5 * (1.0 - w / cw * (1.0 - 2.0 * (ox as f64 / w + offset.x))),
                0.5 * (1.0 - h / ch * (1.0 - 2.0 * (oy as f64 / h + offset.y))),
            );
        }
        let principal_point_offset = offset.as_vec2();
        let (width, height) = f.size;
        let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        if transform::has_scale(&to_world) {
            return Err(Error::scene(&loc, "scale factors in the camera to_world transformation are not allowed"));
        }
        p.finish()?;
        Ok(Camera {
            world_from_camera: transform::to_f32(&to_world),
            fov_x: (fov_x as f32).to_radians(),
            near_clip: near_clip as f32,
            far_clip: far_clip as f32,
            width,
            height,
            principal_point_offset,
            loc,
        })
    }

    /// Film of a sensor: `hdrfilm` width/height (default 768x576) and its crop window
    /// (`crop_offset_x/y`, `crop_width/height`, as Mitsuba's `Film`: the image is the window); the image
    /// size is replaced by `size_override` (the window then keeps its share of the film).
    /// `banner` (Mitsuba 0.x's logo switch, any type) is accepted and ignored, as Mitsuba 3.9.1 does;
    /// `gamma` (an `ldrfilm` property of Mitsuba 0.x) is refused, as Mitsuba 3.9.1 refuses it.
    fn film(&mut self, film: Option<usize>, sensor_loc: &Location) -> Result<Film> {
        let (mut w, mut h, mut loc) = (DEFAULT_FILM_SIZE.0, DEFAULT_FILM_SIZE.1, sensor_loc.clone());
        let mut crop = None;
        if let Some(node) = film {
            let mut p = Props::new(self.doc, node);
            if p.node.plugin != "hdrfilm" {
                return Err(unknown_plugin(&p));
            }
            loc = p.loc().clone();
            (w, _) = p.int("width", w)?;
            (h, _) = p.int("height", h)?;
            if ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"].iter().any(|n| p.has(n)) {
                let (ox, _) = p.int("crop_offset_x", 0)?;
                let (oy, _) = p.int("crop_offset_y", 0)?;
                let (cw, _) = p.int("crop_width", w)?;
                let (ch, _) = p.int("crop_height", h)?;
                let inside = |o: i64, c: i64, n: i64| o >= 0 && c > 0 && n > 0 && o.checked_add(c).is_some_and(|e| e <= n);
                if !inside(ox, cw, w) || !inside(oy, ch, h) || w > u32::MAX as i64 || h > u32::MAX as i64 {
                    return Err(Error::scene(
                        &loc,
                        format!(
                            "invalid crop window: offset ({ox}, {oy}), size {cw}x{ch} must lie inside the {w}x{h} film \
                             (offsets >= 0, sizes > 0)"
                        ),
                    ));
                }
                if (ox, oy, cw, ch) != (0, 0, w, h) {
                    crop = Some((ox as u32, oy as u32, cw as u32, ch as u32));
                }
            }
            if let Some(g) = p.node.props.iter().find(|q| q.name == "gamma") {
                return Err(Error::scene(
                    &g.loc,
                    "property \"gamma\" of the film is not supported: it belongs to Mitsuba 0.x's ldrfilm \
                     (Mitsuba 3.9.1 refuses it in an hdrfilm too); remove it, the renders are linear",
                ));
            }
            p.ignore(&["banner"]);
            for r in p.objects()? {
                let n = &self.doc.nodes[r.node];
                if n.class != "rfilter" {
                    return Err(Error::scene(&r.loc, format!("unsupported <{} type=\"{}\"> inside a film", n.class, n.plugin)));
                }
            }
            p.finish()?;
        }
        let (mut iw, mut ih) = crop.map(|(_, _, cw, ch)| (cw as i64, ch as i64)).unwrap_or((w, h));
        if let Some((ow, oh)) = self.size_override {
            (iw, ih) = (ow as i64, oh as i64);
        }
        if iw <= 0 || ih <= 0 || iw > u32::MAX as i64 || ih > u32::MAX as i64 {
            return Err(Error::scene(&loc, format!("film size {iw}x{ih}: width and height must be positive")));
        }
        let size = (iw as u32, ih as u32);
        // A crop window is a share of the file's film (whose aspect sets fov_axis); else the image is the film.
        let full = if crop.is_some() { (w as u32, h as u32) } else { size };
        Ok(Film { full, crop, size })
    }
}

/// A sensor's film: the full film size (the image size when there is no crop window), its crop window (offset x, y, width, height) when it is not the
/// whole film, and the image size (the crop window's, or `size_override`).
struct Film {
    full: (u32, u32),
    crop: Option<(u32, u32, u32, u32)>,
    size: (u32, u32),
}

/// Horizontal field of view in degrees (Mitsuba's `parse_fov`, `src/render/sensor.cpp`).
fn parse_fov(p: &mut Props, aspect: f64) -> Result<f64> {
    let loc = p.loc().clone();
    let (fov, axis) = match p.opt_float("fov")? {
        Some(fov) => {
            if p.has("focal_length") {
                return Err(Error::scene(&loc, "give either fov or focal_length, not both"));
            }
            let axis = p.string("fov_axis")?.map(|(s, _)| s.to_lowercase()).unwrap_or_else(|| "x".into());
            let axis = match axis.as_str() {
                "smaller" => if aspect > 1.0 { "y" } else { "x" }.to_string(),
                "larger" => if aspect > 1.0 { "x" } else { "y" }.to_string(),
                _ => axis,
            };
            (fov, axis)
        }
        None => {
            let f = p.string("focal_length")?.map(|(s, _)| s).unwrap_or("50mm");
            let v = f.strip_suffix("mm").unwrap_or(f);
            let v: f64 = v
                .trim()
                .parse()
                .map_err(|_| Error::scene(&loc, format!("could not parse focal_length \"{f}\" (must be of the form <x>mm)")))?;
            (2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * v)).atan().to_degrees(), "diagonal".to_string())
        }
    };
    let fov_x = match axis.as_str() {
        "x" => fov,
        "y" => (2.0 * ((0.5 * fov).to_radians().tan() * aspect).atan()).to_degrees(),
        "diagonal" => {
            let diagonal = 2.0 * (0.5 * fov).to_radians().tan();
            let width = diagonal / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (width * 0.5).atan()).to_degrees()
        }
        other => {
            return Err(Error::scene(&loc, format!("fov_axis \"{other}\" must be one of smaller, larger, diagonal, x, y")));
        }
    };
    if !(fov_x > 0.0 && fov_x < 180.0) {
        return Err(Error::scene(&loc, format!("the horizontal field of view ({fov_x} degrees) must be in (0, 180)")));
    }
    Ok(fov_x)
}
