//! `tirebase fit`: plan the groups of a store, fit them, write the tables and `.tir` files, print
//! the failures and a summary on stderr, and turn the outcome into the exit code (0 all stages
//! of all groups produced their result, 1 some failed, 2 nothing could be fitted).
//!
//! In: the parsed arguments. Out: files under `--out` (see `fit::write_outcome`). The work is in
//! `crate::fit`; this layer resolves configuration, holds the store lock while reading and
//! reports. Deliberately not here: any fitting or table logic.

use std::process::ExitCode;

use anyhow::Context;

use crate::cli::FitArgs;
use crate::config::Config;
use crate::fit::{self, FitOptions, StageSet};
use crate::progress;
use crate::store::layout::runs_file;
use crate::store::lock::{LockWait, StoreLock};
use crate::store::results::FailureKind;

/// Fit the store's groups.
pub fn run(args: &FitArgs) -> anyhow::Result<ExitCode> {
    let config = Config::load(args.config.as_deref())?;
    let stages = match StageSet::parse(&args.stages) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: --stages: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    let opts = FitOptions {
        tire: args.tire.clone(),
        stages,
        jobs: args.jobs,
    };
    if !crate::store::tables::has_runs(&args.store) {
        eprintln!(
            "error: {} is not a tirebase store (no {}): ingest first",
            args.store.display(),
            runs_file().display()
        );
        return Ok(ExitCode::from(2));
    }
    let progress = progress::for_stderr();
    let wait = if args.no_wait {
        LockWait::Refuse
    } else {
        LockWait::Wait
    };
    let outcome = {
        let _lock = StoreLock::acquire(&args.store, "fit", wait, |holder| {
            progress.note(&format!("waiting for the store lock held by {holder}"));
        })?;
        let plan = fit::plan_groups(&args.store, &config, &opts)?;
        if plan.is_empty() {
            eprintln!(
                "error: nothing to fit in {}{}: no segment with a nominal pressure that the stages {} read",
                args.store.display(),
                opts.tire
                    .as_deref()
                    .map(|t| format!(" for tire '{t}'"))
                    .unwrap_or_default(),
                opts.stages
            );
            return Ok(ExitCode::from(2));
        }
        fit::fit_groups(&args.store, &config, &plan, &opts, progress.as_ref())?
    };
    fit::write_outcome(&outcome, &args.out)
        .with_context(|| format!("writing results to {}", args.out.display()))?;
    for f in &outcome.failures {
        eprintln!("{}: {f}", f.kind().label());
    }
    for note in &outcome.tir_name_notes {
        eprintln!("renamed .tir: {note}");
    }
    let seconds: Vec<String> = outcome
        .stage_seconds
        .iter()
        .map(|(s, t)| format!("{s} {t:.1} s"))
        .collect();
    for g in &outcome.group_stats {
        eprintln!("timing: {g}");
    }
    eprintln!("{}", outcome.summary());
    eprintln!("stage time summed over groups: {}", seconds.join(", "));
    Ok(if outcome.groups_empty == outcome.groups {
        ExitCode::from(2)
    } else if outcome.groups_failed > 0
        || outcome
            .failures
            .iter()
            .any(|f| f.kind() == FailureKind::LintError)
    {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
