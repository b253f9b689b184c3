use super::*;

/// Projected solid angle of the cap by a midpoint quadrature in (cos, phi) about its axis.
fn cap_numeric(cos_theta: f32, sin2_sigma: f32) -> f64 {
    let theta = (cos_theta as f64).acos();
    let n = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
    let cos_sigma = (1.0 - sin2_sigma as f64).max(0.0).sqrt();
    let (na, nb) = (400, 400);
    let mut sum = 0.0f64;
    for a in 0..na {
        let z = 1.0 - (1.0 - cos_sigma) * (a as f64 + 0.5) / na as f64;
        let rr = (1.0 - z * z).max(0.0).sqrt();
        for b in 0..nb {
            let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / nb as f64;
            let w = Vec3::new((rr * phi.cos()) as f32, (rr * phi.sin()) as f32, z as f32);
            sum += (w.dot(n) as f64).max(0.0);
        }
    }
    sum * 2.0 * std::f64::consts::PI * (1.0 - cos_sigma) / (na * nb) as f64
}

#[test]
fn cap_formula_matches_quadrature() {
    for &s in &[1e-3f32, 0.05, 0.3, 0.7, 0.95, 1.0] {
        for &c in &[1.0f32, 0.9, 0.5, 0.2, 0.05, 0.0] {
            let got = cap_projected_solid_angle(c, s) as f64;
            let want = cap_numeric(c, s);
            assert!((got - want).abs() < 2e-3 * want.max(1e-2), "cos {c} sin2 {s}: {got} vs {want}");
        }
    }
}

#[test]
fn spread_tends_to_the_point_formula_and_stays_bounded() {
    let i = Vec3::new(2.0, 1.0, 0.5);
    let (cy, cx, d2) = (0.6f32, 0.8f32, 4.0f32);
    let point = i / d2;
    for r in [1e-3f32, 1e-2] {
        let f = spread(i, cy, cx, d2, r).unwrap();
        assert!(((f - point) / point).abs().max_element() < 1e-4, "r {r}: {f} vs {point}");
    }
    // Far field: identical up to rounding at r = d / 100.
    let f = spread(i, cy, cx, d2, 0.02).unwrap();
    assert!(((f - point) / point).abs().max_element() < 1e-3);
    // Receivers on the sphere's centre or inside it: F * cos_x * f_r stays below pi / (2 r^2) I / cos_y.
    for d2 in [1e-8f32, 1e-4, 0.01] {
        let f = spread(i, cy, cx, d2, 0.1).unwrap() * cx;
        let bound = i / cy * (PI / (2.0 * 0.01));
        assert!(f.cmple(bound * 1.0001).all() && f.is_finite(), "{f} vs {bound}");
    }
    assert!(spread(i, cy, 0.0, d2, 0.1).is_none());
}

#[test]
fn cap_quadrature_agrees_with_the_closed_form_for_lambertian_lobes() {
    use crate::shading::bsdf::KIND_DIFFUSE;
    let mut b: crate::shading::GpuBsdf = bytemuck::Zeroable::zeroed();
    b.kind = KIND_DIFFUSE;
    b.diffuse = [0.5, 0.5, 0.5];
    let mut set = super::super::LightSet::new(Vec3::ZERO, 10.0);
    let n_v = Vec3::new(0.0, 0.0, 1.0);
    set.push_vpl(Vec3::ZERO, n_v, n_v, Vec3::new(0.3, 0.0, 1.0).normalize(), Vec3::ONE, b).unwrap();
    set.vsl_radius[0] = 0.1;
    let n_r = Vec3::new(0.0, -0.6, -0.8);
    let lambert = |w: Vec3| Vec3::splat(0.7 / PI * w.dot(n_r).max(0.0));
    for (p, tol) in [(Vec3::new(0.3, 0.4, 2.0), 2e-3), (Vec3::new(0.1, 0.2, 0.5), 0.03)] {
        let wo = (set.position[0] - p).normalize();
        let (_, f, _) = set.emitted(0, p, n_r).unwrap();
        let closed = lambert(wo) * f;
        let quad = set.shade_receiver(0, p, wo, f, lambert);
        assert!(((quad - closed) / closed).abs().max_element() < tol, "at {p}: quadrature {quad} vs closed form {closed}");
    }
    // Inside the sphere: finite, at most f_r f_v Phi Omega / (pi r^2) <= 2 f_r f_v Phi / r^2.
    let p = Vec3::new(0.0, 0.02, 0.03);
    let wo = (set.position[0] - p).normalize();
    let (_, f, _) = set.emitted(0, p, n_r).unwrap();
    let q = set.shade_receiver(0, p, wo, f, lambert);
    assert!(q.is_finite() && q.max_element() > 0.0 && q.max_element() <= 2.0 * (0.7 / PI) * (0.5 / PI) / 0.01, "{q}");
}

#[test]
fn radii_from_the_kth_neighbour_and_bad_scales() {
    let pts: Vec<Vec3> = (0..10).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
    let r = radii(&pts, 2, 0.5, 10.0).unwrap();
    // Point 0: its 2nd nearest other point is at distance 2; point 5: at distance 1.
    assert!((r[0] - 1.0).abs() < 1e-6 && (r[5] - 0.5).abs() < 1e-6, "{r:?}");
    for bad in [0.0f32, -1.0, f32::NAN, f32::INFINITY] {
        let e = radii(&pts, 2, bad, 10.0).unwrap_err().to_string();
        assert!(e.contains("vsl_radius_scale") && e.contains(&format!("{bad}")), "{e}");
    }
    assert!(radii(&pts, 0, 1.0, 10.0).unwrap_err().to_string().contains("vsl_neighbours"));
    // Coincident VPLs get the floor, never 0.
    let same = vec![Vec3::ONE; 5];
    assert!(radii(&same, 2, 1.0, 10.0).unwrap().iter().all(|&r| r == MIN_RADIUS_REL * 10.0));
}
