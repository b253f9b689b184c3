use super::*;
use crate::relight::transfer::{Transfer, TransferOptions};
use crate::scene::{load_scene, LoadOptions};
use crate::view::chains::ChainOptions;
use crate::view::ViewSamples;

/// A closed 2 m box of grey diffuse walls (albedo `rho`, every normal inward) seen from inside.
fn closed_box(rho: f32) -> (Scene, ViewSamples, RayTracer) {
    let walls = [
        ("floor", r#"<rotate x="1" angle="-90"/> <translate y="-1"/>"#),
        ("ceiling", r#"<rotate x="1" angle="90"/> <translate y="1"/>"#),
        ("back", r#"<translate z="-1"/>"#),
        ("front", r#"<rotate y="1" angle="180"/> <translate z="1"/>"#),
        ("left", r#"<rotate y="1" angle="90"/> <translate x="-1"/>"#),
        ("right", r#"<rotate y="1" angle="-90"/> <translate x="1"/>"#),
    ];
    let shapes: String = walls
        .iter()
        .map(|(id, t)| format!(r#"<shape type="rectangle" id="{id}"><transform name="to_world">{t}</transform><ref id="grey"/></shape>"#))
        .collect();
    let xml = format!(
        r#"<scene version="3.0.0">
        <sensor type="perspective"><float name="fov" value="60"/>
            <transform name="to_world"><lookat origin="0, 0, 0.8" target="0, 0, -1" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
        <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="{rho}, {rho}, {rho}"/></bsdf>
        {shapes}
        <emitter type="point"><point name="position" x="0" y="0.5" z="0"/><rgb name="intensity" value="1, 1, 1"/></emitter>
        </scene>"#
    );
    let dir = crate::testing::scratch_dir("multibounce");
    let path = dir.join(format!("closed_box_{rho}.xml"));
    std::fs::write(&path, xml).unwrap();
    let scene = load_scene(&path, &LoadOptions::default()).unwrap();
    let tracer = RayTracer::new(&scene).unwrap();
    let ids = crate::view::resolve::cast_visibility_traced(&scene, &tracer).unwrap();
    let view = crate::view::resolve::resolve_view_samples_with(&scene, &ids, &ChainOptions::default()).unwrap();
    (scene, view, tracer)
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

/// The radiance M adds to a uniform unit radiance B_1 = 1 (mean of RGB per gather sample).
fn added(t: &Transfer) -> Vec<f32> {
    let n = t.cloud.len();
    let one = vec![Vec3::ONE; n];
    if t.opts.multibounce == Multibounce::Photons {
        apply(t, &one).unwrap().iter().map(|v| v.element_sum() / 3.0).collect()
    } else {
        let e: Vec<Vec3> = (0..n).map(|g| Vec3::splat(PI) / t.cloud.k_d[g]).collect();
        let b = crate::relight::relight::bounce(t, &e).unwrap();
        (0..n).map(|g| (b[3 * g] + b[3 * g + 1] + b[3 * g + 2]) / 3.0 - 1.0).collect()
    }
}

/// In a closed box of one albedo rho, a uniform radiance 1 leaving every wall makes an irradiance of
/// exactly pi everywhere, so one bounce adds rho and b - 1 bounces add rho + ... + rho^(b-1): M's row
/// sums are known exactly. The photon-mapped M matches them (and the exact gather-to-gather transfer),
/// away from the edges where the K-nearest disk loses photons to the perpendicular walls (module docs).
#[test]
fn photon_rows_sum_to_the_closed_box_series() {
    let rho = 0.5f32;
    let (scene, view, tracer) = closed_box(rho);
    let base = TransferOptions { gather: 4usize.pow(5), coefficients: 16, multibounce_coefficients: 40, ..Default::default() };
    for (bounces, want) in [(2u32, rho), (64, rho / (1.0 - rho))] {
        let opts = TransferOptions { bounces, multibounce: Multibounce::Photons, ..base.clone() };
        let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
        assert!(t.photons > 0 && t.bounce_rows.is_empty() && t.photon_rows.len() == 1024);
        let got = added(&t);
        let m = median(got.clone());
        eprintln!("bounces {bounces}: median {m}, mean {}", got.iter().sum::<f32>() / got.len() as f32);
        let mean = got.iter().sum::<f32>() / got.len() as f32;
        // Measured: bounces 2: median 0.490, mean 0.462; bounces 64: median 0.992, mean 0.960 (edges
        // darker: the bias of the K-nearest disk near the perpendicular walls).
        assert!((m - want).abs() < 0.04 * want, "bounces {bounces}: median {m} vs {want}");
        assert!(mean < want * 1.01 && mean > 0.88 * want, "bounces {bounces}: mean {mean} vs {want}");
        if bounces == 2 {
            let g = Transfer::new(
                &scene,
                &view,
                &tracer,
                &TransferOptions { bounces, multibounce: Multibounce::Gather, ..base.clone() },
                &mut |_, _| {},
            )
            .unwrap();
            let mg = median(added(&g));
            eprintln!("gather: median {mg}");
            assert!((mg - want).abs() < 0.04 * want, "gather: median {mg} vs {want}");
        }
    }
}

/// The photon estimate converges as photons grow with K in proportion (the K-nearest disk keeps its size,
/// its relative noise ~ 1 / sqrt(K) falls): the spread of the row sums of the interior samples (whose
/// disk lies on their own wall) shrinks from 4 photons per sample (K = 24) to 64 (K = 384).
#[test]
fn photon_noise_falls_as_photons_grow() {
    let (scene, view, tracer) = closed_box(0.5);
    let mut spread = Vec::new();
    for per in [4usize, 64] {
        let opts = TransferOptions {
            gather: 4usize.pow(5),
            coefficients: 16,
            bounces: 2,
            multibounce: Multibounce::Photons,
            photons_per_sample: per,
            photon_neighbours: 6 * per,
            ..Default::default()
        };
        let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
        let got = added(&t);
        let inner: Vec<f32> = (0..t.cloud.len())
            .filter(|&g| {
                let p = t.cloud.position[g].abs();
                // On its wall, at least 0.4 m from every edge.
                let coords: Vec<f32> = p.to_array().into_iter().filter(|&c| c < 0.99).collect();
                coords.iter().all(|&c| c < 0.6)
            })
            .map(|g| got[g])
            .collect();
        assert!(inner.len() > 100, "{}", inner.len());
        let mean = inner.iter().sum::<f32>() / inner.len() as f32;
        let var = inner.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / inner.len() as f32;
        spread.push(var.sqrt() / mean);
    }
    // Measured: relative spread 0.22 (4 photons, K 24), 0.10 (64, K 384).
    eprintln!("relative spread {spread:?}");
    assert!(spread[1] < 0.6 * spread[0], "{spread:?}");
}

#[test]
fn bad_photon_options_are_refused() {
    let (scene, view, tracer) = closed_box(0.5);
    for opts in [
        TransferOptions {
            gather: 16,
            coefficients: 4,
            bounces: 2,
            multibounce_coefficients: 4,
            photons_per_sample: 0,
            ..Default::default()
        },
        TransferOptions {
            gather: 16,
            coefficients: 4,
            bounces: 2,
            multibounce_coefficients: 4,
            photon_neighbours: 0,
            ..Default::default()
        },
        TransferOptions {
            gather: 16,
            coefficients: 4,
            bounces: 2,
            multibounce_coefficients: 4,
            photon_neighbours: MAX_PHOTON_COUNT + 1,
            ..Default::default()
        },
    ] {
        let e = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("photon"), "{e}");
    }
    assert!(Multibounce::parse("photon").unwrap_err().to_string().contains("'photons' or 'gather'"));
    assert_eq!(Multibounce::parse("gather").unwrap(), Multibounce::Gather);
}
