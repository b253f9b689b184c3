use super::*;
use crate::gpu::shaders;

const SOURCES: &[(&str, &str)] = &[
    ("BsdfEvalPass", shaders::BSDF_EVAL),
    ("ClusteredVisibilityPass", shaders::CLUSTERED_VISIBILITY),
    ("ColumnsPass", shaders::COLUMNS),
    ("GBufferPass", shaders::GBUFFER),
    ("KMeansPass", shaders::KMEANS),
    ("MappingPass", shaders::MAPPING),
    ("OccludedPass", shaders::OCCLUDED),
    ("ReconstructionPass", shaders::RECONSTRUCTION),
    ("RelightPasses", shaders::RELIGHT),
    ("RowsPass", shaders::ROWS),
    ("ShadowMapPass", shaders::SHADOW),
];

/// A pass's needs read from its WGSL with naga: the module's resources (one layout for all its entry
/// points), or for `RelightPasses` (one layout per kernel) the most any one entry point uses.
fn derive(pass: &'static str, source: &str) -> PassNeeds {
    let module = shaders::validate_wgsl(pass, source).unwrap_or_else(|e| panic!("{e}"));
    if pass == "RelightPasses" {
        let info =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty()).validate(&module).unwrap();
        let mut best: Option<PassNeeds> = None;
        for (i, _) in module.entry_points.iter().enumerate() {
            let used = info.get_entry_point(i);
            let n = derive_module(pass, &module, &|h| !used[h].is_empty());
            best = Some(match best {
                Some(b) if (b.storage_buffers, b.bindings) >= (n.storage_buffers, n.bindings) => b,
                _ => n,
            });
        }
        return best.unwrap();
    }
    derive_module(pass, &module, &|_| true)
}

fn derive_module(pass: &'static str, module: &naga::Module, include: &dyn Fn(naga::Handle<naga::GlobalVariable>) -> bool) -> PassNeeds {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let mut n = PassNeeds {
        pass,
        storage_buffers: 0,
        uniform_buffers: 0,
        sampled_textures: 0,
        storage_textures: 0,
        bindings: 0,
        workgroup_size: [0; 3],
        workgroup_storage: 0,
    };
    for (_, g) in module.global_variables.iter().filter(|(h, _)| include(*h)) {
        match g.space {
            naga::AddressSpace::Storage { .. } => n.storage_buffers += 1,
            naga::AddressSpace::Uniform => n.uniform_buffers += 1,
            naga::AddressSpace::WorkGroup => n.workgroup_storage += layouter[g.ty].size,
            naga::AddressSpace::Handle => match module.types[g.ty].inner {
                naga::TypeInner::Image { class: naga::ImageClass::Storage { .. }, .. } => n.storage_textures += 1,
                naga::TypeInner::Image { .. } => n.sampled_textures += 1,
                _ => {}
            },
            _ => {}
        }
        if let Some(b) = &g.binding {
            assert_eq!(b.group, 0, "{pass}: every pass has one bind group");
            n.bindings = n.bindings.max(b.binding + 1);
        }
    }
    for ep in &module.entry_points {
        if ep.stage == naga::ShaderStage::Compute && ep.workgroup_size.iter().product::<u32>() > n.workgroup_size.iter().product::<u32>() {
            n.workgroup_size = ep.workgroup_size;
        }
    }
    n
}

#[test]
fn the_table_matches_every_pass_wgsl() {
    assert_eq!(SOURCES.len(), PASSES.len());

    for (&(pass, source), table) in SOURCES.iter().zip(PASSES) {
        assert_eq!(table.pass, pass);
        assert_eq!(derive(pass, source), *table, "PASSES entry of {pass} disagrees with its WGSL");
    }
}

#[test]
fn lowered_limits_name_the_pass_and_the_limit() {
    let adapter = wgpu::Limits::default().or_better_values_from(&wgpu::Limits {
        max_storage_buffers_per_shader_stage: 16,
        max_compute_workgroup_storage_size: 32768,
        ..wgpu::Limits::default()
    });
    assert_eq!(unmet(&adapter), Vec::<String>::new());
    let eight = apply_override(adapter.clone(), Some("max_storage_buffers_per_shader_stage=8")).unwrap();
    let msgs = unmet(&eight);
    // The passes with more than 8 storage buffers, and only those.
    let over: Vec<&str> = PASSES.iter().filter(|p| p.storage_buffers > 8).map(|p| p.pass).collect();
    assert_eq!(over, ["ClusteredVisibilityPass", "ColumnsPass", "KMeansPass", "RowsPass"]);
    assert_eq!(msgs.len(), over.len());
    assert_eq!(msgs[1], "ColumnsPass needs max_storage_buffers_per_shader_stage >= 13, the device allows 8");
    let down = apply_override(adapter.clone(), Some("downlevel")).unwrap();
    assert_eq!(down.max_storage_buffers_per_shader_stage, 4);
    let down_unmet = unmet(&down);
    let refused: Vec<&str> = down_unmet.iter().map(|m| m.split(' ').next().unwrap()).collect();
    assert_eq!(refused, ["ClusteredVisibilityPass", "ColumnsPass", "KMeansPass", "ReconstructionPass", "RelightPasses", "RowsPass"]);
    // An override never raises a limit.
    let raised = apply_override(eight.clone(), Some("max_storage_buffers_per_shader_stage=64")).unwrap();
    assert_eq!(raised.max_storage_buffers_per_shader_stage, 8);
    assert!(apply_override(adapter.clone(), Some("max_bogus=3")).unwrap_err().to_string().contains("unknown limit"));
    assert!(apply_override(adapter, Some("max_buffer_size=lots")).is_err());
}
