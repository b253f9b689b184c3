//! Saving and loading a precomputed `Transfer` (Hašan, Pellacini, Bala, SIGGRAPH 2006, Sec. 4: the
//! precomputation is the expensive part, relighting reuses it) as a list of named arrays, and the content
//! hash of what a transfer depends on in its scene.
//!
//! Format: `to_arrays` turns a transfer into named, typed, shaped arrays; `from_arrays` checks and
//! rebuilds one. The container (a zip of `.npy` arrays written and read by numpy, with a format name,
//! version and the scene hash next to these arrays) is the Python side's (`manylights.relight_store`).
//! Names:
//! - `options.*` scalars: the `TransferOptions`; `size` (2,) u32: the film's width and height;
//! - `cloud.*` (n_g, 3) / (n_g,) float32: the gather cloud the rows were computed on. A loaded transfer
//!   regenerates its cloud from the scene and seed (the cloud is deterministic, and its BSDF records are
//!   not stored) and requires these arrays to be bit-identical, so a scene change that moved a surface
//!   point or its coefficients is caught even where the scene hash would not see it;
//! - `hierarchy.order` (n_g,) u32: the quad-tree's leaf order (the gather image);
//! - `emit_position`, `emit_normal` (n_g, 3): where each gather sample emits from;
//! - sparse-row matrices, three arrays each: `<name>.offsets` (rows + 1,) u64 (row r is
//!   `offsets[r] .. offsets[r + 1]` of the next two), `<name>.index` (nnz,) u32 wavelet coefficient,
//!   `<name>.value` (nnz * channels,) float32: `final_gather` (F_d^w, one row per pixel; in a scene with
//!   masked surfaces one per view sample), `multibounce` (the gather-to-gather rows; none with one bounce or
//!   photons), `photon_multibounce` (the photon-mapped
//!   M_E^w, 3 channels, one row per gather sample; none with one bounce or the gather method), `glossy`
//!   (F_g^w, one row per `final_gather` row, or none when no pixel is glossy); `glossy_color` (as many, 3) k_g;
//! - `stats.*` and `seconds.*`: what the precomputation cast and how long its stages took.
//!
//! A new matrix field of `Transfer` is one `w.rows(...)` line in `to_arrays` and one `r.rows(...)` line
//! in `from_arrays`; a new option one line in each of `options` / `read_options`. Derived data (the
//! wavelet lights' image norms) is recomputed on load exactly as `Transfer::new` computes it.
//!
//! Scene hash (`scene_key`): the bytes of what the transfer depends on, in four sections hashed separately
//! by the caller so a mismatch can say which changed: `geometry` (per shape: kind, positions, shading
//! normals, uvs, triangles, face-normal flag), `materials` (per shape: its BSDF with nested BSDFs and
//! textures resolved to their contents, so indices that shift when unrelated entries are added do not
//! matter), `camera` (frame, field of view, clip planes, principal point) and `film` (width, height).
//! Emitters are not part of it (relighting exists to change them; area emitters' shapes are geometry),
//! nor are ids and file locations.
use super::haar::{self, SparseRow};
use super::hierarchy::{morton_pixel, ClusterHierarchy};
use super::multibounce::Multibounce;
use super::transfer::{NearField, Transfer, TransferOptions};
use crate::error::{Error, Result};
use crate::lights::gather::{gather_levels, GatherCloud, GatherOptions};
use crate::scene::{Bsdf, Param, Scene, Texture};
use glam::Vec3;
use std::collections::HashMap;

/// The data of a named array (little-endian when written).
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    F32(Vec<f32>),
    F64(Vec<f64>),
    U32(Vec<u32>),
    U64(Vec<u64>),
}

impl Data {
    pub fn len(&self) -> usize {
        match self {
            Data::F32(v) => v.len(),
            Data::F64(v) => v.len(),
            Data::U32(v) => v.len(),
            Data::U64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// numpy's name of the element type.
    pub fn dtype(&self) -> &'static str {
        match self {
            Data::F32(_) => "float32",
            Data::F64(_) => "float64",
            Data::U32(_) => "uint32",
            Data::U64(_) => "uint64",
        }
    }
}

/// One array of a saved transfer: name, shape (row-major; `[]` for a scalar) and data.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedArray {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: Data,
}

struct Writer(Vec<NamedArray>);

impl Writer {
    fn put(&mut self, name: &str, shape: &[usize], data: Data) {
        self.0.push(NamedArray { name: name.to_string(), shape: shape.to_vec(), data });
    }
    fn u64(&mut self, name: &str, v: u64) {
        self.put(name, &[], Data::U64(vec![v]));
    }
    fn f32(&mut self, name: &str, v: f32) {
        self.put(name, &[], Data::F32(vec![v]));
    }
    fn f64(&mut self, name: &str, v: f64) {
        self.put(name, &[], Data::F64(vec![v]));
    }
    fn f32s(&mut self, name: &str, v: &[f32]) {
        self.put(name, &[v.len()], Data::F32(v.to_vec()));
    }
    fn vec3s(&mut self, name: &str, v: &[Vec3]) {
        self.put(name, &[v.len(), 3], Data::F32(v.iter().flat_map(|p| p.to_array()).collect()));
    }
    /// A sparse-row matrix as `<name>.offsets`, `<name>.index`, `<name>.value`.
    fn rows(&mut self, name: &str, rows: &[SparseRow]) {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0u64);
        let (mut index, mut value) = (Vec::new(), Vec::new());
        for r in rows {
            index.extend_from_slice(&r.index);
            value.extend_from_slice(&r.value);
            offsets.push(index.len() as u64);
        }
        self.put(&format!("{name}.offsets"), &[offsets.len()], Data::U64(offsets));
        self.put(&format!("{name}.index"), &[index.len()], Data::U32(index));
        self.put(&format!("{name}.value"), &[value.len()], Data::F32(value));
    }
}

/// The options part of `to_arrays`.
fn options(w: &mut Writer, o: &TransferOptions) {
    w.u64("options.gather", o.gather as u64);
    w.u64("options.coefficients", o.coefficients as u64);
    w.u64("options.seed", o.seed);
    w.f32("options.k_weight", o.k_weight);
    w.f32("options.threshold", o.threshold);
    w.f32("options.clamp", o.clamp);
    w.u64("options.bounces", o.bounces as u64);
    w.u64("options.multibounce_coefficients", o.multibounce_coefficients as u64);
    w.u64("options.near_field", matches!(o.near_field, NearField::Point) as u64);
    w.u64("options.multibounce", matches!(o.multibounce, Multibounce::Photons) as u64);
    w.u64("options.photons_per_sample", o.photons_per_sample as u64);
    w.u64("options.photon_neighbours", o.photon_neighbours as u64);
    w.u64("options.glossy", o.glossy as u64);
}

/// Every array of a transfer (module docs), in a fixed order.
pub fn to_arrays(t: &Transfer) -> Vec<NamedArray> {
    let mut w = Writer(Vec::new());
    options(&mut w, &t.opts);
    w.put("size", &[2], Data::U32(vec![t.width, t.height]));
    let c = &t.cloud;
    w.vec3s("cloud.position", &c.position);
    w.vec3s("cloud.normal", &c.normal);
    w.vec3s("cloud.geo_normal", &c.geo_normal);
    w.f32s("cloud.area", &c.area);
    w.vec3s("cloud.k_d", &c.k_d);
    w.vec3s("cloud.k_g", &c.k_g);
    w.put("hierarchy.order", &[t.hierarchy.order.len()], Data::U32(t.hierarchy.order.clone()));
    w.vec3s("emit_position", &t.emit_position);
    w.vec3s("emit_normal", &t.emit_normal);
    // Matrices: one line each (module docs).
    w.rows("final_gather", &t.rows);
    w.rows("multibounce", &t.bounce_rows);
    w.rows("photon_multibounce", &t.photon_rows);
    w.rows("glossy", &t.glossy_rows);
    w.vec3s("glossy_color", &t.glossy_color);
    w.u64("stats.glossy_pixels", t.glossy_pixels as u64);
    w.u64("stats.photons", t.photons);
    w.u64("stats.shadow_rays", t.shadow_rays);
    w.u64("stats.links", t.links);
    w.f64("seconds.gather_cloud", t.seconds_cloud);
    w.f64("seconds.hierarchy", t.seconds_hierarchy);
    w.f64("seconds.final_gather", t.seconds_rows);
    w.f64("seconds.multibounce", t.seconds_bounce_rows);
    w.f64("seconds.glossy_final_gather", t.seconds_glossy_rows);
    w.0
}

struct Reader {
    arrays: HashMap<String, NamedArray>,
}

impl Reader {
    fn take(&mut self, name: &str, shape: &[usize]) -> Result<Data> {
        let a = self.arrays.remove(name).ok_or_else(|| Error::invalid(format!("the saved transfer has no array '{name}'")))?;
        if a.shape != shape {
            return Err(Error::invalid(format!("array '{name}' has shape {:?}, expected {shape:?}", a.shape)));
        }
        let count: usize = shape.iter().product();
        if a.data.len() != count {
            return Err(Error::invalid(format!("array '{name}' has {} values for shape {shape:?}", a.data.len())));
        }
        Ok(a.data)
    }
    fn wrong(name: &str, d: &Data, want: &str) -> Error {
        Error::invalid(format!("array '{name}' has dtype {}, expected {want}", d.dtype()))
    }
    fn u64s(&mut self, name: &str, shape: &[usize]) -> Result<Vec<u64>> {
        match self.take(name, shape)? {
            Data::U64(v) => Ok(v),
            d => Err(Reader::wrong(name, &d, "uint64")),
        }
    }
    fn u32s(&mut self, name: &str, shape: &[usize]) -> Result<Vec<u32>> {
        match self.take(name, shape)? {
            Data::U32(v) => Ok(v),
            d => Err(Reader::wrong(name, &d, "uint32")),
        }
    }
    /// float32 values, all finite unless `allow_inf` (then +inf is allowed too, NaN never).
    fn f32s(&mut self, name: &str, shape: &[usize], allow_inf: bool) -> Result<Vec<f32>> {
        let v = match self.take(name, shape)? {
            Data::F32(v) => v,
            d => return Err(Reader::wrong(name, &d, "float32")),
        };
        if let Some(i) = v.iter().position(|x| !(x.is_finite() || allow_inf && *x == f32::INFINITY)) {
            return Err(Error::invalid(format!("array '{name}' holds a non-finite value {} at {i}", v[i])));
        }
        Ok(v)
    }
    fn u64(&mut self, name: &str) -> Result<u64> {
        Ok(self.u64s(name, &[])?[0])
    }
    fn usize(&mut self, name: &str) -> Result<usize> {
        let v = self.u64(name)?;
        usize::try_from(v).map_err(|_| Error::invalid(format!("array '{name}' = {v} is too large")))
    }
    fn f32(&mut self, name: &str, allow_inf: bool) -> Result<f32> {
        Ok(self.f32s(name, &[], allow_inf)?[0])
    }
    fn f64(&mut self, name: &str) -> Result<f64> {
        match self.take(name, &[])? {
            Data::F64(v) if v[0].is_finite() && v[0] >= 0.0 => Ok(v[0]),
            Data::F64(v) => Err(Error::invalid(format!("array '{name}' = {} is not a finite number of seconds", v[0]))),
            d => Err(Reader::wrong(name, &d, "float64")),
        }
    }
    fn vec3s(&mut self, name: &str, n: usize) -> Result<Vec<Vec3>> {
        Ok(self.f32s(name, &[n, 3], false)?.chunks_exact(3).map(Vec3::from_slice).collect())
    }
    /// A sparse-row matrix of `count` rows over `n` wavelet coefficients (indices < n, strictly
    /// increasing within a row, as `haar::cull_area_weighted` makes them).
    fn rows(&mut self, name: &str, count: usize, n: usize) -> Result<Vec<SparseRow>> {
        self.rows_with(name, count, n, 1)
    }

    /// `rows` of `channels` values per kept coefficient.
    fn rows_with(&mut self, name: &str, count: usize, n: usize, channels: usize) -> Result<Vec<SparseRow>> {
        let offsets = self.u64s(&format!("{name}.offsets"), &[count + 1])?;
        let nnz = offsets[count];
        let nnz = usize::try_from(nnz).map_err(|_| Error::invalid(format!("'{name}.offsets' ends at {nnz}")))?;
        let index = self.u32s(&format!("{name}.index"), &[nnz])?;
        let value = self.f32s(&format!("{name}.value"), &[nnz * channels], false)?;
        if offsets[0] != 0 {
            return Err(Error::invalid(format!("'{name}.offsets' must start at 0, got {}", offsets[0])));
        }
        let mut rows = Vec::with_capacity(count);
        for r in 0..count {
            let (a, b) = (offsets[r] as usize, offsets[r + 1] as usize);
            if a > b || b > nnz {
                return Err(Error::invalid(format!("'{name}.offsets' is not increasing at row {r} ({a}, {b})")));
            }
            let idx = &index[a..b];
            if let Some(k) = idx.iter().position(|&j| j as usize >= n) {
                return Err(Error::invalid(format!("'{name}' row {r}: coefficient index {} >= gather ({n})", idx[k])));
            }
            if idx.windows(2).any(|p| p[0] >= p[1]) {
                return Err(Error::invalid(format!("'{name}' row {r}: coefficient indices are not increasing")));
            }
            rows.push(SparseRow { index: idx.to_vec(), value: value[a * channels..b * channels].to_vec() });
        }
        Ok(rows)
    }
}

/// The options part of `from_arrays`, checked as `Transfer::new` checks them.
fn read_options(r: &mut Reader) -> Result<TransferOptions> {
    Ok(TransferOptions {
        gather: r.usize("options.gather")?,
        coefficients: r.usize("options.coefficients")?,
        seed: r.u64("options.seed")?,
        k_weight: r.f32("options.k_weight", false)?,
        threshold: r.f32("options.threshold", false)?,
        clamp: r.f32("options.clamp", true)?,
        bounces: u32::try_from(r.u64("options.bounces")?).map_err(|_| Error::invalid("options.bounces is too large"))?,
        multibounce_coefficients: r.usize("options.multibounce_coefficients")?,
        near_field: match r.u64("options.near_field")? {
            0 => NearField::Disc,
            1 => NearField::Point,
            v => return Err(Error::invalid(format!("options.near_field must be 0 (disc) or 1 (point), got {v}"))),
        },
        multibounce: match r.u64("options.multibounce")? {
            0 => Multibounce::Gather,
            1 => Multibounce::Photons,
            v => return Err(Error::invalid(format!("options.multibounce must be 0 (gather) or 1 (photons), got {v}"))),
        },
        photons_per_sample: r.usize("options.photons_per_sample")?,
        photon_neighbours: r.usize("options.photon_neighbours")?,
        glossy: match r.u64("options.glossy")? {
            0 => false,
            1 => true,
            v => return Err(Error::invalid(format!("options.glossy must be 0 or 1, got {v}"))),
        },
    })
}

/// Requires a regenerated cloud array to equal the saved one bit for bit.
fn same<T: PartialEq>(name: &str, scene: &Scene, saved: &[T], now: &[T]) -> Result<()> {
    if let Some(i) = saved.iter().zip(now).position(|(a, b)| a != b) {
        return Err(Error::invalid(format!(
            "{}: the gather cloud regenerated from this scene differs from the saved one ({name} of sample {i}): \
             the scene changed after the precomputation; precompute again",
            scene.path.display()
        )));
    }
    Ok(())
}

/// Rebuilds a transfer from `arrays` (module docs) on `scene`, whose view is `width` x `height`.
///
/// Errors: `InvalidParameter` naming the array for a missing array, a wrong dtype or shape, non-finite
/// values, rows out of range, a hierarchy order that is not a permutation, options that `Transfer::new`
/// refuses, a film size or gather cloud that differs from this scene's, arrays left over (a file of
/// another format revision); what `GatherCloud::new` raises.
pub fn from_arrays(scene: &Scene, width: u32, height: u32, arrays: Vec<NamedArray>) -> Result<Transfer> {
    let mut r = Reader { arrays: HashMap::new() };
    for a in arrays {
        if r.arrays.contains_key(&a.name) {
            return Err(Error::invalid(format!("array '{}' appears twice", a.name)));
        }
        r.arrays.insert(a.name.clone(), a);
    }
    let opts = read_options(&mut r)?;
    super::multibounce::check_options(&opts)?;
    let levels = gather_levels(opts.gather)?;
    let n = opts.gather;
    if !(1..=n).contains(&opts.coefficients) || (opts.bounces > 1 && !(1..=n).contains(&opts.multibounce_coefficients)) {
        return Err(Error::invalid(format!(
            "saved coefficient counts ({}, {}) must be in 1 ..= gather ({n})",
            opts.coefficients, opts.multibounce_coefficients
        )));
    }
    // NaN never gets here: `Reader::f32` refuses it.
    if !(1..=64).contains(&opts.bounces) || opts.k_weight <= 0.0 || opts.clamp <= 0.0 || opts.threshold < 0.0 {
        return Err(Error::invalid(format!("saved options out of range: {opts:?}")));
    }
    let size = r.u32s("size", &[2])?;
    if (size[0], size[1]) != (width, height) {
        return Err(Error::invalid(format!(
            "{}: the transfer was precomputed for a {}x{} film, the scene's is {width}x{height}",
            scene.path.display(),
            size[0],
            size[1]
        )));
    }
    let cloud = GatherCloud::new(scene, &GatherOptions { n, seed: opts.seed, include_emitters: true })?;
    same("position", scene, &r.vec3s("cloud.position", n)?, &cloud.position)?;
    same("normal", scene, &r.vec3s("cloud.normal", n)?, &cloud.normal)?;
    same("geometric normal", scene, &r.vec3s("cloud.geo_normal", n)?, &cloud.geo_normal)?;
    same("area", scene, &r.f32s("cloud.area", &[n], false)?, &cloud.area)?;
    same("k_d", scene, &r.vec3s("cloud.k_d", n)?, &cloud.k_d)?;
    same("k_g", scene, &r.vec3s("cloud.k_g", n)?, &cloud.k_g)?;
    let order = r.u32s("hierarchy.order", &[n])?;
    let side = 1u32 << levels;
    let (mut pixel, mut sample_at_pixel) = (vec![u32::MAX; n], vec![0u32; n]);
    for (m, &i) in order.iter().enumerate() {
        if i as usize >= n || pixel[i as usize] != u32::MAX {
            return Err(Error::invalid(format!("'hierarchy.order' is not a permutation of 0 .. {n} (entry {m} = {i})")));
        }
        let (row, col) = morton_pixel(m as u64);
        pixel[i as usize] = row * side + col;
        sample_at_pixel[(row * side + col) as usize] = i;
    }
    let hierarchy = ClusterHierarchy { levels, k_weight: opts.k_weight, order, pixel, sample_at_pixel };
    let emit_position = r.vec3s("emit_position", n)?;
    let emit_normal = r.vec3s("emit_normal", n)?;
    let pixels = width as usize * height as usize;
    // Matrices: one line each (module docs). Final-gather rows: one per pixel, or with masked surfaces one
    // per view sample (`masks::row_samples`; the view, made after loading, is checked against them).
    let masked = crate::raytrace::mask::scene_has_masks(scene);
    let row_count = r.arrays.get("final_gather.offsets").map_or(pixels, |a| a.shape.first().copied().unwrap_or(1).saturating_sub(1));
    if row_count != pixels && !(masked && row_count > pixels) {
        return Err(Error::invalid(format!(
            "'final_gather' has {row_count} rows; expected one per pixel ({pixels}){}",
            if masked { " or more (one per view sample)" } else { "" }
        )));
    }
    let rows = r.rows("final_gather", row_count, n)?;
    let photon = opts.bounces > 1 && opts.multibounce == Multibounce::Photons;
    let bounce_rows = r.rows("multibounce", if opts.bounces > 1 && !photon { n } else { 0 }, n)?;
    let photon_rows = r.rows_with("photon_multibounce", if photon { n } else { 0 }, n, 3)?;
    // Glossy rows: one per final-gather row, or none (no glossy pixel, or F_g off).
    let glossy_count = r.arrays.get("glossy.offsets").map_or(0, |a| a.shape.first().copied().unwrap_or(1).saturating_sub(1));
    if glossy_count != 0 && (glossy_count != row_count || !opts.glossy) {
        return Err(Error::invalid(format!(
            "'glossy' has {glossy_count} rows; expected 0 or one per final-gather row ({row_count}) with glossy on"
        )));
    }
    let glossy_rows = r.rows("glossy", glossy_count, n)?;
    let glossy_color = r.vec3s("glossy_color", glossy_count)?;
    let glossy_image_norms = if glossy_rows.is_empty() { Vec::new() } else { haar::column_norms(&glossy_rows, n, 1)? };
    let image_norms = haar::column_norms(&rows, n, 1)?;
    let opacity = super::masks::gather_opacity(&crate::raytrace::mask::Masks::new(scene), &cloud);
    let t = Transfer {
        opacity,
        cloud,
        hierarchy,
        emit_position,
        emit_normal,
        width,
        height,
        rows,
        image_norms,
        bounce_rows,
        photon_rows,
        photons: r.u64("stats.photons")?,
        glossy_rows,
        glossy_color,
        glossy_image_norms,
        glossy_pixels: r.usize("stats.glossy_pixels")?,
        seconds_glossy_rows: r.f64("seconds.glossy_final_gather")?,
        shadow_rays: r.u64("stats.shadow_rays")?,
        links: r.u64("stats.links")?,
        seconds_cloud: r.f64("seconds.gather_cloud")?,
        seconds_hierarchy: r.f64("seconds.hierarchy")?,
        seconds_rows: r.f64("seconds.final_gather")?,
        seconds_bounce_rows: r.f64("seconds.multibounce")?,
        opts,
    };
    if !r.arrays.is_empty() {
        let mut names: Vec<&String> = r.arrays.keys().collect();
        names.sort();
        return Err(Error::invalid(format!("the saved transfer has arrays this version does not know: {names:?}")));
    }
    Ok(t)
}

/// Feeds `sink(section, bytes)` the content that a transfer of `scene` depends on (module docs);
/// sections: "geometry", "materials", "camera", "film", each a sequence of length-prefixed pieces.
pub fn scene_key(scene: &Scene, sink: &mut dyn FnMut(&str, &[u8])) {
    let mut put = |section: &str, bytes: &[u8]| {
        sink(section, &(bytes.len() as u64).to_le_bytes());
        sink(section, bytes);
    };
    for m in &scene.meshes {
        put("geometry", format!("{:?} face_normals={}", m.kind, m.face_normals).as_bytes());
        put("geometry", bytemuck::cast_slice(&m.positions));
        put("geometry", bytemuck::cast_slice(&m.normals));
        put("geometry", bytemuck::cast_slice(&m.uvs));
        put("geometry", bytemuck::cast_slice(&m.indices));
        let mut key = Vec::new();
        bsdf_key(scene, m.bsdf, &mut key, 0);
        put("materials", &key);
    }
    let c = &scene.camera;
    put("camera", bytemuck::cast_slice(&c.world_from_camera.to_cols_array()));
    put("camera", bytemuck::cast_slice(&[c.fov_x, c.near_clip, c.far_clip, c.principal_point_offset.x, c.principal_point_offset.y]));
    put("film", bytemuck::cast_slice(&[c.width, c.height]));
}

/// Every texture-valued parameter of a BSDF that holds no nested BSDFs.
fn params_mut(b: &mut Bsdf) -> Vec<&mut Param> {
    match b {
        Bsdf::Diffuse { reflectance } => vec![reflectance],
        Bsdf::RoughPlastic { diffuse_reflectance, specular_reflectance, .. }
        | Bsdf::Plastic { diffuse_reflectance, specular_reflectance, .. } => vec![diffuse_reflectance, specular_reflectance],
        Bsdf::RoughConductor { alpha_u, alpha_v, specular_reflectance, .. } => vec![alpha_u, alpha_v, specular_reflectance],
        Bsdf::Conductor { specular_reflectance, .. } => vec![specular_reflectance],
        Bsdf::Dielectric { .. } => vec![],
        Bsdf::RoughDielectric { alpha_u, alpha_v, specular_reflectance, specular_transmittance, .. } => {
            vec![alpha_u, alpha_v, specular_reflectance, specular_transmittance]
        }
        Bsdf::ThinDielectric { specular_reflectance, specular_transmittance, .. } => vec![specular_reflectance, specular_transmittance],
        Bsdf::Principled(p) => {
            let p = &mut **p;
            vec![
                &mut p.base_color,
                &mut p.roughness,
                &mut p.anisotropic,
                &mut p.metallic,
                &mut p.spec_tint,
                &mut p.spec_trans,
                &mut p.sheen,
                &mut p.sheen_tint,
                &mut p.clearcoat,
                &mut p.clearcoat_gloss,
                &mut p.flatness,
            ]
        }
        Bsdf::TwoSided { .. } | Bsdf::Blend { .. } | Bsdf::BumpMap { .. } | Bsdf::NormalMap { .. } | Bsdf::Mask { .. } => vec![],
    }
}

/// Canonical bytes of BSDF `i`: nested BSDFs and textures by content, not by index.
fn bsdf_key(scene: &Scene, i: usize, out: &mut Vec<u8>, depth: u32) {
    let Some(b) = scene.bsdfs.get(i) else {
        out.extend_from_slice(format!("missing bsdf {i};").as_bytes());
        return;
    };
    if depth > 8 {
        out.extend_from_slice(b"too deep;");
        return;
    }
    match b {
        Bsdf::TwoSided { front, back } => {
            out.extend_from_slice(b"TwoSided(");
            bsdf_key(scene, *front, out, depth + 1);
            bsdf_key(scene, *back, out, depth + 1);
            out.extend_from_slice(b");");
        }
        Bsdf::Blend { weight, first, second } => {
            let mut w = *weight;
            let tex = param_key(&mut w);
            out.extend_from_slice(format!("Blend({w:?}").as_bytes());
            texture_keys(scene, &tex, out);
            bsdf_key(scene, *first, out, depth + 1);
            bsdf_key(scene, *second, out, depth + 1);
            out.extend_from_slice(b");");
        }
        Bsdf::Mask { opacity, nested } => {
            let mut o = *opacity;
            let tex = param_key(&mut o);
            out.extend_from_slice(format!("Mask({o:?}").as_bytes());
            texture_keys(scene, &tex, out);
            bsdf_key(scene, *nested, out, depth + 1);
            out.extend_from_slice(b");");
        }
        Bsdf::BumpMap { texture, nested, .. } | Bsdf::NormalMap { texture, nested } => {
            let scale = if let Bsdf::BumpMap { scale, .. } = b { format!("{scale:?}") } else { "normal".into() };
            out.extend_from_slice(format!("Perturb({scale}").as_bytes());
            texture_keys(scene, &[*texture], out);
            bsdf_key(scene, *nested, out, depth + 1);
            out.extend_from_slice(b");");
        }
        _ => {
            let mut b = b.clone();
            let mut tex = Vec::new();
            for p in params_mut(&mut b) {
                if let Param::Texture(t) = *p {
                    tex.push(t);
                    *p = Param::Texture(tex.len() - 1);
                }
            }
            out.extend_from_slice(format!("{b:?};").as_bytes());
            texture_keys(scene, &tex, out);
        }
    }
}

/// Replaces a texture index by 0 (the first texture of the key); returns the textures it named.
fn param_key(p: &mut Param) -> Vec<usize> {
    if let Param::Texture(t) = *p {
        *p = Param::Texture(0);
        vec![t]
    } else {
        vec![]
    }
}

fn texture_keys(scene: &Scene, tex: &[usize], out: &mut Vec<u8>) {
    for &t in tex {
        match scene.textures.get(t) {
            Some(Texture::Bitmap { width, height, data, filter, wrap, to_uv, .. }) => {
                out.extend_from_slice(format!("Bitmap({width}x{height} {filter:?} {wrap:?} {to_uv:?})").as_bytes());
                out.extend_from_slice(bytemuck::cast_slice(data));
            }
            Some(c @ Texture::Checkerboard { .. }) => out.extend_from_slice(format!("{c:?}").as_bytes()),
            None => out.extend_from_slice(format!("missing texture {t}").as_bytes()),
        }
        out.push(b';');
    }
}

#[cfg(test)]
mod tests;
