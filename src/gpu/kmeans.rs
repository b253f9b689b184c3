//! The K-means passes (`shaders/kmeans.wgsl`): grid over the centroids (count, prefix sum, fill),
//! assignment of the F nearest centroids (grid shells, then exhaustive chunks for points left unresolved),
//! fixed-point atomic reduction, centroid update and the Eq. 10 fuzzy weights. The algorithm and its
//! paper are documented in `crate::cluster::kmeans`; this file only owns pipelines, buffers and dispatches.
use super::GpuContext;
use crate::cluster::kmeans::{bounds, Quantiser};
use crate::error::{Error, Result};
use crate::gpu::pipeline::{storage, uniform};
use crate::gpu::shaders;
use std::sync::Arc;

/// Threads per workgroup (mirrored in `shaders/kmeans.wgsl`).
pub const WORKGROUP_SIZE: u32 = 256;
/// Centroids per exhaustive `assign_chunk` dispatch (mirrored as CHUNK in the WGSL).
pub const CHUNK: u32 = 2048;
/// Loop iterations `assign` may spend per point before leaving it to the exhaustive chunks (Mesa 22.3
/// cuts every shader invocation at 65,535 iterations).
pub const DEFAULT_BUDGET: u32 = 24_576;
/// Most grid cells (64^3): keeps each `grid_scan` thread's run at <= 1024 cells.
pub const MAX_GRID_CELLS: usize = 1 << 18;
/// Words per cluster in the sums buffer (count + 6 sums of two words), as SUM_WORDS in the WGSL.
pub const SUM_WORDS: usize = 13;

/// Uniforms. Keep in sync with `Params` in `shaders/kmeans.wgsl` (112 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuKMeansParams {
    pub grid_lo: [f32; 4],
    pub grid_dims: [u32; 4],
    pub quant_lo: [f32; 4],
    pub quant_extent: [f32; 4],
    pub n: u32,
    pub k: u32,
    pub f: u32,
    pub use_grid: u32,
    pub has_threshold: u32,
    pub cos_threshold: f32,
    pub chunk_start: u32,
    pub accumulate_sums: u32,
    pub budget: u32,
    pub max_shell: u32,
    pub slack: f32,
    /// First point (or centroid) of this dispatch (`gpu::dispatch::plan_kmeans`).
    pub first_item: u32,
}

/// A data point or centroid as the WGSL `Point` (32 bytes): position, normal.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPoint {
    pub p: [f32; 4],
    pub n: [f32; 4],
}

impl GpuPoint {
    pub fn new(p: [f32; 3], n: [f32; 3]) -> GpuPoint {
        GpuPoint { p: [p[0], p[1], p[2], 0.0], n: [n[0], n[1], n[2], 0.0] }
    }
}

/// The regular grid: origin, cubic cell size h and cells per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub lo: [f32; 3],
    pub h: f32,
    pub dims: [u32; 3],
}

impl Grid {
    /// About `target` cubic cells (at most [`MAX_GRID_CELLS`]) over the box [lo, hi]: the smallest h (by
    /// bisection) whose cell count stays within the target. With k centroids and target k, a cell holds
    /// about one centroid where they are spread evenly.
    pub fn new(lo: [f32; 3], hi: [f32; 3], target: usize) -> Grid {
        let target = target.clamp(1, MAX_GRID_CELLS) as f64;
        let e: Vec<f64> = (0..3).map(|a| (hi[a] - lo[a]).max(0.0) as f64).collect();
        let emax = e.iter().cloned().fold(0.0, f64::max);
        if emax <= 0.0 {
            return Grid { lo, h: 1.0, dims: [1, 1, 1] };
        }
        let cells = |h: f64| -> f64 { e.iter().map(|&x| (x / h).ceil().max(1.0)).product() };
        let (mut good, mut bad) = (emax, emax / target.max(2.0) / 2.0);
        for _ in 0..60 {
            let mid = (good * bad).sqrt();
            if cells(mid) <= target {
                good = mid;
            } else {
                bad = mid;
            }
        }
        let dims = [0, 1, 2].map(|a| (e[a] / good).ceil().max(1.0) as u32);
        Grid { lo, h: good as f32, dims }
    }

    pub fn num_cells(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kernel {
    GridCount = 0,
    GridScan,
    GridFill,
    Assign,
    AssignChunk,
    Accumulate,
    Update,
    FuzzyWeights,
}

const ENTRY_POINTS: [&str; 8] = ["grid_count", "grid_scan", "grid_fill", "assign", "assign_chunk", "accumulate", "update", "fuzzy_weights"];

/// The compute pipelines (one module, one bind group layout, built once per device).
pub struct KMeansPass {
    pipelines: Vec<wgpu::ComputePipeline>,
    bind_group_layout: wgpu::BindGroupLayout,
}

impl KMeansPass {
    pub fn new(device: &wgpu::Device) -> KMeansPass {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("KMeansPass::module"),
            source: wgpu::ShaderSource::Wgsl(shaders::KMEANS.into()),
        });
        let mut entries = vec![uniform(0), storage(1, true)];
        entries.extend((2..12).map(|b| storage(b, false)));
        let bind_group_layout = device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("KMeansPass::bind_group_layout"), entries: &entries });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("KMeansPass::pipeline_layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let pipelines = ENTRY_POINTS
            .iter()
            .map(|entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&format!("KMeansPass::{entry}")),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect();
        KMeansPass { pipelines, bind_group_layout }
    }

    /// The pass for `ctx`'s device, built on first use.
    pub fn shared(ctx: &GpuContext) -> Arc<KMeansPass> {
        crate::gpu::pipeline::shared_pass(&ctx.device, KMeansPass::new)
    }
}

/// Steps one item of `kernel` may take (`gpu::dispatch` module docs): `params.budget` per point for
/// `assign` (its worst case), the chunk's centroids times F for `assign_chunk`, 2 F for the weights.
fn kernel_cost(kernel: Kernel, params: &GpuKMeansParams) -> u64 {
    let f = params.f.max(1) as u64;
    match kernel {
        Kernel::Assign => params.budget.max(1) as u64,
        Kernel::AssignChunk => CHUNK.min(params.k.saturating_sub(params.chunk_start)).max(1) as u64 * f,
        Kernel::FuzzyWeights => 2 * f,
        _ => 1,
    }
}

/// Objective partials of `n` points: one per workgroup of the accumulate dispatches, whose ranges are
/// whole workgroups (but the last) in one row each, so they tile `ceil(n / 256)` slots.
pub fn num_partials(n: usize) -> usize {
    n.div_ceil(WORKGROUP_SIZE as usize).max(1)
}

/// Everything one K-means run or one fuzzy assignment keeps on the GPU.
pub struct KMeansBuffers {
    pass: Arc<KMeansPass>,
    pub params: GpuKMeansParams,
    pub points: wgpu::Buffer,
    pub centroids: wgpu::Buffer,
    cell_count: wgpu::Buffer,
    cell_start: wgpu::Buffer,
    cell_items: wgpu::Buffer,
    pub best_idx: wgpu::Buffer,
    pub best_d2: wgpu::Buffer,
    status: wgpu::Buffer,
    sums: wgpu::Buffer,
    partials: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    num_partials: usize,
}

fn storage_buffer(ctx: &GpuContext, label: &str, size: u64) -> Result<wgpu::Buffer> {
    super::alloc::buffer(
        &ctx.device,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
}

impl KMeansBuffers {
    /// Upload `points` (with unit or zero `normals`) and the initial `centroids`; `f` nearest per point;
    /// `cos_threshold` as Eq. 7. The grid spans the bounding box of points and centroids; the quantiser
    /// the points' box.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        points: &[[f32; 3]],
        normals: &[[f32; 3]],
        centroids: &[[f32; 3]],
        centroid_normals: &[[f32; 3]],
        f: usize,
        cos_threshold: Option<f32>,
        use_grid: bool,
    ) -> Result<KMeansBuffers> {
        let (n, k) = (points.len(), centroids.len());
        let max_binding = ctx.limits.max_storage_buffer_binding_size as u64;
        for (what, bytes) in [("points", n as u64 * 32), ("nearest-centroid lists", (n * f) as u64 * 4), ("centroids", k as u64 * 32)] {
            if bytes > max_binding {
                return Err(Error::OutOfMemory(format!(
                    "kmeans: the {what} take {bytes} bytes, more than the GPU's storage binding limit of {max_binding} bytes"
                )));
            }
        }
        let (plo, phi) = bounds(points);
        let (clo, chi) = bounds(centroids);
        let lo = [0, 1, 2].map(|a| plo[a].min(clo[a]));
        let hi = [0, 1, 2].map(|a| phi[a].max(chi[a]));
        let grid = Grid::new(lo, hi, k);
        let quant = Quantiser::of(points);
        let max_abs = lo.iter().chain(hi.iter()).fold(0.0f32, |m, v| m.max(v.abs()));
        let params = GpuKMeansParams {
            grid_lo: [grid.lo[0], grid.lo[1], grid.lo[2], grid.h],
            grid_dims: [grid.dims[0], grid.dims[1], grid.dims[2], grid.num_cells() as u32],
            quant_lo: [quant.lo[0], quant.lo[1], quant.lo[2], 0.0],
            quant_extent: [quant.extent[0], quant.extent[1], quant.extent[2], 0.0],
            n: n as u32,
            k: k as u32,
            f: f as u32,
            use_grid: use_grid as u32,
            has_threshold: cos_threshold.is_some() as u32,
            cos_threshold: cos_threshold.unwrap_or(-2.0),
            chunk_start: 0,
            accumulate_sums: 0,
            budget: DEFAULT_BUDGET,
            max_shell: *grid.dims.iter().max().unwrap_or(&1),
            slack: 1e-4 * grid.h + 8.0 * max_abs * f32::EPSILON,
            first_item: 0,
        };
        let upload = |label: &str, data: Vec<GpuPoint>| {
            super::alloc::buffer_init(
                &ctx.device,
                label,
                bytemuck::cast_slice(&data),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            )
        };
        let pts = upload("KMeansPass::points", points.iter().zip(normals).map(|(p, q)| GpuPoint::new(*p, *q)).collect())?;
        let cts = upload("KMeansPass::centroids", centroids.iter().zip(centroid_normals).map(|(p, q)| GpuPoint::new(*p, *q)).collect())?;
        // One objective partial per workgroup of the accumulate dispatches (`num_partials`).
        let groups = num_partials(n);
        Ok(KMeansBuffers {
            pass: KMeansPass::shared(ctx),
            params,
            points: pts,
            centroids: cts,
            cell_count: storage_buffer(ctx, "KMeansPass::cell_count", grid.num_cells() as u64 * 4)?,
            cell_start: storage_buffer(ctx, "KMeansPass::cell_start", (grid.num_cells() as u64 + 1) * 4)?,
            cell_items: storage_buffer(ctx, "KMeansPass::cell_items", k as u64 * 4)?,
            best_idx: storage_buffer(ctx, "KMeansPass::best_idx", (n * f) as u64 * 4)?,
            best_d2: storage_buffer(ctx, "KMeansPass::best_d2", (n * f) as u64 * 4)?,
            status: storage_buffer(ctx, "KMeansPass::status", n as u64 * 4)?,
            sums: storage_buffer(ctx, "KMeansPass::sums", (k * SUM_WORDS) as u64 * 4)?,
            partials: storage_buffer(ctx, "KMeansPass::partials", groups as u64 * 4)?,
            weights: storage_buffer(ctx, "KMeansPass::weights", (n * f) as u64 * 4)?,
            num_partials: groups,
        })
    }

    /// `kernel` over `items` points or centroids, split into dispatches within the K-means work budget
    /// (`gpu::dispatch::plan_kmeans`); each item is one invocation of one dispatch whatever the split.
    fn dispatch(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        kernel: Kernel,
        params: &GpuKMeansParams,
        items: usize,
    ) -> Result<()> {
        let budget = super::dispatch::budget();
        for d in super::dispatch::plan_kmeans(items as u32, kernel_cost(kernel, params), &budget) {
            let p = GpuKMeansParams { first_item: d.first, ..*params };
            self.dispatch_range(ctx, enc, kernel, &p, d.count)?;
        }
        Ok(())
    }

    /// One dispatch of `kernel` over `count` items from `params.first_item` (one row of workgroups).
    fn dispatch_range(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        kernel: Kernel,
        params: &GpuKMeansParams,
        count: u32,
    ) -> Result<()> {
        let params_buf =
            super::alloc::buffer_init(&ctx.device, "KMeansPass::params", bytemuck::bytes_of(params), wgpu::BufferUsages::UNIFORM)?;
        let resources = [
            &params_buf,
            &self.points,
            &self.centroids,
            &self.cell_count,
            &self.cell_start,
            &self.cell_items,
            &self.best_idx,
            &self.best_d2,
            &self.status,
            &self.sums,
            &self.partials,
            &self.weights,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .iter()
            .enumerate()
            .map(|(b, buf)| wgpu::BindGroupEntry { binding: b as u32, resource: buf.as_entire_binding() })
            .collect();
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("KMeansPass::bind_group"),
            layout: &self.pass.bind_group_layout,
            entries: &entries,
        });
        let gx = count.div_ceil(WORKGROUP_SIZE).max(1);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(&format!("KMeansPass::{}", ENTRY_POINTS[kernel as usize])),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pass.pipelines[kernel as usize]);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(gx, 1, 1);
        Ok(())
    }

    /// Alg. 1 line 5: rebuild the grid over the current centroids.
    fn encode_grid(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder) -> Result<()> {
        let k = self.params.k as usize;
        enc.clear_buffer(&self.cell_count, 0, None);
        self.dispatch(ctx, enc, Kernel::GridCount, &self.params, k)?;
        self.dispatch(ctx, enc, Kernel::GridScan, &self.params, 1)?;
        enc.clear_buffer(&self.cell_count, 0, None);
        self.dispatch(ctx, enc, Kernel::GridFill, &self.params, k)?;
        Ok(())
    }

    /// The F nearest centroids of every point into `best_idx` / `best_d2` (grid shells, then exhaustive
    /// chunks for the points the grid left unresolved; all points when the grid is off).
    pub fn encode_assign(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder) -> Result<()> {
        let n = self.params.n as usize;
        if self.params.use_grid != 0 {
            self.encode_grid(ctx, enc)?;
            self.dispatch(ctx, enc, Kernel::Assign, &self.params, n)?;
        }
        for chunk_start in (0..self.params.k).step_by(CHUNK as usize) {
            let p = GpuKMeansParams { chunk_start, ..self.params };
            self.dispatch(ctx, enc, Kernel::AssignChunk, &p, n)?;
        }
        Ok(())
    }

    /// Objective partials of the current assignment, plus the cluster sums when `sums` (F must be 1).
    pub fn encode_accumulate(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, sums: bool) -> Result<()> {
        enc.clear_buffer(&self.sums, 0, None);
        let p = GpuKMeansParams { accumulate_sums: sums as u32, ..self.params };
        self.dispatch(ctx, enc, Kernel::Accumulate, &p, self.params.n as usize)?;
        Ok(())
    }

    /// Centroids from the sums of the last `encode_accumulate(.., true)`.
    pub fn encode_update(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder) -> Result<()> {
        self.dispatch(ctx, enc, Kernel::Update, &self.params, self.params.k as usize)?;
        Ok(())
    }

    /// Eq. 10 weights of the current F-nearest lists into `weights`.
    pub fn encode_weights(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder) -> Result<()> {
        self.dispatch(ctx, enc, Kernel::FuzzyWeights, &self.params, self.params.n as usize)?;
        Ok(())
    }

    /// The objective of the last `encode_accumulate`: the per-workgroup partials added in f64.
    pub fn read_objective(&self, ctx: &GpuContext) -> Result<f64> {
        let partials: Vec<f32> = ctx.read_buffer(&self.partials, 0, self.num_partials)?;
        Ok(partials.iter().map(|&v| v as f64).sum())
    }

    /// Centroid positions and normals.
    pub fn read_centroids(&self, ctx: &GpuContext) -> Result<(Vec<[f32; 3]>, Vec<[f32; 3]>)> {
        let c: Vec<GpuPoint> = ctx.read_buffer(&self.centroids, 0, self.params.k as usize)?;
        Ok((c.iter().map(|q| [q.p[0], q.p[1], q.p[2]]).collect(), c.iter().map(|q| [q.n[0], q.n[1], q.n[2]]).collect()))
    }

    /// The F-nearest lists: (index | inadmissible bit, squared distance) per point and slot.
    pub fn read_lists(&self, ctx: &GpuContext) -> Result<(Vec<u32>, Vec<f32>)> {
        let len = (self.params.n * self.params.f) as usize;
        Ok((ctx.read_buffer(&self.best_idx, 0, len)?, ctx.read_buffer(&self.best_d2, 0, len)?))
    }
}

#[cfg(test)]
mod tests;
