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
//! Bad input gives zero contributions, never NaN: the loader refuses non-finite or negative emitted values
//! and texels; a `Scene` built another way still gets 0 per channel for them here (and non-finite env-map
//! texels or scale count as 0, as `Environment` does for the lights).
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
mod tests;
