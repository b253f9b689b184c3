//! `reflecting_side` against hand-made records.
use super::*;
use crate::shading::bsdf::KIND_DIFFUSE;

/// `reflecting_side` of blends: the side both BSDFs share, the other one's where one reflects
/// nothing, none where they differ or one may transmit.
#[test]
fn reflecting_side_of_blends() {
    let rec = |kind: u32, flags: u32| GpuBsdf { kind, flags, ..bytemuck::Zeroable::zeroed() };
    let blend = |a: GpuBsdf, b: GpuBsdf| {
        let mut a = a;
        a.flags |= FLAG_BLEND;
        a.extra[3] = f32::from_bits(1);
        vec![a, b]
    };
    let (up, down) = (Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.0, 0.6, -0.8));
    let d1 = rec(KIND_DIFFUSE, 0);
    let d2 = rec(KIND_DIFFUSE, FLAG_TWOSIDED);
    assert_eq!(reflecting_side(&[d1], 0, up), Some(1.0));
    assert_eq!(reflecting_side(&[d1], 0, down), Some(0.0));
    assert_eq!(reflecting_side(&[d2], 0, down), Some(-1.0));
    assert_eq!(reflecting_side(&blend(d2, d2), 0, down), Some(-1.0));
    assert_eq!(reflecting_side(&blend(d1, d2), 0, down), Some(-1.0));
    assert_eq!(reflecting_side(&blend(d1, d1), 0, down), Some(0.0));
    assert_eq!(reflecting_side(&blend(d2, rec(KIND_ROUGHDIELECTRIC, 0)), 0, up), None);
}
