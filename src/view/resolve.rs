//! Exact resolve of view samples: from the triangle visible at each pixel centre (found by the GPU
//! visibility pass in `gpu::gbuffer`, or by the brute-force CPU caster here) to a full [`ViewSamples`].
//!
//! Per pixel (i, j) the camera ray is Mitsuba's, `Camera::ray(i + 0.5, j + 0.5)` (origin on the near
//! plane), and it is intersected with the one surface found, in f64:
//! - triangles (Mitsuba's `Mesh::compute_surface_interaction`): ray-plane hit and barycentrics (b1, b2);
//!   p = b0 p0 + b1 p1 + b2 p2; geometric normal normalize(cross(p1 - p0, p2 - p0)); shading normal
//!   = normalized interpolated vertex normal (the geometric one when `face_normals` or no normals);
//!   uv interpolated, or (b1, b2) when the mesh has no uvs (Mitsuba's barycentric parameterisation).
//!   Barycentrics are not clamped: a rasterised pixel centre on an edge may sit 1e-7 outside.
//! - `ShapeKind::Sphere` (Mitsuba's `sphere.cpp`): analytic hit (plane-shifted quadratic, far root when
//!   the near one is behind the ray origin), re-projected onto the sphere; n = (p - c) / r, flipped with
//!   `flip_normals`, geometric normal = shading normal; uv = (phi / 2pi, theta / pi) of the local point
//!   (p - c) / r. Deviation: Mitsuba takes the local point through the inverse `to_world`, which may hold
//!   a rotation; `ShapeKind::Sphere` keeps only centre and radius, so a rotated sphere's uv differ.
//!   `prim_index` of a sphere sample is the tessellation triangle the raster found (Mitsuba's is 0).
//!   When the f64 ray misses the sphere (grazing rays at the silhouette), the triangle is used.
//! - `wi = -d`; bsdf = `shading::bsdf::resolve` of the mesh's BSDF at uv (with the perturbed normal of a
//!   bumpmap / normalmap, `shading::perturb::apply`), albedo = its diffuse reflectance (diffuse, plastic,
//!   roughplastic; 0 for conductors and dielectrics).
//!
//! Background pixels: `shape_index = prim_index = -1`, every vector 0, bsdf zeroed.
use crate::error::{Error, Result};
use crate::gpu::scene_buffers::{locate_triangle, triangle_offsets};
use crate::scene::{Camera, Scene, ShapeKind};
use crate::shading::GpuBsdf;
use crate::view::chains::ChainOptions;
use crate::view::ViewSamples;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

/// Ray-plane intersection of the triangle (p0, p1, p2) without bounds: (t, b1, b2), or `None` when the
/// ray is parallel to the plane (or the triangle is degenerate).
pub fn intersect_triangle_plane(o: DVec3, d: DVec3, p0: DVec3, p1: DVec3, p2: DVec3) -> Option<(f64, f64, f64)> {
    // Moller-Trumbore, without the range checks.
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = o - p0;
    let b1 = tvec.dot(pvec) * inv_det;
    let qvec = tvec.cross(e1);
    let b2 = d.dot(qvec) * inv_det;
    let t = e2.dot(qvec) * inv_det;
    t.is_finite().then_some((t, b1, b2))
}

/// Ray-triangle intersection with `t` in `(0, t_max]`: (t, b1, b2).
pub fn intersect_triangle(o: DVec3, d: DVec3, p: [DVec3; 3], t_max: f64) -> Option<(f64, f64, f64)> {
    let (t, b1, b2) = intersect_triangle_plane(o, d, p[0], p[1], p[2])?;
    (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0 && t <= t_max).then_some((t, b1, b2))
}

/// Mitsuba's ray-sphere intersection (`sphere.cpp`, f64 as its scalar variants): the distance along the
/// unit direction `d` in `[0, t_max]`, the far root when the near one is behind the origin.
pub fn intersect_sphere(o: DVec3, d: DVec3, center: DVec3, radius: f64, t_max: f64) -> Option<f64> {
    // Solve from the point of the ray closest to the centre: better conditioned far from the sphere.
    let plane_t = (center - o).dot(d);
    let q = o + d * plane_t - center;
    let disc = radius * radius - q.length_squared();
    if disc < 0.0 {
        return None;
    }
    let h = disc.sqrt();
    let (near_t, far_t) = (plane_t - h, plane_t + h);
    if !(near_t <= t_max && far_t >= 0.0) || (near_t < 0.0 && far_t > t_max) {
        return None;
    }
    Some(if near_t < 0.0 { far_t } else { near_t })
}

/// Largest distance along the unit camera ray `d` (from its near-plane origin) inside the far clip.
fn ray_t_max(camera: &Camera, d: Vec3) -> f64 {
    let cos = camera.world_from_camera.z_axis.truncate().dot(d) as f64;
    (camera.far_clip as f64 - camera.near_clip as f64) / cos
}

/// One resolved pixel.
#[derive(Debug, Clone, Copy)]
struct Sample {
    position: Vec3,
    normal: Vec3,
    geo_normal: Vec3,
    wi: Vec3,
    uv: Vec2,
    albedo: Vec3,
    shape_index: i32,
    prim_index: i32,
    bsdf: GpuBsdf,
}

impl Sample {
    fn background() -> Sample {
        Sample {
            position: Vec3::ZERO,
            normal: Vec3::ZERO,
            geo_normal: Vec3::ZERO,
            wi: Vec3::ZERO,
            uv: Vec2::ZERO,
            albedo: Vec3::ZERO,
            shape_index: -1,
            prim_index: -1,
            bsdf: bytemuck::Zeroable::zeroed(),
        }
    }
}

fn corners(scene: &Scene, m: usize, prim: u32) -> Result<([u32; 3], [DVec3; 3])> {
    let mesh = &scene.meshes[m];
    let tri = *mesh
        .indices
        .get(prim as usize)
        .ok_or_else(|| Error::invalid(format!("mesh {:?} has {} triangles, asked for {prim}", mesh.id, mesh.indices.len())))?;
    let mut p = [DVec3::ZERO; 3];
    for k in 0..3 {
        let v = mesh
            .positions
            .get(tri[k] as usize)
            .ok_or_else(|| Error::scene(&mesh.loc, format!("mesh {:?}: vertex index {} out of range", mesh.id, tri[k])))?;
        p[k] = v.as_dvec3();
    }
    Ok((tri, p))
}

/// Resolve the surface point of pixel (x, y) of camera `cam` on triangle `prim` of mesh `m`.
fn resolve_pixel(scene: &Scene, cam: &Camera, m: usize, prim: u32, x: u32, y: u32) -> Result<Sample> {
    let mesh = &scene.meshes[m];
    let (o32, d32) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
    let (o, d) = (o32.as_dvec3(), d32.as_dvec3());
    let (tri, p) = corners(scene, m, prim)?;
    let n_geo = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();

    let sphere_hit = match mesh.kind {
        ShapeKind::Sphere { center, radius, flip_normals } => {
            let c = center.as_dvec3();
            intersect_sphere(o, d, c, radius as f64, ray_t_max(cam, d32)).map(|t| {
                // Re-project onto the sphere as Mitsuba does.
                let n = (o + d * t - c).normalize();
                let position = c + n * radius as f64;
                let local = n;
                let theta = local.z.clamp(-1.0, 1.0).acos();
                let mut phi = local.y.atan2(local.x);
                if phi < 0.0 {
                    phi += 2.0 * std::f64::consts::PI;
                }
                let uv = Vec2::new((phi / (2.0 * std::f64::consts::PI)) as f32, (theta / std::f64::consts::PI) as f32);
                let n = if flip_normals { -n } else { n };
                (position, n, n, uv)
            })
        }
        _ => None,
    };
    let (position, normal, geo_normal, uv) = match sphere_hit {
        Some(hit) => hit,
        None => {
            let (b1, b2) = match intersect_triangle_plane(o, d, p[0], p[1], p[2]) {
                Some((_, b1, b2)) => (b1, b2),
                // The ray lies in the triangle's plane (an edge-on triangle the raster still touched):
                // no unique hit, take the centroid.
                None => (1.0 / 3.0, 1.0 / 3.0),
            };
            let b0 = 1.0 - b1 - b2;
            let position = p[0] * b0 + p[1] * b1 + p[2] * b2;
            let normal = if mesh.face_normals || mesh.normals.is_empty() {
                n_geo
            } else {
                let n = |k: usize| mesh.normals.get(tri[k] as usize).map(|v| v.as_dvec3()).unwrap_or(n_geo);
                let s = n(0) * b0 + n(1) * b1 + n(2) * b2;
                if s.length_squared() > 0.0 {
                    s.normalize()
                } else {
                    n_geo
                }
            };
            let uv = if mesh.uvs.is_empty() {
                Vec2::new(b1 as f32, b2 as f32)
            } else {
                let t = |k: usize| mesh.uvs.get(tri[k] as usize).copied().unwrap_or(Vec2::ZERO).as_dvec2();
                (t(0) * b0 + t(1) * b1 + t(2) * b2).as_vec2()
            };
            (position, normal, n_geo, uv)
        }
    };
    let mut bsdf = resolve_bsdf(scene, m, uv)?;
    let (position, normal, geo_normal) = (position.as_vec3(), normal.as_vec3(), geo_normal.as_vec3());
    crate::shading::perturb::apply(scene, m, prim as usize, position, geo_normal, normal, uv, &mut [&mut bsdf]);
    Ok(Sample {
        position,
        normal,
        geo_normal,
        wi: -d32,
        uv,
        albedo: Vec3::from(bsdf.diffuse),
        shape_index: m as i32,
        prim_index: prim as i32,
        bsdf,
    })
}

/// The mesh's BSDF resolved at `uv` (`crate::shading::bsdf::resolve`, textures evaluated); an index
/// past `Scene::bsdfs` is an error naming the mesh (`resolve` itself would return an empty BSDF).
fn resolve_bsdf(scene: &Scene, m: usize, uv: Vec2) -> Result<GpuBsdf> {
    let mesh = &scene.meshes[m];
    if mesh.bsdf >= scene.bsdfs.len() {
        return Err(Error::scene(
            &mesh.loc,
            format!("shape {:?} uses BSDF {} but the scene has {}", mesh.id, mesh.bsdf, scene.bsdfs.len()),
        ));
    }
    Ok(crate::shading::bsdf::resolve(&scene.bsdfs, &scene.textures, mesh.bsdf, uv))
}

/// Turn a visibility buffer into view samples, following delta BSDF chains with the default
/// `ChainOptions` (see [`resolve_view_samples_with`]).
pub fn resolve_view_samples(scene: &Scene, ids: &[u32]) -> Result<ViewSamples> {
    resolve_view_samples_with(scene, ids, &ChainOptions::default())
}

/// Turn a visibility buffer into view samples. `ids[y * width + x]` = global triangle id + 1 (0 =
/// background) over `scene.meshes` (see `gpu::scene_buffers`); `ids.len()` must be `width * height` of
/// the camera's film. Then pixels whose hit has a delta BSDF get the extra samples of their delta
/// chains (`crate::view::chains::trace_chains` with `chains`).
pub fn resolve_view_samples_with(scene: &Scene, ids: &[u32], chains: &ChainOptions) -> Result<ViewSamples> {
    resolve_view_samples_for(scene, &scene.camera, ids, chains)
}

/// [`resolve_view_samples_with`] through another camera than the scene's (e.g. the same view at another
/// film size) without copying the scene: `ids` are that camera's visibility buffer.
pub fn resolve_view_samples_for(scene: &Scene, cam: &Camera, ids: &[u32], chains: &ChainOptions) -> Result<ViewSamples> {
    let (w, h) = (cam.width, cam.height);
    let n = w as usize * h as usize;
    if ids.len() != n {
        return Err(Error::invalid(format!("visibility buffer has {} pixels, the film {w}x{h} has {n}", ids.len())));
    }
    let offsets = triangle_offsets(&scene.meshes)?;
    // Start from background everywhere, then fill hit pixels in place (no per-pixel intermediate).
    let bg = Sample::background();
    let mut out = ViewSamples {
        width: w,
        height: h,
        position: vec![bg.position; n],
        normal: vec![bg.normal; n],
        geo_normal: vec![bg.geo_normal; n],
        wi: vec![bg.wi; n],
        uv: vec![bg.uv; n],
        albedo: vec![bg.albedo; n],
        shape_index: vec![bg.shape_index; n],
        prim_index: vec![bg.prim_index; n],
        bsdf: vec![bg.bsdf; n],
        ..Default::default()
    };
    (
        ids.par_iter().enumerate(),
        out.position.par_iter_mut(),
        out.normal.par_iter_mut(),
        out.geo_normal.par_iter_mut(),
        out.wi.par_iter_mut(),
        out.uv.par_iter_mut(),
        out.albedo.par_iter_mut(),
        out.shape_index.par_iter_mut(),
        out.prim_index.par_iter_mut(),
        out.bsdf.par_iter_mut(),
    )
        .into_par_iter()
        .try_for_each(|((i, &id), position, normal, geo_normal, wi, uv, albedo, shape_index, prim_index, bsdf)| {
            if id == 0 {
                return Ok(());
            }
            let (m, prim) = locate_triangle(&offsets, id - 1)
                .ok_or_else(|| Error::Gpu(format!("visibility buffer names triangle {} of {}", id - 1, offsets.last().unwrap_or(&0))))?;
            let s = resolve_pixel(scene, cam, m, prim, i as u32 % w, i as u32 / w)?;
            (*position, *normal, *geo_normal, *wi, *uv) = (s.position, s.normal, s.geo_normal, s.wi, s.uv);
            (*albedo, *shape_index, *prim_index, *bsdf) = (s.albedo, s.shape_index, s.prim_index, s.bsdf);
            Ok::<(), Error>(())
        })?;
    crate::view::chains::trace_chains(scene, &mut out, chains)?;
    // After the chains: the blend records of every sample (extra ones too) go after all samples.
    append_blend_records(scene, &mut out);
    Ok(out)
}

/// Appends the second record of every blended view sample (`blendbsdf`) after the `len()` per-sample
/// records of `view.bsdf` and links it (`shading::bsdf::link_blend`); the GPU passes upload the whole
/// array, so `bsdf_record` finds it there.
pub fn append_blend_records(scene: &Scene, view: &mut ViewSamples) {
    use crate::shading::bsdf::{link_blend, resolve_records, FLAG_BLEND};
    for i in 0..view.len() {
        if view.bsdf[i].flags & FLAG_BLEND == 0 || view.shape_index[i] < 0 {
            continue;
        }
        let mesh = &scene.meshes[view.shape_index[i] as usize];
        let (_, second) = resolve_records(&scene.bsdfs, &scene.textures, mesh.bsdf, view.uv[i]);
        if let Some(s) = second {
            let k = view.bsdf.len();
            view.bsdf.push(s);
            link_blend(&mut view.bsdf[i], k);
        }
    }
}

/// Brute-force CPU visibility at every pixel centre (for tests on small scenes: O(pixels x triangles)):
/// the global id + 1 of the nearest triangle along Mitsuba's camera ray within the clip range, with
/// `ShapeKind::Sphere` meshes hit analytically (reported as the first triangle of their mesh).
pub fn cast_visibility_cpu(scene: &Scene) -> Result<Vec<u32>> {
    let cam = &scene.camera;
    let offsets = triangle_offsets(&scene.meshes)?;
    let tris: Vec<(u32, [DVec3; 3])> = (0..*offsets.last().unwrap_or(&0))
        .map(|g| {
            let (m, prim) = locate_triangle(&offsets, g).unwrap_or((0, 0));
            let is_sphere = matches!(scene.meshes[m].kind, ShapeKind::Sphere { .. });
            corners(scene, m, prim).map(|(_, p)| (if is_sphere { u32::MAX } else { g }, p))
        })
        .collect::<Result<_>>()?;
    let spheres: Vec<(u32, DVec3, f64)> = scene
        .meshes
        .iter()
        .enumerate()
        .filter_map(|(m, mesh)| match mesh.kind {
            ShapeKind::Sphere { center, radius, .. } if !mesh.indices.is_empty() => Some((offsets[m], center.as_dvec3(), radius as f64)),
            _ => None,
        })
        .collect();
    let n = cam.width as usize * cam.height as usize;
    Ok((0..n)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i as u32 % cam.width, i as u32 / cam.width);
            let (o32, d32) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let (o, d) = (o32.as_dvec3(), d32.as_dvec3());
            let t_max = ray_t_max(cam, d32);
            let mut best = (t_max, 0u32);
            for (g, p) in &tris {
                if *g == u32::MAX {
                    continue;
                }
                if let Some((t, _, _)) = intersect_triangle(o, d, *p, best.0) {
                    best = (t, g + 1);
                }
            }
            for &(g, c, r) in &spheres {
                if let Some(t) = intersect_sphere(o, d, c, r, best.0) {
                    if t <= best.0 {
                        best = (t, g + 1);
                    }
                }
            }
            best.1
        })
        .collect())
}

/// Visibility at every pixel centre by ray casting through the scene BVH (the CPU backend's G-buffer,
/// for machines without a hardware GPU): the global id + 1 of the closest primitive along Mitsuba's
/// camera ray (`Camera::ray(x + 0.5, y + 0.5)`) within the clip range, 0 for background; a
/// `ShapeKind::Sphere` hit reports the first triangle of its mesh (the resolve intersects the analytic
/// sphere). Equal to the GPU raster's ids wherever a pixel centre is not on a shared edge (there the
/// watertight ray test and the raster's fill rule may pick different neighbours, both at the centre).
///
/// Errors: the camera checks of `gpu::gbuffer::validate_camera` (sides up to 65,536); host memory.
pub fn cast_visibility_traced(scene: &Scene, tracer: &crate::raytrace::RayTracer) -> Result<Vec<u32>> {
    cast_visibility_traced_for(scene, &scene.camera, tracer)
}

/// [`cast_visibility_traced`] through another camera than the scene's (same scene, same tracer).
pub fn cast_visibility_traced_for(scene: &Scene, cam: &Camera, tracer: &crate::raytrace::RayTracer) -> Result<Vec<u32>> {
    crate::gpu::gbuffer::validate_camera_for(cam, 1 << 16, "the CPU backend's G-buffer limit")?;
    crate::memory::check_view_samples_host(cam.width, cam.height)?;
    let offsets = triangle_offsets(&scene.meshes)?;
    let n = cam.width as usize * cam.height as usize;
    crate::interrupt::par_map_chunked(n, 1 << 16, |i| {
        let (x, y) = (i as u32 % cam.width, i as u32 / cam.width);
        let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
        let t_max = ray_t_max(cam, d) as f32;
        match tracer.intersect(o, d, 0.0, t_max) {
            Some(si) => {
                let prim = if matches!(scene.meshes[si.mesh].kind, ShapeKind::Sphere { .. }) { 0 } else { si.prim as u32 };
                offsets[si.mesh] + prim + 1
            }
            None => 0,
        }
    })
}

/// CPU reference view samples: [`cast_visibility_cpu`] then [`resolve_view_samples`].
pub fn view_samples_cpu_reference(scene: &Scene) -> Result<ViewSamples> {
    resolve_view_samples(scene, &cast_visibility_cpu(scene)?)
}

#[cfg(test)]
pub(crate) mod tests;
