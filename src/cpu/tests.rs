//! The CPU backend against the exact oracle (the same arithmetic: bit-equal) and against the GPU backend
//! with exact rays (`Visibility::RayTraced`: the same rays, f32 rounding of the GPU's shading apart).
use crate::matrix::backend::{Chosen, Device};
use crate::matrix::{ColumnOptions, LightMatrix};
use glam::Vec3;

/// Relative tolerance of "equal" between the backends.
const REL: f32 = 1e-5;

use crate::testing::backend_pair as pair;

/// Lights of every kind (3 each).
fn every_kind(a: &LightMatrix) -> Vec<usize> {
    crate::testing::lights_of_every_kind(&a.lights, 3)
}

/// (elements differing by more than REL relative (+ 1e-6 of the largest value), elements, lit elements).
fn compare(a: &[f32], b: &[f32]) -> (usize, usize, usize) {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().fold(0f32, |s, &v| s.max(v.abs()));
    let bad = a.iter().zip(b).filter(|(x, y)| (*x - *y).abs() > REL * x.abs().max(y.abs()) + 1e-6 * scale).count();
    (bad, a.len(), a.iter().filter(|&&v| v > 0.0).count())
}

#[test]
fn cpu_columns_rows_and_sums_are_the_oracle_exactly() {
    let p = pair(24);
    let a = &p.cpu;
    assert_eq!(a.device().kind, "cpu");
    let (m, n) = a.shape();
    let js = every_kind(a);
    let cols = a.columns(&js).unwrap();
    for (k, &j) in js.iter().enumerate() {
        let exact: Vec<f32> = a.column_exact(j).unwrap().into_iter().flatten().collect();
        assert_eq!(&cols[k * m * 3..(k + 1) * m * 3], &exact[..], "column {j}");
    }
    let is = [0, m / 3, m / 2 + 5, m - 1];
    let rows = a.rows(&is, &mut |_, _| {}).unwrap();
    for (k, &i) in is.iter().enumerate() {
        let exact: Vec<f32> = a.row_exact(i).unwrap().into_iter().flatten().collect();
        assert_eq!(&rows[k * n * 3..(k + 1) * n * 3], &exact[..], "row {i}");
    }
    // weighted_sum = the weighted columns summed in light order.
    let w: Vec<[f32; 3]> = js.iter().enumerate().map(|(k, _)| [0.5 + k as f32, 1.0, 2.0 - 0.1 * k as f32]).collect();
    let sum = a.weighted_sum(&js, &w, &mut |_, _| {}).unwrap();
    let mut expect = vec![0f32; m * 3];
    for (k, wk) in w.iter().enumerate() {
        for i in 0..m {
            for c in 0..3 {
                expect[i * 3 + c] += wk[c] * cols[(k * m + i) * 3 + c];
            }
        }
    }
    let (bad, _, lit) = compare(&sum, &expect);
    assert_eq!(bad, 0);
    assert!(lit > m, "too few lit pixels: {lit}");
    let stats = a.visibility_stats().unwrap();
    assert!(stats.shadow_tests > 0 && stats.ray_casts == stats.shadow_tests && stats.gave_up == 0, "{stats:?}");
}

#[test]
fn cpu_and_gpu_backends_agree_on_columns_rows_and_sums() {
    let p = pair(32);
    let (m, n) = p.cpu.shape();
    let js = every_kind(&p.cpu);
    let (bad, total, lit) = compare(&p.cpu.columns(&js).unwrap(), &p.gpu.columns(&js).unwrap());
    eprintln!("columns: {bad} of {total} elements differ by > {REL} relative ({lit} lit)");
    assert!(lit > total / 10, "too few lit elements: {lit}");
    // Measured: 0 elements differ (the GPU's spot falloff uses `acos_precise`; before, its driver acos
    // put 0.25% of the elements up to 7e-4 apart). A ray grazing an edge could still be decided
    // differently by the two watertight tests: allow 1e-4 of the elements.
    assert!(bad as f64 <= 1e-4 * total as f64, "{bad} of {total} column elements differ");

    let is = crate::matrix::rows::stratified_rows(p.cpu.view.width, p.cpu.view.height, 40, 1).unwrap();
    let (bad, total, lit) = compare(&p.cpu.rows(&is, &mut |_, _| {}).unwrap(), &p.gpu.rows(&is, &mut |_, _| {}).unwrap());
    eprintln!("rows: {bad} of {total} elements differ by > {REL} relative ({lit} lit)");
    assert!(lit > total / 10 && bad as f64 <= 1e-4 * total as f64, "{bad} of {total} row elements differ");

    let all: Vec<usize> = (0..n).collect();
    let w: Vec<[f32; 3]> = (0..n).map(|j| [1.0 + (j % 7) as f32 * 0.1; 3]).collect();
    let cpu = p.cpu.weighted_sum(&all, &w, &mut |_, _| {}).unwrap();
    let gpu = p.gpu.weighted_sum(&all, &w, &mut |_, _| {}).unwrap();
    let num: f64 = cpu.iter().zip(&gpu).map(|(a, b)| ((a - b) as f64).powi(2)).sum();
    let den: f64 = gpu.iter().map(|b| (*b as f64).powi(2)).sum();
    let rel_l2 = (num / den).sqrt();
    eprintln!("weighted sum of all {n} columns: relative L2 {rel_l2:.2e} over {m} pixels");
    assert!(rel_l2 < 1e-4, "weighted sums differ: relative L2 {rel_l2}");
}

#[test]
fn choosing_devices() {
    // An explicit CPU never touches the GPU; "auto" on a machine whose only adapter is software is the CPU.
    assert!(Device::Cpu.choose().unwrap().is_cpu());
    let ctx = crate::testing::gpu_context();
    if std::env::var(crate::matrix::backend::DEVICE_ENV).is_err() {
        assert_eq!(Device::Auto.choose().unwrap().is_cpu(), ctx.summary.is_software);
    }
    assert!(!Device::Gpu.choose().unwrap().is_cpu());
    // Shadow maps exist only on the GPU.
    let p = pair(16);
    let e = LightMatrix::with_device(
        &Chosen::Cpu,
        p.cpu.scene.clone(),
        p.cpu.view.clone(),
        p.cpu.lights.clone(),
        ColumnOptions::default(),
        None,
    )
    .err()
    .expect("hybrid visibility on the CPU must be refused")
    .to_string();
    assert!(e.contains("only the GPU backend") && e.contains("ray_traced"), "{e}");
}

/// `shade_unshadowed` skips a light whose direction its receiver's BSDF reflects nothing from before
/// evaluating the light (`ShadingPoint::may_reflect`): wherever it does, the full evaluation gives exactly
/// 0, on scenes with one-sided and `twosided` diffuse, plastic, rough plastic and rough conductor
/// receivers and lights of every kind (area points with patches, VPLs, the environment's directions).
#[test]
fn receivers_skip_only_lights_they_reflect_nothing_from() {
    use crate::lights::{generate_lights, GenerateOptions};
    use crate::shading::bsdf::eval_records;
    let mut skipped_total = 0;
    for name in ["cbox-lights", "veach-ajar", "living-room"] {
        let (scene, view, _) = crate::testing::scene_view_tracer(&crate::testing::scene_file(&format!("{name}/scene.xml")), 24);
        let gen = GenerateOptions { area: 200, environment: 50, indirect: 400, seed: 3, ..Default::default() };
        let lights = generate_lights(&scene, &gen).unwrap();
        let (mut skipped, mut back) = (0usize, 0usize);
        for i in 0..view.len() {
            let sp = super::ShadingPoint::new(&view, i);
            if !sp.surface {
                continue;
            }
            back += (sp.side == -1.0) as usize;
            for j in 0..lights.len() {
                let Some((wo, _, _)) = lights.toward(j, sp.p) else { continue };
                if sp.may_reflect(wo) || lights.vsl_radius[j] > 0.0 {
                    continue;
                }
                skipped += 1;
                assert!(super::shade_unshadowed(&view, &lights, &sp, i, j).is_none());
                if let Some((wo, radiance, _)) = lights.emitted(j, sp.p, sp.n) {
                    let receiver = |w: Vec3| eval_records(&view.bsdf, i, sp.wi_local, sp.local(w));
                    let f = lights.shade_receiver(j, sp.p, wo, radiance, receiver);
                    assert_eq!(f, Vec3::ZERO, "{name}: sample {i} (side {}), light {j}: skipped but {f}", sp.side);
                }
            }
        }
        println!("{name}: {skipped} elements skipped, {back} samples reflecting from below");
        skipped_total += skipped;
        assert!(skipped > 0, "{name}: no element skipped");
    }
    assert!(skipped_total > 10_000);
}

/// `spatial_order` (the order `rows` traces a row's lights in) is a permutation of the lights, with the
/// directional ones last, and neighbours in it are neighbours in space: the mean distance between
/// consecutive lights falls well below that of the lights' own order (measured 0.27x here).
#[test]
fn spatial_order_is_a_permutation_of_neighbours() {
    let p = pair(16);
    let lights = &p.cpu.lights;
    let n = lights.len();
    let order = super::spatial_order(lights);
    let mut seen = vec![false; n];
    for &j in &order {
        assert!(!seen[j as usize], "light {j} twice");
        seen[j as usize] = true;
    }
    assert!(seen.iter().all(|&s| s) && order.len() == n);
    let directional = |j: u32| lights.kind[j as usize] == crate::lights::LightKind::Directional;
    let first_directional = order.iter().position(|&j| directional(j)).unwrap_or(n);
    assert!(order[first_directional..].iter().all(|&j| directional(j)), "directional lights are not last");
    let at: Vec<u32> = order[..first_directional].to_vec();
    assert!(at.len() > 100, "{} lights at a position", at.len());
    let mean_step = |js: &[u32]| {
        js.windows(2).map(|w| lights.position[w[0] as usize].distance(lights.position[w[1] as usize])).sum::<f32>() / (js.len() - 1) as f32
    };
    let mut own = at.clone();
    own.sort_unstable();
    let (spatial, given) = (mean_step(&at), mean_step(&own));
    println!("mean step between consecutive lights: {spatial} in spatial order, {given} in their own order");
    assert!(spatial < 0.4 * given, "{spatial} against {given}");
}
