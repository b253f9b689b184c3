use super::*;
use crate::lights::generate::sampling::uniform_sphere;
use crate::scene::{Bsdf, MicrofacetDistribution, Param};
use crate::shading::bsdf::{link_blend, resolve, resolve_records, FLAG_GGX, KIND_ROUGHCONDUCTOR};
use glam::Vec2;
use rand_pcg::Pcg32;

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

/// Mean of 1[wo in cone] / p_B over `n` draws of `sample` at record 0 of `records` against the cone's solid
/// angle (within 4 standard errors + 1e-3), for cones of half angle `half_angles` around `axis`.
fn check_cones(records: &[GpuBsdf], wi: Vec3, axis: Vec3, half_angles: &[f32], rng: &mut Pcg32, n: usize, what: &str) {
    for &half_angle in half_angles {
        let cos_c = half_angle.cos();
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (u1, u2) = (uniform(rng), uniform(rng));
            if let Some((wo, _, pdf)) = sample(records, 0, wi, u1, u2) {
                if wo.dot(axis) >= cos_c {
                    let v = 1.0 / pdf as f64;
                    sum += v;
                    sum2 += v * v;
                }
            }
        }
        let mean = sum / n as f64;
        let sd = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        let exact = 2.0 * std::f64::consts::PI * (1.0 - cos_c as f64);
        assert!((mean - exact).abs() < 4.0 * sd + 1e-3 * exact, "{what} cone {half_angle}: {mean} vs {exact} (sd {sd})");
    }
}

/// `sample` draws directions with the density `bsdf_pdf` says: mean of 1[wo in cone] / p_B over draws
/// is the cone's solid angle, for cones around the mirror direction from the lobe core to its tails,
/// for alpha down to the Veach plates' 0.005 (where sqrt(1 - cos^2) used to cancel in f32).
#[test]
fn samples_follow_their_pdf() {
    use crate::lights::generate::sampling::stream;
    let wi = Vec3::new(0.5, 0.1, 0.86).normalize();
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    for (alpha, ggx) in [(0.005f32, true), (0.05, true), (0.3, true), (0.05, false)] {
        let b = conductor(alpha, ggx);
        let mut rng = stream(11, 99, (alpha * 1e4) as u64 + ggx as u64);
        // Cones inside the upper hemisphere (the mirror direction is 0.54 rad from the normal).
        let cones = [(2.0 * alpha).min(0.4), (6.0 * alpha).min(0.5)];
        check_cones(&[b], wi, mirror, &cones, &mut rng, 400_000, &format!("alpha {alpha} ggx {ggx}"));
    }
}

/// Records of a `blendbsdf` as a view's record array holds them: [first, second], linked. `first` /
/// `second` are scene BSDFs (not blends), `w` the weight of the second.
fn blend_records(first: Bsdf, second: Bsdf, w: f32) -> Vec<GpuBsdf> {
    let bsdfs = vec![first, second, Bsdf::Blend { weight: Param::Value(Vec3::splat(w)), first: 0, second: 1 }];
    let (mut a, b) = resolve_records(&bsdfs, &[], 2, Vec2::ZERO);
    link_blend(&mut a, 1);
    vec![a, b.unwrap()]
}

fn roughplastic(alpha: f32) -> Bsdf {
    Bsdf::RoughPlastic {
        diffuse_reflectance: Param::Value(Vec3::new(0.2, 0.3, 0.5)),
        specular_reflectance: Param::Value(Vec3::ONE),
        distribution: MicrofacetDistribution::Ggx,
        alpha,
        int_ior: 1.49,
        ext_ior: 1.000277,
        nonlinear: false,
    }
}

fn roughconductor(alpha: f32) -> Bsdf {
    Bsdf::RoughConductor {
        distribution: MicrofacetDistribution::Ggx,
        alpha_u: Param::Value(Vec3::splat(alpha)),
        alpha_v: Param::Value(Vec3::splat(alpha)),
        eta: Vec3::new(0.2, 0.92, 1.1),
        k: Vec3::new(3.9, 2.45, 2.14),
        specular_reflectance: Param::Value(Vec3::ONE),
    }
}

/// The blend's strategy: its lobes and their probabilities; a sampled direction's pdf is the weighted
/// mixture (1 - w) p_0 + w p_1 of the components' lobe pdfs (exact up to f32 rounding), its weight f / p_B
/// with f the whole blend; each lobe is chosen with its weight; a component without a rough lobe is left
/// out and the rough one takes every sample; the glossy rule sees the narrowest rough component.
#[test]
fn blend_pdf_is_the_weighted_mixture() {
    use crate::lights::generate::sampling::stream;
    let wi = Vec3::new(-0.3, 0.45, 0.84).normalize();
    for w in [0.3f32, 0.75] {
        let rec = blend_records(roughplastic(0.2), roughconductor(0.03), w);
        let (lobes, n) = strategy_lobes(&rec, 0);
        assert_eq!(n, 2);
        assert!((lobes[0].1 - (1.0 - w)).abs() < 1e-6 && (lobes[1].1 - w).abs() < 1e-6, "{lobes:?}");
        assert_eq!(glossy_alpha(&rec, 0), Some(0.03));
        let mut rng = stream(5, 6, (w * 100.0) as u64);
        let (mut chose_second, mut drawn) = (0usize, 0usize);
        for _ in 0..20_000 {
            let (u1, u2) = (uniform(&mut rng), uniform(&mut rng));
            let Some((wo, weight, pdf)) = sample(&rec, 0, wi, u1, u2) else { continue };
            drawn += 1;
            chose_second += usize::from(u1 < w);
            let mixture = (1.0 - w) * bsdf_pdf(&rec[0], wi, wo) + w * bsdf_pdf(&rec[1], wi, wo);
            assert!(pdf > 0.0 && (pdf - mixture).abs() <= 1e-6 * mixture, "w {w}: pdf {pdf} vs mixture {mixture}");
            assert_eq!(pdf, strategy_pdf(&rec, 0, wi, wo));
            let f = eval_records(&rec, 0, wi, wo);
            assert!((weight * pdf - f).abs().max_element() <= 1e-5 * f.max_element(), "{weight} {pdf} {f}");
        }
        assert!(drawn > 19_000, "{drawn}");
        let frac = chose_second as f64 / 20_000.0;
        assert!((frac - w as f64).abs() < 0.02, "{frac}");
    }
    // diffuse + roughconductor: the conductor takes every sample, p_B its own pdf.
    let diffuse = Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) };
    let rec = blend_records(diffuse.clone(), roughconductor(0.05), 0.4);
    let (lobes, n) = strategy_lobes(&rec, 0);
    assert!(n == 1 && lobes[0].1 == 1.0 && lobes[0].0.kind == KIND_ROUGHCONDUCTOR);
    assert_eq!(glossy_alpha(&rec, 0), Some(0.05));
    let (wo, _, pdf) = sample(&rec, 0, wi, 0.3, 0.6).unwrap();
    assert_eq!(pdf, bsdf_pdf(&rec[1], wi, wo));
    // Weight 0 of the rough component, or no rough component: nothing to sample.
    let rec = blend_records(diffuse.clone(), roughconductor(0.05), 0.0);
    assert_eq!((strategy_lobes(&rec, 0).1, glossy_alpha(&rec, 0)), (0, None));
    assert!(sample(&rec, 0, wi, 0.3, 0.6).is_none());
    let rec = blend_records(diffuse.clone(), diffuse, 0.5);
    assert_eq!(glossy_alpha(&rec, 0), None);
    assert_eq!(strategy_pdf(&rec, 0, wi, Vec3::Z), 0.0);
    // The glossy rule: a blend is glossy when its narrowest rough lobe is below the threshold.
    let mut view = ViewSamples {
        width: 1,
        height: 1,
        position: vec![Vec3::ZERO],
        normal: vec![Vec3::Z],
        geo_normal: vec![Vec3::Z],
        wi: vec![Vec3::Z],
        shape_index: vec![0],
        bsdf: blend_records(roughplastic(0.3), roughconductor(0.03), 0.5),
        ..Default::default()
    };
    view.set_glossy(&GlossyOptions { roughness: 0.2, bsdf_samples: 16, seed: 0 }).unwrap();
    assert_eq!(view.bsdf_samples, vec![16]);
    view.set_glossy(&GlossyOptions { roughness: 0.02, bsdf_samples: 16, seed: 0 }).unwrap();
    assert!(view.bsdf_samples.is_empty());
}

/// The blend's samples follow the mixture pdf: the cone test of `samples_follow_their_pdf` around the
/// mirror direction (both lobes' cores and tails) and around a direction off it (the wide lobe only).
#[test]
fn blend_samples_follow_their_pdf() {
    use crate::lights::generate::sampling::stream;
    let wi = Vec3::new(0.5, 0.1, 0.86).normalize();
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    let off = Vec3::new(-0.2, -0.3, 0.93).normalize();
    for (w, a_plastic, a_conductor) in [(0.5f32, 0.2f32, 0.03f32), (0.2, 0.1, 0.005)] {
        let rec = blend_records(roughplastic(a_plastic), roughconductor(a_conductor), w);
        let mut rng = stream(12, 34, (w * 10.0) as u64);
        let what = format!("blend w {w} alphas {a_plastic} / {a_conductor}");
        check_cones(&rec, wi, mirror, &[2.0 * a_conductor, 0.1, 0.4], &mut rng, 400_000, &what);
        check_cones(&rec, wi, off, &[0.15], &mut rng, 400_000, &what);
    }
}

/// The MIS estimator stays unbiased on a blend: I = integral of f(wi, wo) L(wo) over the sphere (f the
/// whole blend with its cosine, L a dim sky with a bright spot just off the mirror direction), estimated
/// as (1 / N_L) sum_j w_L f L / p_L over N_L uniform sphere directions (p_L = 1 / 4 pi, q_L = N_L p_L)
/// plus (1 / n_B) sum_k w_B f L / p_B over n_B `sample`s (the weights as `light_weight` and `bsdf_image`
/// form them). The mean over trials matches a midpoint quadrature of I within 4 standard errors (+ the
/// quadrature's 2e-3), and the spread is far below the light strategy's alone.
#[test]
fn blend_mis_estimator_is_unbiased() {
    check_mis_unbiased(&blend_records(roughplastic(0.15), roughconductor(0.03), 0.6), "blend");
}

/// The same for principled (its GGX specular lobe sampled, alpha 0.04 / 0.0225 anisotropic; sheen and a
/// GTR1 clearcoat left to the light samples) and for a blend of principled and diffuse.
#[test]
fn principled_mis_estimator_is_unbiased() {
    check_mis_unbiased(&[resolve(&[principled(0.2, 0.0, 0.5)], &[], 0, Vec2::ZERO)], "principled");
    check_mis_unbiased(&[resolve(&[principled(0.15, 0.4, 0.0)], &[], 0, Vec2::ZERO)], "anisotropic principled");
    let diffuse = Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) };
    check_mis_unbiased(&blend_records(diffuse, principled(0.2, 0.0, 0.0), 0.5), "diffuse + principled");
}

fn check_mis_unbiased(rec: &[GpuBsdf], what: &str) {
    use crate::lights::generate::sampling::stream;
    let wi = Vec3::new(0.4, -0.2, 0.89).normalize();
    let spot = Vec3::new(-wi.x + 0.03, -wi.y, wi.z).normalize();
    let radiance = |wo: Vec3| 0.5 + 40.0 * wo.dot(spot).max(0.0).powi(400);
    let integrand = |wo: Vec3| eval_records(rec, 0, wi, wo) * radiance(wo);
    // Midpoint quadrature, equal-area cells in (cos theta, phi) over the upper hemisphere (f = 0 below).
    let (n_mu, n_phi) = (2000usize, 2000usize);
    let mut exact = glam::DVec3::ZERO;
    for a in 0..n_mu {
        let mu = (a as f64 + 0.5) / n_mu as f64;
        let s = (1.0 - mu * mu).sqrt();
        for b in 0..n_phi {
            let phi = (b as f64 + 0.5) / n_phi as f64 * std::f64::consts::TAU;
            let wo = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, mu as f32);
            exact += integrand(wo).as_dvec3();
        }
    }
    exact *= std::f64::consts::TAU / (n_mu * n_phi) as f64;
    let (n_l, n_b, trials) = (64usize, 16usize, 4000usize);
    let p_l = 1.0 / (4.0 * std::f32::consts::PI);
    let q = n_l as f32 * p_l;
    let mut rng = stream(77, 1, 0);
    let (mut sum, mut sum2, mut light_sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO, glam::DVec3::ZERO);
    for _ in 0..trials {
        let (mut est, mut light_only) = (Vec3::ZERO, Vec3::ZERO);
        for _ in 0..n_l {
            let wo = uniform_sphere(uniform(&mut rng), uniform(&mut rng));
            let pb = n_b as f32 * strategy_pdf(rec, 0, wi, wo);
            let v = integrand(wo) / (n_l as f32 * p_l);
            est += v * power_heuristic(q, pb);
            light_only += v;
        }
        for _ in 0..n_b {
            let (u1, u2) = (uniform(&mut rng), uniform(&mut rng));
            let Some((wo, weight, pdf)) = sample(rec, 0, wi, u1, u2) else { continue };
            est += weight * radiance(wo) * power_heuristic(n_b as f32 * pdf, q) / n_b as f32;
        }
        sum += est.as_dvec3();
        sum2 += (est * est).as_dvec3();
        let d = (light_only.as_dvec3() - exact) * (light_only.as_dvec3() - exact);
        light_sum2 += d;
    }
    let t = trials as f64;
    let mean = sum / t;
    let sd = ((sum2 / t - mean * mean).max(glam::DVec3::ZERO) / t).powf(0.5);
    let light_sd = (light_sum2 / t).powf(0.5) / t.sqrt();
    for c in 0..3 {
        let (m, e, s) = (mean[c], exact[c], sd[c]);
        assert!((m - e).abs() < 4.0 * s + 2e-3 * e, "{what} channel {c}: MIS mean {m} vs quadrature {e} (sd {s})");
        assert!(s < 0.01 * e && s < 0.5 * light_sd[c], "{what} channel {c}: sd {s}, light strategy alone {}", light_sd[c]);
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

/// A principled BSDF: roughness, anisotropic, clearcoat (metallic 0.5, sheen 0.5, no transmission).
fn principled(roughness: f32, anisotropic: f32, clearcoat: f32) -> Bsdf {
    let v = |x: f32| Param::Value(Vec3::splat(x));
    Bsdf::Principled(Box::new(crate::scene::principled::Principled {
        base_color: Param::Value(Vec3::new(0.7, 0.4, 0.2)),
        roughness: v(roughness),
        anisotropic: v(anisotropic),
        metallic: v(0.5),
        spec_tint: v(0.2),
        spec_trans: v(0.0),
        sheen: v(0.5),
        sheen_tint: v(0.5),
        clearcoat: v(clearcoat),
        clearcoat_gloss: v(0.3),
        flatness: v(0.0),
        eta: 1.5,
    }))
}

/// Principled's specular lobe is sampled as a GGX lobe of alpha sqrt(alpha_u alpha_v): the cone test, and
/// the glossy rule sees that alpha.
#[test]
fn principled_samples_follow_their_pdf() {
    use crate::lights::generate::sampling::stream;
    let wi = Vec3::new(0.5, 0.1, 0.86).normalize();
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    for (roughness, anisotropic) in [(0.2f32, 0.0f32), (0.15, 0.4)] {
        let rec = [resolve(&[principled(roughness, anisotropic, 0.5)], &[], 0, Vec2::ZERO)];
        let alpha = (rec[0].alpha_u * rec[0].alpha_v).sqrt();
        assert_eq!(glossy_alpha(&rec, 0), Some(alpha));
        let mut rng = stream(13, 57, (roughness * 100.0) as u64);
        check_cones(&rec, wi, mirror, &[2.0 * alpha, 6.0 * alpha], &mut rng, 400_000, &format!("principled {roughness} {anisotropic}"));
        // The back side has no BSDF strategy.
        assert!(sample(&rec, 0, Vec3::new(wi.x, wi.y, -wi.z), 0.3, 0.3).is_none());
    }
}
