//! Mitsuba 3 XML reader: `load_scene` turns a scene file (and what it includes) into a [`Scene`],
//! following Mitsuba 3.9.1 (`src/core/parser.cpp` and the plugins' constructors).
//!
//! Stages: [`parse`] reads the files (parameters, `<default>`, `<include>`, `<path>`, typed properties,
//! transforms via `scene::transform`, ids); [`plugins`] builds BSDFs, textures, meshes, emitters and the
//! camera with Mitsuba's defaults; [`props`] gives typed property access and fails on properties nobody
//! read, as Mitsuba does (except the ones in `props::IGNORED`); [`materials`] holds Mitsuba's named IORs.
//!
//! Supported plugins: shapes obj, ply, serialized, rectangle, cube, sphere, disk, cylinder, shapegroup +
//! instance (`instancing`); BSDFs diffuse, twosided, plastic,
//! roughplastic, conductor, roughconductor, dielectric, roughdielectric and thindielectric (`dielectric`), principled, blendbsdf, bumpmap, normalmap (`perturb`), mask (`mask`); textures bitmap (PNG, JPEG, BMP, PPM, TGA,
//! EXR, HDR, PFM), checkerboard; emitters point,
//! spot, directional, area, envmap, constant; sensor perspective with film hdrfilm (crop window included; `banner` of
//! Mitsuba 0.x files ignored and `gamma` refused, as Mitsuba 3.9.1 does). Integrators, samplers
//! and reconstruction filters are read and ignored. Media (`<medium type="homogeneous">` as a shape's
//! interior/exterior): as Mitsuba 3.9.1's integrator of the scene treats them ([`MediaPolicy`]). Anything else is an error naming plugin, file and line.
//!
//! Spectra (`<spectrum value="0.5">`, `value="400:0.3, 500:0.6, ..."`) become RGB as in Mitsuba's RGB
//! variants (`spectrum.rs`); files of version < 2.0 are upgraded as Mitsuba 3 does (`upgrade.rs`).
//!
//! Deviations from Mitsuba (all refusals, never silent differences): spectrum files (use `value=`),
//! `<spectrum type="blackbody">` (Mitsuba's RGB variants cannot evaluate it either), non-similarity
//! sphere transforms, a scene without shapes or without a sensor. Only the first sensor is used (others
//! are checked).
//! Scene-level emitters come first in document order, then the area emitters of shapes in shape order.
mod blend;
mod cie;
mod dielectric;
mod instancing;
mod mask;
mod materials;
mod parse;
mod perturb;
mod plugins;
mod principled;
mod props;
mod sensor;
mod shapes;
mod spectrum;
mod upgrade;

use crate::error::{Error, Location, Result};
use crate::scene::{Integrator, Scene};
use std::path::Path;

/// Options of `load_scene`: `$name` substitutions (like `mitsuba.load_file(path, **params)`) and an
/// optional film size override.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// `(name, value)` pairs replacing `$name` in attributes; they win over `<default>`s. A name that no
    /// attribute uses is an error, as in Mitsuba.
    pub params: Vec<(String, String)>,
    /// Replaces the film's width and height (for scenes whose film size is not a parameter).
    pub size: Option<(u32, u32)>,
    /// How `<medium>`s are taken.
    pub media: MediaPolicy,
}

/// What `load_scene` does with participating media (`<medium type="homogeneous">` as a shape's
/// `interior` / `exterior`, or at the top level for `<ref>`s).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum MediaPolicy {
    /// As Mitsuba 3.9.1 does for the scene's integrator: `volpath`, `volpathmis` and `prbvolpath` use
    /// them (here: Beer-Lambert attenuation with `sigma_t` along delta chains, `Scene::media`; a warning
    /// when a medium scatters, which is not modelled); every other integrator (`path`, the default)
    /// ignores them (a warning says the medium has no effect).
    #[default]
    Follow,
    /// Refuse any `<medium>` (a `Scene` error naming it).
    Error,
}

/// Mitsuba 3.9.1's integrators that use media.
const VOLUMETRIC_INTEGRATORS: &[&str] = &["volpath", "volpathmis", "prbvolpath"];

/// Loads a Mitsuba 3 XML scene.
///
/// Errors: `Error::Scene` (file and line of the offending element, and its value) for malformed or
/// unsupported content; `Error::FileNotFound` (with the location of the element naming it) for a
/// missing scene, include, mesh or texture file.
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let (scene, warnings) = load_scene_with_warnings(path, opts)?;
    for w in warnings {
        log::warn!("{w}");
    }
    Ok(scene)
}

/// [`load_scene`], also returning what was accepted with a warning as Mitsuba does (e.g. a shape whose
/// triangles all have zero area: it stays, empty, so that shape indices remain Mitsuba's).
pub fn load_scene_with_warnings(path: &Path, opts: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    let doc = parse::parse_document(path, &opts.params)?;
    let mut b = plugins::Builder::new(&doc, opts.size);
    b.media_policy = opts.media;
    let root = &doc.nodes[0];
    let mut camera = None;
    let mut area_nodes = Vec::new();
    let mut unused = Vec::new();
    let mut integrator = None;
    for child in &root.children {
        let (node, loc) = match child {
            parse::Child::Object { node, .. } => (*node, doc.nodes[*node].loc.clone()),
            parse::Child::Ref { loc, .. } => {
                return Err(Error::scene(loc, "a <ref> cannot be a direct child of <scene>"));
            }
        };
        let n = &doc.nodes[node];
        match n.class.as_str() {
            "shape" => b.shape(node)?,
            "emitter" if n.plugin == "area" => area_nodes.push(node),
            "emitter" => b.emitter(node)?,
            "sensor" => {
                let c = b.sensor(node)?;
                camera.get_or_insert(c);
            }
            "bsdf" | "texture" => unused.push(node),
            "integrator" => {
                if integrator.is_none() {
                    integrator = Some(read_integrator(&doc, node)?);
                }
            }
            "sampler" | "film" | "rfilter" => {}
            // Built for its errors (shapes refer to it); unused ones are dropped, as Mitsuba's are unused.
            "medium" if opts.media == MediaPolicy::Follow => {
                b.medium(node)?;
            }
            other => return Err(Error::scene(&loc, format!("unsupported <{other} type=\"{}\">", n.plugin))),
        }
    }
    // Top-level BSDFs and textures no shape uses: built anyway (Mitsuba instantiates them, so their
    // errors surface), then dropped.
    let kept = (b.bsdfs.len(), b.textures.len());
    for node in unused {
        if doc.nodes[node].class == "bsdf" {
            b.bsdf(node)?;
        } else {
            b.texture(node)?;
        }
    }
    if (b.bsdfs.len(), b.textures.len()) != kept {
        // Only unused objects were appended after `kept`; used ones were memoised earlier.
        b.bsdfs.truncate(kept.0);
        b.textures.truncate(kept.1);
    }
    for node in area_nodes {
        if !b.is_attached(node) {
            return Err(Error::scene(&doc.nodes[node].loc, "area emitter is not attached to any shape (reference it from a <shape>)"));
        }
    }
    let file_loc = Location::new(path, 0);
    if b.meshes.is_empty() {
        return Err(Error::scene(&file_loc, "the scene has no shapes"));
    }
    let camera = camera.ok_or_else(|| Error::scene(&file_loc, "the scene has no <sensor>"))?;
    let offset = b.emitters.len();
    for m in b.meshes.iter_mut() {
        if let Some(e) = m.emitter.as_mut() {
            *e += offset;
        }
    }
    let mut emitters = b.emitters;
    emitters.extend(b.area_emitters);
    let mut warnings = b.warnings;
    let media = scene_media(&b.meshes, b.media, &b.shape_media, integrator.as_ref(), &mut warnings);
    let scene =
        Scene { path: path.to_path_buf(), camera, meshes: b.meshes, bsdfs: b.bsdfs, textures: b.textures, emitters, integrator, media };
    Ok((scene, warnings))
}

/// The shapes' media as the integrator uses them (`MediaPolicy::Follow`), with their warnings.
fn scene_media(
    meshes: &[crate::scene::Mesh],
    media: Vec<crate::scene::Medium>,
    shape_media: &[(usize, Option<usize>, Option<usize>)],
    integrator: Option<&Integrator>,
    warnings: &mut Vec<String>,
) -> crate::scene::Media {
    let Some(&(first, i0, e0)) = shape_media.first() else {
        return crate::scene::Media::default();
    };
    let m0 = &media[i0.or(e0).unwrap_or(0)];
    let n = shape_media.len();
    let plugin = integrator.map(|i| i.plugin.as_str()).unwrap_or("path");
    let shapes =
        if n == 1 { format!("shape \"{}\"", meshes[first].id) } else { format!("{n} shapes (the first: \"{}\")", meshes[first].id) };
    if !VOLUMETRIC_INTEGRATORS.contains(&plugin) {
        warnings.push(format!(
            "{}: the medium of {shapes} has no effect: the scene's integrator \"{plugin}\" ignores media, as Mitsuba's does \
             (rendered without it; use volpath to attenuate light through it, or load with media=\"error\" to refuse it)",
            m0.loc
        ));
        return crate::scene::Media::default();
    }
    let used: std::collections::BTreeSet<usize> = shape_media.iter().flat_map(|&(_, i, e)| [i, e]).flatten().collect();
    if let Some(&s) = used.iter().find(|&&m| media[m].albedo.max_element() > 0.0) {
        warnings.push(format!(
            "{}: medium with albedo {:?}: scattering inside media is not modelled (light through it is attenuated by \
             Beer-Lambert with sigma_t = {:?}, in-scattered light is missing; exact for albedo 0)",
            media[s].loc,
            media[s].albedo.to_array(),
            media[s].sigma_t.to_array()
        ));
    }
    let mut shape = vec![(None, None); meshes.len()];
    for &(k, i, e) in shape_media {
        shape[k] = (i, e);
    }
    crate::scene::Media { media, shape }
}

/// Mitsuba 3.9.1's integrators with a `max_depth` (default -1: unbounded).
const PATH_INTEGRATORS: &[&str] = &["path", "volpath", "volpathmis", "ptracer", "prb", "prb_basic", "prbvolpath"];

/// The integrator's type and path depth (see [`Integrator`]); only `max_depth` and `hide_emitters` are read
/// (the other properties choose how Mitsuba samples, not what the converged image is).
///
/// Errors: `hide_emitters` true (any integrator): Mitsuba's camera rays then pass through area emitters and
/// see no environment, an image this crate does not render; refused rather than rendered with the emitters.
fn read_integrator(doc: &parse::Document, node: usize) -> Result<Integrator> {
    let mut p = props::Props::new(doc, node);
    let plugin = p.node.plugin.clone();
    if p.bool("hide_emitters", false)? {
        return Err(Error::scene(
            p.loc(),
            format!(
                "integrator \"{plugin}\": hide_emitters=true is not supported (Mitsuba's camera rays then pass \
                 through area emitters and see no environment; this library renders what the camera sees): \
                 remove it or set it to false"
            ),
        ));
    }
    let max_depth = if PATH_INTEGRATORS.contains(&plugin.as_str()) {
        let (d, loc) = p.int("max_depth", -1)?;
        if d < -1 {
            return Err(Error::scene(&loc, format!("integrator \"{plugin}\": max_depth must be -1 (unbounded) or >= 0, got {d}")));
        }
        Some(d)
    } else if plugin == "direct" {
        Some(2)
    } else {
        None
    };
    Ok(Integrator { plugin, max_depth, loc: p.loc().clone() })
}

#[cfg(test)]
mod tests;
