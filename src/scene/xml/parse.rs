//! Stage 1 of loading: XML files -> a flat list of object nodes with typed properties, the way
//! Mitsuba 3.9.1's `src/core/parser.cpp` builds its `SceneNode`s.
//!
//! - `$name` is substituted in every attribute (longest name first, `\$` escapes a dollar); a `$name`
//!   left over is an error. `<default>` adds a parameter only if none of that name exists yet (so
//!   `LoadOptions::params` win, then the first `<default>`); a user parameter that no attribute used is an
//!   error ("unused parameter"), as in Mitsuba.
//! - `<include filename>` is resolved relative to the including file; the included `<scene>`'s children
//!   join the including element; defaults declared in it stay visible afterwards (one parameter list).
//! - `<path value>` (root only) adds a search directory for the files plugins name (newest first, then the
//!   main scene's directory). The directory itself is found as Mitsuba finds it: beside the declaring
//!   file, else in earlier `<path>`s, the scene's folder or the working directory (`FileResolver`);
//!   one that exists nowhere is an error, as in Mitsuba 3.9.1. As in Mitsuba, a mesh or texture named
//!   in an included file is looked up there too, not relative to the included file.
//! - Property elements become [`Prop`]s (transforms are evaluated here); nested objects and `<ref>`s
//!   become [`Child`]ren; ids are collected so references may come before their declaration.
//!
//! - Files with `version` < 2.0.0 (Mitsuba 0.x) have their nodes upgraded as Mitsuba 3 does
//!   (`upgrade.rs`: camelCase names -> snake_case, ...).
//! - `<spectrum value>` keeps the spectrum (uniform or `wavelength:value` pairs); it becomes RGB where a
//!   plugin reads it (`spectrum.rs`), as in Mitsuba's RGB variants. A spectrum file is refused.
use super::spectrum::Spectrum;
use super::upgrade;
use crate::error::{Error, Location, Result};
use crate::scene::transform;
use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How deep `<include>` may nest (Mitsuba's `max_include_depth`).
const MAX_INCLUDE_DEPTH: usize = 15;
/// How many `<include>`s one scene may process in all: a few files that each include the next ten times
/// would otherwise parse 10^depth files (a 2 KB scene that never finishes loading; found by fuzzing).
const MAX_INCLUDES: usize = 10_000;

/// A typed property value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
    /// `<point>` or `<vector>`.
    Vector(DVec3),
    Rgb(DVec3),
    /// `<spectrum value="v">` or `value="w1:v1, w2:v2, ..."` (RGB by use: `spectrum::Spectrum::to_rgb`).
    Spectrum(Spectrum),
    /// Matrix and normal matrix, as Mitsuba keeps them (see `transform::Affine`).
    Transform(transform::Affine),
}

impl Value {
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Int(_) => "integer",
            Value::Bool(_) => "boolean",
            Value::Str(_) => "string",
            Value::Vector(_) => "point/vector",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Transform(_) => "transform",
        }
    }
}

#[derive(Debug, Clone)]
pub struct Prop {
    pub name: String,
    pub value: Value,
    pub loc: Location,
}

/// A nested object or a reference to one, in document order.
#[derive(Debug, Clone)]
pub enum Child {
    Object { name: Option<String>, node: usize },
    Ref { name: Option<String>, id: String, loc: Location },
}

/// An object element (`<scene>`, `<shape>`, `<bsdf>`, ...).
#[derive(Debug, Clone)]
pub struct Node {
    /// Element name: "scene", "shape", "bsdf", "texture", "emitter", "sensor", "film", ...
    pub class: String,
    /// The `type` attribute ("scene" for the root).
    pub plugin: String,
    pub id: Option<String>,
    pub loc: Location,
    pub props: Vec<Prop>,
    pub children: Vec<Child>,
}

/// All object nodes (index 0 = root `<scene>`), the id table and the resource search directories.
#[derive(Debug)]
pub struct Document {
    pub nodes: Vec<Node>,
    pub ids: HashMap<String, usize>,
    /// Directories searched for files that plugins name, first match wins.
    pub search_dirs: Vec<PathBuf>,
}

struct Param {
    key: String,
    value: String,
    used: bool,
}

struct Parser {
    params: Vec<Param>,
    nodes: Vec<Node>,
    ids: HashMap<String, usize>,
    /// `<path>` directories, newest last.
    path_dirs: Vec<PathBuf>,
    /// Per file being parsed (innermost last): its version is < 2.0 (nodes get `upgrade::upgrade_node`).
    legacy: Vec<bool>,
    /// Folder of the main scene file.
    main_dir: Option<PathBuf>,
    /// `<include>`s processed so far (see [`MAX_INCLUDES`]).
    includes: usize,
    /// Per file being parsed (innermost last): the byte offsets of its newlines, for `line_of`.
    newlines: Vec<Vec<usize>>,
}

const OBJECT_CLASSES: &[&str] =
    &["shape", "bsdf", "texture", "emitter", "sensor", "film", "sampler", "integrator", "rfilter", "medium", "phase", "volume", "spectrum"];

/// Reads `path` and everything it includes.
pub fn parse_document(path: &Path, params: &[(String, String)]) -> Result<Document> {
    let mut parser = Parser {
        params: params.iter().map(|(k, v)| Param { key: format!("${k}"), value: v.clone(), used: false }).collect(),
        nodes: Vec::new(),
        ids: HashMap::new(),
        path_dirs: Vec::new(),
        legacy: Vec::new(),
        main_dir: path.parent().map(Path::to_path_buf),
        includes: 0,
        newlines: Vec::new(),
    };
    parser.sort_params();
    parser.parse_file(path, &Location::new(path, 0), None, 0)?;
    let unused: Vec<String> = parser.params.iter().filter(|p| !p.used).map(|p| format!("{}={}", p.key, p.value)).collect();
    if !unused.is_empty() {
        return Err(Error::scene(
            &Location::new(path, 0),
            format!("unused parameter(s) given to load_scene: {} (no attribute refers to them)", unused.join(", ")),
        ));
    }
    let mut search_dirs: Vec<PathBuf> = parser.path_dirs.iter().rev().cloned().collect();
    search_dirs.push(path.parent().map(Path::to_path_buf).unwrap_or_default());
    Ok(Document { nodes: parser.nodes, ids: parser.ids, search_dirs })
}

impl Parser {
    /// 1-based line of a node of the file being parsed: a binary search of its newlines (roxmltree's
    /// `text_pos_at` scans the text from the start, which made loading quadratic in the elements: 17 s for
    /// 5,000 shapes).
    fn line_of(&self, node: roxmltree::Node) -> u32 {
        let newlines = self.newlines.last().map(Vec::as_slice).unwrap_or(&[]);
        newlines.partition_point(|&o| o < node.range().start) as u32 + 1
    }

    /// Where `<path value>` points, as Mitsuba 3.9.1 resolves it: an absolute path as is; a relative one
    /// beside the file declaring it, else in the search path (earlier `<path>`s newest first, the main
    /// scene's folder, the working directory). None if it exists nowhere (Mitsuba fails then too).
    fn resolve_path_element(&self, value: &str, file: &Path) -> Option<PathBuf> {
        let v = Path::new(value);
        if v.is_absolute() {
            return v.exists().then(|| v.to_path_buf());
        }
        let beside = file.parent().unwrap_or(Path::new("")).join(v);
        if beside.exists() {
            return Some(beside);
        }
        self.path_dirs
            .iter()
            .rev()
            .cloned()
            .chain(self.main_dir.clone())
            .chain(std::env::current_dir().ok())
            .map(|d| d.join(v))
            .find(|c| c.exists())
    }

    fn sort_params(&mut self) {
        // Longest first so that `$ab` is not replaced as `$a` + "b" (stable: keeps insertion order).
        self.params.sort_by_key(|p| std::cmp::Reverse(p.key.len()));
    }

    /// Parses one file; its root's children become children of `parent` (None: this is the main file).
    fn parse_file(&mut self, path: &Path, include_loc: &Location, parent: Option<usize>, depth: usize) -> Result<()> {
        if depth >= MAX_INCLUDE_DEPTH {
            return Err(Error::scene(include_loc, format!("exceeded the maximum include depth of {MAX_INCLUDE_DEPTH}")));
        }
        if !path.is_file() {
            return Err(Error::FileNotFound { loc: include_loc.clone(), path: path.to_path_buf() });
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let doc = roxmltree::Document::parse(&text)
            .map_err(|e| Error::scene(&Location::new(path, e.pos().row), format!("malformed XML: {e}")))?;
        self.newlines.push(text.bytes().enumerate().filter(|&(_, b)| b == b'\n').map(|(i, _)| i).collect());
        let root = doc.root_element();
        let loc = Location::new(path, self.line_of(root));
        if root.tag_name().name() != "scene" {
            return Err(Error::scene(&loc, format!("root element must be <scene>, got <{}>", root.tag_name().name())));
        }
        let attrs = self.substitute(root, path)?;
        let Some((_, version)) = attrs.iter().find(|(k, _)| k == "version") else {
            return Err(Error::scene(&loc, "missing version attribute in root element <scene>"));
        };
        let legacy = upgrade::needs_upgrade(upgrade::parse_version(version, &loc)?);
        let target = match parent {
            Some(p) => p,
            None => {
                self.nodes.push(Node {
                    class: "scene".into(),
                    plugin: "scene".into(),
                    id: None,
                    loc,
                    props: Vec::new(),
                    children: Vec::new(),
                });
                0
            }
        };
        self.legacy.push(legacy);
        for child in root.children().filter(|c| c.is_element()) {
            self.parse_element(&doc, child, path, target, target == 0, depth)?;
        }
        self.legacy.pop();
        self.newlines.pop();
        if parent.is_none() && legacy {
            upgrade::upgrade_node(&mut self.nodes[0])?;
        }
        Ok(())
    }

    /// Attributes of `node` with `$name` substituted.
    fn substitute(&mut self, node: roxmltree::Node, path: &Path) -> Result<Vec<(String, String)>> {
        let mut out = Vec::new();
        for a in node.attributes() {
            let mut value = a.value().to_string();
            if value.contains('$') {
                for p in self.params.iter_mut() {
                    let mut pos = 0;
                    while let Some(found) = value[pos..].find(&p.key) {
                        let at = pos + found;
                        if at > 0 && value.as_bytes()[at - 1] == b'\\' {
                            pos = at + p.key.len();
                        } else {
                            value.replace_range(at..at + p.key.len(), &p.value);
                            p.used = true;
                            pos = at + p.value.len();
                        }
                    }
                }
                let bytes = value.as_bytes();
                for (i, b) in bytes.iter().enumerate() {
                    if *b == b'$' && (i == 0 || bytes[i - 1] != b'\\') {
                        let name: String = value[i + 1..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                        return Err(Error::scene(
                            &Location::new(path, self.line_of(node)),
                            format!(
                                "undefined parameter ${name} in {}=\"{}\" (declare it with <default name=\"{name}\" value=\"...\"/> or pass it to load_scene)",
                                a.name(),
                                a.value()
                            ),
                        ));
                    }
                }
                value = value.replace("\\$", "$");
            }
            out.push((a.name().to_string(), value));
        }
        Ok(out)
    }

    fn parse_element(
        &mut self,
        doc: &roxmltree::Document,
        node: roxmltree::Node,
        path: &Path,
        parent: usize,
        parent_is_root: bool,
        depth: usize,
    ) -> Result<()> {
        let tag = node.tag_name().name().to_string();
        let loc = Location::new(path, self.line_of(node));
        let attrs = self.substitute(node, path)?;
        let get = |k: &str| attrs.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
        let check = |allowed: &[&str], required: &[&str]| -> Result<()> {
            for (k, v) in &attrs {
                if !allowed.contains(&k.as_str()) {
                    return Err(Error::scene(&loc, format!("<{tag}>: unexpected attribute {k}=\"{v}\"")));
                }
            }
            for r in required {
                if get(r).is_none() {
                    return Err(Error::scene(&loc, format!("<{tag}>: missing attribute \"{r}\"")));
                }
            }
            Ok(())
        };
        let is_object = OBJECT_CLASSES.contains(&tag.as_str()) && (tag != "spectrum" || get("type").is_some());
        if !is_object && tag != "transform" {
            if let Some(c) = node.children().find(|c| c.is_element()) {
                return Err(Error::scene(&loc, format!("<{}> element cannot occur as child of a property <{tag}>", c.tag_name().name())));
            }
        }
        if is_object {
            check(&["type", "id", "name"], &["type"])?;
            if tag == "spectrum" && get("type").as_deref() == Some("blackbody") {
                // Mitsuba's RGB variants load it but throw when it is evaluated.
                return Err(Error::scene(
                    &loc,
                    "<spectrum type=\"blackbody\"> is not supported: Mitsuba's RGB variants cannot evaluate it either (\"Not implemented for non-spectral modes\"); give an <rgb> value",
                ));
            }
            let idx = self.nodes.len();
            let id = get("id");
            if let Some(id) = &id {
                if let Some(prev) = self.ids.insert(id.clone(), idx) {
                    return Err(Error::scene(&loc, format!("duplicate id \"{id}\" (previous declaration at {})", self.nodes[prev].loc)));
                }
            }
            self.nodes.push(Node {
                class: tag.clone(),
                plugin: get("type").unwrap_or_default(),
                id,
                loc,
                props: Vec::new(),
                children: Vec::new(),
            });
            self.nodes[parent].children.push(Child::Object { name: get("name"), node: idx });
            for child in node.children().filter(|c| c.is_element()) {
                self.parse_element(doc, child, path, idx, false, depth)?;
            }
            if self.legacy.last() == Some(&true) {
                upgrade::upgrade_node(&mut self.nodes[idx])?;
            }
            return Ok(());
        }
        let name = get("name").unwrap_or_default();
        let value = |what: &str| -> Result<String> {
            get("value").ok_or_else(|| Error::scene(&loc, format!("<{what} name=\"{name}\">: missing attribute \"value\"")))
        };
        let value = match tag.as_str() {
            "default" => {
                check(&["name", "value"], &["name", "value"])?;
                let key = format!("${}", name);
                if name.is_empty() {
                    return Err(Error::scene(&loc, "<default>: name must be non-empty"));
                }
                if !self.params.iter().any(|p| p.key == key) {
                    self.params.push(Param { key, value: value("default")?, used: true });
                    self.sort_params();
                }
                return Ok(());
            }
            "include" => {
                check(&["filename", "name"], &["filename"])?;
                let file = get("filename").unwrap_or_default();
                let dir = path.parent().unwrap_or(Path::new(""));
                let inc = dir.join(&file);
                self.includes += 1;
                if self.includes > MAX_INCLUDES {
                    return Err(Error::scene(&loc, format!("more than {MAX_INCLUDES} <include>s in one scene (an include loop?)")));
                }
                return self.parse_file(&inc, &loc, Some(parent), depth + 1);
            }
            "path" => {
                check(&["value"], &["value"])?;
                if !parent_is_root {
                    return Err(Error::scene(&loc, "<path> can only be a child of the root <scene>"));
                }
                let v = value("path")?;
                // Not found anywhere: Mitsuba fails too ("<path>: folder ... not found").
                let dir = self
                    .resolve_path_element(&v, path)
                    .ok_or_else(|| Error::FileNotFound { loc: loc.clone(), path: path.parent().unwrap_or(Path::new("")).join(&v) })?;
                self.path_dirs.push(dir);
                return Ok(());
            }
            "ref" => {
                check(&["id", "name"], &["id"])?;
                let id = get("id").unwrap_or_default();
                self.nodes[parent].children.push(Child::Ref { name: get("name"), id, loc });
                return Ok(());
            }
            "alias" => {
                check(&["id", "as"], &["id", "as"])?;
                let (src, dst) = (get("id").unwrap_or_default(), get("as").unwrap_or_default());
                let Some(&idx) = self.ids.get(&src) else {
                    return Err(Error::scene(&loc, format!("<alias>: source id \"{src}\" not found")));
                };
                if self.ids.insert(dst.clone(), idx).is_some() {
                    return Err(Error::scene(&loc, format!("<alias>: destination id \"{dst}\" already exists")));
                }
                return Ok(());
            }
            "transform" => {
                check(&["name"], &["name"])?;
                let mut m = transform::Affine::IDENTITY;
                for op in node.children().filter(|c| c.is_element()) {
                    let op_loc = Location::new(path, self.line_of(op));
                    let op_attrs = self.substitute(op, path)?;
                    m = transform::apply_op(m, op.tag_name().name(), &op_attrs, &op_loc)?;
                }
                Value::Transform(m)
            }
            "float" => {
                check(&["name", "value"], &["name", "value"])?;
                Value::Float(transform::parse_f64(&value("float")?, &format!("<float name=\"{name}\">"), &loc)?)
            }
            "integer" => {
                check(&["name", "value"], &["name", "value"])?;
                let v = value("integer")?;
                Value::Int(
                    v.trim()
                        .parse::<i64>()
                        .map_err(|_| Error::scene(&loc, format!("could not parse integer value \"{v}\" of <integer name=\"{name}\">")))?,
                )
            }
            "boolean" => {
                check(&["name", "value"], &["name", "value"])?;
                let v = value("boolean")?;
                match v.to_ascii_lowercase().as_str() {
                    "true" => Value::Bool(true),
                    "false" => Value::Bool(false),
                    _ => {
                        return Err(Error::scene(
                            &loc,
                            format!("could not parse boolean value \"{v}\" of <boolean name=\"{name}\"> -- must be \"true\" or \"false\""),
                        ));
                    }
                }
            }
            "string" => {
                check(&["name", "value"], &["name", "value"])?;
                Value::Str(value("string")?)
            }
            "point" | "vector" => {
                check(&["name", "value", "x", "y", "z"], &["name"])?;
                let what = format!("<{tag} name=\"{name}\">");
                if let Some(v) = get("value") {
                    if get("x").is_some() || get("y").is_some() || get("z").is_some() {
                        return Err(Error::scene(&loc, format!("{what}: cannot mix \"value\" and \"x\"/\"y\"/\"z\"")));
                    }
                    let l = transform::parse_list(&v, &what, &loc)?;
                    match l.len() {
                        1 => Value::Vector(DVec3::splat(l[0])),
                        3 => Value::Vector(DVec3::new(l[0], l[1], l[2])),
                        n => return Err(Error::scene(&loc, format!("{what} value=\"{v}\" must have 1 or 3 numbers, got {n}"))),
                    }
                } else {
                    let mut p = DVec3::ZERO;
                    for (i, k) in ["x", "y", "z"].iter().enumerate() {
                        let s = get(k).ok_or_else(|| Error::scene(&loc, format!("{what}: missing attribute \"{k}\"")))?;
                        p[i] = transform::parse_f64(&s, &what, &loc)?;
                    }
                    Value::Vector(p)
                }
            }
            "rgb" => {
                check(&["name", "value"], &["name", "value"])?;
                let v = value("rgb")?;
                let l = transform::parse_list(&v, &format!("<rgb name=\"{name}\">"), &loc)?;
                match l.len() {
                    1 => Value::Rgb(DVec3::splat(l[0])),
                    3 => Value::Rgb(DVec3::new(l[0], l[1], l[2])),
                    n => {
                        return Err(Error::scene(
                            &loc,
                            format!("<rgb name=\"{name}\" value=\"{v}\"> requires one or three values (got {n})"),
                        ));
                    }
                }
            }
            "spectrum" => {
                check(&["name", "value", "filename"], &["name"])?;
                if let Some(f) = get("filename") {
                    return Err(Error::scene(
                        &loc,
                        format!("<spectrum name=\"{name}\" filename=\"{f}\">: spectrum files are not supported; give the data inline as value=\"wavelength:value, ...\" or use <rgb name=\"{name}\" value=\"r, g, b\"/>"),
                    ));
                }
                let v = value("spectrum")?;
                let spectrum = Spectrum::parse(&v)
                    .map_err(|e| Error::scene(&loc, format!("<spectrum name=\"{name}\" value=\"{}\">: {e}", shorten(&v))))?;
                Value::Spectrum(spectrum)
            }
            "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                return Err(Error::scene(&loc, format!("<{tag}> can only appear inside a <transform> element")));
            }
            other => return Err(Error::scene(&loc, format!("unsupported XML element <{other}>"))),
        };
        if let Some(prev) = self.nodes[parent].props.iter().find(|p| p.name == name) {
            return Err(Error::scene(&loc, format!("property \"{name}\" is given twice (first at {})", prev.loc)));
        }
        self.nodes[parent].props.push(Prop { name, value, loc });
        Ok(())
    }
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}
