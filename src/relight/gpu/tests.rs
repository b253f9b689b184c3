use super::*;
use crate::matrix::Visibility;
use crate::raytrace::RayTracer;
use crate::relight::haar;
use crate::relight::transfer::TransferOptions;
use crate::scene::{load_scene, LoadOptions};
use crate::view::chains::ChainOptions;
use glam::Vec3;
use std::time::Instant;

fn setup(size: u32) -> (Arc<Scene>, Arc<ViewSamples>, Arc<RayTracer>) {
    setup_scene(&crate::testing::scene_file("cbox/scene.xml"), size)
}

fn setup_scene(path: &std::path::Path, size: u32) -> (Arc<Scene>, Arc<ViewSamples>, Arc<RayTracer>) {
    let (scene, view, tracer) = crate::testing::scene_view_tracer(path, size);
    (Arc::new(scene), Arc::new(view), Arc::new(tracer))
}

/// Point, spot, directional, oriented-point and VPL lights in the Cornell box (x, z in [0, 556], y in [0, 549];
/// open at z = 0, the camera's side).
fn lights(scene: &Scene) -> Arc<LightSet> {
    let (c, r) = crate::lights::scene_sphere(scene);
    let mut s = LightSet::new(c, r);
    s.push_point(Vec3::new(350.0, 400.0, 250.0), Vec3::new(2e5, 1.5e5, 1e5)).unwrap();
    s.push_spot(Vec3::new(200.0, 520.0, 300.0), Vec3::new(0.2, -1.0, 0.1).normalize(), Vec3::new(3e5, 3e5, 2.5e5), 0.7, 0.5).unwrap();
    s.push_directional(Vec3::new(0.1, -0.3, 1.0).normalize(), Vec3::new(0.5, 0.5, 0.6)).unwrap();
    s.push_oriented_point(Vec3::new(278.0, 540.0, 279.0), -Vec3::Y, Vec3::new(2e5, 2e5, 2e5)).unwrap();
    // A VPL on the floor with a diffuse BSDF, clamped as the light matrix clamps VPLs.
    let bsdf =
        crate::shading::GpuBsdf { diffuse: [0.6, 0.5, 0.4], kind: crate::shading::bsdf::KIND_DIFFUSE, ..bytemuck::Zeroable::zeroed() };
    s.push_vpl(Vec3::new(480.0, 5.0, 100.0), Vec3::Y, Vec3::Y, Vec3::new(0.0, 1.0, 0.2).normalize(), Vec3::splat(3e5), bsdf).unwrap();
    s.vpl_clamp = 1e-3;
    Arc::new(s)
}

fn ctx() -> Arc<GpuContext> {
    crate::testing::gpu_context()
}

fn rel_l2(a: &[f32], b: &[f32]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (*x as f64 - *y as f64).powi(2)).sum();
    let n: f64 = b.iter().map(|y| (*y as f64).powi(2)).sum();
    (d / n).sqrt()
}

/// With exact rays on both devices the GPU relight is the CPU relight up to float rounding (one bounce,
/// two with the gather-to-gather rows, three with the photon-mapped M (the default), all coefficients
/// kept and epsilon 0, then with culling: the same lights are culled).
#[test]
fn gpu_relight_equals_cpu_relight_with_exact_rays() {
    use crate::relight::Multibounce;
    let (scene, view, tracer) = setup(16);
    let l = lights(&scene);
    let mut one_bounce = Vec::new();
    for (bounces, multibounce) in [(1, Multibounce::Photons), (2, Multibounce::Gather), (3, Multibounce::Photons)] {
        let opts = TransferOptions {
            gather: 256,
            coefficients: 256,
            threshold: 0.0,
            bounces,
            multibounce_coefficients: 256,
            multibounce,
            photons_per_sample: 16,
            photon_neighbours: 50,
            ..Default::default()
        };
        let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
        assert_eq!(t.photon_rows.is_empty(), bounces < 3, "bounces {bounces}: photon rows");
        assert_eq!(t.bounce_rows.is_empty(), bounces != 2, "bounces {bounces}: gather-to-gather rows");
        let col = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
        let g = GpuRelight::new(ctx(), scene.clone(), view.clone(), &t, col).unwrap();
        let (want, ws) = crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), l.clone(), 0.0).unwrap();
        let (got, gs) = g.relight(l.clone(), 0.0).unwrap();
        assert_eq!(got.len(), 16 * 16 * 3);
        if bounces == 1 {
            one_bounce = want.clone();
        } else {
            // The multiple bounces are a sizeable part of the image (so a GPU that skipped them fails).
            let share = rel_l2(&one_bounce, &want);
            assert!(share > 0.02, "bounces {bounces}: the multiple bounces' share {share}");
        }
        let e = rel_l2(&got, &want);
        eprintln!("bounces {bounces}: relative L2 {e:.2e}");
        // Measured on lavapipe: 3.9e-8 (one bounce), 4.9e-8 (two, gather), 4.4e-8 (three, photons): f32
        // summation order of the column sums and products, fused multiply-adds.
        assert!(e < 1e-6, "bounces {bounces}: relative L2 {e}");
        assert_eq!((gs.wavelet_lights, gs.wavelet_lights_culled), (ws.wavelet_lights, 0));
        assert!(ws.wavelet_lights > 100, "{ws:?}");
        // Culling: a threshold that removes part of the wavelet lights removes the same ones on both.
        let eps = 0.1;
        let (want, ws) = crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), l.clone(), eps).unwrap();
        let (got, gs) = g.relight(l.clone(), eps).unwrap();
        assert!(ws.wavelet_lights_culled > 10 && ws.wavelet_lights_culled < ws.wavelet_lights, "{ws:?}");
        assert_eq!((gs.wavelet_lights, gs.wavelet_lights_culled), (ws.wavelet_lights, ws.wavelet_lights_culled));
        let e = rel_l2(&got, &want);
        eprintln!("bounces {bounces}, epsilon {eps}: relative L2 {e:.2e}, {ws:?}");
        // Measured: 3.7e-8, 4.7e-8 and 4.8e-8 (162 of 253, 155 of 256 and 158 of 256 wavelet lights
        // culled).
        assert!(e < 1e-6, "bounces {bounces}, epsilon {eps}: relative L2 {e}");
        // Stage times are measured.
        assert!(gs.seconds_gather_direct > 0.0 && gs.seconds_transfer > 0.0 && gs.seconds_readback > 0.0, "{gs:?}");
        assert_eq!(gs.wavelet_lights_culled_glossy, ws.wavelet_lights_culled_glossy);
    }
}

/// The glossy final gather F_g (tests/data/relight_glossy_box.xml: a rough conductor floor) on the GPU
/// equals `glossy::add_glossy` on the CPU up to float rounding, alone and with the photon-mapped M
/// (three bounces), without culling and with culling (the same lights culled against F_d^w's and
/// against F_g^w's image norms).
#[test]
fn gpu_relight_applies_glossy_rows_as_the_cpu() {
    use crate::relight::Multibounce;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests").join("data").join("relight_glossy_box.xml");
    let (scene, view, tracer) = setup_scene(&path, 16);
    let l = Arc::new(LightSet::from_scene(&scene).unwrap());
    let col = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
    for bounces in [1, 3] {
        let opts = TransferOptions {
            gather: 256,
            coefficients: 64,
            bounces,
            multibounce_coefficients: 64,
            multibounce: Multibounce::Photons,
            photons_per_sample: 16,
            photon_neighbours: 50,
            ..Default::default()
        };
        let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
        assert!(t.glossy_pixels >= 20 && t.glossy_rows.len() == 256, "{} glossy pixels", t.glossy_pixels);
        assert_eq!(t.photon_rows.is_empty(), bounces == 1);
        let g = GpuRelight::new(ctx(), scene.clone(), view.clone(), &t, col.clone()).unwrap();
        // Glossy pixels alone (the floor): their F_g share is a visible part of their radiance.
        let floor: Vec<usize> = (0..256).filter(|&i| !t.glossy_rows[i].index.is_empty()).collect();
        for eps in [0.0f32, 0.01] {
            let (want, ws) = crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), l.clone(), eps).unwrap();
            let (got, gs) = g.relight(l.clone(), eps).unwrap();
            let e = rel_l2(&got, &want);
            let pick = |img: &[f32]| -> Vec<f32> { floor.iter().flat_map(|&i| img[3 * i..3 * i + 3].to_vec()).collect() };
            let e_floor = rel_l2(&pick(&got), &pick(&want));
            eprintln!("bounces {bounces}, epsilon {eps}: relative L2 {e:.2e} (glossy pixels {e_floor:.2e}), {ws:?}");
            // Measured on lavapipe: 8.3e-8 (glossy pixels 9.4e-8) with one bounce, 8.3e-8 (1.0e-7) with
            // three; at epsilon 0.01 8.4e-8 (1.1e-7) and 8.3e-8 (1.3e-7), 19 and 62 of 91 lights culled
            // against F_d^w and F_g^w (one bounce), 161 and 209 of 238 (three).
            assert!(e < 1e-6 && e_floor < 1e-6, "bounces {bounces}, epsilon {eps}: relative L2 {e}, glossy pixels {e_floor}");
            assert_eq!(
                (gs.wavelet_lights, gs.wavelet_lights_culled, gs.wavelet_lights_culled_glossy),
                (ws.wavelet_lights, ws.wavelet_lights_culled, ws.wavelet_lights_culled_glossy),
                "bounces {bounces}, epsilon {eps}"
            );
            if eps > 0.0 {
                assert!(ws.wavelet_lights_culled_glossy > 10 && ws.wavelet_lights_culled_glossy < ws.wavelet_lights, "{ws:?}");
            } else {
                assert_eq!(ws.wavelet_lights_culled_glossy, 0);
            }
        }
        // The glossy term is really applied: without it the floor differs (the same transfer, F_g dropped).
        let mut diffuse_only = t.clone();
        diffuse_only.glossy_rows.clear();
        let g2 = GpuRelight::new(ctx(), scene.clone(), view.clone(), &diffuse_only, col.clone()).unwrap();
        let (with, _) = g.relight(l.clone(), 0.0).unwrap();
        let (without, _) = g2.relight(l.clone(), 0.0).unwrap();
        let pick = |img: &[f32]| -> Vec<f32> { floor.iter().flat_map(|&i| img[3 * i..3 * i + 3].to_vec()).collect() };
        let share = rel_l2(&pick(&without), &pick(&with));
        assert!(share > 0.05, "bounces {bounces}: F_g's share of the glossy pixels' radiance {share}");
    }
}

/// The default hybrid visibility (shadow maps where certain, exact rays elsewhere) stays close to the
/// exact CPU result; a bad light set is refused.
#[test]
fn gpu_relight_hybrid_is_close_and_bad_input_is_refused() {
    let (scene, view, tracer) = setup(16);
    let l = lights(&scene);
    let opts = TransferOptions { gather: 256, coefficients: 64, ..Default::default() };
    let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
    let g = GpuRelight::new(ctx(), scene.clone(), view.clone(), &t, ColumnOptions::default()).unwrap();
    let (want, _) = crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), l.clone(), 0.0).unwrap();
    let (got, _) = g.relight(l.clone(), 0.0).unwrap();
    let e = rel_l2(&got, &want);
    // Measured on lavapipe: 1.3e-4 (6.0e-8 without the VPL). Two gather samples on the ceiling just
    // above the luminaire (0.6 units behind it) are taken as lit from the VPL ~620 units away: the
    // hybrid's lit tolerance includes 16 ulps of Depth32Float depth, ~1.5 units at that distance with the
    // near plane at 1e-3 of the scene radius. The camera sees no such point: the view's direct light
    // agrees with exact rays to 2e-8.
    assert!(e < 1e-3, "relative L2 {e}");
    // Another light set on the same setup (the backend's lights are replaced): a single wide spot.
    let (c, r) = crate::lights::scene_sphere(&scene);
    let mut spot = LightSet::new(c, r);
    spot.push_spot(Vec3::new(400.0, 500.0, 200.0), Vec3::new(-0.3, -1.0, 0.2).normalize(), Vec3::splat(5e5), 1.4, 1.2).unwrap();
    let spot = Arc::new(spot);
    let (want, _) = crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), spot.clone(), 0.0).unwrap();
    let (got, _) = g.relight(spot, 0.0).unwrap();
    let e = rel_l2(&got, &want);
    // Measured: 2.4e-7.
    assert!(e < 1e-5, "second light set (a spot with a cube shadow map): relative L2 {e}");
    let empty = Arc::new(LightSet::new(Vec3::ZERO, 1.0));
    assert!(g.relight(empty, 0.0).unwrap_err().to_string().contains("empty"));
    let mut bad = (*l).clone();
    bad.intensity[1] = Vec3::new(1.0, f32::NAN, 1.0);
    assert!(g.relight(Arc::new(bad), 0.0).unwrap_err().to_string().contains("light 1"));
    for eps in [-1.0, f32::NAN, f32::INFINITY] {
        assert!(g.relight(l.clone(), eps).unwrap_err().to_string().contains("epsilon"));
    }
    // A transfer of another image size.
    let (_, small, _) = setup(8);
    let e = GpuRelight::new(ctx(), scene.clone(), small, &t, ColumnOptions::default()).err().unwrap().to_string();
    assert!(e.contains("precomputed for 16x16"), "{e}");
}

/// The GPU Haar passes give `haar::forward` bit for bit (same arithmetic, no fused operations to form).
#[test]
fn gpu_haar_equals_cpu_haar() {
    let ctx = ctx();
    let device = &ctx.device;
    let passes = RelightPasses::new(device);
    for side in [2u32, 8, 64] {
        let n = (side * side) as usize;
        let img: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let x = i as f32;
                [(x * 0.37).sin() + 1.5, (x * 0.11).cos() * 3.0, 1.0 / (1.0 + x), 0.0]
            })
            .collect();
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let image = storage_buffer(device, "test::image", &img, usage).unwrap();
        let zeros = vec![[0f32; 4]; n];
        let (s0, s1, coeffs) = (
            storage_buffer(device, "s0", &zeros, usage).unwrap(),
            storage_buffer(device, "s1", &zeros, usage).unwrap(),
            storage_buffer(device, "c", &zeros, usage).unwrap(),
        );
        let mut enc = device.create_command_encoder(&Default::default());
        passes.encode_haar(device, &mut enc, side, &image, [&s0, &s1], &coeffs).unwrap();
        ctx.queue.submit(Some(enc.finish()));
        let got: Vec<[f32; 4]> = ctx.read_buffer(&coeffs, 0, n).unwrap();
        let mut want: Vec<f32> = img.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        haar::forward(&mut want, side as usize, 3).unwrap();
        let got: Vec<f32> = got.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        assert_eq!(got, want, "side {side}");
    }
}

/// Rows longer than one dispatch's chunk and rows split over several binding-sized parts sum exactly as
/// a sequential loop (the chunks continue the same running sum).
#[test]
fn sparse_products_split_over_chunks_and_parts() {
    let ctx = ctx();
    let device = &ctx.device;
    let passes = RelightPasses::new(device);
    let n = 4 * ROW_CHUNK as usize + 17;
    let lights: Vec<[f32; 4]> = (0..n).map(|j| [1.0 + (j % 7) as f32, 0.5, -((j % 3) as f32), 0.0]).collect();
    let rows: Vec<SparseRow> = (0..9)
        .map(|r| {
            let len = if r == 4 { n } else { r * 13 };
            let index: Vec<u32> = (0..len as u32).map(|k| (k * 7 + r as u32) % n as u32).collect();
            let value: Vec<f32> = (0..len).map(|k| 1.0 / (1.0 + (k + r) as f32)).collect();
            SparseRow { index, value }
        })
        .collect();
    let want: Vec<[f32; 3]> = rows
        .iter()
        .map(|row| {
            let mut s = [0f32; 3];
            for (&j, &f) in row.index.iter().zip(&row.value) {
                for c in 0..3 {
                    s[c] += f * lights[j as usize][c];
                }
            }
            s
        })
        .collect();
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let light_buf = storage_buffer(device, "lights", &lights, usage).unwrap();
    let refs: Vec<&SparseRow> = rows.iter().collect();
    // One part; parts of at most n coefficients (the long row alone); tiny parts of at most 64 (rows 0-3).
    for (max_binding, count) in [(1u64 << 27, rows.len()), (4 * n as u64, rows.len()), (256, 4)] {
        let parts = SparseParts::upload(device, &refs[..count], 1, max_binding, "test rows").unwrap();
        assert_eq!(parts.parts.len() > 1, max_binding < 1 << 27, "{max_binding}: {} parts", parts.parts.len());
        let partial = storage_buffer(device, "partial", &vec![[0f32; 4]; count], usage).unwrap();
        let mut enc = device.create_command_encoder(&Default::default());
        parts.encode(device, &mut enc, &passes, &light_buf, &partial).unwrap();
        ctx.queue.submit(Some(enc.finish()));
        let got: Vec<[f32; 4]> = ctx.read_buffer(&partial, 0, count).unwrap();
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                assert!((g[c] - w[c]).abs() <= 1e-5 * w[c].abs().max(1.0), "{max_binding}: row {r} channel {c}: {} vs {}", g[c], w[c]);
            }
        }
    }
    // A single row above one binding is refused, not truncated.
    let e = SparseParts::upload(device, &refs[4..5], 1, 1024, "test rows").err().unwrap().to_string();
    assert!(e.contains("storage binding limit"), "{e}");
    // RGB rows (`product_rgb`): three values per coefficient, each times its channel of the light; parts
    // sized by the values (3 per coefficient): a binding of 3 n values holds the long row alone.
    let rgb: Vec<SparseRow> = rows
        .iter()
        .enumerate()
        .map(|(r, row)| SparseRow {
            index: row.index.clone(),
            value: row.value.iter().flat_map(|&v| [v, -0.5 * v, v * (1.0 + r as f32)]).collect(),
        })
        .collect();
    let want: Vec<[f32; 3]> = rgb
        .iter()
        .map(|row| {
            let mut s = [0f32; 3];
            for (k, &j) in row.index.iter().enumerate() {
                for c in 0..3 {
                    s[c] += row.value[3 * k + c] * lights[j as usize][c];
                }
            }
            s
        })
        .collect();
    let refs: Vec<&SparseRow> = rgb.iter().collect();
    for max_binding in [1u64 << 27, 12 * n as u64] {
        let parts = SparseParts::upload(device, &refs, 3, max_binding, "test rgb rows").unwrap();
        assert_eq!(parts.parts.len() > 1, max_binding < 1 << 27, "{max_binding}: {} parts", parts.parts.len());
        let partial = storage_buffer(device, "partial", &vec![[0f32; 4]; rgb.len()], usage).unwrap();
        let mut enc = device.create_command_encoder(&Default::default());
        parts.encode(device, &mut enc, &passes, &light_buf, &partial).unwrap();
        ctx.queue.submit(Some(enc.finish()));
        let got: Vec<[f32; 4]> = ctx.read_buffer(&partial, 0, rgb.len()).unwrap();
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                assert!((g[c] - w[c]).abs() <= 1e-5 * w[c].abs().max(1.0), "rgb {max_binding}: row {r} channel {c}: {} vs {}", g[c], w[c]);
            }
        }
    }
    let e = SparseParts::upload(device, &refs[4..5], 3, 4 * n as u64, "test rgb rows").err().unwrap().to_string();
    assert!(e.contains("3 values each") && e.contains("storage binding limit"), "{e}");
    // Values that do not match the channels are refused.
    let e = SparseParts::upload(device, &refs[1..2], 1, 1 << 27, "test rows").err().unwrap().to_string();
    assert!(e.contains("1 per index"), "{e}");
}

/// Relights per second and stage times, CPU vs GPU, on the bundled Cornell box with a moving spot light
/// (default transfer: 4^7 gather samples, 100 coefficients per row). Sizes from `RELIGHT_BENCH_SIZES`
/// (default "128x128,320x240"), bounces from `RELIGHT_BENCH_BOUNCES` (default "1"; b > 1 with the default
/// photon-mapped M). Run: `cargo test --release bench_relight -- --ignored --nocapture`.
///
/// Measured on the 2-core test machine, lavapipe, 320x240, epsilon 0 (medians of 6): see
/// `relight::gpu::choose_device`.
#[test]
#[ignore]
fn bench_relight() {
    let sizes = std::env::var("RELIGHT_BENCH_SIZES").unwrap_or_else(|_| "128x128,320x240".into());
    let bounce_counts = std::env::var("RELIGHT_BENCH_BOUNCES").unwrap_or_else(|_| "1".into());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join("cbox").join("scene.xml");
    for size in sizes.split(',') {
        let (w, h) = size.split_once('x').map(|(a, b)| (a.parse().unwrap(), b.parse().unwrap())).unwrap();
        let scene = load_scene(&path, &LoadOptions { size: Some((w, h)), ..Default::default() }).unwrap();
        let tracer = RayTracer::new(&scene).unwrap();
        let ids = crate::view::resolve::cast_visibility_traced(&scene, &tracer).unwrap();
        let view = crate::view::resolve::resolve_view_samples_with(&scene, &ids, &ChainOptions::default()).unwrap();
        let (scene, view, tracer) = (Arc::new(scene), Arc::new(view), Arc::new(tracer));
        for bounces in bounce_counts.split(',').map(|b| b.parse::<u32>().unwrap()) {
            let t0 = Instant::now();
            let t = Transfer::new(&scene, &view, &tracer, &TransferOptions { bounces, ..Default::default() }, &mut |_, _| {}).unwrap();
            eprintln!(
                "{w}x{h} bounces {bounces}: precompute {:.1} s, {:.1} coefficients per row, {} photon coefficients, {} glossy pixels",
                t0.elapsed().as_secs_f64(),
                t.coefficients_kept() as f64 / t.rows.len() as f64,
                t.photon_coefficients_kept(),
                t.glossy_pixels
            );
            let (c, r) = crate::lights::scene_sphere(&scene);
            let spot = |k: usize| {
                let mut s = LightSet::new(c, r);
                let x = 30.0 * k as f32 - 100.0;
                s.push_spot(Vec3::new(278.0 + x, 530.0, 279.0), Vec3::new(-0.002 * x, -1.0, 0.1).normalize(), Vec3::splat(4e5), 0.6, 0.45)
                    .unwrap();
                Arc::new(s)
            };
            let g = GpuRelight::new(ctx(), scene.clone(), view.clone(), &t, ColumnOptions::default()).unwrap();
            for epsilon in [0.0f32, 1e-3] {
                for device in ["cpu", "gpu"] {
                    let mut all = Vec::new();
                    for k in 0..8 {
                        let t1 = Instant::now();
                        let (_, st) = if device == "gpu" {
                            g.relight(spot(k), epsilon).unwrap()
                        } else {
                            crate::relight::relight::relight(&t, scene.clone(), view.clone(), tracer.clone(), spot(k), epsilon).unwrap()
                        };
                        all.push((t1.elapsed().as_secs_f64(), st));
                    }
                    all.drain(..2); // warm-up
                    all.sort_by(|a, b| a.0.total_cmp(&b.0));
                    let (total, st) = &all[all.len() / 2];
                    eprintln!(
                        "{w}x{h} bounces {bounces} {device} eps {epsilon}: {:.2} relights/s (median {:.1} ms): shadow maps {:.1}, gather direct {:.1}, bounces {:.1}, \
                         wavelet {:.1}, transfer {:.1}, view direct {:.1}, readback {:.1} ms; wavelet lights {} culled {}",
                        1.0 / total, total * 1e3, st.seconds_shadow_maps * 1e3, st.seconds_gather_direct * 1e3, st.seconds_bounces * 1e3,
                        st.seconds_wavelet * 1e3, st.seconds_transfer * 1e3, st.seconds_view_direct * 1e3, st.seconds_readback * 1e3,
                        st.wavelet_lights, st.wavelet_lights_culled
                    );
                }
            }
        }
    }
}
