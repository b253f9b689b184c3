use super::*;
use crate::shading::bsdf::{eval_records, link_blend, random_directions, resolve_records, roughplastic_table_buffer, test_sets};

/// WGSL vs Rust: relative difference with an absolute floor of 1e-6 (values below it are
/// rounding noise of zero-or-tiny lobes).
const RTOL: f32 = 1e-3;
const ATOL: f32 = 1e-6;

#[test]
fn wgsl_matches_rust() {
    let ctx = GpuContext::new().expect("a GPU adapter (software is fine) must exist in tests");
    let dirs = random_directions(4000, 11);
    let (wi, wo): (Vec<Vec3>, Vec<Vec3>) = dirs.chunks(2).map(|p| (p[0], p[1])).unzip();
    for (name, bsdfs, i) in test_sets() {
        let (mut b, second) = resolve_records(&bsdfs, &[], i, glam::Vec2::ZERO);
        let mut records = vec![b];
        if let Some(s) = second {
            link_blend(&mut b, 1);
            records = vec![b, s];
        }
        let tables = roughplastic_table_buffer(&bsdfs);
        let gpu = eval_batch_gpu(&ctx, &records, true, &tables, &wi, &wo).unwrap();
        let mut worst = 0.0f32;
        let mut nonzero = 0;
        for j in 0..wi.len() {
            let cpu = eval_records(&records, 0, wi[j], wo[j]);
            nonzero += (cpu.max_element() > 0.0) as usize;
            let rel = ((gpu[j] - cpu).abs() / (cpu.abs().max(Vec3::splat(ATOL)))).max_element();
            let rel = if (gpu[j] - cpu).abs().max_element() <= ATOL { 0.0 } else { rel };
            worst = worst.max(rel);
        }
        println!("{name}: max rel diff WGSL vs Rust {worst:.3e} ({nonzero} nonzero of {})", wi.len());
        assert!(worst < RTOL, "{name}: {worst}");
        assert!(nonzero > 200, "{name}: only {nonzero} nonzero values");
    }
}
