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
                    return Err(Error::scene(
                        &at(line_no),
                        format!("vertex {} has a non-finite position {p}", vertices.len() + 1),
                    ));
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

    let mut data = MeshData {
        positions: Vec::with_capacity(keys.len()),
        normals: Vec::new(),
        uvs: Vec::new(),
        indices,
    };
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
            return Err(Error::scene(
                &at(line_no),
                format!("reference to invalid normal {} (the file has {})", key[2], normals.len()),
            ));
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
mod tests {
    use super::*;
    use crate::scene::mesh::shared_dir;

    fn parse(s: &str) -> Result<MeshData> {
        parse_obj(s, Path::new("mem.obj"))
    }

    #[test]
    fn face_forms_and_dedup() {
        let src = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0.25\nvn 0 0 1\n\
                   f 1/1/1 2/2/1 3/2/1\nf 1/1/1 3/2/1 4/1/1\n";
        let d = parse(src).unwrap();
        assert_eq!(d.positions.len(), 4);
        assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(d.uvs[1], Vec2::new(1.0, 0.75)); // v flipped
        assert_eq!(d.uvs[0], Vec2::new(0.0, 1.0));
        assert_eq!(d.normals, vec![Vec3::Z; 4]);

        // v only, quad: fan.
        let d = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(d.normals.is_empty() && d.uvs.is_empty());

        // v//vn, pentagon; the same position with two normals gives two vertices.
        let d = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0 0\nvn 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//1 4//1 5//1\nf 1//2 2//2 3//2\n").unwrap();
        assert_eq!(d.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [5, 6, 7]]);
        assert_eq!(d.positions.len(), 8);
        assert_eq!(d.normals[5], Vec3::Y);
        assert_eq!(d.positions[5], Vec3::ZERO);

        // v/vt, tabs and CRLF, comment at the end of a face, unreferenced vertex dropped.
        let d = parse("v 9 9 9\r\nv\t0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvt 0.5 0.5\r\nf 2/1\t3/1 4/1 # c\r\n").unwrap();
        assert_eq!(d.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(d.uvs, vec![Vec2::splat(0.5); 3]);
    }

    /// Binary files renamed .obj and empty files are errors naming the file (Mitsuba fails on them too),
    /// not empty meshes; a file with vertices but no faces still loads.
    #[test]
    fn binary_and_empty_files_are_errors() {
        let dir = crate::testing::scratch_dir("obj");
        let loc = Location::new(Path::new("scene.xml"), 7);
        for (name, bytes, want) in [
            ("png.obj", &b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR"[..], "binary data at byte 8"),
            ("empty.obj", &b""[..], "no vertices"),
            ("comments.obj", &b"# nothing\n\n"[..], "no vertices"),
        ] {
            let p = dir.join(name);
            std::fs::write(&p, bytes).unwrap();
            let e = load_obj(&p, &loc).unwrap_err().to_string();
            assert!(e.starts_with("scene.xml:7:") && e.contains(name) && e.contains(want), "{e}");
        }
        let p = dir.join("points.obj");
        std::fs::write(&p, "v 0 0 0\nv\t1 0 0\n").unwrap();
        assert!(load_obj(&p, &loc).unwrap().indices.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn negative_indices() {
        let d = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf -3/-1 -2/-1 -1/-1\n").unwrap();
        assert_eq!(d.indices, vec![[0, 1, 2]]);
        assert_eq!(d.positions[2], Vec3::new(1., 1., 0.));
    }

    #[test]
    fn errors_name_file_and_line() {
        let e = parse("v 0 0 0\nv 1 x 0\n").unwrap_err().to_string();
        assert!(e.starts_with("mem.obj:2:") && e.contains("v 1 x 0"), "{e}");
        let e = parse("v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err().to_string();
        assert!(e.starts_with("mem.obj:3:") && e.contains("invalid vertex 3"), "{e}");
        let e = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1/4 2/1 3/1\n").unwrap_err().to_string();
        assert!(e.starts_with("mem.obj:5:") && e.contains("texture coordinate 4"), "{e}");
        let e = parse("v 0 0 nan\n").unwrap_err().to_string();
        assert!(e.starts_with("mem.obj:1:") && e.contains("vertex 1") && e.contains("NaN"), "{e}");
        let e = parse("v 0 0 0\nf 1/a 1 1\n").unwrap_err().to_string();
        assert!(e.starts_with("mem.obj:2:") && e.contains("\"a\""), "{e}");
        let e = load_obj(Path::new("/nonexistent/x.obj"), &Location::new("s.xml", 4)).unwrap_err();
        assert!(matches!(e, Error::FileNotFound { .. }), "{e}");
    }

    #[test]
    fn cbox_smallbox_matches_mitsuba() {
        // Values dumped from mitsuba 3.9.1 (scalar_rgb, identity to_world).
        let p = shared_dir().join("scenes/cbox/meshes/cbox_smallbox.obj");
        let d = load_obj(&p, &Location::default()).unwrap();
        assert_eq!((d.positions.len(), d.indices.len()), (24, 12));
        assert_eq!(d.positions[0], Vec3::new(130.0, 165.0, 65.0));
        assert_eq!(d.positions[7], Vec3::new(240.0, 0.0, 272.0));
        assert_eq!(d.positions[23], Vec3::new(130.0, 0.0, 65.0));
        assert_eq!(d.indices[11], [20, 22, 23]);
        assert_eq!(d.normals[7], Vec3::new(0.953400, 0.0, 0.301709)); // file normal, normalised later
        assert_eq!(d.indices[0], [0, 1, 2]);
        assert!(d.uvs.is_empty());
    }
}
