//! What each GPU pass needs of the device, checked against the adapter's limits when the device is
//! chosen (`GpuContext::new` records the unmet needs; `Device::choose` then falls back to the CPU for
//! `device="auto"`, with the reason in `device_info()["reason"]`, and `device="gpu"` raises
//! `GpuUnavailableError` naming the pass and the limit).
//!
//! `PASSES` is written out by hand (no WGSL is parsed at run time); a test derives every entry from the
//! pass's WGSL with naga (resources per shader stage in its one bind group, workgroup size and shared
//! memory) and fails when the two disagree.
//!
//! `MANYLIGHTS_GPU_LIMITS` lowers the adapter's limits, as if the adapter had no more: `default`
//! (`wgpu::Limits::default()`, WebGPU's guaranteed limits), `downlevel`
//! (`wgpu::Limits::downlevel_defaults()`), or a comma-separated list of `name=value` (names of
//! `LIMIT_NAMES`, e.g. `max_storage_buffers_per_shader_stage=8,max_buffer_size=64M`). It is a
//! diagnostic and test hook: it shows what a smaller GPU would do, on this one.
use crate::error::{Error, Result};

/// One pass's needs (per shader stage of its single bind group).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PassNeeds {
    /// The pass, as named in labels and errors (`"ColumnsPass"`).
    pub pass: &'static str,
    pub storage_buffers: u32,
    pub uniform_buffers: u32,
    pub sampled_textures: u32,
    pub storage_textures: u32,
    /// Highest binding index + 1.
    pub bindings: u32,
    /// The largest `@workgroup_size` of its compute entry points ([0, 0, 0] for render passes).
    pub workgroup_size: [u32; 3],
    /// Bytes of `var<workgroup>` memory.
    pub workgroup_storage: u32,
}

const fn needs(
    pass: &'static str,
    storage_buffers: u32,
    uniform_buffers: u32,
    sampled_textures: u32,
    bindings: u32,
    workgroup_size: [u32; 3],
    workgroup_storage: u32,
) -> PassNeeds {
    PassNeeds { pass, storage_buffers, uniform_buffers, sampled_textures, storage_textures: 0, bindings, workgroup_size, workgroup_storage }
}

/// Every pass (module docs).
pub const PASSES: &[PassNeeds] = &[
    needs("BsdfEvalPass", 4, 1, 0, 5, [64, 1, 1], 0),
    needs("ClusteredVisibilityPass", 13, 1, 0, 14, [64, 1, 1], 0),
    needs("ColumnsPass", 13, 1, 1, 15, [64, 1, 1], 0),
    needs("GBufferPass", 0, 2, 0, 2, [0, 0, 0], 0),
    needs("KMeansPass", 11, 1, 0, 12, [256, 1, 1], 2048),
    needs("MappingPass", 3, 1, 0, 4, [64, 1, 1], 0),
    needs("OccludedPass", 4, 1, 0, 5, [64, 1, 1], 0),
    needs("ReconstructionPass", 7, 1, 0, 8, [64, 1, 1], 0),
    // One layout per kernel: the largest kernel's.
    needs("RelightPasses", 7, 1, 0, 18, [64, 1, 1], 0),
    needs("RowsPass", 12, 1, 1, 14, [64, 1, 1], 12),
    needs("ShadowMapPass", 0, 1, 0, 1, [0, 0, 0], 0),
];

/// Every limit a pass need is checked against that `wgpu::Limits` names, as
/// (name, the pass's need, the device's limit).
fn checks(p: &PassNeeds, l: &wgpu::Limits) -> [(&'static str, u64, u64); 11] {
    let invocations = p.workgroup_size.iter().map(|&s| s.max(1) as u64).product::<u64>();
    [
        ("max_storage_buffers_per_shader_stage", p.storage_buffers as u64, l.max_storage_buffers_per_shader_stage as u64),
        ("max_uniform_buffers_per_shader_stage", p.uniform_buffers as u64, l.max_uniform_buffers_per_shader_stage as u64),
        ("max_sampled_textures_per_shader_stage", p.sampled_textures as u64, l.max_sampled_textures_per_shader_stage as u64),
        ("max_storage_textures_per_shader_stage", p.storage_textures as u64, l.max_storage_textures_per_shader_stage as u64),
        ("max_bindings_per_bind_group", p.bindings as u64, l.max_bindings_per_bind_group as u64),
        ("max_bind_groups", 1, l.max_bind_groups as u64),
        ("max_compute_workgroup_size_x", p.workgroup_size[0] as u64, l.max_compute_workgroup_size_x as u64),
        ("max_compute_workgroup_size_y", p.workgroup_size[1] as u64, l.max_compute_workgroup_size_y as u64),
        ("max_compute_workgroup_size_z", p.workgroup_size[2] as u64, l.max_compute_workgroup_size_z as u64),
        (
            "max_compute_invocations_per_workgroup",
            if p.workgroup_size[0] == 0 { 0 } else { invocations },
            l.max_compute_invocations_per_workgroup as u64,
        ),
        ("max_compute_workgroup_storage_size", p.workgroup_storage as u64, l.max_compute_workgroup_storage_size as u64),
    ]
}

/// The needs of every pass that `limits` do not meet, one sentence each naming the pass, the limit, the
/// need and the device's value; empty when every pass can run.
pub fn unmet(limits: &wgpu::Limits) -> Vec<String> {
    PASSES
        .iter()
        .flat_map(|p| {
            checks(p, limits)
                .into_iter()
                .filter(|&(_, need, have)| need > have)
                .map(move |(name, need, have)| format!("{} needs {name} >= {need}, the device allows {have}", p.pass))
        })
        .collect()
}

/// The environment variable of the limits override (module docs).
pub const LIMITS_ENV: &str = "MANYLIGHTS_GPU_LIMITS";

/// The limits `MANYLIGHTS_GPU_LIMITS=name=value` can set.
pub const LIMIT_NAMES: &[&str] = &[
    "max_storage_buffers_per_shader_stage",
    "max_uniform_buffers_per_shader_stage",
    "max_sampled_textures_per_shader_stage",
    "max_bindings_per_bind_group",
    "max_storage_buffer_binding_size",
    "max_buffer_size",
    "max_texture_dimension_2d",
    "max_texture_array_layers",
    "max_compute_workgroup_storage_size",
    "max_compute_invocations_per_workgroup",
    "max_compute_workgroup_size_x",
    "max_compute_workgroups_per_dimension",
];

/// `adapter` lowered by the override `spec` (module docs; None or empty: unchanged).
///
/// Errors: `InvalidParameter` naming an unknown limit or a value that is not a byte count.
pub fn apply_override(adapter: wgpu::Limits, spec: Option<&str>) -> Result<wgpu::Limits> {
    let spec = match spec.map(str::trim) {
        None | Some("") => return Ok(adapter),
        Some(s) => s,
    };
    let lower = match spec.to_ascii_lowercase().as_str() {
        "default" => wgpu::Limits::default(),
        "downlevel" => wgpu::Limits::downlevel_defaults(),
        _ => {
            let mut l = adapter.clone();
            for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
                let (name, value) = item
                    .split_once('=')
                    .ok_or_else(|| Error::invalid(format!("{LIMITS_ENV}: expected name=value, 'default' or 'downlevel', got {item:?}")))?;
                let v = crate::memory::parse_bytes(value)
                    .ok_or_else(|| Error::invalid(format!("{LIMITS_ENV}: {name} must be a number, got {value:?}")))?;
                let v32 = v.min(u32::MAX as u64) as u32;
                match name.trim() {
                    "max_storage_buffers_per_shader_stage" => l.max_storage_buffers_per_shader_stage = v32,
                    "max_uniform_buffers_per_shader_stage" => l.max_uniform_buffers_per_shader_stage = v32,
                    "max_sampled_textures_per_shader_stage" => l.max_sampled_textures_per_shader_stage = v32,
                    "max_bindings_per_bind_group" => l.max_bindings_per_bind_group = v32,
                    "max_storage_buffer_binding_size" => l.max_storage_buffer_binding_size = v,
                    "max_buffer_size" => l.max_buffer_size = v,
                    "max_texture_dimension_2d" => l.max_texture_dimension_2d = v32,
                    "max_texture_array_layers" => l.max_texture_array_layers = v32,
                    "max_compute_workgroup_storage_size" => l.max_compute_workgroup_storage_size = v32,
                    "max_compute_invocations_per_workgroup" => l.max_compute_invocations_per_workgroup = v32,
                    "max_compute_workgroup_size_x" => l.max_compute_workgroup_size_x = v32,
                    "max_compute_workgroups_per_dimension" => l.max_compute_workgroups_per_dimension = v32,
                    other => {
                        return Err(Error::invalid(format!("{LIMITS_ENV}: unknown limit {other:?}; known: {}", LIMIT_NAMES.join(", "))))
                    }
                }
            }
            l
        }
    };
    Ok(adapter.or_worse_values_from(&lower))
}

#[cfg(test)]
mod tests;
