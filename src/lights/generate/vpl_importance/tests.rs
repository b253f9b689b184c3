//! VPL importance sampling (`vpl_importance`): the tau equation, unbiasedness of the image (z-test over
//! seeds against plain VPLs, on the occluded open box with a render view finer than the pilot view),
//! lower variance, determinism, eps = 1 = every candidate, bad options.
use super::{p_accept, solve_tau, trace_importance, PilotView};
use crate::cpu::{shade, ShadingPoint};
use crate::lights::generate::vpl::Tracer;
use crate::lights::generate::*;
use crate::lights::LightKind;
use crate::raytrace::RayTracer;
use crate::testing::light_scenes::{furnace_box, open_box};
use crate::testing::scenes::cast_view;
use crate::view::ViewSamples;
use rayon::prelude::*;

/// Luminance of the VPLs' column sum over the whole view (the indirect image's total).
fn indirect_total(tracer: &RayTracer, view: &ViewSamples, lights: &LightSet) -> f64 {
    let js: Vec<usize> = (0..lights.len()).filter(|&j| lights.kind[j] == LightKind::Vpl).collect();
    (0..view.len())
        .into_par_iter()
        .map(|i| {
            let sp = ShadingPoint::new(view, i);
            js.iter().map(|&j| shade(tracer, view, lights, &sp, i, j).value.element_sum() as f64 / 3.0).sum::<f64>()
        })
        .sum()
}

fn mean_var(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (m, x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0))
}

#[test]
fn tau_solves_the_target_equation() {
    // Equal contributions: tau = phi, every candidate accepted.
    let tau = solve_tau(&[2.0; 10], 5, 0.01).unwrap();
    assert!((tau - 2.0).abs() < 1e-9, "{tau}");
    assert_eq!(p_accept(2.0, tau, 0.01), 1.0);
    // Heavy tail: h(tau) = mu, and each accepted below-target candidate carries tau (= N Phi_v).
    let mut phis = vec![0.0; 900];
    phis.extend((1..=100).map(|k| k as f64));
    let (n, eps) = (400usize, 0.02);
    let tau = solve_tau(&phis, n, eps).unwrap();
    let mu: f64 = phis.iter().sum();
    let h: f64 = phis.iter().map(|&p| tau.min(p + eps * tau)).sum();
    assert!((h - mu).abs() < 1e-9 * mu, "h(tau) {h} vs mu {mu}");
    // Expected acceptances = mu / tau per pilot (sum of p), as N = M tau / mu assumes.
    let accepted: f64 = phis.iter().map(|&p| p_accept(p, tau, eps)).sum();
    assert!((accepted - mu / tau).abs() < 1e-9 * accepted, "{accepted} vs {}", mu / tau);
    assert!(solve_tau(&[0.0; 5], 5, 0.01).is_none());
}

/// Unbiasedness: over 48 seeds, the mean indirect image total with importance sampling equals the plain
/// VPLs' within 4 standard errors, on the open box (a panel occludes, the environment's particles mostly
/// land where the camera does not look), rendered at 24 x 24 while the pilot sees 8 x 8 pixel centres (so
/// eps keeps the unseen candidates). The bound is informative: the standard error is asserted < 5% of
/// the total, and a third of the candidates are rejected (acceptance < 0.7), so dropping the 1/p
/// division would move the mean by far more than 4 standard errors.
#[test]
fn importance_sampling_is_unbiased() {
    let scene = open_box(24);
    let view = cast_view(&scene);
    let tracer = RayTracer::new(&scene).unwrap();
    let imp = VplImportance { view_samples: 64, accept_min: 0.05 };
    let (mut plain, mut is) = (Vec::new(), Vec::new());
    for seed in 0..48u64 {
        let base = GenerateOptions { area: 0, indirect: 300, max_depth: 4, seed, ..Default::default() };
        plain.push(indirect_total(&tracer, &view, &generate_lights(&scene, &base).unwrap()));
        let opts = GenerateOptions { vpl_importance: Some(imp), ..base };
        is.push(indirect_total(&tracer, &view, &generate_lights(&scene, &opts).unwrap()));
    }
    let ((m0, v0), (m1, v1)) = (mean_var(&plain), mean_var(&is));
    let se = ((v0 + v1) / plain.len() as f64).sqrt();
    let z = (m1 - m0) / se;
    println!("indirect total: plain {m0:.4} (sd {:.4}), importance {m1:.4} (sd {:.4}), z = {z:.2}", v0.sqrt(), v1.sqrt());
    assert!(m0 > 0.0 && z.abs() < 4.0, "z = {z}");
    // The estimate is informative: the seeds' spread is well below the difference a missing 1/p would make.
    assert!(se < 0.05 * m0, "standard error {se} of {m0}");
    let areas = area::area_emitters(&scene);
    let env = environment::Environment::from_scene(&scene);
    let opts = GenerateOptions { area: 0, indirect: 300, max_depth: 4, seed: 0, vpl_importance: Some(imp), ..Default::default() };
    let t = Tracer::new(&scene, &areas, env.as_ref(), &opts, 1).unwrap().unwrap();
    let (_, stats) = trace_importance(&t, &opts, &imp).unwrap();
    println!("{stats:?}");
    assert!(stats.acceptance < 0.7 && stats.acceptance >= 0.05, "{stats:?}");
}

#[test]
fn accepted_count_and_stats() {
    let scene = open_box(16);
    let areas = area::area_emitters(&scene);
    let env = environment::Environment::from_scene(&scene);
    let opts = GenerateOptions { area: 0, indirect: 2000, seed: 3, ..Default::default() };
    let t = Tracer::new(&scene, &areas, env.as_ref(), &opts, 1).unwrap().unwrap();
    let imp = VplImportance::default();
    let pilot = PilotView::new(&scene, &t.rt, imp.view_samples).unwrap();
    assert!(pilot.len() >= 100 && pilot.len() <= 300, "{} pilot samples", pilot.len());
    let (set, stats) = trace_importance(&t, &opts, &imp).unwrap();
    assert_eq!(set.len(), stats.accepted);
    // About `indirect` VPLs accepted (a random count; 5 sigma of a Poisson-like count).
    let m = opts.indirect as f64;
    assert!((stats.accepted as f64 - m).abs() < 5.0 * m.sqrt() + 0.02 * m, "{stats:?}");
    assert!((stats.accepted as f64 / stats.candidates as f64 - stats.acceptance).abs() < 0.05, "{stats:?}");
    // eps = 1: every candidate accepted with its plain flux times N_plain / N.
    let all = VplImportance { accept_min: 1.0, ..imp };
    let (set1, stats1) = trace_importance(&t, &opts, &all).unwrap();
    assert_eq!(stats1.accepted, stats1.candidates);
    assert_eq!(stats1.acceptance, 1.0);
    assert!(set1.len() > 0);
}

#[test]
fn same_seed_same_bits_and_option_off_unchanged() {
    let scene = open_box(16);
    let base = GenerateOptions { area: 4, indirect: 500, seed: 9, ..Default::default() };
    let opts = GenerateOptions { vpl_importance: Some(VplImportance::default()), ..base.clone() };
    let a = generate_lights(&scene, &opts).unwrap();
    let b = generate_lights(&scene, &opts).unwrap();
    assert_eq!(a.position, b.position);
    assert_eq!(a.intensity, b.intensity);
    let c = generate_lights(&scene, &GenerateOptions { seed: 10, ..opts.clone() }).unwrap();
    assert_ne!(a.position, c.position);
    // The area lights are untouched by the option.
    let plain = generate_lights(&scene, &base).unwrap();
    let n_area = (0..plain.len()).filter(|&j| plain.kind[j] != LightKind::Vpl).count();
    assert_eq!(a.position[..n_area], plain.position[..n_area]);
    // VSLs: radii on the accepted VPLs.
    let vsl = generate_lights(&scene, &GenerateOptions { vsl: Some(VslOptions::default()), ..opts.clone() }).unwrap();
    assert_eq!(vsl.position, a.position);
    assert!((0..vsl.len()).all(|j| (vsl.vsl_radius[j] > 0.0) == (vsl.kind[j] == LightKind::Vpl)));
}

#[test]
fn delta_lights_without_indirect_are_unchanged() {
    let point = crate::scene::Emitter::Point {
        position: glam::Vec3::new(0.1, 0.2, 0.3),
        intensity: glam::Vec3::new(1.0, 2.0, 3.0),
        loc: crate::error::Location::default(),
    };
    let scene = furnace_box(0.5, vec![point], false);
    let base = GenerateOptions { area: 0, indirect: 0, ..Default::default() };
    let a = generate_lights(&scene, &base).unwrap();
    let b = generate_lights(&scene, &GenerateOptions { vpl_importance: Some(VplImportance::default()), ..base }).unwrap();
    assert_eq!(a.len(), 1);
    assert_eq!((a.kind.clone(), a.position.clone(), a.intensity.clone()), (b.kind, b.position, b.intensity));
}

#[test]
fn bad_importance_options_are_refused() {
    let scene = open_box(8);
    for (imp, what) in [
        (VplImportance { view_samples: 0, ..Default::default() }, "vpl_view_samples"),
        (VplImportance { view_samples: (1 << 16) + 1, ..Default::default() }, "vpl_view_samples"),
        (VplImportance { accept_min: 0.0, ..Default::default() }, "vpl_accept_min"),
        (VplImportance { accept_min: f32::NAN, ..Default::default() }, "vpl_accept_min"),
        (VplImportance { accept_min: 1.5, ..Default::default() }, "vpl_accept_min"),
    ] {
        let opts = GenerateOptions { indirect: 100, vpl_importance: Some(imp), ..Default::default() };
        let err = generate_lights(&scene, &opts).unwrap_err().to_string();
        assert!(err.contains(what), "{err}");
    }
    // A camera that sees no surface: a clear error, not a silent image.
    let mut sky = open_box(8);
    sky.camera = crate::testing::light_scenes::square_camera(8, glam::Vec3::new(0.0, 0.0, 3.4), glam::Vec3::new(0.0, 0.0, 10.0));
    let opts = GenerateOptions { indirect: 100, vpl_importance: Some(VplImportance::default()), ..Default::default() };
    let err = generate_lights(&sky, &opts).unwrap_err().to_string();
    assert!(err.contains("vpl_importance") && err.contains("no surface"), "{err}");
}
