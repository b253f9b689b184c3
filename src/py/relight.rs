//! Thin bindings of `relight::haar` (2D Haar wavelets of the gather image and the paper's culling), for
//! tests and experiments.
use super::util::array;
use crate::error::Error;
use crate::relight::haar;
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// (data, side, channels, shape) of an (s, s) or (s, s, C) float32 image with finite values.
fn image(name: &str, a: &PyReadonlyArrayDyn<'_, f32>) -> PyResult<(Vec<f32>, usize, usize, Vec<usize>)> {
    let shape = a.shape().to_vec();
    let (side, channels) = match *shape.as_slice() {
        [r, c] if r == c => (r, 1),
        [r, c, ch] if r == c && ch >= 1 => (r, ch),
        _ => return Err(Error::invalid(format!("{name} must have shape (s, s) or (s, s, C) with s a power of 2, got {shape:?}")).into()),
    };
    let data: Vec<f32> = a.as_array().iter().copied().collect();
    if let Some(k) = data.iter().position(|v| !v.is_finite()) {
        let (px, ch) = (k / channels, k % channels);
        return Err(Error::invalid(format!(
            "{name}[{}, {}{}] is not finite: {}",
            px / side,
            px % side,
            if shape.len() == 3 { format!(", {ch}") } else { String::new() },
            data[k]
        ))
        .into());
    }
    haar::check_image(data.len(), side, channels)?;
    Ok((data, side, channels, shape))
}

/// Forward 2D Haar transform of a gather image (non-standard decomposition, orthonormal; Hašan et al.
/// 2006 Sec. 3.3 and 5): each pass maps 2 x 2 blocks [a b; c d] to (a+b+c+d)/2 (top-left quadrant, the
/// next pass's input), (a-b+c-d)/2 (top-right), (a+b-c-d)/2 (bottom-left), (a-b-c+d)/2 (bottom-right).
///
/// Args:
///     image: (s, s) or (s, s, C) float32, s a power of 2, finite.
///
/// Returns:
///     float32 array of the same shape: the wavelet coefficients (channels transformed independently).
///
/// Raises:
///     ValueError: a non-square or non-power-of-2 shape, or a non-finite value (its index named).
#[pyfunction]
pub fn haar2d<'py>(py: Python<'py>, image: PyReadonlyArrayDyn<'py, f32>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let (mut data, side, channels, shape) = self::image("image", &image)?;
    py.detach(|| haar::forward(&mut data, side, channels))?;
    array(py, data, &shape)
}

/// Inverse of `haar2d` (same arguments and errors, for coefficients).
#[pyfunction]
pub fn ihaar2d<'py>(py: Python<'py>, coeffs: PyReadonlyArrayDyn<'py, f32>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let (mut data, side, channels, shape) = image("coeffs", &coeffs)?;
    py.detach(|| haar::inverse(&mut data, side, channels))?;
    array(py, data, &shape)
}

/// (side, side) int64: the number of pixels each Haar basis function of a side x side transform covers
/// (side^2 for the scaling coefficient at (0, 0); (side / 2^L)^2 for a detail with max(row, col) in
/// [2^L, 2^(L+1))).
///
/// Raises:
///     ValueError: side not a power of 2 in 1 ..= 2^15.
#[pyfunction]
pub fn haar_support_area<'py>(py: Python<'py>, side: i64) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    if !(1..=1 << 15).contains(&side) || !(side as u64).is_power_of_two() {
        return Err(Error::invalid(format!("side must be a power of 2 in 1 ..= 32768, got {side}")).into());
    }
    let s = side as usize;
    array(py, (0..s * s).map(|i| haar::support_area(i, s) as i64).collect(), &[s, s])
}

/// Area-weighted culling of one wavelet-projected matrix row (Sec. 4.3): keeps the `keep` coefficients
/// of highest |c| * support area (|c|: 2-norm over channels; ties: lower index; zeros never kept).
///
/// Args:
///     coeffs: (s, s) or (s, s, C) float32 wavelet coefficients (`haar2d` of the row's gather image).
///     keep: number of coefficients to keep (>= 0; more than the non-zeros keeps them all).
///
/// Returns:
///     (indices (k,) int64 ascending, row-major into the s x s image; values (k,) or (k, C) float32).
///
/// Raises:
///     ValueError: bad shape, non-finite value, negative keep.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn haar_cull_area_weighted<'py>(
    py: Python<'py>,
    coeffs: PyReadonlyArrayDyn<'py, f32>,
    keep: i64,
) -> PyResult<(Bound<'py, PyArrayDyn<i64>>, Bound<'py, PyArrayDyn<f32>>)> {
    let (data, side, channels, shape) = image("coeffs", &coeffs)?;
    let keep = usize::try_from(keep).map_err(|_| Error::invalid(format!("keep must be >= 0, got {keep}")))?;
    let row = py.detach(|| haar::cull_area_weighted(&data, side, channels, keep))?;
    let k = row.index.len();
    let values_shape = if shape.len() == 3 { vec![k, channels] } else { vec![k] };
    Ok((array(py, row.index.iter().map(|&i| i as i64).collect(), &[k])?, array(py, row.value, &values_shape)?))
}

/// Transport-weighted on-the-fly culling of wavelet lights (Sec. 3.5): the indices j whose light
/// intensity norm times image norm, |light[j]| * image_norms[j], is at least `epsilon`.
///
/// Args:
///     light: (n,) or (n, C) float32 wavelet-projected lighting (flattened `haar2d` of the gather image).
///     image_norms: (n,) float32 2-norms of the wavelet lights' images (columns of the projected
///         transfer matrix), >= 0.
///     epsilon: threshold >= 0 (0 keeps every light).
///
/// Returns:
///     (k,) int64 ascending indices of the lights kept.
///
/// Raises:
///     ValueError: mismatched lengths, non-finite values, negative norms or epsilon.
#[pyfunction]
pub fn cull_wavelet_lights<'py>(
    py: Python<'py>,
    light: PyReadonlyArrayDyn<'py, f32>,
    image_norms: PyReadonlyArrayDyn<'py, f32>,
    epsilon: f32,
) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    let channels = match *light.shape() {
        [_] => 1,
        [_, c] => c,
        ref s => return Err(Error::invalid(format!("light must have shape (n,) or (n, C), got {s:?}")).into()),
    };
    if image_norms.shape().len() != 1 {
        return Err(Error::invalid(format!("image_norms must have shape (n,), got {:?}", image_norms.shape())).into());
    }
    let l: Vec<f32> = light.as_array().iter().copied().collect();
    let norms: Vec<f32> = image_norms.as_array().iter().copied().collect();
    let kept = py.detach(|| haar::cull_wavelet_lights(&l, channels, &norms, epsilon))?;
    let k = kept.len();
    array(py, kept.into_iter().map(|j| j as i64).collect(), &[k])
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(haar2d, m)?)?;
    m.add_function(wrap_pyfunction!(ihaar2d, m)?)?;
    m.add_function(wrap_pyfunction!(haar_support_area, m)?)?;
    m.add_function(wrap_pyfunction!(haar_cull_area_weighted, m)?)?;
    m.add_function(wrap_pyfunction!(cull_wavelet_lights, m)?)?;
    Ok(())
}
