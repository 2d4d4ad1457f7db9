//! Synthetic data with known answers: the virtual TTC test machine (a whole round of raw run
//! files and its truth) and rig-inertia sessions ([`inertia`]).
//!
//! Data flow of a round: `tires` (truth models) + `schedule` (commanded programs) -> `machine`
//! (physics from `physics`, sensors, `noise`) -> `dat` (axes, units, decimals, `.dat`) -> `round`
//! (run list, `.mat`, `defects`, truth files). Nothing here touches the file system: the command
//! layer writes what these functions return.

pub mod dat;
pub mod defects;
pub mod drift;
pub mod inertia;
pub mod machine;
pub mod noise;
pub mod physics;
pub mod quirks;
pub mod round;
pub mod schedule;
pub mod tires;

#[cfg(test)]
mod tests;
