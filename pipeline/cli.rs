//! Command-line definitions (clap derive). Only the shape of the interface lives here; each
//! command's behaviour is in `commands/<name>.rs`.
//!
//! Conventions every command follows: physical inputs and outputs are SI (N, N m, m, rad, s,
//! Pa or kPa where the column name says so); tire quantities are in the ISO-W (TYDEX W) axis
//! frame (x forward, y left, z up, Fz > 0 in compression) unless a help text says SAE.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

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
    /// Run SQL over a store's tables and print the result.
    Query(QueryArgs),
}

/// `tirebase ingest`.
#[derive(Debug, Args)]
#[command(long_about = "\
Read raw TTC run files (.dat ASCII and .mat MATLAB v5, any round, US customary or SI) into the
tire database. Every channel is converted to SI by its own unit string and to the ISO-W axis
frame (Fz > 0 in compression, alpha = -SA, Fy and Mz negated); each run is split into classified
segments (spring-rate holds, cold-to-warm, conditioning, cornering, drive/brake, combined, step
steers, IA and speed sweeps) binned to nominal pressure, inclination, load, slip angle and speed.

Incremental: a file whose content hash is already stored is skipped; a changed file replaces its
rows atomically; a file that cannot be read is listed in the runs table with its error and the
rest of the batch is stored.

Exit codes: 0 every file ingested (or unchanged), 1 some files failed (the others are stored),
2 usage error.")]
pub struct IngestArgs {
    /// Raw files or directories (searched recursively for *.dat and *.mat).
    #[arg(required = true, value_name = "PATH")]
    pub paths: Vec<PathBuf>,
    /// Store root directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub store: PathBuf,
    /// Run catalog TOML mapping (project, run) to tire and rim ([[run]] project, run, tire,
    /// rim_in, kind). Without it the tire comes from the file (tireid, Tire_Name=) or is
    /// named project<p>-run<n>.
    #[arg(long, value_name = "FILE")]
    pub catalog: Option<PathBuf>,
    /// Configuration file (TOML, see config/default.toml); overrides the defaults.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Worker threads (0 = one per core). Results do not depend on it.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub jobs: usize,
    /// Fail at once if another tirebase process holds the store, instead of waiting.
    #[arg(long)]
    pub no_wait: bool,
}

/// Output formats for tables printed to stdout.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// Aligned text table.
    Table,
    /// CSV with a header row, full float precision.
    Csv,
}

/// `tirebase query`.
#[derive(Debug, Args)]
#[command(long_about = "\
Run one SQL statement (polars SQL) over a store and print the result on stdout.

Tables: samples (every sample: et_s, fx_n, fy_n, fz_n, mx_nm, mz_nm, alpha_rad, kappa,
gamma_rad, pressure_kpa, speed_kph, ... in SI and ISO-W, plus the partition columns test, tire,
rim_in, pressure_kpa_nom, ia_deg_nom, fz_n_nom), segments (one row per segment: kind, nominal and
measured levels, ET range, QC flags), runs (one row per raw file: hash, status, error). Published
result tables (coefficients, fit_quality, spring_rate, thermal, thermal_fit, relaxation,
inertia) appear with a version column, <table>_latest holds the newest version only, and
versions lists the versions.

Example:
  tirebase query --store outputs/store \"SELECT kind, count(*) AS n FROM segments GROUP BY kind\"")]
pub struct QueryArgs {
    /// Store root directory.
    #[arg(long, value_name = "DIR")]
    pub store: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    pub format: OutputFormat,
    /// The SQL statement.
    #[arg(value_name = "SQL")]
    pub sql: String,
}
