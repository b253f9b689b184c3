//! Tests of `crate::pathtrace`: unbiasedness on analytic cases (a diffuse plane under a point light, a
//! spherical area emitter and a constant environment), determinism, refused input.
use super::*;
use crate::testing::{scene_view_tracer, scratch_dir};
use std::path::PathBuf;

const R: f32 = 0.6;

/// A 20 x 20 m diffuse plane (z = 0, normal +z, reflectance R) seen from above, plus `emitters`.
fn plane_scene(tag: &str, emitters: &str) -> PathBuf {
    let xml = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, -3, 4" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="10"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{R}"/></bsdf>
    </shape>
    {emitters}
</scene>"#
    );
    let path = scratch_dir(tag).join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    path
}

/// Probe pixels on the plane (mesh 0): a spread of the 16 x 16 film.
fn probes(view: &ViewSamples) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for y in (1..16).step_by(3) {
        for x in (1..16).step_by(3) {
            if view.shape_index[(y * 16 + x) as usize] == 0 {
                out.push((x, y));
            }
        }
    }
    assert!(out.len() >= 20, "the plane must fill the film");
    out
}

/// Asserts every probe's z-score against `exact(i)` below 4.5 (25 probes x 3 channels: a false alarm
/// has probability ~5e-4) and the mean of z^2 within [0.5, 1.6] (75 values: 1 +- 0.16 expected).
fn assert_unbiased(px: &[(u32, u32)], est: &[ProbeEstimate], exact: impl Fn(usize) -> Vec3) {
    let mut z2 = Vec::new();
    for (&(x, y), e) in px.iter().zip(est) {
        let i = (y * 16 + x) as usize;
        let ex = exact(i);
        for c in 0..3 {
            let sd = e.variance_of_mean[c].sqrt();
            assert!(sd > 0.0 && sd < 0.05 * ex[c], "probe ({x}, {y}): std {sd} vs value {}", ex[c]);
            let z = (e.mean[c] - ex[c]) / sd;
            assert!(z.abs() < 4.5, "probe ({x}, {y}) channel {c}: {} vs exact {} (z = {z})", e.mean[c], ex[c]);
            z2.push(z * z);
        }
    }
    let m = z2.iter().sum::<f32>() / z2.len() as f32;
    let max_z = z2.iter().fold(0.0f32, |a, &b| a.max(b)).sqrt();
    eprintln!("mean z^2 = {m:.3} over {} values, max |z| = {max_z:.2}", z2.len());
    assert!((0.5..1.6).contains(&m), "mean z^2 = {m} over {} values", z2.len());
}

fn run(path: &std::path::Path, spp: u32, max_depth: i32, seed: u64) -> (ViewSamples, Vec<(u32, u32)>, Vec<ProbeEstimate>) {
    let (scene, view, rt) = scene_view_tracer(path, 16);
    let px = probes(&view);
    let opts = ProbeOptions { spp, max_depth, seed, ..Default::default() };
    let est = probe_pixels(&scene, &rt, &view, &px, &opts, None, None, &mut |_, _| {}).unwrap();
    (view, px, est)
}

#[test]
fn point_light_is_exact() {
    // L = R / pi * I cos / d^2, no variance (the only emitter is a delta light).
    let p = Vec3::new(0.5, 0.0, 2.0);
    let path = plane_scene(
        "pt-point",
        "<emitter type=\"point\"><point name=\"position\" x=\"0.5\" y=\"0\" z=\"2\"/><rgb name=\"intensity\" value=\"10\"/></emitter>",
    );
    let (view, px, est) = run(&path, 8, 2, 0);
    for (&(x, y), e) in px.iter().zip(&est) {
        let i = (y * 16 + x) as usize;
        let d = p - view.position[i];
        let exact = R / std::f32::consts::PI * 10.0 * d.normalize().z / d.length_squared();
        assert!((e.mean - Vec3::splat(exact)).abs().max_element() < 1e-5 * exact, "({x}, {y}): {} vs {exact}", e.mean);
        assert!(e.variance_of_mean.max_element() < 1e-12);
    }
}

#[test]
fn sphere_emitter_direct_is_unbiased() {
    // A sphere of radiance L fully above the plane acts as a point of intensity L pi r^2:
    // L_o = R L r^2 cos(theta) / D^2 (D the distance to its centre). MIS of area and BSDF sampling.
    let (c, r, l) = (Vec3::new(0.3, 0.2, 1.2), 0.5f32, 4.0f32);
    let path = plane_scene(
        "pt-sphere",
        r#"<shape type="sphere"><point name="center" x="0.3" y="0.2" z="1.2"/><float name="radius" value="0.5"/>
           <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>"#,
    );
    let (view, px, est) = run(&path, 2048, 2, 1);
    assert_unbiased(&px, &est, |i| {
        let d = c - view.position[i];
        Vec3::splat(R * l * r * r * d.normalize().z / d.length_squared())
    });
}

#[test]
fn constant_environment_is_unbiased_at_any_depth() {
    // An unoccluded plane under a constant sky L: L_o = R L, whatever the depth (nothing to bounce off).
    let path = plane_scene("pt-env", r#"<emitter type="constant"><rgb name="radiance" value="0.5, 1.0, 2.0"/></emitter>"#);
    for max_depth in [2, -1] {
        let (_, px, est) = run(&path, 512, max_depth, 2);
        assert_unbiased(&px, &est, |_| Vec3::new(0.5, 1.0, 2.0) * R);
    }
}

#[test]
fn seeded_and_deterministic() {
    let path = plane_scene("pt-seed", r#"<emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#);
    let (_, _, a) = run(&path, 100, -1, 7);
    let (_, _, b) = run(&path, 100, -1, 7);
    let (_, _, c) = run(&path, 100, -1, 8);
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn an_environment_built_beforehand_traces_the_same_paths() {
    // The Python Scene builds the sampled environment once and hands it to every probe call; the paths must
    // be those of a tracer that builds its own, guided or not.
    let path = plane_scene("pt-shared-env", r#"<emitter type="constant"><rgb name="radiance" value="0.5, 1.0, 2.0"/></emitter>"#);
    let (scene, view, rt) = scene_view_tracer(&path, 16);
    let px = probes(&view);
    for guided_env in [true, false] {
        let opts = ProbeOptions { spp: 64, max_depth: 3, seed: 3, guided_env, ..Default::default() };
        let own = probe_pixels(&scene, &rt, &view, &px, &opts, None, None, &mut |_, _| {}).unwrap();
        let env = SampledEnvironment::build(&scene, &rt, guided_env).unwrap().map(Arc::new);
        assert!(env.is_some());
        let shared = probe_pixels(&scene, &rt, &view, &px, &opts, None, env.clone(), &mut |_, _| {}).unwrap();
        let again = probe_pixels(&scene, &rt, &view, &px, &opts, None, env, &mut |_, _| {}).unwrap();
        assert_eq!(own, shared);
        assert_eq!(own, again);
    }
}

#[test]
fn bad_options_and_pixels_are_refused() {
    let path = plane_scene("pt-bad", r#"<emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#);
    let (scene, view, rt) = scene_view_tracer(&path, 16);
    let go = |px: &[(u32, u32)], o: ProbeOptions| probe_pixels(&scene, &rt, &view, px, &o, None, None, &mut |_, _| {});
    assert!(go(&[(16, 0)], ProbeOptions::default()).unwrap_err().to_string().contains("outside"));
    assert!(go(&[(0, 0)], ProbeOptions { spp: 1, ..Default::default() }).unwrap_err().to_string().contains("spp"));
    assert!(go(&[(0, 0)], ProbeOptions { max_depth: 0, ..Default::default() }).unwrap_err().to_string().contains("max_depth"));
    assert!(go(&[], ProbeOptions::default()).unwrap().is_empty());
}

#[test]
fn a_light_set_replaces_the_scene_emitters() {
    // The sphere emitter of the scene is ignored (neither seen nor sampled); the given point light is exact.
    let path = plane_scene(
        "pt-lightset",
        r#"<shape type="sphere"><point name="center" x="0.3" y="0.2" z="1.2"/><float name="radius" value="0.5"/>
           <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>"#,
    );
    let (scene, view, rt) = scene_view_tracer(&path, 16);
    let p = Vec3::new(-0.5, 0.5, 3.0);
    let mut lights = LightSet::new(Vec3::ZERO, 20.0);
    lights.push_point(p, Vec3::splat(10.0)).unwrap();
    let px = probes(&view);
    let opts = ProbeOptions { spp: 8, max_depth: 2, seed: 3, ..Default::default() };
    let est = probe_pixels(&scene, &rt, &view, &px, &opts, Some(lights), None, &mut |_, _| {}).unwrap();
    for (&(x, y), e) in px.iter().zip(&est) {
        let i = (y * 16 + x) as usize;
        let d = p - view.position[i];
        // The sphere shadows part of the plane from p: only unshadowed pixels have the exact value.
        let exact = R / std::f32::consts::PI * 10.0 * d.normalize().z / d.length_squared();
        assert!(e.mean.x == 0.0 || (e.mean - Vec3::splat(exact)).abs().max_element() < 1e-5 * exact, "({x}, {y}): {}", e.mean);
        assert!(e.variance_of_mean.max_element() < 1e-12);
    }
    assert!(est.iter().filter(|e| e.mean.x > 0.0).count() >= px.len() / 2);
}
