//! The PAC2002 / Magic Formula 5.2 tire model: coefficients, steady-state evaluation in ISO-W
//! axes, derivatives with respect to the coefficients, and the `.tir` property-file format.
//!
//! Pure code: no file system, no serde, no Arrow. Reading a `.tir` takes a `&str`.

mod batch;
pub mod factors;
pub mod jacobian;
mod lanes;
pub mod pac2002;
pub mod params;
pub mod real;
pub mod tir;

pub use jacobian::{Channel, MAX_BLOCK};
pub use pac2002::{Evaluation, Mode, Pac2002, SlipInput, TrailPeak};
pub use params::{Coef, Coefs, Section};
pub use real::{Dual, Real};

#[cfg(test)]
pub(crate) mod test_support;
// The seeded generator `test_support` reaches as `super::SplitMix64` (the benches import it too).
#[cfg(test)]
use crate::numerics::random::SplitMix64;
