use super::*;

#[test]
fn creates_a_device_and_reads_back() {
    let ctx = GpuContext::new().expect("a GPU adapter (software is fine) must exist in tests");
    assert!(!ctx.summary.name.is_empty());
    let data: Vec<u32> = (0..1000).collect();
    let buf = wgpu::util::DeviceExt::create_buffer_init(
        &ctx.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("test"),
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        },
    );
    let back: Vec<u32> = ctx.read_buffer(&buf, 0, 1000).unwrap();
    assert_eq!(back, data);
}

#[test]
fn a_lost_device_is_recreated_on_next_use() {
    let a = GpuContext::shared().unwrap();
    assert!(!a.is_lost());
    assert!(Arc::ptr_eq(&a, &GpuContext::shared().unwrap()));
    a.mark_lost();
    let b = GpuContext::shared().unwrap();
    assert!(!Arc::ptr_eq(&a, &b), "a lost device must not be handed out again");
    assert!(!b.is_lost() && a.is_lost());
    // Told apart by the passes' caches (one wgpu instance numbers every device).
    assert!(a.device != b.device);
    // The new device works.
    let buf = crate::gpu::alloc::buffer_init(&b.device, "test", bytemuck::cast_slice(&[7u32, 8, 9]), wgpu::BufferUsages::COPY_SRC).unwrap();
    assert_eq!(b.read_buffer::<u32>(&buf, 0, 3).unwrap(), [7, 8, 9]);
}

#[test]
fn software_and_gl_adapters_rank_below_hardware() {
    let template = GpuContext::shared().unwrap().adapter.get_info();
    let info = |name: &str, device_type, backend| wgpu::AdapterInfo { name: name.into(), device_type, backend, ..template.clone() };
    use wgpu::{Backend as B, DeviceType as T};
    let mut all = [
        info("llvmpipe (LLVM 15.0.6, 256 bits)", T::Other, B::Gl),
        info("some GL driver", T::Other, B::Gl),
        info("lavapipe", T::Cpu, B::Vulkan),
        info("A Vulkan iGPU", T::IntegratedGpu, B::Vulkan),
        info("A Vulkan dGPU", T::DiscreteGpu, B::Vulkan),
        info("Unknown Vulkan", T::Other, B::Vulkan),
    ];
    all.sort_by_key(rank);
    let order: Vec<&str> = all.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(
        order,
        ["A Vulkan dGPU", "A Vulkan iGPU", "Unknown Vulkan", "some GL driver", "lavapipe", "llvmpipe (LLVM 15.0.6, 256 bits)"]
    );
}

/// Every pass's pipeline, built on `device` inside a validation scope: the passes that failed.
fn passes_that_fail(device: &wgpu::Device) -> Vec<&'static str> {
    let mut failed = Vec::new();
    let mut build = |name: &'static str, f: &dyn Fn()| {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        f();
        if pollster::block_on(scope.pop()).is_some() {
            failed.push(name);
        }
    };
    build("BsdfEvalPass", &|| drop(crate::gpu::bsdf_eval::BsdfEvalPass::new(device)));
    build("ClusteredVisibilityPass", &|| drop(crate::gpu::clustered_visibility::ClusteredVisibilityPass::new(device)));
    build("ColumnsPass", &|| drop(crate::gpu::columns::ColumnsPass::new(device)));
    build("GBufferPass", &|| drop(crate::gpu::gbuffer::GBufferPass::new(device)));
    build("KMeansPass", &|| drop(crate::gpu::kmeans::KMeansPass::new(device)));
    build("MappingPass", &|| drop(crate::gpu::mapping::MappingPass::new(device)));
    build("OccludedPass", &|| drop(crate::gpu::bvh::OccludedPass::new(device)));
    build("ReconstructionPass", &|| drop(crate::gpu::reconstruction::ReconstructionPass::new(device)));
    build("RelightPasses", &|| drop(crate::gpu::relight::RelightPasses::new(device)));
    build("RowsPass", &|| drop(crate::gpu::rows::RowsPass::new(device)));
    build("ShadowMapPass", &|| drop(crate::gpu::shadow::ShadowMapPass::new(device)));
    failed
}

#[test]
fn every_pass_builds_or_is_refused_under_lowered_limits() {
    let full = GpuContext::with_limits(None).unwrap();
    assert_eq!(full.unmet, Vec::<String>::new(), "this adapter runs every pass");
    assert_eq!(passes_that_fail(&full.device), Vec::<&str>::new());
    for spec in ["default", "downlevel", "max_storage_buffers_per_shader_stage=8"] {
        let ctx = GpuContext::with_limits(Some(spec)).unwrap();
        // The device got no more than the override allows ...
        let lower = crate::gpu::needs::apply_override(full.adapter.limits(), Some(spec)).unwrap();
        assert!(ctx.device.limits().max_storage_buffers_per_shader_stage <= lower.max_storage_buffers_per_shader_stage);
        // ... and the passes it refuses are exactly those whose pipelines fail on it.
        let mut refused: Vec<&str> = crate::gpu::needs::PASSES
            .iter()
            .filter(|p| ctx.unmet.iter().any(|m| m.starts_with(&format!("{} needs", p.pass))))
            .map(|p| p.pass)
            .collect();
        refused.sort();
        assert_eq!(refused, passes_that_fail(&ctx.device), "{spec}: {:?}", ctx.unmet);
        assert!(!refused.is_empty(), "{spec}: nothing refused");
        let err = ctx.check_needs().unwrap_err().to_string();
        assert!(err.contains("ColumnsPass needs max_storage_buffers_per_shader_stage"), "{err}");
    }
}

#[test]
fn a_pipeline_the_device_refuses_outside_any_scope_is_an_error_at_the_next_wait_not_a_panic() {
    // 8 storage buffers per stage: the columns pass (13) cannot be built on this device.
    let ctx = GpuContext::with_limits(Some("max_storage_buffers_per_shader_stage=8")).unwrap();
    ctx.wait().unwrap();
    drop(crate::gpu::columns::ColumnsPass::new(&ctx.device)); // wgpu's default handler would panic here
    let err = ctx.wait().unwrap_err().to_string();
    assert!(err.contains("outside a guarded call") && err.contains("ColumnsPass"), "{err}");
    ctx.wait().expect("the errors are reported once");
    // The device still works for what it can do.
    let buf = crate::gpu::alloc::buffer_init(&ctx.device, "test", bytemuck::cast_slice(&[1u32, 2]), wgpu::BufferUsages::COPY_SRC).unwrap();
    assert_eq!(ctx.read_buffer::<u32>(&buf, 0, 2).unwrap(), [1, 2]);
}

#[test]
fn no_device_is_created_where_the_address_space_limit_leaves_less_than_a_driver_reserves() {
    assert!(check_driver_room(None).is_ok());
    assert!(check_driver_room(Some(DRIVER_ADDRESS_SPACE)).is_ok());
    match check_driver_room(Some(DRIVER_ADDRESS_SPACE - 1)) {
        Err(Error::GpuUnavailable(m)) => assert!(m.contains("ulimit -v") && m.contains("2.15 GB"), "{m}"),
        other => panic!("expected GpuUnavailable, got {other:?}"),
    }
}
