//! Sec. 4.5: the representative of a cluster and its row of the reconstruction matrix `Rec = sum(S, 2)`,
//! `S(t, (j, k)) = w_(j,k) / w_rep` (per channel with colour averaging, Sec. 5).
use super::split::Cluster;
use super::store::ChunkStore;
use super::Representative;
use rand::RngExt;
use rand_pcg::Pcg64;

/// The centroid representative is chosen among pairs whose weight is at least this fraction of the
/// cluster's mean non-zero weight: its scale `s / w_p` is then at most `2 |C|`, and a pair the rows
/// barely see (a light whose column is a near-contact spike between the sampled rows) cannot be
/// scaled up by hundreds. Measured on the bundled animation (8 frames, 48x48, 3,032 lights, 100 rows
/// + 200 columns, 8 seeds): without the floor one seed in 8 has a cluster of 24 lights whose
/// representative gets Rec = 975 (6.4% error against 1.6%); floors of 0.25 / 0.5 / 1 give mean errors
/// 1.59 / 1.57 / 1.73% and no outlier.
pub(crate) const CENTROID_WEIGHT_FLOOR: f64 = 0.5;

/// (light, local frame) of the cluster's representative: the pair of largest weight (ties: lowest light,
/// then earliest frame), the pair whose information vector is most aligned with the cluster's summed
/// reduced column among the pairs of at least [`CENTROID_WEIGHT_FLOOR`] times the mean weight, or drawn with probability `w_p / s` (uniformly when all weights are 0).
pub(crate) fn representative(store: &ChunkStore, cl: &Cluster, mode: Representative, rng: &mut Pcg64) -> (u32, usize) {
    let pairs = || cl.lights.iter().flat_map(|&j| (cl.k0..cl.k1).map(move |kk| (j, kk)));
    match mode {
        Representative::MaxWeight => {
            let mut best = (cl.lights[0], cl.k0);
            let mut best_w = f64::NEG_INFINITY;
            for (j, kk) in pairs() {
                let w = store.weight(j as usize, kk);
                if w > best_w {
                    best = (j, kk);
                    best_w = w;
                }
            }
            best
        }
        Representative::Centroid => {
            // P = sum of the cluster's reduced columns; the pair maximising P . x_p minimises
            // |P - (s / w_p) R(:, p)|^2 = |P|^2 - 2 s P . x_p + s^2 among pairs of non-zero weight.
            let r = store.num_rows;
            let mut total = vec![0.0f64; r];
            for (j, kk) in pairs() {
                for (t, &v) in total.iter_mut().zip(store.column(j as usize, kk)) {
                    *t += v as f64;
                }
            }
            // Candidates: pairs of at least CENTROID_WEIGHT_FLOOR times the mean non-zero weight, so
            // the scale Rec = s / w_p stays below 2 |C| (module doc: "Deviations and choices").
            let (mut s, mut nonzero) = (0.0f64, 0usize);
            for (j, kk) in pairs() {
                let w = store.weight(j as usize, kk);
                if w > 0.0 {
                    s += w;
                    nonzero += 1;
                }
            }
            let floor = if nonzero > 0 { CENTROID_WEIGHT_FLOOR * s / nonzero as f64 } else { 0.0 };
            let mut best = (cl.lights[0], cl.k0);
            let mut best_dot = f64::NEG_INFINITY;
            for (j, kk) in pairs() {
                let w = store.weight(j as usize, kk);
                if w > 0.0 && w >= floor {
                    let dot = store.column(j as usize, kk).iter().zip(&total).map(|(&v, t)| v as f64 * t).sum::<f64>() / w;
                    if dot > best_dot {
                        best = (j, kk);
                        best_dot = dot;
                    }
                }
            }
            best
        }
        Representative::Sampled => {
            let total: f64 = pairs().map(|(j, kk)| store.weight(j as usize, kk)).sum();
            if total <= 0.0 {
                let at = rng.random_range(0..cl.size());
                return pairs().nth(at).expect("index below the cluster size");
            }
            let u = rng.random::<f64>() * total;
            let mut acc = 0.0;
            let mut last = (cl.lights[0], cl.k0);
            for (j, kk) in pairs() {
                let w = store.weight(j as usize, kk);
                if w > 0.0 {
                    acc += w;
                    last = (j, kk);
                    if u < acc {
                        return (j, kk);
                    }
                }
            }
            last // round-off put u at the very end
        }
    }
}

/// `Rec(t, k)` for k in K (in order): `sum_{j in J} w_(j,k) / w_rep`, or per channel
/// `sum_j |R_ch(:, j, k)| / |R_ch(:, rep)|` with `color_averaging` (scalar ratio where the representative's
/// channel is 0); all 0 when the representative's weight is 0 (then the whole cluster is zero in R).
pub(crate) fn rec(store: &ChunkStore, cl: &Cluster, rep: (u32, usize), color_averaging: bool) -> Vec<[f32; 3]> {
    let w_rep = store.weight(rep.0 as usize, rep.1);
    let c_rep = store.channel_norm(rep.0 as usize, rep.1);
    (cl.k0..cl.k1)
        .map(|kk| {
            if w_rep <= 0.0 {
                return [0.0; 3];
            }
            let mut w = 0.0f64;
            let mut c = [0.0f64; 3];
            for &j in &cl.lights {
                w += store.weight(j as usize, kk);
                let cn = store.channel_norm(j as usize, kk);
                for ch in 0..3 {
                    c[ch] += cn[ch];
                }
            }
            let grey = w / w_rep;
            std::array::from_fn(|ch| if color_averaging && c_rep[ch] > 0.0 { (c[ch] / c_rep[ch]) as f32 } else { grey as f32 })
        })
        .collect()
}
