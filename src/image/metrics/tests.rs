use super::*;

#[test]
fn metrics_on_known_values() {
    let b = [[1.0, 2.0, 2.0], [0.0, 0.0, 0.0]];
    let a = [[1.0, 2.0, 2.0], [0.0, 0.0, 3.0]];
    assert_eq!(relative_l2(&a, &b), 1.0); // ||(0,0,0,0,0,3)|| / ||(1,2,2)|| = 3 / 3
    assert_eq!(mse(&a, &b), 1.5);
    assert_eq!(rmse(&a, &b), 1.5f64.sqrt());
    assert_eq!(mae(&a, &b), 0.5);
    assert_eq!(max_abs_error(&a, &b), 3.0);
    assert_eq!(fraction_within(&a, &b, 0.0, 0.0), 0.5);
    assert_eq!(fraction_within(&a, &b, 0.0, 3.0), 1.0);
    let c = [[1.1, 2.0, 2.0], [0.0, 0.0, 0.0]];
    assert_eq!(fraction_within(&c, &b, 0.05, 0.0), 0.5); // |1.1 - 1| > 0.05
    assert_eq!(fraction_within(&c, &b, 0.11, 0.0), 1.0);
    assert!((relative_mse(&c, &b, 0.01) - 0.1f32.powi(2) as f64 / 1.01 / 6.0).abs() < 1e-7);
    assert_eq!(relative_l2(&b, &b), 0.0);
    let nan = [[f32::NAN, 2.0, 2.0], [0.0, 0.0, 0.0]];
    assert_eq!(fraction_within(&nan, &b, 1.0, 1.0), 0.5);
}
