//! The mask table of `tests/data/mask_leaves.xml` (a constant and a checkerboard opacity), and the GPU
//! backend's light matrix of that scene against the CPU backend's at max_depth 2, 3 and -1: brute-force
//! images in every visibility mode, and columns and rows with exact rays; with bitmap opacities; and without
//! the floor, where masked camera paths escape (P_valid < 1, `direct_factor`); the refusal of a bump map
//! inside a mask.
use super::*;
use crate::cpu::CpuBackend;
use crate::lights::generate::{generate_lights, GenerateOptions};
use crate::matrix::backend::Backend;
use crate::matrix::gpu::GpuBackend;
use crate::matrix::rows::RowOptions;
use crate::matrix::{ColumnOptions, Visibility};
use crate::raytrace::RayTracer;
use crate::scene::xml::{load_scene, LoadOptions};
use crate::view::chains::{trace_chains, ChainOptions};
use std::sync::Arc;

/// GPU against CPU, relative L2 (the project's GPU-vs-CPU tolerance, `tests/lights/test_lights.py`).
const GPU_VS_CPU_TOL: f64 = 1.5e-3;

fn leaves() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mask_leaves.xml");
    load_scene(&path, &LoadOptions::default()).unwrap()
}

fn relative_l2(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len());
    let num: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    let den: f64 = b.iter().map(|&y| (y as f64).powi(2)).sum();
    (num / den).sqrt()
}

#[test]
fn table_of_mask_leaves() {
    let scene = leaves();
    let id = |name: &str| scene.meshes.iter().position(|m| m.id == name).unwrap();
    let records = mesh_records(&scene);
    assert_eq!((records[id("floor")], records[id("light")]), (NO_MASK, NO_MASK));
    let t = MaskTable::build(&scene);
    let c = records[id("leaf-constant")] as usize;
    assert_eq!(t.words[c..c + MESH_HEADER], [CONSTANT, 0.5f32.to_bits(), 0, 0]);
    let k = records[id("leaf-textured")] as usize;
    let m = &scene.meshes[id("leaf-textured")];
    assert_eq!(m.indices.len(), 2);
    assert_eq!(t.words[k + 2], !m.uvs.is_empty() as u32);
    let uv_words = if m.uvs.is_empty() { 0 } else { 6 * m.indices.len() };
    for (n, tri) in m.indices.iter().enumerate().filter(|_| uv_words > 0) {
        for (v, &i) in tri.iter().enumerate() {
            let w = k + MESH_HEADER + 6 * n + 2 * v;
            assert_eq!([f32::from_bits(t.words[w]), f32::from_bits(t.words[w + 1])], m.uvs[i as usize].to_array());
        }
    }
    // The checkerboard's record follows the mesh records: its `eval_1` values (Mitsuba's inverted means) and
    // `to_uv` (a scale by 3).
    let src = t.words[k] as usize;
    assert_eq!(src, k + MESH_HEADER + uv_words);
    assert_eq!(t.words[src], 1);
    let mean = |x: f32| (x + x + x) / 3.0;
    assert_eq!([f32::from_bits(t.words[src + TEXTURE_HEADER]), f32::from_bits(t.words[src + TEXTURE_HEADER + 1])], [mean(0.85), mean(0.1)]);
    assert_eq!([f32::from_bits(t.words[src + 5]), f32::from_bits(t.words[src + 9]), f32::from_bits(t.words[src + 13])], [3.0, 3.0, 1.0]);
    assert_eq!(t.words.len(), src + TEXTURE_HEADER + 2);
    // Without masks: no table, every primitive unmasked.
    let mut opaque = scene.clone();
    opaque.bsdfs =
        opaque.bsdfs.iter().map(|b| if let Bsdf::Mask { nested, .. } = b { scene.bsdfs[*nested].clone() } else { b.clone() }).collect();
    assert!(MaskTable::build(&opaque).words.is_empty());
    assert!(mesh_records(&opaque).iter().all(|&r| r == NO_MASK));
}

#[test]
fn light_fields_follow_which_lights_cross_masks() {
    let scene = leaves();
    let mut view = crate::testing::scenes::cast_view(&scene);
    trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(-1).unwrap()).unwrap();
    let lights = generate_lights(&scene, &GenerateOptions { area: 4, ..Default::default() }).unwrap();
    let light = scene.meshes.iter().position(|m| m.id == "light").unwrap();
    for j in 0..lights.len() {
        let [pdf, passes] = light_fields(&view, &lights, j, false);
        assert_eq!(passes, 1.0);
        assert_eq!(light_fields(&view, &lights, j, true)[1], 1.0);
        // 1 / (area 1.2 x 1.2 x 1 emitter): Mitsuba's area density of the light's mesh.
        assert_eq!(pdf, view.mask_emitter_pdf[light]);
        assert!((pdf - 1.0 / 1.44).abs() < 1e-5, "{pdf}");
    }
    let mut points = crate::lights::LightSet::new(glam::Vec3::ZERO, 10.0);
    points.push_point(glam::Vec3::Y, glam::Vec3::ONE).unwrap();
    assert_eq!(light_fields(&view, &points, 0, true), [0.0, 0.0]);
}

#[test]
fn gpu_matches_cpu_on_mask_leaves() {
    let scene = Arc::new(leaves());
    let lights = Arc::new(generate_lights(&scene, &GenerateOptions { area: 64, ..Default::default() }).unwrap());
    let ctx = crate::testing::gpu_context();
    let tracer = Arc::new(RayTracer::new(&scene).unwrap());
    let js: Vec<usize> = (0..lights.len()).collect();
    let ones = vec![[1.0f32; 3]; js.len()];
    let mut sums = Vec::new();
    for depth in [2, 3, -1] {
        let mut view = crate::testing::scenes::cast_view(&scene);
        trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(depth).unwrap()).unwrap();
        let view = Arc::new(view);
        let cpu = CpuBackend::new(tracer.clone(), view.clone(), lights.clone()).unwrap();
        let reference = cpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap();
        for visibility in [Visibility::RayTraced, Visibility::Hybrid, Visibility::ShadowMap] {
            let opts = ColumnOptions { visibility, ..Default::default() };
            let gpu = GpuBackend::new(ctx.clone(), scene.clone(), view.clone(), lights.clone(), opts).unwrap();
            let img = gpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap();
            let err = relative_l2(&img, &reference);
            let stats = gpu.visibility_stats().unwrap();
            println!("max_depth {depth}, {visibility:?}: GPU vs CPU relative L2 {err:.2e}, {stats:?}");
            // Shadow maps alone are approximate at shadow edges (measured 0.28% to 0.72%).
            let tol = if visibility == Visibility::ShadowMap { 0.015 } else { GPU_VS_CPU_TOL };
            assert!(err <= tol, "max_depth {depth}, {visibility:?}: relative L2 {err}");
            assert_eq!(stats.gave_up, 0);
            if visibility == Visibility::RayTraced {
                sums.push(img.iter().map(|&x| x as f64).sum::<f64>());
                let js3 = [0, 17, 42];
                let err = relative_l2(&gpu.columns(&js3).unwrap(), &cpu.columns(&js3).unwrap());
                println!("max_depth {depth}: columns GPU vs CPU relative L2 {err:.2e}");
                assert!(err <= GPU_VS_CPU_TOL, "max_depth {depth}: columns relative L2 {err}");
                // Rows of every 53rd pixel (on the quads, in their shadows and beside them).
                let is: Vec<usize> = (0..view.num_pixels()).step_by(53).collect();
                let (rows_gpu, _) = gpu.rows(&is, &RowOptions::default(), &mut |_, _| {}).unwrap();
                let (rows_cpu, _) = cpu.rows(&is, &RowOptions::default(), &mut |_, _| {}).unwrap();
                let err = relative_l2(&rows_gpu, &rows_cpu);
                println!("max_depth {depth}: rows GPU vs CPU relative L2 {err:.2e}");
                assert!(err <= GPU_VS_CPU_TOL, "max_depth {depth}: rows relative L2 {err}");
            }
        }
    }
    // Light crosses the masks only with depth to spare: more light at max_depth 3 than 2 (measured +35%), and
    // at -1 than 3 (+0.7%: the floor seen through a mask, lit through a mask).
    assert!(sums[1] > 1.2 * sums[0] && sums[2] > 1.003 * sums[1], "{sums:?}");
}

#[test]
fn gpu_matches_cpu_with_bitmap_opacities() {
    // The checkerboard replaced by a 5 x 3 RGB bitmap (bilinear with repeat, then nearest with mirror): the
    // GPU's texel lookups and luminance against the CPU's `eval_1`.
    let ctx = crate::testing::gpu_context();
    for (filter, wrap) in [(FilterType::Bilinear, WrapMode::Repeat), (FilterType::Nearest, WrapMode::Mirror)] {
        let mut scene = leaves();
        let data: Vec<glam::Vec3> =
            (0..15).map(|k| glam::Vec3::new((k % 4) as f32 * 0.3, (k % 3) as f32 * 0.45, (k % 5) as f32 * 0.2)).collect();
        scene.textures[0] = Texture::Bitmap {
            width: 5,
            height: 3,
            data,
            filter,
            wrap,
            to_uv: glam::Mat3::from_scale(glam::Vec2::new(1.7, 2.3)),
            loc: Default::default(),
        };
        let scene = Arc::new(scene);
        let lights = Arc::new(generate_lights(&scene, &GenerateOptions { area: 32, ..Default::default() }).unwrap());
        let mut view = crate::testing::scenes::cast_view(&scene);
        trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(-1).unwrap()).unwrap();
        let view = Arc::new(view);
        let js: Vec<usize> = (0..lights.len()).collect();
        let ones = vec![[1.0f32; 3]; js.len()];
        let cpu = CpuBackend::new(Arc::new(RayTracer::new(&scene).unwrap()), view.clone(), lights.clone()).unwrap();
        let reference = cpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap();
        let opts = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
        let gpu = GpuBackend::new(ctx.clone(), scene.clone(), view.clone(), lights.clone(), opts).unwrap();
        let err = relative_l2(&gpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap(), &reference);
        println!("{filter:?} / {wrap:?}: GPU vs CPU relative L2 {err:.2e}");
        assert!(err <= GPU_VS_CPU_TOL, "{filter:?} / {wrap:?}: relative L2 {err}");
    }
}

#[test]
fn gpu_matches_cpu_where_masked_paths_escape() {
    // mask_leaves.xml without its floor: camera rays through the quads escape, so their view samples have
    // P_valid = opacity < 1 and the direct light is weighted by `direct_factor` (P + (1 - P) w_B, w_B from
    // the BSDF-sampling density: a rough dielectric quad, and a roughplastic one for the microfacet branch).
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mask_leaves.xml")).unwrap();
    let floor_start = text.find("<shape type=\"rectangle\" id=\"floor\">").unwrap();
    let floor_end = floor_start + text[floor_start..].find("</shape>").unwrap() + "</shape>".len();
    let mut xml = format!("{}{}", &text[..floor_start], &text[floor_end..]);
    let blue = "<bsdf type=\"diffuse\">\n                <rgb name=\"reflectance\" value=\"0.2, 0.5, 0.8\"/>\n            </bsdf>";
    assert!(xml.contains(blue));
    xml = xml.replace(
        blue,
        "<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/>\
         <rgb name=\"diffuse_reflectance\" value=\"0.2, 0.5, 0.8\"/></bsdf>",
    );
    let red = "<bsdf type=\"diffuse\">\n                <rgb name=\"reflectance\" value=\"0.8, 0.3, 0.2\"/>\n            </bsdf>";
    assert!(xml.contains(red));
    xml = xml.replace(red, "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.4\"/></bsdf>");
    let dir = std::env::temp_dir().join(format!("ml-gpu-mask-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("escape.xml");
    std::fs::write(&path, &xml).unwrap();
    let scene = Arc::new(load_scene(&path, &LoadOptions::default()).unwrap());
    std::fs::remove_dir_all(&dir).ok();
    assert!(scene.meshes.iter().all(|m| m.id != "floor"));
    let lights = Arc::new(generate_lights(&scene, &GenerateOptions { area: 64, ..Default::default() }).unwrap());
    let ctx = crate::testing::gpu_context();
    let js: Vec<usize> = (0..lights.len()).collect();
    let ones = vec![[1.0f32; 3]; js.len()];
    for depth in [2, -1] {
        let mut view = crate::testing::scenes::cast_view(&scene);
        trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(depth).unwrap()).unwrap();
        let escaping = view.mask_valid.iter().filter(|&&v| v < 1.0).count();
        assert!(escaping > 100, "max_depth {depth}: {escaping} samples with P_valid < 1");
        // The BSDF-sampling weight w_B takes part: the factor exceeds P_valid by 1e-3 for many (sample, light)
        // pairs (measured 8344 above 1e-3: the light is small, so w_B stays small).
        let raised = (0..view.len())
            .filter(|&i| view.mask_valid[i] < 1.0)
            .flat_map(|i| (0..lights.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                let sp = crate::cpu::ShadingPoint::new(&view, i);
                let wo = (lights.position[j] - sp.p).normalize();
                let wo_local = glam::Vec3::new(wo.dot(sp.s), wo.dot(sp.t), wo.dot(sp.n));
                crate::raytrace::mask::direct_factor(&view, &lights, i, sp.p, sp.wi_local, wo_local, j) > view.mask_valid[i] + 1e-3
            })
            .count();
        assert!(raised > 100, "max_depth {depth}: {raised} pairs with w_B > 1e-3");
        let view = Arc::new(view);
        let cpu = CpuBackend::new(Arc::new(RayTracer::new(&scene).unwrap()), view.clone(), lights.clone()).unwrap();
        let reference = cpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap();
        let opts = ColumnOptions { visibility: Visibility::RayTraced, ..Default::default() };
        let gpu = GpuBackend::new(ctx.clone(), scene.clone(), view.clone(), lights.clone(), opts).unwrap();
        let img = gpu.weighted_sum(&js, &ones, &mut |_, _| {}).unwrap();
        let err = relative_l2(&img, &reference);
        println!(
            "max_depth {depth}: {escaping} samples with P_valid < 1, {raised} pairs with w_B > 1e-3; GPU vs CPU relative L2 {err:.2e}"
        );
        assert!(err <= GPU_VS_CPU_TOL, "max_depth {depth}: relative L2 {err}");
    }
}

#[test]
fn unsupported_names_a_bump_map_inside_a_mask() {
    let mut scene = leaves();
    assert_eq!(unsupported(&scene), None);
    let Some(Bsdf::Mask { nested, .. }) = scene.bsdfs.iter().find(|b| matches!(b, Bsdf::Mask { .. })).cloned() else { unreachable!() };
    let inner = scene.bsdfs.len();
    scene.bsdfs.push(scene.bsdfs[nested].clone());
    scene.bsdfs[nested] = Bsdf::BumpMap { texture: 0, scale: 1.0, nested: inner };
    assert!(unsupported(&scene).unwrap().contains("a mask BSDF around a bumpmap"));
}

#[test]
fn a_vpl_crosses_its_depth_fewer_masks_than_the_view_samples_budget() {
    // A VPL above the constant leaf (opacity 0.5 at y = 0.8 over x in [-1.1, -0.1], z in [-0.2, 0.8]) and one
    // above open floor; the shadow rays start on the floor below them. A VPL of depth d: budget b lets it
    // cross b - d masks, and b < d none of its light at all (`cpu::mask_visibility_at`).
    let scene = leaves();
    let tracer = RayTracer::new(&scene).unwrap();
    let mut vpls = crate::lights::LightSet::new(glam::Vec3::ZERO, 10.0);
    let down = glam::Vec3::NEG_Y;
    for q in [glam::Vec3::new(-0.6, 1.5, 0.3), glam::Vec3::new(2.0, 1.0, 2.0)] {
        vpls.push_vpl(q, down, down, down, glam::Vec3::ONE, bytemuck::Zeroable::zeroed()).unwrap();
    }
    let visibility = |vpls: &crate::lights::LightSet, j: usize, budget: u32| {
        let p = vpls.position[j] * glam::Vec3::new(1.0, 0.0, 1.0);
        let d = vpls.position[j] - p;
        crate::cpu::mask_visibility_at(&tracer, vpls, j, p, glam::Vec3::Y, d.normalize(), d.length(), budget).0
    };
    for (budget, through_leaf, open) in [(0, 0.0, 0.0), (1, 0.0, 1.0), (2, 0.5, 1.0), (u32::MAX, 0.5, 1.0)] {
        assert_eq!((visibility(&vpls, 0, budget), visibility(&vpls, 1, budget)), (through_leaf, open), "budget {budget}");
    }
    let mut view = crate::testing::scenes::cast_view(&scene);
    trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(3).unwrap()).unwrap();
    assert_eq!(light_fields(&view, &vpls, 0, false), [0.0, 2.0]);
    // A second-bounce VPL needs one more unit of depth.
    vpls.set_vpl_depth(0, 2).unwrap();
    vpls.set_vpl_depth(1, 2).unwrap();
    for (budget, through_leaf, open) in [(1, 0.0, 0.0), (2, 0.0, 1.0), (3, 0.5, 1.0), (u32::MAX, 0.5, 1.0)] {
        assert_eq!((visibility(&vpls, 0, budget), visibility(&vpls, 1, budget)), (through_leaf, open), "depth 2, budget {budget}");
    }
    assert_eq!(light_fields(&view, &vpls, 0, false), [0.0, 3.0]);
    assert!(vpls.set_vpl_depth(0, 0).is_err());
}
