use super::*;
use crate::relight::haar;

fn setup() -> (Scene, ViewSamples, RayTracer) {
    crate::testing::scene_view_tracer(&crate::testing::scene_file("cbox/scene.xml"), 8)
}

/// Keeping every coefficient, threshold 0 reproduces the per-sample gather A_g G V (inverse Haar of the
/// stored rows), and a coarser threshold casts fewer rays.
#[test]
fn exact_gather_rows_invert_to_the_per_sample_transfer() {
    let (scene, view, tracer) = setup();
    let opts = TransferOptions { gather: 64, coefficients: 64, threshold: 0.0, near_field: NearField::Point, ..Default::default() };
    let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
    let disc =
        Transfer::new(&scene, &view, &tracer, &TransferOptions { near_field: NearField::Disc, ..opts.clone() }, &mut |_, _| {}).unwrap();
    let side = t.hierarchy.side();
    let mut nonzero = 0;
    for i in 0..view.num_pixels() {
        let mut image = vec![0f32; 64];
        for (&j, &v) in t.rows[i].index.iter().zip(&t.rows[i].value) {
            image[j as usize] = v;
        }
        haar::inverse(&mut image, side, 1).unwrap();
        let row = t.hierarchy.from_image(&image, 1);
        let mut image = vec![0f32; 64];
        for (&j, &v) in disc.rows[i].index.iter().zip(&disc.rows[i].value) {
            image[j as usize] = v;
        }
        haar::inverse(&mut image, side, 1).unwrap();
        let row_disc = disc.hierarchy.from_image(&image, 1);
        let sp = ShadingPoint::new(&view, i);
        let twosided = view.bsdf[i].flags & FLAG_TWOSIDED != 0;
        for (g, &got) in row.iter().enumerate() {
            let (geo, _) = geometry(&tracer, &sp, twosided, t.emit_position[g], t.emit_normal[g], t.cloud.geo_normal[g], f32::INFINITY);
            let want = geo * t.cloud.area[g];
            assert!((got - want).abs() <= 1e-4 * want.abs().max(1e-3), "pixel {i} sample {g}: {got} vs {want}");
            // The disc form: A G' = A cos cos / (d^2 + A / pi) <= the point's, and <= pi.
            let a = t.cloud.area[g];
            let d2 = (t.emit_position[g] - sp.p).length_squared();
            let want_disc = want * d2 / (d2 + a / std::f32::consts::PI);
            let got_disc = row_disc[g];
            assert!((got_disc - want_disc).abs() <= 1e-4 * want.abs().max(1e-3), "pixel {i} sample {g}: disc {got_disc} vs {want_disc}");
            assert!(got_disc <= std::f32::consts::PI + 1e-4);
            nonzero += (want > 0.0) as usize;
        }
    }
    assert!(nonzero > 64, "only {nonzero} non-zero elements");
    let coarse = Transfer::new(&scene, &view, &tracer, &TransferOptions { threshold: 1.0, ..opts.clone() }, &mut |_, _| {}).unwrap();
    assert!(coarse.shadow_rays < t.shadow_rays / 2, "{} vs {}", coarse.shadow_rays, t.shadow_rays);
}

#[test]
fn bad_options_are_refused() {
    let (scene, view, tracer) = setup();
    for opts in [
        TransferOptions { gather: 32, coefficients: 8, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 17, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 0, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 4, threshold: -1.0, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 4, clamp: 0.0, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 4, bounces: 0, ..Default::default() },
        TransferOptions { gather: 16, coefficients: 4, bounces: 2, multibounce_coefficients: 17, ..Default::default() },
    ] {
        assert!(Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).is_err(), "{opts:?}");
    }
}
