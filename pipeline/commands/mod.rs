//! Command layer: one function per subcommand, joining the stages and turning their reports into
//! an exit code. Stages never call each other; this layer does.

use std::process::ExitCode;

use crate::cli::{Cli, Command};

pub mod compare;
pub mod diff;
pub mod fit;
pub mod inertia;
pub mod ingest;
pub mod query;
pub mod report;
pub mod run;
pub mod synth;
pub mod tir;
pub mod versions;

/// Run one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Versions(args) => versions::run(&args),
        Command::Diff(args) => diff::run(&args),
        Command::Tir(cmd) => tir::run(cmd),
        Command::Ingest(args) => ingest::run(&args),
        Command::Fit(args) => fit::run(&args),
        Command::Query(args) => query::run(&args),
        Command::Report(args) => report::run(&args),
        Command::Compare(args) => compare::run(&args),
        Command::Inertia(args) => inertia::run(&args),
        Command::Synth { what } => synth::run(&what),
    }
}
