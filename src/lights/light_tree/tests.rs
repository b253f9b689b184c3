use super::*;
use crate::shading::GpuBsdf;
use bytemuck::Zeroable;
use rand::RngExt;
use rand_pcg::Pcg32;

fn unit(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()) * 2.0 - 1.0;
        if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// `n` lights of every kind (point, spot, directional, oriented point, VPL, VSL) in a 4 m box.
fn mixed_lights(n: usize, seed: u64) -> LightSet {
    let mut rng = Pcg32::new(seed, 7);
    let mut s = LightSet::new(Vec3::ZERO, 4.0);
    let mut b = GpuBsdf::zeroed();
    b.kind = crate::shading::bsdf::KIND_DIFFUSE;
    b.diffuse = [0.6, 0.5, 0.4];
    for k in 0..n {
        let p = Vec3::new(rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()) * 4.0 - 2.0;
        let i = Vec3::new(rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()) + 0.1;
        match k % 6 {
            0 => s.push_point(p, i).unwrap(),
            1 => s.push_spot(p, unit(&mut rng), i, 0.6, 0.3).unwrap(),
            2 => s.push_directional(unit(&mut rng), i * 0.01).unwrap(),
            3 => s.push_oriented_point(p, unit(&mut rng), i).unwrap(),
            _ => {
                let ng = unit(&mut rng);
                let inc = (ng + unit(&mut rng) * 0.5).normalize();
                let inc = if inc.dot(ng) > 0.0 { inc } else { -inc };
                s.push_vpl(p, ng, ng, inc, i, b).unwrap();
                if k % 6 == 5 {
                    s.set_vsl_radius(s.len() - 1, 0.05).unwrap();
                }
            }
        }
    }
    s
}

#[test]
fn every_node_bounds_every_light_below_it() {
    let lights = mixed_lights(600, 1);
    let t = LightTree::build(&lights).unwrap();
    assert_eq!(t.infinite.len(), 100);
    assert_eq!(t.nodes.len(), 2 * 500 - 1);
    let mut below: Vec<Vec<usize>> = vec![Vec::new(); t.nodes.len()];
    for j in 0..lights.len() {
        let mut k = t.node_of_light[j];
        if k == u32::MAX {
            assert_eq!(lights.kind[j], LightKind::Directional);
            continue;
        }
        assert_eq!(t.leaf_light[k as usize] as usize, j);
        while k != u32::MAX {
            below[k as usize].push(j);
            k = t.parent[k as usize];
        }
    }
    assert_eq!(below[0].len(), 500);
    for (k, js) in below.iter().enumerate() {
        let node = &t.nodes[k];
        let mut phi = 0.0;
        for &j in js {
            let b = LightBounds::of_light(&lights, j).unwrap();
            assert!(b.lo.cmpge(node.lo).all() && b.hi.cmple(node.hi).all(), "node {k} light {j}: box");
            // acos of a dot product of equal unit vectors is up to ~2e-8 (the merged cones are padded by 1e-5).
            let inside = node.theta_o >= PI || angle_between(node.w, b.w) + b.theta_o <= node.theta_o + 1e-7;
            assert!(inside, "node {k} light {j}: cone {:?} {} vs {:?} {}", node.w, node.theta_o, b.w, b.theta_o);
            assert!(b.theta_e <= node.theta_e);
            phi += b.phi;
        }
        assert!((phi - node.phi).abs() <= 1e-9 * phi, "node {k}: phi {phi} vs {}", node.phi);
        if !t.is_leaf(k) {
            let [a, c] = t.children[k];
            assert_eq!(below[a as usize].len() + below[c as usize].len(), js.len());
        }
    }
}

#[test]
fn pdfs_sum_to_one_and_match_sampling_frequencies() {
    let lights = mixed_lights(300, 2);
    let t = LightTree::build(&lights).unwrap();
    let mut rng = Pcg32::new(9, 3);
    for q in 0..20 {
        let p = Vec3::new(rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()) * 6.0 - 3.0;
        let n = unit(&mut rng);
        let pdf: Vec<f64> = (0..lights.len()).map(|j| t.pdf(p, n, j)).collect();
        let sum: f64 = pdf.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "point {q}: pdfs sum to {sum}");
        // Every light that sends anything toward p has pdf > 0.
        for j in 0..lights.len() {
            if let Some((wo, f, _)) = lights.emitted(j, p, n) {
                if f.max_element() > 0.0 && wo.dot(n).abs() > 1e-4 {
                    assert!(pdf[j] > 0.0, "point {q}: light {j} ({:?}) lights p but has pdf 0", lights.kind[j]);
                }
            }
        }
        if q < 3 {
            let draws = 200_000;
            let mut count = vec![0u32; lights.len()];
            for _ in 0..draws {
                let (j, prob) = t.sample(p, n, || rng.random::<f64>()).unwrap();
                assert!((prob - pdf[j]).abs() <= 1e-12 * pdf[j].max(1e-300), "sampled pdf {prob} vs pdf {}", pdf[j]);
                count[j] += 1;
            }
            // Chi-square-like check on the lights with an expected count >= 50.
            for j in 0..lights.len() {
                let e = pdf[j] * draws as f64;
                if e >= 50.0 {
                    let z = (count[j] as f64 - e) / e.sqrt();
                    assert!(z.abs() < 5.0, "light {j}: {} draws, expected {e:.1}", count[j]);
                }
            }
        }
    }
}

#[test]
fn empty_set_is_an_error_and_single_light_trees_work() {
    assert!(LightTree::build(&LightSet::new(Vec3::ZERO, 1.0)).is_err());
    let mut s = LightSet::new(Vec3::ZERO, 1.0);
    s.push_point(Vec3::ONE, Vec3::ONE).unwrap();
    let t = LightTree::build(&s).unwrap();
    assert_eq!(t.pdf(Vec3::ZERO, Vec3::Z, 0), 1.0);
    let mut d = LightSet::new(Vec3::ZERO, 1.0);
    d.push_directional(Vec3::Z, Vec3::ONE).unwrap();
    d.push_directional(Vec3::X, Vec3::ONE * 3.0).unwrap();
    let t = LightTree::build(&d).unwrap();
    assert!(t.nodes.is_empty());
    let p1 = t.pdf(Vec3::ZERO, Vec3::Z, 1);
    assert!((p1 - 0.75).abs() < 1e-6, "{p1} {:?}", t.infinite_power);
}
