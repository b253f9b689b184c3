use super::*;

fn a(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

fn mat(tag: &str, attrs: &[(String, String)], loc: &Location) -> Result<DMat4> {
    apply_op(Affine::IDENTITY, tag, attrs, loc).map(|t| t.matrix)
}

fn loc() -> Location {
    Location::new("t.xml", 3)
}

#[test]
fn document_order_last_times_first() {
    let m = apply_op(Affine::IDENTITY, "scale", &a(&[("value", "2")]), &loc()).unwrap();
    let m = apply_op(m, "translate", &a(&[("value", "1, 0, 0")]), &loc()).unwrap().matrix;
    // Scale first, then translate.
    assert_eq!(m.transform_point3(DVec3::new(1.0, 1.0, 1.0)), DVec3::new(3.0, 2.0, 2.0));
    let s = mat("scale", &a(&[("value", "1 2 3")]), &loc()).unwrap();
    assert_eq!(s.transform_point3(DVec3::ONE), DVec3::new(1.0, 2.0, 3.0));
    let s = mat("scale", &a(&[("x", "0.3"), ("z", "2")]), &loc()).unwrap();
    assert_eq!(s.transform_point3(DVec3::ONE), DVec3::new(0.3, 1.0, 2.0));
}

#[test]
fn rotate_is_right_handed_degrees() {
    let m = mat("rotate", &a(&[("y", "1"), ("angle", "90")]), &loc()).unwrap();
    let p = m.transform_point3(DVec3::X);
    assert!((p - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12, "{p}");
    let m = mat("rotate", &a(&[("value", "0 0 1"), ("angle", "90")]), &loc()).unwrap();
    assert!((m.transform_point3(DVec3::X) - DVec3::Y).length() < 1e-12);
}

/// Row-major 3x4 of `m` (rows 0..3, columns 0..4).
fn rows(m: &DMat4) -> [[f64; 4]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m.col(j)[i]))
}

fn assert_rows(got: &DMat4, want: [[f64; 4]; 3], what: &str) {
    let g = rows(got);
    for i in 0..3 {
        for j in 0..4 {
            assert!((g[i][j] - want[i][j]).abs() < 1e-12, "{what}: [{i}][{j}] {} vs {}", g[i][j], want[i][j]);
        }
    }
}

#[test]
fn rotate_keeps_a_non_unit_axis_as_mitsuba() {
    // mi.ScalarTransform4d().rotate([-1, 2, 0.5], -33) in mitsuba 3.9.1: matrix == inverse_transpose.
    let want = [
        [1.0, -0.05033934660163836, -1.1699427860573421, 0.0],
        [-0.5949783816166654, 1.4839882961637278, -0.38330960296045113, 0.0],
        [1.0086133540027662, 0.705968467069603, 0.879002925959068, 0.0],
    ];
    let t = apply_op(Affine::IDENTITY, "rotate", &a(&[("value", "-1, 2, 0.5"), ("angle", "-33")]), &loc()).unwrap();
    assert_rows(&t.matrix, want, "matrix");
    assert_rows(&t.inverse_transpose, want, "normal matrix");
    // lookat with a non-orthogonal up: mi.ScalarTransform4d().look_at([1,2,3], [0,0,0], [0,0.5,1]).
    let t = apply_op(Affine::IDENTITY, "lookat", &a(&[("origin", "1 2 3"), ("target", "0 0 0"), ("up", "0 0.5 1")]), &loc()).unwrap();
    assert_rows(
        &t.matrix,
        [
            [0.408248290463863, -0.8728715609439696, -0.2672612419124244, 1.0],
            [-0.816496580927726, -0.2182178902359924, -0.5345224838248488, 2.0],
            [0.408248290463863, 0.4364357804719848, -0.8017837257372732, 3.0],
        ],
        "lookat",
    );
    let last_row = [t.inverse_transpose.x_axis.w, t.inverse_transpose.y_axis.w, t.inverse_transpose.z_axis.w];
    assert!((last_row[2] - 3.7416573867739413).abs() < 1e-12 && last_row[0].abs() < 1e-12, "{last_row:?}");
    // Products multiply both matrices: scale then translate.
    let t = apply_op(Affine::IDENTITY, "scale", &a(&[("value", "2 4 -8")]), &loc()).unwrap();
    let t = apply_op(t, "translate", &a(&[("x", "1")]), &loc()).unwrap();
    assert_eq!(t.transform_normal(DVec3::ONE), DVec3::new(0.5, 0.25, -0.125));
    assert_eq!(t.inverse_transpose, t.matrix.inverse().transpose());
}

#[test]
fn matrix_row_major_and_3x3() {
    let m = mat("matrix", &a(&[("value", "1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1")]), &loc()).unwrap();
    assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
    let m = mat("matrix", &a(&[("value", "0 -1 0 1 0 0 0 0 1")]), &loc()).unwrap();
    assert_eq!(m.transform_point3(DVec3::X), DVec3::Y);
    let e = mat("matrix", &a(&[("value", "1 2 3")]), &loc()).unwrap_err();
    assert!(e.to_string().contains("t.xml:3") && e.to_string().contains("got 3"), "{e}");
}

#[test]
fn lookat_columns() {
    let m = mat("lookat", &a(&[("origin", "0, 0, 3.9"), ("target", "0, 0, 0"), ("up", "0, 1, 0")]), &loc()).unwrap();
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
    let e = mat("translate", &a(&[("x", "1O")]), &loc()).unwrap_err();
    assert!(e.to_string().contains("\"1O\""), "{e}");
    let e = mat("rotate", &a(&[("angle", "3")]), &loc()).unwrap_err();
    assert!(e.to_string().contains("axis cannot be zero"), "{e}");
    let e = mat("skew", &a(&[]), &loc()).unwrap_err();
    assert!(e.to_string().contains("<skew>"), "{e}");
}

#[test]
fn to_uv_takes_2x2_and_xy_translation() {
    let m = DMat4::from_translation(DVec3::new(0.5, 0.25, 9.0)) * DMat4::from_scale(DVec3::new(8.0, 4.0, 7.0));
    let uv = to_uv_matrix(&m);
    assert_eq!(uv.transform_point2(glam::Vec2::new(1.0, 1.0)), glam::Vec2::new(8.5, 4.25));
}
