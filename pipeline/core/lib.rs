//! tirebase-core: the pure half of tirebase.
//!
//! Everything in this crate is computation on values in memory: the PAC2002 tire model and its
//! `.tir` file format, numerics (least squares, filters, period estimation), the raw TTC file
//! formats (bytes in, typed SI/ISO-W runs out), segmentation, the fitting stages, the rig-inertia
//! methods, the virtual test machine and the tire-selection figures (`compare`). It never touches
//! the store (Parquet, versions, locks): that is the `tirebase` crate's job.
//!
//! It is a separate crate for one measurable reason: it is built at `opt-level = 3` even in debug
//! builds (see the workspace `Cargo.toml`), so fitting tests run at release speed while polars and
//! the rest of the heavy dependency tree stay cheap to compile.

pub mod compare;
pub mod fit;
pub mod frame;
pub mod inertia;
pub mod naming;
pub mod numerics;
pub mod physical;
pub mod segment;
pub mod synth;
pub mod tire_model;
pub mod ttc;
