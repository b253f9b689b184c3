//! Sec. 3.5 "Clustering by top-down splitting": repeatedly split the cluster of highest cost. A split
//! projects the normalised columns `rho_i / |rho_i|` of the cluster onto a random line (Gaussian
//! direction), sorts them along it and takes the best of the |C| - 1 cuts, where a cut's cost is the sum
//! of the Sec. 3.4 costs of both halves. With `s_L = sum |rho|`, `P_L = sum rho` over the left part and
//! `s, T` over the cluster, `cost = s_L^2 - |P_L|^2 + (s - s_L)^2 - |T - P_L|^2`; `|P_L|^2` and `T . P_L`
//! are updated incrementally, so a split costs O(|C| (r' + log |C|)).
use super::columns::Features;
use super::normal;
use rand_pcg::Pcg64;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Sec. 3.4 cost of a cluster of feature columns: `s^2 - |sum rho|^2` (clamped at 0).
pub fn cluster_cost(features: &Features, members: &[u32]) -> f64 {
    let mut total = vec![0.0f64; features.dim];
    let mut s = 0.0f64;
    for &i in members {
        s += features.norm[i as usize];
        for (t, v) in total.iter_mut().zip(features.column(i as usize)) {
            *t += v;
        }
    }
    roundoff_to_zero(s * s - total.iter().map(|v| v * v).sum::<f64>(), s)
}

/// A cost `s^2 - |sum rho|^2` at round-off level (below `1e-12 s^2`, e.g. parallel columns) is 0.
pub fn roundoff_to_zero(cost: f64, s: f64) -> f64 {
    if cost <= 1e-12 * s * s {
        0.0
    } else {
        cost
    }
}

/// Splits `members` (at least 2) at the best cut along a random line: (left, right, cost_left, cost_right).
pub fn split(features: &Features, members: &[u32], rng: &mut Pcg64) -> (Vec<u32>, Vec<u32>, f64, f64) {
    let d = features.dim;
    let direction: Vec<f64> = (0..d).map(|_| normal(rng)).collect();
    let mut order: Vec<(f64, u32)> = members
        .iter()
        .map(|&i| {
            let col = features.column(i as usize);
            let t: f64 = col.iter().zip(&direction).map(|(a, b)| a * b).sum();
            (t / features.norm[i as usize], i)
        })
        .collect();
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));

    let mut total = vec![0.0f64; d];
    let mut s = 0.0f64;
    for &(_, i) in &order {
        s += features.norm[i as usize];
        for (t, v) in total.iter_mut().zip(features.column(i as usize)) {
            *t += v;
        }
    }
    let total_sq: f64 = total.iter().map(|v| v * v).sum();
    let tie = 1e-12 * s * s;
    let len = order.len();
    let (mut left_sum, mut left_sq, mut total_dot_left, mut s_left) = (vec![0.0f64; d], 0.0f64, 0.0f64, 0.0f64);
    // (cut position = size of the left part, total, left cost, right cost)
    let mut best = (0usize, f64::INFINITY, 0.0, 0.0);
    for (pos, &(_, i)) in order.iter().enumerate().take(len - 1) {
        let col = features.column(i as usize);
        let (mut dot_left, mut dot_total) = (0.0f64, 0.0f64);
        for ((l, t), v) in left_sum.iter().zip(&total).zip(col) {
            dot_left += l * v;
            dot_total += t * v;
        }
        let norm = features.norm[i as usize];
        left_sq += 2.0 * dot_left + norm * norm;
        total_dot_left += dot_total;
        for (l, v) in left_sum.iter_mut().zip(col) {
            *l += v;
        }
        s_left += norm;
        let cost_left = roundoff_to_zero(s_left * s_left - left_sq, s_left);
        let s_right = s - s_left;
        let cost_right = roundoff_to_zero(s_right * s_right - (total_sq - 2.0 * total_dot_left + left_sq), s_right);
        let cut = pos + 1;
        let sum = cost_left + cost_right;
        let balance = |c: usize| (2 * c).abs_diff(len);
        if sum < best.1 - tie || ((sum - best.1).abs() <= tie && balance(cut) < balance(best.0)) {
            best = (cut, sum, cost_left, cost_right);
        }
    }
    let left = order[..best.0].iter().map(|&(_, i)| i).collect();
    let right = order[best.0..].iter().map(|&(_, i)| i).collect();
    (left, right, best.2, best.3)
}

/// Heap entry: highest cost first, then largest, then lowest id.
#[derive(PartialEq)]
pub(crate) struct Candidate {
    pub cost: f64,
    pub size: usize,
    pub id: usize,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.cost.total_cmp(&other.cost).then(self.size.cmp(&other.size)).then(other.id.cmp(&self.id))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Splits the highest-cost cluster until there are `target` clusters (or every cluster is a singleton).
/// Errors: only `Error::Interrupted` (Ctrl-C, checked between splits).
pub fn split_until(features: &Features, clusters: &mut Vec<Vec<u32>>, target: usize, rng: &mut Pcg64) -> crate::error::Result<()> {
    let mut heap: BinaryHeap<Candidate> = clusters
        .iter()
        .enumerate()
        .filter(|(_, c)| c.len() >= 2)
        .map(|(id, c)| Candidate { cost: cluster_cost(features, c), size: c.len(), id })
        .collect();
    while clusters.len() < target {
        crate::interrupt::check()?;
        let Some(top) = heap.pop() else { break };
        let (left, right, cost_left, cost_right) = split(features, &clusters[top.id], rng);
        let new_id = clusters.len();
        for (id, part, cost) in [(top.id, &left, cost_left), (new_id, &right, cost_right)] {
            if part.len() >= 2 {
                heap.push(Candidate { cost, size: part.len(), id });
            }
        }
        clusters[top.id] = left;
        clusters.push(right);
    }
    Ok(())
}

#[cfg(test)]
mod tests;
