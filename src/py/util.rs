//! Small conversions shared by the bindings.
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;

/// A flat Vec as a numpy array of the given shape (no copy beyond the Vec's move).
pub fn array<'py, T: numpy::Element>(py: Python<'py>, data: Vec<T>, shape: &[usize]) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    PyArray1::from_vec(py, data).reshape(shape.to_vec())
}

/// Vec3 list as an (N, 3) float32 array.
pub fn vec3_array<'py>(py: Python<'py>, v: &[glam::Vec3]) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let flat: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
    array(py, flat, &[v.len(), 3])
}
