//! The Magic Formula tire model, PAC2002 / MF 5.2 and MF 6.1 / 6.2 (one evaluator, the
//! version as data): coefficients, steady-state evaluation in ISO-W axes, derivatives with
//! respect to the coefficients, and the `.tir` property-file format.
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
pub mod version;

pub use jacobian::{Channel, MAX_BLOCK, MomentForces, moment_split};
pub use pac2002::{Evaluation, MagicFormula, Mode, Pac2002, Pressures, SlipInput, TrailPeak};
pub use params::{Coef, Coefs, Section};
pub use real::{Dual, Real};
pub use version::Version;

#[cfg(test)]
pub(crate) mod test_support;
// The seeded generator `test_support` reaches as `super::SplitMix64` (the benches import it too).
#[cfg(test)]
use crate::numerics::random::SplitMix64;
