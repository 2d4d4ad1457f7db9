//! tirebase: raw TTC tire-test files in, fitted, versioned, queryable PAC2002 models out.
//!
//! ```text
//! raw .dat/.mat ──ingest──▶ runs (SI, ISO-W) ──segment──▶ samples + segments (hive Parquet)
//!        │                                                     │
//!        │                      ┌──────────────fit (rayon fan-out)─────────────┐
//!        │                      ▼            ▼            ▼             ▼
//!        │                 PAC2002 .tir   spring rate   thermal     relaxation
//!        │                      └────────────┴──────┬─────┴─────────────┘
//! inertia sessions ──inertia──────────────────────▶ publish ──▶ versions/vNNNNNN (immutable)
//!                                                           └──▶ query (SQL) · diff · report
//! ```
//!
//! The pure numerics (model, formats, fitting math, inertia math, virtual test machine) live in
//! the `tirebase-core` crate, re-exported here as [`core`]; this crate owns the command line,
//! configuration, the on-disk store and the orchestration of stages.

pub use tirebase_core as core;

pub mod catalog;
pub mod cli;
pub mod commands;
pub mod config;
pub mod diff;
pub mod fit;
pub mod inertia;
pub mod ingest;
pub mod manifest;
pub mod progress;
pub mod query;
pub mod report;
pub mod run;
pub mod schema;
pub mod store;
