//! Per-column statistics, the Sec. 4 random projection and the Sec. 3.4 cluster costs of the reduced
//! matrix. Work is split into fixed column (or row) blocks processed with rayon, products use faer
//! sequentially inside a block, and partial sums are added in block order: results do not depend on
//! the number of threads.
use super::{normal, ReducedMatrix};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Columns per parallel block.
const COLUMN_BLOCK: usize = 512;
/// Rows per parallel block of [`cluster_costs`].
const ROW_BLOCK: usize = 8;

/// Norms of the reduced columns: `norm[j] = |rho_j|` (scalar elements) and the per-channel 2-norms
/// `channel_norm[j][k] = |rho^c_j|_k` of Sec. 4 (so that `norm^2 = sum_k channel_norm_k^2` for RGB).
#[derive(Debug, Clone)]
pub struct ColumnStats {
    pub norm: Vec<f64>,
    pub channel_norm: Vec<[f64; 3]>,
}

pub fn column_stats(reduced: &ReducedMatrix) -> ColumnStats {
    let (r, n) = (reduced.num_rows(), reduced.num_columns());
    let blocks: Vec<Vec<[f64; 3]>> = (0..n.div_ceil(COLUMN_BLOCK))
        .into_par_iter()
        .map(|b| {
            let (j0, j1) = (b * COLUMN_BLOCK, ((b + 1) * COLUMN_BLOCK).min(n));
            let mut sq = vec![[0.0f64; 3]; j1 - j0];
            for i in 0..r {
                for (j, acc) in (j0..j1).zip(sq.iter_mut()) {
                    for (k, a) in acc.iter_mut().enumerate() {
                        let v = reduced.channel(i, j, k);
                        *a += v * v;
                    }
                }
            }
            sq
        })
        .collect();
    let squares: Vec<[f64; 3]> = blocks.into_iter().flatten().collect();
    let one_channel = reduced.channels() == 1;
    let norm = squares.iter().map(|s| if one_channel { s[0].sqrt() } else { (s[0] + s[1] + s[2]).sqrt() }).collect();
    let channel_norm = squares.iter().map(|s| s.map(f64::sqrt)).collect();
    ColumnStats { norm, channel_norm }
}

/// The vectors the clustering works on: column i is the (projected) reduced column of `nonzero[i]`.
#[derive(Debug, Clone)]
pub struct Features {
    /// Dimension r' (r when no projection happened).
    pub dim: usize,
    /// `dim x m`, column-major (column i contiguous).
    pub data: Vec<f64>,
    /// Euclidean norm of each column.
    pub norm: Vec<f64>,
}

impl Features {
    #[inline]
    pub fn column(&self, i: usize) -> &[f64] {
        &self.data[i * self.dim..(i + 1) * self.dim]
    }
    pub fn len(&self) -> usize {
        self.norm.len()
    }
    pub fn is_empty(&self) -> bool {
        self.norm.is_empty()
    }
    pub fn as_mat(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.data, self.dim, self.len())
    }
}

/// Anything whose scalar columns can be projected: the reduced matrix of MRCS, and the unfolded slabs
/// `reshape(permute(R, 1, 3, 2), r f, n)` of the reduced tensor (tensor clustering's initialisation).
pub trait ScalarColumns: Sync {
    /// Length of a column (r for the reduced matrix, r f for the unfolded tensor).
    fn num_rows(&self) -> usize;
    /// Scalar element (row, column).
    fn scalar(&self, row: usize, column: usize) -> f64;
}

impl ScalarColumns for ReducedMatrix<'_> {
    fn num_rows(&self) -> usize {
        ReducedMatrix::num_rows(self)
    }
    #[inline]
    fn scalar(&self, row: usize, column: usize) -> f64 {
        ReducedMatrix::scalar(self, row, column)
    }
}

/// Sec. 4 random projection: the scalar reduced columns `nonzero` multiplied by a `projection_dim x r`
/// matrix of N(0, 1/projection_dim) entries when r > projection_dim; otherwise copied unchanged.
pub fn project<M: ScalarColumns>(reduced: &M, nonzero: &[u32], projection_dim: usize, rng: &mut Pcg64) -> Features {
    let r = reduced.num_rows();
    let dim = if r > projection_dim { projection_dim } else { r };
    let projection: Option<Vec<f64>> = (r > projection_dim).then(|| {
        let scale = 1.0 / (projection_dim as f64).sqrt();
        (0..dim * r).map(|_| normal(rng) * scale).collect()
    });
    let m = nonzero.len();
    let mut data = vec![0.0f64; dim * m];
    data.par_chunks_mut(dim * COLUMN_BLOCK).zip(nonzero.par_chunks(COLUMN_BLOCK)).for_each(|(out, cols)| {
        let b = cols.len();
        // Scalar block S (r x b, column-major).
        let mut block = vec![0.0f64; r * b];
        for i in 0..r {
            for (jj, &j) in cols.iter().enumerate() {
                block[jj * r + i] = reduced.scalar(i, j as usize);
            }
        }
        match &projection {
            Some(g) => {
                let g = MatRef::from_column_major_slice(g, dim, r);
                let s = MatRef::from_column_major_slice(&block, r, b);
                let dst = MatMut::from_column_major_slice_mut(out, dim, b);
                matmul(dst, Accum::Replace, g, s, 1.0, Par::Seq);
            }
            None => out.copy_from_slice(&block),
        }
    });
    let norm = data.chunks(dim.max(1)).map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
    Features { dim, data, norm }
}

/// Sec. 3.4 cost of every cluster of a partition on the unprojected scalar matrix:
/// `cost_k = s_k^2 - |sum_{j in C_k} rho_j|^2` (ordered pairs), `s_k = sum_{j in C_k} |rho_j|`, clamped
/// to 0 at round-off level (`1e-12 s_k^2`). `norm` are the column norms of [`column_stats`].
pub fn cluster_costs(reduced: &ReducedMatrix, assignment: &[u32], num_clusters: usize, norm: &[f64]) -> Vec<f64> {
    let (r, n) = (reduced.num_rows(), reduced.num_columns());
    // |sum rho|^2 = sum over rows of (row-wise cluster sums)^2, accumulated per row block.
    let partial: Vec<Vec<f64>> = (0..r.div_ceil(ROW_BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut squares = vec![0.0f64; num_clusters];
            let mut row_sum = vec![0.0f64; num_clusters];
            for i in b * ROW_BLOCK..((b + 1) * ROW_BLOCK).min(r) {
                row_sum.iter_mut().for_each(|v| *v = 0.0);
                for (j, &a) in assignment.iter().enumerate().take(n) {
                    row_sum[a as usize] += reduced.scalar(i, j);
                }
                for (sq, s) in squares.iter_mut().zip(&row_sum) {
                    *sq += s * s;
                }
            }
            squares
        })
        .collect();
    let mut squared_sum = vec![0.0f64; num_clusters];
    for p in &partial {
        for (t, v) in squared_sum.iter_mut().zip(p) {
            *t += v;
        }
    }
    let mut norm_sum = vec![0.0f64; num_clusters];
    for (&a, &nj) in assignment.iter().zip(norm) {
        norm_sum[a as usize] += nj;
    }
    norm_sum.iter().zip(&squared_sum).map(|(&s, q)| super::splitting::roundoff_to_zero(s * s - q, s)).collect()
}

#[cfg(test)]
mod tests;
