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

/// One line for a failed command: the error and its causes joined by ": ", each cause once.
///
/// Many errors carry their source in their own message (`"query failed: {0}"`, `"{path}:
/// {source}"`) so that `to_string()` alone, as written into manifests, is complete; printing the
/// whole chain as well would repeat every such cause. A cause whose text the line already ends
/// with is therefore skipped.
pub fn error_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("query failed: {0}")]
    struct Wrapping(#[from] std::io::Error);

    #[test]
    fn error_line_names_a_cause_the_message_already_holds_once() {
        let io = std::io::Error::other("column \"test\" not found");
        let err = anyhow::Error::new(Wrapping(io)).context("store outputs/store");
        assert_eq!(
            error_line(&err),
            "store outputs/store: query failed: column \"test\" not found"
        );
    }

    #[test]
    fn error_line_joins_causes_the_message_does_not_hold() {
        let err = anyhow::anyhow!("disk full").context("cannot write v000002");
        assert_eq!(error_line(&err), "cannot write v000002: disk full");
    }
}
