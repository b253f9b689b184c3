use super::*;
use crate::shading::bsdf::{resolve, test_sets};

#[test]
fn equal_area_cells_partition_the_sphere() {
    for n in [1usize, 2, 7, 100, 1000, 4097] {
        let cells = equal_area_cells(n);
        assert_eq!(cells.len(), n);
        let total: f64 = cells.iter().map(|c| c.solid_angle() as f64).sum();
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-4, "{n}: {total}");
        for c in &cells {
            assert!((c.solid_angle() - 4.0 * PI / n as f32).abs() < 1e-4 * 4.0 * PI, "{n}: {c:?}");
        }
    }
}

#[test]
fn streams_are_deterministic_and_distinct() {
    let a: Vec<f32> = (0..4).map(|_| 0).scan(stream(7, STREAM_PARTICLE, 3), |r, _| Some(uniform(r))).collect();
    let b: Vec<f32> = (0..4).map(|_| 0).scan(stream(7, STREAM_PARTICLE, 3), |r, _| Some(uniform(r))).collect();
    let c: Vec<f32> = (0..4).map(|_| 0).scan(stream(7, STREAM_PARTICLE, 4), |r, _| Some(uniform(r))).collect();
    let d: Vec<f32> = (0..4).map(|_| 0).scan(stream(8, STREAM_PARTICLE, 3), |r, _| Some(uniform(r))).collect();
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert_ne!(a, d);
}

/// The sampled weights' mean equals the albedo by quadrature (unbiased sampling) for every
/// non-delta test BSDF, and sampled directions stay in the upper hemisphere.
#[test]
fn bsdf_sampling_weights_are_unbiased() {
    let wi = Vec3::new(0.6, 0.1, 0.79).normalize();
    for (name, bsdfs, i) in test_sets() {
        let b = resolve(&bsdfs, &[], i, Vec2::ZERO);
        if b.kind == KIND_PLASTIC || b.kind == KIND_PRINCIPLED {
            continue; // plastic has a delta lobe (furnace tests); principled: its own module's test
        }
        // Reference albedo: 512^2 stratified cosine quadrature.
        let n = 512;
        let mut reference = glam::DVec3::ZERO;
        for a in 0..n {
            for c in 0..n {
                let wo = cosine_hemisphere((a as f32 + 0.5) / n as f32, (c as f32 + 0.5) / n as f32);
                reference += (eval(&b, wi, wo) * PI / wo.z).as_dvec3();
            }
        }
        reference /= (n * n) as f64;
        let mut rng = stream(1, 99, 0);
        let (mean, err) = crate::testing::mean_and_std_err(400_000, || {
            let s = sample_bsdf(&b, wi, &mut rng)?;
            assert!(s.wo.z > 0.0, "{name}");
            Some(s.weight.as_dvec3())
        });
        for c in 0..3 {
            assert!(
                (mean[c] - reference[c]).abs() <= 4.0 * err[c] + 2e-3 * reference[c],
                "{name}: sampled {mean} vs quadrature {reference} (std err {err})"
            );
        }
    }
}

/// roughdielectric (importance mode): the sampled weights' mean equals the reflected plus transmitted
/// albedo by quadrature over the whole sphere, from either side, and `pdf_bsdf` is the density sampled
/// (its integral is the probability of not rejecting, <= 1).
#[test]
fn roughdielectric_sampling_is_unbiased_from_both_sides() {
    use crate::scene::{Bsdf, MicrofacetDistribution, Param};
    use crate::shading::bsdf::roughdielectric_eval;
    let s = |x: f32| Param::Value(Vec3::splat(x));
    let bsdfs = [Bsdf::RoughDielectric {
        distribution: MicrofacetDistribution::Ggx,
        alpha_u: s(0.15),
        alpha_v: s(0.35),
        int_ior: 1.5,
        ext_ior: 1.0,
        specular_reflectance: Param::Value(Vec3::new(1.0, 0.8, 0.6)),
        specular_transmittance: Param::Value(Vec3::new(0.5, 0.7, 1.0)),
    }];
    let b = resolve(&bsdfs, &[], 0, Vec2::ZERO);
    for wi in [Vec3::new(0.5, 0.2, 0.84).normalize(), Vec3::new(-0.3, 0.4, -0.87).normalize()] {
        // Reference: 1024^2 stratified uniform-sphere quadrature of eval and of the pdf.
        let n = 1024;
        let (mut reference, mut pdf_total) = (glam::DVec3::ZERO, 0.0f64);
        for a in 0..n {
            for c in 0..n {
                let z = 1.0 - 2.0 * (a as f32 + 0.5) / n as f32;
                let phi = 2.0 * PI * (c as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let wo = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                reference += roughdielectric_eval(&b, wi, wo, false).as_dvec3();
                pdf_total += pdf_bsdf(&b, wi, wo) as f64;
            }
        }
        let cell = 4.0 * std::f64::consts::PI / (n * n) as f64;
        reference *= cell;
        pdf_total *= cell;
        let mut rng = stream(2, 99, 0);
        let (mean, err) = crate::testing::mean_and_std_err(400_000, || Some(sample_bsdf(&b, wi, &mut rng)?.weight.as_dvec3()));
        for c in 0..3 {
            assert!(
                (mean[c] - reference[c]).abs() <= 4.0 * err[c] + 3e-3 * reference[c],
                "wi {wi}: sampled {mean} vs quadrature {reference} (std err {err})"
            );
        }
        assert!(pdf_total > 0.9 && pdf_total < 1.0 + 2e-3, "wi {wi}: pdf integrates to {pdf_total}");
        assert!(reference.min_element() > 0.4, "{reference}");
    }
}

/// thindielectric: the mirror with probability R' = 2R / (1 + R) (weight specular_reflectance), else
/// straight through (weight specular_transmittance), from either side.
#[test]
fn thindielectric_sampling_picks_the_slab_lobes() {
    use crate::scene::{Bsdf, Param};
    let bsdfs = [Bsdf::ThinDielectric {
        int_ior: 1.5,
        ext_ior: 1.0,
        specular_reflectance: Param::Value(Vec3::new(1.0, 0.5, 0.25)),
        specular_transmittance: Param::Value(Vec3::new(0.9, 0.8, 0.7)),
    }];
    let b = resolve(&bsdfs, &[], 0, Vec2::ZERO);
    assert!(!is_dielectric(&b));
    for wi in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, -0.8, -0.6)] {
        let r = fresnel(wi.z.abs(), 1.5);
        let r = 2.0 * r / (1.0 + r);
        let mut rng = stream(3, 99, 0);
        let n = 200_000;
        let mut reflected = 0usize;
        for _ in 0..n {
            let s = sample_bsdf(&b, wi, &mut rng).unwrap();
            assert!(s.delta);
            if s.wo == Vec3::new(-wi.x, -wi.y, wi.z) {
                reflected += 1;
                assert_eq!(s.weight, Vec3::new(1.0, 0.5, 0.25));
            } else {
                assert_eq!((s.wo, s.weight), (-wi, Vec3::new(0.9, 0.8, 0.7)));
            }
        }
        let p = reflected as f32 / n as f32;
        assert!((p - r).abs() < 4.0 * (r * (1.0 - r) / n as f32).sqrt(), "wi {wi}: reflected {p}, R' {r}");
    }
}
