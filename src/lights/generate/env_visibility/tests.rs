//! Tests of visibility-allocated environment strata: the partition (equal-area sub-cells, counts), the
//! environment's integral kept whatever the pilot saw, determinism, and the window room's strata going to
//! its window.
use super::*;
use crate::lights::generate::{generate_lights, GenerateOptions};
use crate::lights::LightKind;
use crate::scene::{load_scene, LoadOptions};
use std::path::Path;

fn window_room() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/window-room/scene.xml");
    let opts = LoadOptions { size: Some((64, 36)), ..Default::default() };
    load_scene(&path, &opts).unwrap()
}

fn env_lights(scene: &Scene, n: usize, visibility: bool, seed: u64) -> LightSet {
    let opts = GenerateOptions { area: 0, environment: n, env_visibility: visibility, seed, ..Default::default() };
    generate_lights(scene, &opts).unwrap()
}

fn irradiance_sum(set: &LightSet) -> Vec3 {
    (0..set.len()).filter(|&j| set.kind[j] == LightKind::Directional).map(|j| set.intensity[j]).sum()
}

#[test]
fn split_cell_makes_k_equal_area_cells_inside_the_cell() {
    for (n, c) in [(64usize, 0usize), (64, 30), (4096, 2047), (4096, 4095), (16, 7)] {
        let cell = equal_area_cells(n)[c];
        for k in [1usize, 2, 3, 7, 16, 50, 333] {
            let sub = split_cell(&cell, k);
            assert_eq!(sub.len(), k, "cell {c} of {n}, k {k}");
            let total: f32 = sub.iter().map(Cell::solid_angle).sum();
            assert!((total / cell.solid_angle() - 1.0).abs() < 1e-4, "cell {c} of {n}, k {k}: {total} vs {}", cell.solid_angle());
            for s in &sub {
                assert!((s.solid_angle() * k as f32 / cell.solid_angle() - 1.0).abs() < 2e-3, "k {k}: {s:?} of {cell:?}");
                assert!(s.z_lo >= cell.z_lo - 1e-6 && s.z_hi <= cell.z_hi + 1e-6 && s.z_lo < s.z_hi, "{s:?} of {cell:?}");
                assert!(s.phi_lo >= cell.phi_lo - 1e-6 && s.phi_hi <= cell.phi_hi + 1e-6 && s.phi_lo < s.phi_hi, "{s:?}");
            }
        }
    }
    assert!(split_cell(&equal_area_cells(8)[0], 0).is_empty());
}

#[test]
fn allocate_keeps_the_floor_and_the_total() {
    let lit = [true, true, false, true, true];
    let counts = allocate(100, &lit, &[8.0, 0.0, 50.0, 1.0, 27.0]);
    assert_eq!(counts.iter().sum::<usize>(), 100);
    assert_eq!(counts[2], 0, "an unlit cell gets no strata: {counts:?}");
    // Floor: 0.25 * 100 / 4 lit cells = 6 each; the rest (76) by I^(2/3): 4, 0, 1, 9 of 14.
    assert_eq!(counts, vec![6 + 22, 6, 0, 6 + 5, 6 + 49]);
    // Nothing seen by the pilot: evenly over the lit cells.
    assert_eq!(allocate(10, &[true, false, true], &[0.0, 0.0, 0.0]), vec![5, 0, 5]);
    // Fewer lights than lit cells: one each.
    assert_eq!(allocate(2, &[true, true, true], &[1.0, 2.0, 3.0]), vec![1, 1, 1]);
    assert_eq!(allocate(5, &[false, false], &[1.0, 1.0]), vec![0, 0]);
}

/// The strata partition the sphere: the lights' irradiances add up to the uniform strata's (the
/// environment's integral), in the window room whose pilot sees the sky through one window and in the
/// closed box whose pilot sees none of it.
#[test]
fn visibility_strata_keep_the_environment_integral() {
    let room = window_room();
    let closed = {
        let mut s = crate::testing::light_scenes::furnace_box(0.5, vec![], false);
        s.emitters = room.emitters.clone();
        s
    };
    for scene in [&room, &closed] {
        for n in [200usize, 4096] {
            let uniform = irradiance_sum(&env_lights(scene, n, false, 0));
            let vis = env_lights(scene, n, true, 3);
            let got = irradiance_sum(&vis);
            let rel = ((got - uniform).abs() / uniform).max_element();
            assert!(rel < 2e-3, "n {n}: {got} vs {uniform} ({rel:.2e})");
            assert!(vis.len() <= n && vis.len() >= n * 9 / 10, "n {n}: {} lights", vis.len());
            for j in 0..vis.len() {
                assert!(vis.mis_measure[j] > 0.0, "light {j} has no MIS measure");
            }
        }
    }
}

#[test]
fn visibility_strata_are_deterministic_and_fall_back_below_the_minimum() {
    let room = window_room();
    let (a, b) = (env_lights(&room, 1000, true, 5), env_lights(&room, 1000, true, 5));
    assert_eq!(a.direction, b.direction);
    assert_eq!(a.intensity, b.intensity);
    let small = env_lights(&room, MIN_LIGHTS - 1, true, 5);
    let uniform = env_lights(&room, MIN_LIGHTS - 1, false, 5);
    assert_eq!(small.direction, uniform.direction);
    let both = GenerateOptions { area: 0, environment: 500, env_visibility: true, env_importance: true, ..Default::default() };
    let err = generate_lights(&room, &both).unwrap_err().to_string();
    assert!(err.contains("env_importance and env_visibility"), "{err}");
}

/// In the window room most of the sky is behind walls: the visibility strata put most lights into the
/// directions the camera's surfaces see lit (strata finer than the uniform ones), and the pilot's
/// contribution of those lights is most of the image.
#[test]
fn window_room_strata_go_to_the_window() {
    let room = window_room();
    let n = 4096;
    let vis = env_lights(&room, n, true, 0);
    let uniform_sr = 4.0 * std::f32::consts::PI / n as f32;
    let fine = (0..vis.len()).filter(|&j| vis.mis_measure[j] < 0.5 * uniform_sr).count();
    eprintln!("{fine} of {} strata finer than half a uniform stratum", vis.len());
    assert!(fine as f64 >= 0.6 * vis.len() as f64, "{fine} of {}", vis.len());
    // The pilot's view of the lights: the finest strata carry the image.
    let rt = RayTracer::new(&room).unwrap();
    let pilot = PilotView::new(&room, &rt, 256).unwrap();
    let (mut fine_sum, mut total) = (0.0, 0.0);
    for j in 0..vis.len() {
        let c = pilot.contribution(&rt, &vis, j);
        total += c;
        if vis.mis_measure[j] < 0.5 * uniform_sr {
            fine_sum += c;
        }
    }
    assert!(total > 0.0 && fine_sum >= 0.9 * total, "fine strata carry {fine_sum} of {total}");
}
