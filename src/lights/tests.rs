use super::*;

#[test]
fn diffuse_vpl_reflectance_closed_form_equals_quadrature() {
    use crate::shading::bsdf::{FLAG_TWOSIDED, KIND_DIFFUSE};
    use bytemuck::Zeroable;
    let mut b = GpuBsdf::zeroed();
    b.kind = KIND_DIFFUSE;
    b.diffuse = [0.7, 0.4, 0.1];
    let n = Vec3::new(0.3, -0.5, 0.8).normalize();
    // A shading normal 0.03 rad off n_g takes the quadrature; the closed form must agree with it.
    let tilt = (n + Vec3::new(0.03, 0.0, 0.0)).normalize();
    for (flags, inc) in [(0, n + Vec3::X * 0.2), (0, -n), (FLAG_TWOSIDED, -n + Vec3::Y * 0.3)] {
        b.flags = flags;
        let inc = inc.normalize();
        let closed = vpl_reflectance(&b, n, n, inc);
        let quad = vpl_reflectance(&b, tilt, n, inc);
        assert!((closed - quad).abs().max_element() < 2e-3, "{closed} vs {quad} (flags {flags})");
    }
    b.flags = 0;
    assert_eq!(vpl_reflectance(&b, n, n, n), Vec3::new(0.7, 0.4, 0.1));
    assert_eq!(vpl_reflectance(&b, n, n, -n), Vec3::ZERO);
}

#[test]
fn spot_falloff_matches_mitsuba_definition() {
    let (c, b) = (20f32.to_radians(), 15f32.to_radians());
    assert_eq!(spot_falloff(1.0, c, b), 1.0);
    assert_eq!(spot_falloff(14.9f32.to_radians().cos(), c, b), 1.0);
    let mid = spot_falloff(17.5f32.to_radians().cos(), c, b);
    assert!((mid - 0.5).abs() < 1e-4, "{mid}");
    assert_eq!(spot_falloff(20.01f32.to_radians().cos(), c, b), 0.0);
    assert_eq!(spot_falloff(-1.0, c, b), 0.0);
}

#[test]
fn spot_solid_angle_is_the_falloff_integral() {
    // Midpoint rule over theta of 2 pi falloff(theta) sin(theta).
    let (c, b) = (40f32.to_radians(), 25f32.to_radians());
    let n = 200_000;
    let mut sum = 0.0f64;
    for k in 0..n {
        let theta = (k as f64 + 0.5) / n as f64 * std::f64::consts::PI;
        sum += spot_falloff(theta.cos() as f32, c, b) as f64 * theta.sin();
    }
    let numeric = 2.0 * std::f64::consts::PI * sum * std::f64::consts::PI / n as f64;
    let closed = spot_solid_angle(c, b) as f64;
    assert!((numeric - closed).abs() < 1e-4 * closed, "{numeric} vs {closed}");
    // b = c: a hard cone.
    let hard = spot_solid_angle(c, c) as f64;
    assert!((hard - 2.0 * std::f64::consts::PI * (1.0 - (c as f64).cos())).abs() < 1e-5);
}

#[test]
fn powers_and_validation() {
    let mut s = LightSet::new(Vec3::ZERO, 2.0);
    s.push_point(Vec3::ONE, Vec3::new(1.0, 2.0, 3.0)).unwrap();
    s.push_directional(Vec3::new(0.0, -2.0, 0.0), Vec3::splat(0.5)).unwrap();
    let p = s.power(0);
    assert!((p.x - 4.0 * std::f32::consts::PI).abs() < 1e-5 && (p.z - 12.0 * std::f32::consts::PI).abs() < 1e-4);
    assert!((s.power(1).x - 0.5 * std::f32::consts::PI * 4.0).abs() < 1e-5);
    assert_eq!(s.direction[1], Vec3::new(0.0, -1.0, 0.0));
    let e = s.push_point(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE).unwrap_err().to_string();
    assert!(e.contains("light 2") && e.contains("position"), "{e}");
    let e = s.push_point(Vec3::ZERO, Vec3::new(1.0, -1.0, 0.0)).unwrap_err().to_string();
    assert!(e.contains("non-negative"), "{e}");
    let e = s.push_spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 0.3, 0.4).unwrap_err().to_string();
    assert!(e.contains("beam_width"), "{e}");
    assert_eq!(s.len(), 2);
}

#[test]
fn emitted_point_spot_directional() {
    let mut s = LightSet::new(Vec3::ZERO, 1.0);
    s.push_point(Vec3::new(0.0, 2.0, 0.0), Vec3::splat(4.0)).unwrap();
    s.push_spot(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, Vec3::splat(4.0), 0.5, 0.25).unwrap();
    s.push_directional(Vec3::new(0.0, -1.0, 0.0), Vec3::splat(3.0)).unwrap();
    let (wo, l, d) = s.emitted(0, Vec3::ZERO, Vec3::Y).unwrap();
    assert_eq!((wo, l, d), (Vec3::Y, Vec3::splat(1.0), 2.0));
    assert_eq!(s.emitted(1, Vec3::ZERO, Vec3::Y).unwrap().1, Vec3::splat(1.0));
    assert!(s.emitted(1, Vec3::new(2.0, 0.0, 0.0), Vec3::Y).is_none());
    let (wo, l, d) = s.emitted(2, Vec3::ZERO, Vec3::Y).unwrap();
    assert_eq!((wo, l), (Vec3::Y, Vec3::splat(3.0)));
    assert!(d.is_infinite());
}

/// Writes `emitted` for fixed lights and points to $ML_DUMP (checked against Mitsuba's
/// `sample_direction` by a Python script; run with `--ignored`).
#[test]
#[ignore]
fn dump_emitted_for_mitsuba() {
    let Ok(path) = std::env::var("ML_DUMP") else { return };
    let mut s = LightSet::new(Vec3::ZERO, 1.0);
    s.push_point(Vec3::new(0.3, 1.0, -0.2), Vec3::new(1.0, 2.0, 3.0)).unwrap();
    s.push_spot(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.1, -1.0, 0.2), Vec3::new(2.0, 1.0, 0.5), 0.6, 0.35).unwrap();
    s.push_directional(Vec3::new(0.3, -1.0, 0.2), Vec3::new(0.7, 0.8, 0.9)).unwrap();
    let mut out = String::new();
    for j in 0..3 {
        for k in 0..40 {
            let p = Vec3::new(-1.0 + 0.05 * k as f32, -0.3 + 0.01 * k as f32, 0.4 - 0.03 * k as f32);
            let (wo, l, _) = s.emitted(j, p, Vec3::Y).unwrap_or((Vec3::ZERO, Vec3::ZERO, 0.0));
            out += &format!("{j} {} {} {} {} {} {} {} {} {}\n", p.x, p.y, p.z, wo.x, wo.y, wo.z, l.x, l.y, l.z);
        }
    }
    std::fs::write(path, out).unwrap();
}
