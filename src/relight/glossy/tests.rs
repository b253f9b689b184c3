use super::*;
use crate::relight::transfer::{geometry, NearField, Transfer, TransferOptions};
use crate::shading::bsdf::{eval_records, KIND_DIFFUSE};

fn setup() -> (crate::scene::Scene, ViewSamples, RayTracer) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests").join("data").join("relight_glossy_box.xml");
    crate::testing::scene_view_tracer(&path, 8)
}

fn record(kind: u32) -> GpuBsdf {
    let mut b: GpuBsdf = bytemuck::Zeroable::zeroed();
    b.kind = kind;
    b.diffuse = [0.5, 0.4, 0.3];
    b.specular = [1.0, 0.9, 0.8];
    b.eta = [1.5, 1.0 / 2.25, 0.0];
    b.alpha_u = 0.3;
    b.alpha_v = 0.3;
    b
}

/// Which records are glossy, and that the glossy part of a roughplastic plus its diffuse part is the
/// whole BSDF (`shading::bsdf::eval`, Mitsuba's).
#[test]
fn glossy_lobes_split_the_bsdf() {
    assert!(glossy_lobes(&[record(KIND_DIFFUSE)], 0).is_empty());
    let rc = record(KIND_ROUGHCONDUCTOR);
    let (wi, wo) = (Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(-0.35, -0.05, 0.8).normalize());
    assert_eq!(glossy_eval(&glossy_lobes(&[rc], 0), wi, wo), eval(&rc, wi, wo));
    let mut rp = record(KIND_ROUGHPLASTIC);
    rp.extra = [0.5, f32::from_bits(0), 0.0, 0.0];
    let lobes = glossy_lobes(&[rp], 0);
    let mut diffuse_only = rp;
    diffuse_only.specular = [0.0; 3];
    let sum = glossy_eval(&lobes, wi, wo) + eval(&diffuse_only, wi, wo);
    assert!((sum - eval(&rp, wi, wo)).abs().max_element() <= 1e-6 * eval(&rp, wi, wo).max_element(), "{sum}");
    assert!(glossy_eval(&lobes, wi, wo).max_element() > 0.0);
    // A blend of diffuse (first, weight 1 - 0.25) and roughconductor (second, 0.25).
    let mut first = record(KIND_DIFFUSE);
    first.flags = FLAG_BLEND;
    first.extra = [0.0, 0.0, 0.25, f32::from_bits(1)];
    let records = [first, rc];
    let lobes = glossy_lobes(&records, 0);
    assert_eq!(lobes.len(), 1);
    let want = eval_records(&records, 0, wi, wo) - eval(&first, wi, wo) * 0.75;
    assert!((glossy_eval(&lobes, wi, wo) - want).abs().max_element() <= 1e-6, "{want}");
}

/// Keeping every coefficient with threshold 0, the glossy rows invert to the per-sample
/// A_g min(G, clamp) V mean_rgb(f_g) (module docs); the lobe-driven hierarchical gather casts fewer rays.
#[test]
fn exact_glossy_rows_invert_to_the_per_sample_transfer() {
    let (scene, view, tracer) = setup();
    let opts = TransferOptions { gather: 64, coefficients: 64, threshold: 0.0, near_field: NearField::Point, ..Default::default() };
    let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
    assert!(t.glossy_pixels >= 4 && t.glossy_rows.len() == 64, "{} glossy pixels", t.glossy_pixels);
    let side = t.hierarchy.side();
    let mut nonzero = 0;
    for i in 0..view.num_pixels() {
        let lobes = glossy_lobes(&view.bsdf, i);
        if lobes.is_empty() {
            assert!(t.glossy_rows[i].index.is_empty() && t.glossy_color[i] == Vec3::ZERO);
            continue;
        }
        assert!((t.glossy_color[i].element_sum() - 3.0).abs() < 1e-4, "{}", t.glossy_color[i]);
        let mut image = vec![0f32; 64];
        for (&j, &v) in t.glossy_rows[i].index.iter().zip(&t.glossy_rows[i].value) {
            image[j as usize] = v;
        }
        haar::inverse(&mut image, side, 1).unwrap();
        let row = t.hierarchy.from_image(&image, 1);
        let sp = ShadingPoint::new(&view, i);
        for (g, &got) in row.iter().enumerate() {
            let (geo, _) = geometry(&tracer, &sp, false, t.emit_position[g], t.emit_normal[g], t.cloud.geo_normal[g], f32::INFINITY);
            let wo = local(&sp, (t.emit_position[g] - sp.p).normalize());
            let f = glossy_eval(&lobes, sp.wi_local, wo).element_sum() / (3.0 * wo.z.abs());
            let want = if geo > 0.0 { geo * f * t.cloud.area[g] } else { 0.0 };
            assert!((got - want).abs() <= 1e-4 * want.abs().max(1e-2), "pixel {i} sample {g}: {got} vs {want}");
            nonzero += (want > 0.0) as usize;
        }
    }
    assert!(nonzero > 64, "only {nonzero} non-zero elements");
    let coarse = Transfer::new(&scene, &view, &tracer, &TransferOptions { threshold: 1.0, ..opts.clone() }, &mut |_, _| {}).unwrap();
    assert!(coarse.shadow_rays < t.shadow_rays, "{} vs {}", coarse.shadow_rays, t.shadow_rays);
    let off = Transfer::new(&scene, &view, &tracer, &TransferOptions { glossy: false, ..opts }, &mut |_, _| {}).unwrap();
    assert!(off.glossy_rows.is_empty() && off.glossy_pixels == 0);
}
