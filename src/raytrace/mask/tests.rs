//! Masked surfaces on `tests/data/mask_leaves.xml`: shadow-ray transmittance with its depth budget, the
//! budget per depth, and the delta-chain samples of a masked pixel.
use super::*;
use crate::scene::xml::{load_scene, LoadOptions};
use crate::view::chains::{trace_chains, ChainOptions};

fn leaves() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mask_leaves.xml");
    load_scene(&path, &LoadOptions::default()).unwrap()
}

#[test]
fn transmittance_is_one_minus_opacity_within_the_budget() {
    let scene = leaves();
    let rt = RayTracer::new(&scene).unwrap();
    assert!(rt.masks().any() && !rt.masks().environment);
    // Straight up from the floor under the centre of the opacity-0.5 quad (y = 0.8) to a point above it
    // (beside the light).
    let (p, n_g, q) = (Vec3::new(-0.6, 0.0, 0.3), Vec3::Y, Vec3::new(-0.6, 1.5, 0.3));
    assert_eq!(rt.mask_transmittance(p, n_g, Some(q), Vec3::Y, 1), 0.5);
    assert_eq!(rt.mask_transmittance(p, n_g, Some(q), Vec3::Y, u32::MAX), 0.5);
    assert_eq!(rt.mask_transmittance(p, n_g, Some(q), Vec3::Y, 0), 0.0);
    // The same toward infinity (a directional light), and short of the quad: nothing in the way.
    assert_eq!(rt.mask_transmittance(p, n_g, None, Vec3::Y, 1), 0.5);
    assert_eq!(rt.mask_transmittance(p, n_g, Some(Vec3::new(-0.6, 0.7, 0.3)), Vec3::Y, 0), 1.0);
    // Through the (unmasked) floor from below: blocked whatever the budget.
    assert_eq!(rt.mask_transmittance(Vec3::new(2.0, -1.0, 2.0), -Vec3::Y, Some(Vec3::new(2.0, 0.5, 2.0)), Vec3::Y, u32::MAX), 0.0);
}

#[test]
fn budget_follows_mitsuba_depth() {
    let b = |d: i64, k: u32| ChainOptions::with_max_depth(d).unwrap().mask_budget(k);
    assert_eq!(b(-1, 0), u32::MAX);
    assert_eq!(b(-1, 7), u32::MAX);
    assert_eq!(b(2, 0), 0);
    assert_eq!(b(3, 0), 1);
    assert_eq!(b(3, 1), 0);
    assert_eq!(b(5, 1), 2);
}

#[test]
fn masked_pixel_splits_into_the_surface_and_what_is_behind() {
    let scene = leaves();
    let mut view = crate::testing::scenes::cast_view(&scene);
    let m = view.num_pixels();
    let constant = scene.meshes.iter().position(|x| x.id == "leaf-constant").unwrap() as i32;
    let floor = scene.meshes.iter().position(|x| x.id == "floor").unwrap() as i32;
    let pixel = (0..m).find(|&i| view.shape_index[i] == constant).expect("a pixel on the constant quad");
    let stats = trace_chains(&scene, &mut view, &ChainOptions::with_max_depth(-1).unwrap()).unwrap();
    assert!(stats.extra_samples > 0);
    assert_eq!(view.throughput[pixel], Vec3::splat(0.5));
    // The floor behind it: throughput 1 - 0.5, reached by a null event, shadow rays unlimited; the quad's own
    // light counts in full (P_valid = 1: the floor behind samples its BSDF).
    let extra: Vec<usize> = view.samples_of_pixel(pixel).skip(1).collect();
    assert_eq!(extra.len(), 1);
    let e = extra[0];
    assert_eq!(view.shape_index[e], floor);
    assert_eq!(view.throughput[e], Vec3::splat(0.5));
    assert_eq!((view.mask_budget[pixel], view.mask_budget[e]), (u32::MAX, u32::MAX));
    assert_eq!((view.mask_valid[pixel], view.mask_opacity[pixel], view.mask_opacity[e]), (1.0, 0.5, 1.0));
    assert!((view.wi[e] - view.wi[pixel]).length() < 1e-6);
    // At max_depth 2 the floor behind would not sample emitters: no extra sample, and the floor pixels'
    // shadow rays may cross no mask.
    let mut view2 = crate::testing::scenes::cast_view(&scene);
    trace_chains(&scene, &mut view2, &ChainOptions::with_max_depth(2).unwrap()).unwrap();
    assert_eq!(view2.len(), m);
    assert_eq!(view2.throughput[pixel], Vec3::splat(0.5));
    assert!(view2.mask_budget.iter().all(|&b| b == 0));
    // max_depth 3: the floor behind is a sample whose shadow rays may cross no mask.
    let mut view3 = crate::testing::scenes::cast_view(&scene);
    trace_chains(&scene, &mut view3, &ChainOptions::with_max_depth(3).unwrap()).unwrap();
    let e3 = view3.samples_of_pixel(pixel).nth(1).unwrap();
    assert_eq!((view3.mask_budget[pixel], view3.mask_budget[e3]), (1, 0));
}
