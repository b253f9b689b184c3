//! Mitsuba's `.serialized` meshes (`src/shapes/serialized.cpp` of Mitsuba 3.9.1; the format of
//! Mitsuba 0.5/0.6 scene exporters).
//!
//! A file is a sequence of sub-meshes followed by an end-of-file dictionary; everything little-endian:
//! - per sub-mesh: `u16` format id `0x041C`, `u16` version (3 or 4), then one zlib stream holding
//!   `u32` flags (`0x0001` normals, `0x0002` uvs, `0x0008` vertex colours, `0x0010` face normals,
//!   `0x1000` single, `0x2000` double precision), for version 4 a NUL-terminated name, `u64` vertex
//!   count, `u64` triangle count, positions (xyz), normals (xyz, if flagged), uvs (uv, if flagged),
//!   colours (rgb, if flagged; skipped) as f32 or f64 (cast to f32), then `u32` triangle indices;
//! - the dictionary: the file offset of each sub-mesh (`u64` in version 4, `u32` in version 3) and a
//!   final `u32` sub-mesh count. `shape_index` picks the sub-mesh.
//!
//! As in Mitsuba: the file's face-normal flag is ignored (the shape's `face_normals` decides), uvs are
//! not flipped, missing normals are recomputed (by `mesh::finalize`). Deviations: a `shape_index` equal
//! to the sub-mesh count is an error (Mitsuba's check is off by one and reads past the dictionary);
//! vertex counts above `u32::MAX` are refused (Mitsuba reads `u32` indices whatever the count).
use super::MeshData;
use crate::error::{Error, Location, Result};
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

/// The `u16` that starts every sub-mesh.
pub const FORMAT_ID: u16 = 0x041C;
pub const FLAG_NORMALS: u32 = 0x0001;
pub const FLAG_TEXCOORDS: u32 = 0x0002;
pub const FLAG_COLORS: u32 = 0x0008;
pub const FLAG_FACE_NORMALS: u32 = 0x0010;
pub const FLAG_SINGLE: u32 = 0x1000;
pub const FLAG_DOUBLE: u32 = 0x2000;

/// Loads sub-mesh `shape_index` of a `.serialized` file into local space.
///
/// Errors: `FileNotFound`; `Io` when unreadable; `Scene` naming the file for a bad header or version,
/// a `shape_index` out of range, a truncated or corrupt zlib stream, or indices out of range (checked
/// later by `mesh::finalize`).
pub fn load_serialized(path: &Path, shape_index: i64, loc: &Location) -> Result<MeshData> {
    if !path.exists() {
        return Err(Error::FileNotFound { loc: loc.clone(), path: path.to_path_buf() });
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let file_loc = Location::new(path, 0);
    parse(&bytes, shape_index).map_err(|msg| Error::scene(&file_loc, format!("invalid serialized mesh (shape_index {shape_index}): {msg}")))
}

fn u16_at(b: &[u8], at: usize) -> std::result::Result<u16, String> {
    b.get(at..at + 2).map(|s| u16::from_le_bytes([s[0], s[1]])).ok_or_else(|| format!("file ends at byte {}", b.len()))
}

fn parse(bytes: &[u8], shape_index: i64) -> std::result::Result<MeshData, String> {
    let (format, version) = (u16_at(bytes, 0)?, u16_at(bytes, 2)?);
    if format != FORMAT_ID {
        return Err(format!("format id 0x{format:04X}, expected 0x{FORMAT_ID:04X}"));
    }
    if version != 3 && version != 4 {
        return Err(format!("file version {version}, expected 3 or 4"));
    }
    if shape_index < 0 {
        return Err("shape_index must be non-negative".into());
    }
    let offset = if shape_index == 0 {
        0
    } else {
        let n = bytes.len();
        let count = bytes.get(n.saturating_sub(4)..).filter(|_| n >= 8).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]));
        let count = count.ok_or("file too short for the end-of-file dictionary")? as i64;
        if shape_index >= count {
            return Err(format!("shape_index is out of range: the file has {count} meshes"));
        }
        let width = if version == 4 { 8 } else { 4 };
        let at = (n as i64 - 4 - width * (count - shape_index)) as usize;
        let entry = bytes.get(at..at + width as usize).ok_or("end-of-file dictionary is truncated")?;
        let offset = if width == 8 {
            u64::from_le_bytes(entry.try_into().unwrap_or_default())
        } else {
            u32::from_le_bytes(entry.try_into().unwrap_or_default()) as u64
        };
        let offset = usize::try_from(offset).ok().filter(|&o| o + 4 <= n).ok_or(format!("mesh offset {offset} is past the end of the file"))?;
        if u16_at(bytes, offset)? != FORMAT_ID || u16_at(bytes, offset + 2)? != version {
            return Err(format!("no sub-mesh header at offset {offset}"));
        }
        offset
    };
    let mut z = ZlibDecoder::new(&bytes[offset + 4..]);
    let flags = u32::from_le_bytes(read_exact::<4>(&mut z, "flags")?);
    if version == 4 {
        // The shape's name: NUL-terminated UTF-8 (not used).
        let mut len = 0usize;
        loop {
            let [c] = read_exact::<1>(&mut z, "shape name")?;
            if c == 0 {
                break;
            }
            len += 1;
            if len > 1 << 16 {
                return Err("shape name longer than 65536 bytes (corrupt file?)".into());
            }
        }
    }
    let vertex_count = u64::from_le_bytes(read_exact::<8>(&mut z, "vertex count")?);
    let face_count = u64::from_le_bytes(read_exact::<8>(&mut z, "triangle count")?);
    if vertex_count > u32::MAX as u64 || face_count > u32::MAX as u64 {
        return Err(format!("{vertex_count} vertices / {face_count} triangles: more than 2^32 - 1 is not supported"));
    }
    let (nv, nf) = (vertex_count as usize, face_count as usize);
    let double = flags & FLAG_DOUBLE != 0;
    let mut floats = |dim: usize, what: &str| -> std::result::Result<Vec<f32>, String> {
        let size = if double { 8 } else { 4 };
        let raw = read_n(&mut z, nv * dim * size, what)?;
        Ok(if double {
            raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()) as f32).collect()
        } else {
            raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap_or_default())).collect()
        })
    };
    let p = floats(3, "vertex positions")?;
    let normals = if flags & FLAG_NORMALS != 0 { floats(3, "vertex normals")? } else { Vec::new() };
    let uvs = if flags & FLAG_TEXCOORDS != 0 { floats(2, "texture coordinates")? } else { Vec::new() };
    if flags & FLAG_COLORS != 0 {
        floats(3, "vertex colours")?;
    }
    let raw = read_n(&mut z, nf * 12, "triangle indices")?;
    // Reach the end of the zlib stream so that its Adler-32 checksum is verified (corrupt data that
    // happened to decode is caught here).
    let mut probe = [0u8; 1];
    z.read(&mut probe).map_err(|e| format!("corrupt zlib stream: {e}"))?;
    let idx: Vec<u32> = raw.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap_or_default())).collect();
    Ok(MeshData {
        positions: p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect(),
        normals: normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect(),
        uvs: uvs.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect(),
        indices: idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    })
}

fn read_exact<const N: usize>(z: &mut impl Read, what: &str) -> std::result::Result<[u8; N], String> {
    let mut b = [0u8; N];
    z.read_exact(&mut b).map_err(|e| format!("cannot read the {what}: {e}"))?;
    Ok(b)
}

/// Reads exactly `n` bytes, growing the buffer as data arrives (a corrupt count does not allocate).
fn read_n(z: &mut impl Read, n: usize, what: &str) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    z.take(n as u64).read_to_end(&mut out).map_err(|e| format!("cannot read the {what}: {e}"))?;
    if out.len() != n {
        return Err(format!("the {what} need {n} bytes, the stream ends after {}", out.len()));
    }
    Ok(out)
}

/// One sub-mesh to write with [`write_serialized`] (tests and tools): local-space data and the flags
/// that choose precision and optional arrays (`FLAG_NORMALS` / `FLAG_TEXCOORDS` follow the data).
#[derive(Debug, Clone, Default)]
pub struct SubMesh {
    pub name: String,
    pub data: MeshData,
    pub double: bool,
    /// Vertex colours to store (and which the reader skips); empty for none.
    pub colors: Vec<Vec3>,
}

/// Writes sub-meshes as a version-4 `.serialized` file (zlib streams and the `u64` offset dictionary).
///
/// Errors: `Io` naming the file when writing fails.
pub fn write_serialized(path: &Path, meshes: &[SubMesh]) -> Result<()> {
    use flate2::write::ZlibEncoder;
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for m in meshes {
        offsets.push(out.len() as u64);
        out.extend_from_slice(&FORMAT_ID.to_le_bytes());
        out.extend_from_slice(&4u16.to_le_bytes());
        let d = &m.data;
        let mut flags = if m.double { FLAG_DOUBLE } else { FLAG_SINGLE };
        flags |= if d.normals.is_empty() { 0 } else { FLAG_NORMALS };
        flags |= if d.uvs.is_empty() { 0 } else { FLAG_TEXCOORDS };
        flags |= if m.colors.is_empty() { 0 } else { FLAG_COLORS };
        let mut s = Vec::new();
        s.extend_from_slice(&flags.to_le_bytes());
        s.extend_from_slice(m.name.as_bytes());
        s.push(0);
        s.extend_from_slice(&(d.positions.len() as u64).to_le_bytes());
        s.extend_from_slice(&(d.indices.len() as u64).to_le_bytes());
        let mut put = |v: &[f32]| {
            for &x in v {
                if m.double {
                    s.extend_from_slice(&(x as f64).to_le_bytes());
                } else {
                    s.extend_from_slice(&x.to_le_bytes());
                }
            }
        };
        put(&d.positions.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
        put(&d.normals.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
        put(&d.uvs.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
        put(&m.colors.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
        d.indices.iter().flatten().for_each(|i| s.extend_from_slice(&i.to_le_bytes()));
        let mut enc = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(&s).and_then(|_| enc.finish()).map(|z| out.extend_from_slice(&z)).map_err(|e| Error::io(path, e))?;
    }
    offsets.iter().for_each(|o| out.extend_from_slice(&o.to_le_bytes()));
    out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
    std::fs::write(path, out).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let dir = crate::testing::scratch_dir("serialized");
        dir.join(name)
    }

    fn quad(z: f32) -> MeshData {
        MeshData {
            positions: vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(1.0, 1.0, z), Vec3::new(0.1, 1.0 / 3.0, z)],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn round_trip_every_sub_mesh_and_precision() {
        let mut bare = quad(2.0);
        bare.normals.clear();
        bare.uvs.clear();
        let meshes = vec![
            SubMesh { name: "a".into(), data: quad(0.0), double: false, colors: vec![] },
            SubMesh { name: "b".into(), data: quad(1.0), double: true, colors: vec![Vec3::ONE; 4] },
            SubMesh { name: String::new(), data: bare.clone(), double: false, colors: vec![] },
        ];
        let p = tmp("three.serialized");
        write_serialized(&p, &meshes).unwrap();
        let loc = Location::default();
        assert_eq!(load_serialized(&p, 0, &loc).unwrap(), quad(0.0));
        assert_eq!(load_serialized(&p, 1, &loc).unwrap(), quad(1.0)); // 1/3 survives f64 -> f32 exactly
        assert_eq!(load_serialized(&p, 2, &loc).unwrap(), bare);
        let e = load_serialized(&p, 3, &loc).unwrap_err().to_string();
        assert!(e.contains("three.serialized") && e.contains("out of range") && e.contains("3 meshes"), "{e}");
        assert!(load_serialized(&p, -1, &loc).unwrap_err().to_string().contains("non-negative"));
    }

    #[test]
    fn version_3_dictionary_uses_u32_offsets() {
        // Two version-3 sub-meshes (no name string), u32 offsets.
        let sub = |z: f32| {
            let mut s = Vec::new();
            s.extend_from_slice(&FLAG_SINGLE.to_le_bytes());
            s.extend_from_slice(&3u64.to_le_bytes());
            s.extend_from_slice(&1u64.to_le_bytes());
            for p in [[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]] {
                p.iter().for_each(|c: &f32| s.extend_from_slice(&c.to_le_bytes()));
            }
            [0u32, 1, 2].iter().for_each(|i| s.extend_from_slice(&i.to_le_bytes()));
            let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            std::io::Write::write_all(&mut e, &s).unwrap();
            let mut out = vec![0x1C, 0x04, 3, 0];
            out.extend(e.finish().unwrap());
            out
        };
        let (a, b) = (sub(0.0), sub(5.0));
        let mut file = a.clone();
        file.extend(&b);
        file.extend(0u32.to_le_bytes());
        file.extend((a.len() as u32).to_le_bytes());
        file.extend(2u32.to_le_bytes());
        let p = tmp("v3.serialized");
        std::fs::write(&p, file).unwrap();
        let m = load_serialized(&p, 1, &Location::default()).unwrap();
        assert_eq!(m.positions[2], Vec3::new(0.0, 1.0, 5.0));
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn bad_files_are_scene_errors_naming_the_file() {
        let p = tmp("good.serialized");
        write_serialized(&p, &[SubMesh { name: "q".into(), data: quad(0.0), double: false, colors: vec![] }]).unwrap();
        let good = std::fs::read(&p).unwrap();
        let mut wrong_version = good.clone();
        wrong_version[2] = 5;
        let mut corrupt = good.clone();
        corrupt[10] ^= 0xFF;
        let cases: [(&str, Vec<u8>, &str); 5] = [
            ("cut.serialized", good[..good.len() / 2].to_vec(), "cannot read"),
            ("magic.serialized", b"ply\nformat".to_vec(), "format id"),
            ("version.serialized", wrong_version, "version 5"),
            ("corrupt.serialized", corrupt, "invalid serialized mesh"),
            ("empty.serialized", Vec::new(), "file ends"),
        ];
        for (name, bytes, what) in cases {
            let p = tmp(name);
            std::fs::write(&p, bytes).unwrap();
            let e = load_serialized(&p, 0, &Location::default()).unwrap_err();
            let text = e.to_string();
            assert!(matches!(e, Error::Scene { .. }) && text.contains(name) && text.contains(what), "{text}");
        }
        let e = load_serialized(Path::new("/nonexistent/x.serialized"), 0, &Location::new("s.xml", 3)).unwrap_err();
        assert!(matches!(e, Error::FileNotFound { .. }));
    }
}
