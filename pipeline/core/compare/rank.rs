//! Ranking by an objective that never hides a tie: two entries whose difference is within the
//! uncertainty of that difference are tied, and each entry's rank counts only the entries that
//! are better beyond doubt.
//!
//! In: objective values (higher is better) and a pairwise tolerance (the uncertainty of the
//! difference, e.g. [`difference_tolerance`] of the two values' own errors). Out: per entry its
//! [`Ranked`]: `rank = 1 + the number of entries better by more than the tolerance`, and the
//! entries it is tied with. With tolerances of the form `sqrt(e_i^2 + e_j^2)`, an entry better
//! than another beyond doubt always has a strictly smaller rank; ties do not chain (A tied with
//! B and B tied with C leaves A ahead of C when A - C exceeds their tolerance), and the tie lists
//! say so. A value that is not finite has no rank; a pair whose tolerance is not finite is a tie
//! (its difference cannot be judged).
//!
//! Deliberately not here: where the values and errors come from.

/// One entry's place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ranked {
    /// `1 +` the entries better beyond the tolerance; `None` for a value that is not finite.
    pub rank: Option<usize>,
    /// Indices of the other entries whose difference is within the tolerance, ascending.
    pub tied_with: Vec<usize>,
}

/// The uncertainty of the difference of two values with independent standard errors.
pub fn difference_tolerance(error_a: f64, error_b: f64) -> f64 {
    error_a.hypot(error_b)
}

/// Rank `values` (higher is better) with the pairwise `tolerance(i, j)` (symmetric, >= 0).
pub fn rank(values: &[f64], tolerance: &dyn Fn(usize, usize) -> f64) -> Vec<Ranked> {
    let n = values.len();
    (0..n)
        .map(|i| {
            if !values[i].is_finite() {
                return Ranked {
                    rank: None,
                    tied_with: Vec::new(),
                };
            }
            let mut better = 0;
            let mut tied_with = Vec::new();
            for j in (0..n).filter(|&j| j != i && values[j].is_finite()) {
                let tol = tolerance(i, j);
                let d = values[j] - values[i];
                if !tol.is_finite() || d.abs() <= tol {
                    tied_with.push(j);
                } else if d > 0.0 {
                    better += 1;
                }
            }
            Ranked {
                rank: Some(1 + better),
                tied_with,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ranks(values: &[f64], errors: &[f64]) -> Vec<Ranked> {
        rank(values, &|i, j| difference_tolerance(errors[i], errors[j]))
    }

    #[test]
    fn clear_differences_rank_in_order() {
        let r = ranks(&[1.0, 3.0, 2.0], &[0.01; 3]);
        let got: Vec<_> = r.iter().map(|r| r.rank).collect();
        assert_eq!(got, vec![Some(3), Some(1), Some(2)]);
        assert!(r.iter().all(|r| r.tied_with.is_empty()));
    }

    #[test]
    fn differences_within_the_errors_are_ties_and_do_not_chain() {
        // A - B and B - C within 0.14, A - C = 0.2 beyond it.
        let r = ranks(&[2.2, 2.1, 2.0], &[0.1; 3]);
        assert_eq!(r[0].rank, Some(1));
        assert_eq!(r[1].rank, Some(1), "nobody is better than B beyond doubt");
        assert_eq!(r[2].rank, Some(2), "A is better than C beyond doubt");
        assert_eq!(r[0].tied_with, vec![1]);
        assert_eq!(r[1].tied_with, vec![0, 2]);
        assert_eq!(r[2].tied_with, vec![1]);
    }

    #[test]
    fn unknown_values_and_tolerances() {
        let r = rank(&[1.0, f64::NAN, 0.5], &|_, _| f64::NAN);
        assert_eq!(r[1].rank, None);
        assert_eq!(r[0].rank, Some(1));
        assert_eq!(r[2].rank, Some(1), "an unknown tolerance is a tie");
        assert_eq!(r[0].tied_with, vec![2]);
    }

    proptest! {
        /// Whenever one entry beats another by more than their tolerance, its rank is smaller;
        /// tie lists are symmetric.
        #[test]
        fn beyond_doubt_means_strictly_ahead(
            values in prop::collection::vec(0.0f64..3.0, 2..12),
            errors in prop::collection::vec(0.0f64..0.3, 12),
        ) {
            let r = ranks(&values, &errors);
            for i in 0..values.len() {
                for j in 0..values.len() {
                    if i == j { continue; }
                    let tol = difference_tolerance(errors[i], errors[j]);
                    if values[i] - values[j] > tol {
                        prop_assert!(r[i].rank < r[j].rank, "{i} {j} {r:?}");
                    }
                    prop_assert_eq!(r[i].tied_with.contains(&j), r[j].tied_with.contains(&i));
                }
            }
        }
    }
}
