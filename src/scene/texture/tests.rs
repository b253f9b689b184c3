mod mitsuba;

use super::*;
use glam::Mat3;

fn bitmap(w: u32, h: u32, data: Vec<Vec3>, filter: FilterType, wrap: WrapMode) -> Texture {
    Texture::Bitmap { width: w, height: h, data, filter, wrap, to_uv: Mat3::IDENTITY, loc: Location::default() }
}

#[test]
fn wrap_modes_match_drjit() {
    let r: Vec<usize> = (-5..9).map(|i| wrap(i, 4, WrapMode::Repeat)).collect();
    assert_eq!(r, vec![3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]);
    let m: Vec<usize> = (-5..9).map(|i| wrap(i, 4, WrapMode::Mirror)).collect();
    assert_eq!(m, vec![3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
    let c: Vec<usize> = (-2..6).map(|i| wrap(i, 4, WrapMode::Clamp)).collect();
    assert_eq!(c, vec![0, 0, 0, 1, 2, 3, 3, 3]);
}

#[test]
fn bilinear_texel_centres_and_rows() {
    // 2x2: row 0 (top) = (0, 1), row 1 = (2, 3) in the red channel.
    let data = (0..4).map(|i| Vec3::splat(i as f32)).collect();
    let t = bitmap(2, 2, data, FilterType::Bilinear, WrapMode::Clamp);
    assert_eq!(eval(&t, Vec2::new(0.25, 0.25)).x, 0.0); // texel centre of (0, 0): v=0 is row 0
    assert_eq!(eval(&t, Vec2::new(0.75, 0.75)).x, 3.0);
    assert_eq!(eval(&t, Vec2::new(0.5, 0.25)).x, 0.5);
    assert_eq!(eval(&t, Vec2::new(0.5, 0.5)).x, 1.5);
    assert_eq!(eval(&t, Vec2::new(0.0, 0.0)).x, 0.0); // clamped
    let t = bitmap(2, 2, (0..4).map(|i| Vec3::splat(i as f32)).collect(), FilterType::Bilinear, WrapMode::Repeat);
    assert_eq!(eval(&t, Vec2::new(0.0, 0.25)).x, 0.5); // halfway between texel 1 (wrapped) and 0
    let t = bitmap(2, 2, (0..4).map(|i| Vec3::splat(i as f32)).collect(), FilterType::Nearest, WrapMode::Repeat);
    assert_eq!(eval(&t, Vec2::new(0.99, 0.01)).x, 1.0);
    assert_eq!(eval(&t, Vec2::new(1.01, 0.51)).x, 2.0);
}

#[test]
fn checkerboard_rule() {
    let t = Texture::Checkerboard { color0: Vec3::splat(0.4), color1: Vec3::splat(0.2), to_uv: Mat3::IDENTITY };
    assert_eq!(eval(&t, Vec2::new(0.25, 0.25)).x, 0.4);
    assert_eq!(eval(&t, Vec2::new(0.75, 0.25)).x, 0.2);
    assert_eq!(eval(&t, Vec2::new(0.75, 0.75)).x, 0.4);
    assert_eq!(eval(&t, Vec2::new(-0.25, 0.25)).x, 0.2);
    assert_eq!(eval(&t, Vec2::new(0.5, 0.5)).x, 0.4); // > 0.5 is strict
    assert_eq!(eval_1(&t, Vec2::new(0.25, 0.25)), 0.2); // Mitsuba's inverted eval_1
    let scaled = Texture::Checkerboard { color0: Vec3::X, color1: Vec3::Y, to_uv: Mat3::from_scale(Vec2::new(4.0, 4.0)) };
    assert_eq!(eval(&scaled, Vec2::new(0.2, 0.05)), Vec3::Y); // uv' = (0.8, 0.2)
}

#[test]
fn half_rounding() {
    assert_eq!(round_to_half(1.0), 1.0);
    assert_eq!(round_to_half(1.0 + 1.0 / 2048.0), 1.0); // tie to even
    assert_eq!(round_to_half(1.0 + 3.0 / 2048.0), 1.0 + 2.0 / 1024.0);
    assert_eq!(round_to_half(0.1), 0.099975586);
    assert_eq!(round_to_half(-3.0e-6), -2.9802322e-6); // subnormal half: 50 * 2^-24
    assert_eq!(round_to_half(70000.0), f32::INFINITY);
}

#[test]
fn srgb_curve() {
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert_eq!(srgb_to_linear(1.0), 1.0);
    assert!((srgb_to_linear(0.5) - 0.21404114).abs() < 1e-7);
    for i in 0..=100 {
        let x = i as f32 / 100.0;
        assert!((linear_to_srgb(srgb_to_linear(x)) - x).abs() < 1e-6);
    }
}
