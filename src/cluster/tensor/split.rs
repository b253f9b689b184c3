//! Sec. 4.3.2 top-down splitting of a rectangular cluster `J x K` in time or in lights.
//!
//! Both splits order items (frames of K, or lights of J) and take the best cut of the order. An item
//! carries the sum of its pairs' weights `s_i` and of their reduced columns `P_i`; a part made of items
//! costs `(sum s_i)^2 - |sum P_i|^2` (the Sec. 5 low-rank form of the objective), so every cut is
//! evaluated in O(r) from running sums.
use super::store::ChunkStore;
use crate::cluster::normal;
use crate::cluster::splitting::roundoff_to_zero;
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Work (pairs x rows) above which per-item sums run in parallel (results are the same either way).
const PARALLEL_WORK: usize = 1 << 16;

/// A rectangular cluster: lights (ascending) x frames [k0, k1) local to the chunk.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Cluster {
    pub lights: Vec<u32>,
    pub k0: usize,
    pub k1: usize,
}

impl Cluster {
    /// Number of light-frame pairs.
    pub fn size(&self) -> usize {
        self.lights.len() * (self.k1 - self.k0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SplitKind {
    Time,
    Light,
}

pub(crate) struct Split {
    pub kind: SplitKind,
    pub left: Cluster,
    pub right: Cluster,
    pub cost_left: f64,
    pub cost_right: f64,
}

fn add(acc: &mut [f64], column: &[f32]) {
    for (a, &v) in acc.iter_mut().zip(column) {
        *a += v as f64;
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `(sum_p w_p)^2 - |sum_p R(:, p)|^2` over the pairs of the cluster (clamped at round-off).
pub(crate) fn cluster_cost(store: &ChunkStore, cl: &Cluster) -> f64 {
    let (s, p) = time_items(store, cl);
    let r = store.num_rows;
    let total_s: f64 = s.iter().sum();
    let mut total = vec![0.0f64; r];
    for item in p.chunks(r) {
        for (t, v) in total.iter_mut().zip(item) {
            *t += v;
        }
    }
    roundoff_to_zero(total_s * total_s - dot(&total, &total), total_s)
}

/// Per-item sums computed by `item(index, s, p)`, in parallel when the work is large.
fn items(count: usize, r: usize, work: usize, item: impl Fn(usize, &mut f64, &mut [f64]) + Sync) -> (Vec<f64>, Vec<f64>) {
    let mut s = vec![0.0f64; count];
    let mut p = vec![0.0f64; count * r];
    if work >= PARALLEL_WORK {
        s.par_iter_mut().zip(p.par_chunks_mut(r.max(1))).enumerate().for_each(|(i, (s, p))| item(i, s, p));
    } else {
        s.iter_mut().zip(p.chunks_mut(r.max(1))).enumerate().for_each(|(i, (s, p))| item(i, s, p));
    }
    (s, p)
}

/// Frames of the cluster as items: `s_k = sum_j w_(j,k)`, `P_k = sum_j R(:, j, k)`.
fn time_items(store: &ChunkStore, cl: &Cluster) -> (Vec<f64>, Vec<f64>) {
    let r = store.num_rows;
    items(cl.k1 - cl.k0, r, cl.size() * r, |i, s, p| {
        for &j in &cl.lights {
            *s += store.weight(j as usize, cl.k0 + i);
            add(p, store.column(j as usize, cl.k0 + i));
        }
    })
}

/// Lights of the cluster as items: `s_j = sum_k w_(j,k)`, `P_j = sum_k R(:, j, k)` over K.
fn light_items(store: &ChunkStore, cl: &Cluster) -> (Vec<f64>, Vec<f64>) {
    let r = store.num_rows;
    items(cl.lights.len(), r, cl.size() * r, |i, s, p| {
        let j = cl.lights[i] as usize;
        for kk in cl.k0..cl.k1 {
            *s += store.weight(j, kk);
            add(p, store.column(j, kk));
        }
    })
}

/// Best cut of items in `order`: (number of items left of the cut, cost left, cost right). The cost
/// of a part is `(sum s)^2 - |sum P|^2`; ties (within `1e-12 s^2`) go to the most balanced cut.
fn best_cut(s: &[f64], p: &[f64], r: usize, order: &[usize]) -> (usize, f64, f64) {
    let total_s: f64 = order.iter().map(|&i| s[i]).sum();
    let mut total = vec![0.0f64; r];
    for &i in order {
        for (t, v) in total.iter_mut().zip(&p[i * r..(i + 1) * r]) {
            *t += v;
        }
    }
    let tie = 1e-12 * total_s * total_s;
    let len = order.len();
    let balance = |c: usize| (2 * c).abs_diff(len);
    let mut left = vec![0.0f64; r];
    let mut right = vec![0.0f64; r];
    let mut s_left = 0.0f64;
    let mut best = (0usize, f64::INFINITY, 0.0, 0.0);
    for (pos, &i) in order.iter().enumerate().take(len - 1) {
        s_left += s[i];
        for ((l, rt), (t, v)) in left.iter_mut().zip(right.iter_mut()).zip(total.iter().zip(&p[i * r..(i + 1) * r])) {
            *l += v;
            *rt = t - *l;
        }
        let s_right = (total_s - s_left).max(0.0);
        let cost_left = roundoff_to_zero(s_left * s_left - dot(&left, &left), s_left);
        let cost_right = roundoff_to_zero(s_right * s_right - dot(&right, &right), s_right);
        let (cut, sum) = (pos + 1, cost_left + cost_right);
        if sum < best.1 - tie || ((sum - best.1).abs() <= tie && balance(cut) < balance(best.0)) {
            best = (cut, sum, cost_left, cost_right);
        }
    }
    (best.0, best.2, best.3)
}

/// Index drawn with probability proportional to `weights` among `allowed` ones (uniformly when they
/// all weigh 0).
fn draw(weights: &[f64], skip: Option<usize>, rng: &mut Pcg64) -> usize {
    let allowed = |i: usize| Some(i) != skip;
    let total: f64 = weights.iter().enumerate().filter(|&(i, _)| allowed(i)).map(|(_, w)| w).sum();
    if total > 0.0 {
        let u = rng.random::<f64>() * total;
        let mut acc = 0.0;
        let mut last = None;
        for (i, &w) in weights.iter().enumerate() {
            if allowed(i) && w > 0.0 {
                acc += w;
                last = Some(i);
                if u < acc {
                    return i;
                }
            }
        }
        return last.unwrap_or(0);
    }
    let candidates: Vec<usize> = (0..weights.len()).filter(|&i| allowed(i)).collect();
    candidates[rng.random_range(0..candidates.len())]
}

/// Light split: order the lights by the projection of their information-vector slabs on the line
/// through two lights drawn by total weight over K; best cut of that order.
fn light_split(store: &ChunkStore, cl: &Cluster, rng: &mut Pcg64) -> (Vec<u32>, Vec<u32>, f64, f64) {
    let (r, nk) = (store.num_rows, cl.k1 - cl.k0);
    let (s, p) = light_items(store, cl);
    let a = draw(&s, None, rng);
    let b = draw(&s, Some(a), rng);
    // Direction x_b - x_a over the frames of K (r |K| values).
    let info = |j: usize, kk: usize, i: usize| {
        let w = store.weight(j, kk);
        if w > 0.0 {
            store.column(j, kk)[i] as f64 / w
        } else {
            0.0
        }
    };
    let (ja, jb) = (cl.lights[a] as usize, cl.lights[b] as usize);
    let mut direction: Vec<f64> = (0..nk * r).map(|at| info(jb, cl.k0 + at / r, at % r) - info(ja, cl.k0 + at / r, at % r)).collect();
    if direction.iter().all(|&v| v == 0.0) {
        direction.iter_mut().for_each(|v| *v = normal(rng));
    }
    let project = |i: usize| {
        let j = cl.lights[i] as usize;
        let mut t = 0.0f64;
        for kk in 0..nk {
            let w = store.weight(j, cl.k0 + kk);
            if w > 0.0 {
                let col = store.column(j, cl.k0 + kk);
                t += col.iter().zip(&direction[kk * r..(kk + 1) * r]).map(|(&v, d)| v as f64 * d).sum::<f64>() / w;
            }
        }
        t
    };
    let t: Vec<f64> = if cl.size() * r >= PARALLEL_WORK {
        (0..cl.lights.len()).into_par_iter().map(project).collect()
    } else {
        (0..cl.lights.len()).map(project).collect()
    };
    let mut order: Vec<usize> = (0..cl.lights.len()).collect();
    order.sort_unstable_by(|&x, &y| t[x].total_cmp(&t[y]).then(x.cmp(&y)));
    let (cut, cost_left, cost_right) = best_cut(&s, &p, r, &order);
    let mut left: Vec<u32> = order[..cut].iter().map(|&i| cl.lights[i]).collect();
    let mut right: Vec<u32> = order[cut..].iter().map(|&i| cl.lights[i]).collect();
    left.sort_unstable();
    right.sort_unstable();
    (left, right, cost_left, cost_right)
}

/// Splits a cluster of at least two pairs in time or lights, whichever leaves the lower cost, the time
/// split's cost multiplied by `time_weight` for the comparison (1: the paper; > 1 favours light splits,
/// the weighting the paper's Sec. 4.3.2 suggests; ties: lights).
pub(crate) fn split(store: &ChunkStore, cl: &Cluster, rng: &mut Pcg64, time_weight: f64) -> Split {
    let r = store.num_rows;
    let time = (cl.k1 - cl.k0 >= 2).then(|| {
        let (s, p) = time_items(store, cl);
        let order: Vec<usize> = (0..s.len()).collect();
        let total: f64 = s.iter().sum();
        (best_cut(&s, &p, r, &order), total)
    });
    let light = (cl.lights.len() >= 2).then(|| light_split(store, cl, rng));
    let time_split = |((cut, cost_left, cost_right), _): ((usize, f64, f64), f64)| Split {
        kind: SplitKind::Time,
        left: Cluster { lights: cl.lights.clone(), k0: cl.k0, k1: cl.k0 + cut },
        right: Cluster { lights: cl.lights.clone(), k0: cl.k0 + cut, k1: cl.k1 },
        cost_left,
        cost_right,
    };
    let light_split = |(left, right, cost_left, cost_right): (Vec<u32>, Vec<u32>, f64, f64)| Split {
        kind: SplitKind::Light,
        left: Cluster { lights: left, k0: cl.k0, k1: cl.k1 },
        right: Cluster { lights: right, k0: cl.k0, k1: cl.k1 },
        cost_left,
        cost_right,
    };
    match (time, light) {
        (Some(t), Some(l)) => {
            let tie = 1e-12 * t.1 * t.1;
            if time_weight * ((t.0).1 + (t.0).2) < l.2 + l.3 - tie {
                time_split(t)
            } else {
                light_split(l)
            }
        }
        (Some(t), None) => time_split(t),
        (None, Some(l)) => light_split(l),
        (None, None) => unreachable!("split needs a cluster of at least two light-frame pairs"),
    }
}

#[cfg(test)]
mod tests;
