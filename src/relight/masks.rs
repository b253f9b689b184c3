//! Direct-to-indirect relighting in a scene with masked surfaces (Mitsuba's `mask`, semantics and
//! measurements in `crate::raytrace::mask`; Hašan, Pellacini, Bala, SIGGRAPH 2006, extended to them).
//!
//! The view samples are traced to Mitsuba's depth, max_depth = bounces + 2 (`chain_options`), so a camera ray
//! splits at a mask into the masked surface (throughput a) and the surface behind (1 - a), and every view
//! sample gets a row (`row_samples`), summed into its pixel with its throughput by `relight`. A segment from
//! view sample i to a gather sample crosses masked surfaces with (1 - a) each (`transfer::geometry_patch`'s
//! transmittance), at most b - 1 of them for the sample's `ViewSamples::mask_budget` b: the gather sample is
//! one more bounce and must still sample the light (Mitsuba's depth: i at k, the gather sample at k + 1 + j
//! after j null events, its light sampled while k + 2 + j < max_depth); a sample with b = 0 gets no row. A
//! gather sample on a mask of opacity a reflects a times its nested BSDF (`Transfer::opacity`, applied to its
//! irradiance and to what the gather-to-gather bounce brings it; photons of multiple bounces are stored on it
//! only when they meet the nested BSDF, so theirs carry a already). The direct light's shadow rays toward a
//! gather sample cross at most `gather_mask_budget` masks (toward area points and environment strata only, as
//! everywhere: `lights::animated::irradiance`), a gather-to-gather segment one fewer. Each segment's budget
//! is counted as if the path's other segments crossed no mask: exact for paths that cross masks on one
//! segment, and whenever a budget is not the binding limit. `relight::gpu` relights masked scenes too.
//!
//! Symbols: a opacity, b a view sample's mask budget, j masks crossed, k a view sample's depth.
use crate::error::Result;
use crate::lights::gather::GatherCloud;
use crate::scene::Scene;
use crate::view::ViewSamples;

/// The view samples that get rows of F_d (and F_g): the camera hits, and in a scene with masked surfaces
/// every view sample (module docs: the G-buffer follows camera rays through masks).
pub fn row_samples(view: &ViewSamples, masked: bool) -> usize {
    if masked {
        view.len()
    } else {
        view.num_pixels()
    }
}

/// How the view samples of a relighting precomputation are made for `scene` with `bounces` bounces: in a
/// scene with masked surfaces Mitsuba's depth (max_depth = bounces + 2, which bounds the masks a path may
/// cross), otherwise the default delta chains.
///
/// Errors: none in practice (bounces + 2 >= 3 is a valid max_depth).
pub fn chain_options(scene: &Scene, bounces: u32) -> Result<crate::view::chains::ChainOptions> {
    if crate::raytrace::mask::scene_has_masks(scene) {
        crate::view::chains::ChainOptions::with_max_depth(bounces as i64 + 2)
    } else {
        Ok(crate::view::chains::ChainOptions::default())
    }
}

/// The masks a segment from view sample i to a gather sample may cross (module docs): None without
/// masks; Some(b - 1) for the sample's `ViewSamples::mask_budget` b (the gather sample it reaches must
/// still sample the light), and None as well for a sample whose budget is 0 (`receives_indirect` is
/// false for it).
pub(crate) fn view_mask_budget(view: &ViewSamples, masked: bool, i: usize) -> Option<u32> {
    if !masked {
        return None;
    }
    view.mask_budget.get(i).map(|&b| b.saturating_sub(1))
}

/// Whether view sample i of a masked scene may receive light bounced once (its depth leaves room for a
/// gather sample that samples the light: `ViewSamples::mask_budget` >= 1); always true without masks.
pub(crate) fn receives_indirect(view: &ViewSamples, masked: bool, i: usize) -> bool {
    !masked || view.mask_budget.get(i).is_none_or(|&b| b >= 1)
}

/// The masks the direct light's shadow ray toward a gather sample may cross with `bounces` bounces
/// (Mitsuba's max_depth = bounces + 2: `lights::animated::gather_mask_budget`).
pub fn gather_mask_budget(bounces: u32) -> u32 {
    crate::lights::animated::gather_mask_budget(bounces + 2)
}

/// Each gather sample's opacity (a masked surface reflects a times its nested BSDF: Mitsuba's `mask`
/// eval), 1 elsewhere; empty when the scene has no masks.
pub fn gather_opacity(masks: &crate::raytrace::mask::Masks, cloud: &GatherCloud) -> Vec<f32> {
    if !masks.any() {
        return Vec::new();
    }
    (0..cloud.len()).map(|g| masks.opacity(cloud.shape[g] as usize, cloud.uv[g]).unwrap_or(1.0)).collect()
}
