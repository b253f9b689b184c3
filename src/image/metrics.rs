//! Image error metrics. `a` is the test image, `b` the reference; both `[f32; 3]` pixels of equal length.
//! Sums are accumulated in f64. All functions panic if the lengths differ (a programming error).
fn check(a: &[[f32; 3]], b: &[[f32; 3]]) {
    assert_eq!(a.len(), b.len(), "images have different sizes");
}

fn sum_sq(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).powi(2))).sum()
}

/// Relative L2 error `||a - b|| / ||b||` over all channels (infinite if `b` is zero and `a` is not, 0 if
/// both are zero).
pub fn relative_l2(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    check(a, b);
    let num = sum_sq(a, b).sqrt();
    let den = b.iter().flat_map(|y| y.iter().map(|&v| (v as f64).powi(2))).sum::<f64>().sqrt();
    if num == 0.0 {
        0.0
    } else {
        num / den
    }
}

/// Mean squared error per channel value.
pub fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    check(a, b);
    if a.is_empty() {
        return 0.0;
    }
    sum_sq(a, b) / (3 * a.len()) as f64
}

/// Root mean squared error per channel value.
pub fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    mse(a, b).sqrt()
}

/// Mean absolute error per channel value.
pub fn mae(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    check(a, b);
    if a.is_empty() {
        return 0.0;
    }
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).abs())).sum::<f64>() / (3 * a.len()) as f64
}

/// Largest absolute channel difference.
pub fn max_abs_error(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    check(a, b);
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).abs())).fold(0.0, f64::max)
}

/// Relative MSE as in denoising papers: mean over channel values of `(a - b)^2 / (b^2 + eps)`.
pub fn relative_mse(a: &[[f32; 3]], b: &[[f32; 3]], eps: f64) -> f64 {
    check(a, b);
    if a.is_empty() {
        return 0.0;
    }
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).powi(2) / ((y[c] as f64).powi(2) + eps))).sum::<f64>()
        / (3 * a.len()) as f64
}

/// Fraction of pixels whose every channel satisfies `|a - b| <= abs + rel * |b|` (numpy `isclose`).
/// A NaN in either image makes that pixel fail.
pub fn fraction_within(a: &[[f32; 3]], b: &[[f32; 3]], rel: f64, abs: f64) -> f64 {
    check(a, b);
    if a.is_empty() {
        return 1.0;
    }
    let ok = a.iter().zip(b).filter(|(x, y)| (0..3).all(|c| (x[c] as f64 - y[c] as f64).abs() <= abs + rel * (y[c] as f64).abs())).count();
    ok as f64 / a.len() as f64
}

#[cfg(test)]
mod tests;
