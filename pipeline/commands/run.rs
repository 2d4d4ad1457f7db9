//! `tirebase run`: resolve the input (an explicit directory or the embedded virtual round), run
//! the nightly pipeline (`crate::run`), print the one-screen summary on stderr and turn the
//! outcome into the exit code (0 ok or up to date, 1 published with failures, 2 nothing done).
//!
//! In: the parsed arguments. Out: a version in the store, the summary, the exit code. Deliberately
//! not here: any stage logic.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use tirebase_core::synth::round::SynthConfig;

use crate::cli::RunArgs;
use crate::commands::synth::summary_line;
use crate::config::Config;
use crate::ingest::IngestError;
use crate::manifest::{Problem, ProblemKind, group_problems};
use crate::progress;
use crate::run::{self, RunError, RunOptions, RunOutcome, RunReport};
use crate::store::StoreError;
use crate::store::lock::LockWait;
use crate::synth_round::write_round;

/// Where the embedded virtual round is generated, relative to the working directory.
pub const EMBEDDED_ROUND: &str = "outputs/round";

/// Run the nightly pipeline once.
pub fn run(args: &RunArgs) -> anyhow::Result<ExitCode> {
    let config = Config::load(args.config.as_deref())?;
    let input = match &args.input {
        Some(dir) => dir.clone(),
        None => embedded_round(Path::new(EMBEDDED_ROUND), args.jobs)?,
    };
    // The input's catalog.toml whatever it is (one that is not a readable file is an input
    // error, not silently no catalog).
    let catalog = args.catalog.clone().or_else(|| {
        let default = input.join("catalog.toml");
        std::fs::symlink_metadata(&default)
            .is_ok()
            .then_some(default)
    });
    let opts = RunOptions {
        input: &input,
        store: &args.store,
        catalog: catalog.as_deref(),
        config: &config,
        jobs: args.jobs,
        lock_wait: if args.no_wait {
            LockWait::Refuse
        } else {
            LockWait::Wait
        },
    };
    let progress = progress::for_stderr();
    match run::run(&opts, progress.as_ref()) {
        Ok(RunOutcome::UpToDate {
            version,
            seconds,
            problems,
        }) => {
            print_problems(&problems);
            let failing = problems.iter().filter(|p| p.kind.is_failure()).count();
            let count = |kind: ProblemKind| problems.iter().filter(|p| p.kind == kind).count();
            let mut still = Vec::new();
            // Failed files were read again now; a partial file's content is what it was.
            for (n, what) in [
                (count(ProblemKind::FailedFile), "still failed (tried again)"),
                (count(ProblemKind::PartialFile), "still partial"),
            ] {
                if n > 0 {
                    still.push(format!("{n} input files {what}"));
                }
            }
            eprintln!(
                "up to date: v{version:06} already holds these inputs ({}; {seconds:.2} s){}",
                args.store.display(),
                if still.is_empty() {
                    String::new()
                } else {
                    format!("; {}", still.join(", "))
                }
            );
            Ok(if failing == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
        Ok(RunOutcome::Published(report)) => {
            print_summary(&report);
            Ok(if report.partial() {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            })
        }
        Ok(RunOutcome::Nothing(report)) => {
            print_problems(&report.manifest.problems);
            eprintln!(
                "nothing to publish: no fit group and no inertia session found under {} ({} raw files, {} failed)",
                input.display(),
                report.manifest.counts.files,
                report.manifest.counts.files_failed
            );
            Ok(ExitCode::from(2))
        }
        Err(e @ (RunError::Store(StoreError::Locked { .. }) | RunError::MissingInput(_))) => {
            eprintln!("error: {e}");
            Ok(ExitCode::from(2))
        }
        Err(
            e @ (RunError::Input(_)
            | RunError::Ingest(IngestError::Input(_) | IngestError::MissingInput(_))),
        ) => {
            // The previous version stays the latest; the next run starts over.
            eprintln!("error: {e}; nothing published");
            Ok(ExitCode::from(2))
        }
        Err(e @ (RunError::Store(_) | RunError::Ingest(IngestError::Store(_)))) => {
            // Nothing was published and no input file is blamed; the next run starts over.
            eprintln!("error: store error, nothing published: {e}");
            Ok(ExitCode::from(2))
        }
        Err(e) => Err(e.into()),
    }
}

/// The embedded virtual round: generated with the default synth configuration (fixed seed) on
/// first use, into a temporary sibling that is renamed into place, so a crash never leaves a
/// half-written round behind.
fn embedded_round(dir: &Path, jobs: usize) -> anyhow::Result<PathBuf> {
    if dir.join("catalog.toml").is_file() {
        return Ok(dir.to_path_buf());
    }
    let parent = dir.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .with_context(|| format!("{}: cannot create", parent.display()))?;
    let tmp = parent.join(format!(".round-building-{}", std::process::id()));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp)
            .with_context(|| format!("{}: cannot remove", tmp.display()))?;
    }
    eprintln!(
        "generating the embedded virtual round into {} (first use)",
        dir.display()
    );
    let written = write_round(&SynthConfig::default(), &tmp, (jobs > 0).then_some(jobs))?;
    eprintln!("{}", summary_line(&written, &tmp));
    if dir.exists() && !dir.join("catalog.toml").is_file() {
        std::fs::remove_dir_all(dir)
            .with_context(|| format!("{}: cannot replace an incomplete round", dir.display()))?;
    }
    if let Err(e) = std::fs::rename(&tmp, dir) {
        // Another process generated it meanwhile: use theirs (same seed, same bytes).
        let _ = std::fs::remove_dir_all(&tmp);
        if !dir.join("catalog.toml").is_file() {
            return Err(e).with_context(|| format!("{}: cannot move into place", dir.display()));
        }
    }
    Ok(dir.to_path_buf())
}

/// Every problem, grouped by kind under a line that counts them, one line each (nothing is
/// left out: the manifest holds the same list).
fn print_problems(problems: &[Problem]) {
    for (kind, list) in group_problems(problems) {
        eprintln!("{} {}:", list.len(), kind.plural());
        for p in list {
            eprintln!("{p}");
        }
    }
}

/// The one-screen summary.
fn print_summary(report: &RunReport) {
    print_problems(&report.manifest.problems);
    let m = &report.manifest;
    let c = &m.counts;
    let dir = report
        .version_dir
        .as_ref()
        .map(|d| d.display().to_string())
        .unwrap_or_default();
    eprintln!("published v{:06} -> {dir}", m.version);
    eprintln!("  changes   {}", m.summary);
    let mut work = vec![format!("{} ingested now", c.files_ingested)];
    for (n, what) in [
        (c.files_resegmented, "re-segmented"),
        (c.files_relabelled, "relabelled"),
    ] {
        if n > 0 {
            work.push(format!("{n} {what}"));
        }
    }
    let mut notes = String::new();
    for (n, what) in [
        (c.files_removed, "removed from the store"),
        (c.file_warnings, "warnings"),
        (c.entries_skipped, "entries skipped"),
    ] {
        if n > 0 {
            notes.push_str(&format!("; {n} {what}"));
        }
    }
    eprintln!(
        "  files     {}: {} ok ({}), {} partial, {} failed{}{notes}",
        c.files,
        c.files_ok,
        work.join(", "),
        c.files_partial,
        c.files_failed,
        crate::ingest::duplicate_runs_note(c.files_duplicate as usize),
    );
    let kinds: Vec<String> = c
        .segments_by_kind
        .iter()
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
    eprintln!(
        "  segments  {}: {}",
        c.segments_by_kind.values().sum::<u64>(),
        kinds.join(", ")
    );
    eprintln!(
        "  fits      {} groups: {} fitted, {} reused; {} failed stage fits, {} skipped parts, {} \
         fit-quality flags, {} model limits; {} .tir files, {} .tir lint errors",
        c.groups,
        c.groups_fitted,
        c.groups_reused,
        c.fit_failures,
        c.fit_skipped,
        c.fit_quality_flags,
        c.model_limits,
        c.tir_files,
        c.tir_lint_errors
    );
    if let Some(w) = &report.worst_fit {
        eprintln!("  worst fit {w}");
    }
    if c.inertia_sessions > 0 {
        eprintln!(
            "  inertia   {} sessions: {} results, {} failed runs",
            c.inertia_sessions, c.inertia_results, c.inertia_failed_runs
        );
    }
    eprintln!(
        "  report    {}",
        match report.report_error() {
            Some(e) => format!("FAILED: {e}"),
            None => "report/index.html".to_string(),
        }
    );
    let order = [
        "ingest", "plan", "fit", "merge", "inertia", "report", "total",
    ];
    let timings: Vec<String> = order
        .iter()
        .filter_map(|k| m.timings_s.get(*k).map(|s| format!("{k} {s:.1} s")))
        .collect();
    eprintln!("  timings   {}", timings.join(", "));
}
