//! The `tirebase` binary: parse the command line, run one command, turn its outcome into an
//! exit code. Nothing else lives here.

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = tirebase::cli::Cli::parse();
    match tirebase::commands::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", tirebase::commands::error_line(&err));
            ExitCode::from(2)
        }
    }
}
