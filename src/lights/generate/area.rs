//! Area emitters -> oriented point lights (MRCS 2007 Sec. 4: "area lights ... are handled by stratified
//! uniform sampling").
//!
//! The `area` lights are split among the scene's area emitters in proportion to their power
//! pi A_e mean(L_e) (largest-remainder rounding, so the counts sum to `area` whenever some emitter has
//! power). Emitter e's n_e lights are stratified by area: light k sits in the k-th of n_e strata (meshes
//! with at least as many lights as triangles: the compact pieces of `strata::compact_strata`, each
//! triangle cut into pieces of equal area by longest-edge bisection, a uniform point in each; meshes with
//! fewer lights than triangles: the 1D stratum [k, k+1) / n_e of the triangles' cumulative area,
//! jittered, then a uniform point of the triangle it falls in; spheres: the k-th cell of the equal-area
//! partition of `sampling::equal_area_cells`, jittered). Each light carries I0 = L_e A_k (W/sr), A_k its
//! stratum's area (A_e / n_e, or A_t / m_t for a compact piece of triangle t), with a cosine lobe around
//! the surface normal, so the lights of an emitter sum to pi A_e L_e exactly (up to float rounding).
//! Spheres use their analytic area 4 pi r^2.
//!
//! Mitsuba's area emitters emit on the +normal side only: the lobe's normal is the triangle's geometric
//! normal, flipped to agree with the mesh's vertex normals when it has any (sphere: outward, inward with
//! `flip_normals`). The light sits on the surface, as Mitsuba's emitter samples do: a shadow ray toward it
//! is Mitsuba's `spawn_ray_to`, shortened by `SHADOW_EPSILON`, so the emitter's own surface never shadows it
//! (a light offset off its surface saw more of itself through an opening: 1.4% too much light on walls lit
//! through a ceiling recess). Zero-area or zero-radiance emitters get no lights (zero contribution).
//!
//! Each mesh light carries its patch (`LightSet::patch`, `lights::patch`): its compact piece, or the part
//! of its cumulative-area stratum in the triangle it fell in (`AreaEmitter::stratum_piece`), within which
//! it is uniform; receivers in the
//! patch's near field use the patch's projected solid angle instead of 1 / d^2. Sphere lights and
//! textured emitters have none (the patch formula assumes L constant over the patch).
//!
//! Textured radiance (`Emitter::Area::texture`): each light takes L at its own uv (mesh uvs
//! interpolated, or (b1, b2) without uvs; spheres (phi / 2pi, theta / pi) of the world direction from the
//! centre, as `view::resolve`), I0 = L(uv) A_e / n_e, which keeps each emitter's lights an unbiased
//! stratified estimate of its emission. The emitter's `radiance` used to split the counts (and to pick
//! emitters for particles) is then the mean of L over 4096 stratified surface points; particles carry
//! L at their own uv.
use super::sampling::{equal_area_cells, stream, uniform, uniform_triangle, STREAM_AREA};
use crate::error::{Error, Result};
use crate::lights::{patch, LightSet};
use crate::scene::texture::eval as eval_texture;
use crate::scene::{Emitter, Scene, ShapeKind, Texture};
use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;

/// An area emitter ready for sampling.
#[derive(Debug, Clone)]
pub struct AreaEmitter {
    /// Index into `Scene::emitters`.
    pub emitter: usize,
    /// Index into `Scene::meshes` of the emitting shape.
    pub mesh: usize,
    /// Constant radiance, or the mean of the texture's (module docs).
    pub radiance: Vec3,
    /// Textured radiance (a copy of the scene's texture), evaluated at each point's uv.
    pub texture: Option<Texture>,
    /// Total area (m^2).
    pub area: f32,
    pub shape: AreaShape,
}

#[derive(Debug, Clone)]
pub enum AreaShape {
    /// Triangles (p0, p1, p2, emitting normal), their vertex uvs, the cumulative area after each, and
    /// each one's triangle index in the mesh (degenerate triangles are left out).
    Triangles {
        triangles: Vec<([Vec3; 3], Vec3)>,
        uvs: Vec<[Vec2; 3]>,
        cdf: Vec<f64>,
        tri: Vec<u32>,
    },
    Sphere {
        center: Vec3,
        radius: f32,
        flip: bool,
    },
}

impl AreaEmitter {
    /// Emitted power pi A L (W per channel).
    pub fn power(&self) -> Vec3 {
        self.radiance * (std::f32::consts::PI * self.area)
    }

    /// A point and its emitting normal, uniform by area, for (u0, u1) in [0,1)^2 (u0 selects the triangle).
    pub fn sample_point(&self, u0: f32, u1: f32) -> (Vec3, Vec3) {
        let (p, n, _) = self.sample_point_uv(u0, u1);
        (p, n)
    }

    /// The radiance at surface coordinate `uv` (non-finite or negative channels count as 0).
    pub fn radiance_at(&self, uv: Vec2) -> Vec3 {
        match &self.texture {
            None => self.radiance,
            Some(t) => sanitized(eval_texture(t, uv)),
        }
    }

    /// `sample_point` with the point's uv.
    pub fn sample_point_uv(&self, u0: f32, u1: f32) -> (Vec3, Vec3, Vec2) {
        let (p, n, uv, _) = self.sample_point_tied(u0, u1);
        (p, n, uv)
    }

    /// `sample_point_uv` with where the point sits on its shape (`SurfaceTie`), to re-evaluate it on
    /// another frame of an animation.
    pub fn sample_point_tied(&self, u0: f32, u1: f32) -> (Vec3, Vec3, Vec2, SurfaceTie) {
        match &self.shape {
            AreaShape::Triangles { triangles, uvs, cdf, tri } => {
                let total = *cdf.last().unwrap_or(&0.0);
                let target = u0 as f64 * total;
                let k = cdf.partition_point(|&c| c <= target).min(triangles.len() - 1);
                let before = if k == 0 { 0.0 } else { cdf[k - 1] };
                let a = cdf[k] - before;
                let v = if a > 0.0 { (((target - before) / a) as f32).clamp(0.0, 1.0 - f32::EPSILON) } else { 0.5 };
                let ([p0, p1, p2], n) = triangles[k];
                let [t0, t1, t2] = uvs[k];
                let b = uniform_triangle(v, u1);
                let b0 = 1.0 - b.x - b.y;
                let tie = SurfaceTie::Triangle { mesh: self.mesh, triangle: tri[k], b };
                (p0 * b0 + p1 * b.x + p2 * b.y, n, t0 * b0 + t1 * b.x + t2 * b.y, tie)
            }
            AreaShape::Sphere { center, radius, flip } => {
                let d = super::sampling::uniform_sphere(u0, u1);
                (*center + d * *radius, if *flip { -d } else { d }, sphere_uv(d), SurfaceTie::Sphere { mesh: self.mesh, direction: d })
            }
        }
    }
}

impl AreaEmitter {
    /// The piece of stratum [lo, hi) (fractions of the cumulative area) that holds the point
    /// `sample_point_tied(u0, .)` returns: the stratum's part of that point's triangle, a strip between
    /// two lines parallel to the edge (p0, p1) (`uniform_triangle` maps v to the distance from that
    /// edge), as 4 corners in order (a triangle repeats p2). Spheres: no patch (all zero).
    pub fn stratum_piece(&self, u0: f32, lo: f64, hi: f64) -> [Vec3; 4] {
        let AreaShape::Triangles { triangles, cdf, .. } = &self.shape else {
            return [Vec3::ZERO; 4];
        };
        let total = *cdf.last().unwrap_or(&0.0);
        let target = u0 as f64 * total;
        let k = cdf.partition_point(|&c| c <= target).min(triangles.len() - 1);
        let before = if k == 0 { 0.0 } else { cdf[k - 1] };
        let a = cdf[k] - before;
        if !(a > 0.0) {
            return [Vec3::ZERO; 4];
        }
        // The stratum's range inside triangle k, widened to hold the point's own (rounded) target.
        let v0 = ((lo * total).min(target).max(before) - before) / a;
        let v1 = ((hi * total).max(target).min(cdf[k]) - before) / a;
        let ([p0, p1, p2], _) = triangles[k];
        // b2 = 1 - sqrt(v): the strip between b2 = 1 - sqrt(v1) and 1 - sqrt(v0).
        let edge = |v: f64| {
            let b2 = (1.0 - v.clamp(0.0, 1.0).sqrt()) as f32;
            (p0 * (1.0 - b2) + p2 * b2, p1 * (1.0 - b2) + p2 * b2)
        };
        let (q0, q1) = edge(v1);
        let (q3, q2) = edge(v0);
        [q0, q1, q2, q3]
    }
}

/// Where a point sits on its shape, independent of the shape's placement: a triangle of a mesh and the
/// barycentrics (b1, b2) of its vertices 1 and 2, or a sphere and the world direction from its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfaceTie {
    Triangle { mesh: usize, triangle: u32, b: Vec2 },
    Sphere { mesh: usize, direction: Vec3 },
}

/// The part of its emitter's area that one area light stands for: `Equal(n_e)` for the n_e equal strata
/// of spheres and of meshes with fewer lights than triangles, `Fraction(f)` for a compact piece
/// (`strata::compact_strata`: A_t / m_t of the emitter's area A_e, as f = A_t / (m_t A_e)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AreaShare {
    Equal(u32),
    Fraction(f32),
}

impl AreaShare {
    /// The stratum's area (m^2) on an emitter of area `emitter_area` (the frame's, for animations).
    pub fn area(self, emitter_area: f32) -> f32 {
        match self {
            AreaShare::Equal(n) => emitter_area / n as f32,
            AreaShare::Fraction(f) => emitter_area * f,
        }
    }
}

/// One area light of [`area_lights_tied`]: its emitter (index into the emitter list), where it sits on
/// the emitter's shape, and the part of the emitter's area it stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiedLight {
    pub emitter: usize,
    pub tie: SurfaceTie,
    pub share: AreaShare,
}

/// Mitsuba's sphere uv of a unit direction from the centre: (phi / 2pi, theta / pi).
pub(crate) fn sphere_uv(d: Vec3) -> Vec2 {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    Vec2::new(phi / (2.0 * std::f32::consts::PI), theta / std::f32::consts::PI)
}

/// Non-finite or negative channels -> 0.
fn sanitized(l: Vec3) -> Vec3 {
    Vec3::from_array(l.to_array().map(|c| if c.is_finite() && c > 0.0 { c } else { 0.0 }))
}

/// Points for the mean radiance of a textured emitter.
const MEAN_POINTS: usize = 4096;

/// The scene's area emitters (in `Scene::emitters` order) with their sampling tables.
pub fn area_emitters(scene: &Scene) -> Vec<AreaEmitter> {
    let mut out = Vec::new();
    for (e, emitter) in scene.emitters.iter().enumerate() {
        let Emitter::Area { mesh, radiance, texture, .. } = emitter else { continue };
        let Some(m) = scene.meshes.get(*mesh) else { continue };
        let radiance = radiance.max(Vec3::ZERO);
        let texture = texture.and_then(|t| scene.textures.get(t)).cloned();
        let shape = if let ShapeKind::Sphere { center, radius, flip_normals } = m.kind {
            AreaShape::Sphere { center, radius, flip: flip_normals }
        } else {
            let mut triangles = Vec::with_capacity(m.indices.len());
            let mut uvs = Vec::with_capacity(m.indices.len());
            let mut cdf = Vec::with_capacity(m.indices.len());
            let mut tri = Vec::with_capacity(m.indices.len());
            let mut acc = 0.0f64;
            for (t, idx) in m.indices.iter().enumerate() {
                let [i0, i1, i2] = idx.map(|i| i as usize);
                if [i0, i1, i2].iter().any(|&i| i >= m.positions.len()) {
                    continue;
                }
                let p = [m.positions[i0], m.positions[i1], m.positions[i2]];
                let c = (p[1] - p[0]).cross(p[2] - p[0]);
                let area2 = c.length();
                if !(area2 > 0.0 && area2.is_finite()) {
                    continue;
                }
                let n = emitting_normal(m, [i0, i1, i2], c / area2);
                acc += 0.5 * area2 as f64;
                tri.push(t as u32);
                triangles.push((p, n));
                uvs.push(if m.uvs.len() == m.positions.len() { [m.uvs[i0], m.uvs[i1], m.uvs[i2]] } else { [Vec2::ZERO, Vec2::X, Vec2::Y] });
                cdf.push(acc);
            }
            AreaShape::Triangles { triangles, uvs, cdf, tri }
        };
        let area = match &shape {
            AreaShape::Triangles { cdf, .. } => *cdf.last().unwrap_or(&0.0) as f32,
            AreaShape::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
        };
        let mut a = AreaEmitter { emitter: e, mesh: *mesh, radiance, texture, area: if area.is_finite() { area } else { 0.0 }, shape };
        if a.texture.is_some() {
            a.radiance = mean_radiance(&a);
        }
        out.push(a);
    }
    out
}

/// The emitting side of a mesh triangle with unit face normal `n`: flipped to agree with the sum of its
/// vertex normals when the mesh has them (module docs).
pub(crate) fn emitting_normal(m: &crate::scene::Mesh, [i0, i1, i2]: [usize; 3], n: Vec3) -> Vec3 {
    if m.normals.len() == m.positions.len() && (m.normals[i0] + m.normals[i1] + m.normals[i2]).dot(n) < 0.0 {
        -n
    } else {
        n
    }
}

/// Mean of a textured emitter's radiance over its surface: 64 x 64 stratified points (cell centres).
fn mean_radiance(e: &AreaEmitter) -> Vec3 {
    if e.area <= 0.0 {
        return Vec3::ZERO;
    }
    let k = (MEAN_POINTS as f64).sqrt() as usize;
    let mut sum = glam::DVec3::ZERO;
    for a in 0..k {
        for b in 0..k {
            let (u0, u1) = ((a as f32 + 0.5) / k as f32, (b as f32 + 0.5) / k as f32);
            let (_, _, uv) = e.sample_point_uv(u0, u1);
            sum += e.radiance_at(uv).as_dvec3();
        }
    }
    (sum / (k * k) as f64).as_vec3()
}

/// Split `n` among weights (largest remainder; all zero weights -> all zero counts).
pub fn split_counts(weights: &[f64], n: usize) -> Vec<usize> {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0) || n == 0 {
        return vec![0; weights.len()];
    }
    let exact: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
    let mut counts: Vec<usize> = exact.iter().map(|e| e.floor() as usize).collect();
    let mut left = n - counts.iter().sum::<usize>();
    let mut order: Vec<usize> = (0..weights.len()).filter(|&i| weights[i] > 0.0).collect();
    order.sort_by(|&a, &b| (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())).then(a.cmp(&b)));
    for &i in order.iter().cycle() {
        if left == 0 {
            break;
        }
        counts[i] += 1;
        left -= 1;
    }
    counts
}

/// `n` oriented point lights over `emitters` (module docs).
pub fn area_lights(emitters: &[AreaEmitter], n: usize, seed: u64, center: Vec3, radius: f32) -> Result<LightSet> {
    Ok(area_lights_tied(emitters, n, seed, center, radius)?.0)
}

/// `area_lights` and, per light, its emitter (index into `emitters`) and where it sits on the emitter's
/// shape (to move it with the shape in other frames of an animation).
pub fn area_lights_tied(emitters: &[AreaEmitter], n: usize, seed: u64, center: Vec3, radius: f32) -> Result<(LightSet, Vec<TiedLight>)> {
    let mut set = LightSet::new(center, radius);
    set.try_reserve(n)?;
    let mut ties = Vec::new();
    ties.try_reserve_exact(n).map_err(|e| Error::OutOfMemory(format!("area lights: room for {n} lights' ties ({e})")))?;
    let weights: Vec<f64> = emitters.iter().map(|e| e.power().element_sum() as f64).collect();
    let counts = split_counts(&weights, n);
    for (e, (emitter, &n_e)) in emitters.iter().zip(&counts).enumerate() {
        if n_e == 0 {
            continue;
        }
        let mut rng: Pcg32 = stream(seed, STREAM_AREA, e as u64);
        let equal = AreaShare::Equal(n_e as u32);
        let scale = equal.area(emitter.area);
        match &emitter.shape {
            AreaShape::Triangles { triangles, uvs, cdf, tri } => {
                let corners: Vec<[Vec3; 3]> = triangles.iter().map(|(p, _)| *p).collect();
                if let Some(pieces) = super::strata::compact_strata(&corners, cdf, n_e) {
                    let total = *cdf.last().unwrap_or(&0.0);
                    for piece in pieces {
                        let t = piece.triangle;
                        let ([p0, p1, p2], normal) = triangles[t];
                        let [t0, t1, t2] = uvs[t];
                        let local = uniform_triangle(uniform(&mut rng), uniform(&mut rng));
                        let [c0, c1, c2] = piece.bary;
                        let w = c0 * (1.0 - local.x - local.y) + c1 * local.x + c2 * local.y;
                        // The position as a tie's barycentrics (b1, b2) give it, so an animation's
                        // frame 0 (`lights::animated`) reproduces it bit for bit.
                        let b = Vec2::new(w.y, w.z);
                        let b0 = 1.0 - b.x - b.y;
                        let p = p0 * b0 + p1 * b.x + p2 * b.y;
                        let uv = t0 * b0 + t1 * b.x + t2 * b.y;
                        let share = AreaShare::Fraction((piece.area / total) as f32);
                        let a = share.area(emitter.area);
                        set.push_oriented_point(p, normal, emitter.radiance_at(uv) * a)?;
                        let q = piece.bary.map(|c| p0 * c.x + p1 * c.y + p2 * c.z);
                        // Textured emitters keep the point formula (below).
                        if emitter.texture.is_none() && a > 0.0 {
                            set.set_patch(set.len() - 1, [q[0], q[1], q[2], q[2]])?;
                        }
                        ties.push(TiedLight { emitter: e, tie: SurfaceTie::Triangle { mesh: emitter.mesh, triangle: tri[t], b }, share });
                        set.set_mis(set.len() - 1, a, emitter.mesh as i32);
                    }
                    continue;
                }
                for k in 0..n_e {
                    let u0 = ((k as f64 + uniform(&mut rng) as f64) / n_e as f64) as f32;
                    let u0 = u0.min(1.0 - f32::EPSILON);
                    let (p, normal, uv, tie) = emitter.sample_point_tied(u0, uniform(&mut rng));
                    set.push_oriented_point(p, normal, emitter.radiance_at(uv) * scale)?;
                    let piece = emitter.stratum_piece(u0, k as f64 / n_e as f64, (k + 1) as f64 / n_e as f64);
                    // Textured emitters keep the point formula: the patch formula spreads the point's own
                    // L(uv) over its whole strip, across texels of other radiance (measured: 14% instead of
                    // 3% relative L2 on tests/scene/test_materials.py's checkerboard light).
                    if emitter.texture.is_none() && patch::quad_area(&piece) > 0.0 {
                        set.set_patch(set.len() - 1, piece)?;
                    }
                    ties.push(TiedLight { emitter: e, tie, share: equal });
                    set.set_mis(set.len() - 1, scale, emitter.mesh as i32);
                }
            }
            AreaShape::Sphere { center, radius, flip } => {
                for cell in equal_area_cells(n_e) {
                    let d = cell.sample(uniform(&mut rng), uniform(&mut rng));
                    let normal = if *flip { -d } else { d };
                    let p = *center + d * *radius;
                    set.push_oriented_point(p, normal, emitter.radiance_at(sphere_uv(d)) * scale)?;
                    ties.push(TiedLight { emitter: e, tie: SurfaceTie::Sphere { mesh: emitter.mesh, direction: d }, share: equal });
                    set.set_mis(set.len() - 1, scale, emitter.mesh as i32);
                }
            }
        }
    }
    Ok((set, ties))
}
