use super::*;
use crate::shading::bsdf::{eval, resolve, KIND_DIFFUSE};
use std::path::Path;

/// A rectangle (identity `to_world`: z-up, uv = ((x + 1) / 2, (y + 1) / 2), dp_du = (2, 0, 0),
/// dp_dv = (0, 2, 0), as Mitsuba's `rectangle`) with `bsdf` (XML), loaded from a temporary file.
fn plane(bsdf: &str) -> Scene {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let xml = format!(
        r#"<scene version="3.0.0"><path value="{}"/>
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
        <shape type="rectangle">{bsdf}</shape></scene>"#,
        data.display()
    );
    let dir = std::env::temp_dir().join(format!("ml-perturb-{}-{}", std::process::id(), xml.len()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("plane.xml");
    std::fs::write(&path, xml).unwrap();
    crate::scene::load_scene(&path, &Default::default()).unwrap()
}

/// Mitsuba's `bsdf.eval` at uv (its local frame = world here) on the plane, through the view-sample path:
/// the resolved record with the perturbation applied.
fn eval_at(scene: &Scene, uv: Vec2, wi: Vec3, wo: Vec3) -> Vec3 {
    let p = Vec3::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0);
    let mesh = &scene.meshes[0];
    // The triangle holding p.
    let prim = (0..mesh.indices.len())
        .find(|&k| {
            let t = mesh.indices[k].map(|i| mesh.positions[i as usize]);
            let e = |a: Vec3, b: Vec3| (b - a).cross(p - a).z;
            let s = [e(t[0], t[1]), e(t[1], t[2]), e(t[2], t[0])];
            s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
        })
        .unwrap();
    let (s, t) = tangents(mesh, prim, p, Vec3::Z);
    assert!((s - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6 && (t - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-6, "{s} {t}");
    let mut b = resolve(&scene.bsdfs, &scene.textures, mesh.bsdf, uv);
    apply(scene, 0, prim, p, Vec3::Z, Vec3::Z, uv, &mut [&mut b]);
    eval(&b, wi.normalize(), wo.normalize())
}

/// (uv, wi, wo): the same points as the expected values below.
fn cases() -> [(Vec2, Vec3, Vec3); 5] {
    [
        (Vec2::new(0.3, 0.7), Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.6, 0.0, 0.8)),
        (Vec2::new(0.12, 0.41), Vec3::new(0.3, -0.2, 0.9), Vec3::new(-0.5, 0.4, 0.6)),
        (Vec2::new(0.77, 0.05), Vec3::new(-0.8, 0.1, 0.3), Vec3::new(0.2, 0.9, 0.25)),
        (Vec2::new(0.5, 0.93), Vec3::new(0.1, 0.7, 0.2), Vec3::new(0.9, -0.3, 0.1)),
        (Vec2::new(0.64, 0.28), Vec3::new(0.9, 0.05, 0.1), Vec3::new(-0.2, 0.3, 0.93)),
    ]
}

fn check(scene: &Scene, expected: [[f32; 3]; 5]) {
    for ((uv, wi, wo), e) in cases().into_iter().zip(expected) {
        let got = eval_at(scene, uv, wi, wo);
        let e = Vec3::from_array(e);
        let err = (got - e).abs().max_element() / e.max_element().max(1e-3);
        assert!(err < 2e-4, "uv {uv}: got {got}, Mitsuba {e} (relative {err})");
    }
}

// Expected values: Mitsuba 3.9.1 (scalar_rgb) `bsdf.eval` with a SurfaceInteraction3f of uv, n = sh_frame.n =
// (0, 0, 1), dp_du = (2, 0, 0), dp_dv = (0, 2, 0), wi and wo the normalised directions above (texture files in
// tests/data/textures). Cases 3 and 4 of the bumpmap and 4 of the normal map are 0: wo below the perturbed
// normal or on the other side of a flipped one.

#[test]
fn bumpmap_matches_mitsuba_eval() {
    let scene = plane(
        r#"<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="textures/bump_ripples.png"/>
        <transform name="to_uv"><scale x="3" y="2"/></transform></texture><float name="scale" value="0.4"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf></bsdf>"#,
    );
    check(
        &scene,
        [
            [0.0725243017, 0.0621636882, 0.0518030711],
            [0.161969304, 0.138830841, 0.115692362],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.202490494, 0.173563287, 0.144636065],
        ],
    );
}

#[test]
fn normalmap_matches_mitsuba_eval() {
    let scene = plane(
        r#"<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value="textures/normal_waves.png"/>
        <boolean name="raw" value="true"/></texture>
        <bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/></bsdf></bsdf>"#,
    );
    check(
        &scene,
        [
            [0.130783364, 0.130783364, 0.130783364],
            [0.0480254889, 0.0480254889, 0.0480254889],
            [0.0403358974, 0.0403358974, 0.0403358974],
            [0.0, 0.0, 0.0],
            [0.115999065, 0.115999065, 0.115999065],
        ],
    );
}

#[test]
fn an_unperturbed_normal_changes_nothing() {
    let mut b = GpuBsdf { kind: KIND_DIFFUSE, diffuse: [0.5, 0.4, 0.3], ..bytemuck::Zeroable::zeroed() };
    let plain = b;
    set_normal(&mut b, Vec3::Z);
    assert_eq!(b.flags, FLAG_BUMP);
    for (wi, wo) in [(Vec3::new(0.3, 0.1, 0.9), Vec3::new(-0.4, 0.2, 0.8)), (Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.6, 0.0, 0.8))] {
        let (wi, wo) = (wi.normalize(), wo.normalize());
        assert_eq!(eval(&b, wi, wo), eval(&plain, wi, wo));
    }
    // A tilted normal: the shadowing term is below 1 at grazing wo, and a direction below it gives 0.
    let n = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
    assert!(shadow_terminator(n, Vec3::new(0.9, 0.0, 0.1).normalize()) < 0.9);
    assert_eq!(shadow_terminator(n, Vec3::Z), 1.0);
    set_normal(&mut b, n);
    assert_eq!(eval(&b, Vec3::Z, Vec3::new(-0.95, 0.0, 0.2).normalize()), Vec3::ZERO);
}

#[test]
fn height_gradient_is_the_bilinear_patch_derivative() {
    let tex = crate::scene::Texture::Bitmap {
        width: 3,
        height: 2,
        data: [0.1, 0.5, 0.2, 0.9, 0.3, 0.7].map(Vec3::splat).to_vec(),
        filter: crate::scene::FilterType::Bilinear,
        wrap: crate::scene::WrapMode::Repeat,
        to_uv: glam::Mat3::from_scale(Vec2::new(2.0, 1.5)),
        loc: crate::error::Location::new(Path::new("t"), 0),
    };
    let uv = Vec2::new(0.31, 0.42);
    let g = crate::scene::texture::eval_1_grad(&tex, uv);
    let h = 1e-3;
    let f = |d: Vec2| crate::scene::texture::eval_1(&tex, uv + d) as f64;
    let fd = Vec2::new(
        ((f(Vec2::X * h) - f(-Vec2::X * h)) / (2.0 * h as f64)) as f32,
        ((f(Vec2::Y * h) - f(-Vec2::Y * h)) / (2.0 * h as f64)) as f32,
    );
    assert!((g - fd).length() < 2e-3 * fd.length(), "{g} vs finite differences {fd}");
    assert!(g.length() > 1.0);
}

#[test]
fn samples_weigh_eval_over_pdf() {
    use crate::lights::generate::sampling::{pdf_bsdf, stream};
    use crate::shading::bsdf::{FLAG_GGX, KIND_ROUGHPLASTIC};
    let mut rough =
        GpuBsdf { kind: KIND_ROUGHPLASTIC, flags: FLAG_GGX, diffuse: [0.5, 0.4, 0.3], specular: [1.0; 3], ..bytemuck::Zeroable::zeroed() };
    rough.eta = [1.5, 1.0 / 2.25, 0.0];
    rough.alpha_u = 0.3;
    rough.alpha_v = 0.3;
    rough.extra[0] = crate::shading::bsdf_tables::roughplastic_tables(true, 0.3, 1.5).internal_reflectance;
    let diffuse = GpuBsdf { kind: KIND_DIFFUSE, diffuse: [0.5, 0.4, 0.3], ..bytemuck::Zeroable::zeroed() };
    let mut rng = stream(7, 99, 0);
    for mut b in [diffuse, rough] {
        set_normal(&mut b, Vec3::new(0.35, -0.2, 0.9).normalize());
        let wi = Vec3::new(-0.3, 0.4, 0.85).normalize();
        let mut n = 0;
        for _ in 0..2000 {
            let Some(s) = sample(&b, wi, &mut rng) else { continue };
            let (e, p) = (eval(&b, wi, s.wo), pdf(&b, wi, s.wo));
            assert!(
                p > 0.0 && ((e / p) - s.weight).abs().max_element() < 1e-3 * s.weight.max_element().max(1.0),
                "{e} / {p} vs {}",
                s.weight
            );
            assert_eq!(p, pdf_bsdf(&b, wi, s.wo));
            n += 1;
        }
        assert!(n > 1500, "{n} of 2000 samples");
    }
}
