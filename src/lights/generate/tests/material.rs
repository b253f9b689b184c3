//! Particle tracing through `principled` and `blendbsdf` surfaces: the flux carried from bounce to
//! bounce is unbiased (principled reflection sampled with `shading::principled::sample`, transmission
//! leaving the box; a blend's BSDF picked with its weight; a roughdielectric pane scattering by sampling).
use crate::error::Location;
use crate::lights::generate::*;
use crate::lights::LightKind;
use crate::scene::principled::Principled;
use crate::scene::{Bsdf, Emitter, Param, Scene};
use crate::shading::principled::eval_mode;
use crate::testing::light_scenes::{box_faces, furnace_box, square_camera};
use glam::Vec3;

/// A closed box of one-sided principled walls (spec_trans 0.5: half the light leaves through the walls)
/// around a point light. First-bounce VPLs face the light; the second bounce's total flux must equal
/// sum over first-bounce VPLs of flux * R(w_in), R = the reflected albedo by quadrature.
#[test]
fn principled_box_second_bounce_flux_is_unbiased() {
    let v = |x: f32| Param::Value(Vec3::splat(x));
    let bsdf = Bsdf::Principled(Box::new(Principled {
        base_color: Param::Value(Vec3::new(0.8, 0.6, 0.3)),
        roughness: v(0.6),
        anisotropic: v(0.0),
        metallic: v(0.2),
        spec_tint: v(0.2),
        spec_trans: v(0.5),
        sheen: v(0.3),
        sheen_tint: v(0.0),
        clearcoat: v(0.0),
        clearcoat_gloss: v(0.0),
        flatness: v(0.0),
        eta: 1.5,
    }));
    let light = Vec3::new(0.1, 0.2, -0.3);
    let scene = Scene {
        media: Default::default(),
        path: "principled_box.xml".into(),
        integrator: None,
        camera: square_camera(16, Vec3::new(0.0, 0.0, 0.9), Vec3::ZERO),
        meshes: box_faces(0),
        bsdfs: vec![bsdf],
        textures: vec![],
        emitters: vec![Emitter::Point { position: light, intensity: Vec3::ONE, loc: Location::default() }],
    };
    let mut ratios = Vec::new();
    for seed in 0..5 {
        let opts = GenerateOptions { area: 0, indirect: 3000, max_depth: 4, seed, ..Default::default() };
        let set = generate_lights(&scene, &opts).unwrap();
        let (mut second, mut expect) = (0.0f64, 0.0f64);
        let mut first_count = 0;
        for j in 0..set.len() {
            if set.kind[j] != LightKind::Vpl {
                continue;
            }
            let to_light = (light - set.position[j]).normalize();
            if set.incident[j].dot(to_light) > 1.0 - 1e-5 {
                first_count += 1;
                let wi = sampling::to_local(set.normal[j], set.incident[j]);
                // R(wi): stratified quadrature over wi's hemisphere (uniform measure), 40 x 80 cells.
                let (nz, np) = (40usize, 80usize);
                let mut r = 0.0f64;
                for a in 0..nz {
                    for c in 0..np {
                        let z = (a as f32 + 0.5) / nz as f32;
                        let phi = 2.0 * std::f32::consts::PI * (c as f32 + 0.5) / np as f32;
                        let s = (1.0 - z * z).sqrt();
                        let wo = Vec3::new(s * phi.cos(), s * phi.sin(), z.copysign(wi.z));
                        r += eval_mode(&set.bsdf[j], wi, wo, false).x as f64;
                    }
                }
                r *= 2.0 * std::f64::consts::PI / (nz * np) as f64;
                expect += set.intensity[j].x as f64 * r;
            } else {
                second += set.intensity[j].x as f64;
            }
        }
        assert!(first_count > 500, "{first_count} first-bounce VPLs");
        ratios.push(second / expect);
    }
    let n = ratios.len() as f64;
    let mean = ratios.iter().sum::<f64>() / n;
    let std_err = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    eprintln!("principled box: second-bounce flux / expectation = {mean:.4} +- {std_err:.4} ({ratios:?})");
    assert!(std_err < 0.02, "{ratios:?}");
    assert!((mean - 1.0).abs() < 4.0 * std_err + 3e-3, "{mean} (std err {std_err}, {ratios:?})");
}

/// Furnace box whose two-sided walls blend diffuse 0.8 and diffuse 0.4 with weight 0.25: as diffuse
/// rho = 0.7, the VPLs' reflected power must be Phi (rho + rho^2 + rho^3) in expectation (max_depth 5),
/// within 4 standard errors over seeds (the blend's random pick is the only noise source besides the
/// particle count).
#[test]
fn blend_furnace_power_is_unbiased() {
    let mut scene = furnace_box(
        0.8,
        vec![Emitter::Point { position: Vec3::new(0.1, 0.2, -0.3), intensity: Vec3::ONE, loc: Location::default() }],
        false,
    );
    scene.bsdfs = vec![
        Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.8)) },
        Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.4)) },
        Bsdf::Blend { weight: Param::Value(Vec3::splat(0.25)), first: 0, second: 1 },
        Bsdf::TwoSided { front: 2, back: 2 },
    ];
    for m in &mut scene.meshes {
        m.bsdf = 3;
    }
    let rho = 0.7f64;
    let expect = 4.0 * std::f64::consts::PI * (rho + rho * rho + rho.powi(3));
    let runs: Vec<f64> = (0..6)
        .map(|seed| {
            let set = generate_lights(&scene, &GenerateOptions { area: 0, indirect: 3000, seed, ..Default::default() }).unwrap();
            (0..set.len()).filter(|&j| set.kind[j] == LightKind::Vpl).map(|j| set.power(j)[0] as f64).sum::<f64>()
        })
        .collect();
    let n = runs.len() as f64;
    let mean = runs.iter().sum::<f64>() / n;
    let std_err = (runs.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    eprintln!("blend furnace: VPL power {mean:.4} +- {std_err:.4} vs {expect:.4}");
    assert!(std_err > 0.0 && std_err < 0.01 * expect, "{runs:?}");
    assert!((mean - expect).abs() < 4.0 * std_err, "{mean} vs {expect} (std err {std_err})");
    // A wrong pick probability (e.g. 1 - w) gives rho = 0.5: far outside.
    let wrong = 4.0 * std::f64::consts::PI * (0.5 + 0.25 + 0.125);
    assert!((mean - wrong).abs() > 20.0 * std_err);
}

/// Furnace box lit by an area quad whose radiance is a checkerboard (uv (0,0)..(1,1): half of each
/// colour): the particles carry L at their uv, so the VPLs' reflected power is pi A mean(L) (rho + rho^2
/// + rho^3) in expectation (max_depth 5); the oriented point lights sum to pi A mean(L) too.
#[test]
fn textured_area_furnace_power_is_unbiased() {
    use crate::scene::{vec2, Texture};
    let rho = 0.6f64;
    let mut scene = furnace_box(rho as f32, vec![], true);
    let light = scene.meshes.len() - 1;
    scene.meshes[light].uvs = vec![vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(1.0, 1.0), vec2(0.0, 1.0)];
    scene.textures.push(Texture::Checkerboard {
        color0: Vec3::new(4.0, 1.0, 0.0),
        color1: Vec3::new(0.0, 1.0, 2.0),
        to_uv: glam::Mat3::IDENTITY,
    });
    if let Emitter::Area { texture, .. } = &mut scene.emitters[0] {
        *texture = Some(0);
    }
    let mean_l = Vec3::new(2.0, 1.0, 1.0).as_dvec3();
    let area = 0.36f64;
    let power = mean_l * std::f64::consts::PI * area;
    let set = generate_lights(&scene, &GenerateOptions { area: 4096, indirect: 0, ..Default::default() }).unwrap();
    let lights: glam::DVec3 = (0..set.len()).map(|j| set.power(j).as_dvec3()).sum();
    assert!(((lights - power).abs() / power).max_element() < 0.01, "{lights} vs {power}");
    let series = rho + rho * rho + rho.powi(3);
    let runs: Vec<glam::DVec3> = (0..6)
        .map(|seed| {
            let set = generate_lights(&scene, &GenerateOptions { area: 0, indirect: 3000, seed, ..Default::default() }).unwrap();
            (0..set.len()).filter(|&j| set.kind[j] == LightKind::Vpl).map(|j| set.power(j).as_dvec3()).sum()
        })
        .collect();
    let n = runs.len() as f64;
    let mean = runs.iter().copied().sum::<glam::DVec3>() / n;
    let var = runs.iter().map(|r| (*r - mean) * (*r - mean)).sum::<glam::DVec3>() / (n - 1.0);
    let std_err = (var / n).powf(0.5);
    let expect = power * series;
    eprintln!("textured area furnace: VPL power {mean} +- {std_err} vs {expect}");
    for c in 0..3 {
        assert!((mean[c] - expect[c]).abs() < 4.0 * std_err[c] + 1e-3 * expect[c], "channel {c}: {mean} vs {expect} ({std_err})");
    }
    // Particles carry L at their uv: red and blue (different per cell) vary from run to run, green (1 in
    // both cells) is as exact as a constant radiance's.
    assert!(std_err.x > 0.0 && std_err.z > 0.0 && std_err.y < 1e-6 * expect.y, "{std_err}");
}

/// A point light 0.5 above a wide horizontal `roughdielectric` pane (GGX, alpha 0.3, eta 1.5; no VPL is stored
/// on it) and a floor 0.5 below it: the first VPLs on the floor carry the flux the pane transmits,
/// 2 pi integral_0^1 T(mu) dmu, T(mu) the importance-mode transmitted albedo by quadrature (within 4
/// standard errors over 12 seeds; the light's upward half escapes; measured over 200 seeds: -0.08% +- 0.19%).
#[test]
fn roughdielectric_pane_transmits_unbiased_flux() {
    use crate::scene::MicrofacetDistribution;
    use crate::shading::bsdf::{resolve, roughdielectric_eval};
    use crate::testing::scenes::{quad, square_camera};
    let s = |x: f32| Param::Value(Vec3::splat(x));
    let pane = Bsdf::RoughDielectric {
        distribution: MicrofacetDistribution::Ggx,
        alpha_u: s(0.3),
        alpha_v: s(0.3),
        int_ior: 1.5,
        ext_ior: 1.0,
        specular_reflectance: s(1.0),
        specular_transmittance: s(1.0),
    };
    let (w, f) = (100.0, 300.0);
    let scene = Scene {
        media: Default::default(),
        path: "rough_pane.xml".into(),
        integrator: None,
        camera: square_camera(16, Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO),
        meshes: vec![
            quad(Vec3::new(-w, -w, 0.0), Vec3::X * 2.0 * w, Vec3::Y * 2.0 * w, 0, "pane"),
            quad(Vec3::new(-f, -f, -0.5), Vec3::X * 2.0 * f, Vec3::Y * 2.0 * f, 1, "floor"),
        ],
        bsdfs: vec![pane.clone(), Bsdf::Diffuse { reflectance: s(0.5) }],
        textures: vec![],
        emitters: vec![Emitter::Point { position: Vec3::new(0.0, 0.0, 0.5), intensity: Vec3::ONE, loc: Location::default() }],
    };
    // Expected: T(mu) by a 128 x 256 quadrature of the lower hemisphere, mu at 32 midpoints.
    let b = resolve(&[pane], &[], 0, glam::Vec2::ZERO);
    let (nm, nz, np) = (32usize, 128usize, 256usize);
    let mut t_mean = 0.0f64;
    for k in 0..nm {
        let mu = (k as f32 + 0.5) / nm as f32;
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut t = 0.0f64;
        for a in 0..nz {
            for c in 0..np {
                let z = -(a as f32 + 0.5) / nz as f32;
                let phi = 2.0 * std::f32::consts::PI * (c as f32 + 0.5) / np as f32;
                let r = (1.0 - z * z).sqrt();
                t += roughdielectric_eval(&b, wi, Vec3::new(r * phi.cos(), r * phi.sin(), z), false).x as f64;
            }
        }
        t_mean += t * 2.0 * std::f64::consts::PI / (nz * np) as f64 / nm as f64;
    }
    let expect = 2.0 * std::f64::consts::PI * t_mean;
    let runs: Vec<f64> = (0..12)
        .map(|seed| {
            let opts = GenerateOptions { area: 0, indirect: 2000, max_depth: 4, seed, ..Default::default() };
            let set = generate_lights(&scene, &opts).unwrap();
            (0..set.len()).filter(|&j| set.kind[j] == LightKind::Vpl).map(|j| set.intensity[j].x as f64).sum::<f64>()
        })
        .collect();
    let n = runs.len() as f64;
    let mean = runs.iter().sum::<f64>() / n;
    let std_err = (runs.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    eprintln!("rough pane: floor flux {mean:.4} +- {std_err:.4} vs {expect:.4} (mean T {t_mean:.4})");
    assert!(t_mean > 0.6 && t_mean < 0.97, "{t_mean}");
    assert!(std_err > 0.0 && std_err < 0.01 * expect, "{runs:?}");
    assert!((mean - expect).abs() < 4.0 * std_err + 2e-3 * expect, "{mean} vs {expect} (std err {std_err})");
}
