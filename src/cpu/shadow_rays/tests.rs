//! The batch's rays are the ones `shade` casts: traced alone they give the matrix's own visibility.
use super::*;
use crate::cpu::shade;

#[test]
fn traced_rays_reproduce_the_matrix_visibility_element_by_element() {
    let p = crate::testing::backend_pair(16);
    let a = &p.cpu;
    let (m, n) = a.shape();
    let views: Vec<usize> = (0..m).step_by(3).collect();
    let lights: Vec<usize> = crate::testing::lights_of_every_kind(&a.lights, 3);
    let tracer = a.tracer().unwrap();
    for order in [Order::Columns, Order::Rows] {
        let rays = shadow_rays(&a.view, &a.lights, &views, &lights, order, false).unwrap();
        assert_eq!(rays.elements, (views.len() * lights.len()) as u64);
        let (blocked, _) = trace(&tracer, &rays.origin, &rays.direction, &rays.t_max).unwrap();
        let mut cast = 0;
        for k in 0..rays.view.len() {
            let (i, j) = (rays.view[k] as usize, rays.light[k] as usize);
            let s = shade(&tracer, &a.view, &a.lights, &ShadingPoint::new(&a.view, i), i, j);
            assert!(s.tested, "a ray for ({i}, {j}) that shade does not cast");
            assert_eq!(blocked[k], !s.lit, "element ({i}, {j})");
            cast += 1;
        }
        // Every element that shade tests has its ray in the batch, and some are blocked, some lit.
        let tested = views
            .iter()
            .flat_map(|&i| lights.iter().map(move |&j| (i, j)))
            .filter(|&(i, j)| shade(&tracer, &a.view, &a.lights, &ShadingPoint::new(&a.view, i), i, j).tested)
            .count();
        assert_eq!(cast, tested);
        assert!(blocked.iter().any(|&b| b) && blocked.iter().any(|&b| !b));
        if order == Order::Columns {
            // light by light, in the order asked for
            let first: Vec<u32> = rays.light.iter().fold(Vec::new(), |mut v, &j| {
                if v.last() != Some(&j) {
                    v.push(j);
                }
                v
            });
            assert!(first
                .windows(2)
                .all(|w| lights.iter().position(|&l| l as u32 == w[0]) < lights.iter().position(|&l| l as u32 == w[1])));
        } else {
            // view sample by view sample, each one's lights in the order `rows` traces them (`spatial_order`)
            let order = crate::cpu::spatial_order(&a.lights);
            let rank = |j: u32| order.iter().position(|&l| l == j).unwrap();
            let mut pairs = 0;
            for k in 1..rays.view.len() {
                if rays.view[k] == rays.view[k - 1] {
                    assert!(rank(rays.light[k - 1]) < rank(rays.light[k]), "rays {} and {k} out of order", k - 1);
                    pairs += 1;
                }
            }
            assert!(pairs > 100, "{pairs} pairs of rays of one view sample");
        }
    }
    assert!(shadow_rays(&a.view, &a.lights, &[m], &lights, Order::Rows, false).is_err());
    assert!(shadow_rays(&a.view, &a.lights, &views, &[n], Order::Rows, false).is_err());
    assert!(trace(&tracer, &[Vec3::ZERO], &[], &[1.0]).is_err());
}

/// `every_element`: one ray per element of a surface view sample, lit or not, and the rays `shade` casts
/// among them bit for bit, in the same order.
#[test]
fn every_element_has_its_ray_and_the_cast_ones_are_unchanged() {
    let p = crate::testing::backend_pair(16);
    let a = &p.cpu;
    let (m, _) = a.shape();
    let views: Vec<usize> = (0..m).step_by(2).collect();
    let lights: Vec<usize> = crate::testing::lights_of_every_kind(&a.lights, 4);
    for order in [Order::Columns, Order::Rows] {
        let cast = shadow_rays(&a.view, &a.lights, &views, &lights, order, false).unwrap();
        let every = shadow_rays(&a.view, &a.lights, &views, &lights, order, true).unwrap();
        let surface = views.iter().filter(|&&i| a.view.shape_index[i] >= 0).count();
        assert_eq!(every.t_max.len(), surface * lights.len());
        assert!(cast.t_max.len() < every.t_max.len() && !cast.t_max.is_empty());
        let key = |r: &ShadowRays, k: usize| (r.view[k], r.light[k]);
        let mut e = 0;
        for k in 0..cast.t_max.len() {
            while key(&every, e) != key(&cast, k) {
                e += 1;
            }
            assert_eq!((every.origin[e], every.direction[e], every.t_max[e]), (cast.origin[k], cast.direction[k], cast.t_max[k]));
        }
    }
}

/// About `n` lights of the kinds the scene has (as the benchmark's `mixed_lights`): half area points, a
/// quarter environment strata, the rest VPLs; kinds the scene lacks are dropped.
fn mixed_lights(scene: &crate::scene::Scene, n: usize, seed: u64) -> LightSet {
    use crate::lights::{generate_lights, GenerateOptions};
    let tries = [(n / 2, n / 4), (n / 2, 0), (0, n / 4), (0, 0)];
    tries
        .iter()
        .find_map(|&(area, environment)| {
            generate_lights(scene, &GenerateOptions { area, environment, indirect: n - area - environment, seed, ..Default::default() })
                .ok()
        })
        .expect("lights")
}

/// Shadow rays per second of `trace` against the reference traversal (obvhs's own, per ray) on the
/// benchmark's column batch (every view sample to 256 lights) and row batch (256 stratified view samples to
/// 16,384 lights) of cbox, veach-ajar and bunny at 128^2, interleaved, best of 7; both must agree on every
/// ray. Run with `cargo test --release benchmark_shadow -- --ignored --nocapture`.
#[test]
#[ignore]
fn benchmark_shadow_rays_against_the_reference_traversal() {
    use std::time::Instant;
    for name in ["cbox", "veach-ajar", "bunny"] {
        let (scene, view, tracer) = crate::testing::scene_view_tracer(&crate::testing::scene_file(&format!("{name}/scene.xml")), 128);
        for order in [Order::Columns, Order::Rows] {
            let (views, lights) = match order {
                Order::Columns => ((0..view.len()).collect::<Vec<_>>(), mixed_lights(&scene, 256, 0)),
                Order::Rows => (crate::matrix::rows::stratified_rows(128, 128, 256, 0).unwrap(), mixed_lights(&scene, 16_384, 1)),
            };
            let js: Vec<usize> = (0..lights.len()).collect();
            let rays = shadow_rays(&view, &lights, &views, &js, order, false).unwrap();
            let r = rays.t_max.len();
            let (mut old_best, mut new_best) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..7 {
                let t = Instant::now();
                let old: Vec<bool> = (0..r)
                    .into_par_iter()
                    .with_min_len(256)
                    .map(|k| tracer.occluded_ray_reference(rays.origin[k], rays.direction[k], rays.t_max[k]))
                    .collect();
                old_best = old_best.min(t.elapsed().as_secs_f64());
                let (new, seconds) = trace(&tracer, &rays.origin, &rays.direction, &rays.t_max).unwrap();
                new_best = new_best.min(seconds);
                assert!(old == new, "{name} {order:?}: the traversals disagree");
            }
            println!(
                "{name} {order:?}: {r} rays ({} primitives): reference {:.1} Mrays/s, trace {:.1} Mrays/s ({:.2}x)",
                tracer.num_primitives(),
                r as f64 / old_best / 1e6,
                r as f64 / new_best / 1e6,
                old_best / new_best
            );
        }
    }
}
