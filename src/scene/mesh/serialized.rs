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
        let offset =
            usize::try_from(offset).ok().filter(|&o| o + 4 <= n).ok_or(format!("mesh offset {offset} is past the end of the file"))?;
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
mod tests;
