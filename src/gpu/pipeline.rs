//! Bind-group-layout entries and compute-pipeline creation shared by the compute passes (one bind group,
//! entry point `main`, labels `"<Pass>::<object>"`), and the per-device cache of built passes.

use std::any::{Any, TypeId};
use std::sync::{Arc, Mutex};

/// The pass of type `T` for `device`: built by `build` on first use, then shared by every light matrix on
/// that device. Compiling the shadow-map and column passes took ~2 s per `LightMatrix` on Mesa's software
/// driver before; a pass holds only its pipeline and layout, so sharing it changes no result.
pub fn shared_pass<T: Send + Sync + 'static>(device: &wgpu::Device, build: impl FnOnce(&wgpu::Device) -> T) -> Arc<T> {
    type Entry = (TypeId, wgpu::Device, Arc<dyn Any + Send + Sync>);
    static CACHE: Mutex<Vec<Entry>> = Mutex::new(Vec::new());
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let hit = cache.iter().find(|(t, d, _)| *t == TypeId::of::<T>() && d == device).map(|(_, _, p)| p.clone());
    if let Some(pass) = hit.and_then(|p| p.downcast::<T>().ok()) {
        return pass;
    }
    let pass = Arc::new(build(device));
    cache.push((TypeId::of::<T>(), device.clone(), pass.clone()));
    pass
}

/// A uniform buffer at `binding`, visible to compute.
pub fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, wgpu::BufferBindingType::Uniform)
}

/// A storage buffer at `binding`, visible to compute.
pub fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, wgpu::BufferBindingType::Storage { read_only })
}

/// A depth 2D-array texture (shadow maps) at `binding`, read with `textureLoad`.
pub fn depth_array(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

fn buffer_entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// Compile `wgsl` and build a compute pipeline with one bind group of `entries`, entry point `main`.
/// `owner` names the pass in the labels (`"ColumnsPass::pipeline"`).
pub fn compute_pipeline(
    device: &wgpu::Device,
    owner: &str,
    wgsl: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(&format!("{owner}::module")),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let bind_group_layout =
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(&format!("{owner}::bind_group_layout")), entries });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(&format!("{owner}::pipeline_layout")),
        bind_group_layouts: &[Some(&bind_group_layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(&format!("{owner}::pipeline")),
        layout: Some(&layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    (pipeline, bind_group_layout)
}

/// Bind `resources` (binding k = `resources[k]`) to `layout` and record one dispatch of `pipeline` with
/// `groups` = (x, y) workgroups into `encoder`; `owner` names the pass in the labels.
pub fn encode_dispatch(
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
    owner: &str,
    (pipeline, layout): (&wgpu::ComputePipeline, &wgpu::BindGroupLayout),
    resources: &[wgpu::BindingResource],
    groups: (u32, u32),
) {
    let entries: Vec<wgpu::BindGroupEntry> =
        resources.iter().enumerate().map(|(k, resource)| wgpu::BindGroupEntry { binding: k as u32, resource: resource.clone() }).collect();
    let bind_group =
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(&format!("{owner}::bind_group")), layout, entries: &entries });
    let mut pass =
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&format!("{owner}::dispatch")), timestamp_writes: None });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &bind_group, &[]);
    pass.dispatch_workgroups(groups.0, groups.1, 1);
}

#[cfg(test)]
mod tests;
