//! GPU rows against the CPU ray-cast reference and against GPU columns, on the open box of
//! `testing::light_scenes` with point, spot and directional emitters added and generated
//! oriented points, environment directionals and VPLs; the stratification.
use super::*;
use crate::error::Location;
use crate::gpu::GpuContext;
use crate::lights::generate::{generate_lights, GenerateOptions};
use crate::lights::{LightKind, LightSet};
use crate::matrix::reference::CpuReference;
use crate::matrix::{ColumnOptions, LightMatrix};
use crate::scene::{Emitter, Scene};
use crate::testing::light_scenes;
use glam::Vec3;
use std::sync::Arc;

/// Per-entry tolerance (as the column tests): float rounding relative, with an absolute floor relative
/// to the row's largest entry.
const REL_TOL: f32 = 0.02;
const ABS_TOL: f32 = 1e-3;
/// Fraction of entries that must meet it (the rest: ambiguous visibility at shadow boundaries).
const MIN_MATCH_FRACTION: f64 = 0.99;
/// Rows vs columns with exact rays on both sides: the same WGSL functions on the same inputs.
const RAY_TRACED_REL_TOL: f32 = 1e-5;

fn lit_box(size: u32) -> Scene {
    let mut scene = light_scenes::open_box(size);
    let loc = Location::default();
    scene.emitters.push(Emitter::Point { position: Vec3::new(0.3, 0.6, 0.2), intensity: Vec3::new(1.0, 0.8, 0.6), loc: loc.clone() });
    scene.emitters.push(Emitter::Spot {
        world_from_light: light_scenes::lookat(Vec3::new(-0.5, 0.8, 0.5), Vec3::new(0.1, -1.0, -0.3), Vec3::Y),
        intensity: Vec3::splat(2.0),
        cutoff_angle: 40f32.to_radians(),
        beam_width: 25f32.to_radians(),
        texture: None,
        loc: loc.clone(),
    });
    scene.emitters.push(Emitter::Directional { direction: Vec3::new(0.4, -1.0, -0.3).normalize(), irradiance: Vec3::ONE, loc });
    scene
}

struct Setup {
    scene: Arc<Scene>,
    view: Arc<crate::view::ViewSamples>,
    lights: Arc<LightSet>,
    ctx: Arc<GpuContext>,
}

fn setup(size: u32, gen: GenerateOptions) -> Setup {
    let scene = lit_box(size);
    let lights = generate_lights(&scene, &gen).unwrap();
    let ctx = crate::testing::gpu_context();
    let view = crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap();
    Setup { scene: Arc::new(scene), view: Arc::new(view), lights: Arc::new(lights), ctx }
}

impl Setup {
    fn matrix(&self, opts: ColumnOptions) -> LightMatrix {
        LightMatrix::new(self.ctx.clone(), self.scene.clone(), self.view.clone(), self.lights.clone(), opts).unwrap()
    }
    /// Surface pixels spread over the image (every `step`-th surface sample).
    fn surface_rows(&self, count: usize) -> Vec<usize> {
        let surface: Vec<usize> = (0..self.view.len()).filter(|&i| self.view.shape_index[i] >= 0).collect();
        let step = surface.len() / count;
        surface.iter().step_by(step).take(count).copied().collect()
    }
}

fn within(g: f32, r: f32, scale: f32) -> bool {
    (g - r).abs() <= (REL_TOL * r.abs()).max(ABS_TOL * scale)
}

#[test]
fn gpu_rows_match_cpu_ray_casting_for_every_light_kind() {
    let s = setup(48, GenerateOptions { area: 64, environment: 16, indirect: 300, seed: 3, clamp: Some(0.5), ..Default::default() });
    let kinds: Vec<LightKind> = [LightKind::Point, LightKind::Spot, LightKind::Directional, LightKind::OrientedPoint, LightKind::Vpl]
        .into_iter()
        .filter(|k| s.lights.kind.contains(k))
        .collect();
    assert_eq!(kinds.len(), 5, "every light kind must be present");
    let matrix = s.matrix(ColumnOptions::default());
    let is = s.surface_rows(10);
    let n = s.lights.len();
    let mut calls = Vec::new();
    let (rows, timings) =
        matrix.rows_timed(&is, &RowOptions { resolution: 256, memory_budget: 4 * 24 * 256 * 256 }, &mut |d, r| calls.push((d, r))).unwrap();
    assert_eq!(rows.len(), is.len() * n * 3);
    assert_eq!(timings.batches, 3, "4 cubes per batch for 10 rows");
    assert_eq!(calls, vec![(4, 10), (8, 10), (10, 10)]);
    let reference = CpuReference::new(&s.scene);
    let (mut ok, mut total, mut lit, mut shadowed) = (0usize, 0usize, 0usize, 0usize);
    let mut per_kind = std::collections::HashMap::new();
    for (k, &i) in is.iter().enumerate() {
        let row = &rows[k * n * 3..(k + 1) * n * 3];
        let cpu: Vec<f32> = (0..n).flat_map(|j| reference.element(&s.view, &s.lights, i, j).to_array()).collect();
        let scale = cpu.iter().fold(0f32, |a, &b| a.max(b.abs()));
        for j in 0..n {
            let good = (0..3).all(|c| within(row[3 * j + c], cpu[3 * j + c], scale));
            let (_, vis) = reference.element_with_visibility(&s.view, &s.lights, i, j);
            lit += (cpu[3 * j..3 * j + 3].iter().any(|&v| v > 0.0)) as usize;
            shadowed += (!vis && s.lights.emitted(j, s.view.position[i], s.view.normal[i]).is_some()) as usize;
            ok += good as usize;
            total += 1;
            let e = per_kind.entry(format!("{:?}", s.lights.kind[j])).or_insert((0usize, 0usize));
            e.0 += good as usize;
            e.1 += 1;
        }
    }
    let frac = ok as f64 / total as f64;
    eprintln!(
        "rows vs CPU: {ok}/{total} = {:.3}% entries within tolerance ({lit} lit, {shadowed} shadowed); per kind {per_kind:?}",
        100.0 * frac
    );
    eprintln!("visibility: {:?}; timings {timings:?}", matrix.visibility_stats().unwrap());
    assert!(lit > total / 10 && shadowed > total / 50, "the rows must see light and shadow: {lit}, {shadowed}");
    assert!(frac >= MIN_MATCH_FRACTION, "only {frac} of entries match");
    assert!(rows.iter().all(|v| v.is_finite()));
    assert_eq!(matrix.visibility_stats().unwrap().gave_up, 0);
}

/// A.rows(I)[:, J] == A.columns(J)[I]: exact rays on both sides agree to rounding; hybrid rows and
/// hybrid columns (different shadow maps: cube at the sample vs at the light) agree except where one
/// side's map looked certain and was not, which must be rare.
#[test]
fn rows_agree_with_columns() {
    let s = setup(48, GenerateOptions { area: 32, environment: 8, indirect: 200, seed: 5, clamp: Some(0.5), ..Default::default() });
    let n = s.lights.len();
    let m = s.view.len();
    let is = s.surface_rows(12);
    let js: Vec<usize> = (0..n).step_by(3).collect();
    for visibility in [Visibility::RayTraced, Visibility::Hybrid] {
        let matrix = s.matrix(ColumnOptions { visibility, shadow_resolution: 512, ..Default::default() });
        let rows = matrix.rows(&is, &mut |_, _| {}).unwrap();
        let cols = matrix.columns(&js).unwrap();
        let scale = rows.iter().fold(0f32, |a, &b| a.max(b.abs()));
        let (mut ok, mut total, mut worst) = (0usize, 0usize, 0f32);
        for (k, &i) in is.iter().enumerate() {
            for (kj, &j) in js.iter().enumerate() {
                for c in 0..3 {
                    let (a, b) = (rows[(k * n + j) * 3 + c], cols[(kj * m + i) * 3 + c]);
                    let good = match visibility {
                        Visibility::RayTraced => (a - b).abs() <= RAY_TRACED_REL_TOL * b.abs().max(1e-3 * scale),
                        _ => within(a, b, scale),
                    };
                    worst = worst.max((a - b).abs() / b.abs().max(1e-3 * scale));
                    ok += good as usize;
                    total += 1;
                }
            }
        }
        let frac = ok as f64 / total as f64;
        eprintln!(
            "{visibility:?}: rows vs columns {ok}/{total} channels agree (worst relative {worst:.2e}); {:?}",
            matrix.visibility_stats().unwrap()
        );
        match visibility {
            Visibility::RayTraced => assert_eq!(ok, total, "exact rays: rows and columns must agree"),
            _ => assert!(frac >= MIN_MATCH_FRACTION, "hybrid: only {frac} agree"),
        }
    }
}

/// Rows reuse their cube atlas and output buffer between calls: a smaller call, a larger one (the
/// scratch grows) and one at another cube resolution must give the rows of a fresh matrix bit for bit,
/// and only the first call (or a larger one) pays the setup.
#[test]
fn rows_reuse_gpu_scratch_between_calls() {
    let s = setup(32, GenerateOptions { area: 16, indirect: 100, seed: 2, clamp: Some(0.5), ..Default::default() });
    let is = s.surface_rows(20);
    let opts = ColumnOptions::default();
    let fresh = |rows: &[usize], resolution: u32| {
        let m = s.matrix(opts.clone());
        m.rows_timed(rows, &RowOptions { resolution, ..Default::default() }, &mut |_, _| {}).unwrap().0
    };
    let shared = s.matrix(opts.clone());
    let call = |rows: &[usize], resolution: u32| {
        shared.rows_timed(rows, &RowOptions { resolution, ..Default::default() }, &mut |_, _| {}).unwrap()
    };
    for (rows, res) in [(&is[..5], 256), (&is[..3], 256), (&is[..], 256), (&is[..7], 128), (&is[2..9], 256)] {
        let (got, t) = call(rows, res);
        assert!(got == fresh(rows, res), "{} rows at {res}: reused scratch changed the rows", rows.len());
        assert!(t.setup >= 0.0 && t.evaluation > 0.0);
    }
}

/// Trap 1 (Mesa 22.3 stops an invocation after 65,535 loop iterations): more lights than that in one
/// row; the row sums must equal the column sum at those pixels (exact rays for the columns: no 400k
/// cube maps) and the CPU sum.
#[test]
fn rows_with_more_than_65535_lights_sum_like_columns() {
    let s = setup(8, GenerateOptions { area: 70_000, seed: 9, ..Default::default() });
    let n = s.lights.len();
    assert!(n > 65_535, "{n}");
    let rows_matrix = s.matrix(ColumnOptions::default());
    let is = s.surface_rows(4);
    let rows = rows_matrix.rows(&is, &mut |_, _| {}).unwrap();
    let cols_matrix = s.matrix(ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() });
    let image = cols_matrix.column_sum(None, &mut |_, _| {}).unwrap();
    let reference = CpuReference::new(&s.scene);
    for (k, &i) in is.iter().enumerate() {
        let mut sum = [0f64; 3];
        let mut cpu = [0f64; 3];
        for j in 0..n {
            let e = reference.element(&s.view, &s.lights, i, j);
            for c in 0..3 {
                sum[c] += rows[(k * n + j) * 3 + c] as f64;
                cpu[c] += e[c] as f64;
            }
        }
        eprintln!("row {i}: row sum {sum:?}, column_sum {:?}, cpu {cpu:?}", &image[3 * i..3 * i + 3]);
        for c in 0..3 {
            assert!(cpu[c] > 0.0, "pixel {i} must be lit");
            assert!((sum[c] / image[3 * i + c] as f64 - 1.0).abs() < 1e-3, "row {i} channel {c}: {} vs {}", sum[c], image[3 * i + c]);
            assert!((sum[c] / cpu[c] - 1.0).abs() < 1e-3, "row {i} channel {c}: {} vs cpu {}", sum[c], cpu[c]);
        }
    }
}

#[test]
fn row_argument_errors_are_clear() {
    let s = setup(8, GenerateOptions { area: 4, ..Default::default() });
    let matrix = s.matrix(ColumnOptions { shadow_resolution: 64, ..Default::default() });
    let e = matrix.rows(&[0, 64], &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("row index 64") && e.contains("position 1") && e.contains("64 view samples"), "{e}");
    assert!(matrix.rows(&[], &mut |_, _| {}).unwrap().is_empty());
    let e = matrix.rows_timed(&[0], &RowOptions { resolution: 0, ..Default::default() }, &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("resolution") && e.contains("got 0"), "{e}");
    // Repeats and order are honoured, bit for bit; background rows are zero.
    let n = s.lights.len();
    let bg = (0..64).find(|&i| s.view.shape_index[i] < 0);
    let fg = s.surface_rows(2);
    let a = matrix.rows(&[fg[0], fg[1], fg[0]], &mut |_, _| {}).unwrap();
    assert_eq!(&a[..n * 3], &a[2 * n * 3..]);
    assert!(a[..n * 3].iter().any(|&v| v > 0.0));
    if let Some(bg) = bg {
        assert!(matrix.rows(&[bg], &mut |_, _| {}).unwrap().iter().all(|&v| v == 0.0));
    }
}

#[test]
fn stratified_rows_one_per_block_and_reproducible() {
    for (w, h, r) in
        [(128u32, 128u32, 300usize), (128, 72, 300), (13, 5, 7), (64, 64, 64), (10, 1, 10), (3, 40, 17), (5, 5, 25), (100, 80, 1)]
    {
        let blocks = stratified_blocks(w, h, r);
        assert_eq!(blocks.len(), r);
        // The blocks partition the image.
        let mut owner = vec![usize::MAX; (w * h) as usize];
        for (b, &(y0, y1, x0, x1)) in blocks.iter().enumerate() {
            assert!(y1 > y0 && x1 > x0, "{w}x{h} r={r}: empty block {b}");
            for y in y0..y1 {
                for x in x0..x1 {
                    assert_eq!(owner[y * w as usize + x], usize::MAX, "overlap");
                    owner[y * w as usize + x] = b;
                }
            }
        }
        assert!(owner.iter().all(|&o| o != usize::MAX), "{w}x{h} r={r}: uncovered pixels");
        let areas: Vec<usize> = blocks.iter().map(|&(y0, y1, x0, x1)| (y1 - y0) * (x1 - x0)).collect();
        let (lo, hi) = (*areas.iter().min().unwrap(), *areas.iter().max().unwrap());
        eprintln!("{w}x{h} r={r}: block areas {lo}..{hi} (mean {:.1})", (w * h) as f64 / r as f64);
        assert!(hi as f64 <= 2.0 * lo as f64 + 2.0, "{w}x{h} r={r}: block areas {lo}..{hi}");
        // One row per block, in block order.
        let rows = stratified_rows(w, h, r, 42).unwrap();
        for (b, &i) in rows.iter().enumerate() {
            assert_eq!(owner[i], b);
        }
        assert_eq!(rows, stratified_rows(w, h, r, 42).unwrap(), "same seed, same rows");
        if areas.iter().sum::<usize>() > r {
            assert_ne!(rows, stratified_rows(w, h, r, 43).unwrap(), "another seed, other rows");
        }
    }
    // 128x128 with 256 blocks is the 16 x 16 grid of 8 x 8 blocks.
    assert!(stratified_blocks(128, 128, 256).iter().all(|&(y0, y1, x0, x1)| y1 - y0 == 8 && x1 - x0 == 8));
    // Uniform within a block: over many seeds every pixel of a 4x4 block is drawn.
    let mut seen = [0usize; 16];
    for seed in 0..400 {
        let i = stratified_rows(8, 8, 4, seed).unwrap()[0];
        seen[(i / 8) * 4 + i % 8] += 1;
    }
    assert!(seen.iter().all(|&c| c > 5), "{seen:?}");
    for (r, m) in [(0usize, 64usize), (65, 64)] {
        let e = stratified_rows(8, 8, r, 0).unwrap_err().to_string();
        assert!(e.contains(&format!("got {r}")) && e.contains(&format!("[1, {m}]")), "{e}");
    }
}

/// Timing of r = 300 rows x ~100k lights on the shared cbox at 128x128 (run with `--ignored --nocapture`;
/// `ML_ROWS_RES` sets the cube resolution, `ML_ROWS_VIS` the visibility: hybrid, shadow_map, ray_traced).
#[test]
#[ignore]
fn bench_rows_cbox() {
    let path = crate::testing::scene_file("cbox/scene.xml");
    let opts = crate::scene::LoadOptions { params: vec![("res".to_string(), "128".to_string())], size: None, ..Default::default() };
    let scene = crate::scene::load_scene(&path, &opts).unwrap();
    let lights = generate_lights(&scene, &GenerateOptions { area: 50_000, indirect: 50_000, seed: 1, ..Default::default() }).unwrap();
    let ctx = crate::testing::gpu_context();
    let view = crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap();
    let n = lights.len();
    let visibility = Visibility::parse(&std::env::var("ML_ROWS_VIS").unwrap_or("hybrid".into())).unwrap();
    let copts = ColumnOptions { visibility, ..Default::default() };
    let matrix = LightMatrix::new(ctx.clone(), Arc::new(scene), Arc::new(view), Arc::new(lights), copts).unwrap();
    let is = stratified_rows(128, 128, 300, 0).unwrap();
    let res = std::env::var("ML_ROWS_RES").ok().and_then(|v| v.parse().ok()).unwrap_or(256);
    let opts = RowOptions { resolution: res, ..Default::default() };
    matrix.rows_timed(&is[..2], &opts, &mut |_, _| {}).unwrap();
    matrix.reset_visibility_stats();
    let t = std::time::Instant::now();
    let (rows, timings) = matrix.rows_timed(&is, &opts, &mut |_, _| {}).unwrap();
    eprintln!(
        "cbox 128x128, {n} lights, 300 rows, cubes {res}^2, {visibility:?} ({}): total {:.3} s = shadow maps {:.3} + evaluation {:.3} + readback {:.3} s; {} batches; {:?}",
        ctx.summary.name,
        t.elapsed().as_secs_f64(),
        timings.shadow_maps,
        timings.evaluation,
        timings.readback,
        timings.batches,
        matrix.visibility_stats().unwrap()
    );
    assert_eq!(rows.len(), 300 * n * 3);
}

/// A row count that cannot be allocated is an error, not an abort (bad-input corpus).
#[test]
fn stratified_rows_refuses_an_unallocatable_count() {
    let e = stratified_rows(u32::MAX, u32::MAX, 1 << 60, 0).unwrap_err().to_string();
    assert!(e.contains("1152921504606846976 rows") && e.contains("cannot be allocated"), "{e}");
}
