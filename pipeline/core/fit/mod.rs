//! Fitting stages: measured sweeps in, model coefficients and fit-quality facts out.
//!
//! One module per stage; they share nothing but the numerics in [`crate::numerics`], the
//! measured [`output`] channels, the k-fold-by-sweep dealing and flag rule of the
//! out-of-sample checks ([`sweep_folds`]) and the per-sweep noise factors ([`noise_weights`]).
//! Pure: no file system, no Parquet (the `tirebase` crate reads the store and writes the
//! tables).
//! [`pac2002`] fits the steady-state model; [`spring_rate`], [`thermal`] and [`relaxation`] are
//! the other fan-out stages, reading [`segment_data`] and sharing the 1-D minimiser [`scalar`].
//! [`mf61`] fits one MF 6.1 model per (tire, rim) across the tested pressures, starting from the
//! per-pressure PAC2002 fits.

pub mod mf61;
pub mod noise_weights;
pub mod output;
pub mod pac2002;
pub mod relaxation;
pub mod scalar;
pub mod segment_data;
pub mod spring_rate;
pub mod sweep_folds;
pub mod thermal;

#[cfg(test)]
mod testkit;
#[cfg(test)]
mod virtual_round;
