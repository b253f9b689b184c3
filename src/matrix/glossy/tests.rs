use super::*;
use crate::shading::bsdf::{FLAG_GGX, KIND_ROUGHCONDUCTOR};

#[test]
fn options_are_checked() {
    assert!(GlossyOptions::default().check().is_ok());
    assert!(GlossyOptions::off().check().is_ok());
    for r in [-0.1f32, 1.5, f32::NAN] {
        let e = GlossyOptions { roughness: r, ..Default::default() }.check().unwrap_err().to_string();
        assert!(e.contains("glossy_roughness must be in [0, 1]"), "{e}");
    }
    let e = GlossyOptions { bsdf_samples: 0, ..Default::default() }.check().unwrap_err().to_string();
    assert!(e.contains("bsdf_samples"), "{e}");
}

/// A roughconductor record (no tables needed) of isotropic alpha.
fn conductor(alpha: f32, ggx: bool) -> GpuBsdf {
    GpuBsdf {
        kind: KIND_ROUGHCONDUCTOR,
        flags: if ggx { FLAG_GGX } else { 0 },
        specular: [1.0; 3],
        eta: [0.2, 0.9, 1.1],
        k: [3.9, 2.4, 2.2],
        alpha_u: alpha,
        alpha_v: alpha,
        ..bytemuck::Zeroable::zeroed()
    }
}

/// `sample` draws directions with the density `bsdf_pdf` says: mean of 1[wo in cone] / p_B over draws
/// is the cone's solid angle, for cones around the mirror direction from the lobe core to its tails,
/// for alpha down to the Veach plates' 0.005 (where sqrt(1 - cos^2) used to cancel in f32).
#[test]
fn samples_follow_their_pdf() {
    use crate::lights::generate::sampling::{stream, uniform};
    let wi = Vec3::new(0.5, 0.1, 0.86).normalize();
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    for (alpha, ggx) in [(0.005f32, true), (0.05, true), (0.3, true), (0.05, false)] {
        let b = conductor(alpha, ggx);
        let mut rng = stream(11, 99, (alpha * 1e4) as u64 + ggx as u64);
        let n = 400_000;
        // Cones inside the upper hemisphere (the mirror direction is 0.54 rad from the normal).
        for half_angle in [(2.0 * alpha).min(0.4), (6.0 * alpha).min(0.5)] {
            let cos_c = half_angle.cos();
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            let mut rng2 = rng.clone();
            for _ in 0..n {
                let (u1, u2) = (uniform(&mut rng2), uniform(&mut rng2));
                if let Some((wo, _, pdf)) = sample(&b, wi, u1, u2) {
                    if wo.dot(mirror) >= cos_c {
                        let v = 1.0 / pdf as f64;
                        sum += v;
                        sum2 += v * v;
                    }
                }
            }
            let mean = sum / n as f64;
            let sd = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            let exact = 2.0 * std::f64::consts::PI * (1.0 - cos_c as f64);
            assert!(
                (mean - exact).abs() < 4.0 * sd + 1e-3 * exact,
                "alpha {alpha} ggx {ggx} cone {half_angle}: {mean} vs {exact} (sd {sd})"
            );
            rng = rng2;
        }
    }
}

/// The weights: 1 for samples without BSDF samples and for lights without a measure; q_L of an area
/// sample is d^2 / (A_j cos_l) and the light and BSDF weights of one direction sum to 1.
#[test]
fn light_weights_and_densities() {
    let mut lights = LightSet::new(Vec3::ZERO, 10.0);
    lights.push_oriented_point(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, Vec3::ONE).unwrap();
    lights.push_point(Vec3::new(0.0, 0.0, 2.0), Vec3::ONE).unwrap();
    lights.push_directional(-Vec3::Z, Vec3::ONE).unwrap();
    assert_eq!(light_density(&lights, 0, Vec3::ZERO), None);
    lights.set_mis(0, 0.01, 0);
    lights.set_mis(2, 0.5, -1);
    let p = Vec3::new(0.3, 0.0, 0.0);
    let d = lights.position[0] - p;
    let cos_l = d.z / d.length();
    let q = light_density(&lights, 0, p).unwrap();
    assert!((q - d.length_squared() / (0.01 * cos_l)).abs() < 1e-4 * q, "{q}");
    assert_eq!(light_density(&lights, 1, p), None);
    assert_eq!(light_density(&lights, 2, p), Some(2.0));
    // Behind the oriented point: no density.
    assert_eq!(light_density(&lights, 0, Vec3::new(0.0, 0.0, 3.0)), None);
    for (a, b) in [(1.0f32, 2.0f32), (1e-3, 1e4), (5.0, 0.0)] {
        assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
    }
    assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    // A view sample with n_B = 0 keeps w_L = 1.
    let view = ViewSamples {
        width: 1,
        height: 1,
        position: vec![p],
        normal: vec![Vec3::Z],
        geo_normal: vec![Vec3::Z],
        wi: vec![Vec3::Z],
        shape_index: vec![0],
        bsdf: vec![conductor(0.01, true)],
        ..Default::default()
    };
    let wo = d.normalize();
    assert_eq!(light_weight(&view, &lights, 0, p, Vec3::Z, wo, 0), 1.0);
    let mut glossy = view.clone();
    glossy.set_glossy(&GlossyOptions { roughness: 0.2, bsdf_samples: 64, seed: 0 }).unwrap();
    assert_eq!(glossy.bsdf_samples, vec![64]);
    assert_eq!(glossy.glossy_work(), (1, 64));
    let w = light_weight(&glossy, &lights, 0, p, Vec3::Z, wo, 0);
    let pb = 64.0 * bsdf_pdf(&glossy.bsdf[0], Vec3::Z, wo);
    assert!(w < 1.0 && (w - power_heuristic(q, pb)).abs() < 1e-6, "{w}");
    assert_eq!(light_weight(&glossy, &lights, 0, p, Vec3::Z, wo, 1), 1.0);
    // Rougher than the threshold: not glossy.
    let mut rough = view.clone();
    rough.set_glossy(&GlossyOptions { roughness: 0.005, bsdf_samples: 64, seed: 0 }).unwrap();
    assert!(rough.bsdf_samples.is_empty());
    assert_eq!(rough.glossy_work(), (0, 0));
}
