//! Virtual spherical lights (`lights::vsl`) as generated lights: radius -> 0 gives the unclamped VPL
//! column, the GPU column pass equals the CPU reference (near field included), bad radii are refused.
use crate::lights::generate::*;
use crate::lights::LightKind;
use crate::matrix::reference::CpuReference;
use crate::matrix::{ColumnOptions, LightMatrix};
use crate::testing::light_scenes::open_box;
use crate::testing::scenes::cast_view;
use glam::Vec3;
use std::sync::Arc;

fn vpl_indices(lights: &LightSet) -> Vec<usize> {
    (0..lights.len()).filter(|&j| lights.kind[j] == LightKind::Vpl).collect()
}

#[test]
fn vsl_radius_to_zero_is_the_unclamped_vpl() {
    let scene = open_box(32);
    let opts = GenerateOptions { area: 8, indirect: 200, seed: 5, clamp: Some(f32::INFINITY), ..Default::default() };
    let vpl = generate_lights(&scene, &opts).unwrap();
    let view = cast_view(&scene);
    let reference = CpuReference::new(&scene);
    let js = vpl_indices(&vpl);
    assert!(js.len() > 50, "{} VPLs", js.len());
    let mut compared = 0usize;
    for &j in js.iter().step_by(js.len() / 12) {
        let want = reference.column(&view, &vpl, j);
        let mut tiny = vpl.clone();
        tiny.set_vsl_radius(j, 1e-4).unwrap();
        let got = reference.column(&view, &tiny, j);
        for i in 0..view.len() {
            // Receivers farther than 100 radii: the point formula to 1e-3 (PSA and Omega to O(r^2 / d^2)).
            if (view.position[i] - vpl.position[j]).length() < 1e-2 {
                continue;
            }
            for c in 0..3 {
                let (g, w) = (got[3 * i + c], want[3 * i + c]);
                assert!((g - w).abs() <= 1e-3 * w.abs() + 1e-9, "light {j} pixel {i}: VSL {g} vs VPL {w}");
                compared += (w > 0.0) as usize;
            }
        }
    }
    assert!(compared > 1000, "{compared} lit elements compared");
}

#[test]
fn vsl_generation_sets_radii_and_refuses_bad_scales() {
    let scene = open_box(16);
    let base = GenerateOptions { area: 8, indirect: 300, seed: 2, ..Default::default() };
    let vpl = generate_lights(&scene, &base).unwrap();
    let vsl = generate_lights(&scene, &GenerateOptions { vsl: Some(VslOptions::default()), ..base.clone() }).unwrap();
    // The same VPLs (same streams), now with radii; other kinds keep 0.
    assert_eq!(vpl.position, vsl.position);
    for j in 0..vsl.len() {
        assert_eq!(vsl.vsl_radius[j] > 0.0, vsl.kind[j] == LightKind::Vpl, "light {j}");
        assert_eq!(vpl.vsl_radius[j], 0.0);
    }
    let twice =
        generate_lights(&scene, &GenerateOptions { vsl: Some(VslOptions { scale: 2.0, ..Default::default() }), ..base.clone() }).unwrap();
    let j = vpl_indices(&vsl)[7];
    assert!((twice.vsl_radius[j] - 2.0 * vsl.vsl_radius[j]).abs() <= 1e-6 * twice.vsl_radius[j]);
    for bad in [0.0f32, f32::NAN, -0.5, f32::INFINITY] {
        let e = generate_lights(&scene, &GenerateOptions { vsl: Some(VslOptions { scale: bad, ..Default::default() }), ..base.clone() })
            .unwrap_err()
            .to_string();
        assert!(e.contains("vsl_radius_scale"), "{e}");
    }
    let mut s = vsl.clone();
    for bad in [f32::NAN, -1.0, f32::INFINITY] {
        assert!(s.set_vsl_radius(j, bad).unwrap_err().to_string().contains("vsl_radius"));
    }
    assert!(s.set_vsl_radius(0, 0.1).unwrap_err().to_string().contains("only VPLs"));
}

#[test]
fn gpu_vsl_columns_match_cpu() {
    let size = 64u32;
    let scene = open_box(size);
    let opts = GenerateOptions {
        area: 8,
        indirect: 400,
        seed: 11,
        vsl: Some(VslOptions { scale: 3.0, ..Default::default() }),
        ..Default::default()
    };
    let lights = generate_lights(&scene, &opts).unwrap();
    let view = cast_view(&scene);
    let reference = CpuReference::new(&scene);
    let mut js = Vec::new();
    for bsdf_kind in
        [crate::shading::bsdf::KIND_DIFFUSE, crate::shading::bsdf::KIND_ROUGHPLASTIC, crate::shading::bsdf::KIND_ROUGHCONDUCTOR]
    {
        let v: Vec<usize> = vpl_indices(&lights).into_iter().filter(|&j| lights.bsdf[j].kind == bsdf_kind).collect();
        assert!(v.len() >= 2, "need VSLs on BSDF kind {bsdf_kind}");
        js.extend(v.iter().step_by(v.len() / 2).take(2));
    }
    let ctx = crate::testing::gpu_context();
    let matrix = LightMatrix::new(
        ctx,
        Arc::new(scene),
        Arc::new(view),
        Arc::new(lights),
        ColumnOptions { shadow_resolution: 512, ..Default::default() },
    )
    .unwrap();
    let gpu = matrix.columns(&js).unwrap();
    let m = (size * size) as usize;
    let (l, v) = (&matrix.lights, &matrix.view);
    let mut near = 0usize;
    for (k, &j) in js.iter().enumerate() {
        let cpu = reference.column(v, l, j);
        let col = &gpu[k * m * 3..(k + 1) * m * 3];
        let scale = cpu.iter().fold(0f32, |a, &b| a.max(b.abs()));
        let ok = (0..m)
            .filter(|&i| (0..3).all(|c| (col[3 * i + c] - cpu[3 * i + c]).abs() <= (0.02 * cpu[3 * i + c].abs()).max(1e-3 * scale)))
            .count();
        near += (0..m).filter(|&i| v.shape_index[i] >= 0 && (v.position[i] - l.position[j]).length() < 2.0 * l.vsl_radius[j]).count();
        assert!(col.iter().all(|x| x.is_finite()));
        assert!(ok as f64 >= 0.99 * m as f64, "VSL {j}: {ok} of {m} pixels match");
    }
    assert!(near > 50, "the near field (receivers within 2 radii) must be exercised: {near}");
    // Rows (rows.wgsl) shade VSLs the same way: 64 surface pixels, every chosen VSL.
    let is: Vec<usize> = (0..m).filter(|&i| v.shape_index[i] >= 0).step_by(37).take(64).collect();
    let rows = matrix.rows(&is, &mut |_, _| {}).unwrap();
    let n = l.len();
    let (mut ok, mut total) = (0usize, 0usize);
    for (r, &i) in is.iter().enumerate() {
        for &j in &js {
            let want = reference.element(v, l, i, j);
            let got = Vec3::from_slice(&rows[(r * n + j) * 3..(r * n + j) * 3 + 3]);
            total += 1;
            ok += ((got - want).abs().max_element() <= (0.02 * want.max_element()).max(1e-6)) as usize;
        }
    }
    assert!(ok as f64 >= 0.97 * total as f64, "rows: {ok} of {total} elements match");
}
