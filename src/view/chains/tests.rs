//! Delta chains: branch directions and weights against Mitsuba's formulas, depth semantics, and the light
//! matrix over chain samples (GPU columns = exact oracle; rows = columns; image = folded samples).
use super::*;
use crate::error::Location;
use crate::lights::LightSet;
use crate::matrix::{ColumnOptions, LightMatrix, Visibility};
use crate::scene::{Emitter, Param};
use crate::testing::view_scenes::{cornell_scene, quad, sphere_mesh};
use crate::view::resolve::{cast_visibility_cpu, resolve_view_samples_with};
use std::sync::Arc;

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

#[test]
fn dielectric_branches_follow_snell_and_fresnel() {
    let n = Vec3::Z;
    // Normal incidence, eta 1.5: R = ((1 - 1.5) / (1 + 1.5))^2 = 0.04, T = 0.96 / 1.5^2 entering.
    let b = branches(Delta::Dielectric { eta: 1.5 }, false, Vec3::Z, n);
    assert_eq!(b.len(), 2);
    assert!(close(b[0].0, Vec3::Z, 1e-6) && close(b[0].1, Vec3::splat(0.04), 1e-6), "{b:?}");
    assert!(close(b[1].0, -Vec3::Z, 1e-6) && close(b[1].1, Vec3::splat(0.96 / 2.25), 1e-6), "{b:?}");
    // Leaving the glass (wi below the surface): the radiance scale is eta^2.
    let b = branches(Delta::Dielectric { eta: 1.5 }, false, -Vec3::Z, n);
    assert!(close(b[1].0, Vec3::Z, 1e-6) && close(b[1].1, Vec3::splat(0.96 * 2.25), 1e-5), "{b:?}");
    // 45 degrees from outside: sin_t = sin_i / 1.5, tangential component reversed, mirror reflection.
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let wi = Vec3::new(s, 0.0, s);
    let b = branches(Delta::Dielectric { eta: 1.5 }, false, wi, n);
    assert!(close(b[0].0, Vec3::new(-s, 0.0, s), 1e-6));
    let sin_t = s / 1.5;
    assert!(close(b[1].0, Vec3::new(-sin_t, 0.0, -(1.0 - sin_t * sin_t).sqrt()), 1e-6), "{b:?}");
    let r = fresnel(s, 1.5);
    assert!((r - 0.0503).abs() < 1e-3, "{r}");
    assert!(close(b[1].1, Vec3::splat((1.0 - r) / 2.25), 1e-6));
    // Total internal reflection from inside beyond the critical angle: one branch, weight 1.
    let b = branches(Delta::Dielectric { eta: 1.5 }, false, Vec3::new(0.8, 0.0, -0.6), n);
    assert_eq!(b.len(), 1);
    assert!(close(b[0].0, Vec3::new(-0.8, 0.0, -0.6), 1e-6) && b[0].1 == Vec3::ONE, "{b:?}");
}

#[test]
fn thin_dielectric_branches_are_the_slab_sums() {
    // Normal incidence, eta 1.5: R = 0.04, R' = R + T^2 R / (1 - R^2) = 2R / (1 + R) = 0.076923; the
    // transmitted branch goes straight on, unscaled, from either side.
    let t = Delta::Thin { eta: 1.5, specular: Vec3::new(1.0, 0.5, 0.25), transmittance: Vec3::new(0.9, 1.0, 1.0) };
    let r = 0.04f32 + 0.96 * 0.96 * 0.04 / (1.0 - 0.04 * 0.04);
    assert!((r - 2.0 * 0.04 / 1.04).abs() < 1e-6);
    for side in [1.0f32, -1.0] {
        let wi = Vec3::new(0.0, 0.0, side);
        let b = branches(t, false, wi, Vec3::Z);
        assert_eq!(b.len(), 2, "{b:?}");
        assert!(close(b[0].0, wi, 1e-6) && close(b[0].1, Vec3::new(1.0, 0.5, 0.25) * r, 1e-6), "{b:?}");
        assert!(close(b[1].0, -wi, 1e-6) && close(b[1].1, Vec3::new(0.9, 1.0, 1.0) * (1.0 - r), 1e-6), "{b:?}");
    }
    // 60 degrees from below: Fresnel of |cos_theta_i|, mirror about the normal, straight through.
    let wi = Vec3::new(0.75f32.sqrt(), 0.0, -0.5);
    let b = branches(t, false, wi, Vec3::Z);
    let r = fresnel(0.5, 1.5);
    let r = 2.0 * r / (1.0 + r);
    assert!(close(b[0].0, Vec3::new(-(0.75f32.sqrt()), 0.0, -0.5), 1e-6) && close(b[1].0, -wi, 1e-6), "{b:?}");
    assert!((b[1].1.y - (1.0 - r)).abs() < 1e-6 && r > 0.1, "{b:?} {r}");
}

#[test]
fn conductor_and_plastic_branches_are_one_sided_unless_twosided() {
    let (eta, k, specular) = (Vec3::new(0.2, 0.9, 1.1), Vec3::new(3.9, 2.4, 2.2), Vec3::new(1.0, 0.5, 0.25));
    let c = Delta::Conductor { eta, k, specular };
    let wi = Vec3::new(0.6, 0.0, 0.8);
    let b = branches(c, false, wi, Vec3::Z);
    let f = Vec3::new(fresnel_conductor(0.8, eta.x, k.x), fresnel_conductor(0.8, eta.y, k.y), fresnel_conductor(0.8, eta.z, k.z));
    assert!(close(b[0].0, Vec3::new(-0.6, 0.0, 0.8), 1e-6) && close(b[0].1, specular * f, 1e-7), "{b:?}");
    assert!(f.x > 0.5 && f.x < 1.0, "{f}");
    assert!(branches(c, false, -wi, Vec3::Z).is_empty());
    let back = branches(c, true, -wi, Vec3::Z);
    assert!(close(back[0].0, Vec3::new(0.6, 0.0, -0.8), 1e-6) && close(back[0].1, specular * f, 1e-7), "{back:?}");
    let p = branches(Delta::Plastic { eta: 1.5, specular: Vec3::ONE }, false, Vec3::Z, Vec3::Z);
    assert!(close(p[0].1, Vec3::splat(0.04), 1e-6));
    assert!(branches(Delta::Plastic { eta: 1.5, specular: Vec3::ONE }, false, -Vec3::Z, Vec3::Z).is_empty());
}

#[test]
fn options_are_checked() {
    assert!(ChainOptions::with_max_depth(-1).is_ok() && ChainOptions::with_max_depth(2).is_ok());
    for bad in [0, 1, -2] {
        let e = ChainOptions::with_max_depth(bad).unwrap_err().to_string();
        assert!(e.contains("max_depth") && e.contains(&bad.to_string()), "{e}");
    }
}

/// The G-buffer box with the tilted block turned into a mirror, a glass sphere, a point light and a
/// small area light (the poster).
fn mirror_glass_scene() -> Scene {
    let mut scene = cornell_scene(32, 32, 1.0, 0.05);
    scene.bsdfs.push(Bsdf::Conductor {
        eta: Vec3::new(0.2, 0.9, 1.1),
        k: Vec3::new(3.9, 2.4, 2.2),
        specular_reflectance: Param::Value(Vec3::ONE),
    });
    let mirror = scene.bsdfs.len() - 1;
    scene.bsdfs.push(Bsdf::Dielectric { int_ior: 1.5, ext_ior: 1.0 });
    let glass = scene.bsdfs.len() - 1;
    let block = scene.meshes.iter().position(|m| m.id == "block").unwrap();
    scene.meshes[block].bsdf = mirror;
    scene.meshes.push(sphere_mesh("glass", Vec3::new(-0.45, -0.6, 0.2), 0.35, false, glass));
    // A big mirror on the left wall, slightly in front of it.
    scene.meshes.push(quad(
        "wall_mirror",
        [Vec3::new(-0.98, -0.9, 0.6), Vec3::new(-0.98, -0.9, -0.8), Vec3::new(-0.98, 0.6, -0.8), Vec3::new(-0.98, 0.6, 0.6)],
        mirror,
    ));
    let loc = Location::default();
    scene.emitters.push(Emitter::Point { position: Vec3::new(0.2, 0.7, 0.3), intensity: Vec3::splat(1.0), loc: loc.clone() });
    let poster = scene.meshes.iter().position(|m| m.id == "poster").unwrap();
    scene.emitters.push(Emitter::Area { mesh: poster, radiance: Vec3::new(4.0, 3.0, 2.0), texture: None, loc });
    scene.meshes[poster].emitter = Some(scene.emitters.len() - 1);
    scene
}

fn view_with(scene: &Scene, max_depth: i64) -> ViewSamples {
    let ids = cast_visibility_cpu(scene).unwrap();
    resolve_view_samples_with(scene, &ids, &ChainOptions::with_max_depth(max_depth).unwrap()).unwrap()
}

#[test]
fn chains_give_extra_samples_and_depth_two_only_emission() {
    let scene = mirror_glass_scene();
    let v = view_with(&scene, -1);
    let m = v.num_pixels();
    assert!(v.len() > m + 50, "{} samples for {m} pixels", v.len());
    // Camera hits are unchanged (the G-buffer): the same as without delta BSDFs up to the BSDF.
    let mut plain = scene.clone();
    plain.bsdfs.truncate(plain.bsdfs.len() - 2);
    for mesh in plain.meshes.iter_mut() {
        mesh.bsdf = mesh.bsdf.min(2);
    }
    let pv = view_with(&plain, -1);
    assert_eq!(pv.len(), m);
    assert_eq!(&v.position[..m], &pv.position[..]);
    assert_eq!(&v.shape_index[..m], &pv.shape_index[..]);
    // Extra samples: on non-delta surfaces, with throughput in (0, 1] per channel for the mirror.
    for k in m..v.len() {
        let t = v.throughput[k];
        assert!(t.min_element() > 0.0 && t.is_finite(), "{t}");
        assert_ne!(v.bsdf[k].kind, KIND_SMOOTH);
        let p = v.extra_pixel[k - m] as usize;
        let first = scene.meshes[v.shape_index[p] as usize].bsdf;
        assert!(matches!(scene.bsdfs[first], Bsdf::Conductor { .. } | Bsdf::Dielectric { .. }), "pixel {p}");
    }
    // max_depth 2: no extra samples, but the area light seen through the mirrors / glass is emitted.
    let v2 = view_with(&scene, 2);
    assert_eq!(v2.len(), m);
    let seen: usize = v2.chain_emitted.iter().filter(|e| e.max_element() > 0.0).count();
    assert!(seen > 0, "the poster must be visible in a mirror");
    // Every chain-emitted value is the poster's radiance times a throughput <= 1 per channel (up to the
    // eta^2 scale that cancels through the sphere, and sums of branches).
    assert!(v2.chain_emitted.iter().all(|e| e.cmple(Vec3::new(4.0, 3.0, 2.0) * 1.0001).all()));
    let e1 = crate::matrix::emitted::emitted_radiance(&scene, &v2);
    let e0 = crate::matrix::emitted::emitted_radiance(&plain, &pv);
    let changed = (0..m).filter(|&i| e1[i] != e0[i]).count();
    assert_eq!(changed, seen);
}

#[test]
fn matrix_over_chain_samples_matches_oracle_and_rows() {
    let scene = Arc::new(mirror_glass_scene());
    let view = Arc::new(view_with(&scene, -1));
    let m = view.num_pixels();
    let mut lights = LightSet::from_scene(&scene).unwrap();
    lights.push_point(Vec3::new(-0.3, 0.5, -0.2), Vec3::new(0.5, 1.0, 0.7)).unwrap();
    let lights = Arc::new(lights);
    let ctx = crate::testing::gpu_context();
    let opts = ColumnOptions { visibility: Visibility::RayTraced, shadow_resolution: 128, ..Default::default() };
    let a = LightMatrix::new(ctx, scene.clone(), view.clone(), lights.clone(), opts).unwrap();
    assert_eq!(a.shape(), (m, lights.len()));
    let js: Vec<usize> = (0..lights.len()).collect();
    let cols = a.columns(&js).unwrap();
    assert_eq!(cols.len(), js.len() * m * 3);
    let chained: Vec<usize> = (0..m).filter(|&p| view.samples_of_pixel(p).count() > 1).collect();
    assert!(chained.len() > 20, "{}", chained.len());
    let (mut bad, mut lit_chained) = (0, 0);
    for &j in &js {
        let cpu = a.column_exact(j).unwrap();
        let scale = cpu.iter().flatten().fold(0f32, |s, &v| s.max(v));
        for i in 0..m {
            let g = &cols[(j * m + i) * 3..(j * m + i) * 3 + 3];
            if (0..3).any(|c| (g[c] - cpu[i][c]).abs() > 1e-3 * cpu[i][c].abs() + 1e-6 * scale) {
                bad += 1;
            }
        }
        lit_chained += chained.iter().filter(|&&p| cpu[p][0] > 0.0).count();
    }
    assert!(bad <= 2, "{bad} GPU elements differ from the oracle");
    assert!(lit_chained > 10, "mirror/glass pixels must be lit through their chains: {lit_chained}");
    // The weighted sum is the sum of the columns.
    let sum = a.column_sum(None, &mut |_, _| {}).unwrap();
    for i in 0..m * 3 {
        let s: f32 = js.iter().map(|&j| cols[j * m * 3 + i]).sum();
        assert!((sum[i] - s).abs() <= 1e-4 * s.abs() + 1e-6, "{i}: {} vs {s}", sum[i]);
    }
    // Rows of chained pixels (summed over their samples) equal the columns.
    let rows_idx: Vec<usize> = chained.iter().step_by(chained.len() / 8).copied().collect();
    let rows = a.rows(&rows_idx, &mut |_, _| {}).unwrap();
    let n = lights.len();
    for (r, &p) in rows_idx.iter().enumerate() {
        for j in 0..n {
            for c in 0..3 {
                let (rv, cv) = (rows[(r * n + j) * 3 + c], cols[(j * m + p) * 3 + c]);
                assert!((rv - cv).abs() <= 1e-4 * cv.abs() + 1e-6, "pixel {p} light {j}: row {rv} column {cv}");
            }
        }
    }
}

#[test]
fn gpu_tensor_reconstruction_folds_chain_samples_like_the_cpu() {
    // Three frames of one scene with delta chains; mappings that shift by one pixel (a pixel with no
    // source at the start of each), so chains of mappings and the fold of extra samples both matter.
    let scene = Arc::new(mirror_glass_scene());
    let view = Arc::new(view_with(&scene, -1));
    let p = view.num_pixels();
    assert!(view.len() > p, "the scene must have delta-chain samples");
    let mut lights = LightSet::from_scene(&scene).unwrap();
    lights.push_point(Vec3::new(-0.3, 0.5, -0.2), Vec3::new(0.5, 1.0, 0.7)).unwrap();
    lights.push_point(Vec3::new(0.3, 0.7, 0.1), Vec3::new(0.9, 0.4, 0.7)).unwrap();
    let n = lights.len();
    let ctx = crate::testing::gpu_context();
    let opts = ColumnOptions { visibility: Visibility::RayTraced, shadow_resolution: 128, ..Default::default() };
    let a = LightMatrix::new(ctx, scene.clone(), view.clone(), Arc::new(lights), opts).unwrap();
    let frames = [&a, &a, &a];
    let f = frames.len();
    let shift: Vec<u32> = (0..p as u32).map(|i| if i == 0 { crate::matrix::mapping::NO_SOURCE } else { i - 1 }).collect();
    let back: Vec<u32> = (0..p as u32).map(|i| if i + 1 == p as u32 { crate::matrix::mapping::NO_SOURCE } else { i + 1 }).collect();
    let fw = [shift.as_slice(), shift.as_slice()];
    let bw = [back.as_slice(), back.as_slice()];
    // Representatives in every frame, serving all three frames with different RGB scales.
    let reps: Vec<(u32, u32)> = (0..n as u32).flat_map(|j| [(j, 0), (j, 2), (j, 1)]).collect();
    let rec: Vec<f32> = (0..reps.len() * f * 3).map(|x| 0.25 + (x % 7) as f32 * 0.1).collect();
    let gpu = crate::gpu::reconstruction::reconstruct(&frames, &reps, &rec, &fw, &bw).unwrap();
    let js: Vec<usize> = reps.iter().map(|r| r.0 as usize).collect();
    let source: Vec<u32> = reps.iter().map(|r| r.1).collect();
    let cols = a.columns(&js).unwrap();
    let mut cpu = vec![0f32; f * p * 3];
    crate::matrix::reconstruction::accumulate(&mut cpu, f, p, &cols, &source, &rec, &fw, &bw).unwrap();
    let (num, den) =
        cpu.iter().zip(&gpu.frames).fold((0f64, 0f64), |(n, d), (&c, &g)| (n + ((c - g) as f64).powi(2), d + (c as f64).powi(2)));
    assert!(den > 0.0 && (num / den).sqrt() < 1e-6, "relative L2 {}", (num / den).sqrt());
    assert!(gpu.columns_seconds > 0.0 && gpu.reconstruction_seconds > 0.0);
    // A tiny work budget splits the column passes and the reconstruction into dispatches of one
    // workgroup: the same frames bit for bit.
    let split = crate::gpu::dispatch::with_budget(64, || crate::gpu::reconstruction::reconstruct(&frames, &reps, &rec, &fw, &bw)).unwrap();
    assert!(split.frames == gpu.frames, "split reconstruction differs");
    // A light out of range and a matrix on the CPU are named errors.
    let e = crate::gpu::reconstruction::reconstruct(&frames, &[(n as u32, 0)], &rec[..f * 3], &fw, &bw).unwrap_err().to_string();
    assert!(e.contains(&format!("light {n} of frame 0")), "{e}");
    let tracer = Arc::new(crate::raytrace::RayTracer::new(&scene).unwrap());
    let c = LightMatrix::new_cpu(tracer, scene.clone(), view.clone(), a.lights.clone()).unwrap();
    let e = crate::gpu::reconstruction::reconstruct(&[&c], &[(0, 0)], &rec[..3], &[], &[]).unwrap_err().to_string();
    assert!(e.contains("not on the GPU"), "{e}");
}

/// A glass sphere with an absorbing interior: every extra sample's throughput is the medium-free one times
/// exp(-sigma_t L), L the length its chain travelled inside the sphere, the same L for every channel.
#[test]
fn media_attenuate_chains_by_beer_lambert() {
    let plain = mirror_glass_scene();
    let mut scene = plain.clone();
    let glass = scene.meshes.iter().position(|m| m.id == "glass").unwrap();
    let sigma_t = Vec3::new(0.5, 1.0, 2.0);
    scene.media.media.push(crate::scene::Medium { sigma_t, albedo: Vec3::ZERO, loc: Location::default() });
    scene.media.shape = vec![(None, None); scene.meshes.len()];
    scene.media.shape[glass] = (Some(0), None);
    // No throughput cut-off: the same branches in both.
    let opts = ChainOptions { min_throughput: 0.0, ..Default::default() };
    let view = |s: &Scene| resolve_view_samples_with(s, &cast_visibility_cpu(s).unwrap(), &opts).unwrap();
    let (v, p) = (view(&scene), view(&plain));
    assert_eq!(v.len(), p.len());
    let m = v.num_pixels();
    let mut inside = 0;
    for k in m..v.len() {
        assert_eq!(v.position[k], p.position[k]);
        let l = (p.throughput[k] / v.throughput[k]).to_array().map(|r| r.ln());
        let len = l[0] / sigma_t.x;
        assert!(len >= -1e-6 && (l[1] / sigma_t.y - len).abs() < 1e-4 && (l[2] / sigma_t.z - len).abs() < 1e-4, "{k}: {l:?}");
        if len > 0.05 {
            inside += 1;
            // At most a few chords of the 0.35-radius sphere (8 bounces).
            assert!(len < 8.0 * 0.7, "{len}");
        }
    }
    assert!(inside >= 10, "{inside} samples seen through the medium");
    // The medium's exterior side is no medium: leaving the sphere outward restores the camera's (none).
    assert_eq!(scene.media.after(Some(0), glass, Vec3::X, Vec3::X), None);
    assert_eq!(scene.media.after(None, glass, -Vec3::X, Vec3::X), Some(0));
    assert_eq!(scene.media.after(Some(0), 0, Vec3::X, Vec3::X), Some(0));
    assert_eq!(scene.media.transmittance(Some(0), f32::INFINITY), Vec3::ZERO);
}
