//! The pilot view: surface view samples at the pixel centres of a small film with the camera's aspect
//! (delta chains resolved, throughput applied), where importance-driven light generation measures what a
//! light contributes to the image before the lights are made: importance-sampled VPLs (`vpl_importance`,
//! Georgiev and Slusallek 2010: the camera points, "importons") and visibility-allocated environment strata
//! (`env_visibility`).
//!
//! A light's pilot contribution is the luminance of `cpu::shade` -- the CPU backend's element A(i, j):
//! exact visibility (one shadow ray), both BSDFs, the light's own geometry term -- summed over the pilot's
//! surface samples i.
use crate::cpu::{shade, ShadingPoint};
use crate::error::Result;
use crate::lights::LightSet;
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use crate::view::ViewSamples;

/// Surface view samples of the pilot film, prepared for shading.
pub(crate) struct PilotView {
    view: ViewSamples,
    points: Vec<(usize, ShadingPoint)>,
}

impl PilotView {
    /// The camera of `scene` at about `n` pixels of its aspect (module docs), traced with `rt`.
    pub(crate) fn new(scene: &Scene, rt: &RayTracer, n: usize) -> Result<PilotView> {
        let cam = &scene.camera;
        let aspect = cam.width.max(1) as f64 / cam.height.max(1) as f64;
        let w = ((n as f64 * aspect).sqrt().round() as u32).clamp(1, n as u32);
        let h = ((n as f64 / w as f64).round() as u32).max(1);
        let mut cam = cam.clone();
        (cam.width, cam.height) = (w, h);
        let ids = crate::view::resolve::cast_visibility_traced_for(scene, &cam, rt)?;
        let chains = crate::view::chains::ChainOptions::default();
        let view = crate::view::resolve::resolve_view_samples_for(scene, &cam, &ids, &chains)?;
        let points = (0..view.len()).map(|i| (i, ShadingPoint::new(&view, i))).filter(|(_, sp)| sp.surface).collect();
        Ok(PilotView { view, points })
    }

    /// Surface samples of the pilot view.
    pub(crate) fn len(&self) -> usize {
        self.points.len()
    }

    /// Light j of `set`'s contribution to the pilot view: the luminance of its elements summed over the
    /// surface samples (module docs).
    pub(crate) fn contribution(&self, rt: &RayTracer, set: &LightSet, j: usize) -> f64 {
        self.points
            .iter()
            .map(|(i, sp)| {
                let c = shade(rt, &self.view, set, sp, *i, j).value;
                (c.element_sum() / 3.0) as f64
            })
            .sum()
    }
}
