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
//!                                                           └──▶ query (SQL) · diff · compare · report
//! ```
//!
//! The pure numerics (model, formats, fitting math, inertia math, virtual test machine) live in
//! the `tirebase-core` crate, re-exported here as [`core`]; this crate owns the command line,
//! configuration, the on-disk store and the orchestration of stages.

pub use tirebase_core as core;

pub mod catalog;
pub mod cli;
pub mod commands;
pub mod compare;
pub mod config;
pub mod diff;
pub mod fit;
pub mod inertia;
pub mod ingest;
pub mod manifest;
pub mod progress;
pub mod publish;
pub mod query;
pub mod report;
pub mod run;
pub mod schema;
pub mod score;
pub mod store;

/// Stack of every worker thread that may run polars (ingest, fit, report pools). A rayon worker
/// that waits (in `join`, or for polars' own pool) steals and nests further tasks, and polars'
/// unoptimised frames (debug builds, and its planner/engine crates in release) are large: the
/// default 2 MiB overflowed in ingest (release, full round) and in the report (debug). Virtual
/// memory only: pages are touched as the stack grows.
pub const WORKER_STACK_BYTES: usize = 64 << 20;
