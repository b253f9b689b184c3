use super::*;
use rand::{RngExt, SeedableRng};

/// The definition, step by step: carry each representative's image through the mappings frame by frame
/// (materialising mapped images) and add its scaled copy where Rec is nonzero.
fn naive(f: usize, m: usize, columns: &[f32], source: &[u32], rec: &[f32], fw: &[Vec<u32>], bw: &[Vec<u32>]) -> Vec<f32> {
    let mut acc = vec![0f32; f * m * 3];
    let c = source.len();
    let mut order: Vec<usize> = (0..c).collect();
    order.sort_by_key(|&r| source[r]);
    // Per frame, the terms in the implementation's order: groups by k0, input order within.
    for k in 0..f {
        for &r in &order {
            let k0 = source[r] as usize;
            let s = &rec[(r * f + k) * 3..(r * f + k) * 3 + 3];
            if s == [0.0; 3] {
                continue;
            }
            let mut img: Vec<Option<[f32; 3]>> =
                (0..m).map(|i| Some([columns[(r * m + i) * 3], columns[(r * m + i) * 3 + 1], columns[(r * m + i) * 3 + 2]])).collect();
            let mut q = k0;
            while q != k {
                let (map, nq) = if k > q { (&fw[q], q + 1) } else { (&bw[q - 1], q - 1) };
                img = map.iter().map(|&s| if s == NO_SOURCE { None } else { img[s as usize] }).collect();
                q = nq;
            }
            for i in 0..m {
                if let Some(v) = img[i] {
                    for ch in 0..3 {
                        acc[(k * m + i) * 3 + ch] += s[ch] * v[ch];
                    }
                }
            }
        }
    }
    acc
}

fn refs(v: &[Vec<u32>]) -> Vec<&[u32]> {
    v.iter().map(|x| x.as_slice()).collect()
}

#[test]
fn matches_the_definition_on_random_mappings() {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    let (f, m, c) = (6, 3000, 9);
    let columns: Vec<f32> = (0..c * m * 3).map(|_| rng.random::<f32>()).collect();
    let source: Vec<u32> = (0..c).map(|r| (r * 5 % f) as u32).collect();
    // Each representative serves a contiguous frame range around its frame (zero elsewhere).
    let mut rec = vec![0f32; c * f * 3];
    for r in 0..c {
        let k0 = source[r] as usize;
        let (lo, hi) = (k0.saturating_sub(r % 3), (k0 + r % 4).min(f - 1));
        for k in lo..=hi {
            for ch in 0..3 {
                rec[(r * f + k) * 3 + ch] = 0.5 + rng.random::<f32>();
            }
        }
    }
    let map = |rng: &mut rand_pcg::Pcg32| -> Vec<u32> {
        (0..m).map(|_| if rng.random::<f32>() < 0.05 { NO_SOURCE } else { rng.random_range(0..m as u32) }).collect()
    };
    let fw: Vec<Vec<u32>> = (0..f - 1).map(|_| map(&mut rng)).collect();
    let bw: Vec<Vec<u32>> = (0..f - 1).map(|_| map(&mut rng)).collect();
    let mut acc = vec![0f32; f * m * 3];
    accumulate(&mut acc, f, m, &columns, &source, &rec, &refs(&fw), &refs(&bw)).unwrap();
    let want = naive(f, m, &columns, &source, &rec, &fw, &bw);
    assert_eq!(acc, want);
    // Accumulating in two batches gives the same sums when the batches split by source frame.
    let mut acc2 = vec![0f32; f * m * 3];
    let (a, b): (Vec<usize>, Vec<usize>) = (0..c).partition(|&r| source[r] < 3);
    for part in [a, b] {
        let cols: Vec<f32> = part.iter().flat_map(|&r| columns[r * m * 3..(r + 1) * m * 3].to_vec()).collect();
        let src: Vec<u32> = part.iter().map(|&r| source[r]).collect();
        let rc: Vec<f32> = part.iter().flat_map(|&r| rec[r * f * 3..(r + 1) * f * 3].to_vec()).collect();
        accumulate(&mut acc2, f, m, &cols, &src, &rc, &refs(&fw), &refs(&bw)).unwrap();
    }
    assert_eq!(acc2, want);
}

#[test]
fn identity_mappings_sum_scaled_columns() {
    let (f, m) = (3, 4);
    let id: Vec<Vec<u32>> = vec![(0..m as u32).collect(); f - 1];
    let columns: Vec<f32> = (0..2 * m * 3).map(|x| x as f32).collect();
    let source = [1u32, 2];
    let mut rec = vec![0f32; 2 * f * 3];
    rec[..9].copy_from_slice(&[1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0]); // rep 0: frames 0, 1
    rec[9..].copy_from_slice(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0]); // rep 1: frame 2
    let mut acc = vec![0f32; f * m * 3];
    accumulate(&mut acc, f, m, &columns, &source, &rec, &refs(&id), &refs(&id)).unwrap();
    for i in 0..m * 3 {
        assert_eq!(acc[i], columns[i]);
        assert_eq!(acc[m * 3 + i], 2.0 * columns[i]);
        assert_eq!(acc[2 * m * 3 + i], 3.0 * columns[m * 3 + i]);
    }
}

#[test]
fn a_shift_moves_the_image() {
    // Frame k+1 is frame k shifted right by one pixel (1D image of m pixels).
    let (f, m) = (3, 5);
    let fw: Vec<Vec<u32>> = vec![(0..m as u32).map(|i| if i == 0 { NO_SOURCE } else { i - 1 }).collect(); f - 1];
    let bw: Vec<Vec<u32>> = vec![(0..m as u32).map(|i| if i + 1 == m as u32 { NO_SOURCE } else { i + 1 }).collect(); f - 1];
    let columns: Vec<f32> = (0..m).flat_map(|i| [i as f32 + 1.0; 3]).collect();
    let rec = vec![1f32; f * 3];
    let mut acc = vec![0f32; f * m * 3];
    accumulate(&mut acc, f, m, &columns, &[1], &rec, &refs(&fw), &refs(&bw)).unwrap();
    let red = |k: usize| -> Vec<f32> { (0..m).map(|i| acc[(k * m + i) * 3]).collect() };
    assert_eq!(red(1), vec![1.0, 2.0, 3.0, 4.0, 5.0]);
    assert_eq!(red(2), vec![0.0, 1.0, 2.0, 3.0, 4.0]);
    assert_eq!(red(0), vec![2.0, 3.0, 4.0, 5.0, 0.0]);
}

#[test]
fn bad_input_is_named() {
    let id = vec![vec![0u32, 1]];
    let mut acc = vec![0f32; 2 * 2 * 3];
    let cols = vec![0f32; 6];
    let e = accumulate(&mut acc, 2, 2, &cols, &[2], &[0.0; 6], &refs(&id), &refs(&id)).unwrap_err();
    assert!(e.to_string().contains("representative 0 is in frame 2"), "{e}");
    let bad = vec![vec![0u32, 7]];
    let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 6], &refs(&bad), &refs(&id)).unwrap_err();
    assert!(e.to_string().contains("forward mapping 0: pixel 1 maps to 7"), "{e}");
    let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 3], &refs(&id), &refs(&id)).unwrap_err();
    assert!(e.to_string().contains("Rec has 3 floats"), "{e}");
    let e = accumulate(&mut acc, 2, 2, &cols, &[0], &[0.0; 6], &[], &[]).unwrap_err();
    assert!(e.to_string().contains("0 forward and 0 backward mappings for 2 frames"), "{e}");
}
