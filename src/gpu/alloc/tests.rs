use super::*;

#[test]
fn requests_over_the_limits_are_refused_before_allocating() {
    let limits = wgpu::Limits { max_buffer_size: 1 << 30, max_storage_buffer_binding_size: 1 << 27, ..wgpu::Limits::default() };
    let e = check_buffer(&limits, "ViewBuffers::samples", 3 << 29, false).unwrap_err();
    assert!(matches!(e, Error::OutOfMemory(_)));
    assert_eq!(
        e.to_string(),
        "ViewBuffers::samples needs a GPU buffer of 1610612736 bytes (1.61 GB), above the adapter's max_buffer_size of 1073741824 bytes"
    );
    let e = check_buffer(&limits, "KMeansPass::points", (1 << 27) + 4, true).unwrap_err();
    assert!(e.to_string().contains("above the adapter's max_storage_buffer_binding_size of 134217728 bytes"), "{e}");
    // Bound in ranges: only max_buffer_size applies.
    check_buffer(&limits, "LightMatrix::rows_out", 1 << 29, false).unwrap();
}

#[test]
fn a_refused_request_leaves_the_device_working() {
    let ctx = crate::testing::gpu_context();
    let max = ctx.device.limits().max_storage_buffer_binding_size;
    let desc = wgpu::BufferDescriptor {
        label: Some("test::too_big"),
        size: max + 256,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    };
    let e = buffer(&ctx.device, &desc).unwrap_err();
    assert!(matches!(&e, Error::OutOfMemory(m) if m.starts_with("test::too_big needs a storage binding of")), "{e}");
    // A texture past the dimension limit.
    let dim = ctx.device.limits().max_texture_dimension_2d + 1;
    let e = texture(
        &ctx.device,
        &wgpu::TextureDescriptor {
            label: Some("test::wide"),
            size: wgpu::Extent3d { width: dim, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("above the adapter's max_texture_dimension_2d"), "{e}");
    // A validation error inside the scope (a mapped MAP_READ | STORAGE buffer is not allowed) comes back
    // as an error, not a panic.
    let bad = wgpu::BufferDescriptor {
        label: Some("test::invalid_usage"),
        size: 64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::MAP_WRITE,
        mapped_at_creation: false,
    };
    let e = buffer(&ctx.device, &bad).unwrap_err();
    assert!(matches!(&e, Error::Gpu(m) if m.contains("test::invalid_usage")), "{e}");
    // The device still allocates and reads back.
    let data: Vec<u32> = (0..100).collect();
    let ok = buffer_init(&ctx.device, "test::ok", bytemuck::cast_slice(&data), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC)
        .unwrap();
    assert_eq!(ok.size(), 400);
    assert_eq!(ctx.read_buffer::<u32>(&ok, 0, 100).unwrap(), data);
    // Odd lengths are padded to 4 bytes, as wgpu's create_buffer_init does.
    assert_eq!(buffer_init(&ctx.device, "test::odd", &[1, 2, 3], wgpu::BufferUsages::COPY_SRC).unwrap().size(), 4);
}

#[test]
fn texture_bytes_counts_layers() {
    let desc = wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: 1024, height: 1024, depth_or_array_layers: 64 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    };
    assert_eq!(texture_bytes(&desc), 256 << 20);
}
