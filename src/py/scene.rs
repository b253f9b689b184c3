//! `load_scene`, `Scene` (introspection + G-buffer) and `device_info`.
use super::util::{array, vec3_array};
use crate::gpu::GpuContext;
use crate::matrix::backend::{Chosen, Device, DeviceInfo};
use crate::raytrace::RayTracer;
use crate::scene::{self, Bsdf, Emitter, LoadOptions, Param, ShapeKind};
use crate::view::chains::ChainOptions;
use crate::view::ViewSamples;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// A scene loaded from Mitsuba 3 XML (see `manylights.load_scene`).
#[pyclass(module = "manylights._native", frozen)]
pub struct Scene {
    pub inner: Arc<scene::Scene>,
    /// View samples per delta-chain options (usually one entry).
    view: Mutex<Vec<(ChainOptions, Arc<ViewSamples>)>>,
    /// The scene's CPU ray tracer (BVH), built on first use: the CPU backend's G-buffer and shadow rays,
    /// and the exact oracle of every light matrix of this scene.
    tracer: std::sync::OnceLock<Arc<RayTracer>>,
    /// The probes' environment, sampled by luminance ([0]) or guided by the camera's pilot view ([1])
    /// (`pathtrace::SampledEnvironment`), each built on first use: None without an environment.
    probe_env: [std::sync::OnceLock<Option<Arc<crate::pathtrace::SampledEnvironment>>>; 2],
    /// Per shape, `shading::frame::anisotropic_frame_differs`, computed on first use (it reads every
    /// triangle of a shape with an anisotropic BSDF; `shapes` is read often).
    anisotropic_frame: std::sync::OnceLock<Vec<bool>>,
}

impl Scene {
    /// The view samples (G-buffer) on `device` (once per Scene: later calls return the cached samples).
    pub fn view_samples(&self, py: Python<'_>, device: Device) -> PyResult<Arc<ViewSamples>> {
        let chosen = py.detach(move || device.choose())?;
        self.view_samples_on(py, ChainOptions::default(), &chosen)
    }

    /// The scene's ray tracer, built once (released GIL).
    pub fn tracer(&self, py: Python<'_>) -> PyResult<Arc<RayTracer>> {
        if let Some(t) = self.tracer.get() {
            return Ok(t.clone());
        }
        let scene = self.inner.clone();
        let t = Arc::new(super::signals::detach(py, move || RayTracer::new(&scene))?);
        Ok(self.tracer.get_or_init(|| t).clone())
    }

    /// The probes' environment (`pathtrace::SampledEnvironment`, guided or not), built once per flag
    /// (released GIL): every probe call of this scene samples the same one.
    pub fn probe_env(&self, py: Python<'_>, guided: bool) -> PyResult<Option<Arc<crate::pathtrace::SampledEnvironment>>> {
        let slot = &self.probe_env[usize::from(guided)];
        if let Some(e) = slot.get() {
            return Ok(e.clone());
        }
        let tracer = self.tracer(py)?;
        let scene = self.inner.clone();
        let e = super::signals::detach(py, move || crate::pathtrace::SampledEnvironment::build(&scene, &tracer, guided))?;
        Ok(slot.get_or_init(|| e.map(Arc::new)).clone())
    }

    /// The camera's own view samples (the first `width * height`, which do not depend on the delta-chain
    /// options): any cached entry (so a probe starts from the same hits as the images of this Scene, on
    /// either backend), else computed with the CPU backend's ray cast.
    pub fn camera_samples(&self, py: Python<'_>) -> PyResult<Arc<ViewSamples>> {
        if let Some((_, v)) = self.view.lock().unwrap_or_else(|e| e.into_inner()).first() {
            return Ok(v.clone());
        }
        self.view_samples_on(py, ChainOptions::default(), &Chosen::Cpu)
    }

    /// The view samples with delta chains followed by `chains`, computed once per options and cached:
    /// visibility at pixel centres rasterised on the GPU, or ray cast through the BVH for the CPU
    /// backend (`view::resolve::cast_visibility_traced`), then resolved exactly on the CPU. A cached
    /// entry serves both devices (so matrices of one Scene on either backend share their rows).
    pub fn view_samples_on(&self, py: Python<'_>, chains: ChainOptions, chosen: &Chosen) -> PyResult<Arc<ViewSamples>> {
        if let Some((_, v)) = self.view.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|(o, _)| *o == chains) {
            return Ok(v.clone());
        }
        let scene = self.inner.clone();
        let v = match chosen {
            Chosen::Gpu(ctx) => {
                let ctx = ctx.clone();
                super::signals::detach(py, move || crate::gpu::gbuffer::render_view_samples_with(&ctx, &scene, &chains))?
            }
            Chosen::Cpu => {
                let tracer = self.tracer(py)?;
                super::signals::detach(py, move || -> crate::error::Result<ViewSamples> {
                    let ids = crate::view::resolve::cast_visibility_traced(&scene, &tracer)?;
                    crate::view::resolve::resolve_view_samples_with(&scene, &ids, &chains)
                })?
            }
        };
        let v = Arc::new(v);
        self.view.lock().unwrap_or_else(|e| e.into_inner()).push((chains, v.clone()));
        Ok(v)
    }
}

fn rgb(v: glam::Vec3) -> [f32; 3] {
    v.to_array()
}

fn param<'py>(py: Python<'py>, p: &Param) -> PyResult<Bound<'py, PyAny>> {
    Ok(match p {
        Param::Value(v) => rgb(*v).into_pyobject(py)?.into_any(),
        Param::Texture(i) => format!("texture[{i}]").into_pyobject(py)?.into_any(),
    })
}

#[pymethods]
impl Scene {
    #[getter]
    fn path(&self) -> PathBuf {
        self.inner.path.clone()
    }
    #[getter]
    fn width(&self) -> u32 {
        self.inner.camera.width
    }
    #[getter]
    fn height(&self) -> u32 {
        self.inner.camera.height
    }
    /// Film size as (height, width), numpy order.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        (self.inner.camera.height, self.inner.camera.width)
    }
    /// One dict per shape: id, type, triangles, vertices, bsdf (index), emitter (index or None), file/line,
    /// anisotropic_frame (an anisotropic BSDF whose shading frame differs from Mitsuba's: `shading::frame`).
    #[getter]
    fn shapes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let turned = self.anisotropic_frame.get_or_init(|| {
            (0..self.inner.meshes.len()).map(|k| crate::shading::frame::anisotropic_frame_differs(&self.inner, k)).collect()
        });
        self.inner
            .meshes
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let d = PyDict::new(py);
                d.set_item("id", &m.id)?;
                let kind = match &m.kind {
                    ShapeKind::Obj => "obj",
                    ShapeKind::Ply => "ply",
                    ShapeKind::Rectangle => "rectangle",
                    ShapeKind::Cube => "cube",
                    ShapeKind::Sphere { center, radius, .. } => {
                        d.set_item("center", rgb(*center))?;
                        d.set_item("radius", *radius)?;
                        "sphere"
                    }
                    ShapeKind::Disk => "disk",
                    ShapeKind::Serialized => "serialized",
                    ShapeKind::Cylinder => "cylinder",
                };
                d.set_item("type", kind)?;
                d.set_item("triangles", m.indices.len())?;
                d.set_item("vertices", m.positions.len())?;
                d.set_item("bsdf", m.bsdf)?;
                d.set_item("emitter", m.emitter)?;
                d.set_item("face_normals", m.face_normals)?;
                d.set_item("anisotropic_frame", turned[k])?;
                let lo = m.positions.iter().fold(glam::Vec3::splat(f32::INFINITY), |a, p| a.min(*p));
                let hi = m.positions.iter().fold(glam::Vec3::splat(f32::NEG_INFINITY), |a, p| a.max(*p));
                let (lo, hi) = match &m.kind {
                    ShapeKind::Sphere { center, radius, .. } => (*center - *radius, *center + *radius),
                    _ => (lo, hi),
                };
                d.set_item("bbox_min", rgb(lo))?;
                d.set_item("bbox_max", rgb(hi))?;
                d.set_item("file", m.loc.file.display().to_string())?;
                d.set_item("line", m.loc.line)?;
                Ok(d)
            })
            .collect()
    }
    /// One dict per emitter with its type and parameters (radians for angles).
    #[getter]
    fn emitters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .emitters
            .iter()
            .map(|e| {
                let d = PyDict::new(py);
                match e {
                    Emitter::Point { position, intensity, .. } => {
                        d.set_item("type", "point")?;
                        d.set_item("position", rgb(*position))?;
                        d.set_item("intensity", rgb(*intensity))?;
                    }
                    Emitter::Spot { world_from_light, intensity, cutoff_angle, beam_width, texture, .. } => {
                        d.set_item("type", "spot")?;
                        d.set_item("position", rgb(world_from_light.w_axis.truncate()))?;
                        d.set_item("direction", rgb(world_from_light.z_axis.truncate().normalize()))?;
                        d.set_item("intensity", rgb(*intensity))?;
                        d.set_item("cutoff_angle", *cutoff_angle)?;
                        d.set_item("beam_width", *beam_width)?;
                        if let Some(t) = texture {
                            d.set_item("texture", format!("texture[{t}]"))?;
                        }
                    }
                    Emitter::Directional { direction, irradiance, .. } => {
                        d.set_item("type", "directional")?;
                        d.set_item("direction", rgb(*direction))?;
                        d.set_item("irradiance", rgb(*irradiance))?;
                    }
                    Emitter::Area { mesh, radiance, texture, .. } => {
                        d.set_item("type", "area")?;
                        d.set_item("shape", *mesh)?;
                        match texture {
                            Some(t) => d.set_item("radiance", param(py, &Param::Texture(*t))?)?,
                            None => d.set_item("radiance", rgb(*radiance))?,
                        }
                    }
                    Emitter::EnvMap { map, .. } => {
                        d.set_item("type", "envmap")?;
                        d.set_item("width", map.width)?;
                        d.set_item("height", map.height)?;
                        d.set_item("scale", map.scale)?;
                    }
                    Emitter::Constant { radiance, .. } => {
                        d.set_item("type", "constant")?;
                        d.set_item("radiance", rgb(*radiance))?;
                    }
                }
                Ok(d)
            })
            .collect()
    }
    /// One dict per BSDF with its type and parameters (textured ones as "texture[i]").
    #[getter]
    fn bsdfs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .bsdfs
            .iter()
            .map(|b| {
                let d = PyDict::new(py);
                match b {
                    Bsdf::Diffuse { reflectance } => {
                        d.set_item("type", "diffuse")?;
                        d.set_item("reflectance", param(py, reflectance)?)?;
                    }
                    Bsdf::TwoSided { front, back } => {
                        d.set_item("type", "twosided")?;
                        d.set_item("front", *front)?;
                        d.set_item("back", *back)?;
                    }
                    Bsdf::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, alpha, int_ior, ext_ior, nonlinear } => {
                        d.set_item("type", "roughplastic")?;
                        d.set_item("diffuse_reflectance", param(py, diffuse_reflectance)?)?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                        d.set_item("distribution", format!("{distribution:?}").to_lowercase())?;
                        d.set_item("alpha", *alpha)?;
                        d.set_item("int_ior", *int_ior)?;
                        d.set_item("ext_ior", *ext_ior)?;
                        d.set_item("nonlinear", *nonlinear)?;
                    }
                    Bsdf::Plastic { diffuse_reflectance, specular_reflectance, int_ior, ext_ior, nonlinear } => {
                        d.set_item("type", "plastic")?;
                        d.set_item("diffuse_reflectance", param(py, diffuse_reflectance)?)?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                        d.set_item("int_ior", *int_ior)?;
                        d.set_item("ext_ior", *ext_ior)?;
                        d.set_item("nonlinear", *nonlinear)?;
                    }
                    Bsdf::RoughConductor { distribution, alpha_u, alpha_v, eta, k, specular_reflectance } => {
                        d.set_item("type", "roughconductor")?;
                        d.set_item("distribution", format!("{distribution:?}").to_lowercase())?;
                        d.set_item("alpha_u", param(py, alpha_u)?)?;
                        d.set_item("alpha_v", param(py, alpha_v)?)?;
                        d.set_item("eta", rgb(*eta))?;
                        d.set_item("k", rgb(*k))?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                    }
                    Bsdf::Conductor { eta, k, specular_reflectance } => {
                        d.set_item("type", "conductor")?;
                        d.set_item("eta", rgb(*eta))?;
                        d.set_item("k", rgb(*k))?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                    }
                    Bsdf::Dielectric { int_ior, ext_ior } => {
                        d.set_item("type", "dielectric")?;
                        d.set_item("int_ior", *int_ior)?;
                        d.set_item("ext_ior", *ext_ior)?;
                    }
                    Bsdf::RoughDielectric {
                        distribution,
                        alpha_u,
                        alpha_v,
                        int_ior,
                        ext_ior,
                        specular_reflectance,
                        specular_transmittance,
                    } => {
                        d.set_item("type", "roughdielectric")?;
                        d.set_item("distribution", format!("{distribution:?}").to_lowercase())?;
                        d.set_item("alpha_u", param(py, alpha_u)?)?;
                        d.set_item("alpha_v", param(py, alpha_v)?)?;
                        d.set_item("int_ior", *int_ior)?;
                        d.set_item("ext_ior", *ext_ior)?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                        d.set_item("specular_transmittance", param(py, specular_transmittance)?)?;
                    }
                    Bsdf::ThinDielectric { int_ior, ext_ior, specular_reflectance, specular_transmittance } => {
                        d.set_item("type", "thindielectric")?;
                        d.set_item("int_ior", *int_ior)?;
                        d.set_item("ext_ior", *ext_ior)?;
                        d.set_item("specular_reflectance", param(py, specular_reflectance)?)?;
                        d.set_item("specular_transmittance", param(py, specular_transmittance)?)?;
                    }
                    Bsdf::Principled(p) => {
                        d.set_item("type", "principled")?;
                        d.set_item("base_color", param(py, &p.base_color)?)?;
                        for (name, v) in p.scalars() {
                            d.set_item(name, param(py, v)?)?;
                        }
                        d.set_item("eta", p.eta)?;
                    }
                    Bsdf::Blend { weight, first, second } => {
                        d.set_item("type", "blendbsdf")?;
                        d.set_item("weight", param(py, weight)?)?;
                        d.set_item("bsdf_0", *first)?;
                        d.set_item("bsdf_1", *second)?;
                    }
                    Bsdf::BumpMap { texture, scale, nested } => {
                        d.set_item("type", "bumpmap")?;
                        d.set_item("texture", format!("texture[{texture}]"))?;
                        d.set_item("scale", *scale)?;
                        d.set_item("bsdf", *nested)?;
                    }
                    Bsdf::Mask { opacity, nested } => {
                        d.set_item("type", "mask")?;
                        match opacity {
                            Param::Value(v) => d.set_item("opacity", v.x)?,
                            Param::Texture(_) => d.set_item("opacity", param(py, opacity)?)?,
                        }
                        d.set_item("bsdf", *nested)?;
                    }
                    Bsdf::NormalMap { texture, nested } => {
                        d.set_item("type", "normalmap")?;
                        d.set_item("normalmap", format!("texture[{texture}]"))?;
                        d.set_item("bsdf", *nested)?;
                    }
                }
                Ok(d)
            })
            .collect()
    }
    /// The first top-level `<integrator>`: {"type", "max_depth", "file", "line"}, or None when the file has
    /// none (Mitsuba then renders with `path`, max_depth -1). `max_depth` is Mitsuba's path depth: the
    /// property of a path-tracing plugin (default -1 = unbounded), 2 for `direct`, None for plugins
    /// without one (e.g. `aov`).
    #[getter]
    fn integrator<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(i) = &self.inner.integrator else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("type", &i.plugin)?;
        d.set_item("max_depth", i.max_depth)?;
        d.set_item("file", &i.loc.file)?;
        d.set_item("line", i.loc.line)?;
        Ok(Some(d))
    }
    /// Camera: origin, forward, up, left (world), fov_x / fov_y (degrees), near_clip, width, height,
    /// principal_point_offset (x, y) in film units.
    #[getter]
    fn camera<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.inner.camera;
        let m = c.world_from_camera;
        let d = PyDict::new(py);
        d.set_item("origin", rgb(c.origin()))?;
        d.set_item("left", rgb(m.x_axis.truncate()))?;
        d.set_item("up", rgb(m.y_axis.truncate()))?;
        d.set_item("forward", rgb(m.z_axis.truncate()))?;
        d.set_item("fov_x", c.fov_x.to_degrees())?;
        d.set_item("fov_y", c.fov_y().to_degrees())?;
        d.set_item("near_clip", c.near_clip)?;
        d.set_item("far_clip", c.far_clip)?;
        d.set_item("width", c.width)?;
        d.set_item("height", c.height)?;
        d.set_item("principal_point_offset", (c.principal_point_offset.x, c.principal_point_offset.y))?;
        Ok(d)
    }
    /// Scene bounds ((min xyz), (max xyz)).
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let (lo, hi) = self.inner.bounds();
        (lo.to_array(), hi.to_array())
    }
    /// The deep framebuffer at pixel centres as numpy arrays: position, normal, geo_normal, wi, albedo
    /// (H, W, 3) float32, uv (H, W, 2) float32, shape_index and prim_index (H, W) int32 (-1 = background).
    /// Computed on `device` (GPU raster or CPU ray casting) by the first call that needs it, then cached.
    #[pyo3(signature = (device=None))]
    fn gbuffer<'py>(&self, py: Python<'py>, device: Option<Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let device = match device {
            None => Device::Auto,
            Some(d) => match d.extract::<String>() {
                Ok(name) => Device::parse(&name)?,
                Err(_) => {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "gbuffer: argument device must be 'auto', 'gpu' or 'cpu' (a str), got {}",
                        d.repr().map(|r| r.to_string()).unwrap_or_default()
                    )))
                }
            },
        };
        let v = self.view_samples(py, device)?;
        let (h, w) = (v.height as usize, v.width as usize);
        // The camera's own hits (samples 0 .. H * W; delta-chain samples follow them).
        let m = h * w;
        let d = PyDict::new(py);
        for (name, data) in
            [("position", &v.position), ("normal", &v.normal), ("geo_normal", &v.geo_normal), ("wi", &v.wi), ("albedo", &v.albedo)]
        {
            d.set_item(name, vec3_array(py, &data[..m])?.reshape(vec![h, w, 3])?)?;
        }
        let uv: Vec<f32> = v.uv[..m].iter().flat_map(|p| p.to_array()).collect();
        d.set_item("uv", array(py, uv, &[h, w, 2])?)?;
        d.set_item("shape_index", array(py, v.shape_index[..m].to_vec(), &[h, w])?)?;
        d.set_item("prim_index", array(py, v.prim_index[..m].to_vec(), &[h, w])?)?;
        Ok(d)
    }
    /// Mesh `index` as numpy arrays: positions, normals (V, 3), uvs (V, 2), indices (T, 3) uint32 (world space).
    fn mesh<'py>(&self, py: Python<'py>, index: i64) -> PyResult<Bound<'py, PyDict>> {
        let m = usize::try_from(index).ok().and_then(|i| self.inner.meshes.get(i)).ok_or_else(|| {
            crate::error::Error::invalid(format!("mesh index {index} out of range (scene has {})", self.inner.meshes.len()))
        })?;
        let d = PyDict::new(py);
        d.set_item("positions", vec3_array(py, &m.positions)?)?;
        d.set_item("normals", vec3_array(py, &m.normals)?)?;
        let uv: Vec<f32> = m.uvs.iter().flat_map(|p| p.to_array()).collect();
        d.set_item("uvs", array(py, uv, &[m.uvs.len(), 2])?)?;
        let idx: Vec<u32> = m.indices.iter().flatten().copied().collect();
        d.set_item("indices", array(py, idx, &[m.indices.len(), 3])?)?;
        Ok(d)
    }
    fn __repr__(&self) -> String {
        let s = &self.inner;
        format!(
            "Scene('{}', {}x{}, {} shapes, {} triangles, {} emitters)",
            s.path.display(),
            s.camera.width,
            s.camera.height,
            s.meshes.len(),
            s.meshes.iter().map(|m| m.indices.len()).sum::<usize>(),
            s.emitters.len()
        )
    }
}

use numpy::PyArrayMethods;

/// Load a Mitsuba 3 XML scene. `params` substitute `$name` defaults; `size` = (width, height) overrides the film;
/// `media`: "mitsuba" (media as the scene's integrator uses them) or "error" (refuse `<medium>`s).
#[pyfunction]
#[pyo3(signature = (path, params, size=None, media="mitsuba"))]
pub fn load_scene(py: Python<'_>, path: PathBuf, params: Vec<(String, String)>, size: Option<(u32, u32)>, media: &str) -> PyResult<Scene> {
    let media = match media {
        "mitsuba" => scene::MediaPolicy::Follow,
        "error" => scene::MediaPolicy::Error,
        other => return Err(pyo3::exceptions::PyValueError::new_err(format!("media must be \"mitsuba\" or \"error\", got {other:?}"))),
    };
    let opts = LoadOptions { params, size, media };
    let (s, warnings) = py.detach(move || scene::xml::load_scene_with_warnings(&path, &opts))?;
    for w in &warnings {
        // Accepted input that Mitsuba only warns about (e.g. a shape whose triangles all have zero area).
        let msg = std::ffi::CString::new(w.replace('\0', " ")).unwrap_or_default();
        // stacklevel 2: reported at the caller of `manylights.load_scene`.
        PyErr::warn(py, &py.get_type::<pyo3::exceptions::PyUserWarning>(), &msg, 2)?;
    }
    Ok(Scene {
        inner: Arc::new(s),
        view: Mutex::new(Vec::new()),
        tracer: std::sync::OnceLock::new(),
        probe_env: [std::sync::OnceLock::new(), std::sync::OnceLock::new()],
        anisotropic_frame: std::sync::OnceLock::new(),
    })
}

fn info_dict<'py>(py: Python<'py>, i: &DeviceInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("kind", i.kind)?;
    d.set_item("name", &i.name)?;
    d.set_item("backend", &i.backend)?;
    d.set_item("is_software", i.is_software)?;
    d.set_item("threads", i.threads)?;
    d.set_item("shadow_rays", i.shadow_rays)?;
    Ok(d)
}

/// A `DeviceInfo` as a dict: kind ("cpu" / "gpu"), name, backend, is_software, threads, shadow_rays.
pub fn device_dict<'py>(py: Python<'py>, i: &DeviceInfo) -> PyResult<Bound<'py, PyDict>> {
    info_dict(py, i)
}

/// The device `device` resolves to (`"auto"`: `MANYLIGHTS_DEVICE`, else a hardware GPU that meets every
/// pass's needs, else the CPU) as a dict (kind, name, backend, is_software, threads, and "reason": why
/// "auto" took the CPU, else None), plus "gpu": the adapter wgpu would use (name, backend, device_type,
/// driver, driver_info, is_software, only_software, adapters: every adapter found, unmet: the passes'
/// needs its limits do not meet, lost) or None when there is none. With `scene`: the device a light
/// matrix of that scene takes (`Device::choose_for_scene`: "auto" takes the CPU for a scene the GPU backend
/// does not support, with the reason; "gpu" is a ValueError for one).
#[pyfunction]
#[pyo3(signature = (device="auto", scene=None))]
pub fn device_info<'py>(py: Python<'py>, device: &str, scene: Option<&Scene>) -> PyResult<Bound<'py, PyDict>> {
    let dev = Device::parse(device)?;
    let s = scene.map(|s| s.inner.clone());
    let (chosen, reason) = py.detach(move || match s {
        Some(s) => dev.choose_for_scene(&s),
        None => dev.choose_explained(),
    })?;
    let info = match &chosen {
        Chosen::Gpu(ctx) => DeviceInfo::gpu(ctx),
        Chosen::Cpu => DeviceInfo::cpu(),
    };
    let d = info_dict(py, &info)?;
    d.set_item("reason", reason)?;
    let ctx = match chosen {
        Chosen::Gpu(ctx) => Some(ctx),
        Chosen::Cpu => py.detach(GpuContext::shared).ok(),
    };
    match ctx {
        Some(ctx) => {
            let s = &ctx.summary;
            let g = PyDict::new(py);
            g.set_item("name", &s.name)?;
            g.set_item("backend", &s.backend)?;
            g.set_item("device_type", &s.device_type)?;
            g.set_item("driver", &s.driver)?;
            g.set_item("driver_info", &s.driver_info)?;
            g.set_item("is_software", s.is_software)?;
            g.set_item("only_software", s.only_software)?;
            g.set_item("adapters", &s.adapters)?;
            g.set_item("unmet", ctx.unmet.clone())?;
            g.set_item("lost", ctx.is_lost())?;
            d.set_item("gpu", g)?;
        }
        None => d.set_item("gpu", py.None())?,
    }
    Ok(d)
}

/// Test hook: marks the shared GPU device lost, as a driver reset would; the next GPU call creates a new
/// device (reading `MANYLIGHTS_GPU_LIMITS` and `MANYLIGHTS_ADAPTER` again). Returns whether a device
/// existed. Light matrices made on the old device keep working until it is really gone.
#[pyfunction]
pub fn _gpu_simulate_loss(py: Python<'_>) -> bool {
    py.detach(|| match GpuContext::shared() {
        Ok(ctx) => {
            ctx.mark_lost();
            true
        }
        Err(_) => false,
    })
}

/// The GPU memory a light matrix of `width` x `height` view samples and `lights` lights over
/// `triangles` triangles would take on the device (`matrix::gpu::estimate_gpu_bytes`, bytes per part),
/// with the default column options and `shadow_map_size`. Pure arithmetic: no device is made.
#[pyfunction]
#[pyo3(signature = (width, height, lights, triangles, shadow_map_size=512))]
pub fn _gpu_memory_estimate<'py>(
    py: Python<'py>,
    width: u32,
    height: u32,
    lights: u64,
    triangles: u64,
    shadow_map_size: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = crate::matrix::ColumnOptions { shadow_resolution: shadow_map_size, ..Default::default() };
    let parts = crate::matrix::gpu::estimate_gpu_bytes(width as u64 * height as u64, lights, triangles, &opts);
    let d = PyDict::new(py);
    for (name, bytes) in parts.parts() {
        d.set_item(name, bytes)?;
    }
    d.set_item("total", parts.total())?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_gpu_simulate_loss, m)?)?;
    m.add_function(wrap_pyfunction!(_gpu_memory_estimate, m)?)?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(device_info, m)?)?;
    Ok(())
}
