//! Hand-made scenes for the light-generation tests (no files needed).
use crate::error::Location;
use crate::scene::{Bsdf, Emitter, EnvMap, Mesh, MicrofacetDistribution, Param, Scene};
use glam::{Mat4, Vec3};

pub use crate::testing::scenes::{lookat, quad, square_camera};

/// The six inward-facing faces of [-1, 1]^3, all with BSDF `bsdf`.
pub fn box_faces(bsdf: usize) -> Vec<Mesh> {
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let m = Vec3::splat(-1.0);
    let p = Vec3::splat(1.0);
    vec![
        quad(m, z, x, bsdf, "floor"),
        quad(p, -x, -z, bsdf, "ceiling"),
        quad(m, x, y, bsdf, "back"),
        quad(p, -y, -x, bsdf, "front"),
        quad(m, y, z, bsdf, "left"),
        quad(p, -z, -y, bsdf, "right"),
    ]
}

/// A closed diffuse box of albedo `rho` (two-sided) around the given emitters; `area` adds a two-sided
/// quad of radiance L = (1, 2, 3) below the ceiling facing down (emitter index = `emitters.len()`).
pub fn furnace_box(rho: f32, emitters: Vec<Emitter>, area: bool) -> Scene {
    let bsdfs = vec![Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(rho)) }, Bsdf::TwoSided { front: 0, back: 0 }];
    let mut meshes = box_faces(1);
    let mut emitters = emitters;
    if area {
        let mut q = quad(Vec3::new(-0.3, 0.8, -0.3), Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.6), 1, "light");
        q.emitter = Some(emitters.len());
        emitters.push(Emitter::Area { mesh: meshes.len(), radiance: Vec3::new(1.0, 2.0, 3.0), texture: None, loc: Location::default() });
        meshes.push(q);
    }
    Scene {
        media: Default::default(),
        path: "furnace_box.xml".into(),
        integrator: None,
        camera: square_camera(32, Vec3::new(0.0, 0.0, 0.9), Vec3::ZERO),
        meshes,
        bsdfs,
        textures: vec![],
        emitters,
    }
}

/// An open box (floor, back, left, right walls; no ceiling, no front) with a floating panel and a
/// rough-metal block, lit by an area quad under a missing ceiling, a small sphere emitter and an
/// environment map (8 x 4 texels with a bright patch) -- for the GPU/CPU comparisons.
pub fn open_box(size: u32) -> Scene {
    let v = |r: f32, g: f32, b: f32| Param::Value(Vec3::new(r, g, b));
    let bsdfs = vec![
        Bsdf::Diffuse { reflectance: v(0.8, 0.8, 0.8) },
        Bsdf::Diffuse { reflectance: v(0.7, 0.2, 0.2) },
        Bsdf::RoughPlastic {
            diffuse_reflectance: v(0.3, 0.6, 0.4),
            specular_reflectance: v(1.0, 1.0, 1.0),
            distribution: MicrofacetDistribution::Ggx,
            alpha: 0.2,
            int_ior: 1.5,
            ext_ior: 1.000277,
            nonlinear: false,
        },
        Bsdf::RoughConductor {
            distribution: MicrofacetDistribution::Beckmann,
            alpha_u: v(0.3, 0.3, 0.3),
            alpha_v: v(0.3, 0.3, 0.3),
            eta: Vec3::new(0.2, 0.92, 1.1),
            k: Vec3::new(3.9, 2.45, 2.14),
            specular_reflectance: v(1.0, 1.0, 1.0),
        },
    ];
    let mut meshes = vec![
        quad(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(2.0, 0.0, 0.0), 0, "floor"),
        quad(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0, "back"),
        quad(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, 2.0), 1, "left"),
        quad(Vec3::new(1.0, -1.0, -1.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 2.0, 0.0), 2, "right"),
        quad(Vec3::new(-0.8, 0.1, -0.4), Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.5, 0.0, 0.0), 3, "panel"),
    ];
    let mut light = quad(Vec3::new(-0.3, 0.9, -0.3), Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.6), 0, "light");
    light.emitter = Some(0);
    let light_mesh = meshes.len();
    meshes.push(light);
    let (w, h) = (8u32, 4u32);
    let mut data = vec![Vec3::new(0.2, 0.25, 0.3); (w * h) as usize];
    data[(w + 2) as usize] = Vec3::new(4.0, 3.0, 2.0);
    Scene {
        media: Default::default(),
        path: "open_box.xml".into(),
        integrator: None,
        camera: square_camera(size, Vec3::new(0.0, 0.3, 3.4), Vec3::new(0.0, -0.2, 0.0)),
        meshes,
        bsdfs,
        textures: vec![],
        emitters: vec![
            Emitter::Area { mesh: light_mesh, radiance: Vec3::new(3.0, 3.0, 2.5), texture: None, loc: Location::default() },
            Emitter::EnvMap {
                map: EnvMap { width: w, height: h, data, scale: 1.0, world_from_env: Mat4::IDENTITY },
                loc: Location::default(),
            },
        ],
    }
}
