//! PLY reader (ascii, binary little and big endian, via `ply-rs-bw`) reproducing Mitsuba 3.9.1's
//! `src/shapes/ply.cpp`.
//!
//! Mitsuba's rules, reproduced:
//! - element `vertex`: `x`, `y`, `z`; normals when `nx`, `ny`, `nz` are all present; texture coordinates
//!   from `u`/`v`, else `texture_u`/`texture_v`, else `s`/`t`, *not* flipped (`flip_tex_coords` defaults
//!   to false for PLY); every other property is ignored;
//! - element `face`: the list `vertex_index`, else `vertex_indices`; other elements are skipped.
//!
//! Deviations: faces with more than 3 indices are fan-triangulated like OBJ polygons (Mitsuba rejects them:
//! "is this a triangle mesh?"); integer-typed vertex properties are read as plain numbers (Mitsuba
//! normalises them to [0, 1] with an sRGB curve, a colour convention that makes no sense for positions).
use super::MeshData;
use crate::error::{Error, Location, Result};
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::path::Path;

/// Loads a PLY file into local space.
///
/// Errors: `FileNotFound`; `Io` when unreadable; `Scene` (with the file line when the parser knows it)
/// for malformed files, missing `x`/`y`/`z` or face lists, faces with fewer than 3 indices and
/// non-finite positions.
pub fn load_ply(path: &Path, loc: &Location) -> Result<MeshData> {
    if !path.exists() {
        return Err(Error::FileNotFound { loc: loc.clone(), path: path.to_path_buf() });
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = std::io::BufReader::new(file);
    let ply = Parser::<DefaultElement>::new().read_ply(&mut reader).map_err(|e| {
        let line = e.line().unwrap_or(0) as u32;
        Error::scene(&Location::new(path, line), format!("invalid PLY file: {e}"))
    })?;
    let file_loc = Location::new(path, 0);

    let vertices = ply.payload.get("vertex").ok_or_else(|| Error::scene(&file_loc, "PLY file has no \"vertex\" element"))?;
    let vertex_def = &ply.header.elements["vertex"];
    let has = |name: &str| vertex_def.properties.contains_key(name);
    for c in ["x", "y", "z"] {
        if !has(c) {
            return Err(Error::scene(&file_loc, format!("PLY vertex element has no \"{c}\" property")));
        }
    }
    let has_normals = has("nx") && has("ny") && has("nz");
    let uv_names = [("u", "v"), ("texture_u", "texture_v"), ("s", "t")].into_iter().find(|(u, v)| has(u) && has(v));

    let mut data = MeshData::default();
    data.positions.reserve(vertices.len());
    for (i, el) in vertices.iter().enumerate() {
        let get = |name: &str| -> Result<f32> {
            el.get(name)
                .and_then(Property::to_f32_lossy)
                .ok_or_else(|| Error::scene(&file_loc, format!("PLY vertex {i}: property \"{name}\" is missing or a list")))
        };
        let p = Vec3::new(get("x")?, get("y")?, get("z")?);
        if !p.is_finite() {
            return Err(Error::scene(&file_loc, format!("vertex {i} has a non-finite position {p}")));
        }
        data.positions.push(p);
        if has_normals {
            data.normals.push(Vec3::new(get("nx")?, get("ny")?, get("nz")?));
        }
        if let Some((u, v)) = uv_names {
            data.uvs.push(Vec2::new(get(u)?, get(v)?));
        }
    }

    if let Some(faces) = ply.payload.get("face") {
        let face_def = &ply.header.elements["face"];
        let list_name = ["vertex_index", "vertex_indices"]
            .into_iter()
            .find(|n| face_def.properties.contains_key(*n))
            .ok_or_else(|| Error::scene(&file_loc, "PLY face element has no vertex_index/vertex_indices property"))?;
        data.indices.reserve(faces.len());
        for (f, el) in faces.iter().enumerate() {
            let list = el
                .get(list_name)
                .and_then(Property::to_u32_list)
                .ok_or_else(|| Error::scene(&file_loc, format!("PLY face {f}: \"{list_name}\" is not a list of non-negative integers")))?;
            if list.len() < 3 {
                return Err(Error::scene(&file_loc, format!("PLY face {f} has {} indices {list:?}", list.len())));
            }
            for k in 1..list.len() - 1 {
                data.indices.push([list[0], list[k], list[k + 1]]);
            }
        }
    }
    let unknown: Vec<&str> = ply.header.elements.keys().map(String::as_str).filter(|n| *n != "vertex" && *n != "face").collect();
    if !unknown.is_empty() {
        log::warn!("{}: skipping unknown PLY elements {unknown:?}", path.display());
    }
    Ok(data)
}

#[cfg(test)]
mod tests;
