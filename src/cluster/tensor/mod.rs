//! Tensor clustering of light-frame pairs: M. Hašan, E. Velázquez-Armendáriz, F. Pellacini, K. Bala,
//! "Tensor Clustering for Rendering Many-Light Animations", EGSR 2008 (CGF 27(4)), Sec. 4.3 and 4.5.
//! CPU only; works on the reduced tensor R (r sampled rows x n lights x f frames) given as an array.
//!
//! # What is implemented
//! - Sec. 4.3: light-frame pairs (LFPs) p = (j, k); the reduced column `R(:, j, k)` (RGB elements become
//!   scalars by the 2-norm of the triple, Sec. 5 "Clustering and cost computation"); its weight
//!   `w_p = |R(:, j, k)|` and information vector `x_p = R(:, j, k) / w_p` (0 when `w_p = 0`).
//! - Sec. 4.3.1 objective `sum_t sum_{p, q in C_t} w_p w_q |x_p - x_q|^2`. Per cluster this equals
//!   `2 (s^2 - |sum_p R(:, p)|^2)` with `s = sum_p w_p` (the low-rank form of Sec. 5); we report and
//!   minimise `s^2 - |sum R|^2`, the MRCS convention of [`super::columns::cluster_costs`] (half the paper's
//!   value, same minimisers).
//! - Sec. 4.3.2: only "rectangular" clusters `C = J x K`, K a contiguous range of frames.
//!   * Initialisation: MRCS multi-set sampling (Hašan 2007 Sec. 3.5, [`super::sampling`]) of the light
//!     slabs, the columns of `reshape(permute(R, 1, 3, 2), r f, n)`, after the random projection of
//!     [`super::columns::project`] (to `projection_dim` dimensions when `r f` is larger): light clusters
//!     spanning all frames of the chunk. `init_clusters` of them (paper: "e.g. 100"), at most the chunk's
//!     budget. This initialisation is the paper's bias against early time splits: the first cuts are
//!     always in lights, so no cluster is cut in time before the light structure is found.
//!   * Top-down splitting: the cluster of highest cost (ties: the larger, then the older) is split in time
//!     (the best of the |K| - 1 cuts along the frame order) or in lights (the lights ordered by the
//!     projection of their slabs of information vectors `X(:, j, K)` (r |K| values) on the line through
//!     two lights drawn with probability proportional to their total weight over K, best of the |J| - 1
//!     cuts), whichever gives the lower cost of the two halves; until the chunk's budget is reached.
//! - Sec. 4.5: representative = the LFP of largest weight in the cluster (the paper's deterministic
//!   choice; ties: lowest light, then earliest frame). The scaling tensor `S(t, q) = w_q / w_p` and the
//!   reconstruction matrix `Rec = sum(S, 2)` (c x f): `Rec(t, k) = sum_{j in J_t} w_(j,k) / w_p` for k in
//!   K_t, 0 elsewhere. Per channel (Table 1: Rec is c x f RGBs; Sec. 5: "the per-channel norms of the
//!   columns need to be preserved, since they are needed for the reconstruction"): with
//!   `color_averaging` (default) `Rec(t, k)_ch = sum_j |R_ch(:, j, k)| / |R_ch(:, p)|`, falling back to the
//!   scalar ratio in a channel where the representative's norm is 0. Frame k is then estimated as
//!   `sum_t Rec(t, k) * A(:, rep_t)` (mapped from the representative's frame to k by the renderer).
//! - Sec. 6: the frames are cut into chunks of `chunk` frames (paper: 40) clustered independently; each
//!   chunk gets a share of the total budget `c` proportional to its frame count (largest remainders).
//!
//! # Deviations and choices
//! - The paper's algorithm is biased (Sec. 4.5 says so). [`Representative::Sampled`] offers the [HPB07]
//!   choice instead (representative drawn with probability `w_p / s`); with `color_averaging` off its
//!   weights `Rec(t, k) = sum_j w_(j,k) / w_p` make the estimate of the row sums of R unbiased whenever
//!   the columns of a light do not change over the cluster's frames (one frame, static scenes) and the
//!   sum over all frames unbiased in general. Used by the tests; not the default.
//! - [`Representative::Centroid`] (not in the paper) is a deterministic alternative to the largest
//!   weight: the pair whose scaled column best matches the cluster's summed reduced column. The largest
//!   weight tends to pick the most peaked column (a light closest to some sampled view sample) and
//!   scales it up, which biases every frame the same way. Measured on a moving cbox-lights animation
//!   (403 lights, 8 frames, 48 rows, 20 columns per frame): on the reduced tensor the paper's choice has
//!   6x the relative L2 of sampled and 11x that of centroid representatives; on all 32x32 pixels 0.0102
//!   vs 0.0017 (sampled) and 0.00095 (centroid), at the same low flicker (tests/animation/test_tensor_clustering.py).
//!   Its candidates are the pairs of at least half the cluster's mean weight
//!   ([`reconstruction::CENTROID_WEIGHT_FLOOR`]): a pair the rows barely see may be well aligned with the
//!   cluster by chance while its full column is a near-contact spike between the rows; scaled by
//!   `s / w_p` in the hundreds it was the one outlier seed of the bundled animation (6.4% error).
//! - A cluster whose reduced columns are all zero gets `Rec = 0` (nothing to scale by); its
//!   representative need not be rendered and is not counted in [`TensorClustering::shadow_maps_per_frame`].
//!   Lights whose slab is zero in all frames of the chunk join the first initial cluster (they add
//!   nothing to any cost).
//! - Ties in a split (light vs time within round-off, `1e-12 s^2`) go to the light split; ties between
//!   cuts go to the most balanced cut, so zero-cost clusters are split in halves when the budget asks
//!   for more clusters than the reduced tensor can tell apart. When the two drawn lights have identical
//!   slabs the line is a random Gaussian direction instead.
//! - Randomness: independent PCG64 streams per (seed, chunk, phase); work in parallel is per light or per
//!   frame with sequential sums, so a seed gives identical results whatever the number of threads.
//!
//! # Symbols
//! | paper | here |
//! |---|---|
//! | R (r x n x f) | [`ReducedTensor`] (numpy (r, n, f, 3)) |
//! | c, C_t = J x K | `columns` (total over all chunks), a cluster's `lights` and `frames` |
//! | w_p, x_p | `weight`, reduced column / weight |
//! | Rec (c x f RGB) | [`TensorClustering::rec`] |

mod reconstruction;
mod split;
mod store;
#[cfg(test)]
mod tests;

use super::splitting::Candidate;
use crate::error::{Error, Result};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use split::{Cluster, SplitKind};
use std::collections::BinaryHeap;
use store::ChunkStore;

/// The reduced tensor R: r x n x f elements of `channels` (1 or 3) float32 values, row-major, i.e.
/// element (i, j, k, ch) at `((i * n + j) * f + k) * channels + ch` (numpy shape (r, n, f, 3)).
#[derive(Debug, Clone, Copy)]
pub struct ReducedTensor<'a> {
    data: &'a [f32],
    num_rows: usize,
    num_lights: usize,
    num_frames: usize,
    channels: usize,
    /// Element strides (in units of `channels` values) of row, light and frame.
    strides: [usize; 3],
}

impl<'a> ReducedTensor<'a> {
    /// Checks shape and values: r, n, f > 0, channels in {1, 3}, `data.len() == r n f channels`, every
    /// value finite (the error names row, light, frame and channel of the first offending value).
    pub fn new(data: &'a [f32], num_rows: usize, num_lights: usize, num_frames: usize, channels: usize) -> Result<Self> {
        Self::with_layout(data, num_rows, num_lights, num_frames, channels, false)
    }

    /// `new` for data stored frame by frame, (f, r, n, channels) in memory (each frame's rows as one block,
    /// as `LightMatrix.rows` returns them), indexed the same way.
    pub fn frame_major(data: &'a [f32], num_rows: usize, num_lights: usize, num_frames: usize, channels: usize) -> Result<Self> {
        Self::with_layout(data, num_rows, num_lights, num_frames, channels, true)
    }

    fn with_layout(
        data: &'a [f32],
        num_rows: usize,
        num_lights: usize,
        num_frames: usize,
        channels: usize,
        frame_major: bool,
    ) -> Result<Self> {
        if num_rows == 0 || num_lights == 0 || num_frames == 0 {
            return Err(Error::invalid(format!(
                "reduced tensor must have at least one row, light and frame, got shape ({num_rows}, {num_lights}, {num_frames})"
            )));
        }
        if channels != 1 && channels != 3 {
            return Err(Error::invalid(format!("reduced tensor must have 1 or 3 channels, got {channels}")));
        }
        let expected = num_rows
            .checked_mul(num_lights)
            .and_then(|v| v.checked_mul(num_frames))
            .and_then(|v| v.checked_mul(channels))
            .ok_or_else(|| Error::invalid("reduced tensor shape overflows"))?;
        if data.len() != expected {
            return Err(Error::invalid(format!(
                "reduced tensor of shape ({num_rows}, {num_lights}, {num_frames}, {channels}) needs {expected} values, got {}",
                data.len()
            )));
        }
        let strides = if frame_major { [num_lights, 1, num_rows * num_lights] } else { [num_lights * num_frames, num_frames, 1] };
        if let Some(at) = data.iter().position(|v| !v.is_finite()) {
            let (element, channel) = (at / channels, at % channels);
            let (row, light, frame) = if frame_major {
                (element % (num_rows * num_lights) / num_lights, element % num_lights, element / (num_rows * num_lights))
            } else {
                (element / (num_lights * num_frames), element % (num_lights * num_frames) / num_frames, element % num_frames)
            };
            return Err(Error::invalid(format!(
                "reduced tensor has a non-finite value {} at row {row}, light {light}, frame {frame}, channel {channel}",
                data[at]
            )));
        }
        Ok(ReducedTensor { data, num_rows, num_lights, num_frames, channels, strides })
    }
    pub fn num_rows(&self) -> usize {
        self.num_rows
    }
    pub fn num_lights(&self) -> usize {
        self.num_lights
    }
    pub fn num_frames(&self) -> usize {
        self.num_frames
    }
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Whether the data is stored frame by frame (`frame_major`).
    pub fn is_frame_major(&self) -> bool {
        self.strides[1] == 1 && self.num_frames > 1
    }
    /// Channel `ch` of element (row, light, frame); scalar input repeats its value in every channel.
    #[inline]
    pub fn channel(&self, row: usize, light: usize, frame: usize, ch: usize) -> f64 {
        let [sr, sl, sf] = self.strides;
        let at = (row * sr + light * sl + frame * sf) * self.channels;
        self.data[at + if self.channels == 1 { 0 } else { ch }] as f64
    }
}

/// How the representative of a cluster is chosen (Sec. 4.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Representative {
    /// The paper's choice: the light-frame pair of largest weight (deterministic, biased).
    MaxWeight,
    /// [HPB07]'s choice: drawn with probability proportional to the weight (see the module doc).
    Sampled,
    /// Not in the paper: the pair whose information vector `x_p` is most aligned with the sum of the
    /// cluster's reduced columns `P` (maximum `P . x_p`), i.e. the pair whose scaled column
    /// `(s / w_p) R(:, p)` is closest to `P` (deterministic; see the module doc).
    Centroid,
}

/// Options of [`cluster_tensor`].
#[derive(Debug, Clone)]
pub struct TensorOptions {
    /// Seed of every random choice.
    pub seed: u64,
    /// Frames per chunk (paper: 40); chunks are clustered independently.
    pub chunk: usize,
    /// Light clusters made by the initial sampling (paper: "e.g. 100"), capped by the chunk's budget.
    pub init_clusters: usize,
    /// Dimension of the random projection of the initialisation (MRCS: 50).
    pub projection_dim: usize,
    pub representative: Representative,
    /// Per-channel Rec (Sec. 5, default); off: the scalar weight ratio in every channel.
    pub color_averaging: bool,
    /// A time split is taken only when its cost times `time_weight` is below the light split's (1: the
    /// paper; > 1 makes clusters span more frames: less flicker, Sec. 4.3.2's "weighting light splits
    /// differently from time splits").
    pub time_weight: f64,
    /// Index of the first chunk in the whole animation: random streams are per (seed, chunk index), so
    /// a chunk clustered on its own (a Dask task) with its index here equals the same chunk of the
    /// whole animation clustered at once.
    pub first_chunk: usize,
}

impl Default for TensorOptions {
    fn default() -> Self {
        TensorOptions {
            seed: 0,
            chunk: 40,
            init_clusters: 100,
            projection_dim: 50,
            representative: Representative::MaxWeight,
            color_averaging: true,
            time_weight: 1.0,
            first_chunk: 0,
        }
    }
}

/// What happened in one chunk of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ChunkReport {
    /// Frames [start, end).
    pub frames: (usize, usize),
    /// Clusters of this chunk (its share of the total budget).
    pub budget: usize,
    /// Light clusters made by the initial sampling.
    pub init_clusters: usize,
    pub time_splits: usize,
    pub light_splits: usize,
}

/// A clustering of the n x f light-frame pairs into rectangular clusters, each with a representative
/// pair and its row of the reconstruction matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct TensorClustering {
    pub num_lights: usize,
    pub num_frames: usize,
    /// Cluster of each pair, `assignment[j * f + k]`.
    pub assignment: Vec<u32>,
    /// (light, frame) of each cluster's representative.
    pub representatives: Vec<(u32, u32)>,
    /// Lights J of each cluster, ascending.
    pub lights: Vec<Vec<u32>>,
    /// Frames K = [start, end) of each cluster (global frame indices).
    pub frames: Vec<(u32, u32)>,
    /// Reconstruction matrix, `rec[t * f + k]` = RGB scale of representative t in frame k.
    pub rec: Vec<[f32; 3]>,
    /// Cost `s^2 - |sum R|^2` of each cluster (half the paper's Sec. 4.3.1 value).
    pub cost: Vec<f64>,
    pub chunks: Vec<ChunkReport>,
}

impl TensorClustering {
    pub fn num_clusters(&self) -> usize {
        self.representatives.len()
    }
    /// Whether cluster t's representative has to be rendered: some Rec entry is non-zero.
    pub fn rendered(&self) -> Vec<bool> {
        let f = self.num_frames;
        (0..self.num_clusters()).map(|t| self.rec[t * f..(t + 1) * f].iter().any(|v| v.iter().any(|&x| x != 0.0))).collect()
    }
    /// Shadow maps rendered for frame k: representatives (that need rendering) whose pair is in frame k.
    pub fn shadow_maps_per_frame(&self) -> Vec<usize> {
        let mut out = vec![0usize; self.num_frames];
        for (&(_, k), rendered) in self.representatives.iter().zip(self.rendered()) {
            if rendered {
                out[k as usize] += 1;
            }
        }
        out
    }
    /// Clusters contributing to frame k (non-zero Rec entry): the paper's "effective number of clusters".
    pub fn clusters_per_frame(&self) -> Vec<usize> {
        let f = self.num_frames;
        (0..f).map(|k| (0..self.num_clusters()).filter(|&t| self.rec[t * f + k].iter().any(|&x| x != 0.0)).count()).collect()
    }
}

/// Chunks [start, end) of `chunk` frames and their budgets: `columns * frames / f` rounded down, the
/// remainder given one by one to the chunks with the largest fractional parts (earlier chunk on ties).
pub fn chunk_budgets(num_frames: usize, chunk: usize, columns: usize) -> Vec<(usize, usize, usize)> {
    let ranges: Vec<(usize, usize)> = (0..num_frames.div_ceil(chunk)).map(|b| (b * chunk, ((b + 1) * chunk).min(num_frames))).collect();
    let share = |len: usize| (columns as u128 * len as u128, num_frames as u128);
    let mut budgets: Vec<usize> = ranges.iter().map(|&(a, b)| (share(b - a).0 / share(b - a).1) as usize).collect();
    let given: usize = budgets.iter().sum();
    let mut order: Vec<usize> = (0..ranges.len()).collect();
    order.sort_by_key(|&i| {
        let (num, den) = share(ranges[i].1 - ranges[i].0);
        (std::cmp::Reverse(num % den), i)
    });
    for &i in order.iter().take(columns - given) {
        budgets[i] += 1;
    }
    ranges.iter().zip(budgets).map(|(&(a, b), c)| (a, b, c)).collect()
}

/// Independent random stream per (seed, chunk, phase).
pub(crate) fn chunk_rng(seed: u64, chunk: usize, phase: u64) -> Pcg64 {
    fn mix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    Pcg64::seed_from_u64(mix(mix(seed) ^ ((chunk as u64) << 3 | phase)))
}

/// Clusters the light-frame pairs of `tensor` into `columns` clusters in total (see the module doc).
///
/// Errors: `columns` below the number of frames f or above n f, `chunk`, `init_clusters` or
/// `projection_dim` of 0, Ctrl-C.
pub fn cluster_tensor(tensor: ReducedTensor, columns: usize, opts: &TensorOptions) -> Result<TensorClustering> {
    let (n, f) = (tensor.num_lights(), tensor.num_frames());
    if opts.chunk == 0 {
        return Err(Error::invalid("chunk (frames per chunk) must be at least 1, got 0"));
    }
    if !(opts.time_weight > 0.0 && opts.time_weight.is_finite()) {
        return Err(Error::invalid(format!("time_weight must be a finite number > 0, got {}", opts.time_weight)));
    }
    if opts.init_clusters == 0 {
        return Err(Error::invalid("init_clusters must be at least 1, got 0"));
    }
    if opts.projection_dim == 0 {
        return Err(Error::invalid("projection_dim must be at least 1, got 0"));
    }
    if columns < f {
        return Err(Error::invalid(format!(
            "columns ({columns}) must be at least the number of frames ({f}): one representative per frame on average"
        )));
    }
    if columns > n * f {
        return Err(Error::invalid(format!(
            "columns ({columns}) must not exceed the number of light-frame pairs n * f = {n} * {f} = {}",
            n * f
        )));
    }
    let mut out = TensorClustering {
        num_lights: n,
        num_frames: f,
        assignment: vec![0; n * f],
        representatives: Vec::with_capacity(columns),
        lights: Vec::with_capacity(columns),
        frames: Vec::with_capacity(columns),
        rec: Vec::new(),
        cost: Vec::with_capacity(columns),
        chunks: Vec::new(),
    };
    let mut rec_rows: Vec<Vec<[f32; 3]>> = Vec::with_capacity(columns);
    for (index, (start, end, budget)) in chunk_budgets(f, opts.chunk, columns).into_iter().enumerate() {
        let t0 = std::time::Instant::now();
        let store = ChunkStore::build(&tensor, start, end);
        let (clusters, report) = cluster_chunk(&store, budget, opts, opts.first_chunk + index)?;
        let mut rng_rep = chunk_rng(opts.seed, opts.first_chunk + index, 3);
        for cl in clusters {
            let t = out.representatives.len() as u32;
            for &j in &cl.lights {
                for k in start + cl.k0..start + cl.k1 {
                    out.assignment[j as usize * f + k] = t;
                }
            }
            let (j, kk) = reconstruction::representative(&store, &cl, opts.representative, &mut rng_rep);
            let mut row = vec![[0.0f32; 3]; f];
            for (kk, v) in (cl.k0..cl.k1).zip(reconstruction::rec(&store, &cl, (j, kk), opts.color_averaging)) {
                row[start + kk] = v;
            }
            rec_rows.push(row);
            out.cost.push(split::cluster_cost(&store, &cl));
            out.representatives.push((j, (start + kk) as u32));
            out.frames.push(((start + cl.k0) as u32, (start + cl.k1) as u32));
            out.lights.push(cl.lights);
        }
        log::debug!(
            "tensor clustering: chunk {index} (frames {start}..{end}, {budget} clusters, {} time / {} light splits) {:.3} s",
            report.time_splits,
            report.light_splits,
            t0.elapsed().as_secs_f64()
        );
        out.chunks.push(report);
    }
    out.rec = rec_rows.into_iter().flatten().collect();
    Ok(out)
}

/// Initialisation and top-down splitting of one chunk (frames local to the chunk).
fn cluster_chunk(store: &ChunkStore, budget: usize, opts: &TensorOptions, index: usize) -> Result<(Vec<Cluster>, ChunkReport)> {
    let (n, fc) = (store.num_lights, store.num_frames);
    let (nonzero, zero): (Vec<u32>, Vec<u32>) = (0..n as u32).partition(|&j| store.slab_weight(j as usize) > 0.0);
    let mut lights: Vec<Vec<u32>> = if nonzero.is_empty() {
        vec![(0..n as u32).collect()]
    } else {
        let num_init = opts.init_clusters.min(budget).min(nonzero.len());
        let features = super::columns::project(&store.slabs(), &nonzero, opts.projection_dim, &mut chunk_rng(opts.seed, index, 0));
        crate::interrupt::check()?;
        let local = super::sampling::cluster_by_sampling(&features, num_init, &mut chunk_rng(opts.seed, index, 1))?;
        let mut groups: Vec<Vec<u32>> = local.into_iter().map(|g| g.into_iter().map(|i| nonzero[i as usize]).collect()).collect();
        groups[0].extend_from_slice(&zero);
        groups
    };
    lights.iter_mut().for_each(|g| g.sort_unstable());
    let mut clusters: Vec<Cluster> = lights.into_iter().map(|lights| Cluster { lights, k0: 0, k1: fc }).collect();
    let mut report = ChunkReport {
        frames: (store.first_frame, store.first_frame + fc),
        budget,
        init_clusters: clusters.len(),
        time_splits: 0,
        light_splits: 0,
    };
    let mut heap: BinaryHeap<Candidate> = clusters
        .iter()
        .enumerate()
        .filter(|(_, c)| c.size() >= 2)
        .map(|(id, c)| Candidate { cost: split::cluster_cost(store, c), size: c.size(), id })
        .collect();
    let mut rng = chunk_rng(opts.seed, index, 2);
    while clusters.len() < budget {
        crate::interrupt::check()?;
        let Some(top) = heap.pop() else { break };
        let s = split::split(store, &clusters[top.id], &mut rng, opts.time_weight);
        match s.kind {
            SplitKind::Time => report.time_splits += 1,
            SplitKind::Light => report.light_splits += 1,
        }
        let new_id = clusters.len();
        for (id, part, cost) in [(top.id, &s.left, s.cost_left), (new_id, &s.right, s.cost_right)] {
            if part.size() >= 2 {
                heap.push(Candidate { cost, size: part.size(), id });
            }
        }
        clusters[top.id] = s.left;
        clusters.push(s.right);
    }
    Ok((clusters, report))
}
