//! A spot light's projected texture (Mitsuba 3.9.1 `src/emitters/spot.cpp`, parameter `texture`).
//!
//! The texture multiplies the spot's intensity (and its falloff): for a direction v leaving the light,
//! in the light's local frame (x, y, z) = (v . x_axis, v . y_axis, v . axis), +z the spot axis,
//!     uv = (0.5 + 0.5 x / (z tan(cutoff_angle)), 0.5 + 0.5 y / (z tan(cutoff_angle)))
//! (Mitsuba's `direction_to_uv`), looked up with `crate::scene::texture::eval` (the bitmap's own filter
//! and wrap mode, or a checkerboard). The axes are the unit columns of the spot's `to_world`.
//!
//! Power (W): I times the integral of falloff * texture over the cutoff cone (the mean weight of
//! Mitsuba's `sample_ray`), by a fixed `POWER_N` x `POWER_N` midpoint quadrature over uniform-cone
//! samples (`spot_power_textured`).
//!
//! GPU layout (`gpu_records`): per textured spot, a 16-float header (width, height, wrap, filter as f32;
//! checkerboard: width = 0 and texels = the two colours; then `to_uv` column-major, 9 floats; 3 unused),
//! then the texels as RGB triplets; read by `spot_texture_eval` in `shaders/common/light.wgsl`.
use crate::scene::texture;
use crate::scene::types::{FilterType, Texture, WrapMode};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Quadrature resolution of the textured spot's power.
pub const POWER_N: usize = 256;
/// Floats before the texels in a GPU record.
pub const GPU_HEADER: usize = 16;

/// A projected texture of one spot light.
#[derive(Debug, Clone)]
pub struct SpotTexture {
    /// Unit local x and y axes of the light in world space.
    pub x_axis: Vec3,
    pub y_axis: Vec3,
    /// tan(cutoff_angle).
    pub tan_cutoff: f32,
    pub texture: Arc<Texture>,
}

impl SpotTexture {
    /// Mitsuba's `direction_to_uv` for local (x, y, z).
    pub fn uv(&self, local: Vec3) -> Vec2 {
        Vec2::new(0.5 + 0.5 * local.x / (local.z * self.tan_cutoff), 0.5 + 0.5 * local.y / (local.z * self.tan_cutoff))
    }

    /// Texture value for the world direction `v` leaving the light (spot axis `axis`, unit).
    pub fn eval_world(&self, v: Vec3, axis: Vec3) -> Vec3 {
        texture::eval(&self.texture, self.uv(Vec3::new(v.dot(self.x_axis), v.dot(self.y_axis), v.dot(axis))))
    }

    /// The GPU record (module docs) appended to `out`; returns its offset (in floats).
    pub fn push_gpu_record(&self, out: &mut Vec<f32>) -> u32 {
        let offset = out.len() as u32;
        let mut header = [0.0f32; GPU_HEADER];
        let (to_uv, texels): (glam::Mat3, Vec<Vec3>) = match &*self.texture {
            Texture::Bitmap { width, height, data, filter, wrap, to_uv, .. } => {
                header[0] = *width as f32;
                header[1] = *height as f32;
                header[2] = match wrap {
                    WrapMode::Repeat => 0.0,
                    WrapMode::Mirror => 1.0,
                    WrapMode::Clamp => 2.0,
                };
                header[3] = match filter {
                    FilterType::Bilinear => 0.0,
                    FilterType::Nearest => 1.0,
                };
                (*to_uv, data.clone())
            }
            Texture::Checkerboard { color0, color1, to_uv } => (*to_uv, vec![*color0, *color1]),
        };
        header[4..13].copy_from_slice(&to_uv.to_cols_array());
        out.extend_from_slice(&header);
        for t in texels {
            out.extend_from_slice(&t.to_array());
        }
        offset
    }
}

/// `NO_TEXTURE` in a `GpuLight`'s `texture` field: the light has no projected texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// The GPU records of every textured spot of `lights` (one f32 buffer) and each light's record offset
/// (`NO_TEXTURE` for lights without one).
pub fn gpu_table(lights: &super::LightSet) -> (Vec<f32>, Vec<u32>) {
    let mut data = Vec::new();
    let offsets = lights.spot_texture.iter().map(|t| t.as_ref().map_or(NO_TEXTURE, |t| t.push_gpu_record(&mut data))).collect();
    (data, offsets)
}

/// Uniform direction in the cone of half-angle acos(cos_c) around +z (Mitsuba's `square_to_uniform_cone`).
fn uniform_cone(u: f32, v: f32, cos_c: f32) -> Vec3 {
    let cos_t = (1.0 - u) + u * cos_c;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * v;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Integral over the sphere of falloff(w) * texture(w) (sr, per RGB channel) for a spot with this
/// texture; the local frame is used directly (x, y, z = axes).
pub fn spot_power_textured(tex: &SpotTexture, cutoff_angle: f32, beam_width: f32) -> Vec3 {
    let cos_c = cutoff_angle.cos();
    let mut sum = glam::DVec3::ZERO;
    for a in 0..POWER_N {
        for b in 0..POWER_N {
            let u = (a as f32 + 0.5) / POWER_N as f32;
            let v = (b as f32 + 0.5) / POWER_N as f32;
            let local = uniform_cone(u, v, cos_c);
            let f = super::spot_falloff(local.z, cutoff_angle, beam_width);
            if f > 0.0 {
                sum += (texture::eval(&tex.texture, tex.uv(local)) * f).as_dvec3();
            }
        }
    }
    let solid = 2.0 * std::f64::consts::PI * (1.0 - cos_c as f64);
    (sum * (solid / (POWER_N * POWER_N) as f64)).as_vec3()
}

#[cfg(test)]
mod tests;
