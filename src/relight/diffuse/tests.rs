//! The plastic diffuse lobe factors exactly into a(i) / pi * s(i, wo); diffuse records are left Lambertian.
use super::*;
use crate::scene::{Bsdf, MicrofacetDistribution, Param};
use crate::shading::bsdf::resolve;
use glam::Vec2;

fn view_of(b: GpuBsdf) -> ViewSamples {
    ViewSamples {
        width: 1,
        height: 1,
        position: vec![Vec3::ZERO],
        normal: vec![Vec3::Y],
        geo_normal: vec![Vec3::Y],
        wi: vec![Vec3::new(0.3, 0.8, 0.2).normalize()],
        uv: vec![Vec2::ZERO],
        albedo: vec![Vec3::from(b.diffuse)],
        shape_index: vec![0],
        prim_index: vec![0],
        bsdf: vec![b],
        ..Default::default()
    }
}

#[test]
fn plastic_lobes_factor_exactly_and_diffuse_stays_lambertian() {
    let k_d = Param::Value(Vec3::new(0.8, 0.4, 0.1));
    let spec = Param::Value(Vec3::ONE);
    let plastics = [
        Bsdf::RoughPlastic {
            diffuse_reflectance: k_d,
            specular_reflectance: spec,
            distribution: MicrofacetDistribution::Ggx,
            alpha: 0.15,
            int_ior: 1.5,
            ext_ior: 1.0,
            nonlinear: true,
        },
        Bsdf::Plastic { diffuse_reflectance: k_d, specular_reflectance: spec, int_ior: 1.49, ext_ior: 1.000277, nonlinear: false },
    ];
    for p in plastics {
        let b = resolve(&[p], &[], 0, Vec2::ZERO);
        let view = view_of(b);
        let sp = crate::cpu::ShadingPoint::new(&view, 0);
        let lobe = Lobe::of(&view, 0, sp.wi_local).expect("a plastic has a non-Lambertian diffuse lobe");
        let a = albedo(&view, 0);
        // Near k_d at the normal (the internal reflections against the coating's transmittance and
        // 1 / eta^2), with the colour of k_d / (1 - D).
        assert!(a.x > 0.4 && a.x < 1.0 && a.x / a.z > 0.8 / 0.1 * 0.9, "{a}");
        let mut diffuse_only = b;
        diffuse_only.specular = [0.0; 3];
        for wo in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.7, 0.5, 0.3).normalize(),
            Vec3::new(0.99, 0.0, 0.05).normalize(),
        ] {
            let exact = eval(&diffuse_only, sp.wi_local, wo) / wo.z;
            let factored = a / std::f32::consts::PI * lobe.factor(wo);
            assert!((exact - factored).abs().max_element() <= 1e-5 * exact.max_element().max(1e-3), "{exact} vs {factored} at {wo}");
        }
        assert_eq!(lobe.factor(Vec3::new(0.0, 0.6, -0.8)), 0.0);
    }
    let lambert = resolve(&[Bsdf::Diffuse { reflectance: k_d }], &[], 0, Vec2::ZERO);
    let view = view_of(lambert);
    assert!(Lobe::of(&view, 0, crate::cpu::ShadingPoint::new(&view, 0).wi_local).is_none());
    assert_eq!(albedo(&view, 0), Vec3::new(0.8, 0.4, 0.1));
}
