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
