//! Saving and loading `DirectToIndirect` (`relight::store`): the transfer as named numpy arrays, its
//! rebuilding from them, and the scene hash; the file itself is `manylights.relight_store`'s.
use super::scene::Scene;
use super::signals;
use super::transfer::DirectToIndirect;
use super::util::array;
use crate::relight::store::{self, Data, NamedArray};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// [(name, array)] of a precomputed transfer (`manylights.DirectToIndirect` or its native object), in a
/// fixed order (`relight::store` names them). Raises TypeError for anything else.
#[pyfunction]
fn transfer_arrays<'py>(py: Python<'py>, rel: &Bound<'py, PyAny>) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let native = match rel.cast::<DirectToIndirect>() {
        Ok(r) => r.clone(),
        Err(_) => match rel.getattr("_t").ok().and_then(|t| t.cast_into::<DirectToIndirect>().ok()) {
            Some(r) => r,
            None => return Err(PyTypeError::new_err(format!("rel must be a manylights DirectToIndirect, got {}", rel.get_type().name()?))),
        },
    };
    let mut out = Vec::new();
    for a in store::to_arrays(native.get().transfer()) {
        let arr = match a.data {
            Data::F32(v) => array(py, v, &a.shape)?.into_any(),
            Data::F64(v) => array(py, v, &a.shape)?.into_any(),
            Data::U32(v) => array(py, v, &a.shape)?.into_any(),
            Data::U64(v) => array(py, v, &a.shape)?.into_any(),
        };
        out.push((a.name, arr));
    }
    Ok(out)
}

fn named<'py, T: numpy::Element + Copy>(name: &str, a: &Bound<'py, PyAny>, wrap: fn(Vec<T>) -> Data) -> Option<NamedArray> {
    let r: PyReadonlyArrayDyn<'py, T> = a.extract().ok()?;
    let shape = r.shape().to_vec();
    Some(NamedArray { name: name.to_string(), shape, data: wrap(r.as_array().iter().copied().collect()) })
}

/// Rebuilds a `DirectToIndirect` of `scene` from [(name, array)] (`transfer_arrays` of a saved one).
/// Raises TypeError for an array of another dtype than float32/float64/uint32/uint64, ValueError for
/// what `relight::store::from_arrays` refuses (the array named).
/// `device`, `visibility`, `shadow_map_size`: where it relights, as `DirectToIndirect`'s constructor.
#[pyfunction]
#[pyo3(signature = (scene, arrays, device="auto", visibility=None, shadow_map_size=1024))]
fn transfer_from_arrays(
    py: Python<'_>,
    scene: &Scene,
    arrays: Vec<(String, Bound<'_, PyAny>)>,
    device: &str,
    visibility: Option<&str>,
    shadow_map_size: u32,
) -> PyResult<DirectToIndirect> {
    let mut list = Vec::with_capacity(arrays.len());
    for (name, a) in &arrays {
        let n = named::<f32>(name, a, Data::F32)
            .or_else(|| named::<f64>(name, a, Data::F64))
            .or_else(|| named::<u32>(name, a, Data::U32))
            .or_else(|| named::<u64>(name, a, Data::U64));
        match n {
            Some(n) => list.push(n),
            None => {
                let dtype = a.getattr("dtype").map(|d| d.to_string()).unwrap_or_else(|_| a.get_type().to_string());
                return Err(PyTypeError::new_err(format!("array '{name}' has dtype {dtype}: expected float32, float64, uint32 or uint64")));
            }
        }
    }
    let s = scene.inner.clone();
    let (w, h) = (s.camera.width, s.camera.height);
    let t = signals::detach(py, move || store::from_arrays(&s, w, h, list))?;
    DirectToIndirect::from_transfer(py, scene, t, device, visibility, shadow_map_size)
}

/// {section: SHA-256 hex digest} of what a transfer of `scene` depends on: "geometry", "materials",
/// "camera", "film" (`relight::store::scene_key`; emitters are not part of it).
#[pyfunction]
fn transfer_scene_hash<'py>(py: Python<'py>, scene: &Scene) -> PyResult<Bound<'py, PyDict>> {
    let hashlib = py.import("hashlib")?;
    let out = PyDict::new(py);
    let mut err = None;
    store::scene_key(&scene.inner, &mut |section, bytes| {
        if err.is_some() {
            return;
        }
        let r = (|| -> PyResult<()> {
            let h = match out.get_item(section)? {
                Some(h) => h,
                None => {
                    let h = hashlib.call_method0("sha256")?;
                    out.set_item(section, &h)?;
                    h
                }
            };
            h.call_method1("update", (pyo3::types::PyBytes::new(py, bytes),))?;
            Ok(())
        })();
        if let Err(e) = r {
            err = Some(e);
        }
    });
    if let Some(e) = err {
        return Err(e);
    }
    let digests = PyDict::new(py);
    for (k, h) in out.iter() {
        digests.set_item(k, h.call_method0("hexdigest")?)?;
    }
    Ok(digests)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(transfer_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(transfer_from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(transfer_scene_hash, m)?)?;
    Ok(())
}
