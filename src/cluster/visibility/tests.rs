//! Clustered visibility against the brute-force light matrix (singleton clusters: equal), against
//! explicit single rays (every matrix entry), GPU against CPU, and the representatives' definitions.
use super::*;
use crate::lights::{generate_lights, GenerateOptions};
use crate::matrix::{ColumnOptions, LightMatrix, Visibility};
use crate::raytrace::spawn_ray;
use crate::scene::{load_scene, LoadOptions};
use std::sync::Arc;

use crate::testing::backend_pair as pair;

fn finite_or_zero(v: Vec3) -> [f32; 3] {
    if v.is_finite() {
        v.to_array()
    } else {
        [0.0; 3]
    }
}

/// Every light its own label, centroid = its position.
fn light_singletons(lights: &LightSet) -> LightClustering {
    LightClustering {
        assignment: (0..lights.len() as u32).collect(),
        centroids: lights.position.iter().map(|&p| finite_or_zero(p)).collect(),
    }
}

/// Every view sample its own cluster, F = 1.
fn view_singletons(view: &ViewSamples) -> ViewClustering {
    let m = view.len();
    ViewClustering {
        centroids: view.position.iter().map(|&p| finite_or_zero(p)).collect(),
        normals: view.normal.iter().map(|&n| finite_or_zero(n)).collect(),
        membership: Membership { f: 1, clusters: (0..m as u32).collect(), weights: vec![1.0; m] },
    }
}

/// View clusters = square pixel blocks of `block` (centroid: mean surface position), each sample in its
/// `f` nearest centroids with the paper's normalised inverse-distance weights (Eq. 10).
fn view_blocks(view: &ViewSamples, block: u32, f: usize) -> ViewClustering {
    let (w, h) = (view.width, view.height);
    let (bw, bh) = (w.div_ceil(block), h.div_ceil(block));
    let k = (bw * bh) as usize;
    let (mut sum, mut nsum, mut count) = (vec![Vec3::ZERO; k], vec![Vec3::ZERO; k], vec![0f32; k]);
    let label = |i: usize| ((i as u32 / w) / block * bw + (i as u32 % w) / block) as usize;
    for i in 0..view.num_pixels() {
        if view.shape_index[i] >= 0 {
            sum[label(i)] += view.position[i];
            nsum[label(i)] += view.normal[i];
            count[label(i)] += 1.0;
        }
    }
    let centroids: Vec<Vec3> = (0..k).map(|c| if count[c] > 0.0 { sum[c] / count[c] } else { Vec3::splat(1e6) }).collect();
    let mut clusters = Vec::new();
    let mut weights = Vec::new();
    for i in 0..view.len() {
        let p = if view.position[i].is_finite() { view.position[i] } else { Vec3::ZERO };
        let mut d: Vec<(f32, usize)> = centroids.iter().enumerate().map(|(c, q)| ((p - *q).length(), c)).collect();
        d.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let inv: Vec<f32> = d[..f].iter().map(|&(x, _)| 1.0 / x.max(1e-6)).collect();
        let s: f32 = inv.iter().sum();
        clusters.extend(d[..f].iter().map(|&(_, c)| c as u32));
        weights.extend(inv.iter().map(|x| x / s));
    }
    ViewClustering {
        centroids: centroids.iter().map(|c| c.to_array()).collect(),
        normals: nsum.iter().map(|n| n.normalize_or_zero().to_array()).collect(),
        membership: Membership { f, clusters, weights },
    }
}

/// Lights labelled by a 3x3x3 grid over the scene's bounds (directional lights: label 0).
fn light_grid(lights: &LightSet) -> LightClustering {
    let (lo, hi) = lights.position.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &p| (a.min(p), b.max(p)));
    let cell = |p: Vec3| {
        let t = ((p - lo) / (hi - lo).max(Vec3::splat(1e-6)) * 3.0).floor().clamp(Vec3::ZERO, Vec3::splat(2.0));
        (t.x as u32) * 9 + (t.y as u32) * 3 + t.z as u32
    };
    let assignment: Vec<u32> = lights.position.iter().map(|&p| cell(p)).collect();
    let mut sum = [Vec3::ZERO; 27];
    let mut n = [0f32; 27];
    for (j, &a) in assignment.iter().enumerate() {
        sum[a as usize] += lights.position[j];
        n[a as usize] += 1.0;
    }
    LightClustering { assignment, centroids: (0..27).map(|c| (sum[c] / n[c].max(1.0)).to_array()).collect() }
}

fn rel_l2(a: &[f32], b: &[f32]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
    let den: f64 = b.iter().map(|y| (*y as f64).powi(2)).sum();
    (num / den).sqrt()
}

#[test]
fn singleton_clusters_equal_brute_force_on_both_backends() {
    let p = pair(20);
    let lc = light_singletons(&p.cpu.lights);
    let vc = view_singletons(&p.cpu.view);
    for a in [&p.cpu, &p.gpu] {
        let brute = a.column_sum(None, &mut |_, _| {}).unwrap();
        assert!(brute.iter().any(|&v| v > 0.0));
        let (job, out) = a.clustered_shading(&lc, &vc).unwrap();
        assert_eq!(job.lights.len(), a.lights.len());
        assert_eq!(job.lights.representative, (0..a.lights.len()).collect::<Vec<_>>());
        let surface = (0..a.view.len()).filter(|&i| a.view.shape_index[i] >= 0).count() as u64;
        assert_eq!(out.rays, surface * a.lights.len() as u64);
        assert_eq!(out.gave_up, 0);
        let e = rel_l2(&out.image, &brute);
        eprintln!("{} singletons: relative L2 {e}", a.device().kind);
        assert!(e < 1e-5, "{}: relative L2 against brute force {e}", a.device().kind);
    }
}

#[test]
fn visibility_matrix_entries_are_single_rays_and_backends_agree() {
    let p = pair(20);
    let lc = light_grid(&p.cpu.lights);
    let vc = view_blocks(&p.cpu.view, 4, 3);
    let (job, cpu) = p.cpu.clustered_shading(&lc, &vc).unwrap();
    let (_, gpu) = p.gpu.clustered_shading(&lc, &vc).unwrap();
    let (view, lights) = (&p.cpu.view, &job.lights.lights);
    let mut visible = 0;
    for (k, rep) in job.view_reps.sample.iter().enumerate() {
        for c in 0..lights.len() {
            let expected = match rep {
                None => false,
                Some(i) => {
                    let (q, n_g) = (view.position[*i], view.geo_normal[*i]);
                    if lights.kind[c] == LightKind::Directional {
                        let wo = -lights.direction[c];
                        !p.tracer.occluded_ray(spawn_ray(q, n_g, wo), wo, f32::INFINITY)
                    } else {
                        !p.tracer.occluded(q, n_g, lights.position[c])
                    }
                }
            };
            assert_eq!(cpu.visibility.get(k, c), expected, "CPU entry ({k}, {c})");
            assert_eq!(gpu.visibility.get(k, c), expected, "GPU entry ({k}, {c})");
            visible += expected as usize;
        }
    }
    // Both outcomes occur (the walls and the box block some pairs).
    let total = job.view_reps.sample.iter().flatten().count() * lights.len();
    assert!(visible > total / 10 && visible < total, "{visible} of {total} pairs visible");
    assert_eq!(cpu.rays, total as u64);
    assert_eq!(gpu.gave_up, 0);
    let e = rel_l2(&gpu.image, &cpu.image);
    assert!(e < 1e-5, "GPU against CPU: relative L2 {e}");
}

#[test]
fn cluster_lights_are_the_nearest_member_with_the_summed_intensity_split_by_kind() {
    let mut set = LightSet::new(Vec3::ZERO, 10.0);
    set.push_point(Vec3::new(0.0, 0.0, 0.0), Vec3::splat(1.0)).unwrap();
    set.push_point(Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 3.0, 4.0)).unwrap();
    set.push_directional(Vec3::new(0.0, 0.0, -1.0), Vec3::splat(0.5)).unwrap();
    set.push_directional(Vec3::new(0.0, 0.6, -0.8), Vec3::splat(0.25)).unwrap();
    set.push_directional(Vec3::new(0.0, 0.8, -0.6), Vec3::splat(0.125)).unwrap();
    set.push_point(Vec3::new(5.0, 0.0, 0.0), Vec3::splat(7.0)).unwrap();
    // Labels 0 (two points + three directionals), 2 (one point); label 1 empty.
    let lc = LightClustering { assignment: vec![0, 0, 0, 0, 0, 2], centroids: vec![[0.8, 0.0, 0.0], [9.0; 3], [0.0; 3]] };
    let cl = ClusterLights::new(&set, &lc).unwrap();
    assert_eq!(cl.label, vec![0, 0, 2]);
    assert_eq!(cl.size, vec![2, 3, 1]);
    // Point members: light 1 is nearest (0.8, 0, 0); directional: the mean direction is nearest light 3.
    assert_eq!(cl.representative, vec![1, 3, 5]);
    assert_eq!(cl.lights.kind, vec![LightKind::Point, LightKind::Directional, LightKind::Point]);
    assert_eq!(cl.lights.intensity, vec![Vec3::new(3.0, 4.0, 5.0), Vec3::splat(0.875), Vec3::splat(7.0)]);
    assert_eq!(cl.lights.position[0], Vec3::new(1.0, 0.0, 0.0));
}

#[test]
fn bad_clusterings_are_refused_with_the_value() {
    let mut set = LightSet::new(Vec3::ZERO, 10.0);
    set.push_point(Vec3::ZERO, Vec3::ONE).unwrap();
    let err = |lc: LightClustering| ClusterLights::new(&set, &lc).unwrap_err().to_string();
    assert!(err(LightClustering { assignment: vec![3], centroids: vec![[0.0; 3]] }).contains("light label 3"));
    assert!(err(LightClustering { assignment: vec![0, 0], centroids: vec![[0.0; 3]] }).contains("one entry per light (1)"));
    assert!(err(LightClustering { assignment: vec![0], centroids: vec![[f32::NAN, 0.0, 0.0]] }).contains("NaN"));
    let vc = |f: usize, clusters: Vec<u32>, weights: Vec<f32>| ViewClustering {
        centroids: vec![[0.0; 3], [1.0; 3]],
        normals: vec![[0.0, 0.0, 1.0]; 2],
        membership: Membership { f, clusters, weights },
    };
    let verr = |c: ViewClustering| c.validate(2).unwrap_err().to_string();
    assert!(verr(vc(1, vec![0, 2], vec![1.0, 1.0])).contains("membership cluster 2"));
    assert!(verr(vc(2, vec![0, 1, 1, 0], vec![0.5, 0.6, 0.5, 0.5])).contains("sum to 1"));
    assert!(verr(vc(2, vec![0, 1, 1, 0], vec![0.5, f32::NAN, 0.5, 0.5])).contains("NaN"));
    assert!(verr(vc(1, vec![0], vec![1.0])).contains("shape (2, 1)"));
    assert!(verr(vc(0, vec![], vec![])).contains("got 0"));
    assert!(verr(vc(3, vec![0; 6], vec![1.0 / 3.0; 6])).contains("got 3"));
    let mut bad_normal = vc(1, vec![0, 1], vec![1.0, 1.0]);
    bad_normal.normals[1] = [f32::INFINITY, 0.0, 0.0];
    assert!(verr(bad_normal).contains("view normal 1"));
}

#[test]
fn shading_in_several_gpu_dispatches_still_equals_brute_force() {
    // F = 64 (the most): the GPU shades at most 738 lights per dispatch, so ~1,100 lights take two.
    let xml = crate::testing::scene_file("cbox-lights/scene.xml");
    let opts = LoadOptions { params: vec![("res".into(), "8".into())], size: None, ..Default::default() };
    let scene = Arc::new(load_scene(&xml, &opts).unwrap());
    let gen = GenerateOptions { area: 64, environment: 16, indirect: 1024, seed: 9, ..Default::default() };
    let lights = Arc::new(generate_lights(&scene, &gen).unwrap());
    let per = crate::gpu::clustered_visibility::lights_per_dispatch(MAX_FUZZINESS);
    assert!(lights.len() > per && lights.len() < 2 * per, "{} lights, {per} per dispatch", lights.len());
    let ctx = crate::testing::gpu_context();
    let view = Arc::new(crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap());
    let copts = ColumnOptions { visibility: Visibility::RayTraced, shadow_resolution: 64, ..Default::default() };
    let a = LightMatrix::new(ctx.clone(), scene.clone(), view.clone(), lights.clone(), copts.clone()).unwrap();
    // A matrix with shadow maps only has no GPU BVH of its own: the pass builds one.
    let sm = ColumnOptions { visibility: Visibility::ShadowMap, ..copts };
    let a_sm = LightMatrix::new(ctx, scene, view.clone(), lights.clone(), sm).unwrap();
    let m = view.len();
    let mut vc = view_singletons(&view);
    // Column 0: the sample's own cluster (weight 1); 63 more clusters with weight 0.
    vc.membership = Membership {
        f: MAX_FUZZINESS,
        clusters: (0..m).flat_map(|i| (0..MAX_FUZZINESS).map(move |c| ((i + c) % m) as u32)).collect(),
        weights: (0..m).flat_map(|_| (0..MAX_FUZZINESS).map(|c| if c == 0 { 1.0 } else { 0.0 })).collect(),
    };
    let (_, out) = a.clustered_shading(&light_singletons(&lights), &vc).unwrap();
    let brute = a.column_sum(None, &mut |_, _| {}).unwrap();
    let e = rel_l2(&out.image, &brute);
    assert!(e < 1e-5, "relative L2 against brute force {e}");
    let (_, out_sm) = a_sm.clustered_shading(&light_singletons(&lights), &vc).unwrap();
    assert_eq!(out_sm.visibility, out.visibility);
    assert_eq!(out_sm.image, out.image);
}

/// `tests/data/mask_leaves.xml` (two masked quads over a floor) with its floor made a rough plastic of
/// alpha 0.05 (glossy view samples, so the rule of a ray through a mask applies), chains traced to
/// `max_depth` and its area light as 48 samples, at 24 x 18: the CPU and GPU light matrices and the tracer.
fn masked_pair(max_depth: i64) -> (LightMatrix, LightMatrix, Arc<crate::raytrace::RayTracer>) {
    use crate::matrix::backend::Chosen;
    use crate::matrix::glossy::GlossyOptions;
    use crate::raytrace::RayTracer;
    use crate::view::chains::{trace_chains, ChainOptions};
    let leaves = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mask_leaves.xml");
    let src = std::fs::read_to_string(leaves).unwrap();
    let floor = "<bsdf type=\"diffuse\">\n            <rgb name=\"reflectance\" value=\"0.6, 0.6, 0.55\"/>\n        </bsdf>";
    assert!(src.contains(floor));
    let rough = "<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"0.05\"/></bsdf>";
    let dir = crate::testing::scratch_dir("clustered-masks");
    let xml = dir.join("mask_leaves_rough.xml");
    std::fs::write(&xml, src.replace(floor, rough)).unwrap();
    let opts = LoadOptions { params: vec![("width".into(), "24".into()), ("height".into(), "18".into())], ..Default::default() };
    let scene = Arc::new(load_scene(&xml, &opts).unwrap());
    let lights = Arc::new(generate_lights(&scene, &GenerateOptions { area: 48, ..Default::default() }).unwrap());
    let mut view = crate::testing::scenes::cast_view(&scene);
    trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(max_depth).unwrap()).unwrap();
    view.set_glossy(&GlossyOptions::default()).unwrap();
    assert!(!view.mask_budget.is_empty() && !view.bsdf_samples.is_empty());
    let view = Arc::new(view);
    let tracer = Arc::new(RayTracer::new(&scene).unwrap());
    let ctx = crate::testing::gpu_context();
    let copts = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
    let gpu = LightMatrix::new(ctx, scene.clone(), view.clone(), lights.clone(), copts.clone()).unwrap();
    let cpu = LightMatrix::with_device(&Chosen::Cpu, scene, view, lights, copts, Some(tracer.clone())).unwrap();
    (cpu, gpu, tracer)
}

#[test]
fn masked_scene_singletons_equal_brute_force_and_entries_are_transmittances() {
    for max_depth in [3, -1] {
        let (cpu, gpu, tracer) = masked_pair(max_depth);
        let (view, lights) = (&cpu.view, &cpu.lights);
        let (lc, vc) = (light_singletons(lights), view_singletons(view));
        let mut fractional = 0;
        for a in [&cpu, &gpu] {
            let brute = a.column_sum(None, &mut |_, _| {}).unwrap();
            let (job, out) = a.clustered_shading(&lc, &vc).unwrap();
            assert_eq!(out.gave_up, 0);
            let e = rel_l2(&out.image, &brute);
            eprintln!("max_depth {max_depth}, {}: singletons against brute force {e:.2e}", a.device().kind);
            let tol = if a.device().kind == "cpu" { 1e-6 } else { 1e-5 };
            assert!(e < tol, "max_depth {max_depth}, {}: relative L2 against brute force {e}", a.device().kind);
            // Every entry is the transmittance of the light matrix's element (i, c), crossings included.
            let vis = &out.visibility;
            assert_eq!(vis.transmittance.len(), vis.rows * vis.cols);
            for (k, rep) in job.view_reps.sample.iter().enumerate().step_by(7) {
                let Some(i) = *rep else { continue };
                for c in 0..vis.cols {
                    let (v, crossed) = vis.value(k, c);
                    let (want, want_crossed) = cpu::entry(&tracer, view, lights, i, c);
                    assert!((v - want).abs() <= 1e-6, "{} entry ({k}, {c}): {v} against {want}", a.device().kind);
                    assert_eq!((crossed, vis.get(k, c)), (want_crossed, want > 0.0), "{} entry ({k}, {c})", a.device().kind);
                    fractional += (want > 0.0 && want < 1.0) as usize;
                }
            }
        }
        // Both masks (0.5, and the 0.1 / 0.85 checkerboard) lie between some samples and the light.
        assert!(fractional > 20, "max_depth {max_depth}: {fractional} fractional entries");
    }
}

#[test]
fn masked_scene_clusters_beat_visibility_bits() {
    // Pixel blocks of 3 x 3 with F = 3 against the brute force: the transmittances weigh the light through
    // the masks, which a visibility bit (V = 1 wherever some light gets through) overstates.
    let (cpu, gpu, _) = masked_pair(-1);
    let brute = cpu.column_sum(None, &mut |_, _| {}).unwrap();
    let lc = light_grid(&cpu.lights);
    let vc = view_blocks(&cpu.view, 3, 3);
    let (_, c_out) = cpu.clustered_shading(&lc, &vc).unwrap();
    let (_, g_out) = gpu.clustered_shading(&lc, &vc).unwrap();
    let e = rel_l2(&c_out.image, &brute);
    let mut as_bits = c_out.visibility.clone();
    as_bits.transmittance = as_bits.transmittance.iter().map(|&t| (t > 0.0) as u8 as f32).collect();
    let (job, _) = cpu.clustered_shading(&lc, &vc).unwrap();
    let e_bits = rel_l2(&cpu::shade(&cpu.view, &job, &as_bits).unwrap(), &brute);
    let e_gpu = rel_l2(&g_out.image, &c_out.image);
    eprintln!("clusters against brute force {e:.4}, with bits instead of transmittances {e_bits:.4}; GPU against CPU {e_gpu:.2e}");
    assert!(e < 0.5 * e_bits, "{e} against {e_bits}");
    assert!(e_gpu < 1e-5, "GPU against CPU {e_gpu}");
}
