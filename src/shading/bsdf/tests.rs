use super::*;

#[test]
fn gpu_bsdf_is_80_bytes() {
    assert_eq!(std::mem::size_of::<GpuBsdf>(), 80);
}

#[test]
fn wgsl_parses_and_validates() {
    let src = crate::gpu::shaders::BSDF_EVAL;
    let module = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}"));
    let ty = module.types.iter().find(|(_, t)| t.name.as_deref() == Some("Bsdf")).expect("struct Bsdf").1;
    match &ty.inner {
        naga::TypeInner::Struct { span, members } => {
            assert_eq!(*span, 80);
            let offsets: Vec<u32> = members.iter().map(|m| m.offset).collect();
            assert_eq!(offsets, [0, 12, 16, 28, 32, 44, 48, 60, 64]);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn known_values() {
    let sets = test_sets();
    let (_, bsdfs, i) = &sets[0];
    let b = resolve(bsdfs, &[], *i, Vec2::ZERO);
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let got = eval(&b, Vec3::Z, wo);
    assert!((got - Vec3::new(0.725, 0.71, 0.68) * 0.8 / std::f32::consts::PI).abs().max_element() < 1e-7);
    // One-sided: below the surface is black; twosided mirrors it.
    assert_eq!(eval(&b, -Vec3::Z, -wo), Vec3::ZERO);
    let (_, bsdfs, i) = &sets[5];
    let b = resolve(bsdfs, &[], *i, Vec2::ZERO);
    assert_eq!(eval(&b, -Vec3::Z, -wo), eval(&b, Vec3::Z, wo));
    assert_eq!(eval(&b, -Vec3::Z, wo), Vec3::ZERO);
    // mi.fresnel_diffuse_reflectance(1 / 1.9) (Egan-Hilgeman) and (1.9) (d'Eon-Irving), mitsuba 3.9.1.
    assert!((fresnel_diffuse_reflectance(1.0 / 1.9) - 0.7637073).abs() < 1e-6);
    assert!((fresnel_diffuse_reflectance(1.9) - 0.1474841).abs() < 1e-6);
}

#[test]
fn reciprocal_and_energy_bounded() {
    // f(wi, wo) = f(wo, wi) for diffuse and rough conductors; the cosine-weighted albedo is <= 1 for all.
    let dirs = random_directions(4000, 7);
    for (name, bsdfs, i) in test_sets() {
        let b = resolve(&bsdfs, &[], i, Vec2::ZERO);
        let reciprocal = matches!(b.kind, KIND_DIFFUSE | KIND_ROUGHCONDUCTOR);
        for pair in dirs.chunks(2) {
            let (wi, wo) = (pair[0], pair[1]);
            let (f, r) = (eval(&b, wi, wo), eval(&b, wo, wi));
            assert!(f.is_finite() && f.min_element() >= 0.0, "{name}: {f}");
            if reciprocal && wi.z.abs() > 0.05 && wo.z.abs() > 0.05 {
                let (a, c) = (f / wo.z.abs(), r / wi.z.abs());
                assert!((a - c).abs().max_element() <= 1e-4 * a.max_element().max(1e-3), "{name}: {a} vs {c}");
            }
        }
        // Albedo for wi at 60 degrees by stratified sampling of the hemisphere (uniform pdf 1 / 2pi).
        let wi = Vec3::new(0.866, 0.0, 0.5);
        let n = 256;
        let mut sum = Vec3::ZERO;
        for a in 0..n {
            for c in 0..n {
                let z = (a as f32 + 0.5) / n as f32;
                let phi = 2.0 * std::f32::consts::PI * (c as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).sqrt();
                sum += eval(&b, wi, Vec3::new(r * phi.cos(), r * phi.sin(), z));
            }
        }
        let albedo = sum * 2.0 * std::f32::consts::PI / (n * n) as f32;
        assert!(albedo.max_element() < 1.0, "{name}: albedo {albedo}");
        assert!(albedo.min_element() > 0.01, "{name}: albedo {albedo}");
    }
}
