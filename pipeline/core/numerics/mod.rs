//! Generic numerics shared by the fitting stages (and, later, the rig-inertia methods).
//!
//! In: plain `f64` slices and problem traits. Out: fitted parameters with convergence facts;
//! non-convergence is data (see [`bounded_least_squares::FitOutcome`]), not an error.
//! Deliberately pure: no file system, no serde, no Arrow or polars, no knowledge of tires.

pub mod bounded_least_squares;
