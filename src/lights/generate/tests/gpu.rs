//! GPU columns against the CPU ray-cast reference (`matrix::reference::CpuReference`) for every generated
//! light kind (oriented points, environment directionals, VPLs on diffuse, roughplastic and
//! roughconductor surfaces) on the open box of `testing::light_scenes`.
use crate::lights::generate::*;
use crate::lights::LightKind;
use crate::matrix::reference::CpuReference;
use crate::matrix::{ColumnOptions, LightMatrix};
use crate::testing::light_scenes::open_box;
use crate::testing::scenes::cast_view;
use std::sync::Arc;

/// Per-pixel tolerance (as `matrix::tests`): float rounding relative, with an absolute floor relative
/// to the column's maximum.
const REL_TOL: f32 = 0.02;
const ABS_TOL: f32 = 1e-3;
/// Fraction of pixels of each column that must meet it (the rest: shadow-map texels at boundaries).
const MIN_MATCH_FRACTION: f64 = 0.99;

#[test]
fn gpu_columns_match_cpu_for_generated_lights() {
    let size = 64u32;
    let scene = open_box(size);
    let opts = GenerateOptions { area: 8, environment: 8, indirect: 400, seed: 11, clamp: Some(0.5), ..Default::default() };
    let lights = generate_lights(&scene, &opts).unwrap();
    let view = cast_view(&scene);
    let reference = CpuReference::new(&scene);
    // Lights to compare: 4 oriented points, 4 environment strata, and VPLs on every BSDF kind.
    let mut js: Vec<usize> = Vec::new();
    for kind in [LightKind::OrientedPoint, LightKind::Directional] {
        js.extend((0..lights.len()).filter(|&j| lights.kind[j] == kind).take(4));
    }
    for bsdf_kind in
        [crate::shading::bsdf::KIND_DIFFUSE, crate::shading::bsdf::KIND_ROUGHPLASTIC, crate::shading::bsdf::KIND_ROUGHCONDUCTOR]
    {
        let vpls: Vec<usize> =
            (0..lights.len()).filter(|&j| lights.kind[j] == LightKind::Vpl && lights.bsdf[j].kind == bsdf_kind).collect();
        assert!(vpls.len() >= 2, "need VPLs on BSDF kind {bsdf_kind}, got {}", vpls.len());
        js.extend(vpls.iter().step_by(vpls.len() / 2).take(2));
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
    let mut vpl_clamped = 0usize;
    for (k, &j) in js.iter().enumerate() {
        let cpu = reference.column(&matrix.view, &matrix.lights, j);
        let col = &gpu[k * m * 3..(k + 1) * m * 3];
        let scale = cpu.iter().fold(0f32, |a, &b| a.max(b.abs()));
        let lit = cpu.chunks(3).filter(|c| c.iter().any(|&v| v > 0.0)).count();
        let ok = (0..m)
            .filter(|&i| {
                (0..3).all(|c| {
                    let (g, r) = (col[3 * i + c], cpu[3 * i + c]);
                    (g - r).abs() <= (REL_TOL * r.abs()).max(ABS_TOL * scale)
                })
            })
            .count();
        let frac = ok as f64 / m as f64;
        let l = &matrix.lights;
        if l.kind[j] == LightKind::Vpl {
            vpl_clamped += (0..m)
                .filter(|&i| {
                    let v = &matrix.view;
                    v.shape_index[i] >= 0 && {
                        let d = l.position[j] - v.position[i];
                        let g = d.normalize().dot(v.normal[i]).abs() * d.normalize().dot(l.geo_normal[j]).abs() / d.length_squared();
                        g > l.vpl_clamp
                    }
                })
                .count();
        }
        eprintln!(
            "light {j} ({:?}, bsdf kind {}): {:.3}% of pixels within tolerance, {lit} lit, max {scale:.3e}",
            l.kind[j],
            l.bsdf[j].kind,
            100.0 * frac
        );
        assert!(lit > m / 20, "light {j}: only {lit} lit pixels");
        assert!(col.iter().all(|v| v.is_finite()));
        assert!(frac >= MIN_MATCH_FRACTION, "light {j} ({:?}): only {frac} of pixels match", l.kind[j]);
    }
    eprintln!("{vpl_clamped} VPL pixel evaluations hit the clamp");
    assert!(vpl_clamped > 100, "the clamp must be exercised: {vpl_clamped}");
}
