//! The scene data model: what `xml::load_scene` produces and every renderer reads.
//!
//! Everything is in world space, RGB, linear. Units and conventions follow Mitsuba 3.9.1
//! (`docs/development/mitsuba-conventions.md`). Vectors are `glam::Vec3` (f32), matrices `glam::Mat4`
//! (column-major, `world_from_local` style: `p_world = m.transform_point3(p_local)`).
use crate::error::Location;
use glam::{Mat3, Mat4, Vec2, Vec3};

/// A whole scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The XML file it was loaded from.
    pub path: std::path::PathBuf,
    pub camera: Camera,
    /// One entry per `<shape>`, in document order; `Mesh::id` gives Mitsuba's id (or a generated one).
    pub meshes: Vec<Mesh>,
    /// Every BSDF a shape uses, deduplicated by identity (shapes sharing a `<ref>` share an index).
    pub bsdfs: Vec<Bsdf>,
    /// Every non-constant texture a BSDF uses; `Param::Texture(i)` indexes this.
    pub textures: Vec<Texture>,
    /// All emitters: the top-level ones in document order, then the area emitters of shapes.
    pub emitters: Vec<Emitter>,
    /// The first top-level `<integrator>`, if the file has one (Mitsuba's default is `path`, depth -1).
    pub integrator: Option<Integrator>,
    /// Participating media of the shapes, as the scene's integrator uses them (empty when it ignores
    /// media, e.g. `path`).
    pub media: Media,
}

/// A homogeneous medium (Mitsuba's `homogeneous`) as the renderer uses it: extinction only. Along a
/// segment of length t inside it, radiance is multiplied by `exp(-sigma_t * t)` per RGB channel
/// (Beer-Lambert); in-scattering (`albedo`) is not modelled.
#[derive(Debug, Clone, PartialEq)]
pub struct Medium {
    /// Extinction coefficient per unit length, RGB: Mitsuba's `sigma_t` times `scale`.
    pub sigma_t: Vec3,
    /// Single-scattering albedo, RGB (kept to report what is not modelled).
    pub albedo: Vec3,
    pub loc: Location,
}

/// The media of a scene's shapes: `interior` / `exterior` of `<shape>`s (Mitsuba's medium transitions: a
/// ray leaving a shape with media enters `exterior` if it leaves on the side of the geometric normal,
/// else `interior`; a ray leaving a shape without media stays in its medium). The camera is in no medium.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Media {
    pub media: Vec<Medium>,
    /// Per mesh (same length as `Scene::meshes`, or empty when no shape has media): indices into `media`
    /// of its (interior, exterior) media.
    pub shape: Vec<(Option<usize>, Option<usize>)>,
}

impl Media {
    /// Whether the scene has no media.
    pub fn is_empty(&self) -> bool {
        self.media.is_empty()
    }

    /// The medium a ray is in after leaving mesh `mesh` along `d` (geometric normal `n_g`), having been in
    /// `current`: Mitsuba's `SurfaceInteraction::target_medium` where the shape is a medium transition.
    pub fn after(&self, current: Option<usize>, mesh: usize, d: Vec3, n_g: Vec3) -> Option<usize> {
        match self.shape.get(mesh) {
            Some(&(interior, exterior)) if interior.is_some() || exterior.is_some() => {
                if d.dot(n_g) > 0.0 {
                    exterior
                } else {
                    interior
                }
            }
            _ => current,
        }
    }

    /// Beer-Lambert transmittance of a segment of length `t` in `medium` (1 outside any medium; 0 for
    /// an infinite segment in a medium with sigma_t > 0).
    pub fn transmittance(&self, medium: Option<usize>, t: f32) -> Vec3 {
        match medium {
            None => Vec3::ONE,
            Some(m) => {
                let s = self.media[m].sigma_t;
                Vec3::new(beer(s.x, t), beer(s.y, t), beer(s.z, t))
            }
        }
    }
}

fn beer(sigma_t: f32, t: f32) -> f32 {
    if sigma_t == 0.0 {
        1.0
    } else {
        (-(sigma_t as f64) * t as f64).exp() as f32
    }
}

/// A top-level `<integrator>`: we render no image with it, but its path depth says how much light
/// transport the scene asks for (e.g. whether indirect light, hence VPLs, is wanted).
#[derive(Debug, Clone, PartialEq)]
pub struct Integrator {
    /// The `type` attribute: "path", "volpath", "direct", ...
    pub plugin: String,
    /// Mitsuba's path depth of this integrator (1 = emitters seen directly, 2 = direct light, -1 =
    /// unbounded): `max_depth` of a path-tracing plugin (default -1), 2 for `direct`; `None` for other
    /// plugins (e.g. `aov`), whose depth we do not know.
    pub max_depth: Option<i64>,
    pub loc: Location,
}

/// `<sensor type="perspective">` with its `<film type="hdrfilm">`.
#[derive(Debug, Clone)]
pub struct Camera {
    /// Camera frame: columns = (left, up, forward, origin), no scale (a scale is a load error).
    pub world_from_camera: Mat4,
    /// Full horizontal field of view in radians (resolved from `fov` + `fov_axis` or `focal_length`).
    pub fov_x: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    /// Film size in pixels.
    pub width: u32,
    pub height: u32,
    /// Mitsuba's `principal_point_offset_x/y` (off-axis projection, e.g. from the Blender exporter), in
    /// film units: the ray through film position (px, py) is the centred camera's ray through
    /// (px + x W, py + y H). (0, 0) = centred.
    pub principal_point_offset: Vec2,
    pub loc: Location,
}

/// What a `<shape>` was in the file (the mesh itself is always triangles).
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeKind {
    Obj,
    Ply,
    Rectangle,
    Cube,
    /// Analytic in Mitsuba: `Mesh` holds a fine tessellation for rasterisation and shadow maps; exact
    /// intersections (G-buffer, ray tracing) use `center` and `radius` (world space).
    Sphere {
        center: Vec3,
        radius: f32,
        flip_normals: bool,
    },
    Disk,
    /// Mitsuba's `serialized` mesh.
    Serialized,
    /// Analytic in Mitsuba; here a fine tessellation (`scene::mesh::cylinder`).
    Cylinder,
}

/// A triangle mesh in world space.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Mitsuba id, or `"shape_<k>"` when the file gives none.
    pub id: String,
    pub kind: ShapeKind,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, unit length, world space (same length as `positions`). For
    /// `face_normals=true` and flat built-ins the vertices are unshared so normals are per face.
    pub normals: Vec<Vec3>,
    /// Per-vertex uv as Mitsuba stores it (after its OBJ/PLY v-flip conventions); empty if none.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
    /// True when the shading normal is the face normal (no interpolation).
    pub face_normals: bool,
    /// Index into `Scene::bsdfs`.
    pub bsdf: usize,
    /// Index into `Scene::emitters` of its area emitter.
    pub emitter: Option<usize>,
    pub loc: Location,
}

/// An RGB parameter that may be textured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Param {
    Value(Vec3),
    /// Index into `Scene::textures`.
    Texture(usize),
}

/// A scalar parameter that may be textured (e.g. roughness `alpha`); textured scalars are evaluated as
/// Mitsuba's `eval_1` does (`crate::scene::texture::eval_param_1`).
pub type ScalarParam = Param;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MicrofacetDistribution {
    Beckmann,
    Ggx,
}

/// BSDFs as Mitsuba defines them (RGB variants). Evaluation lives in `crate::shading::bsdf`.
#[derive(Debug, Clone, PartialEq)]
pub enum Bsdf {
    Diffuse {
        reflectance: Param,
    },
    /// Wraps another BSDF (index into `Scene::bsdfs`); one nested BSDF serves both sides
    /// (Mitsuba's second child, for a different back side, is kept as `back`).
    TwoSided {
        front: usize,
        back: usize,
    },
    RoughPlastic {
        diffuse_reflectance: Param,
        specular_reflectance: Param,
        distribution: MicrofacetDistribution,
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        nonlinear: bool,
    },
    /// Smooth plastic: a point light only reaches its diffuse part.
    Plastic {
        diffuse_reflectance: Param,
        specular_reflectance: Param,
        int_ior: f32,
        ext_ior: f32,
        nonlinear: bool,
    },
    RoughConductor {
        distribution: MicrofacetDistribution,
        /// `alpha_u`, `alpha_v` (equal when the file gives `alpha`).
        alpha_u: ScalarParam,
        alpha_v: ScalarParam,
        /// Complex index of refraction (relative to `ext_eta`), RGB.
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Param,
    },
    /// Smooth conductor: no contribution from point lights.
    Conductor {
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Param,
    },
    /// Smooth dielectric: no contribution from point lights.
    Dielectric {
        int_ior: f32,
        ext_ior: f32,
    },
    /// Mitsuba's `roughdielectric`: microfacet reflection and transmission (Walter et al. 2007) at an
    /// interface of relative IOR `int_ior / ext_ior`, both sides (`crate::shading::bsdf`).
    RoughDielectric {
        distribution: MicrofacetDistribution,
        /// `alpha_u`, `alpha_v` (equal when the file gives `alpha`).
        alpha_u: ScalarParam,
        alpha_v: ScalarParam,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Param,
        specular_transmittance: Param,
    },
    /// Mitsuba's `thindielectric`: a thin slab (delta reflection of 2R / (1 + R), straight-through null
    /// transmission of the rest); `eval` is 0 (`crate::view::chains` follows its lobes).
    ThinDielectric {
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Param,
        specular_transmittance: Param,
    },
    /// Mitsuba's `principled` (`crate::shading::principled`); `eta` resolved from `eta` / `specular`.
    Principled(Box<crate::scene::principled::Principled>),
    /// Mitsuba's `blendbsdf`: `(1 - w) f_first + w f_second`, w = clip(weight, 0, 1) (`eval_1` of a
    /// texture); indices into `Scene::bsdfs`, neither a blend (nested blends are refused on load).
    Blend {
        weight: ScalarParam,
        first: usize,
        second: usize,
    },
    /// Mitsuba's `bumpmap`: `nested` (index into `Scene::bsdfs`) evaluated in the shading frame tilted by
    /// the uv gradient of the height texture `texture` (index into `Scene::textures`, a bitmap) times
    /// `scale` (`crate::shading::perturb`).
    BumpMap {
        texture: usize,
        scale: f32,
        nested: usize,
    },
    /// Mitsuba's `mask` (`src/bsdfs/mask.cpp`): `nested` (index into `Scene::bsdfs`) weighted by the
    /// opacity a = clip(eval_1(opacity), 0, 1), plus a null lobe (straight through) of weight 1 - a
    /// (`crate::view::chains`, `crate::raytrace::mask`).
    Mask {
        opacity: ScalarParam,
        nested: usize,
    },
    /// Mitsuba's `normalmap`: `nested` evaluated in the shading frame whose normal is `2 c - 1` of the RGB
    /// texel `c` of `texture` (a raw bitmap), in the tangent frame of the unperturbed shading normal.
    NormalMap {
        texture: usize,
        nested: usize,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterType {
    Nearest,
    Bilinear,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}

/// A texture, evaluated at a uv (see `crate::scene::texture::eval`).
#[derive(Debug, Clone)]
pub enum Texture {
    /// Linear RGB texels, row 0 = first row of the file; `data.len() == width * height`.
    Bitmap {
        width: u32,
        height: u32,
        data: Vec<Vec3>,
        filter: FilterType,
        wrap: WrapMode,
        /// `to_uv` as a 2D affine map (3x3 homogeneous).
        to_uv: Mat3,
        loc: Location,
    },
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        to_uv: Mat3,
    },
}

/// A lat-long environment map (`envmap`).
#[derive(Debug, Clone)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 = +Y (top of the file), before `scale`.
    pub data: Vec<Vec3>,
    pub scale: f32,
    pub world_from_env: Mat4,
}

#[derive(Debug, Clone)]
pub enum Emitter {
    /// `intensity` in W/sr.
    Point {
        position: Vec3,
        intensity: Vec3,
        loc: Location,
    },
    /// Emits along local +z of `world_from_light`. Angles in radians.
    /// `texture`: index into `Scene::textures` of a projected texture (`crate::lights::spot_texture`).
    Spot {
        world_from_light: Mat4,
        intensity: Vec3,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<usize>,
        loc: Location,
    },
    /// `direction`: unit vector the light travels along (world). `irradiance` in W/m^2.
    Directional {
        direction: Vec3,
        irradiance: Vec3,
        loc: Location,
    },
    /// Emits `radiance` from the +normal side of `Scene::meshes[mesh]`; with `texture` (index into
    /// `Scene::textures`) the radiance is that texture at the surface uv instead (`radiance` unused).
    Area {
        mesh: usize,
        radiance: Vec3,
        texture: Option<usize>,
        loc: Location,
    },
    EnvMap {
        map: EnvMap,
        loc: Location,
    },
    Constant {
        radiance: Vec3,
        loc: Location,
    },
}

impl Scene {
    /// Axis-aligned bounds of all mesh vertices: (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for m in &self.meshes {
            for p in &m.positions {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal (the scale for position tolerances and biases).
    pub fn diagonal(&self) -> f32 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }
}

impl Camera {
    /// Full vertical field of view in radians.
    pub fn fov_y(&self) -> f32 {
        2.0 * ((self.fov_x * 0.5).tan() * self.height as f32 / self.width as f32).atan()
    }

    pub fn origin(&self) -> Vec3 {
        self.world_from_camera.w_axis.truncate()
    }

    /// Primary ray through film position (px, py) in pixels ([0,W]x[0,H], row 0 at the top; shifted by
    /// `principal_point_offset` as in Mitsuba's `PerspectiveCamera::sample_ray`):
    /// (origin, unit direction), origin moved by `near_clip` along the ray as Mitsuba does.
    pub fn ray(&self, px: f32, py: f32) -> (Vec3, Vec3) {
        let tx = (self.fov_x * 0.5).tan();
        let ty = tx * self.height as f32 / self.width as f32;
        let o = self.principal_point_offset;
        let d_local = Vec3::new((1.0 - 2.0 * (px / self.width as f32 + o.x)) * tx, (1.0 - 2.0 * (py / self.height as f32 + o.y)) * ty, 1.0)
            .normalize();
        let d = self.world_from_camera.transform_vector3(d_local).normalize();
        let o = self.origin();
        (o + d * (self.near_clip / d_local.z), d)
    }
}

/// Shorthand used by loaders and tests.
pub fn vec2(x: f32, y: f32) -> Vec2 {
    Vec2::new(x, y)
}
