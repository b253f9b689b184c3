//! Typed access to one object's properties, with Mitsuba's check that every property was used.
//!
//! Mitsuba 3.9.1 fails on a property a plugin never queried ("unreferenced property"). We do the same,
//! except for the properties in [`IGNORED`], which only change how Mitsuba samples or stores the image,
//! not what we render.
use super::parse::{Child, Document, Node, Prop, Value};
use super::spectrum::SpectrumUse;
use crate::error::{Error, Location, Result};
use crate::scene::transform::Affine;
use glam::{DMat4, DVec3, Vec3};

/// Properties accepted and ignored on every plugin: they do not change the rendered expectation.
pub const IGNORED: &[&str] = &[
    "focus_distance",
    "pixel_format",
    "component_format",
    "file_format",
    "sample_visible",
    "silhouette_sampling_weight",
    "accel",
    "mis_compensation",
    "shutter_open",
    "shutter_close",
    "sample_border",
];

/// Properties of one node; each query marks what it read.
pub struct Props<'a> {
    pub doc: &'a Document,
    pub node: &'a Node,
    used_props: Vec<bool>,
    used_children: Vec<bool>,
}

/// A child object after following references: its node index and where it was named.
#[derive(Debug, Clone)]
pub struct ObjectRef {
    pub node: usize,
    pub name: Option<String>,
    pub loc: Location,
}

impl<'a> Props<'a> {
    pub fn new(doc: &'a Document, node: usize) -> Self {
        let n = &doc.nodes[node];
        Props { doc, node: n, used_props: vec![false; n.props.len()], used_children: vec![false; n.children.len()] }
    }

    /// A short description for messages: `bsdf "diffuse" (id "white")`.
    pub fn what(&self) -> String {
        match &self.node.id {
            Some(id) => format!("{} \"{}\" (id \"{id}\")", self.node.class, self.node.plugin),
            None => format!("{} \"{}\"", self.node.class, self.node.plugin),
        }
    }

    pub fn loc(&self) -> &'a Location {
        &self.node.loc
    }

    /// Where property `name` is given (its last occurrence, marked as used), else where the node is: the
    /// location an error about the property's value names.
    pub fn loc_of(&mut self, name: &str) -> Location {
        self.prop(name).map(|q| q.loc.clone()).unwrap_or_else(|| self.loc().clone())
    }

    /// The last property named `name` (a later one replaces an earlier one), marked as used.
    pub fn prop(&mut self, name: &str) -> Option<&'a Prop> {
        let node = self.node;
        let mut found = None;
        for (i, p) in node.props.iter().enumerate() {
            if p.name == name {
                self.used_props[i] = true;
                found = Some(p);
            }
        }
        found
    }

    fn type_error(&self, p: &Prop, expected: &str) -> Error {
        Error::scene(&p.loc, format!("property \"{}\" of {} must be {expected}, got <{}>", p.name, self.what(), p.value.type_name()))
    }

    pub fn opt_float(&mut self, name: &str) -> Result<Option<f64>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Float(v) => Ok(Some(*v)),
                Value::Int(v) => Ok(Some(*v as f64)),
                _ => Err(self.type_error(p, "a <float>")),
            },
        }
    }

    pub fn float(&mut self, name: &str, default: f64) -> Result<f64> {
        Ok(self.opt_float(name)?.unwrap_or(default))
    }

    pub fn int(&mut self, name: &str, default: i64) -> Result<(i64, Location)> {
        match self.prop(name) {
            None => Ok((default, self.node.loc.clone())),
            Some(p) => match &p.value {
                Value::Int(v) => Ok((*v, p.loc.clone())),
                _ => Err(self.type_error(p, "an <integer>")),
            },
        }
    }

    pub fn bool(&mut self, name: &str, default: bool) -> Result<bool> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                Value::Bool(v) => Ok(*v),
                _ => Err(self.type_error(p, "a <boolean>")),
            },
        }
    }

    /// A string property and the location of its element.
    pub fn string(&mut self, name: &str) -> Result<Option<(&'a str, &'a Location)>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Str(v) => Ok(Some((v.as_str(), &p.loc))),
                _ => Err(self.type_error(p, "a <string>")),
            },
        }
    }

    pub fn vector(&mut self, name: &str) -> Result<Option<DVec3>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Vector(v) => Ok(Some(*v)),
                _ => Err(self.type_error(p, "a <point> or <vector>")),
            },
        }
    }

    /// A transform's matrix (points and vectors).
    pub fn transform(&mut self, name: &str) -> Result<Option<DMat4>> {
        Ok(self.affine(name)?.map(|t| t.matrix))
    }

    /// A transform with the matrix Mitsuba applies to normals (see `transform::Affine`).
    pub fn affine(&mut self, name: &str) -> Result<Option<Affine>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Transform(m) => Ok(Some(*m)),
                _ => Err(self.type_error(p, "a <transform>")),
            },
        }
    }

    /// A constant colour given as `<rgb>`, `<spectrum>` (converted as Mitsuba's RGB variants do for this
    /// property, `spectrum::SpectrumUse::of`) or `<float>`.
    pub fn color_prop(&mut self, name: &str) -> Result<Option<Vec3>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Rgb(v) => Ok(Some(v.as_vec3())),
                Value::Spectrum(s) => Ok(Some(s.to_rgb(SpectrumUse::of(&self.node.class, name)).as_vec3())),
                Value::Float(v) => Ok(Some(Vec3::splat(*v as f32))),
                Value::Int(v) => Ok(Some(Vec3::splat(*v as f32))),
                _ => Err(self.type_error(p, "an <rgb>, <spectrum>, <float> or a texture")),
            },
        }
    }

    /// True if a property or a named child object has this name.
    pub fn has(&self, name: &str) -> bool {
        self.node.props.iter().any(|p| p.name == name)
            || self.node.children.iter().any(|c| match c {
                Child::Object { name: n, .. } | Child::Ref { name: n, .. } => n.as_deref() == Some(name),
            })
    }

    fn resolve(&self, child: &Child) -> Result<ObjectRef> {
        match child {
            Child::Object { name, node } => Ok(ObjectRef { node: *node, name: name.clone(), loc: self.doc.nodes[*node].loc.clone() }),
            Child::Ref { name, id, loc } => match self.doc.ids.get(id) {
                Some(&node) => Ok(ObjectRef { node, name: name.clone(), loc: loc.clone() }),
                None => Err(Error::scene(loc, format!("<ref id=\"{id}\">: no object with this id"))),
            },
        }
    }

    /// The child object (nested or referenced) named `name`, marked as used.
    pub fn named_object(&mut self, name: &str) -> Result<Option<ObjectRef>> {
        let node = self.node;
        let mut found = None;
        for (i, c) in node.children.iter().enumerate() {
            let n = match c {
                Child::Object { name, .. } | Child::Ref { name, .. } => name,
            };
            if n.as_deref() == Some(name) {
                self.used_children[i] = true;
                found = Some(self.resolve(c)?);
            }
        }
        Ok(found)
    }

    /// Every child object whatever its name, in document order, marked as used.
    pub fn objects(&mut self) -> Result<Vec<ObjectRef>> {
        self.used_children.iter_mut().for_each(|u| *u = true);
        self.node.children.iter().map(|c| self.resolve(c)).collect()
    }

    /// Marks properties as read without using them.
    pub fn ignore(&mut self, names: &[&str]) {
        for n in names {
            self.prop(n);
        }
    }

    /// Fails on the first property or child object nobody read (Mitsuba's "unreferenced property").
    pub fn finish(mut self) -> Result<()> {
        self.ignore(IGNORED);
        for (i, p) in self.node.props.iter().enumerate() {
            if !self.used_props[i] {
                return Err(Error::scene(
                    &p.loc,
                    format!("unreferenced property <{} name=\"{}\"> in {} (not supported)", p.value.type_name(), p.name, self.what()),
                ));
            }
        }
        for (i, c) in self.node.children.iter().enumerate() {
            if !self.used_children[i] {
                let r = self.resolve(c)?;
                let n = &self.doc.nodes[r.node];
                return Err(Error::scene(
                    &r.loc,
                    format!(
                        "unreferenced {} \"{}\"{} in {} (not supported here)",
                        n.class,
                        n.plugin,
                        r.name.map(|s| format!(" named \"{s}\"")).unwrap_or_default(),
                        self.what()
                    ),
                ));
            }
        }
        Ok(())
    }
}
