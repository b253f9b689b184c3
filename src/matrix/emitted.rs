//! What the camera sees of emitters directly: not a column of the light matrix, but part of every image
//! (as in Mitsuba, whose `path` integrator adds it at the first hit).
//!
//! - A view sample on a shape with an area emitter adds its radiance when seen from the emitting side:
//!   Mitsuba's area emitter returns its radiance where `cos_theta(si.wi) > 0` in the shading frame.
//! - A background pixel (no hit) shows the environment (envmap lookup as Mitsuba's, plus constant
//!   emitters) along its camera ray through the pixel centre.
use crate::lights::generate::environment::Environment;
use crate::scene::{Emitter, Scene};
use crate::view::ViewSamples;
use glam::Vec3;
use rayon::prelude::*;

/// The emitted-radiance image, H * W * 3 floats, row 0 at the top. Non-finite radiance counts as 0.
pub fn emitted_image(scene: &Scene, view: &ViewSamples) -> Vec<f32> {
    let env = Environment::from_scene(scene);
    let width = view.width as usize;
    (0..view.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let l = match view.shape_index[i] {
                s if s < 0 => match &env {
                    Some(env) => {
                        let (x, y) = ((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
                        let (_, d) = scene.camera.ray(x, y);
                        env.radiance(d)
                    }
                    None => Vec3::ZERO,
                },
                s => match scene.meshes[s as usize].emitter.map(|e| &scene.emitters[e]) {
                    Some(Emitter::Area { radiance, .. }) if view.wi[i].dot(view.normal[i]) > 0.0 => *radiance,
                    _ => Vec3::ZERO,
                },
            };
            let l = if l.is_finite() { l } else { Vec3::ZERO };
            l.to_array()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuContext;
    use crate::scene::{load_scene, LoadOptions};

    fn scene(name: &str, params: &[(&str, &str)]) -> (Scene, ViewSamples) {
        let path = crate::testing::shared_dir().join("scenes").join(name).join("scene.xml");
        let opts = LoadOptions {
            params: params.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            ..Default::default()
        };
        let s = load_scene(&path, &opts).unwrap();
        let ctx = GpuContext::shared().unwrap();
        let v = crate::gpu::gbuffer::render_view_samples(&ctx, &s).unwrap();
        (s, v)
    }

    #[test]
    fn area_light_pixels_show_their_radiance_and_nothing_else_emits() {
        let (s, v) = scene("cbox", &[("res", "64")]);
        let img = emitted_image(&s, &v);
        let light_mesh = s.meshes.iter().position(|m| m.emitter.is_some()).unwrap() as i32;
        let Emitter::Area { radiance, .. } = s.emitters[s.meshes[light_mesh as usize].emitter.unwrap()] else {
            panic!("cbox's emitter is an area light")
        };
        let mut lit = 0;
        for i in 0..v.len() {
            let px = Vec3::from_slice(&img[3 * i..3 * i + 3]);
            if v.shape_index[i] == light_mesh {
                // The luminaire faces down, the camera looks at it from below.
                assert_eq!(px, radiance);
                lit += 1;
            } else {
                assert_eq!(px, Vec3::ZERO, "pixel {i} (shape {})", v.shape_index[i]);
            }
        }
        assert!(lit > 0);
    }

    #[test]
    fn background_shows_the_environment_along_the_camera_ray() {
        let (s, v) = scene("cbox-lights", &[("res", "32")]);
        let img = emitted_image(&s, &v);
        let env = Environment::from_scene(&s).unwrap();
        let bg: Vec<usize> = (0..v.len()).filter(|&i| v.shape_index[i] < 0).collect();
        assert!(!bg.is_empty());
        for &i in &bg {
            let (_, d) = s.camera.ray((i % 32) as f32 + 0.5, (i / 32) as f32 + 0.5);
            assert_eq!(Vec3::from_slice(&img[3 * i..3 * i + 3]), env.radiance(d));
            assert!(env.radiance(d).max_element() > 0.0);
        }
    }
}
