//! TEMPORARY stand-in for `scene::mesh` / `scene::texture` (helper "scene-assets" writes the real ones with
//! the same signatures). Only here so `xml` compiles and its tests run before that branch lands; delete
//! together with its `mod` line in `scene/mod.rs` and the two `use` lines in `xml/plugins.rs`.
#![allow(dead_code)]
use crate::error::{Error, Location, Result};
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::path::Path;

pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
}

pub fn load_obj(path: &Path, loc: &Location) -> Result<MeshData> {
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| Error::scene(loc, format!("{}: {e}", path.display())))?;
    let mut d = MeshData { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
    for m in models {
        let base = d.positions.len() as u32;
        let m = m.mesh;
        d.positions.extend(m.positions.chunks(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        d.normals.extend(m.normals.chunks(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        d.uvs.extend(m.texcoords.chunks(2).map(|p| Vec2::new(p[0], 1.0 - p[1])));
        d.indices.extend(m.indices.chunks(3).map(|t| [t[0] + base, t[1] + base, t[2] + base]));
    }
    Ok(d)
}

pub fn load_ply(path: &Path, loc: &Location) -> Result<MeshData> {
    use ply_rs_bw::{parser::Parser, ply::{DefaultElement, Property}};
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut r = std::io::BufReader::new(f);
    let ply = Parser::<DefaultElement>::new().read_ply(&mut r).map_err(|e| Error::scene(loc, format!("{}: {e}", path.display())))?;
    let num = |p: &Property| -> Option<f32> {
        match p {
            Property::Float(v) => Some(*v),
            Property::Double(v) => Some(*v as f32),
            _ => None,
        }
    };
    let idx = |p: &Property| -> Option<Vec<u32>> {
        match p {
            Property::ListInt(v) => Some(v.iter().map(|x| *x as u32).collect()),
            Property::ListUInt(v) => Some(v.clone()),
            Property::ListUChar(v) => Some(v.iter().map(|x| *x as u32).collect()),
            Property::ListShort(v) => Some(v.iter().map(|x| *x as u32).collect()),
            Property::ListUShort(v) => Some(v.iter().map(|x| *x as u32).collect()),
            _ => None,
        }
    };
    let mut d = MeshData { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
    for v in ply.payload.get("vertex").map(|v| v.as_slice()).unwrap_or(&[]) {
        let g = |k: &str| v.get(k).and_then(num);
        d.positions.push(Vec3::new(g("x").unwrap_or(0.0), g("y").unwrap_or(0.0), g("z").unwrap_or(0.0)));
        if let (Some(x), Some(y), Some(z)) = (g("nx"), g("ny"), g("nz")) {
            d.normals.push(Vec3::new(x, y, z));
        }
        if let (Some(u), Some(w)) = (g("u").or(g("s")), g("v").or(g("t"))) {
            d.uvs.push(Vec2::new(u, w));
        }
    }
    for f in ply.payload.get("face").map(|v| v.as_slice()).unwrap_or(&[]) {
        let l = f.get("vertex_indices").or(f.get("vertex_index")).and_then(idx).unwrap_or_default();
        for k in 2..l.len() {
            d.indices.push([l[0], l[k - 1], l[k]]);
        }
    }
    Ok(d)
}

pub fn rectangle() -> MeshData {
    let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    MeshData {
        positions: p.iter().map(|(x, y)| Vec3::new(*x, *y, 0.0)).collect(),
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![[0, 1, 2], [2, 3, 0]],
    }
}

pub fn cube() -> MeshData {
    let mut d = MeshData { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let n = Vec3::AXES[axis] * s;
            let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3] * s);
            let b = d.positions.len() as u32;
            for (a, c) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                d.positions.push(n + u * a + v * c);
                d.normals.push(n);
                d.uvs.push(Vec2::new((a + 1.0) / 2.0, (c + 1.0) / 2.0));
            }
            d.indices.extend([[b, b + 1, b + 2], [b + 2, b + 3, b]]);
        }
    }
    d
}

pub fn disk() -> MeshData {
    let n = 64;
    let mut d = MeshData { positions: vec![Vec3::ZERO], normals: vec![Vec3::Z], uvs: vec![], indices: vec![] };
    for i in 0..n {
        let t = i as f32 / n as f32 * std::f32::consts::TAU;
        d.positions.push(Vec3::new(t.cos(), t.sin(), 0.0));
        d.normals.push(Vec3::Z);
        d.indices.push([0, 1 + i, 1 + (i + 1) % n]);
    }
    d
}

pub fn sphere() -> MeshData {
    let (nu, nv) = (64u32, 32u32);
    let mut d = MeshData { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
    for j in 0..=nv {
        for i in 0..=nu {
            let (phi, theta) = (i as f32 / nu as f32 * std::f32::consts::TAU, j as f32 / nv as f32 * std::f32::consts::PI);
            let p = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            d.positions.push(p);
            d.normals.push(p);
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let a = j * (nu + 1) + i;
            let b = a + nu + 1;
            d.indices.extend([[a, b, a + 1], [a + 1, b, b + 1]]);
        }
    }
    d
}

pub fn finalize(
    data: MeshData,
    world_from_local: Mat4,
    face_normals: bool,
    flip_normals: bool,
    loc: &Location,
) -> Result<(Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>)> {
    let n_from_local = Mat3::from_mat4(world_from_local).inverse().transpose();
    let mut p: Vec<Vec3> = data.positions.iter().map(|x| world_from_local.transform_point3(*x)).collect();
    if p.iter().any(|x| !x.is_finite()) {
        return Err(Error::scene(loc, "mesh has NaN/inf vertex positions"));
    }
    let mut uvs = data.uvs;
    let mut idx = data.indices;
    let sign = if flip_normals { -1.0 } else { 1.0 };
    let n: Vec<Vec3> = if face_normals {
        let (mut p2, mut n2, mut uv2, mut i2) = (vec![], vec![], vec![], vec![]);
        for t in &idx {
            let fn_ = (p[t[1] as usize] - p[t[0] as usize]).cross(p[t[2] as usize] - p[t[0] as usize]).normalize_or_zero() * sign;
            let b = p2.len() as u32;
            for k in t {
                p2.push(p[*k as usize]);
                n2.push(fn_);
                if !uvs.is_empty() {
                    uv2.push(uvs[*k as usize]);
                }
            }
            i2.push([b, b + 1, b + 2]);
        }
        p = p2;
        uvs = uv2;
        idx = i2;
        n2
    } else if data.normals.len() == p.len() {
        data.normals.iter().map(|x| (n_from_local * *x).normalize_or_zero() * sign).collect()
    } else {
        let mut acc = vec![Vec3::ZERO; p.len()];
        for t in &idx {
            let fn_ = (p[t[1] as usize] - p[t[0] as usize]).cross(p[t[2] as usize] - p[t[0] as usize]).normalize_or_zero();
            for k in 0..3 {
                let (a, b, c) = (p[t[k] as usize], p[t[(k + 1) % 3] as usize], p[t[(k + 2) % 3] as usize]);
                let ang = (b - a).normalize_or_zero().dot((c - a).normalize_or_zero()).clamp(-1.0, 1.0).acos();
                acc[t[k] as usize] += fn_ * ang;
            }
        }
        acc.iter().map(|x| x.normalize_or_zero() * sign).collect()
    };
    Ok((p, n, uvs, idx))
}

pub fn load_bitmap(path: &Path, loc: &Location, raw: bool) -> Result<(u32, u32, Vec<Vec3>)> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
    if ext == "exr" {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
            |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b),
        )
        .map_err(|e| Error::scene(loc, format!("{}: {e}", path.display())))?;
        let s = img.layer_data.size;
        return Ok((s.width() as u32, s.height() as u32, img.layer_data.channel_data.pixels.1));
    }
    let img = image::open(path).map_err(|e| Error::scene(loc, format!("{}: {e}", path.display())))?.to_rgb32f();
    let lin = |c: f32| if raw { c } else if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    let data = img.pixels().map(|p| Vec3::new(lin(p[0]), lin(p[1]), lin(p[2]))).collect();
    Ok((img.width(), img.height(), data))
}
