//! Command-line definitions (clap derive). Only the shape of the interface lives here; each
//! command's behaviour is in `commands/<name>.rs`.
//!
//! Conventions every command follows: physical inputs and outputs are SI (N, N m, m, rad, s,
//! Pa or kPa where the column name says so); tire quantities are in the ISO-W (TYDEX W) axis
//! frame (x forward, y left, z up, Fz > 0 in compression) unless a help text says SAE.

use clap::{Parser, Subcommand};

/// tirebase: raw TTC tire-test runs in, fitted and versioned PAC2002 tire models out.
#[derive(Debug, Parser)]
#[command(name = "tirebase", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Every subcommand. Each variant is added by the issue that implements it.
#[derive(Debug, Subcommand)]
pub enum Command {}
