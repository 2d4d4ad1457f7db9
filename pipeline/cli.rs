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
    /// PAC2002 / MF 5.2 `.tir` property files: evaluate, lint, convert.
    #[command(subcommand)]
    Tir(TirCommand),
    /// Run SQL over a store's tables and print the result.
    Query(QueryArgs),
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

/// `tirebase tir ...`
#[derive(Debug, Subcommand)]
pub enum TirCommand {
    /// Evaluate a .tir model at the operating points of a CSV file.
    ///
    /// IN.csv needs a header with the columns Fz_N (vertical load, N, > 0 in compression),
    /// kappa (longitudinal slip ratio, > 0 driving, -1 locked), alpha_rad (slip angle, rad),
    /// gamma_rad (inclination angle, rad) and Vx_mps (wheel-centre forward speed, m/s), in any
    /// order; other columns are ignored. All in ISO-W (TYDEX W) axes: x forward, y left, z up,
    /// so alpha > 0 gives Fy < 0 on a normal tire. (From SAE data: negate alpha and Fz.)
    ///
    /// OUT.csv repeats every input column, in the same row order, and adds Fx_N, Fy_N (N),
    /// Mx_Nm, My_Nm, Mz_Nm (N m), ISO-W, combined slip, written with full round-trip
    /// precision. An input column already named like an output is kept as <name>_input.
    Eval(TirEvalArgs),
    /// Check a .tir file for physical problems over its operating envelope.
    ///
    /// Samples Fz, inclination, kappa and alpha over the file's range sections and reports
    /// errors (e.g. C <= 0, Gxa or Gyk <= 0, oscillating Fx/Fy, FNOMIN <= 0, a coefficient
    /// family missing for the declared USE_MODE) and warnings (e.g. E > 1 before clamping,
    /// |RHX1| large). Findings go to stdout as `FILE: severity[code]: message`. The file is
    /// read in SI units (its [UNITS] converted) and ISO-W axes; findings state loads in N and
    /// angles in degrees.
    ///
    /// Exit code: 0 no errors (warnings printed), 1 lint errors found, 2 the file cannot be
    /// read (a one-line reason naming the line).
    Lint(TirLintArgs),
    /// Rewrite any accepted .tir file as a complete PAC2002 file in the Adams layout.
    ///
    /// Accepts PAC2002 (with or without FITTYP), MF_05 and MF 5.2 (FITTYP 6 or 21) files in any
    /// [UNITS]; writes SI units (m, N, rad, kg, s, Pa), PROPERTY_FILE_FORMAT = 'PAC2002' and
    /// FITTYP = 6, every coefficient once with its description, LF line endings. Numbers are
    /// written so that reading the output gives back exactly the same values. Sections it
    /// does not know are kept at the end.
    Convert(TirConvertArgs),
}

/// How inputs are limited when evaluating.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum EvalMode {
    /// Like MFeval useMode 111: inputs clipped to the file's ranges (KPUMIN..KPUMAX,
    /// ALPMIN..ALPMAX, CAMMIN..CAMMAX, Fz <= FZMAX), every curvature factor E <= 1,
    /// low-speed blending below VXLOW.
    Limits,
    /// Like MFeval useMode 211: the equations as they stand, no clipping, no E clamp.
    Raw,
}

/// Arguments of `tir eval`.
#[derive(Debug, Args)]
pub struct TirEvalArgs {
    /// The .tir property file (PAC2002 / MF 5.2).
    #[arg(long, value_name = "FILE")]
    pub tir: PathBuf,
    /// Operating points: CSV with header columns Fz_N, kappa, alpha_rad, gamma_rad, Vx_mps
    /// (SI, ISO-W).
    #[arg(long, value_name = "IN.csv")]
    pub input: PathBuf,
    /// Where to write the input columns plus Fx_N, Fy_N, Mx_Nm, My_Nm, Mz_Nm (SI, ISO-W).
    #[arg(long, value_name = "OUT.csv")]
    pub output: PathBuf,
    /// Input limiting.
    #[arg(long, value_enum, default_value_t = EvalMode::Limits)]
    pub mode: EvalMode,
}

/// Arguments of `tir lint`.
#[derive(Debug, Args)]
pub struct TirLintArgs {
    /// The .tir property file to check.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
}

/// Arguments of `tir convert`.
#[derive(Debug, Args)]
pub struct TirConvertArgs {
    /// Any accepted .tir file.
    #[arg(long, value_name = "F")]
    pub input: PathBuf,
    /// Where to write the normalised PAC2002 file.
    #[arg(long, value_name = "G")]
    pub output: PathBuf,
}
