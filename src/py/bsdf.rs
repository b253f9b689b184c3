//! `bsdf_eval`: evaluate one BSDF given as a small dict on the CPU reference or the GPU (tests against
//! Mitsuba's Python API use it).
use crate::error::{Error, Result};
use crate::gpu::{bsdf_eval::eval_batch_gpu, GpuContext};
use crate::scene::{Bsdf, MicrofacetDistribution, Param};
use crate::shading::bsdf::{eval_records, link_blend, resolve_records, roughplastic_table_buffer};
use glam::{Vec2, Vec3};
use numpy::{ndarray::Array2, IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn get<'py, T: FromPyObjectOwned<'py>>(spec: &Bound<'py, PyDict>, key: &str) -> PyResult<Option<T>> {
    match spec.get_item(key)? {
        Some(v) => match v.extract::<T>() {
            Ok(x) => Ok(Some(x)),
            Err(_) => Err(Error::invalid(format!("spec[{key:?}] has the wrong type: {v}")).into()),
        },
        None => Ok(None),
    }
}

/// An RGB value: a float or three floats.
fn rgb(spec: &Bound<'_, PyDict>, key: &str, default: f32) -> PyResult<Vec3> {
    match spec.get_item(key)? {
        None => Ok(Vec3::splat(default)),
        Some(v) => {
            if let Ok(x) = v.extract::<f32>() {
                return Ok(Vec3::splat(finite(key, x)?));
            }
            let c: Vec<f32> = v.extract().map_err(|e| Error::invalid(format!("spec[{key:?}]: {e}")))?;
            if c.len() != 3 {
                return Err(Error::invalid(format!("spec[{key:?}] must have 3 components, got {}", c.len())).into());
            }
            for x in &c {
                finite(key, *x)?;
            }
            Ok(Vec3::new(c[0], c[1], c[2]))
        }
    }
}

/// A spec value, refused when NaN or infinite (it would evaluate to a silently wrong value).
fn finite(key: &str, v: f32) -> PyResult<f32> {
    if !v.is_finite() {
        return Err(Error::invalid(format!("spec[{key:?}] must be finite, got {v}")).into());
    }
    Ok(v)
}

fn distribution(spec: &Bound<'_, PyDict>) -> PyResult<MicrofacetDistribution> {
    match get::<String>(spec, "distribution")?.as_deref().unwrap_or("beckmann") {
        "beckmann" => Ok(MicrofacetDistribution::Beckmann),
        "ggx" => Ok(MicrofacetDistribution::Ggx),
        d => Err(Error::invalid(format!("distribution must be \"beckmann\" or \"ggx\", got {d:?}")).into()),
    }
}

/// Build the scene BSDF list for `spec` (Mitsuba's defaults; `twosided: True` wraps it) and its index.
fn bsdf_from_spec(spec: &Bound<'_, PyDict>) -> PyResult<(Vec<Bsdf>, usize)> {
    let mut list = Vec::new();
    let index = build(spec, &mut list, 0)?;
    Ok((list, index))
}

/// Appends `spec`'s BSDF (after its nested ones) to `list`; returns its index. `depth`: blend nesting.
fn build(spec: &Bound<'_, PyDict>, list: &mut Vec<Bsdf>, depth: usize) -> PyResult<usize> {
    let ty: String = get(spec, "type")?.ok_or_else(|| Error::invalid("spec needs a \"type\""))?;
    let bsdf = if ty == "blendbsdf" {
        if depth > 0 {
            return Err(Error::invalid("a nested blendbsdf is not supported").into());
        }
        let weight = finite("weight", get::<f32>(spec, "weight")?.ok_or_else(|| Error::invalid("blendbsdf: spec needs a \"weight\""))?)?;
        let mut child = |key: &str| -> PyResult<usize> {
            let d = spec
                .get_item(key)?
                .ok_or_else(|| Error::invalid(format!("blendbsdf: spec needs {key:?}")))?
                .cast_into::<PyDict>()
                .map_err(|_| Error::invalid(format!("blendbsdf: spec[{key:?}] must be a dict")))?;
            build(&d, list, depth + 1)
        };
        let first = child("bsdf_0")?;
        let second = child("bsdf_1")?;
        Bsdf::Blend { weight: Param::Value(Vec3::splat(weight)), first, second }
    } else {
        leaf_from_spec(spec, &ty)?
    };
    let transmits = matches!(bsdf, Bsdf::RoughDielectric { .. } | Bsdf::ThinDielectric { .. });
    if transmits && (depth > 0 || get::<bool>(spec, "twosided")?.unwrap_or(false)) {
        return Err(Error::invalid(format!("{ty}: not allowed inside twosided or blendbsdf (as in scene files)")).into());
    }
    list.push(bsdf);
    if get::<bool>(spec, "twosided")?.unwrap_or(false) {
        list.push(Bsdf::TwoSided { front: list.len() - 1, back: list.len() - 1 });
    }
    Ok(list.len() - 1)
}

/// A BSDF other than a blend.
fn leaf_from_spec(spec: &Bound<'_, PyDict>, ty: &str) -> PyResult<Bsdf> {
    let ty = ty.to_string();
    let f = |key: &str, default: f32| -> PyResult<f32> { finite(key, get::<f32>(spec, key)?.unwrap_or(default)) };
    let nonlinear = get::<bool>(spec, "nonlinear")?.unwrap_or(false);
    let value = |v: Vec3| Param::Value(v);
    let conductor_ior = || -> PyResult<(Vec3, Vec3)> {
        if spec.get_item("eta")?.is_none() || spec.get_item("k")?.is_none() {
            return Err(Error::invalid(format!("{ty}: spec needs \"eta\" and \"k\"")).into());
        }
        Ok((rgb(spec, "eta", 0.0)?, rgb(spec, "k", 1.0)?))
    };
    let bsdf = match ty.as_str() {
        "diffuse" => Bsdf::Diffuse { reflectance: value(rgb(spec, "reflectance", 0.5)?) },
        "plastic" => Bsdf::Plastic {
            diffuse_reflectance: value(rgb(spec, "diffuse_reflectance", 0.5)?),
            specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?),
            int_ior: f("int_ior", 1.49)?,
            ext_ior: f("ext_ior", 1.000277)?,
            nonlinear,
        },
        "roughplastic" => Bsdf::RoughPlastic {
            diffuse_reflectance: value(rgb(spec, "diffuse_reflectance", 0.5)?),
            specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?),
            distribution: distribution(spec)?,
            alpha: f("alpha", 0.1)?,
            int_ior: f("int_ior", 1.49)?,
            ext_ior: f("ext_ior", 1.000277)?,
            nonlinear,
        },
        "roughconductor" => {
            let (eta, k) = conductor_ior()?;
            let alpha = f("alpha", 0.1)?;
            Bsdf::RoughConductor {
                distribution: distribution(spec)?,
                alpha_u: value(Vec3::splat(f("alpha_u", alpha)?)),
                alpha_v: value(Vec3::splat(f("alpha_v", alpha)?)),
                eta,
                k,
                specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?),
            }
        }
        "conductor" => {
            let (eta, k) = conductor_ior()?;
            Bsdf::Conductor { eta, k, specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?) }
        }
        "dielectric" => Bsdf::Dielectric { int_ior: f("int_ior", 1.5046)?, ext_ior: f("ext_ior", 1.000277)? },
        "roughdielectric" => {
            let alpha = f("alpha", 0.1)?;
            Bsdf::RoughDielectric {
                distribution: distribution(spec)?,
                alpha_u: value(Vec3::splat(f("alpha_u", alpha)?)),
                alpha_v: value(Vec3::splat(f("alpha_v", alpha)?)),
                int_ior: f("int_ior", 1.5046)?,
                ext_ior: f("ext_ior", 1.000277)?,
                specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?),
                specular_transmittance: value(rgb(spec, "specular_transmittance", 1.0)?),
            }
        }
        "thindielectric" => Bsdf::ThinDielectric {
            int_ior: f("int_ior", 1.5046)?,
            ext_ior: f("ext_ior", 1.000277)?,
            specular_reflectance: value(rgb(spec, "specular_reflectance", 1.0)?),
            specular_transmittance: value(rgb(spec, "specular_transmittance", 1.0)?),
        },
        "principled" => {
            let s = |key: &str, default: f32| -> PyResult<Param> { Ok(value(Vec3::splat(f(key, default)?))) };
            let has_spec_trans = get::<f32>(spec, "spec_trans")?.is_some_and(|v| v != 0.0);
            let eta = get::<f32>(spec, "eta")?;
            let specular = get::<f32>(spec, "specular")?;
            if eta.is_some() && specular.is_some() {
                return Err(Error::invalid("principled: give either \"eta\" or \"specular\", not both").into());
            }
            Bsdf::Principled(Box::new(crate::scene::principled::Principled {
                base_color: value(rgb(spec, "base_color", 0.5)?),
                roughness: s("roughness", 0.5)?,
                anisotropic: s("anisotropic", 0.0)?,
                metallic: s("metallic", 0.0)?,
                spec_tint: s("spec_tint", 0.0)?,
                spec_trans: s("spec_trans", 0.0)?,
                sheen: s("sheen", 0.0)?,
                sheen_tint: s("sheen_tint", 0.0)?,
                clearcoat: s("clearcoat", 0.0)?,
                clearcoat_gloss: s("clearcoat_gloss", 0.0)?,
                flatness: s("flatness", 0.0)?,
                eta: crate::shading::principled::principled_eta(eta, specular, has_spec_trans),
            }))
        }
        t => return Err(Error::invalid(format!("unsupported BSDF type {t:?}")).into()),
    };
    Ok(bsdf)
}

fn directions(a: &PyReadonlyArray2<'_, f32>, name: &str) -> Result<Vec<Vec3>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(Error::invalid(format!("{name} must have shape (N, 3), got {:?}", a.shape())));
    }
    let v: Vec<Vec3> = a.rows().into_iter().map(|r| Vec3::new(r[0], r[1], r[2])).collect();
    if let Some(k) = v.iter().position(|d| !d.is_finite()) {
        return Err(Error::invalid(format!("{name}[{k}] = {} is not finite (NaN or inf)", v[k])));
    }
    Ok(v)
}

/// Evaluate a BSDF as Mitsuba's `bsdf.eval(ctx, si, wo)` does, in the local frame (z = normal).
///
/// Args:
///     spec: {"type": "diffuse" | "plastic" | "roughplastic" | "roughconductor" | "conductor" | "dielectric"
///         | "roughdielectric" | "thindielectric" | "principled", parameters by Mitsuba's names (reflectance, diffuse_reflectance,
///         specular_reflectance, specular_transmittance, alpha, alpha_u, alpha_v, distribution, int_ior, ext_ior, nonlinear, eta, k;
///         principled: base_color, roughness, anisotropic, metallic, specular or eta, spec_tint, spec_trans,
///         sheen, sheen_tint, clearcoat, clearcoat_gloss, flatness as floats; "blendbsdf": weight (float),
///         bsdf_0 and bsdf_1 (nested spec dicts, not blends)) with Mitsuba's defaults, "twosided": True
///         wraps it; "perturbed_normal": three floats, the unit normal n' of a bumpmap / normalmap around it
///         in the local frame (not with blendbsdf; with "twosided" the twosided is around the bumpmap /
///         normalmap, as `<bsdf type="twosided"><bsdf type="bumpmap">...`, unless "twosided_inside": True)}.
///     wi: (N, 3) float32 unit directions toward the viewer.
///     wo: (N, 3) float32 unit directions toward the light.
///     device: "cpu" (Rust reference) or "gpu" (the WGSL twin).
/// Returns:
///     (N, 3) float32: f(wi, wo) |cos theta_o|.
/// Raises:
///     ValueError: bad spec or shapes. GpuUnavailableError / GpuError for device="gpu".
#[pyfunction]
fn bsdf_eval<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyDict>,
    wi: PyReadonlyArray2<'py, f32>,
    wo: PyReadonlyArray2<'py, f32>,
    device: &str,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let (bsdfs, index) = bsdf_from_spec(spec)?;
    let perturbed = match get::<Vec<f32>>(spec, "perturbed_normal")? {
        None => None,
        Some(n) if n.len() == 3 && n.iter().all(|x| x.is_finite()) && (Vec3::from_slice(&n).length() - 1.0).abs() < 1e-3 => {
            if matches!(bsdfs[index], Bsdf::Blend { .. }) {
                return Err(Error::invalid("spec[\"perturbed_normal\"] cannot be combined with a blendbsdf").into());
            }
            Some(Vec3::from_slice(&n).normalize())
        }
        Some(n) => {
            return Err(Error::invalid(format!("spec[\"perturbed_normal\"] must be 3 finite floats of unit length, got {n:?}")).into())
        }
    };
    let twosided_inside = get::<bool>(spec, "twosided_inside")?.unwrap_or(false);
    let (wi, wo) = (directions(&wi, "wi")?, directions(&wo, "wo")?);
    if wi.len() != wo.len() {
        return Err(Error::invalid(format!("wi and wo must have the same length, got {} and {}", wi.len(), wo.len())).into());
    }
    let device = device.to_string();
    let out: Vec<Vec3> = py.detach(|| -> Result<Vec<Vec3>> {
        let (mut b, second) = resolve_records(&bsdfs, &[], index, Vec2::ZERO);
        if let Some(n) = perturbed {
            use crate::shading::bsdf::{FLAG_TWOSIDED, FLAG_TWOSIDED_OUTER};
            if b.flags & FLAG_TWOSIDED != 0 && !twosided_inside {
                b.flags = (b.flags & !FLAG_TWOSIDED) | FLAG_TWOSIDED_OUTER;
            }
            crate::shading::perturb::set_normal(&mut b, n);
        }
        let records = match second {
            Some(s) => {
                link_blend(&mut b, 1);
                vec![b, s]
            }
            None => vec![b],
        };
        match device.as_str() {
            "cpu" => Ok(wi.iter().zip(&wo).map(|(a, c)| eval_records(&records, 0, *a, *c)).collect()),
            "gpu" => {
                let ctx = GpuContext::shared()?;
                eval_batch_gpu(&ctx, &records, true, &roughplastic_table_buffer(&bsdfs), &wi, &wo)
            }
            d => Err(Error::invalid(format!("device must be \"cpu\" or \"gpu\", got {d:?}"))),
        }
    })?;
    let flat: Vec<f32> = out.iter().flat_map(|v| v.to_array()).collect();
    let arr = Array2::from_shape_vec((out.len(), 3), flat).map_err(|e| Error::invalid(e.to_string()))?;
    Ok(arr.into_pyarray(py))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(bsdf_eval, m)?)
}
