//! Reconstruction cuts (Walter et al., "Lightcuts: a scalable approach to illumination", SIGGRAPH 2005,
//! Sec. 5): full lightcuts (`lightcuts`) only at a sparse grid of pixels (every `block`-th pixel in x
//! and y, plus the last row and column), and at the pixels in between a cut rebuilt from the cuts of
//! the block's (up to) four corners.
//!
//! A pixel is reconstructed when every corner is a surface whose BSDF has a bound, of the same BSDF
//! kind as the pixel, with a shading normal within 25 degrees of the pixel's and the pixel within
//! 10% of its distance of the corner's tangent plane; otherwise it gets a full lightcut. The
//! reconstruction traverses the cluster tree from its roots; at node C each corner's cut either holds
//! C or an ancestor of C (C is "covered", with that node's visibility at the corner) or refined C:
//! - some corner refined C: descend to C's children (a leaf is shaded exactly, with a shadow ray);
//! - every corner covers C and saw its representative blocked: C is discarded (no ray);
//! - every corner covers C and saw it lit: C is shaded with its representative's unshadowed element at
//!   the pixel times lum(I_C) / lum(I_rep) (no ray; the paper's "interpolation" of unoccluded clusters
//!   uses the pixel's own material and geometry terms);
//! - otherwise (corners disagree, or the representative did not reach a corner): C is shaded as in a
//!   lightcut, one shadow ray.
//! The reconstructed cut is therefore at least as fine as every corner's, and shadow rays are cast only
//! where the corners disagree about visibility. Lights without a bound are evaluated exactly everywhere.
//! View samples of delta chains (beyond the camera hits) get full lightcuts.
//!
//! Symbols: B = `block`, C a cluster-tree node.
use super::cut_tree::CutTree;
use super::lightcuts::{check, fold, lightcut, lum, Criterion, Ctx, CutsEstimate, SampleCut, CHUNK, VIS_BLOCKED, VIS_LIT};
use crate::cpu::ShadingPoint;
use crate::error::{Error, Result};
use crate::matrix::LightMatrix;
use glam::DVec3;
use std::time::Instant;

/// Cosine of the largest normal difference between a pixel and a corner it reconstructs from.
const SIMILAR_NORMAL_COS: f32 = 0.906;
/// Largest distance of a pixel from a corner's tangent plane, relative to their distance.
const SIMILAR_PLANE: f32 = 0.1;

/// Whether pixel index q is on the sparse grid.
fn on_grid(x: usize, y: usize, w: usize, h: usize, b: usize) -> bool {
    (x % b == 0 || x == w - 1) && (y % b == 0 || y == h - 1)
}

/// The corners of pixel (x, y)'s block.
fn corners(x: usize, y: usize, w: usize, h: usize, b: usize) -> [usize; 4] {
    let (x0, y0) = (x / b * b, y / b * b);
    let (x1, y1) = ((x0 + b).min(w - 1), (y0 + b).min(h - 1));
    [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1]
}

/// Whether view sample i may be reconstructed from corner c (module docs).
fn similar(a: &LightMatrix, i: usize, c: &ShadingPoint, ci: usize, sp: &ShadingPoint) -> bool {
    let view = &a.view;
    if !c.surface || view.bsdf[ci].kind != view.bsdf[i].kind || c.n.dot(sp.n) < SIMILAR_NORMAL_COS {
        return false;
    }
    let d = sp.p - c.p;
    c.n.dot(d).abs() <= SIMILAR_PLANE * d.length()
}

/// Corner states at a node: `Some(vis)` covered with that visibility, None refined.
type States = [Option<u8>; 4];

fn covered(cut: &SampleCut, k: u32) -> Option<u8> {
    cut.nodes.binary_search_by_key(&k, |e| e.0).ok().map(|p| cut.nodes[p].1)
}

/// The reconstruction cut's estimate below node k (module docs): (value, nodes, rays).
#[allow(clippy::too_many_arguments)]
fn reconstruct(ctx: &Ctx, sp: &ShadingPoint, i: usize, k: u32, parent: States, nb: &[&SampleCut], acc: &mut (DVec3, u32, u32)) {
    let node = &ctx.tree.nodes[k as usize];
    let mut states = parent;
    for (s, cut) in states.iter_mut().zip(nb) {
        if s.is_none() {
            *s = covered(cut, k);
        }
    }
    let states = &states[..nb.len()];
    if states.iter().all(|s| s.is_some()) {
        acc.1 += 1;
        if states.iter().all(|s| *s == Some(VIS_BLOCKED)) {
            return;
        }
        let value = if states.iter().all(|s| *s == Some(VIS_LIT)) {
            ctx.unshadowed(sp, i, node.rep as usize)
        } else {
            ctx.shade(sp, i, node.rep as usize, &mut acc.2).0
        };
        acc.0 += value.as_dvec3() * node.scale;
        return;
    }
    if node.is_leaf() {
        acc.1 += 1;
        acc.0 += ctx.shade(sp, i, node.rep as usize, &mut acc.2).0.as_dvec3();
        return;
    }
    let mut s4: States = [None; 4];
    s4[..nb.len()].copy_from_slice(states);
    for c in node.children {
        reconstruct(ctx, sp, i, c, s4, nb, acc);
    }
}

/// Reconstruction cuts over `a` with sparse blocks of `block` pixels (module docs), the sparse cuts
/// refined by `criterion`.
///
/// Errors: `InvalidParameter` as `lightcuts`, and block = 0; `Interrupted`.
#[allow(clippy::too_many_arguments)]
pub fn reconstruction_cuts(
    a: &LightMatrix,
    tree: &CutTree,
    error: f64,
    max_cut: usize,
    criterion: Criterion,
    block: usize,
) -> Result<CutsEstimate> {
    check(a, tree, error, max_cut)?;
    if block == 0 {
        return Err(Error::invalid("block must be >= 1 pixel, got 0"));
    }
    let tracer = a.tracer()?;
    let view = &*a.view;
    let ctx = Ctx { tree, tracer: &tracer, view, lights: &a.lights };
    let (w, h, px) = (view.width as usize, view.height as usize, view.num_pixels());
    let point = |i: usize| ShadingPoint::new(view, i);
    // Full cuts at the grid pixels (kept) and at delta-chain samples.
    let t0 = Instant::now();
    let sparse: Vec<Option<SampleCut>> = crate::interrupt::par_map_chunked(px, CHUNK, |q| {
        let sp = point(q);
        (sp.surface && on_grid(q % w, q / w, w, h, block)).then(|| lightcut(&ctx, &sp, q, error, max_cut, criterion, true))
    })?;
    let sparse_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let full = std::sync::atomic::AtomicUsize::new(sparse.iter().flatten().count());
    let capped = std::sync::atomic::AtomicUsize::new(sparse.iter().flatten().filter(|c| c.capped).count());
    let per_sample = crate::interrupt::par_map_chunked(view.len(), CHUNK, |i| {
        let sp = point(i);
        if !sp.surface {
            return (DVec3::ZERO, 0, 0);
        }
        if let Some(Some(c)) = sparse.get(i) {
            return (c.value, c.size, c.rays);
        }
        let mut nb: Vec<&SampleCut> = Vec::with_capacity(4);
        let mut ok = i < px;
        if ok {
            let mut cs = corners(i % w, i / w, w, h, block).to_vec();
            cs.dedup();
            for q in cs {
                match &sparse[q] {
                    Some(c) if !c.unbounded && similar(a, i, &point(q), q, &sp) => nb.push(c),
                    _ => ok = false,
                }
            }
        }
        if !ok || nb.is_empty() {
            full.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let c = lightcut(&ctx, &sp, i, error, max_cut, criterion, false);
            capped.fetch_add(c.capped as usize, std::sync::atomic::Ordering::Relaxed);
            return (c.value, c.size, c.rays);
        }
        let mut rays = 0u32;
        let (exact, n_exact) = ctx.exact(&sp, i, false, &mut rays);
        let mut acc = (exact, n_exact, rays);
        for &r in &tree.roots {
            reconstruct(&ctx, &sp, i, r, [None; 4], &nb, &mut acc);
        }
        debug_assert!(lum(acc.0).is_finite());
        (acc.0.max(DVec3::ZERO), acc.1, acc.2)
    })?;
    let shadow_rays = per_sample.iter().map(|s| s.2 as u64).sum();
    let vs: Vec<(DVec3, u32)> = per_sample.iter().map(|s| (s.0, s.1)).collect();
    let (image, cut_sizes) = fold(view, &vs);
    let seconds = vec![("sparse_cuts", sparse_seconds), ("reconstruction", t1.elapsed().as_secs_f64())];
    Ok(CutsEstimate { image, cut_sizes, shadow_rays, seconds, full_cuts: full.into_inner(), capped_cuts: capped.into_inner() })
}
