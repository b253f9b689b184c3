//! LightSlice (Ou and Pellacini, "LightSlice: Matrix Slice Sampling for the Many-Lights Problem",
//! SIGGRAPH Asia 2011): the light matrix is cut into slices of similar view samples, each slice gets its
//! own light clustering refined from a global one, and renders its pixels with it.
//!
//! 1. **Slices**: the pixels whose camera ray hits a surface are split top-down (a kd-tree over the 6-D
//!    feature `((p - c) / D, normal_weight * n)`, c and D the centre and diagonal of the visible points'
//!    box) at the median of the widest dimension of the largest slice, until `slices` slices.
//! 2. **Rows**: one pixel per slice drawn uniformly; its row of A rendered on the matrix's device (the
//!    reduced matrix R, slices x n).
//! 3. **Global clustering**: MRCS's clustering (`crate::cluster::cluster_reduced_columns`: sampling,
//!    then top-down splitting, zero-norm columns in power-drawn strata) of R into `global_columns`.
//! 4. **Local refinement**, per slice: its `neighbours` nearest slices (itself included; distance between
//!    the slices' mean features) give the local reduced matrix R_s. Starting from the global clusters, the
//!    cluster of largest MRCS cost on R_s (Sec. 3.4 of MRCS, `s^2 - |sum rho|^2`) is split along a random
//!    line at its best cut (`crate::cluster::splitting::split`) until the slice has `columns` clusters.
//! 5. **Reconstruction**, per slice: one representative per cluster drawn with probability proportional
//!    to its norm on R_s and weighted 1 / probability (grey), the slice's pixels shaded with them (CPU,
//!    exact shadow rays, `crate::cpu::shade`).
//!
//! Unbiasedness: every light of a cluster has probability > 0. Columns that are 0 on all of R_s ("locally
//! zero") stay in their global cluster through the splits; a cluster holding both kinds draws from the
//! mixture `(1 - lambda) |rho_j| / s + lambda q_j` with `lambda = ZERO_SHARE |zero| / |C|` and q
//! proportional to the columns' global norm on R (their power where that is 0 too).
//!
//! Deviations from the paper: the slicing features, their weight and the neighbour distance are our
//! choices (the paper clusters gather points by position and normal); representatives are drawn per slice
//! (the paper's are too, but it leaves locally-zero columns out, which is biased); the columns are shaded
//! on the CPU with exact rays (the paper traced rays on the CPU as well); no colour averaging.
//!
//! Symbols: S slices, n lights, c = `columns` (clusters per slice), c_g = `global_columns`, k =
//! `neighbours`, R the reduced matrix (S x n), R_s the local one (k x n), rho_j a reduced column.
use crate::cluster::columns::Features;
use crate::cluster::splitting::{cluster_cost, split, Candidate};
use crate::cluster::{cluster_reduced_columns, phase_rng, ClusterOptions, ReducedMatrix};
use crate::error::{Error, Result};
use crate::matrix::LightMatrix;
use glam::{DVec3, Vec3};
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Share of a cluster's draws given to its locally-zero columns, per unit share of them (module docs).
pub const ZERO_SHARE: f64 = 0.25;
/// The random-stream phases of LightSlice (`crate::cluster::phase_rng` of the seed).
const PHASE_ROWS: u64 = 16;
const PHASE_SLICE: u64 = 17;
/// Representatives per block of the reconstruction (their light data stays in cache over a slice).
const RENDER_BLOCK: usize = 256;

/// Parameters of [`lightslice`].
#[derive(Debug, Clone)]
pub struct LightSliceOptions {
    /// S, slices (at most the pixels that see a surface).
    pub slices: usize,
    /// c, clusters (representative lights) per slice.
    pub columns: usize,
    /// c_g, clusters of the global clustering (1 <= c_g <= c).
    pub global_columns: usize,
    /// k, slices whose rows refine a slice's clustering (itself included).
    pub neighbours: usize,
    /// Weight of the normal against the normalised position in the slicing features.
    pub normal_weight: f64,
    pub seed: u64,
}

/// What [`lightslice`] returns.
#[derive(Debug, Clone)]
pub struct LightSliceResult {
    /// H * W * 3 floats (without what the camera sees of emitters).
    pub image: Vec<f32>,
    /// Slice of each pixel, -1 for pixels without a surface.
    pub slice_of_pixel: Vec<i32>,
    /// The representative row (pixel) of each slice.
    pub rows: Vec<usize>,
    /// The global clustering's label of each light.
    pub global_assignment: Vec<u32>,
    /// Clusters of each slice after refinement.
    pub clusters_per_slice: Vec<usize>,
    pub shadow_rays: u64,
    /// Seconds per stage: slicing, rows, clustering, refinement, columns.
    pub timings: Vec<(&'static str, f64)>,
}

/// Top-down kd slicing of `points` (features, one per pixel listed in `pixels`) into `count` slices.
fn slice_pixels(features: &[[f64; 6]], count: usize) -> Vec<Vec<u32>> {
    let mut heap: BinaryHeap<(usize, usize)> = BinaryHeap::new();
    let mut slices: Vec<Vec<u32>> = vec![(0..features.len() as u32).collect()];
    heap.push((features.len(), 0));
    while slices.len() < count {
        let Some((size, id)) = heap.pop() else { break };
        if size < 2 {
            break;
        }
        let members = std::mem::take(&mut slices[id]);
        let (mut lo, mut hi) = ([f64::INFINITY; 6], [f64::NEG_INFINITY; 6]);
        for &m in &members {
            for d in 0..6 {
                lo[d] = lo[d].min(features[m as usize][d]);
                hi[d] = hi[d].max(features[m as usize][d]);
            }
        }
        let axis = (0..6).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).unwrap_or(0);
        let mut members = members;
        let mid = members.len() / 2;
        members.select_nth_unstable_by(mid, |a, b| features[*a as usize][axis].total_cmp(&features[*b as usize][axis]).then(a.cmp(b)));
        let right = members.split_off(mid);
        heap.push((members.len(), id));
        heap.push((right.len(), slices.len()));
        slices[id] = members;
        slices.push(right);
    }
    slices
}

/// A draw proportional to `weights` (sum > 0): (index, probability).
fn draw(weights: &[f64], rng: &mut Pcg64) -> (usize, f64) {
    let total: f64 = weights.iter().sum();
    let u = rng.random::<f64>() * total;
    let (mut acc, mut last) = (0.0, 0);
    for (i, &w) in weights.iter().enumerate() {
        if w > 0.0 {
            acc += w;
            last = i;
            if u < acc {
                return (i, w / total);
            }
        }
    }
    (last, weights[last] / total)
}

/// Draw weights q of locally-zero columns (module docs).
fn zero_weights(members: &[u32], global_norm: &[f64], power: &[f32]) -> Vec<f64> {
    let g: Vec<f64> = members.iter().map(|&j| global_norm[j as usize]).collect();
    if g.iter().sum::<f64>() > 0.0 {
        return g;
    }
    let p: Vec<f64> = members.iter().map(|&j| power[j as usize].max(0.0) as f64).collect();
    if p.iter().sum::<f64>() > 0.0 {
        p
    } else {
        vec![1.0; members.len()]
    }
}

/// One slice's refined clustering and representatives: (light, grey weight) per cluster.
fn refine_slice(
    global: &[Vec<u32>],
    local: &Features,
    columns: usize,
    global_norm: &[f64],
    power: &[f32],
    rng: &mut Pcg64,
) -> Vec<(u32, f32)> {
    // (locally non-zero members, locally zero members) per cluster.
    let mut clusters: Vec<(Vec<u32>, Vec<u32>)> = global.iter().map(|c| c.iter().partition(|&&j| local.norm[j as usize] > 0.0)).collect();
    let mut heap: BinaryHeap<Candidate> = clusters
        .iter()
        .enumerate()
        .filter(|(_, c)| c.0.len() >= 2)
        .map(|(id, c)| Candidate { cost: cluster_cost(local, &c.0), size: c.0.len(), id })
        .collect();
    while clusters.len() < columns {
        let Some(top) = heap.pop() else { break };
        let (left, right, cost_left, cost_right) = split(local, &clusters[top.id].0, rng);
        let new_id = clusters.len();
        for (id, part, cost) in [(top.id, &left, cost_left), (new_id, &right, cost_right)] {
            if part.len() >= 2 {
                heap.push(Candidate { cost, size: part.len(), id });
            }
        }
        clusters[top.id].0 = left;
        clusters.push((right, Vec::new()));
    }
    clusters
        .iter()
        .map(|(nz, z)| {
            let norms: Vec<f64> = nz.iter().map(|&j| local.norm[j as usize]).collect();
            let lambda = if nz.is_empty() {
                1.0
            } else if z.is_empty() {
                0.0
            } else {
                ZERO_SHARE * z.len() as f64 / (z.len() + nz.len()) as f64
            };
            let q = if z.is_empty() { Vec::new() } else { zero_weights(z, global_norm, power) };
            let (s, q_total) = (norms.iter().sum::<f64>(), q.iter().sum::<f64>());
            let mut w: Vec<f64> = norms.iter().map(|v| (1.0 - lambda) * v / s).collect();
            w.extend(q.iter().map(|v| lambda * v / q_total));
            let (at, p) = draw(&w, rng);
            let j = if at < nz.len() { nz[at] } else { z[at - nz.len()] };
            (j, (1.0 / p) as f32)
        })
        .collect()
}

/// LightSlice on `a` (module docs).
///
/// Errors: `InvalidParameter` for a matrix without lights or without visible surfaces, slices, columns,
/// global_columns or neighbours of 0, global_columns > columns, a normal_weight that is negative or not
/// finite; `Interrupted`; the device's errors from the rows.
pub fn lightslice(a: &LightMatrix, opts: &LightSliceOptions) -> Result<LightSliceResult> {
    let n = a.lights.len();
    let view = &*a.view;
    let positive = |what: &str, v: usize| {
        if v == 0 {
            Err(Error::invalid(format!("{what} must be >= 1, got 0")))
        } else {
            Ok(())
        }
    };
    positive("slices", opts.slices)?;
    positive("columns", opts.columns)?;
    positive("global_columns", opts.global_columns)?;
    positive("neighbours", opts.neighbours)?;
    if opts.global_columns > opts.columns {
        return Err(Error::invalid(format!(
            "global_columns ({}) must not exceed columns ({}): slices refine the global clustering",
            opts.global_columns, opts.columns
        )));
    }
    if !(opts.normal_weight >= 0.0 && opts.normal_weight.is_finite()) {
        return Err(Error::invalid(format!("normal_weight must be finite and >= 0, got {}", opts.normal_weight)));
    }
    if n == 0 {
        return Err(Error::invalid("lightslice needs lights (the light matrix has n = 0)"));
    }
    let mut timings = Vec::new();
    let t = Instant::now();
    let pixels = view.num_pixels();
    let visible: Vec<u32> = (0..pixels as u32).filter(|&p| view.shape_index[p as usize] >= 0).collect();
    if visible.is_empty() {
        return Err(Error::invalid("lightslice: no pixel sees a surface (nothing to slice)"));
    }
    let (lo, hi) = visible.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
        let x = view.position[p as usize].as_dvec3();
        (l.min(x), h.max(x))
    });
    let (centre, diag) = ((lo + hi) * 0.5, (hi - lo).length().max(1e-30));
    let features: Vec<[f64; 6]> = visible
        .iter()
        .map(|&p| {
            let (x, nn) = ((view.position[p as usize].as_dvec3() - centre) / diag, view.normal[p as usize].as_dvec3() * opts.normal_weight);
            [x.x, x.y, x.z, nn.x, nn.y, nn.z]
        })
        .collect();
    let slices = slice_pixels(&features, opts.slices.min(visible.len()));
    let mut slice_of_pixel = vec![-1i32; pixels];
    for (s, members) in slices.iter().enumerate() {
        for &m in members {
            slice_of_pixel[visible[m as usize] as usize] = s as i32;
        }
    }
    let centroids: Vec<[f64; 6]> = slices
        .iter()
        .map(|m| {
            let mut c = [0.0; 6];
            for &k in m {
                for d in 0..6 {
                    c[d] += features[k as usize][d] / m.len() as f64;
                }
            }
            c
        })
        .collect();
    let k = opts.neighbours.min(slices.len());
    let neighbours: Vec<Vec<usize>> = (0..slices.len())
        .into_par_iter()
        .map(|s| {
            let mut d: Vec<(f64, usize)> =
                centroids.iter().enumerate().map(|(t, c)| ((0..6).map(|x| (c[x] - centroids[s][x]).powi(2)).sum::<f64>(), t)).collect();
            d.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then((a.1 != s).cmp(&(b.1 != s))).then(a.1.cmp(&b.1)));
            d[..k].iter().map(|x| x.1).collect()
        })
        .collect();
    let mut rng = phase_rng(opts.seed, PHASE_ROWS);
    let rows: Vec<usize> = slices.iter().map(|m| visible[m[rng.random_range(0..m.len())] as usize] as usize).collect();
    timings.push(("slicing", t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let r = a.rows(&rows, &mut |_, _| {})?;
    timings.push(("rows", t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let power = a.lights.power_luminance();
    let reduced = ReducedMatrix::new(&r, rows.len(), n, 3)?;
    let copts = ClusterOptions { seed: opts.seed, power: Some(&power), ..Default::default() };
    let global = cluster_reduced_columns(reduced, opts.global_columns.min(n), &copts)?;
    let scalar: Vec<f64> = (0..rows.len() * n).map(|e| reduced.scalar(e / n, e % n)).collect();
    let global_norm: Vec<f64> = (0..n).map(|j| (0..rows.len()).map(|i| scalar[i * n + j].powi(2)).sum::<f64>().sqrt()).collect();
    timings.push(("clustering", t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let columns = opts.columns.min(n);
    let per_slice: Vec<Vec<(u32, f32)>> = crate::interrupt::par_map_chunked(slices.len(), 64, |s| {
        let rows_s = &neighbours[s];
        let dim = rows_s.len();
        let mut data = vec![0.0f64; dim * n];
        for j in 0..n {
            for (t, &row) in rows_s.iter().enumerate() {
                data[j * dim + t] = scalar[row * n + j];
            }
        }
        let norm = data.chunks(dim).map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
        let local = Features { dim, data, norm };
        let mut rng = phase_rng(opts.seed.wrapping_add(s as u64 * 0x9e37_79b9), PHASE_SLICE);
        refine_slice(&global.clusters, &local, columns, &global_norm, &power, &mut rng)
    })?;
    timings.push(("refinement", t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let tracer = a.tracer()?;
    // Slice by slice (a slice's representatives stay in cache), in blocks of RENDER_BLOCK lights.
    let mut samples_of_slice: Vec<Vec<u32>> = vec![Vec::new(); slices.len()];
    for i in 0..view.len() {
        let pixel = view.pixel_of(i);
        if slice_of_pixel[pixel] >= 0 && view.shape_index[i] >= 0 {
            samples_of_slice[slice_of_pixel[pixel] as usize].push(i as u32);
        }
    }
    let rays = AtomicU64::new(0);
    let shaded: Vec<Vec<Vec3>> = crate::interrupt::par_map_chunked(slices.len(), 64, |s| {
        let samples = &samples_of_slice[s];
        let points: Vec<_> = samples.iter().map(|&i| crate::cpu::ShadingPoint::new(view, i as usize)).collect();
        let mut sums = vec![Vec3::ZERO; samples.len()];
        let mut tested = 0u64;
        for block in per_slice[s].chunks(RENDER_BLOCK) {
            for ((&i, sp), sum) in samples.iter().zip(&points).zip(sums.iter_mut()) {
                for &(j, w) in block {
                    let v = crate::cpu::shade(&tracer, view, &a.lights, sp, i as usize, j as usize);
                    tested += v.tested as u64;
                    *sum += v.value * w;
                }
            }
        }
        rays.fetch_add(tested, Ordering::Relaxed);
        sums
    })?;
    let mut per_sample = vec![Vec3::ZERO; view.len()];
    for (samples, sums) in samples_of_slice.iter().zip(&shaded) {
        for (&i, &v) in samples.iter().zip(sums) {
            per_sample[i as usize] = v;
        }
    }
    let flat: Vec<f32> = per_sample.iter().flat_map(|v| v.to_array()).collect();
    let image = if view.len() == pixels { flat } else { view.fold(&flat, 3) };
    timings.push(("columns", t.elapsed().as_secs_f64()));
    Ok(LightSliceResult {
        image,
        slice_of_pixel,
        rows,
        global_assignment: global.assignment,
        clusters_per_slice: per_slice.iter().map(|c| c.len()).collect(),
        shadow_rays: rays.into_inner(),
        timings,
    })
}

#[cfg(test)]
mod tests;
