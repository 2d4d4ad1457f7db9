//! The nightly run: one incremental, crash-safe pass from raw files to a published version.
//!
//! In: an input directory (raw `.dat`/`.mat` files anywhere below it, optional rig sessions under
//! `inertia/`), a store, an optional catalog and the resolved configuration. Out: either nothing
//! ("up to date") or one new immutable version `STORE/versions/vNNNNNN/` with every result
//! table, every `.tir`, the HTML report and `manifest.toml`, plus a [`RunReport`].
//!
//! ```text
//! lock ─▶ up to date? ─yes─▶ done (nothing loaded but stats, hashes of small files, segments)
//!            │ no
//!            ▼
//!         ingest ─▶ plan groups ─▶ fit changed groups ─┐
//!                      │                              ├─▶ staging dir ─▶ report ─▶ manifest ─▶ rename
//!                      └─ unchanged: rows + .tir of ──┘
//!                         the previous version        inertia sessions ─┘
//! ```
//!
//! The whole run holds the store lock, so a second run waits (or refuses) and then sees the first
//! one's version. A version is built in a hidden staging directory and appears by one rename
//! ([`VersionBuilder`]); a crash at any point leaves earlier versions untouched and the next run
//! removes the staging leftovers. Deliberately not here: the stages themselves (ingest, fit,
//! inertia, report) and printing (the command layer prints the [`RunReport`]).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use polars::prelude::*;
use tirebase_core::naming::tir_file_name;

use crate::catalog::{Catalog, CatalogError};
use crate::config::Config;
use crate::fit::{self, FitError, FitOptions, FitOutcome, GroupPlan};
use crate::inertia::{InertiaRun, find_sessions, process_sessions};
use crate::ingest::{self, IngestError, IngestOptions, IngestReport, source_file_name};
use crate::manifest::{
    Counts, GroupRecord, HashedFile, InputFile, InputInfo, Manifest, ManifestError, now_utc,
};
use crate::progress::Progress;
use crate::report;
use crate::store::StoreError;
use crate::store::files::{read_parquet, sha256_bytes, sha256_file, write_parquet_atomic};
use crate::store::layout::runs_file;
use crate::store::lock::{LockWait, StoreLock};
use crate::store::tables::STATUS_FAILED;
use crate::store::versions::{self, VersionBuilder};

/// Folder of the input holding rig-inertia sessions.
pub const INERTIA_DIR: &str = "inertia";
/// Tables published from the inertia stage (never merged per tire group).
const INERTIA_TABLE: &str = "inertia";
/// A fit group: (tire, rim_in, pressure_kpa).
type GroupKey = (String, i64, i64);

/// The columns every fit result table has, identifying its group.
const GROUP_COLUMNS: [&str; 3] = ["tire", "rim_in", "pressure_kpa"];

/// Errors that stop a run (per-file, per-fit and per-session problems are recorded instead).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The input directory does not exist.
    #[error("{0}: no such input directory")]
    MissingInput(PathBuf),
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
        source: PolarsError,
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
        /// Input files that failed again (retried; the latest version lists them too).
        failed_files: Vec<(String, String)>,
    },
    /// A version was published.
    Published(Box<RunReport>),
    /// Nothing could be published (no fit group and no inertia session).
    Nothing(Box<RunReport>),
}

/// What a publishing run did.
#[derive(Debug, Default)]
pub struct RunReport {
    /// The manifest written (or that would have been written).
    pub manifest: Manifest,
    /// The published version's directory.
    pub version_dir: Option<PathBuf>,
    /// Input files that failed to ingest: (file, reason).
    pub failed_files: Vec<(String, String)>,
    /// Stages that produced nothing for a group in this version (fitted now or reused), one
    /// line each.
    pub fit_failures: Vec<String>,
    /// Parts of stages that were skipped (one load, one sweep) while the stage's result was
    /// written, one line each.
    pub fit_skipped: Vec<String>,
    /// Failed inertia runs, one line each.
    pub inertia_errors: Vec<String>,
    /// The report could not be written.
    pub report_error: Option<String>,
    /// The worst fit by quality, one line.
    pub worst_fit: Option<String>,
}

impl RunReport {
    /// True when something failed but a version was still published.
    pub fn partial(&self) -> bool {
        !self.failed_files.is_empty()
            || !self.fit_failures.is_empty()
            || !self.inertia_errors.is_empty()
            || self.report_error.is_some()
    }
}

/// The hashes that decide, with the file stats and the group plan, whether anything changed.
#[derive(Debug, Default)]
struct Fingerprint {
    files: Vec<InputFile>,
    catalog_sha256: String,
    config_sha256: String,
    inertia_sessions: Vec<PathBuf>,
    inertia_files: Vec<HashedFile>,
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
    // time is tried again, so a version with failures never takes it.
    let files_unchanged = previous
        .as_ref()
        .is_some_and(|(_, _, m)| same_files(&m.files, &fingerprint.files));
    let previous_clean = previous
        .as_ref()
        .is_some_and(|(_, _, m)| m.files.iter().all(|f| f.status != STATUS_FAILED));
    if let Some((n, _, prev)) = &previous
        && files_unchanged
        && previous_clean
        && same_settings(prev, &fingerprint, opts.store)?
    {
        return Ok(RunOutcome::UpToDate {
            version: *n,
            seconds: started.elapsed().as_secs_f64(),
            failed_files: Vec::new(),
        });
    }

    // Ingest: unchanged files cost a stat; new content, a new catalog entry, new segmentation
    // settings or a retry cost what they need (see `ingest::decide`).
    let t = Instant::now();
    let ingest_report = Some(ingest_inputs(opts, progress)?);
    timings.insert("ingest".to_string(), t.elapsed().as_secs_f64());
    let files = input_records(opts.store, &fingerprint.files, previous.as_ref())?;

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
            failed_files: failed_files(&files, ingest_report.as_ref()),
        });
    }
    let (to_fit, reused) = split_reuse(&plan, previous.as_ref().map(|(_, _, m)| m));
    timings.insert("plan".to_string(), t.elapsed().as_secs_f64());
    if plan.is_empty() && fingerprint.inertia_sessions.is_empty() {
        let mut report = RunReport {
            failed_files: failed_files(&files, ingest_report.as_ref()),
            ..Default::default()
        };
        report.manifest.counts.files = files.len() as u64;
        report.manifest.counts.files_failed = report.failed_files.len() as u64;
        return Ok(RunOutcome::Nothing(Box::new(report)));
    }

    // Fit what changed.
    let t = Instant::now();
    let outcome = if to_fit.is_empty() {
        FitOutcome::default()
    } else {
        fit::fit_groups(opts.store, opts.config, &to_fit, &fit_opts, progress)?
    };
    timings.insert("fit".to_string(), t.elapsed().as_secs_f64());

    // Build the version in its staging directory.
    let builder = VersionBuilder::begin(opts.store)?;
    let number = builder.number();
    let staging = builder.dir().to_path_buf();
    let reused_keys: BTreeSet<GroupKey> = reused.keys().cloned().collect();
    let prev_dir = previous.as_ref().map(|(_, d, _)| d.as_path());
    let t = Instant::now();
    let mut tables = merge_tables(&outcome, prev_dir, &reused_keys, &staging, progress)?;
    let tir_files = publish_tir(&outcome, prev_dir, &reused_keys, &staging)?;
    timings.insert("merge".to_string(), t.elapsed().as_secs_f64());

    let t = Instant::now();
    let mut report = RunReport::default();
    let inertia = inertia_stage(&fingerprint.inertia_sessions, opts.jobs, &staging, progress)?;
    if let Some((done, rows)) = &inertia {
        tables.insert(INERTIA_TABLE.to_string(), *rows);
        report.inertia_errors = done.errors().map(|e| e.to_string()).collect();
    }
    timings.insert("inertia".to_string(), t.elapsed().as_secs_f64());

    let t = Instant::now();
    report.report_error = report_stage(opts.store, &staging, opts.jobs, progress);
    timings.insert("report".to_string(), t.elapsed().as_secs_f64());

    report.failed_files = failed_files(&files, ingest_report.as_ref());
    (report.fit_failures, report.fit_skipped) = failure_lines(&staging)?;
    report.worst_fit = worst_fit(&staging);
    let groups: Vec<GroupRecord> = plan
        .iter()
        .map(|g| GroupRecord {
            tire: g.key.tire.clone(),
            rim_in: g.key.rim_in,
            pressure_kpa: g.key.pressure_kpa_nom,
            input_sha256: g.input_sha256.clone(),
            n_segments: g.n_segments as u64,
            from_version: reused.get(&plan_key(g)).copied().unwrap_or(number),
        })
        .collect();
    let counts = Counts {
        files: files.len() as u64,
        files_ok: files.iter().filter(|f| f.status == "ok").count() as u64,
        files_failed: report.failed_files.len() as u64,
        files_ingested: ingest_report.as_ref().map_or(0, |r| {
            r.count(|s| *s == ingest::FileStatus::Ingested) as u64
        }),
        files_resegmented: ingest_report.as_ref().map_or(0, |r| {
            r.count(|s| *s == ingest::FileStatus::Resegmented) as u64
        }),
        files_relabelled: ingest_report.as_ref().map_or(0, |r| {
            r.count(|s| *s == ingest::FileStatus::Relabelled) as u64
        }),
        files_removed: ingest_report.as_ref().map_or(0, |r| r.removed.len() as u64),
        segments_by_kind: segments_by_kind(opts.store),
        groups: plan.len() as u64,
        groups_fitted: to_fit.len() as u64,
        groups_reused: reused.len() as u64,
        fit_failures: report.fit_failures.len() as u64,
        fit_skipped: report.fit_skipped.len() as u64,
        tir_files: tir_files as u64,
        inertia_sessions: fingerprint.inertia_sessions.len() as u64,
        inertia_results: inertia.as_ref().map_or(0, |(d, _)| d.results.len() as u64),
        inertia_failed_runs: report.inertia_errors.len() as u64,
    };
    let mut manifest = Manifest {
        version: number,
        created_utc: now_utc(),
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        previous: previous.as_ref().map_or(0, |(n, _, _)| *n),
        summary: String::new(),
        input: InputInfo {
            root: opts.input.display().to_string(),
            catalog: opts
                .catalog
                .map(|p| p.display().to_string())
                .unwrap_or_default(),
            catalog_sha256: fingerprint.catalog_sha256.clone(),
            config_sha256: fingerprint.config_sha256.clone(),
            runs_table_sha256: runs_table_sha(opts.store)?,
        },
        counts,
        timings_s: timings,
        tables,
        files,
        inertia_files: fingerprint.inertia_files.clone(),
        groups,
        config: toml::from_str(&opts.config.to_toml()).unwrap_or_default(),
    };
    manifest.summary = describe_changes(previous.as_ref().map(|(_, _, m)| m), &manifest);

    // Publish: the manifest records the time up to its own writing; the rename is instant.
    manifest
        .timings_s
        .insert("total".to_string(), started.elapsed().as_secs_f64());
    manifest.write(&staging)?;
    let dir = builder.commit()?;
    report.manifest = manifest;
    report.version_dir = Some(dir);
    Ok(RunOutcome::Published(Box::new(report)))
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
        let key = plan_key(g);
        match prev.get(&key) {
            Some(p) if p.input_sha256 == g.input_sha256 => {
                reused.insert(key, p.from_version);
            }
            _ => to_fit.push(g.clone()),
        }
    }
    (to_fit, reused)
}

/// Process the rig sessions (if any) into `staging/inertia.parquet`; the outcome and its rows.
fn inertia_stage(
    sessions: &[PathBuf],
    jobs: usize,
    staging: &Path,
    progress: &dyn Progress,
) -> Result<Option<(InertiaRun, u64)>, RunError> {
    if sessions.is_empty() {
        return Ok(None);
    }
    let stage = progress.stage("inertia", "sessions", sessions.len() as u64);
    let done = with_pool(jobs, || process_sessions(sessions));
    let mut df = done.table()?;
    write_parquet_atomic(&staging.join(format!("{INERTIA_TABLE}.parquet")), &mut df)?;
    stage.inc(sessions.len() as u64);
    stage.finish(&format!(
        "{} results, {} failed runs",
        done.results.len(),
        done.errors().count()
    ));
    let rows = df.height() as u64;
    Ok(Some((done, rows)))
}

/// Write the HTML report into `staging/report/`; the one-line error if it failed (a failed
/// report does not stop the publish).
fn report_stage(
    store: &Path,
    staging: &Path,
    jobs: usize,
    progress: &dyn Progress,
) -> Option<String> {
    let stage = progress.stage("report", "reports", 1);
    let car = crate::compare::car::Car::builtin();
    let write = || report::write_report(store, staging, &staging.join("report"), &car);
    let written = match rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
    {
        Ok(pool) => pool.install(write),
        Err(_) => write(),
    };
    match written {
        Ok(_) => {
            stage.inc(1);
            stage.finish("written");
            None
        }
        Err(e) => {
            stage.finish("failed");
            Some(e.to_string().replace('\n', " "))
        }
    }
}

/// Input files that failed to ingest, with the reason.
fn failed_files(files: &[InputFile], ingest: Option<&IngestReport>) -> Vec<(String, String)> {
    files
        .iter()
        .filter(|f| f.status == STATUS_FAILED)
        .map(|f| (f.name.clone(), failure_reason(ingest, &f.name)))
        .collect()
}

fn plan_key(g: &GroupPlan) -> GroupKey {
    (g.key.tire.clone(), g.key.rim_in, g.key.pressure_kpa_nom)
}

/// Run `f` on a rayon pool of `jobs` threads (0 = one per core).
fn with_pool<T: Send>(jobs: usize, f: impl FnOnce() -> T + Send) -> T {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// Stats of the raw input files, hashes of the small inputs.
fn fingerprint(opts: &RunOptions) -> Result<Fingerprint, RunError> {
    let raw = ingest::discover(&[opts.input.to_path_buf()])?;
    let mut files = Vec::with_capacity(raw.files.len());
    for path in &raw.files {
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
            status: String::new(),
        });
    }
    let catalog_sha256 = match opts.catalog {
        Some(p) => sha256_file(p)?,
        None => String::new(),
    };
    let sessions = find_sessions(&opts.input.join(INERTIA_DIR));
    let mut inertia_files = Vec::new();
    for dir in &sessions {
        hash_tree(dir, &opts.input.join(INERTIA_DIR), &mut inertia_files)?;
    }
    inertia_files.sort();
    Ok(Fingerprint {
        files,
        catalog_sha256,
        config_sha256: sha256_bytes(opts.config.to_toml().as_bytes()),
        inertia_sessions: sessions,
        inertia_files,
    })
}

/// Hash every file below `dir` (paths relative to `base`).
fn hash_tree(dir: &Path, base: &Path, out: &mut Vec<HashedFile>) -> Result<(), StoreError> {
    let entries = fs::read_dir(dir).map_err(|e| StoreError::io(dir, e))?;
    for entry in entries {
        let path = entry.map_err(|e| StoreError::io(dir, e))?.path();
        if path.is_dir() {
            hash_tree(&path, base, out)?;
        } else {
            out.push(HashedFile {
                path: path
                    .strip_prefix(base)
                    .unwrap_or(&path)
                    .display()
                    .to_string(),
                sha256: sha256_file(&path)?,
            });
        }
    }
    Ok(())
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
    Ok(same_settings_but_runs(prev, now) && prev.input.runs_table_sha256 == runs_table_sha(store)?)
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
    let key = |f: &InputFile| (f.name.clone(), f.sha256.clone(), f.status.clone());
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
            let (t, r, p) = plan_key(g);
            (t, r, p, g.input_sha256.clone())
        })
        .collect();
    a == b
}

fn runs_table_sha(store: &Path) -> Result<String, StoreError> {
    let path = store.join(runs_file());
    if path.exists() {
        sha256_file(&path)
    } else {
        Ok(String::new())
    }
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

/// The input files with their content hash and status from the runs table (or, when ingest was
/// skipped, from the previous manifest).
fn input_records(
    store: &Path,
    stats: &[InputFile],
    previous: Option<&(u32, PathBuf, Manifest)>,
) -> Result<Vec<InputFile>, RunError> {
    let runs = crate::store::tables::read_runs(store)?;
    let prev: BTreeMap<&str, &InputFile> = previous
        .map(|(_, _, m)| m.files.iter().map(|f| (f.path.as_str(), f)).collect())
        .unwrap_or_default();
    Ok(stats
        .iter()
        .map(|f| {
            let mut f = f.clone();
            match runs.get(&f.name) {
                Some(row) => {
                    f.sha256 = row.sha256.clone();
                    f.status = row.status.clone();
                }
                None => {
                    if let Some(p) = prev.get(f.path.as_str()) {
                        f.sha256 = p.sha256.clone();
                        f.status = p.status.clone();
                    }
                }
            }
            f
        })
        .collect())
}

fn failure_reason(report: Option<&IngestReport>, name: &str) -> String {
    report
        .and_then(|r| {
            r.failures()
                .find(|(f, _)| *f == name)
                .map(|(_, e)| e.to_string())
        })
        .unwrap_or_else(|| "failed in an earlier ingest (see the runs table)".to_string())
}

/// Merge this run's tables with the reused groups' rows of the previous version and write them
/// into the staging directory. Returns rows per table.
fn merge_tables(
    outcome: &FitOutcome,
    prev_dir: Option<&Path>,
    reused: &BTreeSet<GroupKey>,
    staging: &Path,
    progress: &dyn Progress,
) -> Result<BTreeMap<String, u64>, RunError> {
    let mut names: BTreeSet<String> = outcome.tables.keys().cloned().collect();
    if let Some(dir) = prev_dir {
        for file in crate::store::files::parquet_files_in(dir)? {
            if let Some(stem) = file.file_stem().and_then(|s| s.to_str())
                && stem != INERTIA_TABLE
            {
                names.insert(stem.to_string());
            }
        }
    }
    let mut rows = BTreeMap::new();
    for name in names {
        let table_err = |source| RunError::Table {
            table: name.clone(),
            source,
        };
        let fresh = outcome.tables.get(&name);
        let old = match prev_dir.map(|d| d.join(format!("{name}.parquet"))) {
            Some(path) if path.exists() && !reused.is_empty() => {
                let df = read_parquet(&path)?;
                if has_group_columns(&df) {
                    Some(rows_of_groups(&df, reused).map_err(table_err)?)
                } else {
                    progress.note(&format!(
                        "warning: {name}: previous table has no tire/rim_in/pressure_kpa columns; its rows are not carried over"
                    ));
                    None
                }
            }
            _ => None,
        };
        let merged = match (fresh, old) {
            (Some(f), Some(o)) => f.vstack(&o).map_err(table_err)?,
            (Some(f), None) => f.clone(),
            (None, Some(o)) => o,
            (None, None) => continue,
        };
        let mut merged = if has_group_columns(&merged) {
            merged
                .sort(
                    GROUP_COLUMNS,
                    SortMultipleOptions::default().with_maintain_order(true),
                )
                .map_err(table_err)?
        } else {
            merged
        };
        rows.insert(name.clone(), merged.height() as u64);
        write_parquet_atomic(&staging.join(format!("{name}.parquet")), &mut merged)?;
    }
    Ok(rows)
}

fn has_group_columns(df: &DataFrame) -> bool {
    GROUP_COLUMNS.iter().all(|c| df.column(c).is_ok())
}

/// The rows of `df` whose (tire, rim_in, pressure_kpa) is in `keys`.
fn rows_of_groups(df: &DataFrame, keys: &BTreeSet<GroupKey>) -> PolarsResult<DataFrame> {
    let tire = df.column("tire")?.str()?;
    let rim = df.column("rim_in")?.i64()?;
    let p = df.column("pressure_kpa")?.i64()?;
    let mask: BooleanChunked = (0..df.height())
        .map(|i| match (tire.get(i), rim.get(i), p.get(i)) {
            (Some(t), Some(r), Some(p)) => keys.contains(&(t.to_string(), r, p)),
            _ => false,
        })
        .collect();
    df.filter(&mask)
}

/// Write this run's `.tir` files and link the reused groups' files from the previous version.
fn publish_tir(
    outcome: &FitOutcome,
    prev_dir: Option<&Path>,
    reused: &BTreeSet<GroupKey>,
    staging: &Path,
) -> Result<usize, StoreError> {
    let dir = staging.join("tir");
    crate::store::files::ensure_dir(&dir)?;
    let mut n = 0;
    for (name, text) in &outcome.tir_files {
        crate::store::files::write_bytes_atomic(&dir.join(name), text.as_bytes())?;
        n += 1;
    }
    if let Some(prev) = prev_dir {
        for (tire, rim, p) in reused {
            let name = tir_file_name(tire, *rim as f64, *p as f64);
            let from = prev.join("tir").join(&name);
            let to = dir.join(&name);
            if from.is_file() && !to.exists() {
                if fs::hard_link(&from, &to).is_err() {
                    fs::copy(&from, &to).map_err(|e| StoreError::io(&to, e))?;
                }
                n += 1;
            }
        }
    }
    Ok(n)
}

/// One line per row of the version's `fit_failures` table: (fatal, skipped parts). A row is
/// fatal when the stage produced nothing for the group (`fatal` column; every row when the
/// table has no such column).
fn failure_lines(staging: &Path) -> Result<(Vec<String>, Vec<String>), StoreError> {
    let path = staging.join("fit_failures.parquet");
    if !path.exists() {
        return Ok((Vec::new(), Vec::new()));
    }
    let df = read_parquet(&path)?;
    let text = |name: &str, i: usize| -> String {
        df.column(name)
            .ok()
            .and_then(|c| c.get(i).ok())
            .map(|v| match v {
                AnyValue::String(s) => s.to_string(),
                AnyValue::Null => String::new(),
                v => v.to_string(),
            })
            .unwrap_or_default()
    };
    let fatal = |i: usize| {
        df.column("fatal")
            .ok()
            .and_then(|c| c.get(i).ok())
            .is_none_or(|v| !matches!(v, AnyValue::Boolean(false)))
    };
    let (mut fatal_lines, mut skipped) = (Vec::new(), Vec::new());
    for i in 0..df.height() {
        let (stage, scope) = (text("stage", i), text("scope", i));
        let part = if scope.is_empty() || scope == stage {
            stage
        } else {
            format!("{stage} ({scope})")
        };
        let line = format!(
            "{} on {} in rim at {} kPa: {part}: {}",
            text("tire", i),
            text("rim_in", i),
            text("pressure_kpa", i),
            text("reason", i)
        );
        if fatal(i) {
            fatal_lines.push(line);
        } else {
            skipped.push(line);
        }
    }
    Ok((fatal_lines, skipped))
}

/// The worst row of `fit_quality` by its normalised error (the first column found of
/// `rmse_pct_of_peak`, `nrmse`, `r2`), as one line naming the group and channel.
fn worst_fit(staging: &Path) -> Option<String> {
    let df = read_parquet(&staging.join("fit_quality.parquet")).ok()?;
    let (column, higher_is_worse) = [("rmse_pct_of_peak", true), ("nrmse", true), ("r2", false)]
        .into_iter()
        .find(|(c, _)| df.column(c).is_ok_and(|c| c.dtype() == &DataType::Float64))?;
    let values = df.column(column).ok()?.f64().ok()?.clone();
    let (i, v) = values
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.filter(|v| v.is_finite()).map(|v| (i, v)))
        .max_by(|a, b| {
            if higher_is_worse {
                a.1.total_cmp(&b.1)
            } else {
                b.1.total_cmp(&a.1)
            }
        })?;
    let label: Vec<String> = df
        .columns()
        .iter()
        .filter(|c| GROUP_COLUMNS.contains(&c.name().as_str()) || c.name() == "channel")
        .filter_map(|c| {
            c.get(i)
                .ok()
                .map(|v| format!("{}={}", c.name(), v.to_string().trim_matches('"')))
        })
        .collect();
    Some(format!("{column} = {v:.4} ({})", label.join(", ")))
}

/// Live segments by kind (empty when the store has none).
fn segments_by_kind(store: &Path) -> BTreeMap<String, u64> {
    let Ok(df) = crate::query::run(
        store,
        "SELECT kind, count(*) AS n FROM segments GROUP BY kind ORDER BY kind",
    ) else {
        return BTreeMap::new();
    };
    let (Ok(kind), Ok(n)) = (df.column("kind"), df.column("n")) else {
        return BTreeMap::new();
    };
    let Ok(n) = n.cast(&DataType::UInt64) else {
        return BTreeMap::new();
    };
    let (Ok(kind), Ok(n)) = (kind.str(), n.u64()) else {
        return BTreeMap::new();
    };
    kind.iter()
        .zip(n.iter())
        .filter_map(|(k, n)| Some((k?.to_string(), n?)))
        .collect()
}

/// One line: what `now` changed against `prev`.
pub fn describe_changes(prev: Option<&Manifest>, now: &Manifest) -> String {
    let Some(prev) = prev else {
        return format!(
            "first version: {} files, {} groups fitted",
            now.files.len(),
            now.counts.groups_fitted
        );
    };
    let mut parts = Vec::new();
    let files_prev: BTreeMap<&str, &str> = prev
        .files
        .iter()
        .map(|f| (f.name.as_str(), f.sha256.as_str()))
        .collect();
    let files_now: BTreeMap<&str, &str> = now
        .files
        .iter()
        .map(|f| (f.name.as_str(), f.sha256.as_str()))
        .collect();
    let added = files_now
        .keys()
        .filter(|k| !files_prev.contains_key(*k))
        .count();
    let removed = files_prev
        .keys()
        .filter(|k| !files_now.contains_key(*k))
        .count();
    let changed = files_now
        .iter()
        .filter(|(k, v)| files_prev.get(*k).is_some_and(|p| p != *v))
        .count();
    for (n, what) in [
        (added, "files added"),
        (changed, "files changed"),
        (removed, "files removed"),
    ] {
        if n > 0 {
            parts.push(format!("{n} {what}"));
        }
    }
    if prev.tool_version != now.tool_version {
        parts.push(format!(
            "tool {} -> {}",
            prev.tool_version, now.tool_version
        ));
    }
    if prev.input.config_sha256 != now.input.config_sha256 {
        parts.push("config changed".to_string());
    }
    if prev.input.catalog_sha256 != now.input.catalog_sha256 {
        parts.push("catalog changed".to_string());
    }
    if prev.inertia_files != now.inertia_files {
        parts.push("inertia sessions changed".to_string());
    }
    let keys_prev: BTreeMap<_, _> = prev.groups.iter().map(|g| (g.key(), g)).collect();
    let keys_now: BTreeMap<_, _> = now.groups.iter().map(|g| (g.key(), g)).collect();
    let g_added = keys_now
        .keys()
        .filter(|k| !keys_prev.contains_key(*k))
        .count();
    let g_removed = keys_prev
        .keys()
        .filter(|k| !keys_now.contains_key(*k))
        .count();
    let g_refit = keys_now
        .iter()
        .filter(|(k, g)| {
            keys_prev
                .get(*k)
                .is_some_and(|p| p.input_sha256 != g.input_sha256)
        })
        .count();
    for (n, what) in [
        (g_added, "groups added"),
        (g_refit, "groups refit"),
        (g_removed, "groups removed"),
    ] {
        if n > 0 {
            parts.push(format!("{n} {what}"));
        }
    }
    let reused = now.groups.len() - g_added - g_refit;
    parts.push(format!("{reused} groups reused"));
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(tire: &str, p: i64, sha: &str) -> GroupRecord {
        GroupRecord {
            tire: tire.into(),
            rim_in: 7,
            pressure_kpa: p,
            input_sha256: sha.into(),
            n_segments: 3,
            from_version: 1,
        }
    }

    fn file(name: &str, sha: &str) -> InputFile {
        InputFile {
            name: name.into(),
            path: format!("raw/{name}"),
            size: 10,
            mtime_ns: 5,
            sha256: sha.into(),
            status: "ok".into(),
        }
    }

    #[test]
    fn change_summary_names_files_config_and_groups() {
        let prev = Manifest {
            tool_version: "0.1.0".into(),
            files: vec![file("a.dat", "1"), file("b.dat", "2")],
            groups: vec![group("T", 69, "x"), group("T", 83, "y")],
            ..Default::default()
        };
        let mut now = prev.clone();
        now.files = vec![file("a.dat", "1"), file("b.dat", "3"), file("c.dat", "4")];
        now.groups = vec![
            group("T", 69, "x"),
            group("T", 83, "z"),
            group("U", 69, "w"),
        ];
        now.input.config_sha256 = "other".into();
        assert_eq!(
            describe_changes(Some(&prev), &now),
            "1 files added, 1 files changed, config changed, 1 groups added, 1 groups refit, 1 groups reused"
        );
        assert!(describe_changes(None, &now).starts_with("first version: 3 files"));
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
    fn rows_of_reused_groups_are_selected_by_key() {
        let df = df!(
            "tire" => ["T", "T", "U"],
            "rim_in" => [7i64, 7, 7],
            "pressure_kpa" => [69i64, 83, 69],
            "value" => [1.0, 2.0, 3.0],
        )
        .unwrap();
        let keys = BTreeSet::from([("T".to_string(), 7, 83), ("U".to_string(), 7, 69)]);
        let out = rows_of_groups(&df, &keys).unwrap();
        let v: Vec<f64> = out
            .column("value")
            .unwrap()
            .f64()
            .unwrap()
            .into_no_null_iter()
            .collect();
        assert_eq!(v, vec![2.0, 3.0]);
        assert!(has_group_columns(&df));
    }
}
