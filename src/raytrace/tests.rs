use super::*;
use crate::testing::raytrace_scenes;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// Required BVH vs brute-force agreement (hit/miss and t) on random rays.
const MIN_AGREEMENT: f64 = 0.9999;
/// Relative t tolerance between BVH and brute force (same primitive test, so ties only).
const T_REL_TOL: f32 = 1e-5;
/// Pairs of points whose segment makes a smaller cosine with either normal count as grazing.
const GRAZING_COS: f32 = 1e-3;
/// Allowed fraction of pairs where one-sided `occluded(a -> b)` and `occluded(b -> a)` differ
/// (measured 0.18% on cbox with spheres).
const ONE_SIDED_ASYMMETRY: f64 = 5e-3;

fn uniform_sphere(rng: &mut Pcg32) -> Vec3 {
    let z = 1.0 - 2.0 * rng.random::<f32>();
    let phi = 2.0 * std::f32::consts::PI * rng.random::<f32>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Half the rays start anywhere in the (enlarged) bounds in a uniform direction, half aim at a
/// random vertex (so small objects get hit often).
fn random_rays(scene: &Scene, n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let (lo, hi) = scene.bounds();
    let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.6);
    let verts: Vec<Vec3> = scene.meshes.iter().flat_map(|m| m.positions.iter().copied()).collect();
    (0..n)
        .map(|k| {
            let o = c + h * Vec3::new(rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0);
            let d = if k % 16 == 15 {
                // Axis-aligned, with negative zeros (a traversal corner case).
                let mut d = Vec3::splat(if rng.random::<bool>() { 0.0 } else { -0.0 });
                d[rng.random_range(0..3)] = if rng.random::<bool>() { 1.0 } else { -1.0 };
                d
            } else if k % 2 == 0 {
                uniform_sphere(&mut rng)
            } else {
                let target = verts[rng.random_range(0..verts.len())] + uniform_sphere(&mut rng) * (hi - lo).length() * 1e-3;
                (target - o).normalize()
            };
            (o, d)
        })
        .collect()
}

/// Rays where the BVH and brute force disagree (hit/miss or t); also checks the hit count is real.
fn count_disagreements(scene: &Scene, n: usize, seed: u64) -> (usize, usize) {
    let rt = RayTracer::new(scene).unwrap();
    let rays = random_rays(scene, n, seed);
    let results: Vec<(bool, bool)> = rays
        .par_iter()
        .map(|&(o, d)| {
            let bvh = rt.bvh.closest(o, d, 0.0, f32::INFINITY);
            let brute = rt.bvh.closest_brute_force(o, d, 0.0, f32::INFINITY);
            let agree = match (bvh, brute) {
                (None, None) => true,
                (Some(a), Some(b)) => (a.t - b.t).abs() <= T_REL_TOL * b.t,
                _ => false,
            };
            (agree, brute.is_some())
        })
        .collect();
    let disagree = results.iter().filter(|r| !r.0).count();
    let hits = results.iter().filter(|r| r.1).count();
    (disagree, hits)
}

#[test]
fn bvh_matches_brute_force_on_test_scenes() {
    for (name, scene, n) in [
        ("cbox", raytrace_scenes::cbox(true), 100_000),
        ("cbox+spheres", raytrace_scenes::cbox_spheres(), 100_000),
        ("bunny", raytrace_scenes::bunny(), 12_000),
    ] {
        let (disagree, hits) = count_disagreements(&scene, n, 1);
        let agreement = 1.0 - disagree as f64 / n as f64;
        println!("{name}: {n} rays, {hits} hits, {disagree} disagreements, agreement {agreement:.6}");
        assert!(agreement >= MIN_AGREEMENT, "{name}: agreement {agreement}");
        assert!(hits > n / 4, "{name}: only {hits} hits of {n} rays");
    }
}

#[test]
fn loaded_scenes_match_brute_force() {
    use crate::scene::{load_scene, LoadOptions};
    for (name, n) in [("cbox", 20_000), ("cbox-lights", 20_000), ("bunny", 3_000), ("matpreview", 2_000), ("veach-ajar", 3_000)] {
        let scene = load_scene(&crate::testing::scene_file(&format!("{name}/scene.xml")), &LoadOptions::default()).unwrap();
        let spheres = scene.meshes.iter().filter(|m| matches!(m.kind, ShapeKind::Sphere { .. })).count();
        let (disagree, hits) = count_disagreements(&scene, n, 6);
        let agreement = 1.0 - disagree as f64 / n as f64;
        println!("{name} (load_scene, {spheres} spheres): {n} rays, {hits} hits, {disagree} disagreements");
        assert!(agreement >= MIN_AGREEMENT, "{name}: agreement {agreement}");
        assert!(hits > n / 4, "{name}: only {hits} hits of {n} rays");
    }
    // The hand-built test scenes are the same geometry as the XML files.
    let loaded = load_scene(&crate::testing::scene_file("bunny/scene.xml"), &LoadOptions::default()).unwrap();
    let (lo, hi) = (loaded.bounds(), raytrace_scenes::bunny().bounds());
    assert!((lo.0 - hi.0).abs().max_element() < 1e-4 && (lo.1 - hi.1).abs().max_element() < 1e-4, "{lo:?} vs {hi:?}");
}

#[test]
fn sphere_interactions_are_analytic() {
    let (c, r) = (Vec3::new(3.0, -2.0, 1.5), 0.75);
    for flip in [false, true] {
        let rt = RayTracer::new(&raytrace_scenes::scene(vec![raytrace_scenes::sphere(c, r, flip)])).unwrap();
        assert_eq!(rt.num_primitives(), 1, "a sphere is one analytic primitive");
        let mut rng = Pcg32::seed_from_u64(5);
        let mut off_tessellation = 0;
        for _ in 0..20_000 {
            // Aim at a random point on the sphere from outside.
            let target = c + uniform_sphere(&mut rng) * r * 0.999;
            let o = c + uniform_sphere(&mut rng) * r * 4.0;
            let d = target - o;
            let si = rt.intersect(o, d, 0.0, f32::INFINITY).expect("ray aimed at the sphere hits it");
            // Closed-form t in f64.
            let (l, d64) = ((o - c).as_dvec3(), d.as_dvec3());
            let (a, b, cc) = (d64.dot(d64), 2.0 * l.dot(d64), l.dot(l) - (r as f64).powi(2));
            let t_exact = (-b - (b * b - 4.0 * a * cc).sqrt()) / (2.0 * a);
            assert!((si.t as f64 - t_exact).abs() <= 1e-5 * t_exact, "t {} vs {t_exact}", si.t);
            assert!(((si.p - c).length() - r).abs() <= 1e-5 * r);
            let n = (si.p - c) / r;
            let n = if flip { -n } else { n };
            assert!((si.n_g - n).length() < 1e-5 && si.n_g == si.n_s);
            let local = ((si.p - c) / r).as_dvec3();
            let phi = local.y.atan2(local.x).rem_euclid(2.0 * std::f64::consts::PI);
            let uv = (phi / (2.0 * std::f64::consts::PI), local.z.clamp(-1.0, 1.0).acos() / std::f64::consts::PI);
            let du = (si.uv.x as f64 - uv.0).abs();
            assert!(du.min(1.0 - du) < 1e-5 && (si.uv.y as f64 - uv.1).abs() < 1e-5, "uv {} vs {uv:?}", si.uv);
            assert!((si.wi + d.normalize()).length() < 1e-6);
            // Count hits outside the inscribed octahedron (|x|+|y|+|z| > r): the tessellation is unused.
            if (si.p - c).abs().element_sum() > r * 1.01 {
                off_tessellation += 1;
            }
        }
        assert!(off_tessellation > 10_000, "{off_tessellation}");
    }
    // Closed-form case: uv of the +y pole direction is (0.25, 0.5).
    let rt = RayTracer::new(&raytrace_scenes::scene(vec![raytrace_scenes::sphere(Vec3::ZERO, 1.0, false)])).unwrap();
    let si = rt.intersect(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY).unwrap();
    assert_eq!((si.t, si.p, si.n_g), (4.0, Vec3::Y, Vec3::Y));
    assert!((si.uv - Vec2::new(0.25, 0.5)).length() < 1e-6);
}

#[test]
fn triangle_interaction_fields() {
    let mut m = raytrace_scenes::sphere(Vec3::ZERO, 1.0, false);
    m.kind = ShapeKind::Obj;
    m.positions = vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
    m.indices = vec![[0, 1, 2]];
    m.normals = vec![Vec3::Z, Vec3::X, Vec3::Y];
    m.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 4.0)];
    m.face_normals = false;
    let o = Vec3::new(0.5, 1.0, 3.0);
    let si = RayTracer::new(&raytrace_scenes::scene(vec![m.clone()])).unwrap().intersect(o, -Vec3::Z * 2.0, 0.0, 10.0).unwrap();
    // b1 = 0.25, b2 = 0.5, b0 = 0.25.
    assert_eq!((si.t, si.p, si.n_g, si.wi, si.mesh, si.prim), (1.5, Vec3::new(0.5, 1.0, 0.0), Vec3::Z, Vec3::Z, 0, 0));
    assert!((si.n_s - Vec3::new(0.25, 0.5, 0.25).normalize()).length() < 1e-6);
    assert!((si.uv - Vec2::new(0.25, 2.0)).length() < 1e-6);
    m.face_normals = true;
    m.uvs.clear();
    let si = RayTracer::new(&raytrace_scenes::scene(vec![m])).unwrap().intersect(o, -Vec3::Z, 0.0, 10.0).unwrap();
    assert_eq!((si.n_s, si.uv), (Vec3::Z, Vec2::new(0.25, 0.5)));
}

#[test]
fn cbox_floor_sees_the_light_without_self_shadowing() {
    let rt = RayTracer::new(&raytrace_scenes::cbox(false)).unwrap();
    let light = Vec3::new(278.0, 548.3, 279.5);
    let n_light = -Vec3::Y;
    let mut rng = Pcg32::seed_from_u64(3);
    let n = 100_000;
    // Floor points found by ray casting, as a renderer finds them.
    let points: Vec<(Vec3, Vec3)> = (0..n)
        .map(|_| {
            let o = Vec3::new(rng.random::<f32>() * 549.0, 300.0, rng.random::<f32>() * 559.0);
            let si = rt.intersect(o, -Vec3::Y, 0.0, f32::INFINITY).expect("floor below");
            assert_eq!(si.mesh, 1, "hit the floor");
            (si.p, si.n_g)
        })
        .collect();
    let one_sided: Vec<_> = points.iter().map(|&(p, n_g)| (p, n_g, light)).collect();
    let both: Vec<_> = points.iter().map(|&(p, n_g)| (p, n_g, light, n_light)).collect();
    let reverse: Vec<_> = points.iter().map(|&(p, _)| (light, n_light, p)).collect();
    assert_eq!(rt.visible_batch(&one_sided).iter().filter(|v| !**v).count(), 0);
    assert_eq!(rt.visible_between_batch(&both).iter().filter(|v| !**v).count(), 0);
    assert_eq!(rt.visible_batch(&reverse).iter().filter(|v| !**v).count(), 0);
    // Without the offset, a good share of the floor would shadow itself; make sure the test can fail.
    let naive = points.iter().filter(|&&(p, _)| rt.occluded_ray(p, light - p, 1.0)).count();
    println!("cbox floor: {n} points, 0 self-shadowed (naive rays without offset: {naive})");
}

#[test]
fn spawned_rays_do_not_hit_their_own_triangle() {
    let scene = raytrace_scenes::bunny();
    let rt = RayTracer::new(&scene).unwrap();
    let mut rng = Pcg32::seed_from_u64(9);
    let (mut tested, mut self_hits) = (0, 0);
    for (o, d) in random_rays(&scene, 40_000, 2) {
        let Some(si) = rt.intersect(o, d, 0.0, f32::INFINITY) else { continue };
        if si.mesh != 1 {
            continue;
        }
        // Leave the (curved backdrop) plane on the side the ray came from; a hit of the same flat
        // triangle can only be a self-intersection.
        let mut w = uniform_sphere(&mut rng);
        if w.dot(si.n_g) * si.wi.dot(si.n_g) < 0.0 {
            w = -w;
        }
        tested += 1;
        if rt.intersect(spawn_ray(si.p, si.n_g, w), w, 0.0, f32::INFINITY).is_some_and(|h| h.mesh == 1 && h.prim == si.prim) {
            self_hits += 1;
        }
    }
    println!("bunny plane: {tested} spawned rays, {self_hits} hit their own triangle");
    assert!(tested > 5_000, "{tested}");
    assert_eq!(self_hits, 0);
}

#[test]
fn occlusion_is_symmetric_and_consistent_with_closest_hits() {
    let scene = raytrace_scenes::cbox_spheres();
    let rt = RayTracer::new(&scene).unwrap();
    let hits: Vec<SurfaceInteraction> = rt.intersect_batch(&random_rays(&scene, 40_000, 4)).into_iter().flatten().collect();
    let pairs: Vec<_> = hits.chunks_exact(2).map(|h| (h[0].p, h[0].n_g, h[1].p, h[1].n_g)).collect();
    let forward = rt.visible_between_batch(&pairs);
    let swapped: Vec<_> = pairs.iter().map(|&(p, np, q, nq)| (q, nq, p, np)).collect();
    assert_eq!(forward, rt.visible_between_batch(&swapped), "occluded_between is exactly symmetric");
    let visible = forward.iter().filter(|v| **v).count();
    assert!(visible > pairs.len() / 10 && visible < pairs.len() * 9 / 10, "{visible} of {}", pairs.len());
    // The one-sided Mitsuba form from either end agrees almost always (for pairs that are not
    // coplanar or grazing, where the result is immaterial: both cosines vanish).
    let facing: Vec<_> = pairs
        .iter()
        .copied()
        .filter(|&(p, np, q, nq)| {
            let w = (q - p).normalize();
            np.dot(w).abs() > GRAZING_COS && nq.dot(w).abs() > GRAZING_COS
        })
        .collect();
    let ab: Vec<_> = facing.iter().map(|&(p, np, q, _)| (p, np, q)).collect();
    let ba: Vec<_> = facing.iter().map(|&(p, _, q, nq)| (q, nq, p)).collect();
    let (vab, vba) = (rt.visible_batch(&ab), rt.visible_batch(&ba));
    let differ = vab.iter().zip(&vba).filter(|(a, b)| a != b).count();
    println!(
        "occlusion: {} pairs, {visible} visible; one-sided a->b vs b->a differ on {differ} of {} non-grazing",
        pairs.len(),
        facing.len()
    );
    // They differ where an occluder lies within `SHADOW_EPSILON * dist` of the endpoint that is not
    // offset (corners such as floor/box edges): Mitsuba's one-sided form skips it from one end only.
    assert!(differ as f64 <= ONE_SIDED_ASYMMETRY * facing.len() as f64);
    // A point and the first hit of a ray spawned from it see each other.
    let mut rng = Pcg32::seed_from_u64(8);
    let (mut n, mut blocked) = (0, 0);
    for si in &hits {
        let mut w = uniform_sphere(&mut rng);
        if w.dot(si.n_g) * si.wi.dot(si.n_g) < 0.0 {
            w = -w;
        }
        if let Some(next) = rt.intersect(spawn_ray(si.p, si.n_g, w), w, 0.0, f32::INFINITY) {
            n += 1;
            blocked += rt.occluded_between(si.p, si.n_g, next.p, next.n_g) as usize;
        }
    }
    println!("occlusion: {n} spawned rays, first hit reported occluded for {blocked}");
    assert!(n > 10_000 && blocked as f64 <= 1e-3 * n as f64);
}

#[test]
fn invalid_meshes_are_errors() {
    let mut s = raytrace_scenes::scene(vec![raytrace_scenes::sphere(Vec3::ZERO, 1.0, false)]);
    s.meshes[0].kind = ShapeKind::Obj;
    s.meshes[0].indices[3] = [0, 1, 6];
    let msg = RayTracer::new(&s).err().expect("bad index").to_string();
    assert!(msg.contains("triangle 3 has vertex indices [0, 1, 6], but the mesh has 6 vertices"), "{msg}");
    let s = raytrace_scenes::scene(vec![raytrace_scenes::sphere(Vec3::ZERO, -1.0, false)]);
    let msg = RayTracer::new(&s).err().expect("bad radius").to_string();
    assert!(msg.contains("radius > 0, got center [0, 0, 0], radius -1"), "{msg}");
    // An empty scene and degenerate rays are fine.
    let rt = RayTracer::new(&raytrace_scenes::scene(vec![])).unwrap();
    assert!(rt.intersect(Vec3::ZERO, Vec3::X, 0.0, 1.0).is_none() && !rt.occluded(Vec3::ZERO, Vec3::Y, Vec3::X));
    let rt = RayTracer::new(&raytrace_scenes::cbox(true)).unwrap();
    assert!(rt.intersect(Vec3::splat(200.0), Vec3::ZERO, 0.0, f32::INFINITY).is_none());
    assert!(rt.intersect(Vec3::splat(200.0), Vec3::new(f32::NAN, 0.0, 1.0), 0.0, f32::INFINITY).is_none());
}

/// Rays per second on the bunny scene (camera rays of bunny/scene.xml at 960x720 and shadow rays
/// to a point above); run with `cargo test --release raytrace -- --ignored --nocapture`.
#[test]
#[ignore]
fn benchmark_bunny() {
    let scene = raytrace_scenes::bunny();
    let t0 = std::time::Instant::now();
    let rt = RayTracer::new(&scene).unwrap();
    println!("bunny: {} primitives, BVH build {:.1} ms", rt.num_primitives(), t0.elapsed().as_secs_f64() * 1e3);
    // Camera of bunny/scene.xml: lookat, fov 28.8415 on the smaller (vertical) axis, 960x720.
    let (origin, target, up) =
        (Vec3::new(3.69558, -3.46243, 3.25463), Vec3::new(3.04072, -2.85176, 2.80939), Vec3::new(-0.317366, 0.312466, 0.895346));
    let dir = (target - origin).normalize();
    let left = up.cross(dir).normalize();
    let up = dir.cross(left);
    let (w, h) = (960u32, 720u32);
    let ty = (28.8415f32.to_radians() * 0.5).tan();
    let tx = ty * w as f32 / h as f32;
    let rays: Vec<(Vec3, Vec3)> = (0..w * h)
        .map(|k| {
            let (px, py) = ((k % w) as f32 + 0.5, (k / w) as f32 + 0.5);
            let (x, y) = ((1.0 - 2.0 * px / w as f32) * tx, (1.0 - 2.0 * py / h as f32) * ty);
            (origin, (left * x + up * y + dir).normalize())
        })
        .collect();
    let hits = rt.intersect_batch(&rays);
    let bunny_hits = hits.iter().flatten().filter(|s| s.mesh == 0).count();
    println!("camera rays: {} of {} hit ({} on the bunny)", hits.iter().flatten().count(), rays.len(), bunny_hits);
    let light = Vec3::new(0.0, 0.0, 6.0);
    let shadow: Vec<(Vec3, Vec3, Vec3)> = hits.iter().flatten().map(|s| (s.p, s.n_g, light)).collect();

    let time = |label: &str, count: usize, f: &dyn Fn()| {
        let t0 = std::time::Instant::now();
        f();
        let s = t0.elapsed().as_secs_f64();
        println!("{label}: {:.2} Mrays/s ({count} rays in {s:.3} s)", count as f64 / s / 1e6);
    };
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let threads = rayon::current_num_threads();
    single.install(|| time("closest hit, 1 thread", rays.len(), &|| drop(rt.intersect_batch(&rays))));
    time(&format!("closest hit, {threads} threads"), rays.len(), &|| drop(rt.intersect_batch(&rays)));
    single.install(|| time("shadow rays, 1 thread", shadow.len(), &|| drop(rt.visible_batch(&shadow))));
    time(&format!("shadow rays, {threads} threads"), shadow.len(), &|| drop(rt.visible_batch(&shadow)));
}

/// Shadow rays for the traversal comparison: `random_rays` with `t_max` infinite, beyond and before
/// their first hit; rays aimed exactly at vertices and at points of edges (shared by two triangles in a
/// mesh) with `t_max` at, before and past the target; and `spawn_ray_to` segments between surface points.
fn shadow_test_rays(rt: &RayTracer, scene: &Scene, n: usize, seed: u64) -> Vec<(Vec3, Vec3, f32)> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let mut rays = Vec::new();
    for (o, d) in random_rays(scene, n, seed) {
        let t_hit = rt.bvh.closest(o, d, 0.0, f32::INFINITY).map_or(1.0, |h| h.t);
        rays.push((o, d, f32::INFINITY));
        rays.push((o, d, t_hit * (1.0 + 1e-6)));
        rays.push((o, d, t_hit * (1.0 - 1e-6)));
    }
    let (lo, hi) = scene.bounds();
    let tris: Vec<[Vec3; 3]> = rt
        .bvh
        .primitives
        .iter()
        .filter_map(|p| match p.geometry {
            Geometry::Triangle(v) => Some(v),
            Geometry::Sphere { .. } => None,
        })
        .collect();
    for _ in 0..n {
        let [p0, p1, p2] = tris[rng.random_range(0..tris.len())];
        let s = [0.0, 0.5, rng.random::<f32>()][rng.random_range(0..3)];
        let target = if rng.random::<bool>() { [p0, p1, p2][rng.random_range(0..3)] } else { p0 + (p1 - p0) * s };
        let o = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random()) * 1.2 - (hi - lo) * 0.1;
        let d = target - o;
        for t_max in [1.0, 1.0 - SHADOW_EPSILON, 1.0 + SHADOW_EPSILON, f32::INFINITY] {
            rays.push((o, d, t_max));
        }
    }
    let surface: Vec<SurfaceInteraction> =
        random_rays(scene, n, seed + 1).iter().filter_map(|&(o, d)| rt.intersect(o, d, 0.0, f32::INFINITY)).collect();
    for pair in surface.windows(2) {
        rays.push(spawn_ray_to(pair[0].p, pair[0].n_g, pair[1].p));
    }
    rays
}

#[test]
fn shadow_traversal_answers_as_the_reference_bit_for_bit() {
    use crate::scene::{load_scene, LoadOptions};
    let veach = load_scene(&crate::testing::scene_file("veach-ajar/scene.xml"), &LoadOptions::default()).unwrap();
    for (name, scene, n) in [
        ("cbox", raytrace_scenes::cbox(true), 20_000),
        ("cbox+spheres", raytrace_scenes::cbox_spheres(), 20_000),
        ("veach-ajar", veach, 4_000),
        ("bunny", raytrace_scenes::bunny(), 2_000),
    ] {
        let rt = RayTracer::new(&scene).unwrap();
        let rays = shadow_test_rays(&rt, &scene, n, 11);
        let results: Vec<(bool, bool, Option<bool>)> = rays
            .par_iter()
            .map(|&(o, d, t_max)| {
                #[cfg(target_arch = "x86_64")]
                let sse = rt.bvh.any_sse(o, d, 0.0, t_max);
                #[cfg(not(target_arch = "x86_64"))]
                let sse = None;
                (rt.occluded_ray(o, d, t_max), rt.occluded_ray_reference(o, d, t_max), sse)
            })
            .collect();
        // The traversal answers as the brute force does on every ray. The reference can differ: within 2e-4
        // of the origin it traces a shifted ray (`bvh::OBVHS_BOX_T_MIN`) whose rounding can flip a hit at the
        // end of a short segment, and its box test is not widened (`occlusion::BOX_T_MAX_SCALE`,
        // `SLAB_SLACK`), so it misses rays through the edge where two faces meet and hits just before `t_max`.
        let exact = |k: usize, ours: bool| {
            let (o, d, t_max) = rays[k];
            rt.bvh.closest_brute_force(o, d, crate::raytrace::bvh::t_floor(o, d, 0.0), t_max).is_some() == ours
        };
        let differ = results.iter().enumerate().filter(|(k, r)| !exact(*k, r.0)).count();
        let sse_differ = results.iter().enumerate().filter(|(k, r)| r.2.is_some_and(|s| !exact(*k, s))).count();
        let edges = results.iter().filter(|r| r.0 != r.1).count();
        println!("{name}: {edges} answers differ from the reference, each as the brute force answers");
        let blocked = results.iter().filter(|r| r.1).count();
        println!("{name}: {} rays, {blocked} blocked, {differ} differ, {sse_differ} differ on SSE2", rays.len());
        assert_eq!((differ, sse_differ), (0, 0), "{name}");
        assert!(cfg!(not(target_arch = "x86_64")) || results.iter().all(|r| r.2.is_some()), "{name}: stack overflow");
        assert!(blocked > rays.len() / 5 && blocked < rays.len() * 4 / 5, "{name}: {blocked} of {} blocked", rays.len());
    }
}

/// A primitive closer than 1e-4 to the origin is hit: obvhs's traversal enters no child box before
/// t = 1e-4, and a wall point 0.1 mm above the window room's floor saw the sky under it (4.7x too bright
/// against Mitsuba). Shadow rays (`any`), the reference traversal and closest hits, down to 1e-5 (the
/// floor of every query is `(1 + max |o|) 2^-20`, 4.7e-6 here, as on the GPU).
#[test]
fn hits_closer_than_obvhs_box_clamp_are_found() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/window-room/scene.xml");
    let scene = crate::scene::load_scene(&path, &Default::default()).unwrap();
    let rt = RayTracer::new(&scene).unwrap();
    for y in [1e-3f32, 2e-4, 1e-4, 8.4543914e-5, 3e-5, 1e-5] {
        for d in [Vec3::new(0.0, -1.0, 0.0), Vec3::new(-3.8222453e-4, -0.88923794, -0.45744503).normalize()] {
            let o = Vec3::new(1.9995593, y, 3.9292707);
            let brute = rt.bvh.closest_brute_force(o, d, 0.0, f32::INFINITY).unwrap();
            assert!(rt.bvh.any(o, d, 0.0, f32::INFINITY), "any: {o} {d}");
            assert!(rt.bvh.any_reference(o, d, 0.0, f32::INFINITY), "any_reference: {o} {d}");
            let hit = rt.bvh.closest(o, d, 0.0, f32::INFINITY).unwrap_or_else(|| panic!("closest: {o} {d}"));
            assert_eq!(hit.index, brute.index, "{o} {d}");
            assert!((hit.t - brute.t).abs() <= 1e-6 * (1.0 + brute.t), "{o} {d}: t {} vs {}", hit.t, brute.t);
            // A t_max before the floor: nothing.
            assert!(!rt.bvh.any(o, d, 0.0, 0.5 * brute.t), "{o} {d}");
            assert!(rt.bvh.closest(o, d, 0.0, 0.5 * brute.t).is_none(), "{o} {d}");
        }
    }
}

/// Mitsuba's `cube` shape alone ([-1, 1]^3, 12 triangles), as a ray tracer.
fn closed_cube() -> RayTracer {
    let dir = std::env::temp_dir().join(format!("ml-cube-edge-{}-{:?}", std::process::id(), std::thread::current().id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cube.xml");
    std::fs::write(
        &path,
        r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
        <shape type="cube"><bsdf type="diffuse"/></shape></scene>"#,
    )
    .unwrap();
    RayTracer::new(&crate::scene::load_scene(&path, &Default::default()).unwrap()).unwrap()
}

/// `n` origins inside `closed_cube` (uniform in [-0.8, 0.8]^3), each with a point on one of the cube's 12
/// edges (two coordinates at +-1), from stream `seed`.
fn cube_edge_points(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = crate::lights::generate::sampling::stream(5, seed, 0);
    let mut u = || crate::lights::generate::sampling::uniform(&mut rng);
    (0..n)
        .map(|k| {
            let o = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 1.6;
            let (a, b) = ((k % 3), (k % 3 + 1) % 3);
            let mut p = Vec3::splat(2.0 * u() - 1.0);
            p[a] = if u() < 0.5 { -1.0 } else { 1.0 };
            p[b] = if u() < 0.5 { -1.0 } else { 1.0 };
            (o, p)
        })
        .collect()
}

/// A ray through the exact edge where two faces of a closed cube meet is blocked (every ray from inside
/// must be): the box test's exit distance is widened by a few ulps (`occlusion::BOX_T_MAX_SCALE`), as the
/// float slab test can put the entry a rounding step past the exit for both faces' flat boxes. Rays from
/// inside through the edges, on them and 1e-7 off them.
#[test]
fn rays_through_cube_edges_are_blocked() {
    let rt = closed_cube();
    let o = Vec3::new(-0.44, 0.06, -0.02);
    let d = Vec3::new(0.629_365_8, 0.526_632_1, 0.571_451_9);
    assert!(rt.occluded_ray(o, d, 10.0), "the reported ray");
    let mut leaks = 0;
    for (k, (o, p)) in cube_edge_points(20_000, 99).into_iter().enumerate() {
        // Through the edge point, nudged by 0 or 1e-7.
        let nudge = if k % 2 == 0 { 0.0 } else { 1e-7 };
        let d = (p - o + Vec3::splat(nudge)).normalize();
        if !rt.occluded_ray(o, d, 10.0) {
            leaks += 1;
        }
    }
    assert_eq!(leaks, 0, "{leaks} of 20,000 rays left the closed cube through an edge");
}

/// Closest hits through `occlusion.rs`'s traversal are the brute force's: the same primitive (among equal t,
/// as on a shared edge or vertex, the lowest index), t and barycentrics bit for bit, on random,
/// vertex-aimed, edge-aimed and surface-to-surface rays of five scenes. obvhs's traversal (the fallback)
/// differs in t on some (printed).
#[test]
fn closest_hits_are_the_brute_force_hits() {
    use crate::scene::{load_scene, LoadOptions};
    let load = |name: &str| load_scene(&crate::testing::scene_file(&format!("{name}/scene.xml")), &LoadOptions::default()).unwrap();
    for (name, scene, n) in [
        ("cbox", raytrace_scenes::cbox(true), 20_000),
        ("cbox+spheres", raytrace_scenes::cbox_spheres(), 20_000),
        ("veach-ajar", load("veach-ajar"), 4_000),
        ("matpreview", load("matpreview"), 2_000),
        ("bunny", raytrace_scenes::bunny(), 2_000),
    ] {
        let rt = RayTracer::new(&scene).unwrap();
        let rays = shadow_test_rays(&rt, &scene, n, 21);
        let results: Vec<(bool, bool, bool)> = rays
            .par_iter()
            .map(|&(o, d, t_max)| {
                let brute = rt.bvh.closest_brute_force(o, d, crate::raytrace::bvh::t_floor(o, d, 0.0), t_max);
                let same = |h: Option<bvh::PrimitiveHit>| match (h, brute) {
                    (None, None) => true,
                    (Some(a), Some(b)) => a == b,
                    _ => false,
                };
                let ours = rt.bvh.closest(o, d, 0.0, t_max);
                let reference = rt.bvh.closest_reference(o, d, 0.0, t_max);
                (same(ours), reference.map(|h| h.t) == brute.map(|h| h.t), brute.is_some())
            })
            .collect();
        let differ = results.iter().filter(|r| !r.0).count();
        let reference_differ = results.iter().filter(|r| !r.1).count();
        let hits = results.iter().filter(|r| r.2).count();
        println!("{name}: {} rays, {hits} hit, {differ} differ from the brute force ({reference_differ} through obvhs)", rays.len());
        assert_eq!(differ, 0, "{name}");
        assert!(hits > rays.len() / 5, "{name}: {hits} hits of {}", rays.len());
    }
}

/// A camera or bounce ray from inside a closed cube through the exact edge where two faces meet hits one
/// of them (the closest-hit twin of `rays_through_cube_edges_are_blocked`).
#[test]
fn closest_hits_through_cube_edges_are_found() {
    let rt = closed_cube();
    let (mut leaks, mut reference_leaks) = (0, 0);
    for (o, p) in cube_edge_points(20_000, 98) {
        let d = (p - o).normalize();
        match rt.intersect(o, d, 0.0, f32::INFINITY) {
            None => leaks += 1,
            Some(si) => assert!((si.p - p).abs().max_element() < 1e-5, "{o} {d}: hit {} for {p}", si.p),
        }
        reference_leaks += rt.bvh.closest_reference(o, d, 0.0, f32::INFINITY).is_none() as usize;
    }
    println!("{reference_leaks} of 20,000 rays left the cube through obvhs's traversal");
    assert_eq!(leaks, 0, "{leaks} of 20,000 rays left the closed cube through an edge");
}

mod packets;
