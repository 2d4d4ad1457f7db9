//! `tirebase ingest`: raw files -> store, with every per-file problem and a summary on stderr
//! and the exit code contract (0 all ingested or unchanged, 1 some failed or stored with rows
//! missing, 2 usage error or a store that cannot be written).

use std::process::ExitCode;

use crate::catalog::Catalog;
use crate::cli::IngestArgs;
use crate::config::Config;
use crate::ingest::{self, FileStatus, IngestOptions, IngestReport};
use crate::progress;
use crate::store::lock::LockWait;

/// Ingest the given paths.
pub fn run(args: &IngestArgs) -> anyhow::Result<ExitCode> {
    let config = Config::load(args.config.as_deref())?;
    let catalog = args.catalog.as_deref().map(Catalog::read).transpose()?;
    let opts = IngestOptions {
        store: &args.store,
        catalog: catalog.as_ref(),
        segment: &config.segment,
        jobs: args.jobs,
        lock_wait: if args.no_wait {
            LockWait::Refuse
        } else {
            LockWait::Wait
        },
        rehash: args.rehash,
        keep_duplicate_runs: args.keep_duplicate_runs,
        // `ingest` may be given part of the input: other files' rows stay.
        prune: false,
    };
    let progress = progress::for_stderr();
    let report = match ingest::run(&args.paths, &opts, progress.as_ref()) {
        Ok(r) => r,
        Err(
            e @ (ingest::IngestError::MissingInput(_)
            | ingest::IngestError::Input(_)
            | ingest::IngestError::Pool { .. }),
        ) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(2));
        }
        Err(ingest::IngestError::Store(e)) => {
            // Not a failure of an input file: nothing was committed, the next ingest starts over.
            eprintln!("error: store error, nothing committed: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    print_problems(&report);
    eprintln!("{}", report.summary());
    if report.files.is_empty() {
        eprintln!("warning: no .dat or .mat files found");
    }
    let failed = report.count(|s| matches!(s, FileStatus::Failed(_)));
    Ok(if failed > 0 || !report.partial.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// Every per-file problem, grouped (failed, partial, warnings, skipped entries) under a line
/// that counts them; one line per problem naming the file.
fn print_problems(report: &IngestReport) {
    let failed: Vec<(String, String)> = report
        .failures()
        .map(|(f, e)| (f.to_string(), e.to_string()))
        .collect();
    let skipped: Vec<(String, String)> = report
        .skipped
        .iter()
        .map(|(p, why)| (p.display().to_string(), why.clone()))
        .collect();
    for (label, what, items) in [
        ("failed", "files failed", &failed),
        ("partial", "files stored with rows missing", &report.partial),
        ("warning", "warnings", &report.warnings),
        ("skipped", "directory entries skipped", &skipped),
    ] {
        if items.is_empty() {
            continue;
        }
        eprintln!("{} {what}:", items.len());
        for (file, reason) in items {
            eprintln!("{label}: {file}: {reason}");
        }
    }
}
