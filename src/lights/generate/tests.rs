//! CPU tests of light generation: power conservation (area exact, environment integrals, VPL furnace),
//! stratification, determinism, conventions and bad input.
mod gpu;
mod material;
mod vsl;

use super::environment::{envmap_radiance, Environment};
use super::sampling::equal_area_cells;
use super::*;
use crate::error::Location;
use crate::lights::LightKind;
use crate::scene::{Bsdf, Emitter, EnvMap, Mesh, Param, ShapeKind};
use crate::testing::light_scenes::{furnace_box, open_box, quad};
use glam::{Mat4, Vec3};
use std::f64::consts::PI;

/// Relative tolerance for sums that are exact up to f32 rounding.
const EXACT_REL: f64 = 1e-5;

fn sum_power(set: &LightSet, kind: LightKind) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for j in 0..set.len() {
        if set.kind[j] == kind {
            let p = set.power(j);
            for c in 0..3 {
                s[c] += p[c] as f64;
            }
        }
    }
    s
}

fn count(set: &LightSet, kind: LightKind) -> usize {
    set.kind.iter().filter(|&&k| k == kind).count()
}

fn only(area: usize, environment: usize, indirect: usize) -> GenerateOptions {
    GenerateOptions { area, environment, indirect, ..Default::default() }
}

/// A scene with two area emitters (a quad and an analytic sphere) of different radiance.
fn two_area_scene() -> Scene {
    let mut scene = furnace_box(0.5, vec![], true);
    let sphere = Mesh {
        id: "sphere".into(),
        kind: ShapeKind::Sphere { center: Vec3::new(0.2, -0.5, 0.1), radius: 0.2, flip_normals: false },
        positions: vec![],
        normals: vec![],
        uvs: vec![],
        indices: vec![],
        face_normals: false,
        bsdf: 0,
        emitter: Some(1),
        loc: Location::default(),
    };
    scene.emitters.push(Emitter::Area {
        mesh: scene.meshes.len(),
        radiance: Vec3::new(5.0, 4.0, 0.5),
        texture: None,
        loc: Location::default(),
    });
    scene.meshes.push(sphere);
    scene
}

#[test]
fn area_power_is_exact_and_split_by_power() {
    let scene = two_area_scene();
    let set = generate_lights(&scene, &only(1000, 0, 0)).unwrap();
    assert_eq!(count(&set, LightKind::OrientedPoint), 1000);
    let quad_power = Vec3::new(1.0, 2.0, 3.0) * (std::f32::consts::PI * 0.36);
    let sphere_power = Vec3::new(5.0, 4.0, 0.5) * (std::f32::consts::PI * 4.0 * std::f32::consts::PI * 0.04);
    let expect = quad_power + sphere_power;
    let got = sum_power(&set, LightKind::OrientedPoint);
    for c in 0..3 {
        assert!((got[c] / expect[c] as f64 - 1.0).abs() < EXACT_REL, "channel {c}: {} vs {}", got[c], expect[c]);
    }
    // Counts proportional to mean power: quad 2 * 0.36 pi = 2.262, sphere 3.167 * 0.16 pi = 1.592.
    let n_sphere = (0..set.len()).filter(|&j| (set.position[j] - Vec3::new(0.2, -0.5, 0.1)).length() < 0.21).count();
    let share = sphere_power.element_sum() / expect.element_sum();
    assert_eq!(n_sphere, (1000.0 * share).round() as usize, "sphere share {share}");
    // Every light emits away from its surface, on which it sits (as Mitsuba's emitter samples).
    for j in 0..set.len() {
        let (p, n) = (set.position[j], set.normal[j]);
        if (p - Vec3::new(0.2, -0.5, 0.1)).length() < 0.21 {
            assert!((p - Vec3::new(0.2, -0.5, 0.1)).normalize().dot(n) > 0.9999);
            assert!(((p - Vec3::new(0.2, -0.5, 0.1)).length() - 0.2).abs() < 1e-6, "{p}");
        } else {
            assert_eq!(n, -Vec3::Y);
            assert!((p.y - 0.8).abs() < 1e-6, "{p}");
        }
    }
}

/// The n strata of a quad emitter (two triangles, compact pieces: `strata`) tile it, each holds its own
/// light, and each light's weight is its stratum's area: I0 = L A_k with L = 1 here.
#[test]
fn area_lights_are_stratified() {
    use crate::lights::patch;
    let scene = furnace_box(0.5, vec![], true);
    let n = 257;
    let set = generate_lights(&scene, &only(n, 0, 0)).unwrap();
    assert_eq!(set.len(), n);
    let mut total = 0.0f64;
    for j in 0..set.len() {
        let c = set.patch[j];
        let a = patch::quad_area(&c) as f64;
        total += a;
        assert!((set.intensity[j].x as f64 / a - 1.0).abs() < 1e-4, "light {j}: I0 {} for a stratum of {a} m^2", set.intensity[j].x);
        // The light lies in its own triangular piece (c[3] repeats c[2]).
        let (e1, e2, q) = (c[1] - c[0], c[2] - c[0], set.position[j] - c[0]);
        let (d11, d12, d22, q1, q2) = (e1.dot(e1), e1.dot(e2), e2.dot(e2), q.dot(e1), q.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let (b1, b2) = ((d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det);
        assert!(b1 >= -1e-4 && b2 >= -1e-4 && b1 + b2 <= 1.0 + 1e-4, "light {j} outside its stratum: {b1} {b2}");
    }
    // The quad of furnace_box is 0.6 x 0.6 m.
    assert!((total - 0.36).abs() < 1e-5, "the strata cover {total} m^2");
}

fn test_envmap(world_from_env: Mat4) -> EnvMap {
    let (w, h) = (16u32, 8u32);
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            Vec3::new(0.1 + 0.05 * x, 0.2 + 0.1 * y, if i == 37 { 40.0 } else { 0.3 })
        })
        .collect();
    EnvMap { width: w, height: h, data, scale: 1.5, world_from_env }
}

fn env_scene(map: EnvMap) -> Scene {
    let mut scene = furnace_box(0.5, vec![], false);
    scene.emitters = vec![Emitter::EnvMap { map, loc: Location::default() }];
    scene
}

#[test]
fn envmap_lookup_follows_mitsuba_conventions() {
    let map = test_envmap(Mat4::IDENTITY);
    let (w, h) = (16usize, 8usize);
    for (r, c) in [(1usize, 3usize), (2, 5), (5, 0), (6, 15), (3, 9)] {
        let u = (c as f32 + 0.5) / w as f32;
        let t = r as f32 / (h - 1) as f32;
        let (theta, phi) = (t * std::f32::consts::PI, u * 2.0 * std::f32::consts::PI);
        // u = atan2(v.x, -v.z) / 2pi: v = (sin theta sin phi, cos theta, -sin theta cos phi).
        let d = Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos());
        let got = envmap_radiance(&map, d);
        let expect = map.data[r * w + c] * 1.5;
        assert!((got - expect).abs().max_element() < 1e-4 * expect.max_element(), "({r}, {c}): {got} vs {expect}");
    }
    // u = 0.25 is +X: column 0.25 W - 0.5 = 3.5, halfway between columns 3 and 4 (row 3.5: rows 3, 4).
    let got = envmap_radiance(&map, Vec3::X);
    let avg = (map.data[3 * w + 3] + map.data[3 * w + 4] + map.data[4 * w + 3] + map.data[4 * w + 4]) * (1.5 / 4.0);
    assert!((got - avg).abs().max_element() < 1e-5, "{got} vs {avg}");
    // world_from_env rotates the map: a lookup of R d equals the unrotated lookup of d.
    let rot = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(0.3);
    let rotated = test_envmap(rot);
    let d = Vec3::new(0.3, 0.5, -0.8).normalize();
    let a = envmap_radiance(&rotated, rot.transform_vector3(d));
    let b = envmap_radiance(&map, d);
    assert!((a - b).abs().max_element() < 1e-4 * b.max_element(), "{a} vs {b}");
}

/// Brute-force int L dw over the sphere (midpoint rule on a fine (z, phi) grid).
fn brute_force_integral(env: &Environment) -> [f64; 3] {
    let (nz, nphi) = (1500usize, 3000usize);
    let mut s = [0.0f64; 3];
    for a in 0..nz {
        let z = 1.0 - 2.0 * (a as f64 + 0.5) / nz as f64;
        for b in 0..nphi {
            let phi = 2.0 * PI * (b as f64 + 0.5) / nphi as f64;
            let l = env.radiance(super::sampling::sphere_dir(z as f32, phi as f32));
            for c in 0..3 {
                s[c] += l[c] as f64;
            }
        }
    }
    s.map(|v| v * 4.0 * PI / (nz * nphi) as f64)
}

/// Env power: the strata's irradiances sum to int L dw, so the lights' powers sum to the power through
/// the bounding disk, pi r^2 int L dw (uniform and luminance-allocated strata, rotated map).
#[test]
fn environment_strata_preserve_power() {
    let rot = Mat4::from_rotation_y(0.4) * Mat4::from_rotation_z(0.2);
    let scene = env_scene(test_envmap(rot));
    let env = Environment::from_scene(&scene).unwrap();
    let reference = brute_force_integral(&env);
    let (_, r) = crate::lights::scene_sphere(&scene);
    for importance in [false, true] {
        for n in [1usize, 37, 600] {
            let opts = GenerateOptions { area: 0, environment: n, env_importance: importance, ..Default::default() };
            let set = generate_lights(&scene, &opts).unwrap();
            assert_eq!(count(&set, LightKind::Directional), n, "importance {importance}, n {n}");
            let got = sum_power(&set, LightKind::Directional);
            for c in 0..3 {
                let expect = reference[c] * PI * (r as f64).powi(2);
                let rel = got[c] / expect - 1.0;
                eprintln!("env importance={importance} n={n} channel {c}: power {:.6} vs {expect:.6} ({rel:+.2e})", got[c]);
                assert!(rel.abs() < 5e-3, "importance {importance}, n {n}, channel {c}: {} vs {expect}", got[c]);
            }
        }
    }
    // Constant environment: exactly L 4 pi / n per stratum.
    let mut scene = furnace_box(0.5, vec![], false);
    scene.emitters = vec![Emitter::Constant { radiance: Vec3::new(0.5, 1.0, 2.0), loc: Location::default() }];
    let set = generate_lights(&scene, &only(0, 100, 0)).unwrap();
    for j in 0..100 {
        let e = set.intensity[j] / (4.0 * std::f32::consts::PI / 100.0);
        assert!((e - Vec3::new(0.5, 1.0, 2.0)).abs().max_element() < 1e-4, "{e}");
    }
}

/// Uniform strata: one light per equal-area cell (its direction lies in its own cell); importance
/// strata: equal luminance per light.
#[test]
fn environment_lights_are_stratified() {
    let scene = env_scene(test_envmap(Mat4::IDENTITY));
    let n = 150;
    let set = generate_lights(&scene, &only(0, n, 0)).unwrap();
    let cells = equal_area_cells(n);
    for (j, cell) in cells.iter().enumerate() {
        let d = -set.direction[j];
        let phi = d.x.atan2(d.z).rem_euclid(2.0 * std::f32::consts::PI);
        assert!(d.y <= cell.z_hi + 1e-4 && d.y >= cell.z_lo - 1e-4, "light {j}: {d} outside {cell:?}");
        assert!(phi >= cell.phi_lo - 1e-4 && phi <= cell.phi_hi + 1e-4, "light {j}: phi {phi} outside {cell:?}");
    }
    let opts = GenerateOptions { area: 0, environment: n, env_importance: true, ..Default::default() };
    let set = generate_lights(&scene, &opts).unwrap();
    let lum: Vec<f32> = (0..n).map(|j| set.intensity[j].element_sum()).collect();
    let mean = lum.iter().sum::<f32>() / n as f32;
    assert!(lum.iter().all(|l| (l / mean - 1.0).abs() < 1e-3), "{lum:?}");
}

/// Furnace: in a closed two-sided diffuse box of albedo rho every particle hits a wall at each bounce
/// and cosine sampling has weight rho exactly, so the VPLs' reflected power must equal
/// Phi (rho + rho^2 + rho^3) for max_depth 5 (no Russian roulette yet), for a point and an area light.
#[test]
fn vpl_power_matches_the_furnace_series() {
    let rho = 0.6f64;
    let point = Emitter::Point { position: Vec3::new(0.1, 0.2, -0.3), intensity: Vec3::new(1.0, 0.5, 0.25), loc: Location::default() };
    for (name, scene, phi) in [
        ("point", furnace_box(rho as f32, vec![point], false), [4.0 * PI, 2.0 * PI, PI]),
        ("area", furnace_box(rho as f32, vec![], true), [0.36 * PI, 0.72 * PI, 1.08 * PI]),
    ] {
        let set = generate_lights(&scene, &GenerateOptions { area: 0, indirect: 3000, ..Default::default() }).unwrap();
        let n_vpl = count(&set, LightKind::Vpl);
        assert!((2700..3300).contains(&n_vpl), "{name}: {n_vpl} VPLs for 3000 asked");
        let got = sum_power(&set, LightKind::Vpl);
        let series = rho + rho * rho + rho.powi(3);
        for c in 0..3 {
            let expect = phi[c] * series;
            eprintln!("furnace {name} channel {c}: VPL power {:.6} vs {expect:.6}", got[c]);
            assert!((got[c] / expect - 1.0).abs() < 1e-4, "{name} channel {c}: {} vs {expect}", got[c]);
        }
    }
}

/// With Russian roulette (max_depth 12): the expectation still matches Phi sum_{k=1}^{10} rho^k,
/// within 4 standard errors (estimated from 8 independent seeds).
#[test]
fn vpl_power_is_unbiased_with_russian_roulette() {
    let rho = 0.7f64;
    let point = Emitter::Point { position: Vec3::new(0.1, 0.2, -0.3), intensity: Vec3::ONE, loc: Location::default() };
    let scene = furnace_box(rho as f32, vec![point], false);
    let expect = 4.0 * PI * (1..=10).map(|k| rho.powi(k)).sum::<f64>();
    let runs: Vec<f64> = (0..8)
        .map(|seed| {
            let opts = GenerateOptions { area: 0, indirect: 4000, max_depth: 12, seed, ..Default::default() };
            sum_power(&generate_lights(&scene, &opts).unwrap(), LightKind::Vpl)[0]
        })
        .collect();
    let mean = runs.iter().sum::<f64>() / 8.0;
    let var = runs.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 7.0;
    let std_err = (var / 8.0).sqrt();
    eprintln!("furnace with RR: mean {mean:.5} vs {expect:.5}, std err {std_err:.5}");
    assert!(std_err > 0.0 && std_err < 0.01 * expect, "{runs:?}");
    assert!((mean - expect).abs() < 4.0 * std_err, "{mean} vs {expect} (std err {std_err})");
}

#[test]
fn generation_is_deterministic_and_seeded() {
    let scene = open_box(16);
    let opts = GenerateOptions { area: 64, environment: 32, indirect: 500, seed: 3, ..Default::default() };
    let a = generate_lights(&scene, &opts).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = pool.install(|| generate_lights(&scene, &opts).unwrap());
    assert_eq!(a.len(), b.len());
    assert_eq!(a.position, b.position);
    assert_eq!(a.intensity, b.intensity);
    assert_eq!(a.incident, b.incident);
    assert_eq!(a.bsdf, b.bsdf);
    let c = generate_lights(&scene, &GenerateOptions { seed: 4, ..opts.clone() }).unwrap();
    assert_ne!(a.position, c.position);
    assert!(count(&a, LightKind::Vpl) > 300, "{}", count(&a, LightKind::Vpl));
    assert!(a.intensity.iter().all(|v| v.is_finite()));
    assert_eq!(a.vpl_clamp, default_clamp(&scene));
}

#[test]
fn bad_input_is_a_clear_error() {
    let scene = open_box(16);
    let e = generate_lights(&scene, &GenerateOptions { clamp: Some(f32::NAN), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("clamp") && e.contains("NaN"), "{e}");
    let e = generate_lights(&scene, &GenerateOptions { clamp: Some(-1.0), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("clamp") && e.contains("-1"), "{e}");
    let e = generate_lights(&scene, &GenerateOptions { area: MAX_LIGHTS + 1, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("area") && e.contains(&(MAX_LIGHTS + 1).to_string()), "{e}");
    let e = generate_lights(&scene, &GenerateOptions { indirect: 10, max_depth: 2, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("max_depth") && e.contains("got 2"), "{e}");
    let mut dark = scene.clone();
    dark.emitters.clear();
    dark.meshes.iter_mut().for_each(|m| m.emitter = None);
    let e = generate_lights(&dark, &GenerateOptions::default()).unwrap_err().to_string();
    assert!(e.contains("no emitters"), "{e}");
}

/// Zero-area and zero-radiance emitters contribute nothing (no lights, no NaN); the others are intact.
#[test]
fn degenerate_emitters_contribute_nothing() {
    let mut scene = furnace_box(0.5, vec![], true);
    let mut flat = quad(Vec3::ZERO, Vec3::X, Vec3::X * 2.0, 0, "flat");
    flat.emitter = Some(1);
    scene.emitters.push(Emitter::Area { mesh: scene.meshes.len(), radiance: Vec3::ONE, texture: None, loc: Location::default() });
    scene.meshes.push(flat);
    let mut black = quad(Vec3::new(0.0, -0.5, 0.0), Vec3::X * 0.2, Vec3::Z * 0.2, 0, "black");
    black.emitter = Some(2);
    scene.emitters.push(Emitter::Area { mesh: scene.meshes.len(), radiance: Vec3::ZERO, texture: None, loc: Location::default() });
    scene.meshes.push(black);
    let set = generate_lights(&scene, &GenerateOptions { area: 100, indirect: 200, ..Default::default() }).unwrap();
    assert_eq!(count(&set, LightKind::OrientedPoint), 100);
    assert!(
        (0..set.len()).filter(|&j| set.kind[j] == LightKind::OrientedPoint).all(|j| set.position[j].y > 0.79),
        "all on the real emitter"
    );
    assert!((0..set.len()).all(|j| set.power(j).is_finite() && set.intensity[j].is_finite()));
    // An environment that is black: no lights, no NaN.
    let mut scene = furnace_box(0.5, vec![], false);
    scene.emitters = vec![Emitter::Constant { radiance: Vec3::ZERO, loc: Location::default() }];
    let set = generate_lights(&scene, &GenerateOptions { area: 0, environment: 10, indirect: 10, ..Default::default() }).unwrap();
    assert_eq!(set.len(), 0);
}

/// `emitted` for the new kinds: the cosine lobe, and a diffuse VPL's Phi rho / pi cos_v / d^2 with
/// the geometry-term clamp.
#[test]
fn emitted_oriented_point_and_vpl() {
    let mut s = LightSet::new(Vec3::ZERO, 1.0);
    s.push_oriented_point(Vec3::ZERO, Vec3::Y, Vec3::splat(2.0)).unwrap();
    let p = Vec3::new(0.0, 1.0, 1.0);
    let (wo, l, d) = s.emitted(0, p, -Vec3::Y).unwrap();
    assert!((d - 2f32.sqrt()).abs() < 1e-6 && (wo + p.normalize()).length() < 1e-6);
    assert!((l.x - 2.0 * (0.5f32.sqrt()) / 2.0).abs() < 1e-6, "{l}");
    assert!(s.emitted(0, Vec3::new(0.0, -1.0, 0.0), Vec3::Y).is_none());
    assert!((s.power(0).x - 2.0 * std::f32::consts::PI).abs() < 1e-5);
    let bsdf = crate::shading::bsdf::resolve(&[Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) }], &[], 0, glam::Vec2::ZERO);
    let incident = Vec3::new(0.3, 1.0, 0.0).normalize();
    s.push_vpl(Vec3::ZERO, Vec3::Y, Vec3::Y, incident, Vec3::splat(3.0), bsdf).unwrap();
    let n_recv = (-p).normalize();
    let (_, l, _) = s.emitted(1, p, n_recv).unwrap();
    let cos_v = p.normalize().y;
    let expect = 3.0 * 0.5 / std::f32::consts::PI * cos_v / 2.0;
    assert!((l.x - expect).abs() < 1e-6, "{l} vs {expect}");
    // Clamp: G = cos_v * 1 / d^2 = 0.3536; clamp at 0.1 scales by 0.1 / G.
    s.vpl_clamp = 0.1;
    let (_, l2, _) = s.emitted(1, p, n_recv).unwrap();
    let g = cos_v / 2.0;
    assert!((l2.x - expect * 0.1 / g).abs() < 1e-6, "{l2}");
    // Behind the surface: nothing. Diffuse power: Phi rho.
    assert!(s.emitted(1, -p, Vec3::Y).is_none());
    assert!((s.power(1).x - 1.5).abs() < 1e-5, "{}", s.power(1));
}

/// Each area point's patch is the part of its stratum in its triangle, and the near-field estimate of a receiver 1 cm from the emitter is unbiased: its mean
/// over seeds is L times the emitter's exact projected solid angle (`lights::patch`), with n = 7 strata
/// on the quad's two triangles.
#[test]
fn area_patches_are_stratum_pieces_and_the_near_field_is_unbiased() {
    use crate::lights::patch;
    let scene = furnace_box(0.5, vec![], true);
    let corners = [Vec3::new(-0.3, 0.8, -0.3), Vec3::new(0.3, 0.8, -0.3), Vec3::new(0.3, 0.8, 0.3), Vec3::new(-0.3, 0.8, 0.3)];
    let (p, n) = (Vec3::new(0.05, 0.79, 0.02), Vec3::Y);
    let (exact, _) = patch::clipped_projected_solid_angle(&corners, p, n);
    let seeds = 200;
    let mut mean = 0.0f64;
    // The same receiver facing away from the emitter (a `twosided` one lit from its back): |cos_r|.
    let mut mean_back = 0.0f64;
    for seed in 0..seeds {
        let set = generate_lights(&scene, &GenerateOptions { seed, ..only(7, 0, 0) }).unwrap();
        // Each patch is its stratum: the strata tile the 0.36 m^2 quad (4 and 3 compact pieces of its
        // two triangles).
        let areas: Vec<f64> = set.patch.iter().map(|c| patch::quad_area(c) as f64).collect();
        assert!(areas.iter().all(|&a| a > 0.0), "{areas:?}");
        assert!((areas.iter().sum::<f64>() / 0.36 - 1.0).abs() < EXACT_REL, "{areas:?}");
        for j in 0..set.len() {
            assert!(patch::is_near(&set.patch[j], p));
            // A diffuse receiver's value is f_r F cos_r: sum F cos_r / L over the lights (L = (1, 2, 3)).
            let (wo, f, _) = set.emitted(j, p, n).unwrap();
            mean += (f.x * wo.dot(n)) as f64 / seeds as f64;
            let (wo_b, f_b, _) = set.emitted(j, p, -n).expect("lit from the back");
            assert_eq!((wo_b, f_b), (wo, f));
            mean_back += (f_b.x * wo_b.dot(-n).abs()) as f64 / seeds as f64;
        }
    }
    assert!((mean / exact as f64 - 1.0).abs() < 5e-3, "mean {mean} vs exact projected solid angle {exact}");
    assert_eq!(mean_back, mean);
}
