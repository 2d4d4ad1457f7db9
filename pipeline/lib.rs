//! tirebase: raw TTC tire-test files in, fitted, versioned, queryable tire models (PAC2002 per
//! tested pressure, MF 6.1 per tire and rim) out.
//!
//! ```text
//! raw .dat/.mat ──ingest──▶ runs (SI, ISO-W) ──segment──▶ samples + segments (hive Parquet)
//!        │                                                     │
//!        │      fit, per (tire, rim, pressure) group (rayon fan-out; the plan: fit::group):
//!        │        spring rate ─▶ PAC2002 ─▶ relaxation [─▶ PAC2002 de-lagged ─▶ relaxation]
//!        │        thermal (independent)
//!        │      then per (tire, rim): MF 6.1 across its tested pressures (fit::mf61)
//!        │                                                     │
//! inertia sessions ──inertia──────────────────────────────▶ publish ──▶ versions/vNNNNNN (immutable)
//!                                                           └──▶ query (SQL) · diff · compare · report
//! ```
//!
//! `run` chains them on one store (ingest ─▶ fit the changed groups ─▶ publish, which adds
//! inertia and the report; see [`run`]); each stage is also a command of its own. The
//! pure numerics (model, formats, fitting math, inertia math, virtual test machine) live in the
//! `tirebase-core` crate, re-exported here as [`core`]; this crate owns the command line,
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
pub mod synth_round;

/// Stack of every worker thread that may run polars (ingest, fit, report pools). A rayon worker
/// that waits (in `join`, or for polars' own pool) steals and nests further tasks, and polars'
/// unoptimised frames (debug builds, and its planner/engine crates in release) are large: the
/// default 2 MiB overflowed in ingest (release, full round) and in the report (debug). Virtual
/// memory only: pages are touched as the stack grows.
pub const WORKER_STACK_BYTES: usize = 64 << 20;
