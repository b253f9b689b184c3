//! Wavefront OBJ reader reproducing Mitsuba 3.9.1's `src/shapes/obj.cpp`.
//!
//! Written by hand rather than with `tobj` because Mitsuba merges every `o`/`g` group into one mesh with a
//! single vertex table, which `tobj` (one model per group) cannot reproduce, and because errors must name
//! the file line.
//!
//! Mitsuba's rules, reproduced:
//! - `v x y z` (a 4th value is ignored), `vn x y z`, `vt u v` (a 3rd value is ignored) with the v-flip
//!   `v' = 1 - v` (`flip_tex_coords`, default true); every other statement (`o`, `g`, `s`, `usemtl`,
//!   `mtllib`, comments) is ignored.
//! - Faces `v`, `v/vt`, `v//vn`, `v/vt/vn`; polygons are fan-triangulated `(0,1,2), (0,2,3), ...`.
//! - Output vertices are the distinct `(v, vt, vn)` triples in order of first use; unreferenced `v` lines
//!   are dropped.
//! - uvs are present when the file has any `vt`; normals when it has any `vn`.
//!
//! Deviations: negative (relative) indices are resolved as the OBJ specification says (Mitsuba rejects
//! them as "reference to invalid vertex"); a face corner without `vt` (or `vn`) in a file that has them
//! gets uv (0, 0) (Mitsuba leaves the memory uninitialised) -- for normals the whole mesh falls back to
//! recomputed normals, with a warning; a face with fewer than 3 corners is skipped with a warning as
//! Mitsuba skips it silently.
use super::MeshData;
use crate::error::{Error, Location, Result};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Loads an OBJ file into local space (Mitsuba applies `to_world` later, in [`super::finalize`]).
///
/// Errors: `FileNotFound`; `Io` when unreadable; `Scene` with `file:line` for unparsable numbers,
/// non-finite positions and indices that reference missing `v`/`vt`/`vn` entries.
pub fn load_obj(path: &Path, loc: &Location) -> Result<MeshData> {
    if !path.exists() {
        return Err(Error::FileNotFound { loc: loc.clone(), path: path.to_path_buf() });
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    // An OBJ is text: a NUL byte means a binary file (an image or mesh of another format renamed .obj),
    // which would otherwise load as an empty mesh.
    if let Some(at) = bytes.iter().position(|&b| b == 0) {
        return Err(Error::scene(loc, format!("\"{}\" is not an OBJ text file (binary data at byte {at})", path.display())));
    }
    let text = String::from_utf8_lossy(&bytes);
    let data = parse_obj(&text, path)?;
    if data.positions.is_empty() && !text.lines().any(|l| l.trim_start().strip_prefix('v').is_some_and(|r| r.starts_with([' ', '\t']))) {
        return Err(Error::scene(loc, format!("\"{}\" holds no vertices (an empty or non-OBJ file)", path.display())));
    }
    Ok(data)
}

/// One face corner: 1-based (v, vt, vn), 0 = absent (Mitsuba's hash key).
type Key = [u32; 3];

fn parse_obj(text: &str, path: &Path) -> Result<MeshData> {
    let at = |line: usize| Location::new(path, line as u32);
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut texcoords: Vec<Vec2> = Vec::new();
    let mut key_to_id: HashMap<Key, u32> = HashMap::new();
    let mut keys: Vec<(Key, usize)> = Vec::new(); // key and the line of its first use, by output id
    let mut indices: Vec<[u32; 3]> = Vec::new();

    for (line_idx, raw) in text.split('\n').enumerate() {
        let line_no = line_idx + 1;
        let line = raw.trim_start_matches([' ', '\t', '\r']);
        let (tag, rest) = match line.find([' ', '\t']) {
            Some(i) => (&line[..i], &line[i + 1..]),
            None => continue,
        };
        match tag {
            "v" => {
                let [x, y, z] = parse_floats::<3>(rest, line_no, path, line)?;
                let p = Vec3::new(x, y, z);
                if !p.is_finite() {
                    return Err(Error::scene(&at(line_no), format!("vertex {} has a non-finite position {p}", vertices.len() + 1)));
                }
                vertices.push(p);
            }
            "vn" => {
                let [x, y, z] = parse_floats::<3>(rest, line_no, path, line)?;
                normals.push(Vec3::new(x, y, z));
            }
            "vt" => {
                let [u, v] = parse_floats::<2>(rest, line_no, path, line)?;
                texcoords.push(Vec2::new(u, 1.0 - v));
            }
            "f" => {
                let mut corners: Vec<u32> = Vec::with_capacity(4);
                for token in rest.split_ascii_whitespace() {
                    if token.starts_with('#') {
                        break;
                    }
                    let key = parse_corner(token, [vertices.len(), texcoords.len(), normals.len()])
                        .map_err(|msg| Error::scene(&at(line_no), format!("{msg} in \"{}\"", line.trim_end())))?;
                    if key[0] as usize > vertices.len() {
                        return Err(Error::scene(
                            &at(line_no),
                            format!("reference to invalid vertex {} ({} defined so far)", key[0], vertices.len()),
                        ));
                    }
                    let id = *key_to_id.entry(key).or_insert_with(|| {
                        keys.push((key, line_no));
                        (keys.len() - 1) as u32
                    });
                    corners.push(id);
                }
                if corners.len() < 3 {
                    log::warn!("{}: face with {} corners skipped", at(line_no), corners.len());
                    continue;
                }
                for k in 1..corners.len() - 1 {
                    indices.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }

    let mut data = MeshData { positions: Vec::with_capacity(keys.len()), normals: Vec::new(), uvs: Vec::new(), indices };
    let mut missing_uv = 0usize;
    let mut missing_normal = 0usize;
    for &(key, line_no) in &keys {
        data.positions.push(vertices[key[0] as usize - 1]);
        if key[1] as usize > texcoords.len() {
            return Err(Error::scene(
                &at(line_no),
                format!("reference to invalid texture coordinate {} (the file has {})", key[1], texcoords.len()),
            ));
        }
        if key[2] as usize > normals.len() {
            return Err(Error::scene(&at(line_no), format!("reference to invalid normal {} (the file has {})", key[2], normals.len())));
        }
        if !texcoords.is_empty() {
            if key[1] == 0 {
                missing_uv += 1;
                data.uvs.push(Vec2::ZERO);
            } else {
                data.uvs.push(texcoords[key[1] as usize - 1]);
            }
        }
        if !normals.is_empty() {
            if key[2] == 0 {
                missing_normal += 1;
            } else {
                data.normals.push(normals[key[2] as usize - 1]);
            }
        }
    }
    if missing_uv > 0 {
        log::warn!("{}: {missing_uv} face corners have no texture coordinate; using (0, 0)", path.display());
    }
    if missing_normal > 0 {
        log::warn!("{}: {missing_normal} face corners have no normal; recomputing all normals", path.display());
        data.normals.clear();
    }
    Ok(data)
}

/// Parses the first `N` whitespace-separated floats of `rest` (more are ignored, as Mitsuba does).
fn parse_floats<const N: usize>(rest: &str, line_no: usize, path: &Path, line: &str) -> Result<[f32; N]> {
    let mut out = [0.0f32; N];
    let mut it = rest.split_ascii_whitespace();
    for slot in out.iter_mut() {
        *slot = it.next().and_then(|t| t.parse::<f32>().ok()).ok_or_else(|| {
            Error::scene(
                &Location::new(path, line_no as u32),
                format!("could not parse line \"{}\" (expected {N} numbers)", line.trim_end()),
            )
        })?;
    }
    Ok(out)
}

/// Parses a face corner `v[/vt[/vn]]` into a key of 1-based indices; `counts` resolves negative indices.
fn parse_corner(token: &str, counts: [usize; 3]) -> std::result::Result<Key, String> {
    let mut key = [0u32; 3];
    let parts: Vec<&str> = token.split('/').collect();
    if parts.len() > 3 {
        return Err(format!("face corner \"{token}\" has more than 3 parts"));
    }
    for (slot, part) in parts.iter().enumerate() {
        if part.is_empty() {
            if slot == 0 {
                return Err(format!("face corner \"{token}\" has no vertex index"));
            }
            continue;
        }
        let value: i64 = part.parse().map_err(|_| format!("bad index \"{part}\" in face corner \"{token}\""))?;
        let resolved = if value < 0 { counts[slot] as i64 + value + 1 } else { value };
        if resolved <= 0 || resolved > u32::MAX as i64 {
            return Err(format!("index {value} in face corner \"{token}\" is out of range"));
        }
        key[slot] = resolved as u32;
    }
    Ok(key)
}

#[cfg(test)]
mod tests;
