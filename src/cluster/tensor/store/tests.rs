use super::*;
use crate::cluster::columns::project;
use rand::SeedableRng;

#[test]
fn slabs_are_the_unfolded_tensor_and_weights_the_column_norms() {
    let (r, n, f) = (3, 4, 5);
    let data: Vec<f32> = (0..r * n * f * 3).map(|v| ((v * 7919) % 23) as f32 * 0.1).collect();
    let t = ReducedTensor::new(&data, r, n, f, 3).unwrap();
    let store = ChunkStore::build(&t, 1, 4);
    let scalar = |i: usize, j: usize, k: usize| (0..3).map(|ch| t.channel(i, j, k, ch).powi(2)).sum::<f64>().sqrt();
    let slabs = store.slabs();
    assert_eq!(slabs.num_rows(), r * 3);
    for j in 0..n {
        for kk in 0..3 {
            let mut sq = 0.0;
            let mut ch_sq = [0.0f64; 3];
            for i in 0..r {
                // Row kk * r + i of reshape(permute(R, 1, 3, 2), r f, n) (Matlab's column-major order).
                assert!((slabs.scalar(kk * r + i, j) - scalar(i, j, 1 + kk)).abs() < 1e-6);
                assert_eq!(store.column(j, kk)[i], scalar(i, j, 1 + kk) as f32);
                sq += scalar(i, j, 1 + kk).powi(2);
                for ch in 0..3 {
                    ch_sq[ch] += t.channel(i, j, 1 + kk, ch).powi(2);
                }
            }
            assert!((store.weight(j, kk) - sq.sqrt()).abs() < 1e-5);
            for ch in 0..3 {
                assert!((store.channel_norm(j, kk)[ch] - ch_sq[ch].sqrt()).abs() < 1e-9);
            }
        }
    }
    // Below projection_dim the features are the slabs themselves.
    let features = project(&slabs, &[2, 0], 50, &mut rand_pcg::Pcg64::seed_from_u64(0));
    assert_eq!(features.dim, r * 3);
    assert_eq!(features.column(0)[4], slabs.scalar(4, 2));
    assert_eq!(features.column(1)[7], slabs.scalar(7, 0));
}
