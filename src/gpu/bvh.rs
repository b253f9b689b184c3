//! The scene's BVH on the GPU, for exact shadow rays (`shaders/common/bvh.wgsl`), and `OccludedPass`, a
//! batch of shadow-ray queries (`shaders/occluded.wgsl`).
//!
//! The BVH is a binary obvhs `Bvh2` (PLOC, Meister and Bittner, TVCG 2018, plus reinsertion and leaf
//! collapsing; `BvhBuildParams::medium_build`, at most 8 primitives per leaf) built on the CPU over the
//! same primitives as `raytrace::RayTracer`: every triangle, and one analytic sphere per
//! `ShapeKind::Sphere` mesh (never its tessellation). Primitives are stored in leaf order, so a leaf's
//! `first_index` indexes them directly. The WGSL traversal is obvhs' `ray_traverse_dynamic` (nearer
//! child first, a fixed stack of `STACK_SIZE` entries) with an any-hit exit, a watertight triangle test
//! and Mitsuba's ray offsets, so it agrees with `RayTracer::occluded` (tested on 100k+ segments per
//! scene).
//!
//! Deviations from the CPU tracer: the sphere test runs in f32 (the CPU uses f64), and an edge function
//! whose rounded value might have the wrong sign (within 2^-21 of its operands' products, which covers
//! exactly 0) is recomputed exactly in f32 expansion arithmetic instead of f64. The rounded edge
//! functions are only trusted where their sign is exact whether or not a driver fuses their products
//! into fused multiply-adds (WGSL cannot forbid that), so triangles sharing an edge or a vertex agree
//! on every GPU (`gpu::watertight` models the test under every contraction and checks it). Node boxes
//! are padded by a few ulps and the box exit distance scaled by `1 + 2 gamma(3)` (Ize, JCGT 2013), so
//! rounding never culls a box a ray touches.
//!
//! Storage: nodes are 32 bytes and primitives 48 bytes, each array one storage binding; scenes whose
//! arrays exceed the device's binding limit (128 MiB on Mesa: about 2.8M primitives) are an error.
use super::columns::{dispatch_size, storage_buffer};
use super::pipeline::{compute_pipeline, encode_dispatch, storage, uniform};
use super::GpuContext;
use crate::error::{Error, Result};
use crate::gpu::shaders;
use crate::scene::{Scene, ShapeKind};
use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::{Boundable, BvhBuildParams};

/// Most steps (node pairs visited + primitives tested) of one ray; mirrored in `bvh.wgsl`.
pub const MAX_RAY_STEPS: u32 = 2048;
/// Steps shared by all rays of one shader invocation (below Mesa 22.3's 65,535 loop iterations, with
/// room for the caller's own loops); mirrored in `bvh.wgsl`.
pub const INVOCATION_BUDGET: u32 = 61440;
/// Traversal stack entries; mirrored in `bvh.wgsl`. Trees deeper than this are rejected at upload.
pub const STACK_SIZE: u32 = 48;
/// Rays one invocation can always afford at the worst case of `MAX_RAY_STEPS` each.
pub const RAYS_PER_INVOCATION: u32 = INVOCATION_BUDGET / MAX_RAY_STEPS;

const PRIM_TRIANGLE: u32 = 0;
const PRIM_SPHERE: u32 = 1;

/// Keep in sync with `struct BvhNode` in `shaders/common/bvh.wgsl` (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuBvhNode {
    pub aabb_min: [f32; 3],
    /// 0 for inner nodes (children at `first_index`, `first_index + 1`), else the leaf's primitives.
    pub prim_count: u32,
    pub aabb_max: [f32; 3],
    pub first_index: u32,
}

/// Keep in sync with `struct BvhPrim` in `shaders/common/bvh.wgsl` (48 bytes): a triangle (v0, v1, v2)
/// or a sphere (v0 = centre, v1[0] = radius).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPrimitive {
    pub v0: [f32; 3],
    pub kind: u32,
    pub v1: [f32; 3],
    /// Offset of its mesh's record in the mask table (`crate::gpu::mask`), `mask::NO_MASK` when the mesh is
    /// not masked.
    pub mask: u32,
    pub v2: [f32; 3],
    /// The triangle's index in its mesh (0 for a sphere).
    pub index: u32,
}

impl Boundable for GpuPrimitive {
    fn aabb(&self) -> Aabb {
        let v0 = Vec3::from_array(self.v0);
        if self.kind == PRIM_SPHERE {
            let r = Vec3::splat(self.v1[0]);
            return Aabb::new((v0 - r).into(), (v0 + r).into());
        }
        let (v1, v2) = (Vec3::from_array(self.v1), Vec3::from_array(self.v2));
        Aabb::new(v0.min(v1).min(v2).into(), v0.max(v1).max(v2).into())
    }
}

/// The packed BVH on the host: nodes (root first) and primitives in leaf order.
#[derive(Debug, Clone)]
pub struct PackedBvh {
    pub nodes: Vec<GpuBvhNode>,
    pub primitives: Vec<GpuPrimitive>,
    /// Longest root-to-leaf path (nodes); the traversal stack holds at most `depth - 1` entries.
    pub depth: u32,
}

/// Every primitive of `scene`: triangles, and spheres as (centre, radius), each with its mesh's mask
/// record (`crate::gpu::mask::mesh_records`).
fn scene_primitives(scene: &Scene) -> Result<Vec<GpuPrimitive>> {
    let mut prims = Vec::new();
    let masks = super::mask::mesh_records(scene);
    for (index, mesh) in scene.meshes.iter().enumerate() {
        let mask = masks.get(index).copied().unwrap_or(super::mask::NO_MASK);
        let at = |what: String| Error::scene(&mesh.loc, format!("mesh {index} ('{}'): {what}", mesh.id));
        if let ShapeKind::Sphere { center, radius, .. } = mesh.kind {
            if !center.is_finite() || !(radius > 0.0 && radius.is_finite()) {
                return Err(at(format!("sphere needs a finite center and a radius > 0, got {center}, {radius}")));
            }
            prims.push(GpuPrimitive { v0: center.to_array(), kind: PRIM_SPHERE, v1: [radius, 0.0, 0.0], mask, v2: [0.0; 3], index: 0 });
            continue;
        }
        let n = mesh.positions.len();
        for (k, tri) in mesh.indices.iter().enumerate() {
            if tri.iter().any(|&i| i as usize >= n) {
                return Err(at(format!("triangle {k} has vertex indices {tri:?}, but the mesh has {n} vertices")));
            }
            let [v0, v1, v2] = tri.map(|i| mesh.positions[i as usize]);
            if !(v0.is_finite() && v1.is_finite() && v2.is_finite()) {
                return Err(at(format!("triangle {k} has a non-finite vertex ({v0}, {v1}, {v2})")));
            }
            prims.push(GpuPrimitive {
                v0: v0.to_array(),
                kind: PRIM_TRIANGLE,
                v1: v1.to_array(),
                mask,
                v2: v2.to_array(),
                index: k as u32,
            });
        }
    }
    Ok(prims)
}

/// A box grown by a few ulps of its coordinates (conservative against rounding in the slab test).
fn padded(min: Vec3A, max: Vec3A) -> ([f32; 3], [f32; 3]) {
    let pad = min.abs().max(max.abs()) * (8.0 * f32::EPSILON) + Vec3A::splat(1e-30);
    ((min - pad).to_array(), (max + pad).to_array())
}

impl PackedBvh {
    /// Builds the BVH of `scene` on the CPU.
    ///
    /// Errors: `Error::Scene` for out-of-range indices, non-finite vertices or invalid spheres;
    /// `Error::InvalidParameter` for a tree deeper than the traversal stack.
    pub fn build(scene: &Scene) -> Result<PackedBvh> {
        PackedBvh::from_primitives(scene_primitives(scene)?)
    }

    /// Builds the BVH over `prims` (any order).
    pub fn from_primitives(prims: Vec<GpuPrimitive>) -> Result<PackedBvh> {
        if prims.is_empty() {
            // One leaf holding a degenerate triangle (never hit), so the arrays bind and the root exists.
            let nothing =
                GpuPrimitive { v0: [0.0; 3], kind: PRIM_TRIANGLE, v1: [0.0; 3], mask: super::mask::NO_MASK, v2: [0.0; 3], index: 0 };
            let root = GpuBvhNode { aabb_min: [0.0; 3], prim_count: 1, aabb_max: [0.0; 3], first_index: 0 };
            return Ok(PackedBvh { nodes: vec![root], primitives: vec![nothing], depth: 1 });
        }
        let mut build_time = std::time::Duration::ZERO;
        let bvh = build_bvh2(&prims, BvhBuildParams::medium_build(), &mut build_time);
        let primitives: Vec<GpuPrimitive> = bvh.primitive_indices.iter().map(|&i| prims[i as usize]).collect();
        let nodes: Vec<GpuBvhNode> = bvh
            .nodes
            .iter()
            .map(|n| {
                let (aabb_min, aabb_max) = padded(n.aabb.min, n.aabb.max);
                GpuBvhNode { aabb_min, prim_count: n.prim_count, aabb_max, first_index: n.first_index }
            })
            .collect();
        // Depth by an explicit walk (node index, depth).
        let mut depth = 0u32;
        let mut todo = vec![(0usize, 1u32)];
        while let Some((i, d)) = todo.pop() {
            depth = depth.max(d);
            if nodes[i].prim_count == 0 {
                let c = nodes[i].first_index as usize;
                todo.push((c, d + 1));
                todo.push((c + 1, d + 1));
            }
        }
        if depth > STACK_SIZE {
            return Err(Error::invalid(format!("the scene's BVH is {depth} levels deep; the GPU traversal stack holds {STACK_SIZE}")));
        }
        Ok(PackedBvh { nodes, primitives, depth })
    }
}

/// The BVH in two storage buffers (bind them as `bvh_nodes` and `bvh_prims`).
pub struct GpuBvh {
    pub nodes: wgpu::Buffer,
    pub primitives: wgpu::Buffer,
    pub num_nodes: u32,
    pub num_primitives: u32,
    pub depth: u32,
}

impl GpuBvh {
    /// Builds (`PackedBvh::build`) and uploads the BVH of `scene`; `max_binding` is the device's largest
    /// storage binding in bytes. An empty scene gets one leaf with a degenerate triangle (every ray is free).
    pub fn upload(device: &wgpu::Device, scene: &Scene, max_binding: u64) -> Result<GpuBvh> {
        GpuBvh::from_packed(device, &PackedBvh::build(scene)?, max_binding)
    }

    /// A BVH that blocks nothing (for passes that bind one but cast no rays).
    pub fn empty(device: &wgpu::Device) -> Result<GpuBvh> {
        GpuBvh::from_packed(device, &PackedBvh::from_primitives(Vec::new())?, u64::MAX)
    }

    /// Uploads a packed BVH.
    pub fn from_packed(device: &wgpu::Device, packed: &PackedBvh, max_binding: u64) -> Result<GpuBvh> {
        for (what, bytes) in
            [("nodes", std::mem::size_of_val(packed.nodes.as_slice())), ("primitives", std::mem::size_of_val(packed.primitives.as_slice()))]
        {
            if bytes as u64 > max_binding {
                return Err(Error::invalid(format!(
                    "the scene's BVH {what} need {bytes} bytes, above the {max_binding}-byte storage binding limit"
                )));
            }
        }
        let usage = wgpu::BufferUsages::STORAGE;
        Ok(GpuBvh {
            nodes: storage_buffer(device, "GpuBvh::nodes", &packed.nodes, usage)?,
            primitives: storage_buffer(device, "GpuBvh::primitives", &packed.primitives, usage)?,
            num_nodes: packed.nodes.len() as u32,
            num_primitives: packed.primitives.len() as u32,
            depth: packed.depth,
        })
    }
}

/// What `OcclusionQuery::mode` asks.
pub const QUERY_RAY: u32 = 0;
pub const QUERY_TO_POINT: u32 = 1;
pub const QUERY_DIRECTION: u32 = 2;

/// Keep in sync with `struct OcclusionQuery` in `shaders/occluded.wgsl` (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OcclusionQuery {
    pub p: [f32; 3],
    pub mode: u32,
    pub v: [f32; 3],
    pub t_max: f32,
    pub q: [f32; 3],
    pub _pad: u32,
}

impl OcclusionQuery {
    /// Anything on `o + t d`, `0 < t < t_max` (as `RayTracer::occluded_ray`)?
    pub fn ray(o: Vec3, d: Vec3, t_max: f32) -> Self {
        OcclusionQuery { p: o.to_array(), mode: QUERY_RAY, v: d.to_array(), t_max, q: [0.0; 3], _pad: 0 }
    }
    /// Shadow ray from surface point `p` (geometric normal `n_g`) to `q` (as `RayTracer::occluded`).
    pub fn to_point(p: Vec3, n_g: Vec3, q: Vec3) -> Self {
        OcclusionQuery { p: p.to_array(), mode: QUERY_TO_POINT, v: n_g.to_array(), t_max: 0.0, q: q.to_array(), _pad: 0 }
    }
    /// Unbounded ray from surface point `p` (normal `n_g`) along unit `wo`, origin `offset_p(p, n_g, wo)`.
    pub fn direction(p: Vec3, n_g: Vec3, wo: Vec3) -> Self {
        OcclusionQuery { p: p.to_array(), mode: QUERY_DIRECTION, v: wo.to_array(), t_max: 0.0, q: n_g.to_array(), _pad: 0 }
    }
}

/// Outcome of one query.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OcclusionResult {
    pub occluded: bool,
    /// The ray ran out of steps or stack (its `occluded` is then meaningless).
    pub gave_up: bool,
    /// Traversal steps taken.
    pub steps: u32,
}

/// Batch shadow-ray queries against a `GpuBvh`, one thread per query (tests, and callers that want
/// exact GPU visibility of arbitrary segments).
pub struct OccludedPass {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group_layout: wgpu::BindGroupLayout,
}

impl OccludedPass {
    pub fn new(device: &wgpu::Device) -> OccludedPass {
        let (pipeline, bind_group_layout) = compute_pipeline(
            device,
            "OccludedPass",
            shaders::OCCLUDED,
            &[uniform(0), storage(1, true), storage(2, true), storage(3, true), storage(4, false)],
        );
        OccludedPass { pipeline, bind_group_layout }
    }

    /// Runs `queries` (split into dispatches within the ray budget, `gpu::dispatch::plan_rays`) and
    /// reads the results back.
    pub fn run(&self, ctx: &GpuContext, bvh: &GpuBvh, queries: &[OcclusionQuery]) -> Result<Vec<OcclusionResult>> {
        let device = &ctx.device;
        let mut out = Vec::with_capacity(queries.len());
        if queries.len() > u32::MAX as usize {
            return Err(Error::invalid(format!("{} shadow-ray queries in one batch: at most {}", queries.len(), u32::MAX)));
        }
        let plan = super::dispatch::plan_rays(queries.len() as u32, &super::dispatch::budget());
        for d in plan.into_iter().filter(|d| d.count > 0) {
            let chunk = &queries[d.first as usize..(d.first + d.count) as usize];
            let n = chunk.len() as u32;
            let (gx, gy, width) = dispatch_size(n);
            let params = storage_buffer(device, "OccludedPass::params", &[n, width, 0, 0], wgpu::BufferUsages::UNIFORM)?;
            let query_buf = storage_buffer(device, "OccludedPass::queries", chunk, wgpu::BufferUsages::STORAGE)?;
            let results = crate::gpu::alloc::buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some("OccludedPass::results"),
                    size: (n as u64 * 4).max(16),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            )?;
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("OccludedPass::encoder") });
            encode_dispatch(
                device,
                &mut encoder,
                "OccludedPass",
                (&self.pipeline, &self.bind_group_layout),
                &[
                    params.as_entire_binding(),
                    bvh.nodes.as_entire_binding(),
                    bvh.primitives.as_entire_binding(),
                    query_buf.as_entire_binding(),
                    results.as_entire_binding(),
                ],
                (gx, gy),
            );
            ctx.queue.submit(Some(encoder.finish()));
            let raw = ctx.read_buffer::<u32>(&results, 0, chunk.len())?;
            out.extend(raw.iter().map(|&r| OcclusionResult { occluded: r & 3 == 1, gave_up: r & 3 == 2, steps: r >> 2 }));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
