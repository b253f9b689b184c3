//! GPU vertex data of a scene: every triangle of `Scene::meshes`, concatenated, with unshared vertices.
//!
//! Vertex `3 * t + k` is corner `k` of global triangle `t` (world space, packed `f32x3`), so a vertex
//! shader recovers the triangle as `vertex_index / 3` on every backend (no `primitive_index` feature).
//! Mesh `m` owns the global triangles `triangle_offsets[m] .. triangle_offsets[m + 1]`; its triangle `i`
//! is `Mesh::indices[i]`. The buffer carries nothing camera-specific: the G-buffer pass and depth-only
//! passes (shadow maps) draw it with their own `clip_from_world`, using [`SceneGeometry::VERTEX_LAYOUT`]
//! at shader location 0 (`@location(0) position: vec3<f32>`).
use crate::error::{Error, Result};
use crate::scene::{Mesh, Scene};
use glam::Vec3;

/// Global triangle offsets of each mesh: `offsets[m]` = first global triangle of mesh `m`,
/// `offsets[meshes.len()]` = total triangle count.
pub fn triangle_offsets(meshes: &[Mesh]) -> Result<Vec<u32>> {
    let mut offsets = Vec::with_capacity(meshes.len() + 1);
    let mut total: u64 = 0;
    offsets.push(0);
    for m in meshes {
        total += m.indices.len() as u64;
        // Three vertices per triangle must be addressable by a u32 `vertex_index`.
        if total * 3 > u32::MAX as u64 {
            return Err(Error::invalid(format!("scene has too many triangles for one vertex buffer: {total} (at most {})", u32::MAX / 3)));
        }
        offsets.push(total as u32);
    }
    Ok(offsets)
}

/// Which mesh and which of its triangles a global triangle id is: `(shape_index, prim_index)`.
/// `None` when `global` is past the last triangle.
pub fn locate_triangle(offsets: &[u32], global: u32) -> Option<(usize, u32)> {
    let total = *offsets.last()?;
    if global >= total {
        return None;
    }
    // The last mesh whose first triangle is <= global (empty meshes share offsets: skip past them).
    let m = offsets.partition_point(|&o| o <= global) - 1;
    Some((m, global - offsets[m]))
}

/// Unshared world-space vertices of all triangles (3 per triangle), in global triangle order.
/// Errors name the mesh and triangle whose index is out of range.
pub fn unshared_positions(meshes: &[Mesh]) -> Result<Vec<[f32; 3]>> {
    let count: usize = meshes.iter().map(|m| m.indices.len() * 3).sum();
    let mut out = Vec::with_capacity(count);
    for m in meshes {
        for (t, tri) in m.indices.iter().enumerate() {
            for &v in tri {
                let p: Vec3 = *m.positions.get(v as usize).ok_or_else(|| {
                    Error::scene(
                        &m.loc,
                        format!("mesh {:?}: triangle {t} uses vertex {v}, but the mesh has {} vertices", m.id, m.positions.len()),
                    )
                })?;
                out.push(p.to_array());
            }
        }
    }
    Ok(out)
}

/// A scene's triangles on the GPU (see the module docs).
pub struct SceneGeometry {
    /// `3 * num_triangles` vertices of `[f32; 3]` (usage VERTEX | STORAGE | COPY_DST).
    pub vertex_buffer: wgpu::Buffer,
    pub num_triangles: u32,
    /// `triangle_offsets(&scene.meshes)`.
    pub triangle_offsets: Vec<u32>,
}

impl SceneGeometry {
    /// Vertex stride in bytes (packed f32x3).
    pub const VERTEX_STRIDE: u64 = 12;
    const ATTRIBUTES: [wgpu::VertexAttribute; 1] =
        [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 0 }];
    /// Layout of `vertex_buffer` for a render pipeline: world position at `@location(0)`.
    pub const VERTEX_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: Self::VERTEX_STRIDE,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &Self::ATTRIBUTES,
    };

    /// Upload all triangles of `scene`. A scene without triangles gets a one-vertex dummy buffer
    /// (wgpu refuses empty vertex buffers) and `num_triangles == 0`.
    pub fn upload(device: &wgpu::Device, scene: &Scene) -> Result<SceneGeometry> {
        let triangle_offsets = triangle_offsets(&scene.meshes)?;
        let num_triangles = *triangle_offsets.last().unwrap_or(&0);
        let mut positions = unshared_positions(&scene.meshes)?;
        if positions.is_empty() {
            positions.push([0.0; 3]);
        }
        let vertex_buffer = crate::gpu::alloc::buffer_init(
            device,
            &format!("SceneGeometry::vertex_buffer ({num_triangles} triangles)"),
            bytemuck::cast_slice(&positions),
            wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )?;
        Ok(SceneGeometry { vertex_buffer, num_triangles, triangle_offsets })
    }

    /// Vertex range of mesh `m` (for per-mesh draws), empty when `m` is out of range.
    pub fn mesh_vertices(&self, m: usize) -> std::ops::Range<u32> {
        match (self.triangle_offsets.get(m), self.triangle_offsets.get(m + 1)) {
            (Some(&a), Some(&b)) => a * 3..b * 3,
            _ => 0..0,
        }
    }

    /// Bind the vertex buffer at slot 0 and draw every triangle.
    pub fn draw_all(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.num_triangles == 0 {
            return;
        }
        pass.set_vertex_buffer(0, self.vertex_buffer.slice(..));
        pass.draw(0..self.num_triangles * 3, 0..1);
    }
}

#[cfg(test)]
mod tests;
