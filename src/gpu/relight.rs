//! The relighting kernels (`shaders/relight.wgsl`) of direct-to-indirect transfer on the GPU (Hašan,
//! Pellacini, Bala, SIGGRAPH 2006, Sec. 3.3, 3.5, 5): the 2D Haar transform level by level, on-the-fly
//! culling of wavelet lights, sparse products over CSR rows (one value per coefficient, or RGB for the
//! photon-mapped M), the multi-bounce update and the final combination with direct light (and the glossy
//! final gather's product). `crate::relight::gpu` drives them; the direct light comes from the
//! column pass (`gpu::columns`).
//!
//! Sparse products, per-row gathers rather than the paper's image-based scatter: the paper draws one quad
//! per block of each wavelet light's image and lets the blending hardware add them (Sec. 4.4, 5); a
//! compute version of that scatter needs float atomics (not in WGSL) or a float-blendable render target
//! (`FLOAT32_BLENDABLE`, missing on GL), and its summation order varies from run to run. One thread per
//! row that walks the row's sorted coefficients needs neither, reads each row contiguously, writes each
//! output once and adds in the CPU's order (`relight::relight`), so both devices give the same sums up to
//! rounding. On-the-fly culling zeroes the culled lights' coefficients (`cull`), which keeps the result of
//! the image-based form; it does not skip their work as the scatter would.
use crate::gpu::columns::dispatch_size;
use crate::gpu::pipeline::{storage, uniform};
use crate::gpu::shaders;

/// Most coefficients of one row that one invocation of `product` sums (the host splits longer rows over
/// dispatches): far below Mesa 22.3's 65,535 loop iterations per invocation.
pub const ROW_CHUNK: u32 = 8192;

/// Keep in sync with `struct RelightParams` in `shaders/relight.wgsl` (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RelightParams {
    pub side: u32,
    pub size: u32,
    pub num_rows: u32,
    pub row_offset: u32,
    pub first: u32,
    pub count: u32,
    pub dispatch_width: u32,
    pub epsilon: f32,
}

/// One kernel: its pipeline, bind group layout and the bindings it uses (in layout order).
pub struct Kernel {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bindings: Vec<u32>,
    name: &'static str,
}

/// The compiled kernels.
pub struct RelightPasses {
    pub haar_level: Kernel,
    pub cull: Kernel,
    pub product: Kernel,
    pub product_rgb: Kernel,
    pub finish_bounce: Kernel,
    pub combine: Kernel,
    pub combine_glossy: Kernel,
}

/// Storage bindings that kernels write (`read_write` in the WGSL).
const WRITABLE: [u32; 7] = [2, 3, 5, 6, 10, 12, 15];

fn kernel(device: &wgpu::Device, module: &wgpu::ShaderModule, name: &'static str, bindings: &[u32]) -> Kernel {
    let entries: Vec<wgpu::BindGroupLayoutEntry> =
        bindings.iter().map(|&b| if b == 0 { uniform(0) } else { storage(b, !WRITABLE.contains(&b)) }).collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("RelightPasses::{name}::bind_group_layout")),
        entries: &entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(&format!("RelightPasses::{name}::pipeline_layout")),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(&format!("RelightPasses::{name}::pipeline")),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(name),
        compilation_options: Default::default(),
        cache: None,
    });
    Kernel { pipeline, layout, bindings: bindings.to_vec(), name }
}

impl Kernel {
    /// Record one dispatch of `threads` threads with `params` and `buffers` (one per binding of the
    /// kernel after the uniform, in order).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        params: &RelightParams,
        threads: u32,
        buffers: &[&wgpu::Buffer],
    ) -> crate::error::Result<()> {
        assert_eq!(buffers.len() + 1, self.bindings.len(), "RelightPasses::{}: wrong number of buffers", self.name);
        let (gx, gy, dispatch_width) = dispatch_size(threads);
        let params = RelightParams { dispatch_width, ..*params };
        let params_buf = crate::gpu::columns::storage_buffer(device, "RelightPasses::params", &[params], wgpu::BufferUsages::UNIFORM)?;
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: params_buf.as_entire_binding() }];
        for (b, buf) in self.bindings[1..].iter().zip(buffers) {
            entries.push(wgpu::BindGroupEntry { binding: *b, resource: buf.as_entire_binding() });
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&format!("RelightPasses::{}::bind_group", self.name)),
            layout: &self.layout,
            entries: &entries,
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(&format!("RelightPasses::{}::dispatch", self.name)),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
        Ok(())
    }
}

impl RelightPasses {
    pub fn new(device: &wgpu::Device) -> RelightPasses {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("RelightPasses::module"),
            source: wgpu::ShaderSource::Wgsl(shaders::RELIGHT.into()),
        });
        RelightPasses {
            // src, dst, coeffs
            haar_level: kernel(device, &module, "haar_level", &[0, 1, 2, 3]),
            // coeffs, norms, wavelet_lights, counters
            cull: kernel(device, &module, "cull", &[0, 3, 4, 5, 6]),
            // wavelet_lights, row_start, row_index, row_value, partial
            product: kernel(device, &module, "product", &[0, 5, 7, 8, 9, 10]),
            // the same with three values per coefficient
            product_rgb: kernel(device, &module, "product_rgb", &[0, 5, 7, 8, 9, 10]),
            // dst, partial, albedo, total
            finish_bounce: kernel(device, &module, "finish_bounce", &[0, 2, 10, 11, 12]),
            // partial, albedo, direct, extra_start, image
            combine: kernel(device, &module, "combine", &[0, 10, 11, 13, 14, 15]),
            // the same plus partial_glossy, glossy_color
            combine_glossy: kernel(device, &module, "combine_glossy", &[0, 10, 11, 13, 14, 15, 16, 17]),
        }
    }

    /// Record the forward Haar transform of the `side` x `side` RGBA image `image` into `coeffs`
    /// (`haar::forward`'s layout and arithmetic), ping-ponging the averages through `scratch`. `side` >= 2.
    pub fn encode_haar(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        side: u32,
        image: &wgpu::Buffer,
        scratch: [&wgpu::Buffer; 2],
        coeffs: &wgpu::Buffer,
    ) -> crate::error::Result<()> {
        let mut size = side;
        let mut level = 0;
        while size > 1 {
            let src = if level == 0 { image } else { scratch[(level + 1) % 2] };
            let dst = scratch[level % 2];
            let h = size / 2;
            self.haar_level.encode(
                device,
                encoder,
                &RelightParams { side, size, num_rows: h * h, ..Default::default() },
                h * h,
                &[src, dst, coeffs],
            )?;
            size = h;
            level += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
