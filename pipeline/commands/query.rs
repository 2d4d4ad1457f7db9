//! `tirebase query`: SQL over a store, result on stdout (aligned table or CSV).

use std::io::Write;
use std::process::ExitCode;

use crate::cli::{OutputFormat, QueryArgs};
use crate::query;

/// Run the query and print it.
pub fn run(args: &QueryArgs) -> anyhow::Result<ExitCode> {
    let mut df = query::run(&args.store, &args.sql)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match args.format {
        OutputFormat::Csv => query::write_csv(&mut df, &mut out)?,
        OutputFormat::Table => out.write_all(query::format_table(&df).as_bytes())?,
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
