//! The nightly run: one incremental, crash-safe pass from raw files to a published version.
//!
//! In: an input directory (raw `.dat`/`.mat` files anywhere below it, optional rig sessions under
//! `inertia/`), a store, an optional catalog and the resolved configuration. Out: either nothing
//! ("up to date") or one new immutable version `STORE/versions/vNNNNNN/` (built by
//! [`crate::publish`]), plus a [`RunReport`].
//!
//! ```text
//! lock ─▶ up to date? ─yes─▶ done (nothing read but stats, the runs table, small inputs)
//!            │ no
//!            ▼
//!         ingest (ingest::decide per file) ─▶ plan groups ─▶ same as the latest? ─yes─▶ done
//!                                                 │ no
//!                                                 ▼
//!                                   fit changed groups ─▶ publish (merge with the reused
//!                                                         groups, inertia, report, manifest)
//! ```
//!
//! A version is a function of the inputs: what the store holds for a file follows its content,
//! catalog entry, `[segment]` configuration and the tool version (`ingest::decide`), files gone
//! from the input leave the store, and a group is refit when anything its fit reads changed. The
//! whole run holds the store lock, so a second run waits (or refuses) and then sees the first
//! one's version; a crash at any point leaves earlier versions untouched. Deliberately not here:
//! the stages themselves (ingest, fit, inertia, report), building the version (publish) and
//! printing (the command layer prints the [`RunReport`]).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::catalog::{Catalog, CatalogError};
use crate::config::Config;
use crate::fit::{self, FitError, FitOptions, FitResults, GroupPlan};
use crate::inertia::find_sessions;
use crate::ingest::{self, IngestError, IngestOptions, IngestReport, InputError, source_file_name};
use crate::manifest::{
    GroupRecord, HashedFile, InputFile, Manifest, ManifestError, Problem, ProblemKind,
};
use crate::progress::Progress;
pub use crate::publish::RunReport;
use crate::publish::{self, GroupKey, Publication};
use crate::store::StoreError;
use crate::store::files::{sha256_bytes, sha256_file};
use crate::store::lock::{LockWait, StoreLock};
use crate::store::tables::{self, RunRow, RunStatus, read_runs};
use crate::store::versions;

/// Folder of the input holding rig-inertia sessions.
pub const INERTIA_DIR: &str = "inertia";

/// Errors that stop a run (per-file, per-fit and per-session problems are recorded instead).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The input directory does not exist.
    #[error("{0}: no such input directory")]
    MissingInput(PathBuf),
    /// An input (the catalog, a rig-session file) could not be read.
    #[error(transparent)]
    Input(InputError),
    /// The store could not be read or written (includes a refused lock).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The catalog could not be read.
    #[error(transparent)]
    Catalog(#[from] CatalogError),
    /// Ingest failed as a whole.
    #[error(transparent)]
    Ingest(#[from] IngestError),
    /// Fitting failed at the store level.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// A manifest could not be read or written.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A result table could not be merged.
    #[error("{table}: {source}")]
    Table {
        /// Table name.
        table: String,
        /// polars' error.
        source: polars::error::PolarsError,
    },
}

/// What to run on.
pub struct RunOptions<'a> {
    /// Input directory.
    pub input: &'a Path,
    /// Store root.
    pub store: &'a Path,
    /// Run catalog, if any.
    pub catalog: Option<&'a Path>,
    /// Resolved configuration.
    pub config: &'a Config,
    /// Worker threads (0 = one per core); results do not depend on it.
    pub jobs: usize,
    /// Wait for, or refuse, a store another process holds.
    pub lock_wait: LockWait,
}

/// How a run ended.
#[derive(Debug)]
pub enum RunOutcome {
    /// Nothing changed since the latest version; nothing was published.
    UpToDate {
        /// The latest version.
        version: u32,
        /// Wall time, s.
        seconds: f64,
        /// Failed (retried now, failing again) and partial input files of the latest version,
        /// and the directory entries skipped now.
        problems: Vec<Problem>,
    },
    /// A version was published.
    Published(Box<RunReport>),
    /// Nothing could be published (no fit group and no inertia session).
    Nothing(Box<RunReport>),
}

/// The hashes that decide, with the file stats and the group plan, whether anything changed.
#[derive(Debug, Default)]
pub struct Fingerprint {
    /// Input files with their stats (hash and status filled in after ingest).
    pub files: Vec<InputFile>,
    /// Directory entries discovery passed over, with the reason.
    pub skipped: Vec<(PathBuf, String)>,
    /// SHA-256 of the catalog file ("" without one).
    pub catalog_sha256: String,
    /// SHA-256 of the resolved configuration's TOML.
    pub config_sha256: String,
    /// Rig session directories.
    pub inertia_sessions: Vec<PathBuf>,
    /// Every file of the rig sessions, hashed.
    pub inertia_files: Vec<HashedFile>,
}

/// Run the nightly pipeline once.
pub fn run(opts: &RunOptions, progress: &dyn Progress) -> Result<RunOutcome, RunError> {
    let started = Instant::now();
    if !opts.input.is_dir() {
        return Err(RunError::MissingInput(opts.input.to_path_buf()));
    }
    let _lock = StoreLock::acquire(opts.store, "run", opts.lock_wait, |holder| {
        progress.note(&format!(
            "waiting for the store lock held by {holder} (--no-wait to refuse instead)"
        ));
    })?;
    versions::remove_incomplete(opts.store)?;
    let previous = match versions::latest(opts.store)? {
        Some((n, dir)) => Some((n, dir.clone(), Manifest::read(&dir)?)),
        None => None,
    };
    let fingerprint = fingerprint(opts)?;
    let fit_opts = FitOptions {
        jobs: opts.jobs,
        ..Default::default()
    };
    let mut timings = BTreeMap::new();

    // The fast path reads no samples and no segments: what the store holds is a function of
    // the files (same paths, sizes and mtimes as recorded), the catalog, the configuration and
    // the tool version, and the group plan a function of the store. A file that failed last
    // time is tried again, so a version with failed files never takes it.
    let files_unchanged = previous
        .as_ref()
        .is_some_and(|(_, _, m)| same_files(&m.files, &fingerprint.files));
    let previous_clean = previous
        .as_ref()
        .is_some_and(|(_, _, m)| m.files.iter().all(|f| f.status != Some(RunStatus::Failed)));
    if let Some((n, _, prev)) = &previous
        && files_unchanged
        && previous_clean
        && same_settings(prev, &fingerprint, opts.store)?
    {
        return Ok(RunOutcome::UpToDate {
            version: *n,
            seconds: started.elapsed().as_secs_f64(),
            problems: failures_of_files(&prev.problems)
                .into_iter()
                .filter(|p| p.kind != ProblemKind::SkippedEntry)
                .chain(skipped_problems(&fingerprint.skipped))
                .collect(),
        });
    }

    // Ingest: unchanged files cost a stat; new content, a new catalog entry, new segmentation
    // settings or a retry cost what they need (see `ingest::decide`).
    let t = Instant::now();
    let ingest_report = ingest_inputs(opts, progress)?;
    timings.insert("ingest".to_string(), t.elapsed().as_secs_f64());
    let runs = read_runs(opts.store)?;
    let files = input_records(&runs, &fingerprint.files);
    let file_problems = file_problems(&runs, &files, &fingerprint.skipped);

    // Plan and reuse.
    let t = Instant::now();
    let plan = fit::plan_groups(opts.store, opts.config, &fit_opts)?;
    if let Some((n, _, prev)) = &previous
        && same_content(&prev.files, &files)
        && same_settings_but_runs(prev, &fingerprint)
        && same_groups(&prev.groups, &plan)
    {
        // Files were touched (new mtime) but hold the same bytes, or failed files failed again.
        return Ok(RunOutcome::UpToDate {
            version: *n,
            seconds: started.elapsed().as_secs_f64(),
            problems: failures_of_files(&file_problems),
        });
    }
    let (to_fit, reused) = split_reuse(&plan, previous.as_ref().map(|(_, _, m)| m));
    timings.insert("plan".to_string(), t.elapsed().as_secs_f64());
    if plan.is_empty() && fingerprint.inertia_sessions.is_empty() {
        let mut report = RunReport::default();
        report.manifest.counts.files = files.len() as u64;
        report.manifest.counts.files_failed = count_status(&files, RunStatus::Failed);
        report.manifest.problems = file_problems;
        return Ok(RunOutcome::Nothing(Box::new(report)));
    }

    // Fit what changed.
    let t = Instant::now();
    let outcome = if to_fit.is_empty() {
        FitResults::default()
    } else {
        fit::fit_groups(opts.store, opts.config, &to_fit, &fit_opts, progress)?
    };
    timings.insert("fit".to_string(), t.elapsed().as_secs_f64());

    let report = publish::publish(
        Publication {
            opts,
            started,
            previous: previous.as_ref(),
            fingerprint: &fingerprint,
            files,
            file_problems,
            ingest: &ingest_report,
            plan: &plan,
            groups_fitted: to_fit.len(),
            reused: &reused,
            outcome,
            timings,
        },
        progress,
    )?;
    Ok(RunOutcome::Published(Box::new(report)))
}

/// What an up-to-date run still says about its inputs: the failed and partial files and the
/// skipped directory entries among `problems`.
fn failures_of_files(problems: &[Problem]) -> Vec<Problem> {
    problems
        .iter()
        .filter(|p| {
            matches!(
                p.kind,
                ProblemKind::FailedFile | ProblemKind::PartialFile | ProblemKind::SkippedEntry
            )
        })
        .cloned()
        .collect()
}

/// Skipped directory entries as problems of the version.
fn skipped_problems(skipped: &[(PathBuf, String)]) -> impl Iterator<Item = Problem> + '_ {
    skipped
        .iter()
        .map(|(p, why)| Problem::new(ProblemKind::SkippedEntry, p.display().to_string(), why))
}

fn count_status(files: &[InputFile], status: RunStatus) -> u64 {
    files.iter().filter(|f| f.status == Some(status)).count() as u64
}

/// Split the plan into groups to fit and groups whose results the previous version holds for
/// the same input hash (with the version that computed them).
fn split_reuse(
    plan: &[GroupPlan],
    previous: Option<&Manifest>,
) -> (Vec<GroupPlan>, BTreeMap<GroupKey, u32>) {
    let prev: BTreeMap<GroupKey, &GroupRecord> = previous
        .map(|m| {
            m.groups
                .iter()
                .map(|g| ((g.tire.clone(), g.rim_in, g.pressure_kpa), g))
                .collect()
        })
        .unwrap_or_default();
    let mut to_fit = Vec::new();
    let mut reused = BTreeMap::new();
    for g in plan {
        let key = publish::plan_key(g);
        match prev.get(&key) {
            Some(p) if p.input_sha256 == g.input_sha256 => {
                reused.insert(key, p.from_version);
            }
            _ => to_fit.push(g.clone()),
        }
    }
    (to_fit, reused)
}

/// Per-file problems of the version: failed and partial files, file warnings (every present
/// file's, not only those read now) and skipped directory entries.
fn file_problems(
    runs: &BTreeMap<String, RunRow>,
    files: &[InputFile],
    skipped: &[(PathBuf, String)],
) -> Vec<Problem> {
    let mut out = Vec::new();
    for f in files {
        let Some(row) = runs.get(&f.name) else {
            continue;
        };
        let reason = row.error.clone().unwrap_or_default();
        match row.status {
            // A failed file keeps the data of its last good content (see `ingest`): said, as
            // the version's models hold them.
            RunStatus::Failed if row.has_live_data() => out.push(Problem::new(
                ProblemKind::FailedFile,
                &f.name,
                format!(
                    "{reason} (the {} rows of its last good content stay in the store and the models)",
                    row.rows
                ),
            )),
            RunStatus::Failed => out.push(Problem::new(ProblemKind::FailedFile, &f.name, &reason)),
            RunStatus::Partial => out.push(Problem::new(ProblemKind::PartialFile, &f.name, &reason)),
            _ => {}
        }
        if row.status != RunStatus::Failed
            && let Some(w) = &row.warnings
        {
            let partial_reason = (row.status == RunStatus::Partial).then_some(reason.as_str());
            out.extend(
                w.split("; ")
                    .filter(|w| !w.is_empty() && !partial_reason.is_some_and(|r| r.contains(w)))
                    .map(|w| Problem::new(ProblemKind::FileWarning, &f.name, w)),
            );
        }
    }
    out.extend(skipped_problems(skipped));
    out
}

/// Stats of the raw input files, hashes of the small inputs.
fn fingerprint(opts: &RunOptions) -> Result<Fingerprint, RunError> {
    let inertia_dir = opts.input.join(INERTIA_DIR);
    let sessions = find_sessions(&inertia_dir);
    let in_session = |p: &Path| sessions.iter().any(|s| p.starts_with(s));
    // One walk of the input for raw files and rig-session files: every directory once (a
    // symlink loop is a skipped entry), a FIFO or device is a skipped entry, never read.
    let found = ingest::discover_with(&[opts.input.to_path_buf()], &|p| {
        ingest::is_run_file(p) || in_session(p)
    })?;
    let mut files = Vec::with_capacity(found.files.len());
    for path in found.files.iter().filter(|p| ingest::is_run_file(p)) {
        // A file that cannot be stat'ed (a dangling symlink) is listed with no size; ingest
        // records it as one failed file.
        let stamp = ingest::FileStamp::of(path).unwrap_or_default();
        files.push(InputFile {
            name: source_file_name(path),
            path: path
                .strip_prefix(opts.input)
                .unwrap_or(path)
                .display()
                .to_string(),
            size: u64::try_from(stamp.size_bytes).unwrap_or(0),
            mtime_ns: stamp.mtime_ns,
            sha256: String::new(),
            status: None,
        });
    }
    let catalog_sha256 = match opts.catalog {
        Some(p) => {
            // A FIFO would block the read forever.
            match std::fs::metadata(p) {
                Ok(m) if !m.is_file() => {
                    return Err(RunError::Input(InputError {
                        path: p.to_path_buf(),
                        error: std::io::Error::other("not a regular file"),
                    }));
                }
                _ => {}
            }
            sha256_file(p).map_err(input_error)?
        }
        None => String::new(),
    };
    let mut inertia_files = Vec::new();
    for path in found.files.iter().filter(|p| in_session(p)) {
        inertia_files.push(HashedFile {
            path: path
                .strip_prefix(&inertia_dir)
                .unwrap_or(path)
                .display()
                .to_string(),
            sha256: sha256_file(path).map_err(input_error)?,
        });
    }
    inertia_files.sort();
    Ok(Fingerprint {
        files,
        skipped: found.skipped,
        catalog_sha256,
        config_sha256: sha256_bytes(opts.config.to_toml().as_bytes()),
        inertia_sessions: sessions,
        inertia_files,
    })
}

/// A file-system error on an input path, as an input error.
fn input_error(e: StoreError) -> RunError {
    match e {
        StoreError::Io { path, error, .. } => RunError::Input(InputError { path, error }),
        other => RunError::Store(other),
    }
}

/// Same set of input files with the same size and modification time as last time.
fn same_files(previous: &[InputFile], now: &[InputFile]) -> bool {
    let key = |f: &InputFile| (f.path.clone(), f.size, f.mtime_ns);
    let a: BTreeSet<_> = previous.iter().map(key).collect();
    let b: BTreeSet<_> = now.iter().map(key).collect();
    a == b
}

/// Same tool version, configuration, catalog, inertia inputs and runs table as `prev`.
fn same_settings(prev: &Manifest, now: &Fingerprint, store: &Path) -> Result<bool, RunError> {
    Ok(same_settings_but_runs(prev, now)
        && prev.input.runs_table_sha256 == tables::runs_sha256(store)?)
}

/// Same tool version, configuration, catalog and inertia inputs as `prev`.
fn same_settings_but_runs(prev: &Manifest, now: &Fingerprint) -> bool {
    prev.tool_version == env!("CARGO_PKG_VERSION")
        && prev.input.config_sha256 == now.config_sha256
        && prev.input.catalog_sha256 == now.catalog_sha256
        && prev.inertia_files == now.inertia_files
}

/// Same input files with the same content and ingest status as last time.
fn same_content(previous: &[InputFile], now: &[InputFile]) -> bool {
    let key = |f: &InputFile| (f.name.clone(), f.sha256.clone(), f.status);
    let a: BTreeSet<_> = previous.iter().map(key).collect();
    let b: BTreeSet<_> = now.iter().map(key).collect();
    a == b
}

/// Same groups with the same input hashes.
fn same_groups(prev: &[GroupRecord], plan: &[GroupPlan]) -> bool {
    let a: BTreeSet<_> = prev
        .iter()
        .map(|g| {
            (
                g.tire.clone(),
                g.rim_in,
                g.pressure_kpa,
                g.input_sha256.clone(),
            )
        })
        .collect();
    let b: BTreeSet<_> = plan
        .iter()
        .map(|g| {
            let (t, r, p) = publish::plan_key(g);
            (t, r, p, g.input_sha256.clone())
        })
        .collect();
    a == b
}

fn ingest_inputs(opts: &RunOptions, progress: &dyn Progress) -> Result<IngestReport, RunError> {
    let catalog = opts.catalog.map(Catalog::read).transpose()?;
    let ingest_opts = IngestOptions {
        store: opts.store,
        catalog: catalog.as_ref(),
        segment: &opts.config.segment,
        jobs: opts.jobs,
        lock_wait: opts.lock_wait,
        // The nightly run trusts the ingest fast path (unchanged size, mtime and path).
        rehash: false,
        keep_duplicate_runs: false,
        // The input directory is the whole input: files gone from it leave the store.
        prune: true,
    };
    Ok(ingest::run_locked(
        &[opts.input.to_path_buf()],
        &ingest_opts,
        progress,
    )?)
}

/// The input files with their content hash and status from the runs table.
fn input_records(runs: &BTreeMap<String, RunRow>, stats: &[InputFile]) -> Vec<InputFile> {
    stats
        .iter()
        .map(|f| {
            let mut f = f.clone();
            if let Some(row) = runs.get(&f.name) {
                f.sha256 = row.sha256.clone();
                f.status = Some(row.status);
            }
            f
        })
        .collect()
}

/// Files of the version that hold no data of their own (a duplicate copy of another's run).
pub(crate) fn count_duplicates(files: &[InputFile]) -> u64 {
    count_status(files, RunStatus::Duplicate)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, sha: &str) -> InputFile {
        InputFile::ok_for_test(name, sha)
    }

    #[test]
    fn stat_identity_and_content_identity() {
        let a = vec![file("a.dat", "1")];
        let mut touched = a.clone();
        touched[0].mtime_ns = 6;
        assert!(same_files(&a, &a));
        assert!(
            !same_files(&a, &touched),
            "a new mtime is a possible change"
        );
        assert!(same_content(&a, &touched), "same bytes are no change");
        let mut edited = a.clone();
        edited[0].sha256 = "2".into();
        assert!(!same_content(&a, &edited));
    }

    #[test]
    fn file_problems_list_failed_partial_warnings_and_skipped_entries() {
        let row =
            |name: &str, status: RunStatus, error: Option<&str>, warnings: Option<&str>| RunRow {
                source_file: name.into(),
                status,
                error: error.map(String::from),
                warnings: warnings.map(String::from),
                ..RunRow::default()
            };
        let runs: BTreeMap<String, RunRow> = [
            row("a.dat", RunStatus::Ok, None, Some("w1; w2")),
            row(
                "b.dat",
                RunStatus::Failed,
                Some("b.dat: line 3: bad"),
                Some("old"),
            ),
            row(
                "c.dat",
                RunStatus::Partial,
                Some("rows stop early: line 9: truncated last line"),
                Some("line 9: truncated last line; other"),
            ),
            row("gone.dat", RunStatus::Failed, Some("x"), None),
        ]
        .into_iter()
        .map(|r| (r.source_file.clone(), r))
        .collect();
        let files = vec![file("a.dat", "1"), file("b.dat", "2"), file("c.dat", "3")];
        let skipped = vec![(PathBuf::from("raw/pipe.dat"), "a FIFO".to_string())];
        let p = file_problems(&runs, &files, &skipped);
        let lines: Vec<String> = p.iter().map(|p| p.to_string()).collect();
        assert_eq!(
            lines,
            vec![
                "warning: a.dat: w1",
                "warning: a.dat: w2",
                "failed file: b.dat: b.dat: line 3: bad",
                "partial file: c.dat: rows stop early: line 9: truncated last line",
                "warning: c.dat: other",
                "skipped entry: raw/pipe.dat: a FIFO",
            ]
        );
        assert_eq!(failures_of_files(&p).len(), 3);
    }
}
