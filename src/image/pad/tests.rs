use super::*;

#[test]
fn replicates_last_column_then_last_row() {
    assert_eq!(pad_to(1, 1, vec![7], 2, 3), (2, 3, vec![7; 6]));
    assert_eq!(pad_to(3, 1, vec![1, 2, 3], 2, 3), (3, 3, vec![1, 2, 3, 1, 2, 3, 1, 2, 3]));
    assert_eq!(pad_to(1, 2, vec![1, 2], 2, 3), (2, 3, vec![1, 1, 2, 2, 2, 2]));
    assert_eq!(pad_to(2, 3, vec![0; 6], 2, 3), (2, 3, vec![0; 6]));
}
