//! `tirebase ingest`: raw files -> store, with a summary on stderr and the exit code contract
//! (0 all ingested or unchanged, 1 some failed, 2 usage error).

use std::process::ExitCode;

use crate::catalog::Catalog;
use crate::cli::IngestArgs;
use crate::config::Config;
use crate::ingest::{self, FileStatus, IngestOptions};
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
        Err(e @ ingest::IngestError::MissingInput(_)) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(2));
        }
        Err(e) => return Err(e.into()),
    };
    for (file, error) in report.failures() {
        eprintln!("failed: {file}: {error}");
    }
    eprintln!("{}", report.summary());
    if report.files.is_empty() {
        eprintln!("warning: no .dat or .mat files found");
    }
    let failed = report.count(|s| matches!(s, FileStatus::Failed(_)));
    Ok(if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
