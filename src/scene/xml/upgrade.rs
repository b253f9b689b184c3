//! Scenes written for Mitsuba 0.x (`<scene version="0.5.0">`, `0.6.0`, ...; any version < 2.0.0), upgraded
//! on load as Mitsuba 3.9.1's `transform_upgrade` pass does (`src/core/parser.cpp`, `upgrade_from_v1`):
//! - every property name and every name of a nested or referenced object goes from camelCase to
//!   snake_case: an upper-case letter that follows a lower-case one becomes `_` + lower case, and so do the
//!   upper-case letters right after it (`toWorld` -> `to_world`, `intIOR` -> `int_ior`,
//!   `diffuseReflectance` -> `diffuse_reflectance`, `fovAxis` -> `fov_axis`);
//! - a `diffuse` BSDF's `diffuse_reflectance` becomes `reflectance`;
//! - a texture's `uoffset`, `voffset`, `uscale`, `vscale` become `to_uv` = scale(uscale, vscale, 1) *
//!   translate(uoffset, voffset, 0).
//!
//! Each node is upgraded by the version of the file it was declared in. Element names are not changed
//! (Mitsuba 3 does not either: `<lookAt>` is an unknown element there as here).
use super::parse::{Child, Node, Prop, Value};
use crate::error::{Error, Location, Result};
use crate::scene::transform::Affine;
use glam::{DMat4, DVec3};

/// A `version` attribute: three numbers separated by periods (Mitsuba's `util::Version`).
pub fn parse_version(value: &str, loc: &Location) -> Result<(u32, u32, u32)> {
    let parts: Vec<&str> = value.split(['.', ' ']).filter(|s| !s.is_empty()).collect();
    let bad = || Error::scene(loc, format!("invalid version number \"{value}\" (expected three period-separated numbers, e.g. \"3.0.0\")"));
    if parts.len() != 3 {
        return Err(bad());
    }
    let n: Vec<u32> = parts.iter().map(|p| p.parse::<u32>().map_err(|_| bad())).collect::<Result<_>>()?;
    Ok((n[0], n[1], n[2]))
}

/// True if nodes of a file with this version need [`upgrade_node`].
pub fn needs_upgrade(version: (u32, u32, u32)) -> bool {
    version < (2, 0, 0)
}

/// Mitsuba's `camel_to_underscore_case`.
pub fn camel_to_snake(input: &str) -> String {
    let c: Vec<char> = input.chars().collect();
    let mut out = String::with_capacity(input.len() + 4);
    let mut i = 0;
    while i < c.len() {
        if i > 0 && c[i - 1].is_ascii_lowercase() && c[i].is_ascii_uppercase() {
            out.push('_');
            out.push(c[i].to_ascii_lowercase());
            while i + 1 < c.len() && c[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(c[i].to_ascii_lowercase());
            }
        } else {
            out.push(c[i]);
        }
        i += 1;
    }
    out
}

fn rename_child(child: &mut Child, f: impl Fn(&str) -> Option<String>) {
    let name = match child {
        Child::Object { name, .. } | Child::Ref { name, .. } => name,
    };
    if let Some(new) = name.as_deref().and_then(f) {
        *name = Some(new);
    }
}

/// Upgrades one node of a version < 2.0 file in place (see the module doc).
pub fn upgrade_node(node: &mut Node) -> Result<()> {
    for p in node.props.iter_mut() {
        p.name = camel_to_snake(&p.name);
    }
    for c in node.children.iter_mut() {
        rename_child(c, |n| Some(camel_to_snake(n)));
    }
    if node.plugin == "diffuse" {
        let old = |n: &str| (n == "diffuse_reflectance").then(|| "reflectance".to_string());
        for p in node.props.iter_mut() {
            if let Some(n) = old(&p.name) {
                p.name = n;
            }
        }
        for c in node.children.iter_mut() {
            rename_child(c, old);
        }
    }
    let uv_keys = ["uoffset", "voffset", "uscale", "vscale"];
    if node.props.iter().any(|p| uv_keys.contains(&p.name.as_str())) {
        let mut offset = DVec3::ZERO;
        let mut scale = DVec3::ONE;
        let mut loc = node.loc.clone();
        for p in node.props.iter().filter(|p| uv_keys.contains(&p.name.as_str())) {
            let v = match p.value {
                Value::Float(v) => v,
                Value::Int(v) => v as f64,
                ref other => {
                    return Err(Error::scene(&p.loc, format!("\"{}\" must be a <float>, got <{}>", p.name, other.type_name())));
                }
            };
            match p.name.as_str() {
                "uoffset" => offset.x = v,
                "voffset" => offset.y = v,
                "uscale" => scale.x = v,
                _ => scale.y = v,
            }
            loc = p.loc.clone();
        }
        node.props.retain(|p| !uv_keys.contains(&p.name.as_str()) && p.name != "to_uv");
        let t = Affine { matrix: DMat4::from_scale(scale), inverse_transpose: DMat4::from_scale(scale.recip()) }
            * Affine { matrix: DMat4::from_translation(offset), inverse_transpose: DMat4::from_translation(-offset).transpose() };
        node.props.push(Prop { name: "to_uv".into(), value: Value::Transform(t), loc });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
