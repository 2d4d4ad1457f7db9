//! Synthetic data: the virtual TTC test machine (a whole round of raw run files and its truth).
//!
//! Data flow: `tires` (truth models) + `schedule` (commanded programs) -> `machine` (physics from
//! `physics`, sensors, `noise`) -> `dat` (axes, units, decimals, `.dat`) -> `round` (run list,
//! `.mat`, `defects`, truth files).

pub mod dat;
pub mod defects;
pub mod machine;
pub mod noise;
pub mod physics;
pub mod round;
pub mod schedule;
pub mod tires;

#[cfg(test)]
mod tests;
