//! Command-line definitions (clap derive). Only the shape of the interface lives here; each
//! command's behaviour is in `commands/<name>.rs`.
//!
//! Conventions every command follows: physical inputs and outputs are SI (N, N m, m, rad, s,
//! Pa or kPa where the column name says so); tire quantities are in the ISO-W (TYDEX W) axis
//! frame (x forward, y left, z up, Fz > 0 in compression) unless a help text says SAE.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// tirebase: raw TTC tire-test runs in, fitted and versioned PAC2002 tire models out.
#[derive(Debug, Parser)]
#[command(name = "tirebase", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Every subcommand. Each variant is added by the issue that implements it.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Rig inertia: process vehicle inertia/CG rig sessions into OUT/inertia.parquet.
    Inertia(InertiaArgs),
    /// Write synthetic data with known answers.
    Synth {
        #[command(subcommand)]
        what: SynthCommand,
    },
}

/// `tirebase inertia SESSION_DIR... --out OUT`
#[derive(Debug, Args)]
#[command(
    long_about = "Process rig-inertia sessions (yaw table with falling mass, trifilar pendulum, \
compound pendulum on a knife edge) into OUT/inertia.parquet: one row per result with columns \
session, run, object, axis, quantity, method, value, uncertainty (standard, k = 1), units (SI: \
kg*m^2, m, s, rad, N*m) and diagnostics. Axis is yaw (vertical), pitch or roll. A session is a \
directory with session.toml and one CSV per run (format: schemas/inertia_session.md). A failed \
run is reported on stderr and the other runs continue; the exit code is then 1 (2 for fatal \
errors). A short summary of the main results goes to stdout."
)]
pub struct InertiaArgs {
    /// Session directories (each holding session.toml and its run CSVs).
    #[arg(required = true, value_name = "SESSION_DIR")]
    pub sessions: Vec<PathBuf>,
    /// Output directory; inertia.parquet is written (replaced) there.
    #[arg(long, value_name = "OUT")]
    pub out: PathBuf,
}

/// What `tirebase synth` generates.
#[derive(Debug, Subcommand)]
pub enum SynthCommand {
    /// Synthetic rig-inertia sessions with known answers (validation cases V1-V5 of the inertia
    /// methods document, noise-free and noisy, plus a raw-encoder session with bounce, missed
    /// edges and drift). Each goes to DIR/<case>/ with session.toml, run CSVs and expected.toml.
    Inertia(SynthInertiaArgs),
}

/// `tirebase synth inertia --out DIR [--seed N]`
#[derive(Debug, Args)]
pub struct SynthInertiaArgs {
    /// Directory to write the sessions into (created; existing case directories are replaced).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Seed of the noise generators (SplitMix64); same seed, same bytes.
    #[arg(long, default_value_t = 20250314, value_name = "N")]
    pub seed: u64,
}
