use super::*;
use crate::raytrace::RayTracer;
use crate::scene::Emitter;
use crate::view::ViewSamples;

fn setup() -> (Scene, ViewSamples, RayTracer) {
    crate::testing::scene_view_tracer(&crate::testing::scene_file("cbox/scene.xml"), 8)
}

fn transfer(bounces: u32) -> (Scene, Transfer) {
    transfer_with(bounces, crate::relight::Multibounce::Photons)
}

fn transfer_with(bounces: u32, multibounce: crate::relight::Multibounce) -> (Scene, Transfer) {
    let (scene, view, tracer) = setup();
    let opts = TransferOptions {
        gather: 64,
        coefficients: 20,
        bounces,
        multibounce_coefficients: 10,
        multibounce,
        photons_per_sample: 8,
        photon_neighbours: 16,
        ..Default::default()
    };
    let t = Transfer::new(&scene, &view, &tracer, &opts, &mut |_, _| {}).unwrap();
    (scene, t)
}

fn key(scene: &Scene) -> HashMap<String, Vec<u8>> {
    let mut out: HashMap<String, Vec<u8>> = HashMap::new();
    scene_key(scene, &mut |s, b| out.entry(s.to_string()).or_default().extend_from_slice(b));
    out
}

#[test]
fn round_trip_rebuilds_the_same_transfer() {
    use crate::relight::Multibounce;
    for (bounces, multibounce) in [(1, Multibounce::Photons), (2, Multibounce::Gather), (2, Multibounce::Photons)] {
        let (scene, t) = transfer_with(bounces, multibounce);
        let back = from_arrays(&scene, 8, 8, to_arrays(&t)).unwrap();
        assert_eq!(back.opts, t.opts);
        assert_eq!(back.rows, t.rows);
        assert_eq!(back.bounce_rows, t.bounce_rows);
        assert_eq!(back.photon_rows, t.photon_rows);
        assert_eq!(back.photons, t.photons);
        let photons = bounces > 1 && multibounce == Multibounce::Photons;
        assert_eq!(back.photon_rows.len(), if photons { 64 } else { 0 });
        assert!(!photons || back.photon_rows.iter().any(|r| r.value.len() == 3 * r.index.len() && !r.index.is_empty()));
        assert_eq!(back.hierarchy, t.hierarchy);
        assert_eq!(back.image_norms, t.image_norms);
        assert_eq!(back.emit_position, t.emit_position);
        assert_eq!(back.cloud.bsdf.len(), t.cloud.bsdf.len());
        assert_eq!((back.shadow_rays, back.links, back.seconds_rows), (t.shadow_rays, t.links, t.seconds_rows));
        assert_eq!(back.bounce_rows.len(), if bounces > 1 && !photons { 64 } else { 0 });
    }
}

#[test]
fn damaged_arrays_are_refused_with_their_name() {
    let (scene, t) = transfer(1);
    let arrays = to_arrays(&t);
    let edit = |name: &str, f: &dyn Fn(&mut NamedArray)| {
        let mut a = arrays.clone();
        f(a.iter_mut().find(|x| x.name == name).unwrap());
        from_arrays(&scene, 8, 8, a).unwrap_err().to_string()
    };
    let e = edit("final_gather.index", &|a| {
        if let Data::U32(v) = &mut a.data {
            v[0] = 64;
        }
    });
    assert!(e.contains("final_gather") && e.contains("64"), "{e}");
    let e = edit("final_gather.value", &|a| {
        if let Data::F32(v) = &mut a.data {
            v[3] = f32::NAN;
        }
    });
    assert!(e.contains("final_gather.value") && e.contains("NaN"), "{e}");
    let e = edit("hierarchy.order", &|a| {
        if let Data::U32(v) = &mut a.data {
            v[1] = v[0];
        }
    });
    assert!(e.contains("permutation"), "{e}");
    let e = edit("cloud.position", &|a| {
        if let Data::F32(v) = &mut a.data {
            v[5] += 0.5;
        }
    });
    assert!(e.contains("differs") && e.contains("sample 1"), "{e}");
    let e = edit("options.coefficients", &|a| a.data = Data::U64(vec![65]));
    assert!(e.contains("65") && e.contains("gather (64)"), "{e}");
    let e = edit("options.gather", &|a| a.data = Data::U64(vec![32]));
    assert!(e.contains("32"), "{e}");
    let e = edit("size", &|a| a.data = Data::U32(vec![8, 9]));
    assert!(e.contains("8x9"), "{e}");
    let e = edit("stats.links", &|a| a.data = Data::F32(vec![1.0]));
    assert!(e.contains("stats.links") && e.contains("float32"), "{e}");
    let e = edit("emit_normal", &|a| a.shape = vec![63, 3]);
    assert!(e.contains("emit_normal") && e.contains("[63, 3]"), "{e}");
    let mut missing = arrays.clone();
    missing.retain(|a| a.name != "final_gather.offsets");
    assert!(from_arrays(&scene, 8, 8, missing).unwrap_err().to_string().contains("no array 'final_gather.offsets'"));
    let mut extra = arrays.clone();
    extra.push(NamedArray { name: "glossy.offsets".into(), shape: vec![], data: Data::U64(vec![0]) });
    assert!(from_arrays(&scene, 8, 8, extra).unwrap_err().to_string().contains("glossy.offsets"));
    // The film size of the view that asks.
    assert!(from_arrays(&scene, 8, 16, arrays.clone()).unwrap_err().to_string().contains("8x8"));
}

#[test]
fn scene_key_sees_geometry_materials_camera_and_film_but_not_emitters() {
    let (scene, _, _) = setup();
    let base = key(&scene);
    assert_eq!(base.len(), 4);
    let mut s = scene.clone();
    for e in &mut s.emitters {
        match e {
            Emitter::Point { intensity, .. } | Emitter::Spot { intensity, .. } => *intensity *= 2.0,
            Emitter::Area { radiance, .. } => *radiance *= 2.0,
            _ => {}
        }
    }
    s.emitters.push(Emitter::Point { position: Vec3::ONE, intensity: Vec3::ONE, loc: Default::default() });
    assert_eq!(key(&s), base);
    let changed = |s: &Scene| {
        let k = key(s);
        let mut d: Vec<String> = k.iter().filter(|(n, v)| base[*n] != **v).map(|(n, _)| n.clone()).collect();
        d.sort();
        d
    };
    let mut s = scene.clone();
    s.meshes[0].positions[0].x += 1e-3;
    assert_eq!(changed(&s), ["geometry"]);
    let mut s = scene.clone();
    let b = s.meshes[0].bsdf;
    s.bsdfs[b] = Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) };
    assert_eq!(changed(&s), ["materials"]);
    let mut s = scene.clone();
    s.camera.fov_x *= 1.01;
    assert_eq!(changed(&s), ["camera"]);
    let mut s = scene.clone();
    s.camera.width = 9;
    assert_eq!(changed(&s), ["film"]);
    // Reordering BSDFs (indices change, contents do not) keeps the key.
    let mut s = scene.clone();
    s.bsdfs.insert(0, Bsdf::Dielectric { int_ior: 1.5, ext_ior: 1.0 });
    for m in &mut s.meshes {
        m.bsdf += 1;
    }
    for b in &mut s.bsdfs {
        if let Bsdf::TwoSided { front, back } = b {
            *front += 1;
            *back += 1;
        }
    }
    assert_eq!(key(&s), base);
}
