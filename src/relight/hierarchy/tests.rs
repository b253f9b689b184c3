use super::*;
use rand::RngExt;
use rand_pcg::Pcg32;

fn jitter(rng: &mut Pcg32, s: f32) -> Vec3 {
    Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5) * s
}

/// Morton codes and pixels are inverse bijections, and the quad-tree path bits are (row, col) bits.
#[test]
fn morton_mapping_round_trips() {
    for m in 0..4096u64 {
        let (r, c) = morton_pixel(m);
        assert!(r < 64 && c < 64);
        assert_eq!(pixel_morton(r, c), m);
    }
    assert_eq!(morton_pixel(0b10), (1, 0)); // q = 2: bottom-left
    assert_eq!(morton_pixel(0b01), (0, 1)); // q = 1: top-right
    assert_eq!(morton_pixel(0b11_00), (2, 2)); // q_1 = 3 of a 4 x 4: bottom-right block's corner
}

/// The tree is perfectly balanced: at every depth j there are 4^j clusters of 4^(k - j) samples, each a
/// 2^(k-j) x 2^(k-j) aligned block of the gather image; `order` and `pixel` are permutations.
#[test]
fn tree_is_balanced_and_clusters_are_blocks() {
    let mut rng = Pcg32::new(3, 1);
    let k = 4u32;
    let n = 1usize << (2 * k);
    let p: Vec<Vec3> = (0..n).map(|_| jitter(&mut rng, 10.0)).collect();
    let nn: Vec<Vec3> = (0..n).map(|_| jitter(&mut rng, 1.0).normalize()).collect();
    let h = ClusterHierarchy::build(&p, &nn, 17.3, 30.0).unwrap();
    assert_eq!((h.levels, h.side(), h.len()), (k, 16, n));
    let mut seen = vec![false; n];
    for &i in &h.order {
        assert!(!seen[i as usize]);
        seen[i as usize] = true;
    }
    for i in 0..n {
        assert_eq!(h.sample_at_pixel[h.pixel[i] as usize] as usize, i);
    }
    for depth in 0..=k {
        let block = 1u32 << (k - depth);
        let mut count = 0;
        for c in 0..1usize << (2 * depth) {
            let members = h.cluster(depth, c);
            assert_eq!(members.len(), (block * block) as usize, "depth {depth}");
            let (r0, c0) = morton_pixel(c as u64);
            for &i in members {
                let (r, cc) = (h.pixel[i as usize] / 16, h.pixel[i as usize] % 16);
                assert_eq!((r / block, cc / block), (r0, c0), "depth {depth} cluster {c}");
            }
            count += 1;
        }
        assert_eq!(count, 1 << (2 * depth));
    }
    // Image layout round trip.
    let values: Vec<f32> = (0..n * 3).map(|v| v as f32).collect();
    let img = h.to_image(&values, 3);
    assert_eq!(&img[h.pixel[7] as usize * 3..h.pixel[7] as usize * 3 + 3], &values[21..24]);
    assert_eq!(h.from_image(&img, 3), values);
    // Deterministic.
    assert_eq!(ClusterHierarchy::build(&p, &nn, 17.3, 30.0).unwrap(), h);
}

/// The modified 2-means groups four separated blobs of 16 samples (shuffled, unequal spreads) into the
/// four children of the root; two slabs stacked along y but longer along x are split by y (a median
/// split along the longest axis would mix them).
#[test]
fn two_means_groups_separated_clusters() {
    let mut rng = Pcg32::new(11, 2);
    let centres = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 0.0, 0.0), Vec3::new(0.0, 10.0, 0.0), Vec3::new(10.0, 10.0, 5.0)];
    let mut pts: Vec<(usize, Vec3)> = (0..64).map(|i| (i % 4, centres[i % 4] + jitter(&mut rng, 1.0 + (i % 4) as f32))).collect();
    for i in (1..pts.len()).rev() {
        let j = (rng.random::<u32>() as usize) % (i + 1);
        pts.swap(i, j);
    }
    let p: Vec<Vec3> = pts.iter().map(|x| x.1).collect();
    let n = vec![Vec3::Y; 64];
    let h = ClusterHierarchy::build(&p, &n, 20.0, 30.0).unwrap();
    let mut labels_seen = Vec::new();
    for c in 0..4 {
        let labels: Vec<usize> = h.cluster(1, c).iter().map(|&i| pts[i as usize].0).collect();
        assert!(labels.iter().all(|&l| l == labels[0]), "child {c}: {labels:?}");
        labels_seen.push(labels[0]);
    }
    labels_seen.sort();
    assert_eq!(labels_seen, vec![0, 1, 2, 3]);

    // Two thin rods along (1, 1), 10 apart along (1, -1), 14 long: their x (and y) ranges overlap, so a
    // median split along an axis mixes them; 2-means separates them (within-variance 14^2 / 12 = 16.3
    // against 29.1 for cutting both rods across).
    let dir = Vec3::new(1.0, 1.0, 0.0).normalize();
    let off = Vec3::new(1.0, -1.0, 0.0).normalize() * 10.0;
    let p: Vec<Vec3> =
        (0..64).map(|i| dir * (((i / 2) as f32 / 31.0 - 0.5) * 14.0) + off * (i % 2) as f32 + jitter(&mut rng, 0.05)).collect();
    let xs_a: Vec<f32> = p.iter().step_by(2).map(|q| q.x).collect();
    let xs_b: Vec<f32> = p.iter().skip(1).step_by(2).map(|q| q.x).collect();
    assert!(xs_a.iter().cloned().fold(f32::MIN, f32::max) > xs_b.iter().cloned().fold(f32::MAX, f32::min), "ranges overlap");
    let n = vec![Vec3::Z; 64];
    let h = ClusterHierarchy::build(&p, &n, 30.0, 30.0).unwrap();
    let top: Vec<u32> = h.order[..32].iter().map(|&i| i % 2).collect();
    assert!(top.iter().all(|&l| l == top[0]), "top half mixes the rods: {top:?}");
}

/// Normals count: coincident positions with opposite normals split by normal (Eq. 9's D^2 |n - n'|^2),
/// while with a large K the position wins over normals for distant groups.
#[test]
fn normals_and_positions_weigh_by_eq_9() {
    let mut rng = Pcg32::new(5, 3);
    // 8 samples at nearly one point facing +z, 8 facing -z (a thin wall's two sides).
    let p: Vec<Vec3> = (0..16).map(|_| jitter(&mut rng, 1e-3)).collect();
    let n: Vec<Vec3> = (0..16).map(|i| if i % 3 == 0 || i == 5 || i == 7 { Vec3::Z } else { -Vec3::Z }).collect();
    assert_eq!(n.iter().filter(|v| v.z > 0.0).count(), 8);
    let h = ClusterHierarchy::build(&p, &n, 1.0, 30.0).unwrap();
    let side_of = |i: u32| n[i as usize].z > 0.0;
    assert!(h.order[..8].iter().all(|&i| side_of(i) == side_of(h.order[0])));
    // Two groups 1 apart in a scene of diagonal 1 with K = 30: position term 900 vs normal term <= 4.
    let p: Vec<Vec3> = (0..16).map(|i| Vec3::new((i % 2) as f32, 0.0, 0.0) + jitter(&mut rng, 1e-2)).collect();
    let n: Vec<Vec3> = (0..16).map(|i| if i < 8 { Vec3::Z } else { -Vec3::Z }).collect();
    let h = ClusterHierarchy::build(&p, &n, 1.0, 30.0).unwrap();
    assert!(h.order[..8].iter().all(|&i| i % 2 == h.order[0] % 2));
}

#[test]
fn bad_input_is_an_error() {
    let p = vec![Vec3::ZERO; 8];
    assert!(ClusterHierarchy::build(&p, &p, 1.0, 30.0).unwrap_err().to_string().contains("power of 4"));
    let p = vec![Vec3::ZERO; 4];
    assert!(ClusterHierarchy::build(&p, &p[..3], 1.0, 30.0).unwrap_err().to_string().contains("3 normals"));
    assert!(ClusterHierarchy::build(&p, &p, 1.0, 0.0).unwrap_err().to_string().contains("K"));
    assert!(ClusterHierarchy::build(&p, &p, f32::NAN, 30.0).unwrap_err().to_string().contains("diagonal"));
    let mut q = p.clone();
    q[2].x = f32::NAN;
    assert!(ClusterHierarchy::build(&q, &p, 1.0, 30.0).unwrap_err().to_string().contains("sample 2"));
    assert!(ClusterHierarchy::build(&[], &[], 1.0, 30.0).is_err());
    // One sample: a 1 x 1 image.
    let h = ClusterHierarchy::build(&[Vec3::ONE], &[Vec3::Z], 1.0, 30.0).unwrap();
    assert_eq!((h.levels, h.order.clone(), h.pixel.clone()), (0, vec![0], vec![0]));
}

/// What the hierarchy is for: on a cbox-lights gather cloud (4^6 samples), the unshadowed irradiance of
/// a point light laid out as the gather image compresses far better in Haar wavelets than the same
/// values in a random layout: relative L2 error of the image rebuilt from the 5% area-weighted most
/// important coefficients. Measured: 0.20 (K = 30), against 0.82 for a random layout (K = 1e4, positions
/// only: 0.20; K = 0.1, normals first: 0.16 on this signal).
#[test]
fn hierarchy_layout_compresses_a_lighting_signal() {
    use crate::lights::gather::{GatherCloud, GatherOptions};
    use crate::relight::haar;
    let path = crate::testing::scene_file("cbox-lights/scene.xml");
    let scene = crate::scene::load_scene(&path, &Default::default()).unwrap();
    let cloud = GatherCloud::new(&scene, &GatherOptions { n: 4096, seed: 0, include_emitters: true }).unwrap();
    let x0 = Vec3::new(0.2, 0.7, 0.3);
    let g: Vec<f32> = (0..cloud.len())
        .map(|i| {
            let d = x0 - cloud.position[i];
            cloud.normal[i].dot(d).max(0.0) / d.length().powi(3)
        })
        .collect();
    let error = |perm: &[u32]| -> f64 {
        let mut img: Vec<f32> = perm.iter().map(|&i| g[i as usize]).collect();
        haar::forward(&mut img, 64, 1).unwrap();
        let kept = haar::cull_area_weighted(&img, 64, 1, 4096 / 20).unwrap();
        let mut back = vec![0.0f32; 4096];
        for (&j, &v) in kept.index.iter().zip(&kept.value) {
            back[j as usize] = v;
        }
        haar::inverse(&mut back, 64, 1).unwrap();
        let num: f64 = back.iter().zip(perm).map(|(b, &i)| (*b as f64 - g[i as usize] as f64).powi(2)).sum();
        let den: f64 = g.iter().map(|v| (*v as f64).powi(2)).sum();
        (num / den).sqrt()
    };
    let h = ClusterHierarchy::of_cloud(&cloud, DEFAULT_K).unwrap();
    let mut rng = Pcg32::new(1, 1);
    let mut random: Vec<u32> = (0..4096).collect();
    for i in (1..random.len()).rev() {
        random.swap(i, (rng.random::<u32>() as usize) % (i + 1));
    }
    let (e_h, e_r) = (error(&h.sample_at_pixel), error(&random));
    let e_pos_only = error(&ClusterHierarchy::of_cloud(&cloud, 1e4).unwrap().sample_at_pixel);
    let e_normal_heavy = error(&ClusterHierarchy::of_cloud(&cloud, 0.1).unwrap().sample_at_pixel);
    eprintln!("5% coefficients: hierarchy K=30 {e_h:.4}, K=1e4 {e_pos_only:.4}, K=0.1 {e_normal_heavy:.4}, random {e_r:.4}");
    assert!(e_h < 0.3 && e_h < 0.4 * e_r, "hierarchy {e_h} vs random {e_r}");
}
