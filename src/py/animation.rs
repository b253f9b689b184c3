//! Bindings of animations (`scene::animation`), pixel mappings (`matrix::mapping`, `gpu::mapping`) and
//! deep-framebuffer anti-aliasing (`image::antialias`). The Python API is `manylights.animation`.
//!
//! Index arrays cross the boundary as int64 with -1 for "no source" (`mapping::NO_SOURCE` inside).
use super::scene::Scene;
use super::util::array;
use crate::error::Error;
use crate::gpu::mapping::apply_chain_gpu;
use crate::matrix::backend::{Chosen, Device};
use crate::matrix::mapping::{PixelMapping, NO_SOURCE};
use crate::view::features::DeepMetric;
use crate::view::ViewSamples;
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::{Arc, Mutex, Weak};

fn device(name: &str) -> PyResult<Device> {
    Ok(Device::parse(name)?)
}

/// Check that `frames` share frame 0's topology (film size, shapes, triangles, emitters).
#[pyfunction]
pub fn check_animation_topology(frames: Vec<PyRef<'_, Scene>>) -> PyResult<()> {
    let scenes: Vec<&crate::scene::Scene> = frames.iter().map(|s| s.inner.as_ref()).collect();
    crate::scene::animation::check_topology(&scenes)?;
    Ok(())
}

/// "16x32" for a shape (16, 32).
fn dims(shape: &[usize]) -> String {
    shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join("x")
}

/// A mapping as an (H, W) int64 array, -1 for no source.
fn mapping_array<'py>(py: Python<'py>, m: &PixelMapping) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let data: Vec<i64> = m.source.iter().map(|&s| if s == NO_SOURCE { -1 } else { s as i64 }).collect();
    array(py, data, &[m.height as usize, m.width as usize])
}

/// An (H, W) integer array (-1 = no source) as a mapping, every index checked.
fn mapping_from(a: &PyReadonlyArrayDyn<'_, i64>, what: &str) -> PyResult<PixelMapping> {
    let shape = a.shape();
    if shape.len() != 2 || shape[0] == 0 || shape[1] == 0 {
        return Err(Error::invalid(format!("{what} must be an (H, W) integer array, got shape {shape:?}")).into());
    }
    let (h, w) = (shape[0], shape[1]);
    let m = w * h;
    let view = a.as_array();
    let mut source = Vec::with_capacity(m);
    for (i, &v) in view.iter().enumerate() {
        if v == -1 {
            source.push(NO_SOURCE);
        } else if v < 0 || v as u64 >= m as u64 {
            return Err(
                Error::invalid(format!("{what}[{}, {}] = {v} is not a pixel index in [0, {m}) or -1 (no source)", i / w, i % w)).into()
            );
        } else {
            source.push(v as u32);
        }
    }
    Ok(PixelMapping { width: w as u32, height: h as u32, source })
}

/// The nearest-neighbour pixel mapping from frame `src` to frame `dst` in the 9-D deep framebuffer,
/// with positions scaled by K / the diagonal of `reference` (the animation's frame 0): (H, W) int64,
/// per pixel of `dst` the pixel `y * W + x` of `src`, -1 where `dst` sees no surface.
#[pyfunction]
#[pyo3(signature = (src, dst, reference, device="auto"))]
pub fn pixel_mapping<'py>(
    py: Python<'py>,
    src: PyRef<'py, Scene>,
    dst: PyRef<'py, Scene>,
    reference: PyRef<'py, Scene>,
    device: &str,
) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let dev = self::device(device)?;
    let a = src.view_samples(py, dev)?;
    let b = dst.view_samples(py, dev)?;
    let metric = DeepMetric::for_diagonal(reference.inner.diagonal());
    let m = super::signals::detach(py, move || PixelMapping::nearest(&metric.features(&a), &metric.features(&b)))?;
    mapping_array(py, &m)
}

/// The chain `mappings[0]`, then `mappings[1]`, ... as one mapping (H, W) int64.
#[pyfunction]
pub fn compose_mappings<'py>(py: Python<'py>, mappings: Vec<PyReadonlyArrayDyn<'py, i64>>) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let first = mappings.first().ok_or_else(|| Error::invalid("compose_mappings needs at least one mapping, got 0"))?;
    if let Some((k, m)) = mappings.iter().enumerate().find(|(_, m)| m.shape() != first.shape()) {
        return Err(
            Error::invalid(format!("mappings[{k}] is {} but mappings[0] is {} (H x W)", dims(m.shape()), dims(first.shape()))).into()
        );
    }
    let maps = mappings.iter().enumerate().map(|(k, a)| mapping_from(a, &format!("mappings[{k}]"))).collect::<PyResult<Vec<_>>>()?;
    let first = &maps[0];
    let refs: Vec<&PixelMapping> = maps.iter().collect();
    let out = PixelMapping::chain(first.width, first.height, &refs)?;
    mapping_array(py, &out)
}

/// Apply the chain `mappings` (applied in order) to `images` (K, H, W, 3) float32 on `device`
/// ("cpu": rayon gather of the composed mapping; "gpu": one WGSL gather per mapping on GPU-resident
/// images, read back once). Returns (K, H, W, 3) float32.
#[pyfunction]
#[pyo3(signature = (images, mappings, device="auto"))]
pub fn apply_mapping<'py>(
    py: Python<'py>,
    images: PyReadonlyArrayDyn<'py, f32>,
    mappings: Vec<PyReadonlyArrayDyn<'py, i64>>,
    device: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let first = mappings.first().ok_or_else(|| Error::invalid("apply_mapping needs a mapping, got an empty chain"))?;
    if let Some((k, m)) = mappings.iter().enumerate().find(|(_, m)| m.shape() != first.shape()) {
        return Err(Error::invalid(format!("mapping[{k}] is {} but mapping[0] is {} (H x W)", dims(m.shape()), dims(first.shape()))).into());
    }
    let maps = mappings
        .iter()
        .enumerate()
        .map(|(k, a)| mapping_from(a, if mappings.len() == 1 { "mapping".to_string() } else { format!("mapping[{k}]") }.as_str()))
        .collect::<PyResult<Vec<_>>>()?;
    let first = &maps[0];
    let shape = images.shape().to_vec();
    if shape.len() != 4 || shape[3] != 3 || (shape[1], shape[2]) != (first.height as usize, first.width as usize) {
        return Err(Error::invalid(format!(
            "images must have shape (K, {}, {}, 3) to match the mapping, got {shape:?}",
            first.height, first.width
        ))
        .into());
    }
    let data: Vec<f32> = images.as_array().iter().copied().collect();
    let chosen = {
        let dev = self::device(device)?;
        py.detach(move || dev.choose())?
    };
    let out = super::signals::detach(py, move || match chosen {
        Chosen::Cpu => {
            let refs: Vec<&PixelMapping> = maps.iter().collect();
            let m = PixelMapping::chain(maps[0].width, maps[0].height, &refs)?;
            m.apply(&data, 3)
        }
        Chosen::Gpu(ctx) => {
            let refs: Vec<&PixelMapping> = maps.iter().collect();
            apply_chain_gpu(&ctx, &refs, &data)
        }
    })?;
    array(py, out, &shape)
}

/// High-resolution view samples per (scene, factor), held weakly so that they go with their scene.
type HiresCache = Mutex<Vec<(Weak<crate::scene::Scene>, u32, Arc<ViewSamples>)>>;
static HIRES: HiresCache = Mutex::new(Vec::new());
/// Most cached high-resolution deep framebuffers (an animation of 40 frames fits).
const HIRES_CACHE: usize = 64;

fn hires_view(py: Python<'_>, scene: &Scene, factor: u32, chosen: &Chosen) -> PyResult<Arc<ViewSamples>> {
    {
        let mut cache = HIRES.lock().unwrap_or_else(|e| e.into_inner());
        cache.retain(|(w, _, _)| w.strong_count() > 0);
        if let Some((_, _, v)) = cache.iter().find(|(w, f, _)| *f == factor && std::ptr::eq(w.as_ptr(), Arc::as_ptr(&scene.inner))) {
            return Ok(v.clone());
        }
    }
    let hi = Arc::new(crate::image::antialias::scaled_scene(&scene.inner, factor)?);
    let chains = crate::view::chains::ChainOptions::default();
    let v = match chosen {
        Chosen::Gpu(ctx) => {
            let ctx = ctx.clone();
            super::signals::detach(py, move || crate::gpu::gbuffer::render_view_samples_with(&ctx, &hi, &chains))?
        }
        Chosen::Cpu => {
            // The high-resolution scene has the same geometry: the scene's own BVH serves it.
            let tracer = scene.tracer(py)?;
            super::signals::detach(py, move || -> crate::error::Result<ViewSamples> {
                let ids = crate::view::resolve::cast_visibility_traced(&hi, &tracer)?;
                crate::view::resolve::resolve_view_samples_with(&hi, &ids, &chains)
            })?
        }
    };
    let v = Arc::new(v);
    let mut cache = HIRES.lock().unwrap_or_else(|e| e.into_inner());
    if cache.len() >= HIRES_CACHE {
        cache.remove(0);
    }
    cache.push((Arc::downgrade(&scene.inner), factor, v.clone()));
    Ok(v)
}

/// Anti-alias `image` (H, W, C) float32 rendered from `scene` with a deep framebuffer at `factor` x the
/// resolution (`image::antialias`). Returns (H, W, C) float32.
#[pyfunction]
#[pyo3(signature = (image, scene, factor=3, device="auto"))]
pub fn antialias<'py>(
    py: Python<'py>,
    image: PyReadonlyArrayDyn<'py, f32>,
    scene: PyRef<'py, Scene>,
    factor: u32,
    device: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let shape = image.shape().to_vec();
    let (w, h) = (scene.inner.camera.width as usize, scene.inner.camera.height as usize);
    if shape.len() != 3 || (shape[0], shape[1]) != (h, w) || shape[2] == 0 {
        return Err(Error::invalid(format!("image must have shape ({h}, {w}, C) to match the scene's {w}x{h} film, got {shape:?}")).into());
    }
    if !(1..=crate::image::antialias::MAX_FACTOR).contains(&factor) {
        return Err(Error::invalid(format!("factor must be in [1, {}], got {factor}", crate::image::antialias::MAX_FACTOR)).into());
    }
    let data: Vec<f32> = image.as_array().iter().copied().collect();
    let dev = self::device(device)?;
    let chosen = py.detach(move || dev.choose())?;
    let low = scene.view_samples_on(py, crate::view::chains::ChainOptions::default(), &chosen)?;
    let high = hires_view(py, &scene, factor, &chosen)?;
    let metric = DeepMetric::for_diagonal(scene.inner.diagonal());
    let channels = shape[2];
    let out = super::signals::detach(py, move || {
        crate::image::antialias::antialias(&data, channels, &metric.features(&low), &metric.features(&high), factor)
    })?;
    array(py, out, &shape)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(check_animation_topology, m)?)?;
    m.add_function(wrap_pyfunction!(pixel_mapping, m)?)?;
    m.add_function(wrap_pyfunction!(compose_mappings, m)?)?;
    m.add_function(wrap_pyfunction!(apply_mapping, m)?)?;
    m.add_function(wrap_pyfunction!(antialias, m)?)?;
    Ok(())
}
