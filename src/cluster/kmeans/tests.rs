use super::fuzzy::eq10_weights;
use super::gpu::{fuzzy_membership_gpu_with_budget, kmeans_gpu_with_budget};
use super::*;
use crate::gpu::GpuContext;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn ctx() -> std::sync::Arc<GpuContext> {
    crate::testing::gpu_context()
}

fn unit(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

/// Uniform points in the unit cube with random unit normals.
fn uniform_points(n: usize, seed: u64) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let p = (0..n).map(|_| [rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()]).collect();
    let nn = (0..n).map(|_| unit([rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5])).collect();
    (p, nn)
}

/// `blobs` Gaussian-ish blobs (radius ~0.03) at random centres in a 4 x 4 x 1 box, points on one of the
/// six box-face normals (exactly axis-aligned) chosen per blob, so Eq. 7 keeps faces apart.
fn blob_points(n: usize, blobs: usize, seed: u64) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let centres: Vec<[f32; 3]> = (0..blobs).map(|_| [rng.random::<f32>() * 4.0, rng.random::<f32>() * 4.0, rng.random::<f32>()]).collect();
    let faces = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    let mut p = Vec::with_capacity(n);
    let mut nn = Vec::with_capacity(n);
    for i in 0..n {
        let b = i % blobs;
        let c = centres[b];
        let mut r = || (rng.random::<f32>() - 0.5) * 0.06;
        let (dx, dy, dz) = (r(), r(), r());
        p.push([c[0] + dx, c[1] + dy, c[2] + dz]);
        nn.push(faces[(b * 7 + (i / blobs) % 2) % 6]);
    }
    (p, nn)
}

/// Smallest gap, over points, between the distance to the nearest and the second-nearest centroid
/// (Eq. 7 order; an inadmissible runner-up counts as an infinite gap).
fn min_gap(points: &[[f32; 3]], normals: &[[f32; 3]], r: &KMeansResult, cos: Option<f32>) -> f32 {
    let normals = check_points(points, normals, cos, "t").unwrap();
    points
        .iter()
        .zip(&normals)
        .map(|(p, n)| {
            let l = nearest_f(p, n, &r.centroids, &r.centroid_normals, 2, cos);
            if l[0].0 != l[1].0 {
                f32::INFINITY
            } else {
                l[1].1.sqrt() - l[0].1.sqrt()
            }
        })
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn downsampling_takes_one_seeded_sample_per_block() {
    let s = downsample_indices(103, 4, 7).unwrap();
    assert_eq!(s.len(), 26);
    for (b, &i) in s.iter().enumerate() {
        assert!((b * 4..(b * 4 + 4).min(103)).contains(&(i as usize)), "block {b}: {i}");
    }
    assert_eq!(s, downsample_indices(103, 4, 7).unwrap());
    assert_ne!(s, downsample_indices(103, 4, 8).unwrap());
    assert_eq!(downsample_indices(5, 1, 0).unwrap(), vec![0, 1, 2, 3, 4]);
    assert!(downsample_indices(5, 0, 0).is_err());
}

#[test]
fn initial_centroids_are_distinct_data_points() {
    let idx = initial_indices(50, 50, 3);
    let mut sorted = idx.clone();
    sorted.sort();
    assert_eq!(sorted, (0..50).collect::<Vec<u32>>());
    assert_eq!(initial_indices(1000, 10, 3), initial_indices(1000, 10, 3));
}

#[test]
fn bad_parameters_are_errors_naming_the_value() {
    let (p, n) = uniform_points(10, 1);
    let run = |q: &KMeansParams, p: &[[f32; 3]], n: &[[f32; 3]]| kmeans_cpu(p, n, q).unwrap_err().to_string();
    assert!(run(&KMeansParams::new(0), &p, &n).contains("got 0"));
    assert!(run(&KMeansParams::new(11), &p, &n).contains("got 11"));
    let mut bad = p.clone();
    bad[4][1] = f32::NAN;
    assert!(run(&KMeansParams::new(2), &bad, &n).contains("point 4"));
    assert!(run(&KMeansParams::new(2), &p, &n[..9]).contains("9 normals"));
    let q = KMeansParams { cos_threshold: Some(1.5), ..KMeansParams::new(2) };
    assert!(run(&q, &p, &n).contains("1.5"));
    let q = KMeansParams { tolerance: -1.0, ..KMeansParams::new(2) };
    assert!(run(&q, &p, &n).contains("-1"));
    assert!(run(&KMeansParams::new(2), &p, &vec![[0.0; 3]; 10]).contains("zero length"));
    assert!(kmeans_gpu(&ctx(), &p, &n, &KMeansParams::new(11)).unwrap_err().to_string().contains("got 11"));
    assert!(fuzzy_membership(&p, &n, &p[..3], &n[..3], 4, None).unwrap_err().to_string().contains("got 4"));
    assert!(fuzzy_membership(&p, &n, &p[..3], &n[..3], 0, None).is_err());
}

#[test]
fn objective_falls_monotonically_on_cpu_and_gpu() {
    // Threshold off: K-means' objective cannot rise. Threshold on with face normals (clusters never mix
    // faces, so centroid normals stay the face normals): it cannot rise either.
    let ctx = ctx();
    for (cos, (pts, nrm)) in [(None, uniform_points(5000, 2)), (Some(DEFAULT_COS_THRESHOLD), blob_points(5000, 60, 3))] {
        let q = KMeansParams { k: 50, max_iterations: 12, cos_threshold: cos, ..KMeansParams::new(50) };
        for r in [kmeans_cpu(&pts, &nrm, &q).unwrap(), kmeans_gpu(&ctx, &pts, &nrm, &q).unwrap()] {
            assert_eq!(r.objective.len(), 13, "{}", r.device);
            assert_eq!(r.iterations, 12);
            for w in r.objective.windows(2) {
                assert!(w[1] <= w[0] * (1.0 + 1e-6), "{} objective rose: {:?}", r.device, r.objective);
            }
            assert!(r.objective[12] < 0.8 * r.objective[0], "{} barely fell: {:?}", r.device, r.objective);
        }
    }
}

#[test]
fn gpu_equals_cpu_on_tie_free_data() {
    // Tie-free: blobs (+-0.03) far apart (mean spacing ~0.5), and an initialisation seed (the first of
    // 0..30) for which along the CPU's whole trajectory every point's runner-up centroid is at least
    // TIE_GAP farther than its nearest. CPU and GPU centroids differ by ~1e-7 of the 4 x 4 x 1 box (module
    // docs, "Precision"), 50x less than TIE_GAP, so no assignment can differ by rounding.
    const TIE_GAP: f32 = 2e-5;
    let ctx = ctx();
    let (pts, nrm) = blob_points(3000, 48, 11);
    for cos in [None, Some(DEFAULT_COS_THRESHOLD)] {
        let tie_free = |q: &KMeansParams| {
            (0..=q.max_iterations).all(|t| {
                let r = kmeans_cpu(&pts, &nrm, &KMeansParams { max_iterations: t, ..q.clone() }).unwrap();
                min_gap(&pts, &nrm, &r, cos) > TIE_GAP
            })
        };
        let q = (0..30)
            .map(|seed| KMeansParams { k: 40, max_iterations: 8, cos_threshold: cos, seed, ..KMeansParams::new(40) })
            .find(|q| tie_free(q))
            .expect("precondition: some seed gives a tie-free trajectory");
        let cpu = kmeans_cpu(&pts, &nrm, &q).unwrap();
        let gpu = kmeans_gpu(&ctx, &pts, &nrm, &q).unwrap();
        assert_eq!(cpu.initial, gpu.initial);
        assert_eq!(cpu.assignment, gpu.assignment, "cos {cos:?}");
        for (a, b) in cpu.objective.iter().zip(&gpu.objective) {
            assert!((a - b).abs() <= 1e-5 * a, "objective {a} vs {b}");
        }
        for (a, b) in cpu.centroids.iter().zip(&gpu.centroids) {
            for ax in 0..3 {
                assert!((a[ax] - b[ax]).abs() < 2e-6, "centroid {a:?} vs {b:?}");
            }
        }
        for (a, b) in cpu.centroid_normals.iter().zip(&gpu.centroid_normals) {
            for ax in 0..3 {
                assert!((a[ax] - b[ax]).abs() < 1e-5, "normal {a:?} vs {b:?}");
            }
        }
    }
}

#[test]
fn grid_assignment_equals_exhaustive() {
    // k = 2500 > one exhaustive chunk (2048); uniform and clumped data; threshold on (random normals: many
    // points have inadmissible candidates, some no admissible centroid at all) and off; and a budget of 8
    // loop iterations that sends every point to the exhaustive fallback.
    let ctx = ctx();
    let (pts, nrm) = uniform_points(12_000, 21);
    let (cts, cns) = uniform_points(2500, 22);
    let (bp, bn) = blob_points(8000, 30, 23);
    // Planar data (a flat grid axis), normals +-z.
    let flat: Vec<[f32; 3]> = pts.iter().map(|p| [p[0], p[1], 0.0]).collect();
    let flat_n: Vec<[f32; 3]> = nrm.iter().map(|n| [0.0, 0.0, n[2].signum()]).collect();
    for cos in [None, Some(DEFAULT_COS_THRESHOLD)] {
        for (p, n, c, cn) in
            [(&pts, &nrm, &cts[..], &cns[..]), (&bp, &bn, &bp[..300], &bn[..300]), (&flat, &flat_n, &flat[..500], &flat_n[..500])]
        {
            let ex = fuzzy_membership_gpu_with_budget(&ctx, p, n, c, cn, 6, cos, false, None).unwrap();
            let grid = fuzzy_membership_gpu_with_budget(&ctx, p, n, c, cn, 6, cos, true, None).unwrap();
            let starved = fuzzy_membership_gpu_with_budget(&ctx, p, n, c, cn, 6, cos, true, Some(8)).unwrap();
            assert_eq!(grid.clusters, ex.clusters, "cos {cos:?}");
            assert_eq!(grid.distances2, ex.distances2);
            assert_eq!(starved.clusters, ex.clusters);
            // Against the CPU: equal except where two candidates' distances agree to float rounding.
            let cpu = fuzzy_membership(p, n, c, cn, 6, cos).unwrap();
            let mut differ = 0;
            for i in 0..cpu.clusters.len() {
                if cpu.clusters[i] != ex.clusters[i] {
                    differ += 1;
                    assert!((cpu.distances2[i] - ex.distances2[i]).abs() <= 1e-6 * cpu.distances2[i].max(1e-6), "slot {i}");
                }
            }
            assert!(differ <= 2, "{differ} slots differ from the CPU");
        }
    }
    // The largest fuzziness (F = 16), threshold on.
    let cos = Some(DEFAULT_COS_THRESHOLD);
    let ex = fuzzy_membership_gpu_with_budget(&ctx, &pts, &nrm, &cts[..500], &cns[..500], MAX_FUZZY, cos, false, None).unwrap();
    let grid = fuzzy_membership_gpu_with_budget(&ctx, &pts, &nrm, &cts[..500], &cns[..500], MAX_FUZZY, cos, true, None).unwrap();
    let starved = fuzzy_membership_gpu_with_budget(&ctx, &pts, &nrm, &cts[..500], &cns[..500], MAX_FUZZY, cos, true, Some(8)).unwrap();
    assert_eq!(grid.clusters, ex.clusters);
    assert_eq!(starved.clusters, ex.clusters);
    assert_eq!(grid.weights, ex.weights);
    // The whole K-means run: grid and exhaustive give bit-identical centroids and assignments.
    let (pts, nrm) = uniform_points(20_000, 31);
    let q = KMeansParams { k: 300, max_iterations: 6, cos_threshold: Some(DEFAULT_COS_THRESHOLD), ..KMeansParams::new(300) };
    let a = kmeans_gpu_with_budget(&ctx, &pts, &nrm, &q, None).unwrap();
    let b = kmeans_gpu_with_budget(&ctx, &pts, &nrm, &KMeansParams { use_grid: false, ..q.clone() }, None).unwrap();
    assert_eq!(a.assignment, b.assignment);
    assert_eq!(a.centroids, b.centroids);
    assert_eq!(a.objective, b.objective);
}

#[test]
fn tolerance_stops_early_and_zero_iterations_is_the_initial_assignment() {
    let (pts, nrm) = uniform_points(3000, 41);
    let q = KMeansParams { k: 20, max_iterations: 200, tolerance: 1e-3, cos_threshold: None, ..KMeansParams::new(20) };
    let r = kmeans_cpu(&pts, &nrm, &q).unwrap();
    assert!(r.iterations < 200 && r.iterations >= 2, "{}", r.iterations);
    let t = r.objective.len() - 1;
    assert!(r.objective[t - 1] - r.objective[t] <= 1e-3 * r.objective[t - 1]);
    let g = kmeans_gpu(&ctx(), &pts, &nrm, &q).unwrap();
    assert_eq!(g.iterations, r.iterations);
    let z = kmeans_cpu(&pts, &nrm, &KMeansParams { max_iterations: 0, ..q }).unwrap();
    assert_eq!(z.objective.len(), 1);
    let init: Vec<[f32; 3]> = z.initial.iter().map(|&i| pts[i as usize]).collect();
    assert_eq!(z.centroids, init);
}

#[test]
fn eq10_weights_match_hand_computed_values() {
    // Admissible at distances 1, 2, 4: w' = 1, 1/2, 1/4, W = 7/4 -> 4/7, 2/7, 1/7; inadmissible: 0.
    let w = eq10_weights(&[(true, 1.0), (true, 4.0), (true, 16.0), (false, 0.25)]);
    let want = [4.0 / 7.0, 2.0 / 7.0, 1.0 / 7.0, 0.0];
    for (a, b) in w.iter().zip(want) {
        assert!((a - b).abs() < 1e-7, "{w:?}");
    }
    // A cluster at distance 0 takes everything; two share it.
    assert_eq!(eq10_weights(&[(true, 0.0), (true, 1.0)]), vec![1.0, 0.0]);
    assert_eq!(eq10_weights(&[(true, 0.0), (true, 0.0), (true, 9.0)]), vec![0.5, 0.5, 0.0]);
    // No admissible cluster: Euclidean inverse distances (distances 1 and 3 -> 3/4, 1/4).
    let w = eq10_weights(&[(false, 1.0), (false, 9.0)]);
    assert!((w[0] - 0.75).abs() < 1e-7 && (w[1] - 0.25).abs() < 1e-7, "{w:?}");

    // The same through fuzzy_membership (CPU and GPU): a point at the origin facing +z, centroids at 1, 2, 4
    // along x facing +z and one at 0.5 facing -z (inadmissible with the threshold on).
    let p = [[0.0f32, 0.0, 0.0]];
    let n = [[0.0f32, 0.0, 1.0]];
    let c = [[2.0f32, 0.0, 0.0], [0.0, 0.5, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 4.0]];
    let cn = [[0.0f32, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    let cpu = fuzzy_membership(&p, &n, &c, &cn, 4, Some(DEFAULT_COS_THRESHOLD)).unwrap();
    let gpu = fuzzy_membership_gpu(&ctx(), &p, &n, &c, &cn, 4, Some(DEFAULT_COS_THRESHOLD), true).unwrap();
    for m in [&cpu, &gpu] {
        assert_eq!(m.clusters, vec![2, 0, 3, 1]);
        assert_eq!(m.admissible, vec![true, true, true, false]);
        for (a, b) in m.weights.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{:?}", m.weights);
        }
    }
    // Threshold off: the nearest is the one at 0.5 (w' = 2): 2, 1, 1/2, 1/4 over 15/4.
    let off = fuzzy_membership(&p, &n, &c, &cn, 4, None).unwrap();
    assert_eq!(off.clusters, vec![1, 2, 0, 3]);
    for (a, b) in off.weights.iter().zip([8.0 / 15.0, 4.0 / 15.0, 2.0 / 15.0, 1.0 / 15.0]) {
        assert!((a - b).abs() < 1e-7, "{:?}", off.weights);
    }
}

#[test]
fn fuzzy_f1_is_the_hard_assignment_and_rows_sum_to_one() {
    let (pts, nrm) = blob_points(4000, 40, 51);
    let q = KMeansParams { k: 30, max_iterations: 5, ..KMeansParams::new(30) };
    let km = kmeans_cpu(&pts, &nrm, &q).unwrap();
    let ctx = ctx();
    for f1 in [
        fuzzy_membership(&pts, &nrm, &km.centroids, &km.centroid_normals, 1, q.cos_threshold).unwrap(),
        fuzzy_membership_gpu(&ctx, &pts, &nrm, &km.centroids, &km.centroid_normals, 1, q.cos_threshold, true).unwrap(),
    ] {
        assert_eq!(f1.clusters, km.assignment);
        assert!(f1.weights.iter().all(|&w| w == 1.0));
    }
    let f6 = fuzzy_membership_gpu(&ctx, &pts, &nrm, &km.centroids, &km.centroid_normals, 6, q.cos_threshold, true).unwrap();
    for (i, row) in f6.weights.chunks(6).enumerate() {
        let s: f32 = row.iter().sum();
        assert!((s - 1.0).abs() < 1e-5, "row {i} sums to {s}");
        assert!(row.windows(2).all(|w| w[0] >= w[1] - 1e-6), "row {i} not nearest first: {row:?}");
        assert_eq!(f6.clusters[i * 6], km.assignment[i]);
    }
}

#[test]
fn view_sample_clustering_downsamples_then_assigns_everything() {
    let (pts, nrm) = blob_points(6000, 40, 61);
    let q = KMeansParams { k: 100, max_iterations: 4, ..KMeansParams::new(100) };
    let cpu = cluster_view_samples(KMeansDevice::Cpu, &pts, &nrm, 4, &q, 6).unwrap();
    assert_eq!(cpu.gamma, 4);
    assert_eq!(cpu.subset.len(), 1500);
    assert_eq!(cpu.kmeans.assignment.len(), 1500);
    assert_eq!(cpu.membership.clusters.len(), 6000 * 6);
    // gamma lowered so that the subset keeps >= k points: 6000 / 2000 = 3.
    let q2 = KMeansParams { k: 2000, max_iterations: 1, ..q.clone() };
    assert_eq!(cluster_view_samples(KMeansDevice::Cpu, &pts, &nrm, 8, &q2, 1).unwrap().gamma, 3);
    let gpu = cluster_view_samples(KMeansDevice::Gpu(&ctx()), &pts, &nrm, 4, &q, 6).unwrap();
    assert_eq!(gpu.subset, cpu.subset);
    assert_eq!(gpu.kmeans.initial, cpu.kmeans.initial);
}

#[test]
fn split_dispatches_give_bit_identical_results() {
    // A tiny work budget sends every kernel out in dispatches of one 256-point workgroup (the objective
    // partials at their offsets, the exhaustive chunks split by points): nothing may change by a bit.
    use crate::gpu::dispatch::with_budget;
    let ctx = ctx();
    let (pts, nrm) = uniform_points(3000, 41);
    let q = KMeansParams { k: 40, max_iterations: 3, cos_threshold: Some(DEFAULT_COS_THRESHOLD), ..KMeansParams::new(40) };
    let whole = kmeans_gpu_with_budget(&ctx, &pts, &nrm, &q, None).unwrap();
    let split = with_budget(100, || kmeans_gpu_with_budget(&ctx, &pts, &nrm, &q, None)).unwrap();
    assert_eq!(split.assignment, whole.assignment);
    assert_eq!(split.centroids, whole.centroids);
    assert_eq!(split.objective, whole.objective);
    assert!(whole.objective.len() == 4 && whole.objective[0] > 0.0);
    let (c, cn) = (&whole.centroids, &whole.centroid_normals);
    for grid in [true, false] {
        let a = fuzzy_membership_gpu_with_budget(&ctx, &pts, &nrm, c, cn, 4, None, grid, None).unwrap();
        let b = with_budget(100, || fuzzy_membership_gpu_with_budget(&ctx, &pts, &nrm, c, cn, 4, None, grid, None)).unwrap();
        assert_eq!((&a.clusters, &a.distances2, &a.weights), (&b.clusters, &b.distances2, &b.weights));
    }
}
