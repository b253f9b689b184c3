use super::*;
use crate::lights::{generate_lights, GenerateOptions};
use crate::matrix::{ColumnOptions, Visibility};
use crate::scene::{load_scene, LoadOptions};
use std::sync::Arc;

/// GPU `RayTraced` columns cast the same rays as the oracle: only f32 rounding of the shading
/// separates them (the spot falloff's acos is `acos_precise` on the GPU, within ~2 ulp of libm's).
const REL_TOL: f32 = 1e-5;
/// Absolute floor relative to the column maximum (rounding near zero).
const ABS_TOL: f32 = 1e-6;
/// Pixels allowed to differ: rays grazing an edge may be decided differently by the GPU's and the
/// CPU's watertight tests (1e-4 of the pixels, as the BVH agreement measured in `gpu::bvh`).
const MAX_MISMATCH_FRACTION: f64 = 1e-3;

fn matrix(visibility: Visibility) -> LightMatrix {
    let xml = crate::testing::scene_file("cbox-lights/scene.xml");
    let opts = LoadOptions { params: vec![("res".into(), "32".into())], size: None, ..Default::default() };
    let scene = load_scene(&xml, &opts).unwrap();
    let gen = GenerateOptions { area: 16, environment: 16, indirect: 200, seed: 3, ..Default::default() };
    let lights = generate_lights(&scene, &gen).unwrap();
    let ctx = crate::testing::gpu_context();
    let view = crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap();
    let opts = ColumnOptions { visibility, shadow_resolution: 256, ..Default::default() };
    LightMatrix::new(ctx, Arc::new(scene), Arc::new(view), Arc::new(lights), opts).unwrap()
}

#[test]
fn oracle_matches_gpu_ray_traced_columns_for_every_kind() {
    let a = matrix(Visibility::RayTraced);
    let js = crate::testing::lights_of_every_kind(&a.lights, 3);
    let gpu = a.columns(&js).unwrap();
    let m = a.view.len();
    let (mut bad, mut lit) = (0usize, 0usize);
    for (k, &j) in js.iter().enumerate() {
        let cpu = a.column_exact(j).unwrap();
        let scale = cpu.iter().flatten().fold(0f32, |s, &v| s.max(v));
        for i in 0..m {
            let g = &gpu[(k * m + i) * 3..(k * m + i) * 3 + 3];
            lit += (cpu[i][0] > 0.0) as usize;
            if (0..3).any(|c| (g[c] - cpu[i][c]).abs() > REL_TOL * cpu[i][c].abs() + ABS_TOL * scale) {
                bad += 1;
            }
        }
    }
    let frac = bad as f64 / (js.len() * m) as f64;
    eprintln!("{} lights: {bad} of {} elements differ ({lit} lit)", js.len(), js.len() * m);
    assert!(lit > js.len() * m / 10, "too few lit elements: {lit}");
    assert!(frac <= MAX_MISMATCH_FRACTION, "{frac} of the elements differ");
}

#[test]
fn element_row_column_agree_and_indices_are_checked() {
    let a = matrix(Visibility::ShadowMap);
    let (m, n) = a.shape();
    let i = (m / 2) + 7;
    let row = a.row_exact(i).unwrap();
    assert_eq!(row.len(), n);
    for j in [0, 1, n / 2, n - 1] {
        assert_eq!(a.element(i, j).unwrap(), row[j]);
        assert_eq!(a.column_exact(j).unwrap()[i], row[j]);
    }
    assert!(row.iter().flatten().any(|&v| v > 0.0));
    for e in [a.element(m, 0).unwrap_err(), a.element(0, n).unwrap_err(), a.row_exact(m).unwrap_err(), a.column_exact(n).unwrap_err()] {
        assert!(matches!(e, Error::InvalidParameter(_)), "{e}");
        assert!(e.to_string().contains("out of range"), "{e}");
    }
}
