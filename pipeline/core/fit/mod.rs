//! Fitting stages: measured sweeps in, model coefficients and fit-quality facts out.
//!
//! One module per stage; they share nothing but the numerics in [`crate::numerics`]. Pure: no
//! file system, no Parquet (the `tirebase` crate reads the store and writes the tables).
//! Deliberately minimal here: the spring-rate, thermal and relaxation stages become siblings of
//! `pac2002`.

pub mod relaxation;
pub mod scalar;
pub mod segment_data;
pub mod spring_rate;
pub mod thermal;

#[cfg(test)]
mod testkit;
