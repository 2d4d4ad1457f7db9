//! Ingest: raw TTC run files -> the tire database (samples, segments, runs), incrementally.
//!
//! In: `.dat`/`.mat` paths (files or directories), an optional run catalog, the segmentation
//! config. Out: for every file, its samples in hive partitions, its segments, and one row of the
//! runs table; an [`IngestReport`]. Per file, in parallel, the pure decision of [`decide`] (what
//! the store holds for a file is a function of its content, the catalog entry that applies, the
//! resolved `[segment]` config and the tool version) says what to do: nothing (same path, size
//! and mtime as recorded, or same content), hash and decide again, relabel the stored parts
//! (only the catalog identity changed: no parse), or read (`tirebase_core::ttc`, SI and ISO-W)
//! -> identify the tire -> segment (`tirebase_core::segment`) -> write that file's Parquet parts
//! under names keyed by everything they derive from (`store::tables::parts_sha256`). Then, once,
//! the runs table is rewritten atomically: that rename is the commit (skipped when no row
//! changed, so a no-change ingest writes nothing). Parts of a crashed or superseded ingest are
//! invisible to readers (only parts the runs table names are live) and are garbage-collected at
//! the next ingest. With `prune` (the nightly run, which sees the whole input), files no longer
//! present leave the runs table and the store.
//!
//! A file that fails to read or segment is recorded as failed with a one-line reason and tried
//! again by every later ingest; whatever the store held for it before stays (its row keeps
//! `data_sha256`, `rows` and the tire of the stored version, with `status = failed`, the error and
//! the failed content's `sha256`). One bad file never stops the others; a store that cannot be
//! written stops the ingest (a store error, not a failure of the input file). Files holding the
//! same run (project and run number: the `.dat`, `.mat`, US, SI, run and raw copies the
//! consortium ships) are stored once (`mark_duplicate_runs`; the others get
//! `status = duplicate`, no data). Discovery never follows a directory symlink loop and skips
//! non-regular files (FIFOs, sockets, devices) with a note.

mod decide;

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use polars::prelude::*;
use polars_arrow::array::{BooleanArray, MutableBinaryViewArray, PrimitiveArray, Utf8ViewArray};
use rayon::prelude::*;

use tirebase_core::segment::{self, RunSignals, Segment, SegmentConfig, TreadTemps};
use tirebase_core::ttc::{self, RunTable, SourceFormat, TtcFileName, UnitSystem};

pub use decide::{Decision, Now, decide};

use crate::catalog::Catalog;
use crate::progress::Progress;
use crate::store::files::{sha256_bytes, sync_filesystem};
use crate::store::layout::{PartitionKey, source_part_name};
use crate::store::lock::{LockWait, StoreLock};
pub use crate::store::tables::RunRow;
use crate::store::tables::{
    RunStatus, collect_garbage, has_runs, parts_sha256, read_runs, relabel_parts, write_runs,
    write_samples_part, write_segments_part,
};
use crate::store::{IoOp, StoreError};

/// An input (a file or directory given or found under one) could not be read: an input problem,
/// not a store error. `ingest` and `run` both report it.
#[derive(Debug, thiserror::Error)]
#[error("{path}: cannot read the input: {error}")]
pub struct InputError {
    /// The file or directory.
    pub path: PathBuf,
    /// The OS error.
    pub error: std::io::Error,
}

/// Ingest errors that stop the whole ingest (per-file problems are recorded, not raised).
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// A path given on the command line does not exist.
    #[error("{0}: no such file or directory")]
    MissingInput(PathBuf),
    /// An input directory could not be listed.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The store could not be read or written.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The worker pool could not start.
    #[error("cannot start {jobs} worker threads: {message}")]
    Pool {
        /// Threads asked for.
        jobs: usize,
        /// Why.
        message: String,
    },
}

/// What to ingest into where.
pub struct IngestOptions<'a> {
    /// Store root.
    pub store: &'a Path,
    /// Run catalog, if any.
    pub catalog: Option<&'a Catalog>,
    /// Segmentation configuration.
    pub segment: &'a SegmentConfig,
    /// Worker threads (0 = one per core).
    pub jobs: usize,
    /// Wait for (or refuse) a store locked by another process.
    pub lock_wait: LockWait,
    /// Hash every file, even one whose size, modification time and path equal the ones the runs
    /// table recorded for it (by default such a file is taken as unchanged without reading it).
    pub rehash: bool,
    /// Store every file even when another holds the same project and run (by default one copy
    /// of a run is stored, see `mark_duplicate_runs`).
    pub keep_duplicate_runs: bool,
    /// The paths are the whole input: files of the runs table not found among them are removed
    /// from the store (the nightly run). Without it, other files' rows are left alone.
    pub prune: bool,
}

/// What happened to one file.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum FileStatus {
    /// Same content, identity and segmentation as already stored: nothing done.
    Unchanged,
    /// Read, segmented and stored.
    Ingested,
    /// Same content, new segmentation settings or tool: read and segmented again.
    Resegmented,
    /// Same content and segmentation, new catalog identity: the stored parts were relabelled.
    Relabelled,
    /// Could not be read or segmented; the one-line reason.
    Failed(String),
    /// Another file holds the same run (project and run number) and is the one stored; the
    /// one-line note naming it. Not a failure.
    Duplicate(String),
}

/// The outcome of an ingest.
#[derive(Clone, Debug, Default)]
pub struct IngestReport {
    /// Per file (sorted by file name): status.
    pub files: Vec<(String, FileStatus)>,
    /// Files of the runs table no longer in the input, removed with their data (`prune`).
    pub removed: Vec<String>,
    /// Directory entries that were not ingested, with the reason (non-regular files, symlink
    /// loops).
    pub skipped: Vec<(PathBuf, String)>,
    /// Files stored although their rows stop early (`status = partial`), with the reason; every
    /// such file of the input, not only those read now.
    pub partial: Vec<(String, String)>,
    /// Warnings of the files read now (reader, segmentation, copies of one run that disagree),
    /// one per entry: (file, warning).
    pub warnings: Vec<(String, String)>,
    /// Segments written by this ingest, by kind.
    pub segments_by_kind: BTreeMap<String, usize>,
    /// Samples written by this ingest.
    pub rows: usize,
    /// Wall time, s.
    pub seconds: f64,
}

impl IngestReport {
    /// Files that failed, with their reasons.
    pub fn failures(&self) -> impl Iterator<Item = (&str, &str)> {
        self.files.iter().filter_map(|(f, s)| match s {
            FileStatus::Failed(e) => Some((f.as_str(), e.as_str())),
            _ => None,
        })
    }

    /// Count of files with a status.
    pub fn count(&self, pred: impl Fn(&FileStatus) -> bool) -> usize {
        self.files.iter().filter(|(_, s)| pred(s)).count()
    }

    /// A one-line summary.
    pub fn summary(&self) -> String {
        let duplicates = self.count(|s| matches!(s, FileStatus::Duplicate(_)));
        let mut extra = String::new();
        for (n, what) in [
            (
                self.count(|s| *s == FileStatus::Resegmented),
                "re-segmented",
            ),
            (self.count(|s| *s == FileStatus::Relabelled), "relabelled"),
            (self.removed.len(), "removed"),
            (self.skipped.len(), "skipped entries"),
        ] {
            if n > 0 {
                extra.push_str(&format!(", {n} {what}"));
            }
        }
        format!(
            "{} files: {} ingested, {} unchanged, {} failed{}{extra}; {} segments, {} samples in {:.1} s",
            self.files.len(),
            self.count(|s| *s == FileStatus::Ingested),
            self.count(|s| *s == FileStatus::Unchanged),
            self.count(|s| matches!(s, FileStatus::Failed(_))),
            duplicate_runs_note(duplicates),
            self.segments_by_kind.values().sum::<usize>(),
            self.rows,
            self.seconds
        )
    }
}

/// The input files found under some paths, and the entries passed over.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Discovery {
    /// `.dat`/`.mat` files (and symlinks named so, dangling ones included: they fail as one
    /// file), sorted.
    pub files: Vec<PathBuf>,
    /// Entries not ingested, with the reason (non-regular files, directory symlink loops).
    pub skipped: Vec<(PathBuf, String)>,
}

/// A raw run file by its name (`.dat` or `.mat`, any case).
pub fn is_run_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("dat") || e.eq_ignore_ascii_case("mat"))
}

/// What a non-regular file is, for the note that skips it.
fn file_kind(meta: &fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
    }
    let _ = meta;
    "not a regular file"
}

/// The identity of a directory for loop detection.
fn dir_id(path: &Path, meta: &fs::Metadata) -> (u64, u64, PathBuf) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let _ = path;
        (meta.dev(), meta.ino(), PathBuf::new())
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        (
            0,
            0,
            fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
        )
    }
}

/// Every `.dat`/`.mat` file under the given paths (files are taken as given), sorted. Symlinks
/// are followed, directories once each (a symlink back up the tree is a skipped entry, not a
/// loop); a FIFO, socket or device is a skipped entry (reading it could block forever); a
/// dangling or looping file symlink is kept as a file (it fails with its reason).
pub fn discover(paths: &[PathBuf]) -> Result<Discovery, IngestError> {
    discover_with(paths, &is_run_file)
}

/// [`discover`] for the files `wanted` accepts (run files, rig-session files).
pub fn discover_with(
    paths: &[PathBuf],
    wanted: &dyn Fn(&Path) -> bool,
) -> Result<Discovery, IngestError> {
    let mut out = Discovery::default();
    let mut visited = BTreeSet::new();
    for p in paths {
        let Ok(link_meta) = fs::symlink_metadata(p) else {
            return Err(IngestError::MissingInput(p.clone()));
        };
        match fs::metadata(p) {
            Ok(meta) if meta.is_dir() => {
                visited.insert(dir_id(p, &meta));
                walk(p, wanted, &mut visited, &mut out)
                    .map_err(|(path, error)| InputError { path, error })?;
            }
            Ok(meta) if meta.is_file() => out.files.push(p.clone()),
            Ok(meta) => out.skipped.push((p.clone(), file_kind(&meta).to_string())),
            // A dangling or looping symlink given by name: one failed file.
            Err(_) if link_meta.file_type().is_symlink() => out.files.push(p.clone()),
            Err(_) => return Err(IngestError::MissingInput(p.clone())),
        }
    }
    out.files.sort();
    out.files.dedup();
    out.skipped.sort();
    Ok(out)
}

/// List the files of `dir` that `wanted` accepts recursively into `out`; the directory that
/// could not be listed and why.
fn walk(
    dir: &Path,
    wanted: &dyn Fn(&Path) -> bool,
    visited: &mut BTreeSet<(u64, u64, PathBuf)>,
    out: &mut Discovery,
) -> Result<(), (PathBuf, std::io::Error)> {
    let at = |e| (dir.to_path_buf(), e);
    let mut entries: Vec<_> = fs::read_dir(dir)
        .and_then(|d| d.collect::<Result<_, _>>())
        .map_err(at)?;
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let path = entry.path();
        let file_type = entry.file_type().map_err(|e| (path.clone(), e))?;
        let meta = if file_type.is_symlink() {
            match fs::metadata(&path) {
                Ok(m) => m,
                Err(_) => {
                    if wanted(&path) {
                        out.files.push(path);
                    }
                    continue;
                }
            }
        } else {
            entry.metadata().map_err(|e| (path.clone(), e))?
        };
        if meta.is_dir() {
            if visited.insert(dir_id(&path, &meta)) {
                walk(&path, wanted, visited, out)?;
            } else if file_type.is_symlink() {
                out.skipped.push((
                    path,
                    "directory symlink to a directory already searched (a loop?)".to_string(),
                ));
            }
        } else if wanted(&path) {
            if meta.is_file() {
                out.files.push(path);
            } else {
                out.skipped
                    .push((path, format!("{}, not a regular file", file_kind(&meta))));
            }
        }
    }
    Ok(())
}

/// Size and modification time of a file, as the runs table records them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FileStamp {
    /// Size, bytes.
    pub size_bytes: i64,
    /// Modification time, ns since the Unix epoch (0 if the platform gives none).
    pub mtime_ns: i64,
}

impl FileStamp {
    /// Stamp of `path` (one `stat`, no read).
    pub fn of(path: &Path) -> std::io::Result<Self> {
        let meta = fs::metadata(path)?;
        let mtime_ns = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        Ok(FileStamp {
            size_bytes: i64::try_from(meta.len()).unwrap_or(i64::MAX),
            mtime_ns,
        })
    }
}

/// The identity key of a raw file in the store: its file name.
pub fn source_file_name(path: &Path) -> String {
    path.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// SHA-256 of what the stored segments depend on besides the file: the resolved segmentation
/// configuration and the store layout ([`STORE_LAYOUT`]), so a store written with an older
/// layout is segmented again by the next ingest of its files.
pub fn segment_config_sha256(segment: &SegmentConfig) -> String {
    let config = toml::to_string(segment).unwrap_or_else(|e| format!("unrenderable: {e}"));
    sha256_bytes(format!("layout {STORE_LAYOUT}\n{config}").as_bytes())
}

/// The layout of the stored segments and samples: 3 keys a swept or unheld pressure and load
/// partition as the hive null, 2 as `-1`; 2 keys the inclination as `ia_cdeg_nom` (hundredths of
/// a degree, null when swept), 1 (no tag in the hash) as `ia_deg_nom`.
pub const STORE_LAYOUT: u32 = 3;

/// This tool's version, as the runs table records what computed the stored parts.
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Ingest `paths` into the store (takes the store lock for the duration).
pub fn run(
    paths: &[PathBuf],
    opts: &IngestOptions,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    discover(paths)?;
    let _lock = StoreLock::acquire(opts.store, "ingest", opts.lock_wait, |holder| {
        progress.note(&format!("waiting for the store lock held by {holder}"));
    })?;
    run_locked(paths, opts, progress)
}

/// Settings every file's work shares.
struct Shared<'a> {
    opts: &'a IngestOptions<'a>,
    segment_config_sha256: String,
    writers: usize,
}

/// One file's result: its new runs row, status, the segments and samples it wrote.
type FileOutcome = (RunRow, FileStatus, Vec<Segment>, usize);

/// [`run`] for a caller that already holds the store lock (`tirebase run` holds it from ingest
/// to publish); `opts.lock_wait` is not used.
pub fn run_locked(
    paths: &[PathBuf],
    opts: &IngestOptions,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    let start = Instant::now();
    let found = discover(paths)?;
    let files = &found.files;
    let previous = read_runs(opts.store)?;
    collect_garbage(opts.store, &previous)?;

    let bar = progress.stage("ingest", "files", files.len() as u64);
    let mut seen: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut jobs: Vec<(PathBuf, String, Option<String>)> = Vec::new();
    for path in files {
        let name = source_file_name(path);
        let duplicate = seen
            .insert(name.clone(), path.clone())
            .map(|first| format!("{}: same file name as {}", path.display(), first.display()));
        jobs.push((path.clone(), name, duplicate));
    }
    let present: BTreeSet<&str> = if opts.prune {
        seen.keys().map(String::as_str).collect()
    } else {
        previous
            .keys()
            .map(String::as_str)
            .chain(seen.keys().map(String::as_str))
            .collect()
    };

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
        .map_err(|e| IngestError::Pool {
            jobs: opts.jobs,
            message: e.to_string(),
        })?;
    // Threads left over when there are fewer files than workers write a file's partitions.
    let threads = pool.current_num_threads();
    let shared = Shared {
        opts,
        segment_config_sha256: segment_config_sha256(opts.segment),
        writers: (threads / jobs.len().clamp(1, threads)).max(1),
    };
    let results: Vec<Result<FileOutcome, StoreError>> = pool.install(|| {
        jobs.par_iter()
            .map(|(path, name, duplicate)| {
                let prev = previous.get(name);
                let out = match duplicate {
                    Some(msg) => Ok(failed_row(path, name, "", prev, msg.clone())),
                    None => {
                        let canonical_present =
                            prev.is_some_and(|p| canonical_present(p, &previous, &present));
                        process_file(path, name, prev, canonical_present, &shared)
                    }
                };
                bar.inc(1);
                out
            })
            .collect()
    });

    let mut report = IngestReport {
        skipped: found.skipped.clone(),
        ..IngestReport::default()
    };
    let mut rows: BTreeMap<String, RunRow> = previous.clone();
    if opts.prune {
        report.removed = previous
            .keys()
            .filter(|name| !seen.contains_key(*name))
            .cloned()
            .collect();
        for name in &report.removed {
            rows.remove(name);
        }
    }
    let mut written: BTreeMap<String, (Vec<Segment>, usize)> = BTreeMap::new();
    for ((_, name, duplicate), result) in jobs.iter().zip(results) {
        let (row, status, segments, n) = result?;
        written.insert(name.clone(), (segments, n));
        if duplicate.is_none() {
            rows.insert(name.clone(), row);
        }
        report.files.push((name.clone(), status));
    }
    let marked = if opts.keep_duplicate_runs {
        BTreeMap::new()
    } else {
        mark_duplicate_runs(&mut rows)
    };
    for (name, status) in report.files.iter_mut() {
        if let Some(row) = rows.get(name).filter(|r| r.status == RunStatus::Duplicate) {
            *status = FileStatus::Duplicate(row.error.clone().unwrap_or_default());
        }
    }
    for (name, (segments, n)) in &written {
        if marked.contains_key(name) {
            continue;
        }
        for s in segments {
            *report
                .segments_by_kind
                .entry(s.kind.as_str().to_string())
                .or_default() += 1;
        }
        report.rows += n;
    }
    report.files.sort();
    for (name, _) in &report.files {
        let Some(row) = rows.get(name) else { continue };
        if row.status == RunStatus::Partial {
            report
                .partial
                .push((name.clone(), row.error.clone().unwrap_or_default()));
        }
        // Parsed now, or newly found to be a copy of another file's run.
        let read_now = written.get(name).is_some_and(|(_, n)| *n > 0) || marked.contains_key(name);
        if read_now && let Some(w) = &row.warnings {
            // The warning that makes a file partial is reported as such, not twice.
            let partial_reason = row
                .error
                .as_deref()
                .filter(|_| row.status == RunStatus::Partial);
            report.warnings.extend(
                w.split("; ")
                    .filter(|w| !w.is_empty() && !partial_reason.is_some_and(|r| r.contains(w)))
                    .map(|w| (name.clone(), w.to_string())),
            );
        }
    }
    // A store's first ingest writes its runs table even with no file (an input of rig sessions
    // only): the store then exists for the stages after ingest.
    if rows != previous || !has_runs(opts.store) {
        // The runs table is the commit point: every sample and segment file it names is made
        // durable first (written with `Durability::Deferred`).
        sync_filesystem(opts.store)?;
        write_runs(opts.store, &rows)?;
        // Garbage exists only if some file's parts were replaced or dropped, or a file failed
        // (possibly after writing some partitions); otherwise the walk of the store is skipped.
        let replaced = previous
            .iter()
            .any(|(name, p)| rows.get(name).map(RunRow::part_name) != Some(p.part_name()));
        let failed = report
            .files
            .iter()
            .any(|(_, s)| matches!(s, FileStatus::Failed(_)));
        if replaced || failed || !marked.is_empty() {
            collect_garbage(opts.store, &rows)?;
        }
    }
    report.seconds = start.elapsed().as_secs_f64();
    // The caller reports the summary; the bar only closes its line.
    bar.finish(&format!("{} files", report.files.len()));
    Ok(report)
}

/// For a duplicate's row: another file of its run holds data and is still present.
fn canonical_present(
    dup: &RunRow,
    rows: &BTreeMap<String, RunRow>,
    present: &BTreeSet<&str>,
) -> bool {
    dup.status == RunStatus::Duplicate
        && dup.project.is_some()
        && dup.run.is_some()
        && rows.values().any(|r| {
            r.source_file != dup.source_file
                && (r.project, r.run) == (dup.project, dup.run)
                && r.has_live_data()
                && present.contains(r.source_file.as_str())
        })
}

/// A failed row: the reason, and whatever data the store held before.
fn failed_row(
    path: &Path,
    name: &str,
    sha: &str,
    prev: Option<&RunRow>,
    error: String,
) -> FileOutcome {
    let mut row = prev.cloned().unwrap_or_default();
    row.source_file = name.to_string();
    row.source_path = path.display().to_string();
    row.sha256 = sha.to_string();
    row.status = RunStatus::Failed;
    row.error = Some(error.clone());
    let stamp = FileStamp::of(path).ok();
    row.size_bytes = stamp.map(|s| s.size_bytes);
    row.mtime_ns = stamp.map(|s| s.mtime_ns);
    if row.data_sha256.is_none() {
        row.rows = 0;
        row.n_segments = 0;
    }
    (row, FileStatus::Failed(error), Vec::new(), 0)
}

/// The catalog's identity for a stored file (its name, its project and run), if it has an entry.
pub fn catalog_identity(
    catalog: Option<&Catalog>,
    file: &str,
    project: Option<i64>,
    run: Option<i64>,
) -> Option<Identity> {
    let number = |n: Option<i64>| n.and_then(|n| u32::try_from(n).ok());
    let e = catalog?.lookup(file, number(project), number(run))?;
    Some(Identity {
        tire: e.tire.clone(),
        rim_in: Some(e.rim_in.round() as i64),
        source: "catalog",
        kind_hint: e.kind.clone(),
    })
}

/// Decide and act for one file; `Err` only when the store cannot be read or written.
fn process_file(
    path: &Path,
    name: &str,
    prev: Option<&RunRow>,
    canonical_present: bool,
    shared: &Shared,
) -> Result<FileOutcome, StoreError> {
    let opts = shared.opts;
    let io_failure = |e: std::io::Error| format!("{}: {e}", path.display());
    let meta = match fs::metadata(path) {
        Ok(m) => m,
        Err(e) => return Ok(failed_row(path, name, "", prev, io_failure(e))),
    };
    if !meta.is_file() {
        let reason = format!(
            "{}: {}, not a regular file",
            path.display(),
            file_kind(&meta)
        );
        return Ok(failed_row(path, name, "", prev, reason));
    }
    let stamp = match FileStamp::of(path) {
        Ok(s) => s,
        Err(e) => return Ok(failed_row(path, name, "", prev, io_failure(e))),
    };
    let catalog = prev.and_then(|p| catalog_identity(opts.catalog, name, p.project, p.run));
    let path_text = path.display().to_string();
    let mut now = Now {
        path: &path_text,
        stamp,
        sha256: None,
        catalog: catalog.as_ref(),
        segment_config_sha256: &shared.segment_config_sha256,
        tool_version: TOOL_VERSION,
        rehash: opts.rehash,
        canonical_present,
    };
    let mut decision = decide(prev, &now);
    let mut content: Option<(Vec<u8>, String)> = None;
    if decision == Decision::Hash {
        let bytes = match fs::read(path) {
            Ok(b) => b,
            Err(e) => return Ok(failed_row(path, name, "", prev, io_failure(e))),
        };
        let sha = sha256_bytes(&bytes);
        content = Some((bytes, sha));
        now.sha256 = content.as_ref().map(|(_, s)| s.as_str());
        decision = decide(prev, &now);
    }
    let unchanged = |prev: &RunRow| {
        let mut row = prev.clone();
        row.source_path = path_text.clone();
        row.size_bytes = Some(stamp.size_bytes);
        row.mtime_ns = Some(stamp.mtime_ns);
        (row, FileStatus::Unchanged, Vec::new(), 0)
    };
    match (&decision, prev) {
        (Decision::UpToDate, Some(p)) => return Ok(unchanged(p)),
        (Decision::Relabel(identity), Some(p)) => {
            if let Some(mut row) = relabel(opts.store, p, identity)? {
                row.source_path = path_text.clone();
                row.size_bytes = Some(stamp.size_bytes);
                row.mtime_ns = Some(stamp.mtime_ns);
                return Ok((row, FileStatus::Relabelled, Vec::new(), 0));
            }
            // The stored parts are gone (a damaged store): derive them again.
        }
        _ => {}
    }
    let resegment = matches!(decision, Decision::Resegment | Decision::Relabel(_));
    let (bytes, sha) = match content {
        Some((bytes, sha)) => (bytes, Some(sha)),
        None => match fs::read(path) {
            Ok(b) => (b, None),
            Err(e) => return Ok(failed_row(path, name, "", prev, io_failure(e))),
        },
    };
    let mut out = parse_and_store(path, name, prev, stamp, bytes, sha, shared)?;
    if resegment && out.1 == FileStatus::Ingested {
        out.1 = FileStatus::Resegmented;
    }
    Ok(out)
}

/// Relabel a file's stored parts with a new identity, without a parse: the segments table is
/// rewritten with the new tire and rim, the samples files (whose content does not name the
/// tire) are linked into the new partitions. Returns the new row, or `None` when the stored
/// parts are missing.
fn relabel(store: &Path, prev: &RunRow, identity: &Identity) -> Result<Option<RunRow>, StoreError> {
    let (Some(data), Some(old_part)) = (prev.data_sha256.as_deref(), prev.part_name()) else {
        return Ok(None);
    };
    let mut row = prev.clone();
    row.tire = Some(identity.tire.clone());
    row.rim_in = identity.rim_in;
    if identity.rim_in.is_some() {
        row.warnings = row.warnings.take().and_then(|w| {
            let kept: Vec<&str> = w
                .split("; ")
                .filter(|w| !w.starts_with(UNKNOWN_IDENTITY))
                .collect();
            (!kept.is_empty()).then(|| kept.join("; "))
        });
    }
    row.tire_source = Some(identity.source.to_string());
    row.kind_hint = identity
        .kind_hint
        .clone()
        .or_else(|| prev.run_class.clone());
    row.parts_sha256 = Some(parts_sha256(
        data,
        &identity.tire,
        identity.rim_in,
        prev.segment_config_sha256.as_deref().unwrap_or_default(),
        prev.tool_version.as_deref().unwrap_or_default(),
    ));
    let new_part = row.part_name().expect("a row with data has parts");
    if new_part == old_part {
        return Ok(Some(row));
    }
    let relabelled = relabel_parts(
        store,
        &old_part,
        &new_part,
        &identity.tire,
        identity.rim_in.unwrap_or(0),
    )?;
    if !relabelled {
        return Ok(None);
    }
    Ok(Some(row))
}

/// Read, segment and store one file's content (`sha` when already hashed).
fn parse_and_store(
    path: &Path,
    name: &str,
    prev: Option<&RunRow>,
    stamp: FileStamp,
    bytes: Vec<u8>,
    sha: Option<String>,
    shared: &Shared,
) -> Result<FileOutcome, StoreError> {
    let opts = shared.opts;
    let source_name = path.display().to_string();
    // A scoped thread, not `rayon::join`: a rayon worker waiting in `join` steals other files'
    // jobs and nests them on its stack (observed: 1.9 GB and a stack overflow). A file not yet
    // hashed is hashed while it is parsed (a round is gigabytes; each takes about as long).
    let (sha, parsed) = match sha {
        Some(sha) => {
            let parsed = ttc::read_run(&bytes, &source_name);
            (sha, parsed)
        }
        None => std::thread::scope(|s| {
            let hash = s.spawn(|| sha256_bytes(&bytes));
            let parsed = ttc::read_run(&bytes, &source_name);
            let sha = hash
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            (sha, parsed)
        }),
    };
    let run = match parsed {
        Ok(r) => r,
        Err(e) => return Ok(failed_row(path, name, &sha, prev, e.to_string())),
    };
    drop(bytes);
    let identity = identify(&run, opts.catalog);
    let (segments, seg_report) = match segment::run(&signals(&run), opts.segment) {
        Ok(s) => s,
        Err(e) => {
            return Ok(failed_row(
                path,
                name,
                &sha,
                prev,
                format!("{source_name}: {e}"),
            ));
        }
    };
    let parts = parts_sha256(
        &sha,
        &identity.tire,
        identity.rim_in,
        &shared.segment_config_sha256,
        TOOL_VERSION,
    );
    let part = source_part_name(name, &parts);
    let ctx = FileContext {
        name,
        sha: &sha,
        part: &part,
        identity: &identity,
        run: &run,
    };
    write_file_parts(opts.store, &ctx, &segments, shared.writers)?;
    let mut warnings = run.meta.warnings.clone();
    warnings.extend(seg_report.warnings.iter().cloned());
    warnings.extend(unknown_identity_warning(&run, &identity, name));
    let run_class = seg_report.run_class.as_str().to_string();
    let stops_early = stops_early(&run);
    let row = RunRow {
        source_file: name.to_string(),
        source_path: path.display().to_string(),
        sha256: sha.clone(),
        data_sha256: Some(sha.clone()),
        status: if stops_early.is_some() {
            RunStatus::Partial
        } else {
            RunStatus::Ok
        },
        error: stops_early,
        project: run.meta.project.map(i64::from),
        run: run.meta.run.map(i64::from),
        format: Some(
            match run.meta.format {
                SourceFormat::Dat => "dat",
                SourceFormat::Mat => "mat",
            }
            .to_string(),
        ),
        round_style: Some(round_style(&run).to_string()),
        units: Some(
            match run.meta.unit_system() {
                Some(UnitSystem::Si) => "SI",
                Some(UnitSystem::Uscs) => "USCS",
                _ => "mixed",
            }
            .to_string(),
        ),
        sample_rate_hz: run.meta.sample_rate_hz,
        rows: run.len() as i64,
        n_segments: segments.len() as i64,
        tire: Some(identity.tire.clone()),
        rim_in: identity.rim_in,
        tire_source: Some(identity.source.to_string()),
        kind_hint: Some(
            identity
                .kind_hint
                .clone()
                .unwrap_or_else(|| run_class.clone()),
        ),
        warnings: (!warnings.is_empty()).then(|| warnings.join("; ")),
        size_bytes: Some(stamp.size_bytes),
        mtime_ns: Some(stamp.mtime_ns),
        run_class: Some(run_class),
        et_start_s: run.et_s.first().copied(),
        et_end_s: run.et_s.last().copied(),
        segment_config_sha256: Some(shared.segment_config_sha256.clone()),
        tool_version: Some(TOOL_VERSION.to_string()),
        parts_sha256: Some(parts),
    };
    let n = run.len();
    Ok((row, FileStatus::Ingested, segments, n))
}

/// Why a run's rows stop early (a transfer cut the file), if the reader saw it: the `.dat`
/// reader drops a truncated last line with a warning that says so. A file cut exactly at a line
/// end cannot be told from a short run.
fn stops_early(run: &RunTable) -> Option<String> {
    run.meta
        .warnings
        .iter()
        .find(|w| w.contains("truncated last line"))
        .map(|w| format!("rows stop early (file cut in transfer?): {w}"))
}

/// Which tire and rim a run is, and where that came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Identity {
    /// Tire name.
    pub tire: String,
    /// Rim width, whole inches.
    pub rim_in: Option<i64>,
    /// `catalog`, `tireid`, `tire_name` or `unknown` (named after the file, see [`identify`]).
    pub source: &'static str,
    /// Run kind from the catalog.
    pub kind_hint: Option<String>,
}

/// Tire identity: the catalog entry, else the file's own tire fields (`.mat` `tireid`, `.dat`
/// `Tire_Name=`/`Rim_Width=`), else the tire is unknown and the run is named from what it has:
/// `unknown (<file stem>)`, plus `project <p> run <n>` when the header states them and the file
/// name does not (`unknown (drivebrake)`, `unknown (B1965run51)`), rim unknown, source
/// `unknown`. A later catalog entry for the file's name or its project and run re-labels it.
pub fn identify(run: &RunTable, catalog: Option<&Catalog>) -> Identity {
    let meta = &run.meta;
    if let Some(e) = catalog.and_then(|c| c.lookup(&meta.source_name, meta.project, meta.run)) {
        return Identity {
            tire: e.tire.clone(),
            rim_in: Some(e.rim_in.round() as i64),
            source: "catalog",
            kind_hint: e.kind.clone(),
        };
    }
    if let Some(tire) = meta.tire_name.as_ref().filter(|t| !t.trim().is_empty()) {
        return Identity {
            tire: tire.trim().to_string(),
            rim_in: meta.rim_width_in.map(|w| w.round() as i64),
            source: if meta.format == SourceFormat::Mat {
                "tireid"
            } else {
                "tire_name"
            },
            kind_hint: None,
        };
    }
    let base = meta
        .source_name
        .rsplit(['/', '\\'])
        .next()
        .unwrap_or(&meta.source_name);
    let stem = base.rsplit_once('.').map_or(base, |(stem, _)| stem);
    let mut name = format!("unknown ({stem}");
    if let (None, Some(p), Some(r)) = (&meta.file_name, meta.project, meta.run) {
        name.push_str(&format!(", project {p} run {r}"));
    }
    name.push(')');
    Identity {
        tire: name,
        rim_in: None,
        source: "unknown",
        kind_hint: None,
    }
}

/// The start of [`unknown_identity_warning`] (a relabel to a catalogued identity drops it).
const UNKNOWN_IDENTITY: &str = "tire and rim unknown";

/// A warning for a file whose tire or rim is unknown (neither the catalog nor its own fields
/// name them: its models would be fitted on an unknown rim), saying which catalog entry names
/// them. `name` is the file's name as the catalog matches it.
fn unknown_identity_warning(run: &RunTable, identity: &Identity, name: &str) -> Option<String> {
    if identity.rim_in.is_some() {
        return None;
    }
    let what = if identity.source == "unknown" {
        "the file states no tire (no tireid / Tire_Name) and no catalog entry names it"
    } else {
        "the file states no rim width and no catalog entry names it"
    };
    let by_run = match (run.meta.project, run.meta.run) {
        (Some(p), Some(r)) => format!(" (or project = {p}, run = {r})"),
        _ => String::new(),
    };
    // No "; " inside: a row's warnings are joined with it.
    Some(format!(
        "{UNKNOWN_IDENTITY} ({what}, stored as tire {:?} on an unknown rim): add to the catalog \
         (--catalog) a [[run]] with file = {name:?}{by_run}, tire = \"<tire name>\", rim_in = \
         <whole inches>",
        identity.tire
    ))
}

/// Header style of a run: R9 (`Tire_Name=` in line 1), R8 (`Date`/`ISO` fields), R4 (bare
/// `Project; Run`), or `mat`.
fn round_style(run: &RunTable) -> &'static str {
    let meta = &run.meta;
    match meta.format {
        SourceFormat::Mat => "mat",
        _ if meta.tire_name.is_some() || meta.rim_width_in.is_some() => "R9",
        _ if meta.date.is_some() || meta.iso_flag.is_some() => "R8",
        _ => "R4",
    }
}

/// The segmentation view of a run.
fn signals(run: &RunTable) -> RunSignals<'_> {
    static EMPTY: Vec<f64> = Vec::new();
    let rl = run.loaded_radius_m.as_deref().unwrap_or(&EMPTY);
    let mut s = RunSignals::from_iso_w(&run.tire, &run.et_s, &run.speed_kph, &run.pressure_kpa, rl);
    s.has_kappa = run.meta.kappa_source.is_available();
    if let (Some(inner_c), Some(centre_c), Some(outer_c)) = (
        run.tread_inner_temp_c.as_deref(),
        run.tread_centre_temp_c.as_deref(),
        run.tread_outer_temp_c.as_deref(),
    ) {
        s.tread_temps = Some(TreadTemps {
            inner_c,
            centre_c,
            outer_c,
        });
    }
    s
}

/// What every part written for one file needs.
struct FileContext<'a> {
    name: &'a str,
    sha: &'a str,
    /// File name of every part written (see `store::tables::RunRow::part_name`).
    part: &'a str,
    identity: &'a Identity,
    run: &'a RunTable,
}

impl FileContext<'_> {
    fn segment_id(&self, index: usize) -> String {
        let part = source_part_name(self.name, self.sha);
        let stem = part.trim_end_matches(".parquet");
        let stem = &stem[..stem.len() - 4]; // sha12 -> sha8
        format!("{stem}-{index:03}")
    }
}

/// The hive partition of a segment's samples.
fn partition_of(s: &Segment, id: &Identity) -> PartitionKey {
    PartitionKey {
        test: s.kind.as_str().to_string(),
        tire: id.tire.clone(),
        rim_in: id.rim_in.unwrap_or(0),
        pressure_kpa_nom: s.nominal.pressure_kpa,
        ia_cdeg_nom: s.nominal.ia_cdeg,
        fz_n_nom: s.nominal.fz_n,
    }
}

/// Write one file's segments table and its samples, one Parquet file per partition.
fn write_file_parts(
    store: &Path,
    ctx: &FileContext,
    segments: &[Segment],
    writers: usize,
) -> Result<(), StoreError> {
    let mut by_partition: BTreeMap<PartitionKey, Vec<&Segment>> = BTreeMap::new();
    for s in segments {
        by_partition
            .entry(partition_of(s, ctx.identity))
            .or_default()
            .push(s);
    }
    let part_name = ctx.part;
    let write = |(key, segs): (&PartitionKey, &Vec<&Segment>)| -> Result<(), StoreError> {
        let arrays = samples_arrays(ctx, segs);
        let rows = arrays.first().map_or(0, |(_, a)| a.len());
        write_samples_part(store, key, part_name, rows, arrays)
    };
    let segments_table = || -> Result<(), StoreError> {
        let df =
            segments_frame(ctx, segments).map_err(|e| StoreError::polars(IoOp::Write, store, e))?;
        write_segments_part(store, ctx.part, df)
    };
    // Partitions are independent files (a run has ~30): the calling thread and `writers - 1`
    // scoped threads (which block while they work; rayon workers would steal and nest other
    // files' jobs) take them from one queue, the calling thread after the segments table. The
    // first failure stops every taker.
    let parts: Vec<_> = by_partition.iter().collect();
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let take = || -> Result<(), StoreError> {
        while !failed.load(Ordering::Relaxed) {
            let Some(&part) = parts.get(next.fetch_add(1, Ordering::Relaxed)) else {
                break;
            };
            write(part).inspect_err(|_| failed.store(true, Ordering::Relaxed))?;
        }
        Ok(())
    };
    std::thread::scope(|s| {
        let helpers: Vec<_> = (1..writers.clamp(1, parts.len().max(1)))
            .map(|_| s.spawn(take))
            .collect();
        let mine = segments_table()
            .inspect_err(|_| failed.store(true, Ordering::Relaxed))
            .and_then(|()| take());
        let theirs = helpers.into_iter().try_for_each(|h| {
            h.join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        });
        mine.and(theirs)
    })
}

/// Gather `column[i]` for every sample index of the segments.
fn gather(column: &[f64], idx: &[usize]) -> Vec<f64> {
    idx.iter().map(|&i| column[i]).collect()
}

/// A float column of the samples: the gathered channel, or all null when the run lacks it.
fn float_array(column: Option<&Vec<f64>>, idx: &[usize]) -> ArrayRef {
    match column {
        Some(c) => PrimitiveArray::from_vec(gather(c, idx)).boxed(),
        None => PrimitiveArray::<f64>::new_null(ArrowDataType::Float64, idx.len()).boxed(),
    }
}

/// A string column holding `runs[k].0` on `runs[k].1` rows in turn (one buffer, one view per
/// row).
fn string_runs<S: AsRef<str>>(runs: &[(S, usize)]) -> ArrayRef {
    let n = runs.iter().map(|r| r.1).sum();
    let mut out = MutableBinaryViewArray::<str>::with_capacity(n);
    for (value, count) in runs {
        for _ in 0..*count {
            out.push_value(value.as_ref());
        }
    }
    let array: Utf8ViewArray = out.into();
    array.boxed()
}

/// An Int64 column of one value (null when unknown).
fn int64_constant(value: Option<u32>, n: usize) -> ArrayRef {
    match value {
        Some(v) => PrimitiveArray::from_vec(vec![i64::from(v); n]).boxed(),
        None => PrimitiveArray::<i64>::new_null(ArrowDataType::Int64, n).boxed(),
    }
}

/// The samples of one partition as Arrow arrays, by column name. Built directly, not through
/// a polars DataFrame: polars' DataFrame crates are unoptimised in release builds (see README
/// "Build profiles"), and with a run split into ~30 small partitions their per-column overhead
/// was a third of ingest time.
fn samples_arrays(ctx: &FileContext, segs: &[&Segment]) -> Vec<(&'static str, ArrayRef)> {
    let run = ctx.run;
    let idx: Vec<usize> = segs.iter().flat_map(|s| s.samples.clone()).collect();
    let n = idx.len();
    let seg_ids: Vec<(String, usize)> = segs
        .iter()
        .map(|s| (ctx.segment_id(s.index), s.samples.len()))
        .collect();
    let t = &run.tire;
    let kappa = if t.kappa.is_empty() {
        vec![0.0; n]
    } else {
        gather(&t.kappa, &idx)
    };
    let f = |c: &Vec<f64>| float_array(Some(c), &idx);
    let kappa_measured = run.meta.kappa_source.is_measured();
    let kappa_derived = run.meta.kappa_source == ttc::KappaSource::Derived;
    vec![
        ("segment_id", string_runs(&seg_ids)),
        ("source_file", string_runs(&[(ctx.name, n)])),
        ("source_sha256", string_runs(&[(ctx.sha, n)])),
        ("project", int64_constant(run.meta.project, n)),
        ("run", int64_constant(run.meta.run, n)),
        (
            "sample_index",
            PrimitiveArray::from_vec(idx.iter().map(|&i| i as i64).collect::<Vec<i64>>()).boxed(),
        ),
        ("et_s", f(&run.et_s)),
        ("speed_kph", f(&run.speed_kph)),
        (
            "wheel_speed_rpm",
            float_array(run.wheel_speed_rpm.as_ref(), &idx),
        ),
        ("fx_n", f(&t.fx_n)),
        ("fy_n", f(&t.fy_n)),
        ("fz_n", f(&t.fz_n)),
        ("mx_nm", f(&t.mx_nm)),
        ("mz_nm", f(&t.mz_nm)),
        ("alpha_rad", f(&t.alpha_rad)),
        ("gamma_rad", f(&t.gamma_rad)),
        ("kappa", PrimitiveArray::from_vec(kappa).boxed()),
        (
            "kappa_measured",
            BooleanArray::from_slice(vec![kappa_measured; n]).boxed(),
        ),
        (
            "kappa_derived",
            BooleanArray::from_slice(vec![kappa_derived; n]).boxed(),
        ),
        ("sr", float_array(run.sr.as_ref(), &idx)),
        ("pressure_kpa", f(&run.pressure_kpa)),
        (
            "loaded_radius_m",
            float_array(run.loaded_radius_m.as_ref(), &idx),
        ),
        (
            "effective_radius_m",
            float_array(run.effective_radius_m.as_ref(), &idx),
        ),
        ("nfx", float_array(run.nfx.as_ref(), &idx)),
        ("nfy", float_array(run.nfy.as_ref(), &idx)),
        ("road_temp_c", float_array(run.road_temp_c.as_ref(), &idx)),
        (
            "tread_inner_c",
            float_array(run.tread_inner_temp_c.as_ref(), &idx),
        ),
        (
            "tread_centre_c",
            float_array(run.tread_centre_temp_c.as_ref(), &idx),
        ),
        (
            "tread_outer_c",
            float_array(run.tread_outer_temp_c.as_ref(), &idx),
        ),
        ("ambient_c", float_array(run.ambient_temp_c.as_ref(), &idx)),
    ]
}

fn min_max(values: impl Iterator<Item = f64>) -> (Option<f64>, Option<f64>) {
    values.fold((None, None), |(lo, hi), v| {
        (
            Some(lo.map_or(v, |l: f64| l.min(v))),
            Some(hi.map_or(v, |h: f64| h.max(v))),
        )
    })
}

fn segments_frame(ctx: &FileContext, segments: &[Segment]) -> PolarsResult<DataFrame> {
    let run = ctx.run;
    let n = segments.len();
    let nom =
        |f: fn(&Segment) -> Option<i64>| -> Vec<Option<i64>> { segments.iter().map(f).collect() };
    let mean = |f: fn(&Segment) -> f64| -> Vec<f64> { segments.iter().map(f).collect() };
    let alpha_range: Vec<_> = segments
        .iter()
        .map(|s| {
            min_max(
                run.tire.alpha_rad[s.samples.clone()]
                    .iter()
                    .map(|a| a.to_degrees()),
            )
        })
        .collect();
    let kappa_range: Vec<_> = segments
        .iter()
        .map(|s| {
            if run.tire.kappa.is_empty() {
                (None, None)
            } else {
                min_max(run.tire.kappa[s.samples.clone()].iter().copied())
            }
        })
        .collect();
    df!(
        "segment_id" => segments.iter().map(|s| ctx.segment_id(s.index)).collect::<Vec<_>>(),
        "source_file" => vec![ctx.name; n],
        "source_sha256" => vec![ctx.sha; n],
        "project" => vec![run.meta.project.map(i64::from); n],
        "run" => vec![run.meta.run.map(i64::from); n],
        "segment_index" => segments.iter().map(|s| s.index as i64).collect::<Vec<_>>(),
        "kind" => segments.iter().map(|s| s.kind.as_str()).collect::<Vec<_>>(),
        "tire" => vec![ctx.identity.tire.as_str(); n],
        "rim_in" => vec![ctx.identity.rim_in.unwrap_or(0); n],
        "pressure_kpa_nom" => nom(|s| s.nominal.pressure_kpa),
        "ia_cdeg_nom" => nom(|s| s.nominal.ia_cdeg),
        "fz_n_nom" => nom(|s| s.nominal.fz_n),
        "alpha_deg_nom" => nom(|s| s.nominal.alpha_deg),
        "speed_kph_nom" => nom(|s| s.nominal.speed_kph),
        "pressure_kpa_mean" => mean(|s| s.measured.pressure_kpa.mean),
        "ia_deg_mean" => mean(|s| s.measured.ia_deg.mean),
        "fz_n_mean" => mean(|s| s.measured.fz_n.mean),
        "alpha_deg_mean" => mean(|s| s.measured.alpha_deg.mean),
        "speed_kph_mean" => mean(|s| s.measured.speed_kph.mean),
        "alpha_deg_min" => alpha_range.iter().map(|r| r.0).collect::<Vec<_>>(),
        "alpha_deg_max" => alpha_range.iter().map(|r| r.1).collect::<Vec<_>>(),
        "kappa_min" => kappa_range.iter().map(|r| r.0).collect::<Vec<_>>(),
        "kappa_max" => kappa_range.iter().map(|r| r.1).collect::<Vec<_>>(),
        "et_start_s" => mean(|s| s.et_start_s),
        "et_end_s" => mean(|s| s.et_end_s),
        "sample_start" => segments.iter().map(|s| s.samples.start as i64).collect::<Vec<_>>(),
        "sample_end" => segments.iter().map(|s| s.samples.end as i64).collect::<Vec<_>>(),
        "n_samples" => segments.iter().map(|s| s.n_samples as i64).collect::<Vec<_>>(),
        "qc_flags" => segments.iter().map(|s| s.qc_string()).collect::<Vec<_>>(),
        "qc_ok" => segments.iter().map(|s| s.qc.is_empty()).collect::<Vec<_>>(),
    )
}
/// `", N duplicate runs (stored once)"` for the summary lines, empty when there is none.
pub fn duplicate_runs_note(duplicates: usize) -> String {
    if duplicates > 0 {
        format!(", {duplicates} duplicate runs (stored once)")
    } else {
        String::new()
    }
}

/// One run enters the store once. The consortium ships every run as `.dat` and `.mat`, in US
/// customary (`A` prefix) and SI (`B`), and from Round 6 as "run" and "raw" files: a whole round
/// download holds each test up to eight times, and every copy's segments would enter the fits.
/// Among the stored files of one (project, run), the canonical one is the most complete and
/// precise: SI before US customary or mixed, "raw" (dwells kept) before "run", `.mat` before
/// `.dat`, then the file name. The others get status `duplicate`, the canonical name in `error`
/// and no stored data (their partitions are collected). Returns the newly marked files with
/// their canonical file. A file whose run number could not be read is never a duplicate.
fn mark_duplicate_runs(rows: &mut BTreeMap<String, RunRow>) -> BTreeMap<String, String> {
    let mut runs: BTreeMap<(i64, i64), Vec<&RunRow>> = BTreeMap::new();
    for r in rows.values() {
        if let (Some(project), Some(run), Some(_)) = (r.project, r.run, &r.data_sha256)
            && (r.status == RunStatus::Ok || r.status == RunStatus::Partial)
        {
            runs.entry((project, run)).or_default().push(r);
        }
    }
    let preference = |r: &RunRow| {
        (
            r.status == RunStatus::Partial,
            r.units.as_deref() != Some("SI"),
            !TtcFileName::parse(&r.source_file).is_some_and(|n| n.raw),
            r.format.as_deref() != Some("mat"),
            r.source_file.clone(),
        )
    };
    let mut marked = BTreeMap::new();
    for ((project, run), mut copies) in runs {
        if copies.len() < 2 {
            continue;
        }
        copies.sort_by_key(|r| preference(r));
        let canonical = copies[0].source_file.clone();
        for r in &copies[1..] {
            let disagreement = copies_disagree(copies[0], r);
            marked.insert(
                r.source_file.clone(),
                (
                    canonical.clone(),
                    format!("project {project}, run {run}"),
                    disagreement,
                ),
            );
        }
    }
    marked
        .into_iter()
        .map(|(name, (canonical, which, disagreement))| {
            let row = rows.get_mut(&name).expect("marked rows exist");
            row.status = RunStatus::Duplicate;
            row.error = Some(format!(
                "same run as {canonical} ({which}), which is the copy stored"
            ));
            // The copy's own reader warnings concern data that is not stored; what matters is
            // whether it agrees with the copy that is.
            row.warnings = disagreement.map(|d| {
                format!("copies of {which} disagree: {d} ({canonical} is the copy stored)")
            });
            row.data_sha256 = None;
            row.parts_sha256 = None;
            row.n_segments = 0;
            (name, canonical)
        })
        .collect()
}

/// How two copies of one run disagree, if they do: copies of the same kind (both "run", both
/// "raw") hold the same rows over the same elapsed-time range; a "run" copy (dwells cut) holds
/// at most the rows of a "raw" copy, within its time range. Tolerance: half a sample period.
fn copies_disagree(kept: &RunRow, copy: &RunRow) -> Option<String> {
    let (Some(k0), Some(k1), Some(c0), Some(c1)) = (
        kept.et_start_s,
        kept.et_end_s,
        copy.et_start_s,
        copy.et_end_s,
    ) else {
        return None;
    };
    let raw = |r: &RunRow| TtcFileName::parse(&r.source_file).is_some_and(|n| n.raw);
    let rate = kept.sample_rate_hz.filter(|r| *r > 0.0).unwrap_or(100.0);
    let tol = 0.5 / rate;
    let describe = || {
        format!(
            "{} has {} rows over ET {k0:.3}..{k1:.3} s, {} has {} rows over ET {c0:.3}..{c1:.3} s",
            kept.source_file, kept.rows, copy.source_file, copy.rows
        )
    };
    let agree = if raw(kept) == raw(copy) {
        kept.rows == copy.rows && (k0 - c0).abs() <= tol && (k1 - c1).abs() <= tol
    } else {
        // The raw copy holds the run copy.
        let (big, small) = if raw(kept) {
            ((kept.rows, k0, k1), (copy.rows, c0, c1))
        } else {
            ((copy.rows, c0, c1), (kept.rows, k0, k1))
        };
        small.0 <= big.0 && small.1 >= big.1 - tol && small.2 <= big.2 + tol
    };
    (!agree).then(describe)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_of_one_run_must_hold_the_same_rows_and_time_range() {
        let copy = |name: &str, rows: i64, et: (f64, f64)| RunRow {
            source_file: name.into(),
            rows,
            et_start_s: Some(et.0),
            et_end_s: Some(et.1),
            sample_rate_hz: Some(100.0),
            ..RunRow::default()
        };
        let kept = copy("B1965run51.mat", 1000, (0.0, 9.99));
        assert_eq!(
            copies_disagree(&kept, &copy("A1965run51.dat", 1000, (0.0, 9.99))),
            None
        );
        assert_eq!(
            copies_disagree(&kept, &copy("A1965run51.dat", 1000, (0.001, 9.992))),
            None
        );
        let other = copies_disagree(&kept, &copy("A1965run51.dat", 800, (0.0, 7.99))).unwrap();
        assert!(other.contains("B1965run51.mat has 1000 rows"), "{other}");
        assert!(
            other.contains("A1965run51.dat has 800 rows over ET 0.000..7.990 s"),
            "{other}"
        );
        assert!(copies_disagree(&kept, &copy("A1965run51.dat", 1000, (20.0, 29.99))).is_some());
        // A raw copy keeps the dwells a run copy cuts: more rows, a wider time range.
        let raw = copy("B1965raw51.mat", 1500, (0.0, 14.99));
        assert_eq!(copies_disagree(&raw, &kept), None);
        assert_eq!(copies_disagree(&kept, &raw), None);
        assert!(copies_disagree(&raw, &copy("B1965run51.dat", 1600, (0.0, 15.99))).is_some());
        // Rows stored before the time range was recorded are not compared.
        let mut legacy = copy("A1965run51.dat", 5, (0.0, 1.0));
        legacy.et_start_s = None;
        assert_eq!(copies_disagree(&kept, &legacy), None);
    }

    /// Issue 17: without a catalog entry or a tire field, the tire is unknown and named after
    /// the file (and the header's project and run when the name does not carry them).
    #[test]
    fn a_tire_without_catalog_or_tireid_is_unknown_and_named_after_the_file() {
        use tirebase_core::ttc::example::{ExampleStyle, example_dat, example_mat};
        use tirebase_core::ttc::mat::Compression;
        let dat = ttc::read_run(
            &example_dat(ExampleStyle::R4Uscs, 20, false),
            "in/drivebrake.dat",
        )
        .unwrap();
        let id = identify(&dat, None);
        assert_eq!(id.tire, "unknown (drivebrake, project 1320 run 125)");
        assert_eq!((id.rim_in, id.source), (None, "unknown"));
        let mut mat =
            ttc::read_run(&example_mat(20, Compression::None), "x/B1320run15.mat").unwrap();
        mat.meta.tire_name = None;
        assert_eq!(identify(&mat, None).tire, "unknown (B1320run15)");
    }

    /// A file with no tire id is warned about, with the catalog entry that names it; an entry
    /// keyed by its file name does, and the warning goes.
    #[test]
    fn an_unknown_tire_is_warned_about_and_a_file_keyed_catalog_entry_names_it() {
        use tirebase_core::ttc::example::{ExampleStyle, example_dat};
        let dat = ttc::read_run(
            &example_dat(ExampleStyle::R4Uscs, 20, false),
            "in/drivebrake.dat",
        )
        .unwrap();
        let id = identify(&dat, None);
        let w = unknown_identity_warning(&dat, &id, "drivebrake.dat").unwrap();
        assert!(w.starts_with(UNKNOWN_IDENTITY), "{w}");
        assert!(
            w.contains("file = \"drivebrake.dat\" (or project = 1320, run = 125)")
                && w.contains("rim_in = <whole inches>")
                && !w.contains("; "),
            "{w}"
        );
        let catalog = Catalog::parse(
            "[[run]]\nfile = \"drivebrake.dat\"\ntire = \"Hoosier R25B\"\nrim_in = 7\n",
            "c.toml",
        )
        .unwrap();
        let id = identify(&dat, Some(&catalog));
        assert_eq!(
            (id.tire.as_str(), id.rim_in, id.source),
            ("Hoosier R25B", Some(7), "catalog")
        );
        assert_eq!(unknown_identity_warning(&dat, &id, "drivebrake.dat"), None);
        let stored = catalog_identity(Some(&catalog), "drivebrake.dat", None, None).unwrap();
        assert_eq!(stored, id);
    }

    fn row(name: &str, run: Option<i64>, units: &str, format: &str) -> RunRow {
        RunRow {
            source_file: name.to_string(),
            status: RunStatus::Ok,
            data_sha256: Some(format!("sha-{name}")),
            project: Some(1965),
            run,
            units: Some(units.to_string()),
            format: Some(format.to_string()),
            n_segments: 40,
            ..RunRow::default()
        }
    }

    #[test]
    fn one_file_per_run_is_kept_si_raw_mat_first() {
        let mut rows: BTreeMap<String, RunRow> = [
            row("A1965run51.dat", Some(51), "USCS", "dat"),
            row("B1965run51.dat", Some(51), "SI", "dat"),
            row("B1965run51.mat", Some(51), "SI", "mat"),
            row("B1965raw51.mat", Some(51), "SI", "mat"),
            row("B1965run52.mat", Some(52), "SI", "mat"),
            row("unknown.dat", None, "SI", "dat"),
            row("unknown2.dat", None, "SI", "dat"),
        ]
        .into_iter()
        .map(|r| (r.source_file.clone(), r))
        .collect();
        let marked = mark_duplicate_runs(&mut rows);
        let expected: Vec<&str> = vec!["A1965run51.dat", "B1965run51.dat", "B1965run51.mat"];
        assert_eq!(
            marked.keys().map(String::as_str).collect::<Vec<_>>(),
            expected
        );
        assert!(marked.values().all(|c| c == "B1965raw51.mat"), "{marked:?}");
        for name in expected {
            let r = &rows[name];
            assert_eq!(r.status, RunStatus::Duplicate);
            assert_eq!(r.data_sha256, None);
            assert!(
                r.error
                    .as_deref()
                    .unwrap()
                    .contains("B1965raw51.mat (project 1965, run 51)"),
                "{r:?}"
            );
        }
        for name in [
            "B1965raw51.mat",
            "B1965run52.mat",
            "unknown.dat",
            "unknown2.dat",
        ] {
            assert_eq!(rows[name].status, RunStatus::Ok, "{name}");
        }
        // Already marked: nothing more to do.
        assert!(mark_duplicate_runs(&mut rows).is_empty());
    }
}
