//! The gather cloud: n_g = 4^k points spread uniformly by area over the scene's surfaces, each tied to
//! its surface by (shape, triangle, barycentrics) so it can be re-evaluated on another frame of an
//! animation. It serves as the gather samples of direct-to-indirect relighting (Hašan, Pellacini, Bala,
//! "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006, Sec. 3.2, 4.1) and as the
//! indirect lights of tensor clustering (Hašan et al., EGSR 2008, Sec. 5).
//!
//! Sampling (the 2006 paper's Sec. 4.1 "uniform sampling", divide and conquer): the surfaces are a list
//! of regions (every triangle of every mesh; an analytic `ShapeKind::Sphere` is one region of area
//! 4 pi r^2, its tessellation is never sampled). A set of regions with a budget of b samples is split by
//! an axis-aligned plane (normal to the longest extent of the region centroids, at the position where
//! the cumulative area reaches half) into two subsets of areas A_1, A_2; the budget splits as
//! b_1 = floor(b A_1 / (A_1 + A_2) + xi), b_2 = b - b_1 (xi uniform: the expected count of every subset
//! is exactly proportional to its area), and each subset recurses. A set with a budget of one picks one
//! region with probability proportional to its area and a uniform point in it. A single region with a
//! budget b > 1 keeps dividing (the paper samples it "uniformly"; we stratify it too, since the walls of
//! a box scene are two triangles that carry most samples): a triangle is bisected at the midpoint of its
//! longest world-space edge (two halves of equal area, budget floor(b / 2 + xi) and the rest); a sphere
//! region, a rectangle in (z = cos theta, phi), is halved in z or in phi, whichever is longer on the
//! surface. Every sample is therefore uniform by area in expectation (each point has the same density
//! n_g / A), and the samples are stratified by area: a subset of area A_s holds A_s n_g / A samples
//! up to the rounding of its ancestors' splits.
//!
//! Which surfaces: all of them, as in the paper's scenes -- including emitters' own surfaces
//! (`GatherOptions::include_emitters`, default true: an area light's quad is geometry that reflects
//! too; its k_d is the reflectance of its BSDF, often black) and surfaces whose BSDF has only delta lobes
//! (glass, mirrors: k_d = k_g = 0). The density stays uniform over every included surface.
//!
//! What a sample stores (`GatherCloud`, struct of arrays, index i = sample):
//! - `shape[i]` (index into `Scene::meshes`), `triangle[i]` (triangle of the mesh; `SPHERE_TRIANGLE` for
//!   an analytic sphere), `coords[i]`: the barycentrics (b1, b2) of vertices 1 and 2 of the triangle, or a
//!   sphere's local parametric coordinates (u, v) = (phi / 2 pi, theta / pi) of the direction from its
//!   centre, Mitsuba's sphere uv (theta from +z, phi from +x toward +y; the world frame, as in `raytrace`:
//!   the scene stores only a sphere's centre and radius, so on a rotated sphere (`on`) a sample keeps its
//!   world direction from the centre).
//! - `position`, `normal` (shading normal: interpolated vertex normals, or the face normal for
//!   `face_normals` meshes, meshes without normals and spheres), `geo_normal`, `uv` (the texture
//!   coordinate) -- the same values `raytrace::RayTracer` reports for a hit at that point.
//! - `area[i]`: the area the sample stands for, total area / n_g (m^2) on the scene the cloud was made
//!   on. On another frame (`on`) it is scaled by the change of its triangle's area (the samples keep
//!   their barycentrics, so their density on a deformed triangle changes by that ratio; rigid motion
//!   keeps every area).
//! - `k_d[i]`: diffuse coefficient (RGB, textures evaluated at `uv`): `reflectance` of diffuse,
//!   `diffuse_reflectance` of plastic / roughplastic, `base_color (1 - metallic)(1 - spec_trans)` of
//!   principled, 0 for conductors, dielectrics and black surfaces; a blendbsdf mixes its two BSDFs'
//!   coefficients with its weight.
//! - `k_g[i]`: glossy coefficient (RGB): `specular_reflectance` of roughplastic and roughconductor,
//!   `lerp(1, base_color, metallic)` of principled (the tint of its specular lobe); 0 for diffuse and for
//!   the delta lobes of smooth plastic, conductor and dielectric (not glossy: no point light reaches them).
//!   `roughness[i]`: the microfacet alpha of that glossy lobe (sqrt(alpha_u alpha_v); principled's
//!   `roughness`), 0 without one.
//! - `bsdf`: the BSDF resolved at the sample (`shading::bsdf::resolve_records`), one record per sample
//!   then the second records of blended samples (linked as in `view::resolve::append_blend_records`), for
//!   exact evaluation by `shading::bsdf::eval_records` or the GPU passes.
//!
//! Re-evaluation (`GatherCloud::on`): a cloud made on one scene is evaluated on another scene with the
//! same topology (same number of shapes; per shape: analytic sphere or not, the same vertex and
//! triangle counts and the same triangle indices) -- the next frame of an animation, where transforms
//! and vertices moved and materials may change. Positions, normals, uvs, areas and coefficients are
//! recomputed from (shape, triangle, coords); a different topology is an error naming the shape.
//!
//! Determinism: one `sampling::stream` (family `STREAM_GATHER`) per seed, consumed depth-first; the
//! same scene and seed give a bit-identical cloud.
use super::generate::sampling::stream;
use crate::error::{Error, Result};
use crate::scene::{Mesh, Scene, ShapeKind};
use crate::shading::bsdf::{
    link_blend, resolve_records, FLAG_BLEND, KIND_DIFFUSE, KIND_PLASTIC, KIND_PRINCIPLED, KIND_ROUGHCONDUCTOR, KIND_ROUGHPLASTIC,
};
use crate::shading::GpuBsdf;
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;
use stratify::{scene_regions, stratify, Region};

/// `triangle[i]` of a sample on an analytic sphere.
pub const SPHERE_TRIANGLE: u32 = u32::MAX;
/// Random stream family of the gather cloud (distinct from `sampling::STREAM_*`).
pub const STREAM_GATHER: u64 = 0x6761_7468_6572;
/// Largest cloud: 4^12 samples (a 4096 x 4096 gather image).
pub const MAX_GATHER: usize = 1 << 24;
/// Host bytes per sample (arrays above, a BSDF record, the sampler's bookkeeping), for the memory check.
const BYTES_PER_SAMPLE: u64 = 8 + 8 + 4 * 12 + 8 + 4 + 2 * 12 + 4 + 80 + 4 + 64;

/// What `GatherCloud::new` makes.
#[derive(Debug, Clone, PartialEq)]
pub struct GatherOptions {
    /// Number of samples n_g; a power of 4 (4^k, the 2^k x 2^k gather image), >= 1.
    pub n: usize,
    pub seed: u64,
    /// Sample the surfaces of area emitters too (module docs).
    pub include_emitters: bool,
}

impl Default for GatherOptions {
    fn default() -> Self {
        GatherOptions { n: 4usize.pow(7), seed: 0, include_emitters: true }
    }
}

/// One shape's topology, as the cloud's scene had it.
#[derive(Debug, Clone, PartialEq)]
struct ShapeTopology {
    id: String,
    sphere: bool,
    vertices: usize,
    triangles: usize,
    /// FNV-1a of the triangle indices.
    index_hash: u64,
}

impl ShapeTopology {
    fn of(m: &Mesh) -> Self {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for i in m.indices.iter().flatten() {
            for b in i.to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
            }
        }
        ShapeTopology {
            id: m.id.clone(),
            sphere: matches!(m.kind, ShapeKind::Sphere { .. }),
            vertices: m.positions.len(),
            triangles: m.indices.len(),
            index_hash: h,
        }
    }
}

/// The gather cloud (module docs): struct of arrays, one entry per sample.
#[derive(Debug, Clone)]
pub struct GatherCloud {
    pub shape: Vec<u32>,
    pub triangle: Vec<u32>,
    /// Barycentrics (b1, b2), or a sphere's (u, v) (module docs).
    pub coords: Vec<Vec2>,
    pub position: Vec<Vec3>,
    /// Shading normal (unit; zero on a triangle that collapsed to zero area in `on`).
    pub normal: Vec<Vec3>,
    pub geo_normal: Vec<Vec3>,
    pub uv: Vec<Vec2>,
    /// Area each sample stands for (m^2).
    pub area: Vec<f32>,
    pub k_d: Vec<Vec3>,
    pub k_g: Vec<Vec3>,
    pub roughness: Vec<f32>,
    /// Record array: `len()` per-sample records, then the blend seconds they link to.
    pub bsdf: Vec<GpuBsdf>,
    /// Total sampled area (m^2) of the scene the cloud was made on (or last evaluated on, by `on`).
    pub total_area: f64,
    /// Bounding-box diagonal of that scene (`Scene::diagonal`), the position scale of the hierarchy.
    pub diagonal: f32,
    pub seed: u64,
    topology: Vec<ShapeTopology>,
    /// Area of each sample's triangle (or sphere) in the current scene.
    primitive_area: Vec<f32>,
}

/// A surface point evaluated from (shape, triangle, coords).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SurfacePoint {
    pub p: Vec3,
    /// Unit face normal (zero on a triangle of zero area).
    pub n_g: Vec3,
    pub n_s: Vec3,
    pub uv: Vec2,
    pub primitive_area: f32,
}

/// Sphere direction of (u, v) = (phi / 2 pi, theta / pi).
fn sphere_direction(c: Vec2) -> Vec3 {
    let (phi, theta) = (2.0 * PI * c.x, PI * c.y);
    let s = theta.sin();
    Vec3::new(s * phi.cos(), s * phi.sin(), theta.cos())
}

/// The triangle's vertex indices, checked against the mesh.
fn triangle_vertices(m: &Mesh, shape: usize, tri: usize) -> Result<[usize; 3]> {
    let idx = m
        .indices
        .get(tri)
        .ok_or_else(|| Error::scene(&m.loc, format!("shape {shape} ('{}'): no triangle {tri} (it has {})", m.id, m.indices.len())))?;
    let v = idx.map(|i| i as usize);
    if let Some(&bad) = v.iter().find(|&&i| i >= m.positions.len()) {
        return Err(Error::scene(
            &m.loc,
            format!("shape {shape} ('{}'): triangle {tri} names vertex {bad}, but the mesh has {}", m.id, m.positions.len()),
        ));
    }
    if let Some(&bad) = v.iter().find(|&&i| !m.positions[i].is_finite()) {
        return Err(Error::scene(
            &m.loc,
            format!("shape {shape} ('{}'): vertex {bad} has a non-finite position {}", m.id, m.positions[bad]),
        ));
    }
    Ok(v)
}

/// The point of `scene.meshes[shape]` at (triangle, coords), with the ray tracer's conventions.
pub(crate) fn surface_point(scene: &Scene, shape: usize, tri: u32, c: Vec2) -> Result<SurfacePoint> {
    let m = &scene.meshes[shape];
    if let ShapeKind::Sphere { center, radius, flip_normals } = m.kind {
        if !(center.is_finite() && radius > 0.0 && radius.is_finite()) {
            return Err(Error::scene(
                &m.loc,
                format!("shape {shape} ('{}'): sphere needs a finite center and a radius > 0, got {center}, {radius}", m.id),
            ));
        }
        let d = sphere_direction(c);
        let n = if flip_normals { -d } else { d };
        return Ok(SurfacePoint { p: center + d * radius, n_g: n, n_s: n, uv: c, primitive_area: 4.0 * PI * radius * radius });
    }
    let [i0, i1, i2] = triangle_vertices(m, shape, tri as usize)?;
    let (p0, p1, p2) = (m.positions[i0], m.positions[i1], m.positions[i2]);
    let (b1, b2) = (c.x, c.y);
    let b0 = 1.0 - b1 - b2;
    let cross = (p1 - p0).cross(p2 - p0);
    let n_g = cross.try_normalize().unwrap_or(Vec3::ZERO);
    let n_s = if m.face_normals || m.normals.len() != m.positions.len() {
        n_g
    } else {
        (m.normals[i0] * b0 + m.normals[i1] * b1 + m.normals[i2] * b2).try_normalize().unwrap_or(n_g)
    };
    let uv = if m.uvs.len() == m.positions.len() { m.uvs[i0] * b0 + m.uvs[i1] * b1 + m.uvs[i2] * b2 } else { c };
    Ok(SurfacePoint { p: p0 * b0 + p1 * b1 + p2 * b2, n_g, n_s, uv, primitive_area: 0.5 * cross.length() })
}

/// (k_d, k_g, roughness) of one resolved record (module docs).
fn record_coefficients(b: &GpuBsdf) -> (Vec3, Vec3, f32) {
    let d = Vec3::from_array(b.diffuse);
    let s = Vec3::from_array(b.specular);
    match b.kind {
        KIND_DIFFUSE | KIND_PLASTIC => (d, Vec3::ZERO, 0.0),
        KIND_ROUGHPLASTIC => (d, s, b.alpha_u),
        KIND_ROUGHCONDUCTOR => (Vec3::ZERO, s, (b.alpha_u * b.alpha_v).sqrt()),
        KIND_PRINCIPLED => {
            // specular = [metallic, spec_tint, spec_trans]; extra[0] = roughness (shading::principled).
            let (metallic, spec_trans) = (b.specular[0], b.specular[2]);
            (d * ((1.0 - metallic) * (1.0 - spec_trans)), Vec3::ONE.lerp(d, metallic), b.extra[0])
        }
        _ => (Vec3::ZERO, Vec3::ZERO, 0.0),
    }
}

/// Checks that `n` is a power of 4 in 1 ..= MAX_GATHER; returns k with n = 4^k.
pub fn gather_levels(n: usize) -> Result<u32> {
    if n == 0 || !n.is_power_of_two() || n.trailing_zeros() % 2 != 0 || n > MAX_GATHER {
        return Err(Error::invalid(format!(
            "the number of gather samples must be a power of 4 (4^k, a 2^k x 2^k gather image) in 1 ..= {MAX_GATHER}, got {n}"
        )));
    }
    Ok(n.trailing_zeros() / 2)
}

impl GatherCloud {
    /// Samples a cloud on `scene` (module docs).
    ///
    /// Errors: `InvalidParameter` when `opts.n` is not a power of 4 in 1 ..= `MAX_GATHER` or the scene has
    /// no surface of positive area (among the included shapes); `Scene` for a mesh with out-of-range
    /// indices, non-finite vertices or a bad sphere; `OutOfMemory` when the cloud would not fit.
    pub fn new(scene: &Scene, opts: &GatherOptions) -> Result<GatherCloud> {
        gather_levels(opts.n)?;
        GatherCloud::new_any_count(scene, opts)
    }

    /// `new` for any count 1 ..= `MAX_GATHER` (not only powers of 4: such a cloud has no gather image,
    /// `ClusterHierarchy` refuses it), e.g. for the indirect lights of tensor clustering.
    pub fn new_any_count(scene: &Scene, opts: &GatherOptions) -> Result<GatherCloud> {
        if opts.n == 0 || opts.n > MAX_GATHER {
            return Err(Error::invalid(format!("the number of gather samples must be in 1 ..= {MAX_GATHER}, got {}", opts.n)));
        }
        crate::memory::check_host(
            &format!("gather cloud of {} samples", opts.n),
            crate::memory::product(&[opts.n as u64, BYTES_PER_SAMPLE]),
        )?;
        let mut regions = scene_regions(scene, opts.include_emitters)?;
        let total: f64 = regions.iter().map(Region::area).sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err(Error::invalid(format!(
                "{}: the scene has no surface to put gather samples on ({} shapes{}, total area {total})",
                scene.path.display(),
                scene.meshes.len(),
                if opts.include_emitters { "" } else { ", emitters excluded" }
            )));
        }
        let mut rng = stream(opts.seed, STREAM_GATHER, 0);
        let sites = stratify(&mut regions, opts.n, &mut rng);
        debug_assert_eq!(sites.len(), opts.n);
        let n = sites.len();
        let mut cloud = GatherCloud {
            shape: sites.iter().map(|s| s.0).collect(),
            triangle: sites.iter().map(|s| s.1).collect(),
            coords: sites.iter().map(|s| s.2).collect(),
            position: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            geo_normal: vec![Vec3::ZERO; n],
            uv: vec![Vec2::ZERO; n],
            area: vec![(total / n as f64) as f32; n],
            k_d: vec![Vec3::ZERO; n],
            k_g: vec![Vec3::ZERO; n],
            roughness: vec![0.0; n],
            bsdf: Vec::with_capacity(n),
            total_area: total,
            diagonal: scene.diagonal(),
            seed: opts.seed,
            topology: scene.meshes.iter().map(ShapeTopology::of).collect(),
            primitive_area: vec![0.0; n],
        };
        cloud.evaluate(scene, false)?;
        Ok(cloud)
    }

    pub fn len(&self) -> usize {
        self.shape.len()
    }

    pub fn is_empty(&self) -> bool {
        self.shape.is_empty()
    }

    /// k with `len() == 4^k` (the gather image is 2^k x 2^k); for a cloud of another count
    /// (`new_any_count`), floor(log4(len())).
    pub fn levels(&self) -> u32 {
        self.len().max(1).ilog2() / 2
    }

    /// The same samples on `other`, a scene with the same topology (module docs): positions, normals,
    /// uvs, areas, coefficients and BSDF records recomputed from (shape, triangle, coords).
    ///
    /// Errors: `InvalidParameter` naming the first shape whose topology differs (count of shapes, sphere
    /// or mesh, vertex or triangle count, triangle indices); `Scene` for non-finite vertices or a bad sphere.
    pub fn on(&self, other: &Scene) -> Result<GatherCloud> {
        self.check_topology(other)?;
        let mut c = self.clone();
        c.diagonal = other.diagonal();
        c.topology = other.meshes.iter().map(ShapeTopology::of).collect();
        c.evaluate(other, true)?;
        Ok(c)
    }

    /// Whether `other` has the topology of the cloud's scene (`on`'s check).
    pub fn check_topology(&self, other: &Scene) -> Result<()> {
        let here = other.path.display();
        if other.meshes.len() != self.topology.len() {
            return Err(Error::invalid(format!(
                "{here}: the gather cloud was made on a scene with {} shapes, this one has {}: not the same topology",
                self.topology.len(),
                other.meshes.len()
            )));
        }
        for (s, (mine, m)) in self.topology.iter().zip(&other.meshes).enumerate() {
            let theirs = ShapeTopology::of(m);
            let what = if mine.sphere != theirs.sphere {
                format!("is {} here, {} in the cloud's scene", kind_name(theirs.sphere), kind_name(mine.sphere))
            } else if mine.sphere {
                continue;
            } else if mine.vertices != theirs.vertices {
                format!("has {} vertices here, {} in the cloud's scene", theirs.vertices, mine.vertices)
            } else if mine.triangles != theirs.triangles {
                format!("has {} triangles here, {} in the cloud's scene", theirs.triangles, mine.triangles)
            } else if mine.index_hash != theirs.index_hash {
                "has different triangle indices (connectivity) than in the cloud's scene".to_string()
            } else {
                continue;
            };
            return Err(Error::invalid(format!(
                "{here}: shape {s} ('{}', was '{}') {what}: the gather cloud needs the same topology",
                theirs.id, mine.id
            )));
        }
        Ok(())
    }

    /// Fills the per-sample values from `scene`; `rescale` scales each area by its primitive's change of area.
    fn evaluate(&mut self, scene: &Scene, rescale: bool) -> Result<()> {
        let n = self.len();
        self.bsdf.clear();
        let mut seconds = Vec::new();
        let mut total = 0.0f64;
        for i in 0..n {
            let s = self.shape[i] as usize;
            let p = surface_point(scene, s, self.triangle[i], self.coords[i])?;
            if rescale {
                let old = self.primitive_area[i];
                self.area[i] = if old > 0.0 { self.area[i] * (p.primitive_area / old) } else { 0.0 };
            }
            self.primitive_area[i] = p.primitive_area;
            total += self.area[i] as f64;
            let (n_g, n_s) = if p.primitive_area > 0.0 { (p.n_g, p.n_s) } else { (Vec3::ZERO, Vec3::ZERO) };
            (self.position[i], self.normal[i], self.geo_normal[i], self.uv[i]) = (p.p, n_s, n_g, p.uv);
            let (mut first, second) = resolve_records(&scene.bsdfs, &scene.textures, scene.meshes[s].bsdf, p.uv);
            if p.primitive_area > 0.0 {
                crate::shading::perturb::apply(scene, s, self.triangle[i] as usize, p.p, n_g, n_s, p.uv, &mut [&mut first]);
            }
            let (mut kd, mut kg, mut alpha) = record_coefficients(&first);
            if let Some(b) = second {
                let w = first.extra[2];
                let (kd2, kg2, a2) = record_coefficients(&b);
                kd = kd * (1.0 - w) + kd2 * w;
                kg = kg * (1.0 - w) + kg2 * w;
                alpha = alpha * (1.0 - w) + a2 * w;
                seconds.push((i, b));
            }
            (self.k_d[i], self.k_g[i], self.roughness[i]) = (kd, kg, alpha);
            self.bsdf.push(first);
        }
        for (i, b) in seconds {
            let k = self.bsdf.len();
            self.bsdf.push(b);
            debug_assert!(self.bsdf[i].flags & FLAG_BLEND != 0);
            link_blend(&mut self.bsdf[i], k);
        }
        if rescale {
            self.total_area = total;
        }
        Ok(())
    }

    /// Sum of the samples' areas (m^2), in f64.
    pub fn area_sum(&self) -> f64 {
        self.area.iter().map(|&a| a as f64).sum()
    }

    /// Per-shape sample counts (index = shape).
    pub fn counts_per_shape(&self) -> Vec<usize> {
        let mut c = vec![0usize; self.topology.len()];
        for &s in &self.shape {
            c[s as usize] += 1;
        }
        c
    }

    /// Area-weighted mean k_d (a quick check of the cloud's albedo).
    pub fn mean_k_d(&self) -> Vec3 {
        let mut s = DVec3::ZERO;
        for (k, a) in self.k_d.iter().zip(&self.area) {
            s += k.as_dvec3() * *a as f64;
        }
        (s / self.area_sum().max(f64::MIN_POSITIVE)).as_vec3()
    }
}

fn kind_name(sphere: bool) -> &'static str {
    if sphere {
        "an analytic sphere"
    } else {
        "a triangle mesh"
    }
}

mod stratify;
#[cfg(test)]
mod tests;
