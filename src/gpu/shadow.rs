//! Shadow maps for delta lights: depth-only rasterisation of all scene triangles into layers of a 2D
//! depth array texture (`shaders/shadow.wgsl`), consumed by `columns.wgsl` with `textureLoad`.
//!
//! - point light: a cube map as 6 layers (faces +X, -X, +Y, -Y, +Z, -Z, 90 degree perspective); the
//!   shader picks the face from the major axis of (p - light position).
//! - spot light: one perspective layer covering the cutoff cone (fov = 2 atan(1.02 tan(cutoff))); spots
//!   wider than `MAX_SPOT_MAP_CUTOFF` use a cube like a point light.
//! - directional light (also environment strata): one orthographic layer fitted to the scene's bounding sphere.
//! - oriented point (area light sample) and VPL: a cube map like a point light (all 6 faces are kept,
//!   even those behind the emitting hemisphere, so batches lay out alike).
//! Near/far planes enclose the scene's bounding sphere (near = 1e-3 radius: geometry closer than that to
//! a point/spot light is clipped and casts no shadow). No face culling (occluders are two-sided).
//!
//! Depth comparisons happen in the layer's own projected depth: the column pass offsets the shaded point
//! in world space (normal offset + slope-scaled depth bias, in units of the layer's world-space texel
//! size) and compares its projected depth with the stored one. Biases are in `ColumnOptions`.
use crate::gpu::scene_buffers::SceneGeometry;
use crate::gpu::shaders;
use crate::lights::{LightKind, LightSet};
use glam::{Mat4, Vec3};

/// Depth format of the shadow-map array.
pub const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Spots with a wider cutoff (radians, 75 degrees) get a cube map instead of one perspective map.
pub const MAX_SPOT_MAP_CUTOFF: f32 = 75.0 * std::f32::consts::PI / 180.0;
/// Stride of `GpuShadowLayer` in its buffer (the dynamic uniform offset alignment).
pub const SHADOW_LAYER_STRIDE: u64 = 256;

/// One shadow-map layer. Keep in sync with `struct ShadowLayer` in `shaders/common/shadow_layer.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuShadowLayer {
    pub view_proj: [[f32; 4]; 4],
    /// World-space texel size per unit of clip w.
    pub texel_scale: f32,
    pub is_ortho: u32,
    pub _pad0: [u32; 2],
    pub _pad1: [[f32; 4]; 16 - 4 - 1],
}

/// The 6 cube face directions and up vectors, in the order of `cube_face()` in the WGSL.
pub fn cube_face_dirs() -> [(Vec3, Vec3); 6] {
    [(Vec3::X, Vec3::Y), (Vec3::NEG_X, Vec3::Y), (Vec3::Y, Vec3::Z), (Vec3::NEG_Y, Vec3::Z), (Vec3::Z, Vec3::Y), (Vec3::NEG_Z, Vec3::Y)]
}

/// True when light j's shadow map is a cube (6 layers).
pub fn uses_cube(lights: &LightSet, j: usize) -> bool {
    match lights.kind[j] {
        LightKind::Point | LightKind::OrientedPoint | LightKind::Vpl => true,
        LightKind::Spot => lights.cutoff_angle[j] > MAX_SPOT_MAP_CUTOFF,
        LightKind::Directional => false,
    }
}

/// Number of layers light j needs.
pub fn layer_count(lights: &LightSet, j: usize) -> u32 {
    if uses_cube(lights, j) {
        6
    } else {
        1
    }
}

fn any_up(dir: Vec3) -> Vec3 {
    if dir.y.abs() < 0.99 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

/// View matrix (right-handed, looking down -z) from eye toward center.
fn look_at_rh(eye: Vec3, center: Vec3, up: Vec3) -> Mat4 {
    let f = (center - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// Perspective projection to wgpu's clip space (depth 0 at `near`, 1 at `far`), square aspect.
fn perspective_rh(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let h = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(h / aspect, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, h, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, -1.0),
        glam::Vec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// Orthographic projection to wgpu's clip space (depth 0 at `near`, 1 at `far`).
fn orthographic_rh(left: f32, right: f32, bottom: f32, top: f32, near: f32, far: f32) -> Mat4 {
    let (rw, rh, r) = (1.0 / (right - left), 1.0 / (top - bottom), 1.0 / (near - far));
    Mat4::from_cols(
        glam::Vec4::new(2.0 * rw, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 2.0 * rh, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, 0.0),
        glam::Vec4::new(-(left + right) * rw, -(top + bottom) * rh, r * near, 1.0),
    )
}

fn layer(view_proj: Mat4, texel_scale: f32, is_ortho: bool) -> GpuShadowLayer {
    GpuShadowLayer { view_proj: view_proj.to_cols_array_2d(), texel_scale, is_ortho: is_ortho as u32, _pad0: [0; 2], _pad1: [[0.0; 4]; 11] }
}

/// The layers (1 or 6) of light j's shadow map at `resolution` texels per side.
pub fn light_layers(lights: &LightSet, j: usize, resolution: u32) -> Vec<GpuShadowLayer> {
    let radius = lights.scene_radius.max(1e-6);
    let center = lights.scene_center;
    let res = resolution as f32;
    match lights.kind[j] {
        LightKind::Directional => {
            let dir = lights.direction[j];
            let extent = radius * 1.01;
            let eye = center - dir * (2.0 * radius);
            let view = look_at_rh(eye, center, any_up(dir));
            let proj = orthographic_rh(-extent, extent, -extent, extent, 0.5 * radius, 3.5 * radius);
            vec![layer(proj * view, 2.0 * extent / res, true)]
        }
        kind => {
            let pos = lights.position[j];
            let far = ((pos - center).length() + radius) * 1.01;
            let near = (1e-3 * radius).min(0.5 * far);
            if kind == LightKind::Spot && !uses_cube(lights, j) {
                let dir = lights.direction[j];
                let half_fov = (lights.cutoff_angle[j].tan() * 1.02).atan();
                let view = look_at_rh(pos, pos + dir, any_up(dir));
                let proj = perspective_rh(2.0 * half_fov, 1.0, near, far);
                vec![layer(proj * view, 2.0 * half_fov.tan() / res, false)]
            } else {
                let proj = perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, near, far);
                cube_face_dirs().iter().map(|(dir, up)| layer(proj * look_at_rh(pos, pos + *dir, *up), 2.0 / res, false)).collect()
            }
        }
    }
}

/// A 2D depth array texture holding a batch's shadow maps, with one attachment view per layer.
pub struct ShadowAtlas {
    pub texture: wgpu::Texture,
    /// Render-attachment view of each layer.
    pub layer_views: Vec<wgpu::TextureView>,
    /// The whole array, for sampling (`texture_depth_2d_array`).
    pub array_view: wgpu::TextureView,
    pub resolution: u32,
    pub num_layers: u32,
}

impl ShadowAtlas {
    /// Errors: `OutOfMemory` / `Gpu` from the guarded allocation (`gpu::alloc`).
    pub fn new(device: &wgpu::Device, resolution: u32, num_layers: u32) -> crate::error::Result<ShadowAtlas> {
        let texture = crate::gpu::alloc::texture(
            device,
            &wgpu::TextureDescriptor {
                label: Some("ShadowAtlas::texture"),
                size: wgpu::Extent3d { width: resolution, height: resolution, depth_or_array_layers: num_layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: SHADOW_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
        )?;
        let layer_views = (0..num_layers)
            .map(|l| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("ShadowAtlas::layer_view"),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: l,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let array_view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("ShadowAtlas::array_view"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Ok(ShadowAtlas { texture, layer_views, array_view, resolution, num_layers })
    }
}

/// The depth-only pass: pipeline and the layout of its one dynamic uniform binding.
pub struct ShadowMapPass {
    pub pipeline: wgpu::RenderPipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

impl ShadowMapPass {
    pub fn new(device: &wgpu::Device) -> ShadowMapPass {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("ShadowMapPass::module"),
            source: wgpu::ShaderSource::Wgsl(shaders::SHADOW.into()),
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ShadowMapPass::bind_group_layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(SHADOW_LAYER_STRIDE),
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ShadowMapPass::pipeline_layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("ShadowMapPass::pipeline"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(SceneGeometry::VERTEX_LAYOUT)],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        ShadowMapPass { pipeline, bind_group_layout }
    }

    /// Render `num_layers` layers of `atlas`, layer l with `layers_buffer` at offset l * 256, drawing the
    /// scene's triangles from `geometry` (shared with the G-buffer pass).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        atlas: &ShadowAtlas,
        layers_buffer: &wgpu::Buffer,
        num_layers: u32,
        geometry: &SceneGeometry,
    ) {
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ShadowMapPass::bind_group"),
            layout: &self.bind_group_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: layers_buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(SHADOW_LAYER_STRIDE),
                }),
            }],
        });
        for l in 0..num_layers {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ShadowMapPass::layer"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &atlas.layer_views[l as usize],
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if geometry.num_triangles == 0 {
                continue;
            }
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[(l as u64 * SHADOW_LAYER_STRIDE) as u32]);
            geometry.draw_all(&mut pass);
        }
    }
}

#[cfg(test)]
mod tests;
