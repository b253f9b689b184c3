//! EXR / PNG I/O for (H, W, 3) float32 images: reading, and encoding to bytes (files are written by the
//! Python writer path, `manylights._utils.files.atomic_write`).
use super::util::array;
use crate::error::Error;
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::PathBuf;

fn hw3(img: &PyReadonlyArrayDyn<'_, f32>) -> PyResult<(u32, u32, Vec<[f32; 3]>)> {
    let shape = img.shape();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(Error::invalid(format!("image must have shape (H, W, 3), got {shape:?}")).into());
    }
    if shape[0] == 0 || shape[1] == 0 {
        return Err(Error::invalid(format!("image is empty: shape {shape:?}")).into());
    }
    let a = img.as_array();
    let data: Vec<[f32; 3]> = a
        .as_standard_layout()
        .as_slice()
        .ok_or_else(|| Error::invalid("image is not contiguous"))?
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Ok((shape[1] as u32, shape[0] as u32, data))
}

/// The bytes of a float32 RGB OpenEXR file of an (H, W, 3) image (written by the Python writer path).
#[pyfunction]
pub fn encode_exr<'py>(py: Python<'py>, image: PyReadonlyArrayDyn<'py, f32>) -> PyResult<Bound<'py, PyBytes>> {
    let (w, h, data) = hw3(&image)?;
    let bytes = py.detach(move || crate::image::encode_exr(w, h, &data))?;
    Ok(PyBytes::new(py, &bytes))
}

/// Read an OpenEXR file as (H, W, 3) float32 (RGB; Y is broadcast).
#[pyfunction]
pub fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let (w, h, data) = py.detach(move || crate::image::read_exr(&path))?;
    let flat: Vec<f32> = data.into_iter().flatten().collect();
    array(py, flat, &[h as usize, w as usize, 3])
}

/// The bytes of an 8-bit sRGB PNG of a linear image scaled by 2^exposure (clamped).
#[pyfunction]
#[pyo3(signature = (image, exposure=0.0))]
pub fn encode_png<'py>(py: Python<'py>, image: PyReadonlyArrayDyn<'py, f32>, exposure: f32) -> PyResult<Bound<'py, PyBytes>> {
    if !exposure.is_finite() {
        return Err(Error::invalid(format!("exposure must be finite, got {exposure}")).into());
    }
    let (w, h, data) = hw3(&image)?;
    let bytes = py.detach(move || crate::image::encode_png(w, h, &data, exposure))?;
    Ok(PyBytes::new(py, &bytes))
}

/// A linear image as 8-bit sRGB, scaled by 2^exposure and clamped, exactly as `write_png` encodes it.
#[pyfunction]
#[pyo3(signature = (image, exposure=0.0))]
pub fn encode_srgb8<'py>(py: Python<'py>, image: PyReadonlyArrayDyn<'py, f32>, exposure: f32) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    if !exposure.is_finite() {
        return Err(Error::invalid(format!("exposure must be finite, got {exposure}")).into());
    }
    let (w, h, data) = hw3(&image)?;
    let bytes = py.detach(move || crate::image::encode_srgb8_image(&data, exposure));
    array(py, bytes, &[h as usize, w as usize, 3])
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(encode_srgb8, m)?)?;
    m.add_function(wrap_pyfunction!(encode_exr, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(encode_png, m)?)?;
    Ok(())
}
