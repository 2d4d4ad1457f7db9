//! Command layer: one function per subcommand, joining the stages and turning their reports into
//! an exit code. Stages never call each other; this layer does.

use std::process::ExitCode;

use crate::cli::{Cli, Command};

pub mod query;
pub mod synth;

/// Run one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match &cli.command {
        Command::Query(args) => query::run(args),
        Command::Synth(cmd) => synth::run(cmd),
    }
}
