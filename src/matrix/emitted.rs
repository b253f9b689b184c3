//! What the camera sees directly (Mitsuba's `path` integrator at depth 0): not a column of the light
//! matrix, but part of every image, `image = A 1 + emitted`.
//!
//! - A view sample on a shape with an area emitter adds the emitter's radiance L (a textured one at the
//!   sample's uv) when seen from the
//!   emitter's +normal side: Mitsuba's `AreaLight::eval` returns L where `Frame3f::cos_theta(si.wi) > 0`,
//!   `si.wi` in the shading frame, i.e. `dot(wi, n_s) > 0` with the shading normal n_s.
//! - A background sample (`shape_index < 0`) shows the environment (envmap / constant emitters, summed)
//!   along the pixel-centre camera ray `Camera::ray(x + 0.5, y + 0.5)`, looked up by
//!   `lights::generate::environment::Environment` (Mitsuba's lat-long lookup, MITSUBA_CONVENTIONS.md).
//! - Delta lights (point, spot, directional) are invisible to the camera, as in Mitsuba.
//! - Emission seen through delta BSDF chains (mirrors, glass: `crate::view::chains`) is added per pixel
//!   from `ViewSamples::chain_emitted`, computed when the chains were traced.
//!
//! Bad input gives zero contributions, never NaN: non-finite or negative area radiance counts as 0
//! per channel; non-finite env-map texels or scale count as 0 (as `Environment` does for the lights).
use super::LightMatrix;
use crate::lights::generate::environment::Environment;
use crate::scene::{Emitter, Scene, Texture};
use crate::view::ViewSamples;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// A radiance with non-finite or negative channels replaced by 0.
pub(crate) fn sanitized(l: Vec3) -> Vec3 {
    Vec3::from_array(l.to_array().map(|c| if c.is_finite() && c > 0.0 { c } else { 0.0 }))
}

/// Area radiance of every mesh of a scene: a constant (sanitized) or a texture evaluated at the hit's uv;
/// zero for meshes without an area emitter. Used for the camera's own hits and for delta chains.
pub(crate) struct AreaRadiance<'a> {
    per_mesh: Vec<(Vec3, Option<&'a Texture>)>,
}

impl<'a> AreaRadiance<'a> {
    pub(crate) fn new(scene: &'a Scene) -> Self {
        let per_mesh = scene
            .meshes
            .iter()
            .map(|m| match m.emitter.and_then(|e| scene.emitters.get(e)) {
                Some(Emitter::Area { radiance, texture: Some(t), .. }) => (*radiance, scene.textures.get(*t)),
                Some(Emitter::Area { radiance, .. }) => (sanitized(*radiance), None),
                _ => (Vec3::ZERO, None),
            })
            .collect();
        AreaRadiance { per_mesh }
    }

    /// The radiance L leaving mesh `mesh` at `uv` on its emitting side (zero for other meshes).
    pub(crate) fn at(&self, mesh: usize, uv: Vec2) -> Vec3 {
        match self.per_mesh.get(mesh) {
            Some((_, Some(t))) => sanitized(crate::scene::texture::eval(t, uv)),
            Some((l, None)) => *l,
            None => Vec3::ZERO,
        }
    }
}

/// The directly visible emission of every pixel, H * W RGB (row 0 at the top): the camera's own hit
/// plus what its delta chains see (`ViewSamples::chain_emitted`).
pub fn emitted_radiance(scene: &Scene, view: &ViewSamples) -> Vec<Vec3> {
    let env = Environment::from_scene(scene);
    let area = AreaRadiance::new(scene);
    let width = view.width as usize;
    let chain = |i: usize| view.chain_emitted.get(i).copied().unwrap_or(Vec3::ZERO);
    (0..view.num_pixels().min(view.len()))
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let shape = view.shape_index[i];
            if shape < 0 {
                let Some(env) = &env else { return Vec3::ZERO };
                let (x, y) = ((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
                let (_, d) = scene.camera.ray(x, y);
                return sanitized(env.radiance(d));
            }
            let l = area.at(shape as usize, view.uv[i]);
            let own = if l != Vec3::ZERO && view.wi[i].dot(view.normal[i]) > 0.0 { l } else { Vec3::ZERO };
            own + chain(i)
        })
        .collect()
}

impl LightMatrix {
    /// What the camera sees directly (module docs) plus, with glossy view samples, the BSDF strategy of
    /// glossy MIS (`glossy::bsdf_image`, exact rays on the CPU): H * W * 3 floats, row 0 at the top, RGB.
    ///
    /// Errors: building the ray tracer (GPU backend, first use).
    pub fn emitted(&self) -> crate::error::Result<Vec<f32>> {
        let mut e = emitted_radiance(&self.scene, &self.view);
        if !self.view.bsdf_samples.is_empty() {
            let tracer = self.tracer()?;
            let g = super::glossy::bsdf_image(&self.scene, &tracer, &self.view, &self.lights, self.view.glossy_seed);
            for (a, b) in e.iter_mut().zip(g) {
                *a += b;
            }
        }
        Ok(e.iter().flat_map(|v| v.to_array()).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Location;
    use crate::scene::{Camera, EnvMap, Mesh, ShapeKind};
    use glam::{Mat4, Vec2};

    /// One pixel row of three samples: background, the emitter seen from the front, from the back.
    fn setup(emitters: Vec<Emitter>) -> (Scene, ViewSamples) {
        let camera = Camera {
            world_from_camera: Mat4::IDENTITY,
            fov_x: 0.7,
            near_clip: 0.01,
            far_clip: 1e4,
            width: 3,
            height: 1,
            principal_point_offset: glam::Vec2::ZERO,
            loc: Location::default(),
        };
        let mut scene = Scene {
            path: "test".into(),
            integrator: None,
            camera,
            meshes: Vec::new(),
            bsdfs: Vec::new(),
            textures: Vec::new(),
            emitters,
        };
        scene.meshes.push(Mesh {
            id: "panel".into(),
            kind: ShapeKind::Rectangle,
            positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
            normals: vec![Vec3::Z; 3],
            uvs: vec![],
            indices: vec![[0, 1, 2]],
            face_normals: true,
            bsdf: 0,
            emitter: scene.emitters.iter().position(|e| matches!(e, Emitter::Area { .. })),
            loc: Location::default(),
        });
        let view = ViewSamples {
            width: 3,
            height: 1,
            position: vec![Vec3::ZERO; 3],
            normal: vec![Vec3::ZERO, Vec3::Z, Vec3::Z],
            geo_normal: vec![Vec3::ZERO, Vec3::Z, Vec3::Z],
            wi: vec![Vec3::ZERO, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.0, 0.6, -0.8)],
            uv: vec![Vec2::ZERO; 3],
            albedo: vec![Vec3::ZERO; 3],
            shape_index: vec![-1, 0, 0],
            prim_index: vec![-1, 0, 0],
            bsdf: vec![bytemuck::Zeroable::zeroed(); 3],
            ..Default::default()
        };
        (scene, view)
    }

    #[test]
    fn area_emitter_front_side_only_and_constant_background() {
        let loc = Location::default();
        let (scene, view) = setup(vec![
            Emitter::Constant { radiance: Vec3::new(0.25, 0.5, 1.0), loc: loc.clone() },
            Emitter::Area { mesh: 0, radiance: Vec3::new(3.0, 2.0, 1.0), texture: None, loc },
        ]);
        let e = emitted_radiance(&scene, &view);
        assert_eq!(e, vec![Vec3::new(0.25, 0.5, 1.0), Vec3::new(3.0, 2.0, 1.0), Vec3::ZERO]);
    }

    #[test]
    fn envmap_background_uses_the_camera_ray_and_bad_values_are_zero() {
        let loc = Location::default();
        // A 4 x 3 map: constant 2 except NaN / inf texels, which count as 0.
        let mut data = vec![Vec3::splat(2.0); 12];
        data[5] = Vec3::new(f32::NAN, 1.0, f32::INFINITY);
        let map = EnvMap { width: 4, height: 3, data, world_from_env: Mat4::IDENTITY, scale: 1.0 };
        let (scene, view) = setup(vec![
            Emitter::EnvMap { map: map.clone(), loc: loc.clone() },
            Emitter::Area { mesh: 0, radiance: Vec3::new(f32::NAN, -1.0, 4.0), texture: None, loc },
        ]);
        let e = emitted_radiance(&scene, &view);
        let (_, d) = scene.camera.ray(0.5, 0.5);
        let expect = crate::lights::generate::environment::envmap_radiance(&map, d);
        assert!(e.iter().all(|v| v.is_finite()), "{e:?}");
        if expect.is_finite() {
            assert_eq!(e[0], expect);
        }
        assert_eq!(e[1], Vec3::new(0.0, 0.0, 4.0));
        assert_eq!(e[2], Vec3::ZERO);
    }
}
