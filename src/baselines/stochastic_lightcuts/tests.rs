//! Exact expectation (the cut partitions the lights, the pdfs below every cut node sum to 1 and are > 0
//! wherever A(i, j) != 0) and a seeded z-test with the power to see a 2% bias, on cbox-lights (point,
//! spot, directional, area, environment and indirect lights).
use super::*;
use crate::baselines::tests::{cbox_lights, total_z};

#[test]
fn cut_partitions_the_lights_and_the_expectation_is_the_row_sum() {
    let a = cbox_lights(12);
    let tree = LightTree::build(&a.lights).unwrap();
    let slc = SlcTree::new(&tree, &a.lights);
    let tracer = a.tracer().unwrap();
    let (m, n) = a.shape();
    let mut checked = 0;
    for i in (0..m).step_by(5) {
        let sp = ShadingPoint::new(&a.view, i);
        if !sp.surface {
            continue;
        }
        let r = Receiver::new(&a.view, &sp, i);
        for size in [1, 8, 40] {
            let cut = slc.cut(&r, size);
            assert!(!cut.is_empty() && cut.len() <= size, "sample {i}: cut of {} nodes for size {size}", cut.len());
            let mut seen = vec![0u32; n];
            let (mut expectation, mut row_sum) = (DVec3::ZERO, DVec3::ZERO);
            for &k in &cut {
                let leaves = slc.leaf_probabilities(k as usize, &r);
                let total: f64 = leaves.iter().map(|l| l.1).sum();
                assert!((total - 1.0).abs() < 1e-9, "sample {i} node {k}: pdfs sum to {total}");
                for (j, pdf) in leaves {
                    seen[j] += 1;
                    if crate::cpu::shade_unshadowed(&a.view, &a.lights, &sp, i, j).is_some() {
                        assert!(pdf > 0.0, "sample {i} light {j} ({:?}): A != 0 but pdf 0", a.lights.kind[j]);
                        checked += 1;
                        let f = crate::cpu::shade(&tracer, &a.view, &a.lights, &sp, i, j).value.as_dvec3();
                        expectation += pdf * (f / pdf);
                        row_sum += f;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "sample {i}: the cut does not partition the lights");
            assert!((expectation - row_sum).abs().max_element() <= 1e-9 * row_sum.max_element().max(1e-30));
        }
    }
    assert!(checked > 12_000, "{checked} non-zero elements checked");
}

#[test]
fn stochastic_lightcuts_is_unbiased_and_detects_a_two_percent_bias() {
    let a = cbox_lights(24);
    let tree = LightTree::build(&a.lights).unwrap();
    let reference = a.column_sum(None, &mut |_, _| {}).unwrap();
    let e = stochastic_lightcuts(&a, &tree, 8, 96, 3).unwrap();
    let (z, z_biased) = (total_z(&e, &reference, 1.0), total_z(&e, &reference, 1.02));
    eprintln!("SLC: z {z:.3}, biased z {z_biased:.3}, {:.3} s, {} rays", e.seconds, e.shadow_rays);
    assert!(z.abs() < 4.0, "z = {z}");
    assert!(z_biased.abs() > 6.0, "a 2% bias gives only z = {z_biased}");
    assert!(e.shadow_rays > 0 && e.shadow_rays <= 96 * 8 * a.shape().0 as u64, "{} rays", e.shadow_rays);
}

#[test]
fn bad_inputs_are_errors() {
    let a = cbox_lights(8);
    let tree = LightTree::build(&a.lights).unwrap();
    assert!(stochastic_lightcuts(&a, &tree, 0, 1, 0).is_err());
    assert!(stochastic_lightcuts(&a, &tree, 4, 0, 0).is_err());
}
