use super::*;
use crate::shading::bsdf::KIND_PRINCIPLED;
use bytemuck::Zeroable;

/// A principled record as `bsdf::resolve` builds it.
pub(crate) fn record(
    base: [f32; 3],
    metallic: f32,
    spec_tint: f32,
    spec_trans: f32,
    eta: f32,
    sheen: f32,
    sheen_tint: f32,
    clearcoat: f32,
    clearcoat_gloss: f32,
    flatness: f32,
    roughness: f32,
    anisotropic: f32,
) -> GpuBsdf {
    let mut b = GpuBsdf::zeroed();
    b.kind = KIND_PRINCIPLED;
    b.diffuse = base;
    b.specular = [metallic, spec_tint, spec_trans];
    b.eta = [eta, sheen, sheen_tint];
    b.k = [clearcoat, clearcoat_gloss, flatness];
    (b.alpha_u, b.alpha_v) = dist_params(anisotropic, roughness);
    b.extra = [roughness, 0.0, 0.0, 0.0];
    b
}

#[test]
fn eta_from_specular_as_mitsuba() {
    // mi.traverse of principled: specular 0.5 -> eta 1.5 (2 / (1 - 0.2) - 1), eta given as is.
    assert!((principled_eta(None, None, false) - 1.5).abs() < 1e-6);
    assert_eq!(principled_eta(Some(1.33), Some(0.2), true), 1.33);
    assert_eq!(principled_eta(Some(1.0), None, true), 1.001);
    assert_eq!(principled_eta(Some(1.0), None, false), 1.0);
    let e = principled_eta(None, Some(0.0), true);
    assert!((e - (2.0 / (1.0 - (0.08f32 * 1e-3).sqrt()) - 1.0)).abs() < 1e-6);
}

/// Importance sampling for particles is unbiased: the mean weight equals the albedo (reflection and
/// transmission, importance mode) by quadrature over the sphere, from both sides.
#[test]
fn sampling_weights_are_unbiased() {
    let sets = [
        record([0.8, 0.3, 0.2], 0.0, 0.0, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0),
        record([0.9, 0.6, 0.2], 0.7, 0.3, 0.0, 1.5, 0.5, 0.5, 0.8, 0.3, 0.0, 0.3, 0.5),
        record([0.5, 0.7, 0.9], 0.1, 0.0, 0.8, 1.45, 0.0, 0.0, 0.5, 0.9, 0.4, 0.35, 0.0),
    ];
    for (si, b) in sets.iter().enumerate() {
        for wi in [Vec3::new(0.6, 0.1, 0.79).normalize(), Vec3::new(-0.3, 0.4, -0.87).normalize()] {
            if wi.z < 0.0 && !has_back_side(b) {
                continue;
            }
            // Reference: stratified uniform sphere quadrature (1024 x 2048 cells).
            let (nz, np) = (1024usize, 2048usize);
            let mut reference = glam::DVec3::ZERO;
            for a in 0..nz {
                for c in 0..np {
                    let z = 1.0 - 2.0 * (a as f32 + 0.5) / nz as f32;
                    let phi = 2.0 * PI * (c as f32 + 0.5) / np as f32;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let wo = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    reference += eval_mode(b, wi, wo, false).as_dvec3();
                }
            }
            reference *= 4.0 * std::f64::consts::PI / (nz * np) as f64;
            let mut rng = crate::lights::generate::sampling::stream(3, 77, si as u64);
            let u = |r: &mut rand_pcg::Pcg32| crate::lights::generate::sampling::uniform(r);
            let (mean, err) = crate::testing::mean_and_std_err(400_000, || {
                let (u0, u1, u2) = (u(&mut rng), u(&mut rng), u(&mut rng));
                sample(b, wi, u0, u1, u2).map(|(_, w)| w.as_dvec3())
            });
            for c in 0..3 {
                assert!(
                    (mean[c] - reference[c]).abs() <= 4.0 * err[c] + 3e-3 * reference[c],
                    "set {si} wi {wi}: sampled {mean} vs quadrature {reference} (std err {err})"
                );
            }
            assert!(reference.max_element() > 0.05 && reference.max_element() < 1.0, "set {si}: {reference}");
        }
    }
}
