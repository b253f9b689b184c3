//! GPU shadow rays (`OccludedPass`) against the CPU `RayTracer` on the shared scenes.
use super::*;
use crate::raytrace::{offset_p, RayTracer};
use crate::scene::{load_scene, LoadOptions};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// Required GPU vs CPU agreement on random segments (the brief's acceptance: 99.99%).
const MIN_AGREEMENT: f64 = 0.9999;
/// Queries per scene.
const NUM_QUERIES: usize = 120_000;

pub(crate) fn load_shared(name: &str) -> Scene {
    let path = crate::testing::scene_file(&format!("{name}/scene.xml"));
    load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn struct_sizes_and_wgsl() {
    assert_eq!(std::mem::size_of::<GpuBvhNode>(), 32);
    assert_eq!(std::mem::size_of::<GpuPrimitive>(), 48);
    assert_eq!(std::mem::size_of::<OcclusionQuery>(), 48);
    let module = crate::gpu::shaders::validate_wgsl("occluded.wgsl", shaders::OCCLUDED).unwrap();
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    for (name, size) in [("BvhNode", 32), ("BvhPrim", 48), ("OcclusionQuery", 48)] {
        let (h, _) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).expect(name);
        assert_eq!(layouter[h].size, size, "{name}");
    }
    assert!(RAYS_PER_INVOCATION >= 16 && INVOCATION_BUDGET + 1024 < 65_535);
    for (rust, wgsl) in [
        (MAX_RAY_STEPS, "const BVH_MAX_RAY_STEPS: u32 = 2048u;"),
        (INVOCATION_BUDGET, "const BVH_INVOCATION_BUDGET: u32 = 61440u;"),
        (STACK_SIZE, "const BVH_STACK_SIZE: u32 = 48u;"),
    ] {
        assert!(shaders::OCCLUDED.contains(wgsl) && wgsl.contains(&format!(" {rust}u;")), "{wgsl}");
    }
    // The WGSL literals are Mitsuba's epsilons exactly.
    assert_eq!(8.940696716308594e-5_f32, crate::raytrace::RAY_EPSILON);
    assert_eq!(8.940696716308594e-4_f32, crate::raytrace::SHADOW_EPSILON);
    assert!(shaders::OCCLUDED.contains("const RAY_EPSILON: f32 = 8.940696716308594e-5;"));
    assert!(shaders::OCCLUDED.contains("const SHADOW_EPSILON: f32 = 8.940696716308594e-4;"));
}

/// Random queries of four kinds: free segments between points of the (enlarged) bounds, shadow rays from
/// surface points (found by casting random rays) to points of the bounds, to other surface points and to
/// vertices, and unbounded rays from surface points.
fn random_queries(scene: &Scene, tracer: &RayTracer, n: usize, seed: u64) -> Vec<OcclusionQuery> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let (lo, hi) = scene.bounds();
    let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.55);
    let verts: Vec<Vec3> = scene.meshes.iter().flat_map(|m| m.positions.iter().copied()).collect();
    let point = |rng: &mut Pcg32| {
        c + h * Vec3::new(rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0)
    };
    let unit = |rng: &mut Pcg32| loop {
        let v = Vec3::new(rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0);
        if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
            break v.normalize();
        }
    };
    let surface = |rng: &mut Pcg32| loop {
        let o = point(rng);
        let d = unit(rng);
        if let Some(si) = tracer.intersect(o, d, 0.0, f32::INFINITY) {
            break (si.p, si.n_g);
        }
    };
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        out.push(match k % 5 {
            0 => {
                let (a, b) = (point(&mut rng), point(&mut rng));
                let d = (b - a).normalize();
                OcclusionQuery::ray(a, d, (b - a).length())
            }
            1 => {
                let (p, n_g) = surface(&mut rng);
                OcclusionQuery::to_point(p, n_g, point(&mut rng))
            }
            2 => {
                let ((p, n_p), (q, _)) = (surface(&mut rng), surface(&mut rng));
                OcclusionQuery::to_point(p, n_p, q)
            }
            3 => {
                let (p, n_g) = surface(&mut rng);
                OcclusionQuery::to_point(p, n_g, verts[rng.random_range(0..verts.len())] + unit(&mut rng) * 1e-3 * h.length())
            }
            _ => {
                let (p, n_g) = surface(&mut rng);
                OcclusionQuery::direction(p, n_g, unit(&mut rng))
            }
        });
    }
    out
}

fn cpu_occluded(tracer: &RayTracer, q: &OcclusionQuery) -> bool {
    let (p, v, t) = (Vec3::from_array(q.p), Vec3::from_array(q.v), Vec3::from_array(q.q));
    match q.mode {
        QUERY_RAY => tracer.occluded_ray(p, v, q.t_max),
        QUERY_TO_POINT => tracer.occluded(p, v, t),
        _ => tracer.occluded_ray(offset_p(p, t, v), v, f32::INFINITY),
    }
}

#[test]
fn gpu_occluded_matches_cpu_ray_tracer_on_shared_scenes() {
    let ctx = crate::testing::gpu_context();
    let pass = OccludedPass::new(&ctx.device);
    let max_binding = ctx.limits.max_storage_buffer_binding_size as u64;
    for (k, name) in ["cbox-lights", "veach-ajar", "bunny"].iter().enumerate() {
        let scene = load_shared(name);
        let tracer = RayTracer::new(&scene).unwrap();
        let bvh = GpuBvh::upload(&ctx.device, &scene, max_binding).unwrap();
        assert_eq!(bvh.num_primitives as usize, tracer.num_primitives());
        let queries = random_queries(&scene, &tracer, NUM_QUERIES, 17 + k as u64);
        let t = std::time::Instant::now();
        let gpu = pass.run(&ctx, &bvh, &queries).unwrap();
        let gpu_ms = t.elapsed().as_secs_f64() * 1e3;
        let cpu: Vec<bool> = queries.iter().map(|q| cpu_occluded(&tracer, q)).collect();
        let gave_up = gpu.iter().filter(|r| r.gave_up).count();
        let agree = gpu.iter().zip(&cpu).filter(|(g, &c)| g.occluded == c).count();
        let blocked = cpu.iter().filter(|&&c| c).count();
        let max_steps = gpu.iter().map(|r| r.steps).max().unwrap();
        let mean_steps = gpu.iter().map(|r| r.steps as f64).sum::<f64>() / gpu.len() as f64;
        eprintln!(
            "{name}: {} prims, depth {}, {agree}/{} agree ({:.4}%), {blocked} occluded, {gave_up} gave up, \
             steps mean {mean_steps:.1} max {max_steps}, GPU {gpu_ms:.0} ms",
            bvh.num_primitives,
            bvh.depth,
            queries.len(),
            100.0 * agree as f64 / queries.len() as f64
        );
        for (q, (g, c)) in queries.iter().zip(gpu.iter().zip(&cpu)).filter(|(_, (g, &c))| g.occluded != c).take(5) {
            eprintln!("  mismatch {q:?}: gpu {g:?} cpu {c}");
        }
        assert_eq!(gave_up, 0, "{name}: rays ran out of steps");
        assert!(blocked > queries.len() / 10 && blocked < queries.len() * 9 / 10, "{name}: {blocked} blocked");
        assert!(agree as f64 >= MIN_AGREEMENT * queries.len() as f64, "{name}: {agree}/{}", queries.len());
    }
}

#[test]
fn empty_scene_blocks_nothing() {
    let ctx = crate::testing::gpu_context();
    let mut scene = load_shared("cbox-lights");
    scene.meshes.clear();
    let bvh = GpuBvh::upload(&ctx.device, &scene, 1 << 27).unwrap();
    let r = OccludedPass::new(&ctx.device).run(&ctx, &bvh, &[OcclusionQuery::ray(Vec3::ZERO, Vec3::X, 10.0)]).unwrap();
    assert_eq!(r[0], OcclusionResult { occluded: false, gave_up: false, steps: 1 });
}

/// Shadow rays from the wall/ceiling contact edge of cbox-lights (pixel (115, 12) at 128^2; the G-buffer
/// puts p on the wall, Mitsuba on the ceiling): the origin lies exactly in the ceiling's plane. Mitsuba
/// 3.9.1 and the CPU tracer say free; so must the GPU (it needed the t_min of `hit_triangle`).
#[test]
fn contact_edge_rays_are_free() {
    let ctx = crate::testing::gpu_context();
    let scene = load_shared("cbox-lights");
    let tracer = RayTracer::new(&scene).unwrap();
    let bvh = GpuBvh::upload(&ctx.device, &scene, 1 << 27).unwrap();
    let lights = crate::lights::LightSet::from_scene(&scene).unwrap();
    let q = lights.position[0];
    let cases =
        [(Vec3::new(1.0, 1.0, 0.8998124), Vec3::new(-1.0, 0.0, 0.0)), (Vec3::new(0.99999964, 1.0, 0.89981294), Vec3::new(0.0, -1.0, 0.0))];
    let qs: Vec<OcclusionQuery> = cases.iter().map(|&(p, n)| OcclusionQuery::to_point(p, n, q)).collect();
    let gpu = OccludedPass::new(&ctx.device).run(&ctx, &bvh, &qs).unwrap();
    for ((p, n), g) in cases.iter().zip(gpu) {
        assert!(!tracer.occluded(*p, *n, q) && !g.occluded && !g.gave_up, "p {p} n {n}: gpu {g:?}");
    }
}

#[test]
fn split_dispatches_give_identical_results() {
    // A tiny ray budget sends 3,000 queries out in dispatches of 64: the same hits and the same steps.
    let ctx = crate::testing::gpu_context();
    let scene = load_shared("cbox-lights");
    let tracer = RayTracer::new(&scene).unwrap();
    let bvh = GpuBvh::upload(&ctx.device, &scene, 1 << 27).unwrap();
    let queries = random_queries(&scene, &tracer, 3000, 5);
    let pass = OccludedPass::new(&ctx.device);
    let whole = pass.run(&ctx, &bvh, &queries).unwrap();
    let split = crate::gpu::dispatch::with_budget(64, || pass.run(&ctx, &bvh, &queries)).unwrap();
    assert_eq!(crate::gpu::dispatch::with_budget(64, || crate::gpu::dispatch::plan_rays(3000, &crate::gpu::dispatch::budget())).len(), 47);
    assert_eq!(split, whole);
    let blocked = whole.iter().filter(|r| r.occluded).count();
    assert!(blocked > 300 && blocked < 2700, "{blocked} of 3000 blocked");
}
