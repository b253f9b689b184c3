//! G-buffer as a visibility buffer: rasterise the scene at pixel centres into an `R32Uint` target
//! holding `global triangle id + 1` (0 = background), read it back, then resolve every pixel exactly on
//! the CPU (`crate::view::resolve`) into [`ViewSamples`].
//!
//! Implementation details:
//! - Camera: Mitsuba's perspective sensor. In its frame (left, up, forward) a point (x, y, z) lands at
//!   film position px = W (1 - x / (z tan_x)) / 2, py = H (1 - y / (z tan_y)) / 2, so clip space is
//!   (-x / tan_x, y / tan_y, A z + B, z): column 0 looks toward +left, row 0 toward +up. A principal point
//!   offset (ox, oy) (film units, as Mitsuba's) shifts the film: clip x -= 2 ox z, clip y += 2 oy z. The rasteriser
//!   samples pixel (i, j) at (i + 0.5, j + 0.5), the centre Mitsuba's pixel-centre rays go through.
//! - Depth: reverse-Z in Depth32Float, d = A + B / z = 1 at `near_clip`, 0 at `far_clip` (A = 0 when
//!   far is infinite), compare "greater". 1/z is affine in screen space, so the interpolated depth is
//!   exact up to f32 rounding: relative depth precision ~1e-7 at every distance (cbox: 1e-4 units at
//!   800 units), and the clip range is exactly Mitsuba's [near_clip, far_clip] along z.
//! - No culling (Mitsuba sees back faces). The clip matrix is composed in f64, applied in f32.
//! - `ShapeKind::Sphere` meshes are drawn with a second pipeline: the tessellation, enlarged about the
//!   centre just enough to enclose the sphere, selects candidate pixels; the fragment shader intersects
//!   the exact sphere along the pixel's camera ray, discards misses and writes the hit's depth. The
//!   silhouette is thus the analytic one (not the tessellation's), as in Mitsuba.
//! - Read back through a buffer with rows padded to 256 bytes (GL cannot copy depth; ids suffice).
use crate::error::{Error, Result};
use crate::gpu::scene_buffers::SceneGeometry;
use crate::gpu::shaders;
use crate::gpu::GpuContext;
use crate::scene::{Camera, Mesh, Scene, ShapeKind};
use crate::view::ViewSamples;
use glam::{DMat4, DVec4};
use std::sync::{Arc, Mutex};

/// Format of the visibility target.
pub const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Keep in sync with `struct GBufferUniforms` in `shaders/gbuffer.wgsl` (160 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GBufferUniforms {
    pub clip_from_world: [[f32; 4]; 4],
    /// xyz: camera left axis, w: tan(fov_x / 2).
    pub left_tan_x: [f32; 4],
    /// xyz: camera up axis, w: tan(fov_y / 2).
    pub up_tan_y: [f32; 4],
    /// xyz: camera forward axis, w: near_clip.
    pub forward_near: [f32; 4],
    /// xyz: camera origin, w: far_clip.
    pub origin_far: [f32; 4],
    /// Film width, height (pixels), depth A, depth B.
    pub film_depth: [f32; 4],
    /// xy: the camera's principal point offset (film units, `Camera::principal_point_offset`); zw: 0.
    pub principal_point: [f32; 4],
}

/// Keep in sync with `struct SphereUniforms` in `shaders/gbuffer.wgsl` (32 bytes, bound at a
/// dynamic offset of `sphere_stride`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SphereUniforms {
    /// xyz: centre, w: radius.
    pub center_radius: [f32; 4],
    /// x: enlargement of the tessellation about the centre; yzw: padding.
    pub scale: [f32; 4],
}

/// Reverse-Z depth coefficients (A, B) with d = A + B / z: 1 at `near`, 0 at `far` (A = 0 if far = inf).
pub fn reverse_z(near: f64, far: f64) -> (f64, f64) {
    if far.is_finite() {
        (-near / (far - near), near * far / (far - near))
    } else {
        (0.0, near)
    }
}

/// Check what the projection needs of a camera (sides up to the GPU's texture limit `max_dim`).
pub fn validate_camera(camera: &Camera, max_dim: u32) -> Result<()> {
    validate_camera_for(camera, max_dim, "the device's texture limit")
}

/// `validate_camera` with the reason for the side limit named in the error.
pub fn validate_camera_for(camera: &Camera, max_dim: u32, limit: &str) -> Result<()> {
    let bad = |what: String| Err(Error::scene(&camera.loc, what));
    if camera.width == 0 || camera.height == 0 || camera.width > max_dim || camera.height > max_dim {
        return bad(format!("film size {}x{} unsupported: each side must be in 1..={max_dim} ({limit})", camera.width, camera.height));
    }
    if !(camera.fov_x > 0.0 && camera.fov_x < std::f32::consts::PI) {
        return bad(format!("fov_x must be in (0, pi) radians, got {}", camera.fov_x));
    }
    if !(camera.near_clip > 0.0 && camera.near_clip.is_finite() && camera.far_clip > camera.near_clip) {
        return bad(format!("clip range must satisfy 0 < near_clip < far_clip, got near {} far {}", camera.near_clip, camera.far_clip));
    }
    if !camera.world_from_camera.is_finite() {
        return bad("camera to_world has non-finite entries".to_string());
    }
    Ok(())
}

impl GBufferUniforms {
    pub fn new(camera: &Camera) -> GBufferUniforms {
        let world_from_camera = camera.world_from_camera.as_dmat4();
        let camera_from_world = world_from_camera.inverse();
        let tan_x = (camera.fov_x as f64 * 0.5).tan();
        let tan_y = tan_x * camera.height as f64 / camera.width as f64;
        let (near, far) = (camera.near_clip as f64, camera.far_clip as f64);
        let (a, b) = reverse_z(near, far);
        // clip = (-x / tan_x - 2 ox z, y / tan_y + 2 oy z, A z + B, z) in the camera frame (x = left),
        // (ox, oy) the principal point offset: film position px / W = (1 - x / (z tan_x)) / 2 - ox.
        let o = camera.principal_point_offset.as_dvec2();
        let proj = DMat4::from_cols(
            DVec4::new(-1.0 / tan_x, 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0 / tan_y, 0.0, 0.0),
            DVec4::new(-2.0 * o.x, 2.0 * o.y, a, 1.0),
            DVec4::new(0.0, 0.0, b, 0.0),
        );
        let clip_from_world = (proj * camera_from_world).as_mat4();
        let axis = |v: glam::Vec4, w: f64| [v.x, v.y, v.z, w as f32];
        let m = camera.world_from_camera;
        GBufferUniforms {
            clip_from_world: clip_from_world.to_cols_array_2d(),
            left_tan_x: axis(m.x_axis, tan_x),
            up_tan_y: axis(m.y_axis, tan_y),
            forward_near: axis(m.z_axis, near),
            origin_far: axis(m.w_axis, far),
            film_depth: [camera.width as f32, camera.height as f32, a as f32, b as f32],
            principal_point: [o.x as f32, o.y as f32, 0.0, 0.0],
        }
    }
}

/// Factor by which the tessellation of a sphere must grow about `center` so that every triangle plane
/// lies at least `radius` away (the enlarged convex tessellation then encloses the sphere), with a
/// 1e-3 margin for f32 rounding. 1 for an empty mesh; capped at 4 (a non-convex or off-centre mesh).
pub fn sphere_enlargement(mesh: &Mesh, center: glam::Vec3, radius: f32) -> f32 {
    let c = center.as_dvec3();
    let mut scale: f64 = 1.0;
    for tri in &mesh.indices {
        let p: Vec<glam::DVec3> = tri.iter().filter_map(|&v| mesh.positions.get(v as usize)).map(|p| p.as_dvec3()).collect();
        if p.len() != 3 {
            continue;
        }
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        if n.length_squared() == 0.0 {
            continue;
        }
        let h = n.normalize().dot(p[0] - c).abs();
        scale = scale.max(radius as f64 / h.max(1e-30));
    }
    (scale * 1.001).min(4.0) as f32
}

/// The G-buffer visibility pass: pipelines for triangles and analytic spheres and their layout.
pub struct GBufferPass {
    pub triangles_pipeline: wgpu::RenderPipeline,
    pub sphere_pipeline: wgpu::RenderPipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

impl GBufferPass {
    /// Compile the pass (once per device).
    pub fn new(device: &wgpu::Device) -> Result<GBufferPass> {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("GBufferPass::module"),
            source: wgpu::ShaderSource::Wgsl(shaders::GBUFFER.into()),
        });
        let uniform = |binding, dynamic, size: usize| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: wgpu::BufferSize::new(size as u64),
            },
            count: None,
        };
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("GBufferPass::bind_group_layout"),
            entries: &[uniform(0, false, std::mem::size_of::<GBufferUniforms>()), uniform(1, true, std::mem::size_of::<SphereUniforms>())],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("GBufferPass::pipeline_layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let pipeline = |label, vs, fs| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[Some(SceneGeometry::VERTEX_LAYOUT)],
                },
                primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleList, cull_mode: None, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format: ID_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let triangles_pipeline = pipeline("GBufferPass::triangles_pipeline", "vs_triangles", "fs_triangles");
        let sphere_pipeline = pipeline("GBufferPass::sphere_pipeline", "vs_sphere", "fs_sphere");
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("creating the G-buffer pipelines failed: {e}")));
        }
        Ok(GBufferPass { triangles_pipeline, sphere_pipeline, bind_group_layout })
    }

    /// The pass for `device`, compiled on first use and cached (a few devices at most).
    pub fn cached(device: &wgpu::Device) -> Result<Arc<GBufferPass>> {
        static CACHE: Mutex<Vec<(wgpu::Device, Arc<GBufferPass>)>> = Mutex::new(Vec::new());
        let mut cache = CACHE.lock().map_err(|_| Error::Gpu("G-buffer pass cache poisoned".into()))?;
        if let Some((_, pass)) = cache.iter().find(|(d, _)| d == device) {
            return Ok(pass.clone());
        }
        let pass = Arc::new(GBufferPass::new(device)?);
        // Keep the newest few: tests create several devices, a session uses one.
        if cache.len() >= 4 {
            cache.remove(0);
        }
        cache.push((device.clone(), pass.clone()));
        Ok(pass)
    }

    /// Rasterise `geometry` (uploaded from `scene`) and return the visibility buffer:
    /// `ids[y * width + x]` = global triangle id + 1, 0 for background.
    pub fn render_visibility(&self, ctx: &GpuContext, scene: &Scene, geometry: &SceneGeometry) -> Result<Vec<u32>> {
        let device = &ctx.device;
        let camera = &scene.camera;
        validate_camera(camera, ctx.limits.max_texture_dimension_2d)?;
        let (w, h) = (camera.width, camera.height);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom_scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);

        let uniforms = super::alloc::buffer_init(
            device,
            "GBufferPass::uniforms",
            bytemuck::bytes_of(&GBufferUniforms::new(camera)),
            wgpu::BufferUsages::UNIFORM,
        )?;
        // One uniform block per analytic sphere, at the device's dynamic-offset alignment.
        let align = device.limits().min_uniform_buffer_offset_alignment.max(32) as usize;
        let stride = std::mem::size_of::<SphereUniforms>().div_ceil(align) * align;
        let mut sphere_bytes = vec![0u8; stride];
        let mut draws: Vec<(Option<u32>, std::ops::Range<u32>)> = Vec::new();
        for (m, mesh) in scene.meshes.iter().enumerate() {
            let range = geometry.mesh_vertices(m);
            if range.is_empty() {
                continue;
            }
            match mesh.kind {
                ShapeKind::Sphere { center, radius, .. } => {
                    let slot = (sphere_bytes.len() / stride) as u32 - 1;
                    let u = SphereUniforms {
                        center_radius: [center.x, center.y, center.z, radius],
                        scale: [sphere_enlargement(mesh, center, radius), 0.0, 0.0, 0.0],
                    };
                    let start = slot as usize * stride;
                    sphere_bytes[start..start + std::mem::size_of::<SphereUniforms>()].copy_from_slice(bytemuck::bytes_of(&u));
                    sphere_bytes.resize(sphere_bytes.len() + stride, 0);
                    draws.push((Some(slot), range));
                }
                _ => match draws.last_mut() {
                    // Merge consecutive triangle meshes into one draw.
                    Some((None, r)) if r.end == range.start => r.end = range.end,
                    _ => draws.push((None, range)),
                },
            }
        }
        let spheres = super::alloc::buffer_init(device, "GBufferPass::spheres", &sphere_bytes, wgpu::BufferUsages::UNIFORM)?;
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("GBufferPass::bind_group"),
            layout: &self.bind_group_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &spheres,
                        offset: 0,
                        size: wgpu::BufferSize::new(std::mem::size_of::<SphereUniforms>() as u64),
                    }),
                },
            ],
        });

        let extent = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let texture = |label, format, usage| {
            super::alloc::texture(
                device,
                &wgpu::TextureDescriptor {
                    label: Some(label),
                    size: extent,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                },
            )
        };
        let ids = texture("GBufferPass::ids", ID_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC)?;
        let depth = texture("GBufferPass::depth", DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT)?;
        let ids_view = ids.create_view(&Default::default());
        let depth_view = depth.create_view(&Default::default());

        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GBufferPass::encoder") });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("GBufferPass::render_pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &ids_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    // Reverse-Z: clear to the far value 0.
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if geometry.num_triangles > 0 {
                pass.set_vertex_buffer(0, geometry.vertex_buffer.slice(..));
            }
            for (sphere, range) in &draws {
                match sphere {
                    None => {
                        pass.set_pipeline(&self.triangles_pipeline);
                        pass.set_bind_group(0, &bind_group, &[0]);
                    }
                    Some(slot) => {
                        pass.set_pipeline(&self.sphere_pipeline);
                        pass.set_bind_group(0, &bind_group, &[slot * stride as u32]);
                    }
                }
                pass.draw(range.clone(), 0..1);
            }
        }
        let padded_row = (w * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let readback = super::alloc::buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("GBufferPass::readback"),
                size: padded_row as u64 * h as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        )?;
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo { texture: &ids, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded_row), rows_per_image: Some(h) },
            },
            extent,
        );
        ctx.queue.submit(Some(encoder.finish()));
        if let Some(e) = pollster::block_on(oom_scope.pop()) {
            return Err(Error::Gpu(format!("G-buffer pass ran out of memory ({w}x{h}): {e}")));
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("G-buffer pass failed: {e}")));
        }
        let padded: Vec<u32> = ctx.read_buffer(&readback, 0, (padded_row / 4 * h) as usize)?;
        let row = (padded_row / 4) as usize;
        Ok(padded.chunks_exact(row).flat_map(|r| r[..w as usize].iter().copied()).collect())
    }
}

/// The deep framebuffer of `scene` seen from its camera: rasterised visibility at pixel centres on the
/// GPU, resolved exactly on the CPU (see `crate::view::resolve`).
pub fn render_view_samples(ctx: &GpuContext, scene: &Scene) -> Result<ViewSamples> {
    render_view_samples_with(ctx, scene, &crate::view::chains::ChainOptions::default())
}

/// As [`render_view_samples`], following delta BSDF chains with `chains` (`crate::view::chains`).
pub fn render_view_samples_with(ctx: &GpuContext, scene: &Scene, chains: &crate::view::chains::ChainOptions) -> Result<ViewSamples> {
    let ids = render_visibility(ctx, scene)?;
    crate::view::resolve::resolve_view_samples_with(scene, &ids, chains)
}

/// As [`render_view_samples`], reusing geometry already uploaded with `SceneGeometry::upload(device,
/// scene)` (e.g. shared with shadow-map passes).
pub fn render_view_samples_with_geometry(ctx: &GpuContext, scene: &Scene, geometry: &SceneGeometry) -> Result<ViewSamples> {
    if geometry.triangle_offsets != crate::gpu::scene_buffers::triangle_offsets(&scene.meshes)? {
        return Err(Error::invalid("the uploaded geometry belongs to another scene (triangle counts differ)"));
    }
    let ids = GBufferPass::cached(&ctx.device)?.render_visibility(ctx, scene, geometry)?;
    crate::view::resolve::resolve_view_samples(scene, &ids)
}

/// Only the visibility buffer of `scene` (global triangle id + 1 per pixel, 0 = background).
pub fn render_visibility(ctx: &GpuContext, scene: &Scene) -> Result<Vec<u32>> {
    validate_camera(&scene.camera, ctx.limits.max_texture_dimension_2d)?;
    crate::memory::check_view_samples(ctx, scene.camera.width, scene.camera.height)?;
    let pass = GBufferPass::cached(&ctx.device)?;
    let geometry = SceneGeometry::upload(&ctx.device, scene)?;
    pass.render_visibility(ctx, scene, &geometry)
}

#[cfg(test)]
mod tests;
