//! View samples: the deep framebuffer, one surface point per pixel centre (the rows of the light matrix).
//!
//! Produced by `crate::gpu::gbuffer` (rasterised visibility at pixel centres, then resolved exactly on the
//! CPU from the camera ray and the hit triangle / analytic sphere). Index `i = y * width + x`, row 0 at
//! the top, as Mitsuba's images.
use crate::shading::GpuBsdf;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Default)]
pub struct ViewSamples {
    pub width: u32,
    pub height: u32,
    /// World-space hit point (0 where `shape_index < 0`).
    pub position: Vec<Vec3>,
    /// Shading normal (interpolated vertex normal, or the face normal), unit, world space.
    pub normal: Vec<Vec3>,
    /// Geometric normal: normalize(cross(p1 - p0, p2 - p0)) (Mitsuba's), or the sphere's outward normal.
    pub geo_normal: Vec<Vec3>,
    /// Unit direction from the hit point toward the camera (Mitsuba's `-ray.d`, world space).
    pub wi: Vec<Vec3>,
    pub uv: Vec<Vec2>,
    /// Diffuse albedo at the point (textures evaluated): diffuse reflectance of diffuse/plastics, 0 else.
    pub albedo: Vec<Vec3>,
    /// Index into `Scene::meshes`, -1 for background.
    pub shape_index: Vec<i32>,
    /// Triangle index within the mesh, -1 for background.
    pub prim_index: Vec<i32>,
    /// The BSDF resolved at the point (`crate::shading::bsdf::resolve`): record i for sample i; past
    /// `len()`, the second records of blended samples (`blendbsdf`, linked from their first record; see
    /// `crate::view_resolve::append_blend_records`). Evaluate with `shading::bsdf::eval_records`.
    pub bsdf: Vec<GpuBsdf>,
}

impl ViewSamples {
    pub fn len(&self) -> usize {
        self.shape_index.len()
    }
    pub fn is_empty(&self) -> bool {
        self.shape_index.is_empty()
    }
}
