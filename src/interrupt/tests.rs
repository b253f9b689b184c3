use super::*;

#[test]
fn chunked_map_keeps_order_and_values() {
    let v = par_map_chunked(10_001, 1000, |i| i * 3).unwrap();
    assert_eq!(v.len(), 10_001);
    assert!(v.iter().enumerate().all(|(i, &x)| x == 3 * i));
    assert!(par_map_chunked(0, 10, |i| i).unwrap().is_empty());
}
