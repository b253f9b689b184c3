use super::*;
use glam::Mat3;

fn checker() -> SpotTexture {
    SpotTexture {
        x_axis: Vec3::X,
        y_axis: Vec3::Y,
        tan_cutoff: 0.5f32.tan(),
        texture: Arc::new(Texture::Checkerboard { color0: Vec3::splat(1.0), color1: Vec3::splat(0.0), to_uv: Mat3::IDENTITY }),
    }
}

#[test]
fn uv_is_mitsubas_direction_to_uv() {
    let t = checker();
    assert_eq!(t.uv(Vec3::Z), Vec2::splat(0.5));
    // On the cutoff cone along +x: u = 1.
    let d = Vec3::new(0.5f32.sin(), 0.0, 0.5f32.cos());
    assert!((t.uv(d).x - 1.0).abs() < 1e-6);
    assert!((t.uv(-d * Vec3::new(1.0, 1.0, -1.0)).x - 0.0).abs() < 1e-6);
}

#[test]
fn constant_texture_power_equals_the_falloff_integral() {
    let mut t = checker();
    t.texture = Arc::new(Texture::Checkerboard { color0: Vec3::splat(2.0), color1: Vec3::splat(2.0), to_uv: Mat3::IDENTITY });
    let p = spot_power_textured(&t, 0.5, 0.3);
    let exact = 2.0 * super::super::spot_solid_angle(0.5, 0.3);
    assert!((p.x / exact - 1.0).abs() < 1e-4, "{p} vs {exact}");
    // A checkerboard of 1 / 0 quarters is symmetric: half the power.
    let half = spot_power_textured(&checker(), 0.5, 0.3).x / super::super::spot_solid_angle(0.5, 0.3);
    assert!((half - 0.5).abs() < 1e-3, "{half}");
}
