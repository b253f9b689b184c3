//! `<transform>` children of Mitsuba 3 XML files, as `src/core/parser.cpp` of Mitsuba 3.9.1 reads them.
//!
//! Operations (`translate`, `rotate`, `scale`, `matrix`, `lookat`) apply in document order:
//! M = last * ... * first. Arithmetic is in f64 like Mitsuba's parser; callers cast to f32 at the end.
//! - `translate`: `x`/`y`/`z` (missing = 0) or `value="x, y, z"` (1 value = all three).
//! - `rotate`: axis from `x`/`y`/`z` or `value`, `angle` in degrees, right-handed; a zero axis is an error.
//! - `scale`: `x`/`y`/`z` (missing = 1) or `value` (1 or 3 numbers).
//! - `matrix`: 16 (or 9, for the upper-left 3x3) numbers, row-major.
//! - `lookat`: `origin`, `target`, optional `up` (zero or missing: any vector perpendicular to the view
//!   direction); columns (left, up', dir, origin) with left = normalize(up x dir), up' = dir x left.
//!
//! `to_uv` transforms of textures become 2D affine maps the way Mitsuba's `Transform::extract` does:
//! the upper-left 2x2 block plus the x/y translation (the z row and column are dropped).
use crate::error::{Error, Location, Result};
use glam::{DMat4, DVec3, DVec4, Mat3, Vec3};

/// Numbers of a list attribute: separated by commas and/or whitespace, as Mitsuba's `string::tokenize`.
pub fn tokenize(value: &str) -> Vec<&str> {
    value.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect()
}

/// Parses one floating-point number (surrounding whitespace allowed); the error names the value.
pub fn parse_f64(value: &str, what: &str, loc: &Location) -> Result<f64> {
    value
        .trim()
        .parse::<f64>()
        .map_err(|_| Error::scene(loc, format!("could not parse {what} \"{value}\" as a number")))
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
            n => Err(Error::scene(
                loc,
                format!("<{tag}> value=\"{value}\" must have exactly 1 or 3 numbers, got {n}"),
            )),
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

/// Right-handed rotation by `angle_deg` degrees about `axis` (normalised here).
pub fn rotate(axis: DVec3, angle_deg: f64) -> DMat4 {
    DMat4::from_axis_angle(axis.normalize(), angle_deg.to_radians())
}

/// Mitsuba's `look_at`: columns (left, up', dir, origin). NaN (e.g. up parallel to dir) is an error.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3, loc: &Location) -> Result<DMat4> {
    let dir = (target - origin).normalize();
    let up = if up == DVec3::ZERO { any_orthogonal(dir) } else { up };
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0));
    if m.to_cols_array().iter().any(|x| !x.is_finite()) {
        return Err(Error::scene(
            loc,
            format!("invalid lookat transformation (origin {origin}, target {target}, up {up})"),
        ));
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
pub fn apply_op(m: DMat4, tag: &str, attrs: &[(String, String)], loc: &Location) -> Result<DMat4> {
    let op = match tag {
        "translate" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value"], loc)?;
            DMat4::from_translation(xyz(tag, attrs, 0.0, loc)?)
        }
        "scale" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value"], loc)?;
            DMat4::from_scale(xyz(tag, attrs, 1.0, loc)?)
        }
        "rotate" => {
            check_attrs(tag, attrs, &["x", "y", "z", "value", "angle"], loc)?;
            let axis = xyz(tag, attrs, 0.0, loc)?;
            if axis == DVec3::ZERO {
                return Err(Error::scene(loc, "<rotate>: rotation axis cannot be zero"));
            }
            let angle = attr(attrs, "angle")
                .ok_or_else(|| Error::scene(loc, "<rotate>: missing attribute \"angle\""))?;
            rotate(axis, parse_f64(angle, "<rotate> angle", loc)?)
        }
        "matrix" => {
            check_attrs(tag, attrs, &["value"], loc)?;
            let value = attr(attrs, "value")
                .ok_or_else(|| Error::scene(loc, "<matrix>: missing attribute \"value\""))?;
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
            DMat4::from_cols(cols[0], cols[1], cols[2], cols[3])
        }
        "lookat" => {
            check_attrs(tag, attrs, &["origin", "target", "up"], loc)?;
            let origin = vec3_attr(tag, attrs, "origin", loc)?
                .ok_or_else(|| Error::scene(loc, "<lookat>: missing attribute \"origin\""))?;
            let target = vec3_attr(tag, attrs, "target", loc)?
                .ok_or_else(|| Error::scene(loc, "<lookat>: missing attribute \"target\""))?;
            let up = vec3_attr(tag, attrs, "up", loc)?.unwrap_or(DVec3::ZERO);
            look_at(origin, target, up, loc)?
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
    Mat3::from_cols(
        Vec3::new(m.x_axis.x, m.x_axis.y, 0.0),
        Vec3::new(m.y_axis.x, m.y_axis.y, 0.0),
        Vec3::new(m.w_axis.x, m.w_axis.y, 1.0),
    )
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
mod tests {
    use super::*;

    fn a(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    fn loc() -> Location {
        Location::new("t.xml", 3)
    }

    #[test]
    fn document_order_last_times_first() {
        let m = apply_op(DMat4::IDENTITY, "scale", &a(&[("value", "2")]), &loc()).unwrap();
        let m = apply_op(m, "translate", &a(&[("value", "1, 0, 0")]), &loc()).unwrap();
        // Scale first, then translate.
        assert_eq!(m.transform_point3(DVec3::new(1.0, 1.0, 1.0)), DVec3::new(3.0, 2.0, 2.0));
        let s = apply_op(DMat4::IDENTITY, "scale", &a(&[("value", "1 2 3")]), &loc()).unwrap();
        assert_eq!(s.transform_point3(DVec3::ONE), DVec3::new(1.0, 2.0, 3.0));
        let s = apply_op(DMat4::IDENTITY, "scale", &a(&[("x", "0.3"), ("z", "2")]), &loc()).unwrap();
        assert_eq!(s.transform_point3(DVec3::ONE), DVec3::new(0.3, 1.0, 2.0));
    }

    #[test]
    fn rotate_is_right_handed_degrees() {
        let m = apply_op(DMat4::IDENTITY, "rotate", &a(&[("y", "1"), ("angle", "90")]), &loc()).unwrap();
        let p = m.transform_point3(DVec3::X);
        assert!((p - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12, "{p}");
        let m = apply_op(DMat4::IDENTITY, "rotate", &a(&[("value", "0 0 1"), ("angle", "90")]), &loc()).unwrap();
        assert!((m.transform_point3(DVec3::X) - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn matrix_row_major_and_3x3() {
        let m = apply_op(
            DMat4::IDENTITY,
            "matrix",
            &a(&[("value", "1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1")]),
            &loc(),
        )
        .unwrap();
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
        let m = apply_op(DMat4::IDENTITY, "matrix", &a(&[("value", "0 -1 0 1 0 0 0 0 1")]), &loc()).unwrap();
        assert_eq!(m.transform_point3(DVec3::X), DVec3::Y);
        let e = apply_op(DMat4::IDENTITY, "matrix", &a(&[("value", "1 2 3")]), &loc()).unwrap_err();
        assert!(e.to_string().contains("t.xml:3") && e.to_string().contains("got 3"), "{e}");
    }

    #[test]
    fn lookat_columns() {
        let m = apply_op(
            DMat4::IDENTITY,
            "lookat",
            &a(&[("origin", "0, 0, 3.9"), ("target", "0, 0, 0"), ("up", "0, 1, 0")]),
            &loc(),
        )
        .unwrap();
        assert_eq!(m.x_axis, DVec4::new(-1.0, 0.0, 0.0, 0.0)); // left
        assert_eq!(m.y_axis, DVec4::new(0.0, 1.0, 0.0, 0.0));
        assert_eq!(m.z_axis, DVec4::new(0.0, 0.0, -1.0, 0.0));
        assert_eq!(m.w_axis, DVec4::new(0.0, 0.0, 3.9, 1.0));
        let e = look_at(DVec3::ZERO, DVec3::Y, DVec3::Y, &loc()).unwrap_err();
        assert!(e.to_string().contains("invalid lookat"), "{e}");
        assert!(!has_scale(&m));
        assert!(has_scale(&(DMat4::from_scale(DVec3::splat(2.0)) * m)));
    }

    #[test]
    fn bad_values_name_the_value() {
        let e = apply_op(DMat4::IDENTITY, "translate", &a(&[("x", "1O")]), &loc()).unwrap_err();
        assert!(e.to_string().contains("\"1O\""), "{e}");
        let e = apply_op(DMat4::IDENTITY, "rotate", &a(&[("angle", "3")]), &loc()).unwrap_err();
        assert!(e.to_string().contains("axis cannot be zero"), "{e}");
        let e = apply_op(DMat4::IDENTITY, "skew", &a(&[]), &loc()).unwrap_err();
        assert!(e.to_string().contains("<skew>"), "{e}");
    }

    #[test]
    fn to_uv_takes_2x2_and_xy_translation() {
        let m = DMat4::from_translation(DVec3::new(0.5, 0.25, 9.0)) * DMat4::from_scale(DVec3::new(8.0, 4.0, 7.0));
        let uv = to_uv_matrix(&m);
        assert_eq!(uv.transform_point2(glam::Vec2::new(1.0, 1.0)), glam::Vec2::new(8.5, 4.25));
    }
}
