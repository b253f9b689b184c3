use super::*;

#[test]
fn gauss_legendre_integrates_polynomials() {
    let (x, w) = gauss_legendre(32);
    let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(6)).sum();
    assert!((s - 2.0 / 7.0).abs() < 1e-13, "{s}");
    assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-13);
}

#[test]
fn erf_and_erfinv_are_inverse() {
    for y in [-0.999, -0.5, 0.0, 0.3, 0.9, 0.99999] {
        assert!((erf(erfinv(y)) - y).abs() < 1e-8, "{y}");
    }
    assert!((erf(0.5) - 0.520499877813).abs() < 2e-7);
}

#[test]
fn tables_match_values_measured_from_mitsuba() {
    // Read back from mitsuba 3.9.1 scalar_rgb (diffuse eval with specular_reflectance 0); int_ior 1.9 over
    // Mitsuba's default ext_ior "air" = 1.000277.
    let t = roughplastic_tables(true, 0.1, 1.9 / 1.000277);
    for (k, want) in [(0, 0.544532), (1, 0.540424), (10, 0.631266), (63, 0.903259)] {
        assert!((t.external_transmittance[k] - want).abs() < 5e-6, "ggx {k}: {}", t.external_transmittance[k]);
    }
    assert!((t.internal_reflectance - 0.720195).abs() < 5e-6, "{}", t.internal_reflectance);
    let t = roughplastic_tables(false, 0.1, 1.9 / 1.000277);
    for (k, want) in [(0, 0.351438), (5, 0.463025), (63, 0.903759)] {
        assert!((t.external_transmittance[k] - want).abs() < 5e-6, "beckmann {k}: {}", t.external_transmittance[k]);
    }
    assert!((t.internal_reflectance - 0.747400).abs() < 5e-6, "{}", t.internal_reflectance);
}
