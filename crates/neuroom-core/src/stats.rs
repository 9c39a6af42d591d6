//! Order statistics the stages share.

use std::cmp::Ordering;

/// The upper median of `values` under `order`: the element at index `len / 2` once sorted (for an
/// even count, the upper of the two middle ones), found by selection, which reorders `values`.
/// `None` when there are none.
pub fn upper_median_by<T: Copy>(
    values: &mut [T],
    order: impl FnMut(&T, &T) -> Ordering,
) -> Option<T> {
    if values.is_empty() {
        return None;
    }
    let mid = values.len() / 2;
    Some(*values.select_nth_unstable_by(mid, order).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_upper_median_is_the_middle_of_the_sorted_values() {
        assert_eq!(
            upper_median_by(&mut [3.0f32, 1.0, 2.0], f32::total_cmp),
            Some(2.0)
        );
        assert_eq!(
            upper_median_by(&mut [4.0f64, 1.0, 3.0, 2.0], f64::total_cmp),
            Some(3.0)
        );
        assert_eq!(upper_median_by(&mut [] as &mut [f32], f32::total_cmp), None);
    }
}
