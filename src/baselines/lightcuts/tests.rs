//! Lightcuts: the cluster bounds hold for every light below a node at every receiver (diffuse and
//! glossy BSDFs, every light kind, clamped VPLs), the per-pixel error stays within the requested bound,
//! reconstruction cuts stay close with fewer rays, and bad input is an error.
use super::*;
use crate::baselines::cut_tree::material_bound;
use crate::baselines::reconstruction_cuts;
use crate::lights::{generate_lights, GenerateOptions};
use std::sync::Arc;

/// A scene file with the given parameters on the CPU backend with the given lights.
fn matrix(xml: &std::path::Path, params: &[(&str, u32)], gen: GenerateOptions) -> LightMatrix {
    use crate::scene::{load_scene, LoadOptions};
    let params = params.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let opts = LoadOptions { params, size: None, ..Default::default() };
    let scene = Arc::new(load_scene(xml, &opts).unwrap());
    let lights = Arc::new(generate_lights(&scene, &gen).unwrap());
    let tracer = Arc::new(crate::raytrace::RayTracer::new(&scene).unwrap());
    let ids = crate::view::resolve::cast_visibility_traced(&scene, &tracer).unwrap();
    let view = crate::view::resolve::resolve_view_samples_with(&scene, &ids, &Default::default()).unwrap();
    LightMatrix::new_cpu(tracer, scene, Arc::new(view), lights).unwrap()
}

/// cbox-lights (point, spot, directional, area, environment, clamped VPLs).
fn cbox_lights(res: u32) -> LightMatrix {
    let gen = GenerateOptions { area: 64, environment: 32, indirect: 400, seed: 5, ..Default::default() };
    matrix(&crate::testing::scene_file("cbox-lights/scene.xml"), &[("res", res)], gen)
}

/// Checks U_C >= sum of the unshadowed elements below C, per channel, at every `stride`-th surface
/// sample and every node; returns (checks, nodes with a finite non-zero bound).
fn check_bounds(a: &LightMatrix, stride: usize) -> (usize, usize) {
    let tree = CutTree::build(&a.lights, 1).unwrap();
    let n_nodes = tree.nodes.len();
    // Lights below each node (children are pushed before their parent).
    let mut below: Vec<Vec<u32>> = vec![Vec::new(); n_nodes];
    for k in 0..n_nodes {
        below[k] = if tree.nodes[k].is_leaf() {
            vec![tree.nodes[k].rep]
        } else {
            let [c0, c1] = tree.nodes[k].children;
            [below[c0 as usize].clone(), below[c1 as usize].clone()].concat()
        };
    }
    let (mut checks, mut finite) = (0, 0);
    for i in (0..a.view.len()).step_by(stride) {
        let sp = ShadingPoint::new(&a.view, i);
        if !sp.surface {
            continue;
        }
        let m = material_bound(&a.view.bsdf, i, &sp);
        assert!(!m.unbounded);
        let f: Vec<DVec3> =
            (0..a.lights.len()).map(|j| shade_unshadowed(&a.view, &a.lights, &sp, i, j).map_or(DVec3::ZERO, |s| s.0.as_dvec3())).collect();
        for k in 0..n_nodes {
            let u = tree.bound(k, &sp, &m, a.lights.vpl_clamp);
            let sum: DVec3 = below[k].iter().map(|&j| f[j as usize]).sum();
            assert!(
                (sum - u).max_element() <= 1e-6 * sum.max_element(),
                "sample {i} node {k} ({} lights, kind {:?}): bound {u} < exact {sum}",
                below[k].len(),
                a.lights.kind[tree.nodes[k].rep as usize]
            );
            checks += 1;
            finite += (u.max_element().is_finite() && u.max_element() > 0.0) as usize;
        }
    }
    (checks, finite)
}

#[test]
fn bounds_hold_for_every_light_kind_and_clamped_vpls() {
    let a = cbox_lights(12);
    assert!(a.lights.vpl_clamp.is_finite());
    let (checks, finite) = check_bounds(&a, 3);
    assert!(checks > 20_000 && finite > checks / 3, "{checks} checks, {finite} finite bounds");
}

#[test]
fn near_field_bounds_hold_next_to_area_lights() {
    // A panel 5 mm above a floor, a floor within millimetres of a panel's plane lit from its back, a disk
    // light in a ceiling recess: receivers inside the near field of many compact pieces.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    for (file, area) in [("nearfield_panel.xml", 256), ("twosided_wall.xml", 512), ("disk_recess.xml", 512)] {
        let gen = GenerateOptions { area, environment: 0, indirect: 0, seed: 3, ..Default::default() };
        let a = matrix(&root.join(file), &[("res", 16)], gen);
        let tree = CutTree::build(&a.lights, 1).unwrap();
        // Finite bounds of nodes whose box is within the near field of the receiver.
        let mut near_finite = 0;
        for i in 0..a.view.len() {
            let sp = ShadingPoint::new(&a.view, i);
            if !sp.surface {
                continue;
            }
            let m = material_bound(&a.view.bsdf, i, &sp);
            let p = sp.p.as_dvec3();
            for (k, node) in tree.nodes.iter().enumerate() {
                let d2 = (node.lo - p).max(DVec3::ZERO).max(p - node.hi).length_squared();
                let u = tree.bound(k, &sp, &m, a.lights.vpl_clamp).max_element();
                near_finite += (node.near > 0.0 && d2 > 0.0 && d2 < node.near * node.near && u.is_finite() && u > 0.0) as usize;
            }
        }
        let (checks, finite) = check_bounds(&a, 1);
        assert!(near_finite > 50 && finite > checks / 4, "{file}: {near_finite} near-field finite bounds, {finite} of {checks}");
    }
}

#[test]
fn bounds_hold_on_glossy_receivers() {
    let xml = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/glossy_blend.xml");
    let gen = GenerateOptions { area: 0, environment: 48, indirect: 60, seed: 2, ..Default::default() };
    let a = matrix(&xml, &[("width", 16), ("height", 12)], gen);
    let glossy = (0..a.view.len()).filter(|&i| a.view.bsdf[i].kind != crate::shading::bsdf::KIND_DIFFUSE).count();
    assert!(glossy > 20, "{glossy} glossy view samples");
    let (checks, finite) = check_bounds(&a, 2);
    assert!(checks > 2_000 && finite > 0, "{checks} checks, {finite} finite bounds");
}

/// Relative luminance error per lit pixel against the exact column sum.
fn rel_errors(image: &[f32], truth: &[f32]) -> Vec<f64> {
    let l = |v: &[f32]| 0.2126 * v[0] as f64 + 0.7152 * v[1] as f64 + 0.0722 * v[2] as f64;
    image.chunks(3).zip(truth.chunks(3)).filter(|(_, t)| l(t) > 0.0).map(|(x, t)| (l(x) - l(t)).abs() / l(t)).collect()
}

fn fraction_within(image: &[f32], truth: &[f32], bound: f64) -> f64 {
    let e = rel_errors(image, truth);
    e.iter().filter(|&&x| x <= bound).count() as f64 / e.len() as f64
}

#[test]
fn lightcuts_meet_the_error_bound_and_reconstruction_cuts_save_rays() {
    let a = cbox_lights(24);
    let truth = a.column_sum(None, &mut |_, _| {}).unwrap();
    let tree = CutTree::build(&a.lights, 7).unwrap();
    let n = a.lights.len() as f32;
    // The per-pixel criterion bounds each pixel's error (bounds above are >= the exact sums).
    let px = lightcuts(&a, &tree, 0.02, 1000, Criterion::Pixel).unwrap();
    let within = fraction_within(&px.image, &truth, 0.02);
    let surface: Vec<f32> = px.cut_sizes.iter().copied().filter(|&s| s > 0.0).collect();
    let mean = surface.iter().sum::<f32>() / surface.len() as f32;
    eprintln!("lightcuts (pixel): {within:.4} within 2%, mean cut {mean:.1} of {n}, {} rays", px.shadow_rays);
    assert!(within >= 0.99, "{within}");
    assert!(surface.iter().all(|&s| s > 1.0 && s <= 1000.0), "mean cut {mean}");
    // The paper's per-cluster criterion: smaller cuts, errors that add up over the cut.
    let lc = lightcuts(&a, &tree, 0.02, 1000, Criterion::Cluster).unwrap();
    let mean_lc = lc.cut_sizes.iter().sum::<f32>() / surface.len() as f32;
    let within_lc = fraction_within(&lc.image, &truth, 0.02);
    eprintln!("lightcuts (cluster): {within_lc:.4} within 2%, mean cut {mean_lc:.1}, {} rays", lc.shadow_rays);
    assert!(mean_lc < mean && mean_lc < 0.5 * n && fraction_within(&lc.image, &truth, 0.1) >= 0.99);
    // A tighter bound gives larger cuts and a smaller error.
    let fine = lightcuts(&a, &tree, 0.002, 1000, Criterion::Cluster).unwrap();
    let mean_fine = fine.cut_sizes.iter().sum::<f32>() / surface.len() as f32;
    let err = |img: &[f32]| rel_errors(img, &truth).iter().sum::<f64>();
    assert!(mean_fine > mean_lc && err(&fine.image) < err(&lc.image));
    // The cut cap holds.
    let capped = lightcuts(&a, &tree, 0.02, 8, Criterion::Pixel).unwrap();
    assert!(capped.cut_sizes.iter().all(|&s| s <= 8.0));
    let e = rel_errors(&lc.image, &truth);
    let rc = reconstruction_cuts(&a, &tree, 0.02, 1000, Criterion::Cluster, 4).unwrap();
    let mean_rc = rel_errors(&rc.image, &truth).iter().sum::<f64>() / e.len() as f64;
    eprintln!("reconstruction: mean error {mean_rc:.4}, {} rays, {} full cuts", rc.shadow_rays, rc.full_cuts);
    // cbox-lights at 24 x 24 is busy: most blocks straddle an edge and get full cuts.
    assert!(rc.shadow_rays < lc.shadow_rays && rc.full_cuts < a.view.len());
    assert!(mean_rc < 0.03, "{mean_rc}");
    // block = 1: a full lightcut at every pixel, Lightcuts' image.
    let one = reconstruction_cuts(&a, &tree, 0.02, 1000, Criterion::Cluster, 1).unwrap();
    assert_eq!(one.image, lc.image);
    assert_eq!(one.shadow_rays, lc.shadow_rays);
}

#[test]
fn bad_inputs_are_errors() {
    let a = cbox_lights(4);
    let tree = CutTree::build(&a.lights, 0).unwrap();
    let c = Criterion::Cluster;
    assert!(lightcuts(&a, &tree, 0.0, 10, c).is_err());
    assert!(lightcuts(&a, &tree, f64::NAN, 10, c).is_err());
    assert!(lightcuts(&a, &tree, 0.02, 0, c).is_err());
    assert!(reconstruction_cuts(&a, &tree, 0.02, 10, c, 0).is_err());
    let mut other = (*a.lights).clone();
    other.push_point(glam::Vec3::ZERO, glam::Vec3::ONE).unwrap();
    assert!(lightcuts(&a, &CutTree::build(&other, 0).unwrap(), 0.02, 10, c).is_err());
    assert!(CutTree::build(&crate::lights::LightSet::default(), 0).is_err());
}
