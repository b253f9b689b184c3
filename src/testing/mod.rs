//! Test-only helpers shared by the unit tests of every module: where the test scenes are, and the
//! scenes the tests build: `scenes` (hand-made meshes, cameras and CPU-cast view samples),
//! `light_scenes` (closed and open boxes for light generation and the light matrix), `view_scenes`
//! (G-buffer and view-sample scenes) and `raytrace_scenes` (geometry of the cbox and bunny test scenes).
use std::path::{Path, PathBuf};

/// A test scene's file by its path below the scene folders (`"cbox/scene.xml"`, `"bunny/meshes/bunny.ply"`):
/// in the bundled `scenes/` or in the test-only `tests/data/scenes/` (matpreview, bunny), both in the repository.
pub fn scene_file(rel: &str) -> PathBuf {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let folder = rel.split('/').next().unwrap_or(rel);
    [repo.join("scenes"), repo.join("tests/data/scenes")]
        .into_iter()
        .find(|root| root.join(folder).is_dir())
        .map(|root| root.join(rel))
        .unwrap_or_else(|| panic!("test scene {rel:?}: no folder {folder:?} in scenes/ or tests/data/scenes/"))
}

/// The shared GPU context for the tests that run GPU passes (software adapters are fine). Panics, saying
/// what to install, where no adapter exists or the one chosen cannot run every pass (an OpenGL adapter:
/// `GpuContext::unmet`'s `GL_UNVALIDATED`, or limits below the passes' needs), instead of running the
/// passes there (on Mesa's llvmpipe over EGL they gave wrong answers, then an abort).
pub fn gpu_context() -> std::sync::Arc<crate::gpu::GpuContext> {
    const INSTALL: &str = "the GPU tests need an adapter that runs every pass (Vulkan; `make system` installs Mesa's lavapipe)";
    let ctx = crate::gpu::GpuContext::shared().unwrap_or_else(|e| panic!("{INSTALL}: {e}"));
    if let Err(e) = ctx.check_needs() {
        panic!("{INSTALL}: {e}");
    }
    ctx
}

pub mod light_scenes;
pub mod raytrace_scenes;
pub mod scenes;
pub mod view_scenes;

/// A new, empty scratch directory for one test file: `<temp>/manylights-<tag>-<pid>-<n>` with `n` unique
/// per call. Tests run in parallel threads of one process, so a directory per process shared by file
/// name lets one test truncate a file another is reading (a CI failure of the EXR size-policy test);
/// one directory per call cannot collide.
pub fn scratch_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("manylights-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("cannot create a test scratch directory");
    dir
}

/// Monte Carlo mean and standard error (per channel) of `m` sample weights; `None` is a zero weight.
pub fn mean_and_std_err(m: usize, mut weight: impl FnMut() -> Option<glam::DVec3>) -> (glam::DVec3, glam::DVec3) {
    let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for _ in 0..m {
        if let Some(w) = weight() {
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / m as f64;
    let err = ((sum2 / m as f64 - mean * mean) / m as f64).max(glam::DVec3::ZERO).powf(0.5);
    (mean, err)
}

/// Up to `per_kind` lights of each kind of `lights` (point, spot, directional, oriented point, VPL),
/// spread over each kind's index range; panics when a kind is missing (the test scenes must have all).
pub fn lights_of_every_kind(lights: &crate::lights::LightSet, per_kind: usize) -> Vec<usize> {
    use crate::lights::LightKind;
    let mut js = Vec::new();
    for kind in [LightKind::Point, LightKind::Spot, LightKind::Directional, LightKind::OrientedPoint, LightKind::Vpl] {
        let of_kind: Vec<usize> = (0..lights.len()).filter(|&j| lights.kind[j] == kind).collect();
        assert!(!of_kind.is_empty(), "the test scene must give {kind:?} lights");
        js.extend(of_kind.iter().step_by((of_kind.len() / per_kind).max(1)).take(per_kind));
    }
    js
}

/// A scene loaded at `size` x `size`, its BVH and its view samples at pixel centres (exact camera rays,
/// delta chains resolved): what the relighting tests precompute transfers on.
pub fn scene_view_tracer(path: &Path, size: u32) -> (crate::scene::Scene, crate::view::ViewSamples, crate::raytrace::RayTracer) {
    let opts = crate::scene::LoadOptions { size: Some((size, size)), ..Default::default() };
    let scene = crate::scene::load_scene(path, &opts).unwrap();
    let tracer = crate::raytrace::RayTracer::new(&scene).unwrap();
    let ids = crate::view::resolve::cast_visibility_traced(&scene, &tracer).unwrap();
    let view = crate::view::resolve::resolve_view_samples_with(&scene, &ids, &crate::view::chains::ChainOptions::default()).unwrap();
    (scene, view, tracer)
}

/// The same light matrix on both backends with exact rays: cbox-lights (point, spot, directional,
/// oriented points, VPLs) at res x res, 24 area + 24 environment + 300 indirect lights (seed 5), and the
/// CPU backend's ray tracer.
pub struct BackendPair {
    pub cpu: crate::matrix::LightMatrix,
    pub gpu: crate::matrix::LightMatrix,
    pub tracer: std::sync::Arc<crate::raytrace::RayTracer>,
}

pub fn backend_pair(res: u32) -> BackendPair {
    use crate::lights::{generate_lights, GenerateOptions};
    use crate::matrix::backend::Chosen;
    use crate::matrix::{ColumnOptions, LightMatrix, Visibility};
    use crate::scene::{load_scene, LoadOptions};
    use std::sync::Arc;
    let xml = scene_file("cbox-lights/scene.xml");
    let opts = LoadOptions { params: vec![("res".into(), res.to_string())], size: None, ..Default::default() };
    let scene = Arc::new(load_scene(&xml, &opts).unwrap());
    let gen = GenerateOptions { area: 24, environment: 24, indirect: 300, seed: 5, ..Default::default() };
    let lights = Arc::new(generate_lights(&scene, &gen).unwrap());
    let ctx = crate::testing::gpu_context();
    let view = Arc::new(crate::gpu::gbuffer::render_view_samples(&ctx, &scene).unwrap());
    let tracer = Arc::new(crate::raytrace::RayTracer::new(&scene).unwrap());
    let copts = ColumnOptions { visibility: Visibility::RayTraced, shadow_resolution: 256, ..Default::default() };
    let gpu = LightMatrix::new(ctx, scene.clone(), view.clone(), lights.clone(), copts.clone()).unwrap();
    let cpu = LightMatrix::with_device(&Chosen::Cpu, scene, view, lights, copts, Some(tracer.clone())).unwrap();
    BackendPair { cpu, gpu, tracer }
}
