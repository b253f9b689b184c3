//! The glossy final-gather matrix F_g of direct-to-indirect transfer (Hašan, Pellacini, Bala,
//! "Direct-to-Indirect Transfer for Cinematic Relighting", SIGGRAPH 2006, Sec. 3.2, 3.3 Eq. 6 and 8,
//! 4.3 "The glossy final gather matrix").
//!
//! Glossy view samples: the camera hits (pixels) whose BSDF has a glossy lobe -- a non-delta lobe that
//! is not Lambertian: `roughplastic` (its specular microfacet lobe), `roughconductor` (all of it), and a
//! `blendbsdf` with either among its two BSDFs (the glossy lobes weighted by the blend). Not glossy:
//! `diffuse`, smooth `plastic`, `conductor` and `dielectric` (delta lobes: no gather sample reaches
//! them), and `principled` (its specular lobes share a Fresnel term with the diffuse ones and are not
//! separated here; principled view samples keep their diffuse part through F_d only). Delta-chain samples
//! (seen through mirrors or glass) get no glossy indirect light either, as they get no diffuse, except in
//! a scene with masked surfaces, where every view sample is a candidate and V is the transmittance through
//! the masks (`masks` module docs).
//!
//! The camera is fixed, so each glossy view sample's BSDF toward its viewer is baked into its row. With
//! wi the direction to the viewer, wo = (q_g - p) / d toward gather sample g (emitting at q_g), and
//! f_g(wi, wo) the BRDF of the glossy lobes only (`glossy_eval`, the project's Mitsuba-exact BSDF code,
//! `shading::bsdf::eval`, on a copy of the record whose diffuse reflectance is 0; RGB), the row is
//!
//!   F_g(i, g) = A_g * min(G, clamp) * V(i, g) * mean_rgb(f_g(wi, wo)),
//!
//! G, clamp and V exactly as for F_d (`transfer::geometry_patch` with the options' `near_field`), and the pixel's glossy coefficient is the
//! colour of its lobe at the peak, k_g(i) = f_g(wi, wr) / mean_rgb(f_g(wi, wr)) (wr = wi mirrored about
//! the shading normal; (1, 1, 1) where that is 0), so that the glossy indirect radiance is
//!
//!   L_g(i) = k_g(i) * sum_g F_g(i, g) B_g    (Eq. 6; B = (M + I) g_d the gather samples' radiance).
//!
//! k_g F_g equals the glossy BSDF exactly when the lobe's colour does not vary with wo (roughplastic:
//! scalar dielectric Fresnel times specular_reflectance; a conductor whose eta and k are grey); a
//! coloured conductor Fresnel is taken at the lobe's peak.
//!
//! Hierarchical gather with the paper's lobe-dependent subdivision (4.3: "force more subdivision around
//! the peak of the lobe"): the quad-tree is descended as for F_d (clusters behind the tangent plane
//! culled), but a cluster is subdivided while s^2 / d^2 * max(1, pi f) > threshold, where f is the mean
//! glossy BRDF toward the cluster's box centre, or at the lobe's peak wr when wr points into the
//! cluster's cone (angle to the centre below atan(s / 2d)). The BRDF is evaluated before a shadow ray is
//! cast; a link whose BRDF is 0 casts none. Rows are laid out as the gather image, projected to Haar
//! wavelets and culled to `coefficients` (final_gather_coefficients) like F_d.
use super::haar::{self, SparseRow};
use super::hierarchy::ClusterHierarchy;
use super::masks::{receives_indirect, view_mask_budget};
use super::transfer::{behind_tangent_plane, geometry_patch, TransferOptions};
use crate::cpu::ShadingPoint;
use crate::error::Result;
use crate::lights::gather::GatherCloud;
use crate::raytrace::RayTracer;
use crate::shading::bsdf::{eval, FLAG_BLEND, FLAG_TWOSIDED, KIND_ROUGHCONDUCTOR, KIND_ROUGHPLASTIC};
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use glam::Vec3;
use std::f32::consts::PI;

/// Pixels per parallel task and between interruption checks.
const ROW_CHUNK: usize = 16;
const ROW_BLOCK: usize = 256;

/// The glossy-only copy of one record, or None when it has no glossy lobe (module docs).
fn glossy_record(b: &GpuBsdf) -> Option<GpuBsdf> {
    match b.kind {
        KIND_ROUGHPLASTIC => {
            let mut g = *b;
            g.diffuse = [0.0; 3];
            g.flags &= !FLAG_BLEND;
            Some(g)
        }
        KIND_ROUGHCONDUCTOR => {
            let mut g = *b;
            g.flags &= !FLAG_BLEND;
            Some(g)
        }
        _ => None,
    }
}

/// The glossy lobes of record `i` of a record array (following a blend to its second record) as
/// (record, weight) pairs; empty when the sample is not glossy (module docs).
pub fn glossy_lobes(records: &[GpuBsdf], i: usize) -> Vec<(GpuBsdf, f32)> {
    let b = &records[i];
    let mut out = Vec::new();
    if b.flags & FLAG_BLEND == 0 {
        out.extend(glossy_record(b).map(|g| (g, 1.0)));
        return out;
    }
    let w = b.extra[2];
    out.extend(glossy_record(b).map(|g| (g, 1.0 - w)));
    if let Some(s) = records.get(b.extra[3].to_bits() as usize) {
        // A blend's second record carries no link of its own; the twosided flag is the first's.
        let mut s = *s;
        s.flags |= b.flags & FLAG_TWOSIDED;
        out.extend(glossy_record(&s).map(|g| (g, w)));
    }
    out.retain(|(_, w)| *w > 0.0);
    out
}

/// Mitsuba's `eval` of the glossy lobes only, f_g(wi, wo) |cos theta_o| (RGB; local frame, wi toward
/// the viewer).
pub fn glossy_eval(lobes: &[(GpuBsdf, f32)], wi: Vec3, wo: Vec3) -> Vec3 {
    lobes.iter().map(|(b, w)| eval(b, wi, wo) * *w).sum()
}

/// The F_g rows of the glossy pixels and their glossy colours k_g (module docs).
pub struct GlossyRows {
    /// One culled wavelet row per pixel (1 channel; empty for pixels that are not glossy).
    pub rows: Vec<SparseRow>,
    /// k_g per pixel (RGB, unit mean over channels; 0 for pixels that are not glossy).
    pub color: Vec<Vec3>,
    /// Glossy pixels.
    pub pixels: usize,
    pub shadow_rays: u64,
    pub links: u64,
}

/// Computes the F_g rows of every glossy view sample among the first `samples` of `view` (the camera
/// hits, or every view sample in a scene with masks: `masks::row_samples`; module docs);
/// `progress(done, total)` over them. Returns empty `rows` and `color` when none is glossy.
///
/// Errors: `Interrupted`.
#[allow(clippy::too_many_arguments)]
pub fn glossy_rows(
    view: &ViewSamples,
    samples: usize,
    tracer: &RayTracer,
    cloud: &GatherCloud,
    hierarchy: &ClusterHierarchy,
    emit_position: &[Vec3],
    emit_normal: &[Vec3],
    opts: &TransferOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<GlossyRows> {
    let pixels = samples.min(view.len());
    let masked = tracer.masks().any();
    let glossy: Vec<bool> = (0..pixels).map(|i| view.shape_index[i] >= 0 && !glossy_lobes(&view.bsdf, i).is_empty()).collect();
    let count = glossy.iter().filter(|&&g| g).count();
    if count == 0 {
        progress(pixels, pixels);
        return Ok(GlossyRows { rows: Vec::new(), color: Vec::new(), pixels: 0, shadow_rays: 0, links: 0 });
    }
    let levels = hierarchy.levels;
    let bounds: Vec<Vec<(Vec3, Vec3)>> = (0..=levels).map(|d| hierarchy.cluster_bounds(d, emit_position)).collect();
    let ctx = Gather { cloud, hierarchy, bounds: &bounds, emit_position, emit_normal, opts };
    let side = hierarchy.side();
    let n = cloud.len();
    let (mut rows, mut color) = (Vec::with_capacity(pixels), Vec::with_capacity(pixels));
    let (mut shadow_rays, mut links) = (0u64, 0u64);
    let mut start = 0;
    while start < pixels {
        let end = (start + ROW_BLOCK).min(pixels);
        let part = crate::interrupt::par_map_chunked(end - start, ROW_CHUNK, |k| -> Result<(SparseRow, Vec3, u64, u64)> {
            let i = start + k;
            if !glossy[i] {
                return Ok((SparseRow::default(), Vec3::ZERO, 0, 0));
            }
            let lobes = glossy_lobes(&view.bsdf, i);
            let sp = ShadingPoint::new(view, i);
            let twosided = view.bsdf[i].flags & FLAG_TWOSIDED != 0;
            let mut dense = vec![0f32; n];
            // Through masks: the view sample's budget less the gather sample's own bounce (`masks`).
            if !receives_indirect(view, masked, i) {
                return Ok((SparseRow::default(), Vec3::ZERO, 0, 0));
            }
            let (rays, l) = ctx.gather(tracer, &sp, twosided, &lobes, view_mask_budget(view, masked, i), &mut dense);
            let mut image = hierarchy.to_image(&dense, 1);
            haar::forward(&mut image, side, 1)?;
            let wi = sp.wi_local;
            let peak = glossy_eval(&lobes, wi, Vec3::new(-wi.x, -wi.y, wi.z));
            let m = peak.element_sum() / 3.0;
            let c = if m > 0.0 && m.is_finite() { peak / m } else { Vec3::ONE };
            Ok((haar::cull_area_weighted(&image, side, 1, opts.coefficients)?, c, rays, l))
        })?;
        for r in part {
            let (row, c, rays, l) = r?;
            rows.push(row);
            color.push(c);
            shadow_rays += rays;
            links += l;
        }
        start = end;
        progress(start, pixels);
    }
    Ok(GlossyRows { rows, color, pixels: count, shadow_rays, links })
}

struct Gather<'a> {
    cloud: &'a GatherCloud,
    hierarchy: &'a ClusterHierarchy,
    bounds: &'a [Vec<(Vec3, Vec3)>],
    emit_position: &'a [Vec3],
    emit_normal: &'a [Vec3],
    opts: &'a TransferOptions,
}

/// World `v` in the shading frame of `sp`.
fn local(sp: &ShadingPoint, v: Vec3) -> Vec3 {
    Vec3::new(v.dot(sp.s), v.dot(sp.t), v.dot(sp.n))
}

impl Gather<'_> {
    /// Mean over RGB of the glossy BRDF (without the cosine) toward world point `q`.
    fn brdf(&self, sp: &ShadingPoint, lobes: &[(GpuBsdf, f32)], q: Vec3) -> f32 {
        let Some(wo) = (q - sp.p).try_normalize() else { return 0.0 };
        let wo = local(sp, wo);
        if wo.z == 0.0 {
            return 0.0;
        }
        let v = glossy_eval(lobes, sp.wi_local, wo).element_sum() / (3.0 * wo.z.abs());
        if v.is_finite() {
            v.max(0.0)
        } else {
            0.0
        }
    }

    /// Fills the dense row F_g(i, .) (sample order); returns (rays, links).
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        tracer: &RayTracer,
        sp: &ShadingPoint,
        twosided: bool,
        lobes: &[(GpuBsdf, f32)],
        masks: Option<u32>,
        dense: &mut [f32],
    ) -> (u64, u64) {
        let side_n = if twosided && sp.wi_local.z < 0.0 { -sp.n } else { sp.n };
        // The lobe's peak: wi mirrored about the shading normal (world space).
        let wi_world = sp.s * sp.wi_local.x + sp.t * sp.wi_local.y + sp.n * sp.wi_local.z;
        let mirror = 2.0 * wi_world.dot(sp.n) * sp.n - wi_world;
        let peak = self.brdf(sp, lobes, sp.p + mirror);
        let (mut rays, mut links) = (0u64, 0u64);
        let mut stack = vec![(0u32, 0usize)];
        while let Some((depth, c)) = stack.pop() {
            let (lo, hi) = self.bounds[depth as usize][c];
            if behind_tangent_plane(lo, hi, sp.p, side_n) {
                continue;
            }
            let members = self.hierarchy.cluster(depth, c);
            let leaf = depth == self.hierarchy.levels;
            if !leaf {
                let centre = (lo + hi) * 0.5;
                let s2 = (hi - lo).length_squared();
                let d2 = (centre - sp.p).length_squared();
                let mut f = self.brdf(sp, lobes, centre);
                if let Some(dir) = (centre - sp.p).try_normalize() {
                    // The peak lies in the cluster's cone: cos(angle) >= cos(atan(s / 2d)).
                    let cos_cone = 1.0 / (1.0 + s2 / (4.0 * d2.max(f32::MIN_POSITIVE))).sqrt();
                    if dir.dot(mirror) >= cos_cone {
                        f = f.max(peak);
                    }
                } else {
                    f = f.max(peak);
                }
                if s2 * (PI * f).max(1.0) > self.opts.threshold * d2 {
                    for child in 0..4 {
                        stack.push((depth + 1, 4 * c + child));
                    }
                    continue;
                }
            }
            let r = if members.len() == 1 {
                members[0] as usize
            } else {
                members[representative(self.opts.seed, depth, c, members.len())] as usize
            };
            links += 1;
            let f = self.brdf(sp, lobes, self.emit_position[r]);
            if f <= 0.0 {
                continue;
            }
            let area = self.opts.near_field.patch_area(self.cloud.area[r]);
            let (g, tested) = geometry_patch(
                tracer,
                sp,
                twosided,
                self.emit_position[r],
                self.emit_normal[r],
                self.cloud.geo_normal[r],
                self.opts.clamp,
                area,
                masks,
            );
            rays += tested as u64;
            if g > 0.0 {
                for &m in members {
                    dense[m as usize] = g * f * self.cloud.area[m as usize];
                }
            }
        }
        (rays, links)
    }
}

/// A deterministic random member index in 0..size for cluster (depth, c) (the F_d gather's choice,
/// with another stream so the two matrices do not share their representatives' errors).
fn representative(seed: u64, depth: u32, c: usize, size: usize) -> usize {
    let mut x = (seed ^ 0x676c_6f73_7379) ^ ((depth as u64) << 56) ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^= x >> 31;
    (x % size as u64) as usize
}

/// Adds the glossy indirect radiance k_g(i) sum_j F_g^w(i, j) b^w_j to `out` (per row sample RGB) from the
/// projected gather radiance `bw` (gather image, 3 channels), skipping wavelet lights whose intensity
/// times image norm (`image_norms` of F_g^w) is below `epsilon` (Sec. 3.5). Returns the lights culled.
///
/// Errors: `InvalidParameter` for mismatched sizes; `Interrupted`.
pub fn add_glossy(
    rows: &[SparseRow],
    color: &[Vec3],
    image_norms: &[f32],
    bw: &[f32],
    epsilon: f32,
    out: &mut [[f32; 3]],
) -> Result<usize> {
    if rows.is_empty() {
        return Ok(0);
    }
    let n = image_norms.len();
    if rows.len() != out.len() || color.len() != out.len() || bw.len() != 3 * n {
        return Err(crate::error::Error::invalid(format!(
            "glossy rows: {} rows, {} colours, {} pixels, {} lighting values for {n} gather samples",
            rows.len(),
            color.len(),
            out.len(),
            bw.len()
        )));
    }
    let kept = haar::cull_wavelet_lights(bw, 3, image_norms, epsilon)?;
    let mut on = vec![false; n];
    for &j in &kept {
        on[j as usize] = true;
    }
    let culled = (0..n).filter(|&j| !on[j] && bw[3 * j..3 * j + 3].iter().any(|&v| v != 0.0)).count();
    let add = crate::interrupt::par_map_chunked(rows.len(), 256, |i| {
        let mut s = Vec3::ZERO;
        for (&j, &f) in rows[i].index.iter().zip(&rows[i].value) {
            let j = j as usize;
            if on[j] {
                s += f * Vec3::new(bw[3 * j], bw[3 * j + 1], bw[3 * j + 2]);
            }
        }
        color[i] * s
    })?;
    for (o, a) in out.iter_mut().zip(add) {
        for (x, y) in o.iter_mut().zip(a.to_array()) {
            *x += y;
        }
    }
    Ok(culled)
}

#[cfg(test)]
mod tests;
