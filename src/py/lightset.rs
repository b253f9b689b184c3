//! The Python `LightSet`: numpy views of a `lights::LightSet`, and sets made by users
//! (`from_arrays`, `concat`, indexing with ints, slices, index arrays and boolean masks).
use super::scene::Scene;
use super::util::{array, vec3_array};
use crate::error::Error;
use crate::lights::{self, LightArrays};
use crate::shading::GpuBsdf;
use glam::Vec3;
use numpy::PyArrayDyn;
use pyo3::exceptions::PyIndexError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PySlice};
use std::sync::Arc;

/// u32 words of one `GpuBsdf`.
const BSDF_WORDS: usize = std::mem::size_of::<GpuBsdf>() / 4;
/// Keyword arguments of `from_arrays`.
const KEYS: [&str; 16] = [
    "kind",
    "position",
    "direction",
    "normal",
    "geo_normal",
    "incident",
    "intensity",
    "power",
    "cutoff_angle",
    "beam_width",
    "bsdf",
    "albedo",
    "vpl_clamp",
    "patch",
    "vsl_radius",
    "vpl_depth",
];

/// A set of lights (struct of arrays); numpy views via the properties.
#[pyclass(module = "manylights._native", frozen)]
pub struct LightSet {
    pub inner: Arc<lights::LightSet>,
    /// `power`, computed once (VPLs on glossy surfaces need a quadrature each).
    power: std::sync::OnceLock<Vec<glam::Vec3>>,
}

impl LightSet {
    pub fn new(set: lights::LightSet) -> LightSet {
        LightSet { inner: Arc::new(set), power: std::sync::OnceLock::new() }
    }
}

#[pymethods]
impl LightSet {
    fn __len__(&self) -> usize {
        self.inner.len()
    }
    /// Light kinds as int32 (0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL).
    #[getter]
    fn kind<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<i32>>> {
        let k: Vec<i32> = self.inner.kind.iter().map(|k| *k as i32).collect();
        let n = k.len();
        array(py, k, &[n])
    }
    /// (n, 3) world positions (0 for directional lights).
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.position)
    }
    /// (n, 3) unit directions: spot axis, directional travel direction, 0 for point lights.
    #[getter]
    fn direction<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.direction)
    }
    /// (n, 3) unit emission normal (oriented point) or shading normal (VPL); 0 for other kinds.
    #[getter]
    fn normal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.normal)
    }
    /// (n, 3) VPL geometric normal (oriented point: its normal); 0 for other kinds.
    #[getter]
    fn geo_normal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.geo_normal)
    }
    /// (n, 3) VPL incident direction (unit, toward where its particle came from); 0 for other kinds.
    #[getter]
    fn incident<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.incident)
    }
    /// VPL geometry-term clamp (1/m^2; inf = none).
    #[getter]
    fn vpl_clamp(&self) -> f32 {
        self.inner.vpl_clamp
    }
    /// (n, 3) RGB intensity (W/sr; oriented point: along its normal), irradiance (W/m^2, directional)
    /// or flux (W, VPL).
    #[getter]
    fn intensity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        vec3_array(py, &self.inner.intensity)
    }
    /// (n, 3) RGB emitted power (W).
    #[getter]
    fn power<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        if let Some(p) = self.power.get() {
            return vec3_array(py, p);
        }
        // In chunks between Ctrl-C checks (glossy VPLs need a 1024-point quadrature each).
        let set = self.inner.clone();
        let p = super::signals::detach(py, move || crate::interrupt::par_map_chunked(set.len(), 16384, |j| set.power(j)))?;
        vec3_array(py, self.power.get_or_init(|| p))
    }
    /// (n,) spot cutoff angles in radians (0 for other kinds).
    #[getter]
    fn cutoff_angle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        array(py, self.inner.cutoff_angle.clone(), &[self.inner.len()])
    }
    /// (n,) spot beam widths in radians (0 for other kinds).
    #[getter]
    fn beam_width<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        array(py, self.inner.beam_width.clone(), &[self.inner.len()])
    }
    /// (n, 20) uint32: each VPL's BSDF as the 80-byte record the GPU reads (textures resolved at its
    /// hit; zero for other kinds). Opaque: pass it back to `from_arrays` for the same scene.
    #[getter]
    fn bsdf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let words: Vec<u32> = bytemuck::cast_slice(&self.inner.bsdf).to_vec();
        array(py, words, &[self.inner.len(), BSDF_WORDS])
    }
    /// (n, 4, 3) float32: each oriented point's patch, the 4 corners (m, in order around a planar convex
    /// quadrilateral; a triangle repeats one) of the piece of area emitter it stands for; receivers
    /// within 8 patch radii of its centre get the patch's projected solid angle instead of 1 / d^2.
    /// All zero = none (other kinds, sphere emitters, user-made points without one).
    #[getter]
    fn patch<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let flat: Vec<f32> = self.inner.patch.iter().flat_map(|c| c.iter().flat_map(|v| v.to_array())).collect();
        array(py, flat, &[self.inner.len(), 4, 3])
    }
    /// (n,) float32: each VPL's virtual-spherical-light radius in m (Hasan et al. 2009; 0 = a point
    /// VPL, clamped by ``vpl_clamp``; 0 for other kinds). ``generate_lights(indirect_kind="vsl")`` sets
    /// it from the distance to the k-th nearest VPL.
    #[getter]
    fn vsl_radius<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        array(py, self.inner.vsl_radius.clone(), &[self.inner.len()])
    }
    /// (n,) uint32: each VPL's depth, the bounce its particle was stored at (``generate_lights``: Mitsuba's
    /// depth of the vertex, null events through masked surfaces included; 1 for VPLs made otherwise); 0 for
    /// other kinds. In a scene with masks a VPL lights a view sample only with depth to spare: its shadow
    /// ray crosses at most the sample's budget minus this many masked surfaces.
    #[getter]
    fn vpl_depth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        array(py, self.inner.vpl_depth.clone(), &[self.inner.len()])
    }
    /// Centre (3,) and radius of the scene's bounding sphere the set belongs to.
    #[getter]
    fn scene_sphere(&self) -> ([f32; 3], f32) {
        (self.inner.scene_center.to_array(), self.inner.scene_radius)
    }
    /// A LightSet built from per-light arrays (n lights), for light sets made by researchers.
    ///
    /// Args:
    ///     scene: the Scene the lights belong to (its bounding sphere fits directional shadow maps and
    ///         gives directional power).
    ///     kind: (n,) ints or one int for all: 0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL.
    ///     position: (n, 3) world positions (m); required except for directional lights.
    ///     direction: (n, 3) unit vectors: spot axis, or the direction a directional light travels.
    ///     normal: (n, 3) unit emission normal (oriented point) or shading normal (VPL).
    ///     geo_normal: (n, 3) unit geometric normal (VPL).
    ///     incident: (n, 3) unit direction from a VPL toward where its particle came from.
    ///     intensity: (n, 3) RGB or (n,) grey, >= 0: W/sr (point, spot; oriented point along its
    ///         normal), W/m^2 irradiance (directional), W flux (VPL).
    ///     power: instead of intensity, (n, 3) or (n,) emitted power in W (the `power` property's
    ///         formulas inverted).
    ///     cutoff_angle, beam_width: (n,) or scalar spot angles in radians,
    ///         0 <= beam_width <= cutoff_angle <= pi.
    ///     bsdf: (n, 20) uint32 VPL BSDF records (the `bsdf` property of a set of the same scene), or
    ///     albedo: (n, 3) or (n,) diffuse reflectance in [0, 1] of each VPL's Lambertian BSDF.
    ///     vpl_clamp: bound on the VPL geometry term in 1/m^2 (default inf: no clamp).
    ///     patch: (n, 4, 3) corners (m) of each oriented point's patch (the `patch` property); all zero
    ///         or omitted = none (point formula everywhere); ignored for other kinds.
    ///     vsl_radius: (n,) or scalar VSL radii in m (the `vsl_radius` property), finite and >= 0;
    ///         0 or omitted = point VPLs; ignored for other kinds.
    ///     vpl_depth: (n,) or scalar integer VPL depths >= 1 (the `vpl_depth` property); omitted = 1;
    ///         ignored for other kinds.
    ///
    /// Fields a kind does not use are ignored and stored as 0, and unit vectors are stored as given
    /// (not renormalised), so ``LightSet.from_arrays(scene, kind=s.kind, position=s.position, ...)``
    /// of a set s rebuilds it bit for bit. Any array-like works; values are converted to float32.
    ///
    /// Returns:
    ///     LightSet of n lights.
    ///
    /// Raises:
    ///     ValueError: naming the argument and light: a missing required array, a shape other than
    ///         the expected one (both shapes given), a non-numeric dtype, NaN or infinite values,
    ///         negative intensity or power, a vector whose length is not 1 (within 1e-4), spot angles
    ///         out of range, an unknown kind, an unknown keyword, a patch with NaN/infinite corners or
    ///         zero area, a NaN, infinite or negative vsl_radius, a VPL depth that is not an integer >= 1.
    #[staticmethod]
    #[pyo3(signature = (scene, **arrays))]
    fn from_arrays(py: Python<'_>, scene: &Scene, arrays: Option<&Bound<'_, PyDict>>) -> PyResult<LightSet> {
        Ok(LightSet::new(from_arrays_impl(py, scene, arrays)?))
    }
    /// All lights of ``sets`` (a list of LightSets) in order, as one LightSet.
    ///
    /// Raises:
    ///     ValueError: an empty list, sets of different scenes (bounding spheres differ), or VPL sets
    ///         with different ``vpl_clamp``.
    #[staticmethod]
    fn concat(sets: Vec<PyRef<'_, LightSet>>) -> PyResult<LightSet> {
        let refs: Vec<&lights::LightSet> = sets.iter().map(|s| s.inner.as_ref()).collect();
        Ok(LightSet::new(lights::LightSet::concat(&refs)?))
    }
    /// ``lights[key]``: a new LightSet of the chosen lights, in key order. key: an int (a set of that one
    /// light), a slice, an integer array (any order, repeats allowed, negatives count from the end) or
    /// a boolean mask of shape (n,). Column k of a LightMatrix of ``lights[key]`` equals column
    /// ``indices[k]`` of the full set's.
    ///
    /// Raises:
    ///     IndexError: an index out of range or a mask of another length.
    ///     TypeError: another kind of key (floats, strings).
    fn __getitem__(&self, key: &Bound<'_, PyAny>) -> PyResult<LightSet> {
        let idx = light_indices(key, self.inner.len())?;
        Ok(LightSet::new(self.inner.select(&idx)?))
    }
    fn __repr__(&self) -> String {
        format!("LightSet({} lights)", self.inner.len())
    }
}

/// `obj` as a C-contiguous numpy array of `dtype` with its shape; ValueError naming `name` for
/// non-numeric input (strings, objects, complex numbers).
fn numeric<'py>(
    py: Python<'py>,
    name: &str,
    obj: &Bound<'py, PyAny>,
    dtype: &str,
    ints_only: bool,
) -> PyResult<(Bound<'py, PyAny>, Vec<usize>)> {
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (obj,)).map_err(|e| Error::invalid(format!("{name} must be a numeric array: {e}")))?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    let allowed = if ints_only { "iu" } else { "iuf" };
    if !allowed.contains(kind.as_str()) {
        let dt = a.getattr("dtype")?.str()?.to_string();
        let want = if ints_only { "integers" } else { "real numbers" };
        return Err(Error::invalid(format!("{name} must hold {want}, got dtype {dt}")).into());
    }
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    let c = np.call_method1("ascontiguousarray", (a, dtype))?;
    Ok((c, shape))
}

fn shape_str(s: &[usize]) -> String {
    match s {
        [a] => format!("({a},)"),
        _ => format!("({})", s.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

/// An (n, 3) float array (or (n,) when `grey`: the same value in R, G and B) as Vec3s.
fn vec3s(py: Python<'_>, name: &str, obj: &Bound<'_, PyAny>, n: usize, grey: bool) -> PyResult<Vec<Vec3>> {
    let (a, shape) = numeric(py, name, obj, "float32", false)?;
    let flat: Vec<f32> = a.call_method0("ravel")?.call_method0("tolist")?.extract()?;
    match shape.as_slice() {
        [m, 3] if *m == n => Ok(flat.chunks_exact(3).map(Vec3::from_slice).collect()),
        [m] if grey && *m == n => Ok(flat.into_iter().map(Vec3::splat).collect()),
        _ => Err(Error::invalid(format!(
            "{name} must have shape (n, 3) = ({n}, 3){}, got {}",
            if grey { format!(" or ({n},)") } else { String::new() },
            shape_str(&shape)
        ))
        .into()),
    }
}

/// An (n,) float array, or a scalar for every light.
fn floats(py: Python<'_>, name: &str, obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f32>> {
    let (a, shape) = numeric(py, name, obj, "float32", false)?;
    let flat: Vec<f32> = a.call_method0("ravel")?.call_method0("tolist")?.extract()?;
    match shape.as_slice() {
        [] => Ok(vec![flat[0]; n]),
        [m] if *m == n => Ok(flat),
        _ => Err(Error::invalid(format!("{name} must have shape (n,) = ({n},) or be a scalar, got {}", shape_str(&shape))).into()),
    }
}

fn from_arrays_impl(py: Python<'_>, scene: &Scene, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<lights::LightSet> {
    let empty = PyDict::new(py);
    let kw = kwargs.unwrap_or(&empty);
    for key in kw.keys() {
        let k: String = key.extract()?;
        if !KEYS.contains(&k.as_str()) {
            return Err(Error::invalid(format!("from_arrays got an unknown argument '{k}'; accepted: {}", KEYS.join(", "))).into());
        }
    }
    let get = |k: &str| -> PyResult<Option<Bound<'_, PyAny>>> { Ok(kw.get_item(k)?.filter(|v| !v.is_none())) };
    // n: from kind when it is an array, else from the first per-light array given.
    let kind_obj = get("kind")?.ok_or_else(|| {
        Error::invalid("from_arrays needs kind= (int or (n,) ints: 0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL)")
    })?;
    let (kind_arr, kind_shape) = numeric(py, "kind", &kind_obj, "int64", true)?;
    let kind_vals: Vec<i64> = kind_arr.call_method0("ravel")?.call_method0("tolist")?.extract()?;
    let n = match kind_shape.as_slice() {
        [n] => *n,
        [] => {
            let mut n = None;
            for k in ["position", "direction", "normal", "intensity", "power"] {
                if let Some(v) = get(k)? {
                    let (_, s) = numeric(py, k, &v, "float32", false)?;
                    n = s.first().copied();
                    break;
                }
            }
            n.ok_or_else(|| {
                Error::invalid("kind is a scalar and no per-light array (position, direction, normal, intensity, power) gives n")
            })?
        }
        _ => return Err(Error::invalid(format!("kind must have shape (n,) or be a scalar, got {}", shape_str(&kind_shape))).into()),
    };
    let kind: Vec<i32> = if kind_shape.is_empty() {
        vec![kind_vals[0].clamp(i32::MIN as i64, i32::MAX as i64) as i32; n]
    } else {
        kind_vals.iter().map(|&k| k.clamp(i32::MIN as i64, i32::MAX as i64) as i32).collect()
    };
    let v3 = |k: &str| -> PyResult<Option<Vec<Vec3>>> { get(k)?.map(|v| vec3s(py, k, &v, n, false)).transpose() };
    let fl = |k: &str| -> PyResult<Option<Vec<f32>>> { get(k)?.map(|v| floats(py, k, &v, n)).transpose() };
    let mut arrays = LightArrays {
        kind,
        position: v3("position")?,
        direction: v3("direction")?,
        normal: v3("normal")?,
        geo_normal: v3("geo_normal")?,
        incident: v3("incident")?,
        intensity: Vec::new(),
        cutoff_angle: fl("cutoff_angle")?,
        beam_width: fl("beam_width")?,
        bsdf: None,
        patch: None,
        vsl_radius: fl("vsl_radius")?,
        vpl_depth: None,
    };
    if let Some(d) = fl("vpl_depth")? {
        // >= 1 for VPLs is checked by `LightSet::from_arrays` (other kinds' entries, 0 in the property, are ignored).
        let bad = d.iter().position(|&x| !(x >= 0.0 && x.fract() == 0.0 && x <= u32::MAX as f32));
        if let Some(j) = bad {
            return Err(Error::invalid(format!("vpl_depth[{j}] must be an integer >= 1 for a VPL, got {}", d[j])).into());
        }
        arrays.vpl_depth = Some(d.iter().map(|&x| x as u32).collect());
    }
    if let Some(p) = get("patch")? {
        let (a, shape) = numeric(py, "patch", &p, "float32", false)?;
        if shape != [n, 4, 3] {
            return Err(Error::invalid(format!("patch must have shape (n, 4, 3) = ({n}, 4, 3), got {}", shape_str(&shape))).into());
        }
        let flat: Vec<f32> = a.call_method0("ravel")?.call_method0("tolist")?.extract()?;
        arrays.patch = Some(flat.chunks_exact(12).map(|c| [0, 1, 2, 3].map(|k| Vec3::from_slice(&c[3 * k..3 * k + 3]))).collect());
    }
    // The VPL BSDF: raw records (the `bsdf` property of another set of this scene) or a diffuse albedo.
    match (get("bsdf")?, get("albedo")?) {
        (Some(_), Some(_)) => return Err(Error::invalid("give either bsdf= or albedo=, not both").into()),
        (Some(b), None) => {
            let (a, shape) = numeric(py, "bsdf", &b, "uint32", true)?;
            if shape != [n, BSDF_WORDS] {
                return Err(Error::invalid(format!(
                    "bsdf must have shape (n, {BSDF_WORDS}) = ({n}, {BSDF_WORDS}) uint32 (a LightSet's bsdf), got {}",
                    shape_str(&shape)
                ))
                .into());
            }
            let words: Vec<u32> = a.call_method0("ravel")?.call_method0("tolist")?.extract()?;
            arrays.bsdf = Some(words.chunks_exact(BSDF_WORDS).map(|w| bytemuck::pod_read_unaligned(bytemuck::cast_slice(w))).collect());
        }
        (None, Some(a)) => {
            let albedo = vec3s(py, "albedo", &a, n, true)?;
            let mut out = Vec::with_capacity(n);
            for (j, c) in albedo.iter().enumerate() {
                if !(c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                    return Err(Error::invalid(format!("albedo[{j}] must be in [0, 1], got {:?}", c.to_array())).into());
                }
                let mut b: GpuBsdf = bytemuck::Zeroable::zeroed();
                b.kind = crate::shading::bsdf::KIND_DIFFUSE;
                b.diffuse = c.to_array();
                out.push(b);
            }
            arrays.bsdf = Some(out);
        }
        (None, None) => {}
    }
    let vpl_clamp = match get("vpl_clamp")? {
        Some(v) => v.extract::<f32>().map_err(|_| Error::invalid("vpl_clamp must be a number (1/m^2; inf for none)"))?,
        None => f32::INFINITY,
    };
    let (center, radius) = lights::scene_sphere(&scene.inner);
    // Intensity directly, or from power (W) by the inverse of `LightSet::power`'s formulas.
    match (get("intensity")?, get("power")?) {
        (Some(_), Some(_)) => return Err(Error::invalid("give either intensity= or power=, not both").into()),
        (Some(i), None) => arrays.intensity = vec3s(py, "intensity", &i, n, true)?,
        (None, Some(p)) => {
            let power = vec3s(py, "power", &p, n, true)?;
            // Validate everything else with unit intensities first (the conversion needs valid lights).
            arrays.intensity = vec![Vec3::ONE; n];
            let unit = lights::LightSet::from_arrays(&arrays, center, radius, vpl_clamp)?;
            let per_unit = unit.powers();
            arrays.intensity = Vec::with_capacity(n);
            for j in 0..n {
                let (p, u) = (power[j], per_unit[j]);
                if !(p.is_finite() && p.min_element() >= 0.0) {
                    return Err(Error::invalid(format!("power[{j}] must be finite and >= 0, got {:?}", p.to_array())).into());
                }
                let mut i = Vec3::ZERO;
                for c in 0..3 {
                    if p[c] > 0.0 {
                        if !(u[c] > 0.0) {
                            return Err(Error::invalid(format!(
                                "power[{j}] channel {c} = {} cannot be reached: this light emits nothing in that channel per unit intensity (e.g. a VPL whose BSDF reflects none of it)",
                                p[c]
                            ))
                            .into());
                        }
                        i[c] = p[c] / u[c];
                    }
                }
                arrays.intensity.push(i);
            }
        }
        (None, None) => return Err(Error::invalid("from_arrays needs intensity= (n, 3) or power= (n, 3)").into()),
    }
    Ok(lights::LightSet::from_arrays(&arrays, center, radius, vpl_clamp)?)
}

/// Light indices chosen by `key` (int, slice, integer array, boolean mask) among n lights.
fn light_indices(key: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<usize>> {
    let py = key.py();
    let wrap = |i: i64, k: usize| -> PyResult<usize> {
        let j = if i < 0 { i + n as i64 } else { i };
        if j < 0 || j >= n as i64 {
            return Err(PyIndexError::new_err(format!("light index {i} (at position {k}) is out of range for {n} lights")));
        }
        Ok(j as usize)
    };
    if let Ok(s) = key.cast::<PySlice>() {
        let ind = s.indices(n as isize)?;
        let mut out = Vec::with_capacity(ind.slicelength);
        let mut i = ind.start;
        for _ in 0..ind.slicelength {
            out.push(i as usize);
            i += ind.step;
        }
        return Ok(out);
    }
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (key,))?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    match kind.as_str() {
        "b" => {
            if shape != [n] {
                return Err(PyIndexError::new_err(format!(
                    "a boolean mask must have shape ({n},) for {n} lights, got {}",
                    shape_str(&shape)
                )));
            }
            let m: Vec<bool> = a.call_method0("tolist")?.extract()?;
            Ok(m.iter().enumerate().filter(|(_, &b)| b).map(|(j, _)| j).collect())
        }
        "i" | "u" => {
            if shape.len() > 1 {
                return Err(PyIndexError::new_err(format!("light indices must be a scalar or 1-D, got shape {}", shape_str(&shape))));
            }
            let flat: Vec<i64> = a.call_method1("astype", ("int64",))?.call_method0("ravel")?.call_method0("tolist")?.extract()?;
            flat.iter().enumerate().map(|(k, &i)| wrap(i, k)).collect()
        }
        _ => Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "LightSet indices must be an int, a slice, integers or a boolean mask, got dtype {}",
            a.getattr("dtype")?.str()?
        ))),
    }
}
