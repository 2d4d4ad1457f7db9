//! Generic numerics shared by the fitting stages and the rig-inertia methods.
//!
//! In: plain slices and nalgebra vectors of `f64`. Out: fitted parameters with covariances and
//! convergence facts. One solver per kind of problem: linear least squares in [`least_squares`],
//! nonlinear least squares (optional bounds and robust loss; non-convergence is data, see
//! [`nonlinear_least_squares::FitOutcome`]) in [`nonlinear_least_squares`], used by every stage;
//! the one-dimensional minimiser of `fit::scalar` is argmin's Brent method, a different problem
//! (a scalar cost, no residuals). Also the seeded generator [`random::SplitMix64`] and the
//! medians of [`stats`], and the thread CPU clock of [`cpu_clock`] that times the fits.
//! Deliberately pure: no file system (bar that clock, read from `/proc`), no serde, no Arrow or
//! polars, no knowledge of tires or rigs.

pub mod cpu_clock;
pub mod damped_sine;
pub mod least_squares;
pub mod nonlinear_least_squares;
pub mod ode;
pub mod period;
pub mod random;
pub mod stats;

/// Bad input to a numerical routine (non-convergence is not an error: it is reported in the
/// outcome structs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NumericsError {
    /// Fewer data points than the model needs.
    #[error("{what}: need at least {needed} points, found {found}")]
    TooFewPoints {
        what: &'static str,
        needed: usize,
        found: usize,
    },
    /// Inputs of different lengths.
    #[error("{what}: length mismatch ({left} vs {right})")]
    LengthMismatch {
        what: &'static str,
        left: usize,
        right: usize,
    },
    /// A NaN or infinity in the input.
    #[error("{what}: non-finite value at index {index}")]
    NotFinite { what: &'static str, index: usize },
    /// The problem has no unique solution (rank-deficient design, flat signal).
    #[error("{what}: {reason}")]
    Degenerate { what: &'static str, reason: String },
}

/// Checks that every value is finite; `what` names the input in the error.
pub fn check_finite(what: &'static str, values: &[f64]) -> Result<(), NumericsError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(NumericsError::NotFinite { what, index }),
        None => Ok(()),
    }
}
