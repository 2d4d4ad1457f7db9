//! Order statistics shared by every stage: the median, in its two conventions, and the number
//! of distinct levels a variable takes.
//!
//! In: `f64` values (a scratch slice the functions may reorder, or any iterator). Out: the
//! median, `None` when there are no values; a count of levels ([`count_levels`]). Two conventions, because results depend on them:
//! [`median`] averages the two middle values of an even count (the textbook median);
//! [`median_high`] takes the upper one (always a member of the data, cheaper, what robust
//! step and rate estimates use). Order is `f64::total_cmp`, so the result never depends on the
//! input order. The `finite_` forms skip NaN and infinities first.

/// The median of `values` (reordered in place): the mean of the two middle values for an even
/// count; `None` when empty.
pub fn median(values: &mut [f64]) -> Option<f64> {
    let mid = values.len() / 2;
    let upper = median_high(values)?;
    if values.len() % 2 == 1 {
        return Some(upper);
    }
    // after the selection every value below `mid` is <= the upper middle one
    let lower = values[..mid].iter().copied().max_by(f64::total_cmp)?;
    Some(0.5 * (lower + upper))
}

/// The upper median of `values` (reordered in place): the value at position `len / 2` in
/// sorted order; `None` when empty.
pub fn median_high(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mid = values.len() / 2;
    let (_, m, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// [`median`] of the finite values.
pub fn finite_median(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    median(&mut finite(values))
}

/// [`median_high`] of the finite values.
pub fn finite_median_high(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    median_high(&mut finite(values))
}

/// Counts the distinct levels of the finite `values`: in sorted order, a value starts a new level
/// when it exceeds the first value of the current level by more than `tol`.
pub fn count_levels(values: impl IntoIterator<Item = f64>, tol: f64) -> usize {
    let mut v = finite(values);
    v.sort_by(f64::total_cmp);
    let mut n = 0;
    let mut last = f64::NEG_INFINITY;
    for x in v {
        if x - last > tol {
            n += 1;
            last = x;
        }
    }
    n
}

fn finite(values: impl IntoIterator<Item = f64>) -> Vec<f64> {
    values.into_iter().filter(|v| v.is_finite()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::random::SplitMix64;

    #[test]
    fn levels_are_counted_with_tolerance() {
        assert_eq!(count_levels([222.0, 223.0, 445.0, 444.0, 667.0], 5.0), 3);
        assert_eq!(count_levels([0.0, 4.0, 8.0, 12.0], 5.0), 2);
        assert_eq!(count_levels([f64::NAN, 1.0, f64::INFINITY], 1.0), 1);
        assert_eq!(count_levels([], 1.0), 0);
    }

    /// The definitions by sorting, to compare bits with.
    fn sorted_median(v: &[f64]) -> (f64, f64) {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let mean = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        (mean, s[n / 2])
    }

    #[test]
    fn small_cases() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median_high(&mut []), None);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median_high(&mut [4.0, 1.0, 3.0, 2.0]), Some(3.0));
        assert_eq!(finite_median([3.0, f64::NAN, 1.0, 2.0]), Some(2.0));
        assert_eq!(finite_median_high([f64::INFINITY, 1.0, 2.0]), Some(2.0));
        assert_eq!(finite_median([f64::NAN]), None);
    }

    #[test]
    fn selection_gives_the_bits_of_sorting() {
        // Random lengths and values with repeats, signed zeros and extremes: the selection
        // returns exactly the sorted definition's bits.
        let mut rng = SplitMix64::new(11);
        for _ in 0..500 {
            let n = 1 + (rng.next_u64() % 40) as usize;
            let v: Vec<f64> = (0..n)
                .map(|_| match rng.next_u64() % 6 {
                    0 => 0.0,
                    1 => -0.0,
                    2 => 1.0,
                    3 => f64::MAX,
                    _ => rng.uniform_in(-10.0, 10.0),
                })
                .collect();
            let (mean, high) = sorted_median(&v);
            assert_eq!(median(&mut v.clone()).unwrap().to_bits(), mean.to_bits());
            assert_eq!(
                median_high(&mut v.clone()).unwrap().to_bits(),
                high.to_bits()
            );
        }
    }
}
