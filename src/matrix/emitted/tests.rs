use super::*;
use crate::error::Location;
use crate::scene::{Camera, EnvMap, Mesh, ShapeKind};
use glam::{Mat4, Vec2};

/// One pixel row of three samples: background, the emitter seen from the front, from the back.
fn setup(emitters: Vec<Emitter>) -> (Scene, ViewSamples) {
    let camera = Camera {
        world_from_camera: Mat4::IDENTITY,
        fov_x: 0.7,
        near_clip: 0.01,
        far_clip: 1e4,
        width: 3,
        height: 1,
        principal_point_offset: glam::Vec2::ZERO,
        loc: Location::default(),
    };
    let mut scene = Scene {
        media: Default::default(),
        path: "test".into(),
        integrator: None,
        camera,
        meshes: Vec::new(),
        bsdfs: Vec::new(),
        textures: Vec::new(),
        emitters,
    };
    scene.meshes.push(Mesh {
        id: "panel".into(),
        kind: ShapeKind::Rectangle,
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
        normals: vec![Vec3::Z; 3],
        uvs: vec![],
        indices: vec![[0, 1, 2]],
        face_normals: true,
        bsdf: 0,
        emitter: scene.emitters.iter().position(|e| matches!(e, Emitter::Area { .. })),
        loc: Location::default(),
    });
    let view = ViewSamples {
        width: 3,
        height: 1,
        position: vec![Vec3::ZERO; 3],
        normal: vec![Vec3::ZERO, Vec3::Z, Vec3::Z],
        geo_normal: vec![Vec3::ZERO, Vec3::Z, Vec3::Z],
        wi: vec![Vec3::ZERO, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.0, 0.6, -0.8)],
        uv: vec![Vec2::ZERO; 3],
        albedo: vec![Vec3::ZERO; 3],
        shape_index: vec![-1, 0, 0],
        prim_index: vec![-1, 0, 0],
        bsdf: vec![bytemuck::Zeroable::zeroed(); 3],
        ..Default::default()
    };
    (scene, view)
}

#[test]
fn area_emitter_front_side_only_and_constant_background() {
    let loc = Location::default();
    let (scene, view) = setup(vec![
        Emitter::Constant { radiance: Vec3::new(0.25, 0.5, 1.0), loc: loc.clone() },
        Emitter::Area { mesh: 0, radiance: Vec3::new(3.0, 2.0, 1.0), texture: None, loc },
    ]);
    let e = emitted_radiance(&scene, &view);
    assert_eq!(e, vec![Vec3::new(0.25, 0.5, 1.0), Vec3::new(3.0, 2.0, 1.0), Vec3::ZERO]);
}

#[test]
fn envmap_background_uses_the_camera_ray_and_bad_values_are_zero() {
    let loc = Location::default();
    // A 4 x 3 map: constant 2 except NaN / inf texels, which count as 0.
    let mut data = vec![Vec3::splat(2.0); 12];
    data[5] = Vec3::new(f32::NAN, 1.0, f32::INFINITY);
    let map = EnvMap { width: 4, height: 3, data, world_from_env: Mat4::IDENTITY, scale: 1.0 };
    let (scene, view) = setup(vec![
        Emitter::EnvMap { map: map.clone(), loc: loc.clone() },
        Emitter::Area { mesh: 0, radiance: Vec3::new(f32::NAN, -1.0, 4.0), texture: None, loc },
    ]);
    let e = emitted_radiance(&scene, &view);
    let (_, d) = scene.camera.ray(0.5, 0.5);
    let expect = crate::lights::generate::environment::envmap_radiance(&map, d);
    assert!(e.iter().all(|v| v.is_finite()), "{e:?}");
    if expect.is_finite() {
        assert_eq!(e[0], expect);
    }
    assert_eq!(e[1], Vec3::new(0.0, 0.0, 4.0));
    assert_eq!(e[2], Vec3::ZERO);
}
