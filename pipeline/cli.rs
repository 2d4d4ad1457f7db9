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
