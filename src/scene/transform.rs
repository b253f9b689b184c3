//! `<transform>` children of Mitsuba 3 XML files, as `src/core/parser.cpp` of Mitsuba 3.9.1 reads them.
//!
//! Operations (`translate`, `rotate`, `scale`, `matrix`, `lookat`) apply in document order:
//! M = last * ... * first. Arithmetic is in f64 like Mitsuba's parser; callers cast to f32 at the end.
//!
//! Like Mitsuba's `AffineTransform4d`, an [`Affine`] carries its matrix *and* the matrix that transforms
//! normals (`inverse_transpose`), each operation supplying its own and products multiplying both. They
//! are inverse transposes of each other except after a `rotate` about an axis that is not unit length:
//! - `rotate`: Rodrigues' matrix built from the axis *as given* (Mitsuba 3.9.1 does not normalise it:
//!   `rotate x="0" y="1" z="1"` scales and shears), with the same matrix as its normal transform.
//! - `translate`: `x`/`y`/`z` (missing = 0) or `value="x, y, z"` (1 value = all three).
//! - `scale`: `x`/`y`/`z` (missing = 1) or `value` (1 or 3 numbers); normal transform scale(1 / v).
//! - `matrix`: 16 (or 9, for the upper-left 3x3) numbers, row-major; normal transform from Mitsuba's
//!   `update()`: inverse transpose of the 3x3 block, last row `-(invT)^T t`.
//! - `lookat`: `origin`, `target`, optional `up` (zero or missing: any vector perpendicular to the view
//!   direction); columns (left, up', dir, origin) with left = normalize(up x dir), up' = dir x left.
//!
//! `to_uv` transforms of textures become 2D affine maps the way Mitsuba's `Transform::extract` does:
//! the upper-left 2x2 block plus the x/y translation (the z row and column are dropped).
use crate::error::{Error, Location, Result};
use glam::{DMat3, DMat4, DVec3, DVec4, Mat3, Vec3};

/// A transform as Mitsuba's parser keeps it: the matrix and the matrix applied to normals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Applied to points and vectors (column-major, f64).
    pub matrix: DMat4,
    /// Applied to normals (its upper-left 3x3 block; then normalised by the caller).
    pub inverse_transpose: DMat4,
}

impl Affine {
    pub const IDENTITY: Affine = Affine { matrix: DMat4::IDENTITY, inverse_transpose: DMat4::IDENTITY };

    /// From a matrix, its normal transform computed as Mitsuba's `Transform::update()` does (NaN for a
    /// singular 3x3 block, as there).
    pub fn from_matrix(matrix: DMat4) -> Affine {
        let invt_rot = DMat3::from_mat4(matrix).inverse().transpose();
        let inv_trans = -(invt_rot.transpose() * matrix.w_axis.truncate());
        let mut it = DMat4::from_mat3(invt_rot);
        // Mitsuba's entry (3, i) = row 3, column i.
        it.x_axis.w = inv_trans.x;
        it.y_axis.w = inv_trans.y;
        it.z_axis.w = inv_trans.z;
        Affine { matrix, inverse_transpose: it }
    }

    /// The 3x3 block Mitsuba's `Transform::inverse()` applies to vectors: the transpose of the normal
    /// matrix (the true inverse except after a `rotate` about a non-unit axis, where it is R^T).
    pub fn inverse_linear(&self) -> DMat3 {
        DMat3::from_mat4(self.inverse_transpose).transpose()
    }

    /// A normal (local) to world: the normal transform's 3x3 block applied, not normalised.
    pub fn transform_normal(&self, n: DVec3) -> DVec3 {
        DMat3::from_mat4(self.inverse_transpose) * n
    }
}

impl std::ops::Mul for Affine {
    type Output = Affine;
    fn mul(self, o: Affine) -> Affine {
        Affine { matrix: self.matrix * o.matrix, inverse_transpose: self.inverse_transpose * o.inverse_transpose }
    }
}

/// Numbers of a list attribute: separated by commas and/or whitespace, as Mitsuba's `string::tokenize`.
pub fn tokenize(value: &str) -> Vec<&str> {
    value.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect()
}

/// Parses one floating-point number (surrounding whitespace allowed); the error names the value.
pub fn parse_f64(value: &str, what: &str, loc: &Location) -> Result<f64> {
    value.trim().parse::<f64>().map_err(|_| Error::scene(loc, format!("could not parse {what} \"{value}\" as a number")))
}

/// Parses a list of numbers ("1 2 3", "1, 2, 3").
pub fn parse_list(value: &str, what: &str, loc: &Location) -> Result<Vec<f64>> {
    tokenize(value).into_iter().map(|t| parse_f64(t, what, loc)).collect()
}

fn attr<'a>(attrs: &'a [(String, String)], name: &str) -> Option<&'a str> {
    attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
}

/// Reads `x`/`y`/`z` (missing ones = `default`) or `value` (1 or 3 numbers) of a transform element.
fn xyz(tag: &str, attrs: &[(String, String)], default: f64, loc: &Location) -> Result<DVec3> {
    let has_xyz = ["x", "y", "z"].iter().any(|k| attr(attrs, k).is_some());
    if let Some(value) = attr(attrs, "value") {
        if has_xyz {
            return Err(Error::scene(loc, format!("<{tag}>: cannot mix \"value\" and \"x\"/\"y\"/\"z\" attributes")));
        }
        let v = parse_list(value, &format!("<{tag}> value"), loc)?;
        return match v.len() {
            1 => Ok(DVec3::splat(v[0])),
            3 => Ok(DVec3::new(v[0], v[1], v[2])),
            n => Err(Error::scene(loc, format!("<{tag}> value=\"{value}\" must have exactly 1 or 3 numbers, got {n}"))),
        };
    }
    let mut out = DVec3::splat(default);
    for (i, k) in ["x", "y", "z"].iter().enumerate() {
        if let Some(v) = attr(attrs, k) {
            out[i] = parse_f64(v, &format!("<{tag}> {k}"), loc)?;
        }
    }
    Ok(out)
}

/// Checks that an element has only the allowed attributes (Mitsuba's `check_attributes`).
fn check_attrs(tag: &str, attrs: &[(String, String)], allowed: &[&str], loc: &Location) -> Result<()> {
    for (k, v) in attrs {
        if !allowed.contains(&k.as_str()) {
            return Err(Error::scene(loc, format!("<{tag}>: unexpected attribute {k}=\"{v}\"")));
        }
    }
    Ok(())
}

fn vec3_attr(tag: &str, attrs: &[(String, String)], name: &str, loc: &Location) -> Result<Option<DVec3>> {
    let Some(value) = attr(attrs, name) else { return Ok(None) };
    let v = parse_list(value, &format!("<{tag}> {name}"), loc)?;
    if v.len() != 3 {
        return Err(Error::scene(loc, format!("<{tag}> {name}=\"{value}\": expected 3 numbers, got {}", v.len())));
    }
    Ok(Some(DVec3::new(v[0], v[1], v[2])))
}

/// Right-handed rotation by `angle_deg` degrees about `axis`, as Dr.Jit's `rotate<Matrix4>` builds it:
/// Rodrigues' formula with the axis *as given* (not normalised; a non-unit axis gives a matrix that also
/// scales and shears, exactly as in Mitsuba 3.9.1).
pub fn rotate(axis: DVec3, angle_deg: f64) -> DMat4 {
    let (s, c) = angle_deg.to_radians().sin_cos();
    let t = 1.0 - c;
    let DVec3 { x, y, z } = axis;
    // Rows of the 3x3 block, written as columns for glam.
    DMat4::from_cols(
        DVec4::new(c + x * x * t, x * y * t + z * s, x * z * t - y * s, 0.0),
        DVec4::new(x * y * t - z * s, c + y * y * t, y * z * t + x * s, 0.0),
        DVec4::new(x * z * t + y * s, y * z * t - x * s, c + z * z * t, 0.0),
        DVec4::W,
    )
}

/// Mitsuba's `look_at`: columns (left, up', dir, origin). NaN (e.g. up parallel to dir) is an error.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3, loc: &Location) -> Result<DMat4> {
    let dir = (target - origin).normalize();
    let up = if up == DVec3::ZERO { any_orthogonal(dir) } else { up };
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0));
    if m.to_cols_array().iter().any(|x| !x.is_finite()) {
        return Err(Error::scene(loc, format!("invalid lookat transformation (origin {origin}, target {target}, up {up})")));
    }
    Ok(m)
}

/// A unit vector perpendicular to `n` (Mitsuba's `coordinate_system`, first vector; Duff et al. 2017).
fn any_orthogonal(n: DVec3) -> DVec3 {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(n.x * n.x * a * sign + 1.0, b * sign, -n.x * sign)
}

/// Applies one `<transform>` child (`tag` with substituted attributes) after `m`: returns op * m.
pub fn apply_op(m: Affine, tag: &str, attrs: &[(String, String)], loc: &Location) -> Result<Affine> {
    let op = match tag {
        "translate" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value"], loc)?;
            let v = xyz(tag, attrs, 0.0, loc)?;
            Affine { matrix: DMat4::from_translation(v), inverse_transpose: DMat4::from_translation(-v).transpose() }
        }
        "scale" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value"], loc)?;
            let v = xyz(tag, attrs, 1.0, loc)?;
            Affine { matrix: DMat4::from_scale(v), inverse_transpose: DMat4::from_scale(v.recip()) }
        }
        "rotate" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value", "angle"], loc)?;
            let axis = xyz(tag, attrs, 0.0, loc)?;
            if axis == DVec3::ZERO {
                return Err(Error::scene(loc, "<rotate>: rotation axis cannot be zero"));
            }
            let angle = attr(attrs, "angle").ok_or_else(|| Error::scene(loc, "<rotate>: missing attribute \"angle\""))?;
            let r = rotate(axis, parse_f64(angle, "<rotate> angle", loc)?);
            Affine { matrix: r, inverse_transpose: r }
        }
        "matrix" => {
            check_attrs(tag, attrs, &["value"], loc)?;
            let value = attr(attrs, "value").ok_or_else(|| Error::scene(loc, "<matrix>: missing attribute \"value\""))?;
            let v = parse_list(value, "<matrix> value", loc)?;
            let n = match v.len() {
                16 => 4,
                9 => 3,
                k => {
                    return Err(Error::scene(loc, format!("<matrix> must have 9 or 16 values, got {k}")));
                }
            };
            // Row-major in the file; glam is column-major.
            let mut cols = [DVec4::X, DVec4::Y, DVec4::Z, DVec4::W];
            for (i, row) in v.chunks(n).enumerate() {
                for (j, x) in row.iter().enumerate() {
                    cols[j][i] = *x;
                }
            }
            Affine::from_matrix(DMat4::from_cols(cols[0], cols[1], cols[2], cols[3]))
        }
        "lookat" => {
            check_attrs(tag, attrs, &["origin", "target", "up"], loc)?;
            let origin =
                vec3_attr(tag, attrs, "origin", loc)?.ok_or_else(|| Error::scene(loc, "<lookat>: missing attribute \"origin\""))?;
            let target =
                vec3_attr(tag, attrs, "target", loc)?.ok_or_else(|| Error::scene(loc, "<lookat>: missing attribute \"target\""))?;
            let up = vec3_attr(tag, attrs, "up", loc)?.unwrap_or(DVec3::ZERO);
            Affine::from_matrix(look_at(origin, target, up, loc)?)
        }
        other => {
            return Err(Error::scene(loc, format!("unexpected <{other}> element inside <transform>")));
        }
    };
    Ok(op * m)
}

/// The f32 matrix of an f64 transform.
pub fn to_f32(m: &DMat4) -> glam::Mat4 {
    m.as_mat4()
}

/// A `to_uv` transform as a 2D affine map (Mitsuba's `Transform4f::extract`).
pub fn to_uv_matrix(m: &DMat4) -> Mat3 {
    let m = m.as_mat4();
    Mat3::from_cols(Vec3::new(m.x_axis.x, m.x_axis.y, 0.0), Vec3::new(m.y_axis.x, m.y_axis.y, 0.0), Vec3::new(m.w_axis.x, m.w_axis.y, 1.0))
}

/// Mitsuba's `has_scale`: rows of the linear part not orthonormal within 1e-3.
pub fn has_scale(m: &DMat4) -> bool {
    let rows: Vec<DVec3> = (0..3).map(|i| DVec3::new(m.x_axis[i], m.y_axis[i], m.z_axis[i])).collect();
    for i in 0..3 {
        for j in i..3 {
            let expected = if i == j { 1.0 } else { 0.0 };
            if (rows[i].dot(rows[j]) - expected).abs() > 1e-3 {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests;
