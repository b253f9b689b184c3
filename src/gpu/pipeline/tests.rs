use super::*;
use crate::gpu::context::GpuContext;

#[test]
fn a_pass_is_built_once_per_device_and_type() {
    let a = GpuContext::new().unwrap();
    let b = GpuContext::new().unwrap();
    let mut builds = 0;
    let p1 = shared_pass(&a.device, |_| {
        builds += 1;
        7u64
    });
    let p2 = shared_pass(&a.device, |_| -> u64 { unreachable!("built twice for one device") });
    assert!(Arc::ptr_eq(&p1, &p2));
    assert_eq!(builds, 1);
    // Another device, or another type on the same device: a pass of its own.
    let p3 = shared_pass(&b.device, |_| 8u64);
    assert!(!Arc::ptr_eq(&p1, &p3));
    assert_eq!((*p1, *p3), (7, 8));
    let p4 = shared_pass(&a.device, |_| 9u32);
    assert_eq!(*p4, 9);
    assert_eq!(*shared_pass(&a.device, |_| -> u64 { unreachable!() }), 7);
}
