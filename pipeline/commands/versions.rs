//! `tirebase versions --store DIR`: per published version a line (number, date, input files,
//! groups fitted/reused, coefficient rows, .tir files, what changed) and a line of row counts per
//! table, read from the manifests; stdout.
//!
//! Deliberately not here: anything that writes.

use std::process::ExitCode;

use crate::cli::VersionsArgs;
use crate::manifest::Manifest;
use crate::store::versions;

/// List the versions.
pub fn run(args: &VersionsArgs) -> anyhow::Result<ExitCode> {
    let all = versions::list(&args.store)?;
    if all.is_empty() {
        eprintln!("{}: no published versions", args.store.display());
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{:<8} {:<20} {:>13} {:>15} {:>6} {:>6}  changes",
        "version", "date (UTC)", "files ok/fail", "groups fit/reuse", "coefs", ".tir"
    );
    for (n, dir) in all {
        match Manifest::read(&dir) {
            Ok(m) => {
                let c = &m.counts;
                println!(
                    "v{n:06} {:<20} {:>13} {:>15} {:>6} {:>6}  {}",
                    m.created_utc,
                    format!("{}/{}", c.files_ok, c.files_failed),
                    format!("{}/{}", c.groups_fitted, c.groups_reused),
                    m.tables.get("coefficients").copied().unwrap_or(0),
                    c.tir_files,
                    m.summary
                );
                let tables: Vec<String> = m
                    .tables
                    .iter()
                    .map(|(t, rows)| format!("{t} {rows}"))
                    .collect();
                println!("{:8} rows: {}", "", tables.join(", "));
            }
            Err(e) => println!("v{n:06} unreadable manifest: {e}"),
        }
    }
    Ok(ExitCode::SUCCESS)
}
