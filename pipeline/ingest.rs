//! Ingest: raw TTC run files -> the tire database (samples, segments, runs), incrementally.
//!
//! In: `.dat`/`.mat` paths (files or directories), an optional run catalog, the segmentation
//! config. Out: for every file, its samples in hive partitions, its segments, and one row of the
//! runs table; an [`IngestReport`]. Per file, in parallel: stat (same path, size and mtime as the
//! runs table recorded after a successful ingest? unchanged, not even read; `rehash` turns this
//! off) -> hash (same content as stored? unchanged) -> read (`tirebase_core::ttc`, SI and ISO-W)
//! -> identify the tire -> segment (`tirebase_core::segment`) -> write that file's Parquet parts
//! under content-addressed names. Then, once, the runs table is rewritten atomically: that rename
//! is the commit (skipped when no row changed, so a no-change ingest writes nothing). Files of a
//! crashed or superseded ingest are invisible to queries (they are filtered by the runs table) and
//! are garbage-collected at the next ingest.
//!
//! A file that fails to read or segment is recorded as failed with a one-line reason; whatever the
//! store held for it before stays (its row keeps `data_sha256`, `rows` and the tire of the stored
//! version, with `status = failed`, the error and the failed content's `sha256`). One bad file
//! never stops the others. Files holding the same run (project and run number: the `.dat`,
//! `.mat`, US, SI, run and raw copies the consortium ships) are stored once
//! (`mark_duplicate_runs`; the others get `status = duplicate`, no data).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use polars::prelude::*;
use polars_arrow::array::{BooleanArray, MutableBinaryViewArray, PrimitiveArray, Utf8ViewArray};
use polars_arrow::record_batch::RecordBatchT;
use rayon::prelude::*;

use tirebase_core::segment::{self, RunSignals, Segment, SegmentConfig, TreadTemps};
use tirebase_core::ttc::{self, RunTable, SourceFormat, TtcFileName, UnitSystem};

use crate::catalog::Catalog;
use crate::progress::Progress;
use crate::schema;
use crate::store::StoreError;
use crate::store::files::{
    Durability, ensure_dir, parquet_files_below, parquet_files_in, read_parquet, sha256_bytes,
    sync_filesystem, write_arrow_parquet_atomic_with, write_parquet_atomic,
    write_parquet_atomic_with,
};
use crate::store::layout::{
    PartitionKey, SAMPLES_DIR, SEGMENTS_DIR, SWEPT, TEMP_SUFFIX, partition_dir, runs_file,
    segments_file, source_part_name,
};
use crate::store::lock::{LockWait, StoreLock};

/// Ingest errors that stop the whole ingest (per-file problems are recorded, not raised).
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// A path given on the command line does not exist.
    #[error("{0}: no such file or directory")]
    MissingInput(PathBuf),
    /// The store could not be read or written.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The runs table could not be built.
    #[error("runs table: {0}")]
    Polars(#[from] PolarsError),
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
}

/// What happened to one file.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum FileStatus {
    /// Same content as already stored: nothing done.
    Unchanged,
    /// Read, segmented and stored.
    Ingested,
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
        format!(
            "{} files: {} ingested, {} unchanged, {} failed{}; {} segments, {} samples in {:.1} s",
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

/// One row of the runs table (see `schemas/runs.toml`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunRow {
    pub source_file: String,
    pub source_path: String,
    pub sha256: String,
    pub data_sha256: Option<String>,
    pub status: String,
    pub error: Option<String>,
    pub project: Option<i64>,
    pub run: Option<i64>,
    pub format: Option<String>,
    pub round_style: Option<String>,
    pub units: Option<String>,
    pub sample_rate_hz: Option<f64>,
    pub rows: i64,
    pub n_segments: i64,
    pub tire: Option<String>,
    pub rim_in: Option<i64>,
    pub tire_source: Option<String>,
    pub kind_hint: Option<String>,
    pub warnings: Option<String>,
    pub size_bytes: Option<i64>,
    pub mtime_ns: Option<i64>,
}

/// Every `.dat`/`.mat` file under the given paths (files are taken as given), sorted.
pub fn discover(paths: &[PathBuf]) -> Result<Vec<PathBuf>, IngestError> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_file() {
            out.push(p.clone());
        } else if p.is_dir() {
            walk(p, &mut out).map_err(|e| StoreError::io(p, e))?;
        } else {
            return Err(IngestError::MissingInput(p.clone()));
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            walk(&path, out)?;
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("dat") || e.eq_ignore_ascii_case("mat"))
        {
            out.push(path);
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

    /// True when `row` is a successful ingest of this very file: same path, size and mtime.
    fn matches(&self, path: &Path, row: &RunRow) -> bool {
        (row.status == "ok" || row.status == DUPLICATE)
            && row.source_path == path.display().to_string()
            && row.size_bytes == Some(self.size_bytes)
            && row.mtime_ns == Some(self.mtime_ns)
    }
}

/// The identity key of a raw file in the store: its file name.
pub fn source_file_name(path: &Path) -> String {
    path.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

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

/// [`run`] for a caller that already holds the store lock (`tirebase run` holds it from ingest
/// to publish); `opts.lock_wait` is not used.
pub fn run_locked(
    paths: &[PathBuf],
    opts: &IngestOptions,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    let start = Instant::now();
    let files = discover(paths)?;
    let previous = read_runs(opts.store)?;
    collect_garbage(opts.store, &previous)?;

    let bar = progress.stage("ingest", "files", files.len() as u64);
    let mut seen: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut jobs: Vec<(PathBuf, String, Option<String>)> = Vec::new();
    for path in &files {
        let name = source_file_name(path);
        let duplicate = seen
            .insert(name.clone(), path.clone())
            .map(|first| format!("{}: same file name as {}", path.display(), first.display()));
        jobs.push((path.clone(), name, duplicate));
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
        .map_err(|e| StoreError::io(opts.store, std::io::Error::other(e)))?;
    // Threads left over when there are fewer files than workers write a file's partitions.
    let threads = pool.current_num_threads();
    let writers = (threads / jobs.len().clamp(1, threads)).max(1);
    let results: Vec<(RunRow, FileStatus, Vec<Segment>, usize)> = pool.install(|| {
        jobs.par_iter()
            .map(|(path, name, duplicate)| {
                let prev = previous.get(name);
                let out = match duplicate {
                    Some(msg) => failed_row(path, name, "", prev, msg.clone()),
                    None => ingest_file(path, name, prev, opts, writers),
                };
                bar.inc(1);
                out
            })
            .collect()
    });

    let mut report = IngestReport::default();
    let mut rows: BTreeMap<String, RunRow> = previous.clone();
    let mut written: BTreeMap<String, (Vec<Segment>, usize)> = BTreeMap::new();
    for ((_, name, duplicate), (row, status, segments, n)) in jobs.iter().zip(results) {
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
        if let Some(row) = rows.get(name).filter(|r| r.status == DUPLICATE) {
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
    if rows != previous {
        // The runs table is the commit point: every sample and segment file it names is made
        // durable first (written with `Durability::Deferred`).
        sync_filesystem(opts.store)?;
        write_runs(opts.store, &rows)?;
        // Garbage exists only if a stored version was replaced or dropped, or a file failed
        // (possibly after writing some partitions); otherwise the walk of the store is skipped.
        let replaced = previous
            .iter()
            .any(|(name, p)| rows.get(name).map(|r| &r.data_sha256) != Some(&p.data_sha256));
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

/// A failed row: the reason, and whatever data the store held before.
fn failed_row(
    path: &Path,
    name: &str,
    sha: &str,
    prev: Option<&RunRow>,
    error: String,
) -> (RunRow, FileStatus, Vec<Segment>, usize) {
    let mut row = prev.cloned().unwrap_or_default();
    row.source_file = name.to_string();
    row.source_path = path.display().to_string();
    row.sha256 = sha.to_string();
    row.status = "failed".into();
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

/// Read, segment and store one file.
fn ingest_file(
    path: &Path,
    name: &str,
    prev: Option<&RunRow>,
    opts: &IngestOptions,
    writers: usize,
) -> (RunRow, FileStatus, Vec<Segment>, usize) {
    let io_failure = |e: std::io::Error| format!("{}: {e}", path.display());
    let stamp = match FileStamp::of(path) {
        Ok(s) => s,
        Err(e) => return failed_row(path, name, "", prev, io_failure(e)),
    };
    if let Some(p) = prev
        && !opts.rehash
        && stamp.matches(path, p)
    {
        return (p.clone(), FileStatus::Unchanged, Vec::new(), 0);
    }
    let bytes = match fs::read(path) {
        Ok(b) => b,
        Err(e) => return failed_row(path, name, "", prev, io_failure(e)),
    };
    let source_name = path.display().to_string();
    let stored = prev.filter(|p| p.status == "ok" && p.data_sha256.is_some());
    // A file the store holds is hashed first: unchanged content needs no parse. A new file is
    // hashed and parsed at the same time (a round is gigabytes; each takes about as long).
    let (sha, parsed) = if let Some(p) = stored {
        let sha = sha256_bytes(&bytes);
        if p.data_sha256.as_deref() == Some(sha.as_str()) {
            let mut row = p.clone();
            row.source_path = path.display().to_string();
            row.size_bytes = Some(stamp.size_bytes);
            row.mtime_ns = Some(stamp.mtime_ns);
            return (row, FileStatus::Unchanged, Vec::new(), 0);
        }
        (sha, ttc::read_run(&bytes, &source_name))
    } else {
        // A scoped thread, not `rayon::join`: a rayon worker waiting in `join` steals other
        // files' jobs and nests them on its stack (observed: 1.9 GB and a stack overflow).
        std::thread::scope(|s| {
            let hash = s.spawn(|| sha256_bytes(&bytes));
            let parsed = ttc::read_run(&bytes, &source_name);
            let sha = hash
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            (sha, parsed)
        })
    };
    let run = match parsed {
        Ok(r) => r,
        Err(e) => return failed_row(path, name, &sha, prev, e.to_string()),
    };
    drop(bytes);
    let identity = identify(&run, opts.catalog);
    let (segments, seg_report) = match segment::run(&signals(&run), opts.segment) {
        Ok(s) => s,
        Err(e) => return failed_row(path, name, &sha, prev, format!("{source_name}: {e}")),
    };
    let ctx = FileContext {
        name,
        sha: &sha,
        identity: &identity,
        run: &run,
    };
    if let Err(e) = write_file_parts(opts.store, &ctx, &segments, writers) {
        return failed_row(path, name, &sha, prev, e.to_string());
    }
    let mut warnings = run.meta.warnings.clone();
    warnings.extend(seg_report.warnings.iter().cloned());
    let row = RunRow {
        source_file: name.to_string(),
        source_path: path.display().to_string(),
        sha256: sha.clone(),
        data_sha256: Some(sha.clone()),
        status: "ok".into(),
        error: None,
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
                .unwrap_or_else(|| seg_report.run_class.as_str().to_string()),
        ),
        warnings: (!warnings.is_empty()).then(|| warnings.join("; ")),
        size_bytes: Some(stamp.size_bytes),
        mtime_ns: Some(stamp.mtime_ns),
    };
    let n = run.len();
    (row, FileStatus::Ingested, segments, n)
}

/// Which tire and rim a run is, and where that came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Identity {
    /// Tire name.
    pub tire: String,
    /// Rim width, whole inches.
    pub rim_in: Option<i64>,
    /// `catalog`, `tireid`, `tire_name` or `fallback`.
    pub source: &'static str,
    /// Run kind from the catalog.
    pub kind_hint: Option<String>,
}

/// Tire identity: the catalog entry, else the file's own tire fields (`.mat` `tireid`, `.dat`
/// `Tire_Name=`/`Rim_Width=`), else `project<p>-run<n>` with the rim unknown.
pub fn identify(run: &RunTable, catalog: Option<&Catalog>) -> Identity {
    let meta = &run.meta;
    if let (Some(c), Some(p), Some(r)) = (catalog, meta.project, meta.run)
        && let Some(e) = c.get(p, r)
    {
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
    let project = meta
        .project
        .map_or("unknown".to_string(), |p| p.to_string());
    let run_no = meta.run.map_or("unknown".to_string(), |r| r.to_string());
    Identity {
        tire: format!("project{project}-run{run_no}"),
        rim_in: None,
        source: "fallback",
        kind_hint: None,
    }
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
    s.has_kappa = run.meta.kappa_source.is_measured();
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
    let level = |v: Option<i32>| v.map_or(SWEPT, i64::from);
    PartitionKey {
        test: s.kind.as_str().to_string(),
        tire: id.tire.clone(),
        rim_in: id.rim_in.unwrap_or(0),
        pressure_kpa_nom: level(s.nominal.pressure_kpa),
        ia_deg_nom: level(s.nominal.ia_deg),
        fz_n_nom: level(s.nominal.fz_n),
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
    let part_name = source_part_name(ctx.name, ctx.sha);
    let write = |(key, segs): (&PartitionKey, &Vec<&Segment>)| -> Result<(), StoreError> {
        let arrays = samples_arrays(ctx, segs);
        let rows = arrays.first().map_or(0, |(_, a)| a.len());
        let (schema, arrays) = schema::table("samples").conform_arrays(arrays)?;
        let batch = RecordBatchT::try_new(rows, Arc::new(schema.clone()), arrays)
            .map_err(|e| StoreError::polars(store, e))?;
        let dir = store.join(partition_dir(key));
        ensure_dir(&dir)?;
        write_arrow_parquet_atomic_with(&dir.join(&part_name), Durability::Deferred, schema, batch)
    };
    let segments_table = || -> Result<(), StoreError> {
        let df = segments_frame(ctx, segments).map_err(|e| StoreError::polars(store, e))?;
        let mut df = schema::table("segments").conform(df)?;
        write_parquet_atomic_with(
            &store.join(segments_file(ctx.name, ctx.sha)),
            Durability::Deferred,
            &mut df,
        )
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
    let nom = |f: fn(&Segment) -> Option<i32>| -> Vec<Option<i64>> {
        segments.iter().map(|s| f(s).map(i64::from)).collect()
    };
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
        "ia_deg_nom" => nom(|s| s.nominal.ia_deg),
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

/// The runs table by source file (empty for a new store).
pub fn read_runs(store: &Path) -> Result<BTreeMap<String, RunRow>, IngestError> {
    let path = store.join(runs_file());
    if !path.exists() {
        return Ok(BTreeMap::new());
    }
    let df = read_parquet(&path)?;
    let s = |name: &str| -> PolarsResult<Vec<Option<String>>> {
        Ok(df
            .column(name)?
            .str()?
            .iter()
            .map(|v| v.map(str::to_string))
            .collect())
    };
    let i = |name: &str| -> PolarsResult<Vec<Option<i64>>> {
        Ok(df.column(name)?.i64()?.iter().collect())
    };
    let (source_file, source_path, sha256, data_sha256, status, error) = (
        s("source_file")?,
        s("source_path")?,
        s("sha256")?,
        s("data_sha256")?,
        s("status")?,
        s("error")?,
    );
    let (project, run, rows, n_segments, rim_in) = (
        i("project")?,
        i("run")?,
        i("rows")?,
        i("n_segments")?,
        i("rim_in")?,
    );
    let (format, round_style, units, tire, tire_source, kind_hint, warnings) = (
        s("format")?,
        s("round_style")?,
        s("units")?,
        s("tire")?,
        s("tire_source")?,
        s("kind_hint")?,
        s("warnings")?,
    );
    let rate: Vec<Option<f64>> = df.column("sample_rate_hz")?.f64()?.iter().collect();
    // Stores written before these columns existed have none: every file is then hashed once.
    let optional_i = |name: &str| -> PolarsResult<Vec<Option<i64>>> {
        match df.column(name) {
            Ok(c) => Ok(c.i64()?.iter().collect()),
            Err(_) => Ok(vec![None; df.height()]),
        }
    };
    let (size_bytes, mtime_ns) = (optional_i("size_bytes")?, optional_i("mtime_ns")?);
    let mut out = BTreeMap::new();
    for k in 0..df.height() {
        let row = RunRow {
            source_file: source_file[k].clone().unwrap_or_default(),
            source_path: source_path[k].clone().unwrap_or_default(),
            sha256: sha256[k].clone().unwrap_or_default(),
            data_sha256: data_sha256[k].clone(),
            status: status[k].clone().unwrap_or_default(),
            error: error[k].clone(),
            project: project[k],
            run: run[k],
            format: format[k].clone(),
            round_style: round_style[k].clone(),
            units: units[k].clone(),
            sample_rate_hz: rate[k],
            rows: rows[k].unwrap_or(0),
            n_segments: n_segments[k].unwrap_or(0),
            tire: tire[k].clone(),
            rim_in: rim_in[k],
            tire_source: tire_source[k].clone(),
            kind_hint: kind_hint[k].clone(),
            warnings: warnings[k].clone(),
            size_bytes: size_bytes[k],
            mtime_ns: mtime_ns[k],
        };
        out.insert(row.source_file.clone(), row);
    }
    Ok(out)
}

/// Rewrite the runs table atomically (the ingest's commit point).
fn write_runs(store: &Path, rows: &BTreeMap<String, RunRow>) -> Result<(), IngestError> {
    let r: Vec<&RunRow> = rows.values().collect();
    let df = df!(
        "source_file" => r.iter().map(|x| x.source_file.as_str()).collect::<Vec<_>>(),
        "source_path" => r.iter().map(|x| x.source_path.as_str()).collect::<Vec<_>>(),
        "sha256" => r.iter().map(|x| x.sha256.as_str()).collect::<Vec<_>>(),
        "data_sha256" => r.iter().map(|x| x.data_sha256.clone()).collect::<Vec<_>>(),
        "status" => r.iter().map(|x| x.status.as_str()).collect::<Vec<_>>(),
        "error" => r.iter().map(|x| x.error.clone()).collect::<Vec<_>>(),
        "project" => r.iter().map(|x| x.project).collect::<Vec<_>>(),
        "run" => r.iter().map(|x| x.run).collect::<Vec<_>>(),
        "format" => r.iter().map(|x| x.format.clone()).collect::<Vec<_>>(),
        "round_style" => r.iter().map(|x| x.round_style.clone()).collect::<Vec<_>>(),
        "units" => r.iter().map(|x| x.units.clone()).collect::<Vec<_>>(),
        "sample_rate_hz" => r.iter().map(|x| x.sample_rate_hz).collect::<Vec<_>>(),
        "rows" => r.iter().map(|x| x.rows).collect::<Vec<_>>(),
        "n_segments" => r.iter().map(|x| x.n_segments).collect::<Vec<_>>(),
        "tire" => r.iter().map(|x| x.tire.clone()).collect::<Vec<_>>(),
        "rim_in" => r.iter().map(|x| x.rim_in).collect::<Vec<_>>(),
        "tire_source" => r.iter().map(|x| x.tire_source.clone()).collect::<Vec<_>>(),
        "kind_hint" => r.iter().map(|x| x.kind_hint.clone()).collect::<Vec<_>>(),
        "warnings" => r.iter().map(|x| x.warnings.clone()).collect::<Vec<_>>(),
        "size_bytes" => r.iter().map(|x| x.size_bytes).collect::<Vec<_>>(),
        "mtime_ns" => r.iter().map(|x| x.mtime_ns).collect::<Vec<_>>(),
    )?;
    let mut df = schema::table("runs").conform(df)?;
    write_parquet_atomic(&store.join(runs_file()), &mut df)?;
    Ok(())
}

/// `", N duplicate runs (stored once)"` for the summary lines, empty when there is none.
pub fn duplicate_runs_note(duplicates: usize) -> String {
    if duplicates > 0 {
        format!(", {duplicates} duplicate runs (stored once)")
    } else {
        String::new()
    }
}

/// `runs.status` of a file whose run another file holds (see [`mark_duplicate_runs`]).
pub const DUPLICATE: &str = "duplicate";

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
            && r.status == "ok"
        {
            runs.entry((project, run)).or_default().push(r);
        }
    }
    let preference = |r: &RunRow| {
        (
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
            marked.insert(
                r.source_file.clone(),
                (canonical.clone(), format!("project {project}, run {run}")),
            );
        }
    }
    marked
        .into_iter()
        .map(|(name, (canonical, which))| {
            let row = rows.get_mut(&name).expect("marked rows exist");
            row.status = DUPLICATE.to_string();
            row.error = Some(format!(
                "same run as {canonical} ({which}), which is the copy stored"
            ));
            row.data_sha256 = None;
            row.n_segments = 0;
            (name, canonical)
        })
        .collect()
}

/// Delete parts that are not the committed data of some file (superseded versions, leftovers of
/// a crashed ingest), stale temporary files, and empty partition directories. Call with the
/// store lock held.
fn collect_garbage(store: &Path, rows: &BTreeMap<String, RunRow>) -> Result<(), StoreError> {
    let live: BTreeSet<String> = rows
        .values()
        .filter_map(|r| {
            r.data_sha256
                .as_deref()
                .map(|sha| source_part_name(&r.source_file, sha))
        })
        .collect();
    let mut candidates = parquet_files_in(&store.join(SEGMENTS_DIR))?;
    candidates.extend(parquet_files_below(&store.join(SAMPLES_DIR))?);
    for path in candidates {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if !live.contains(name) {
            fs::remove_file(&path).map_err(|e| StoreError::io(&path, e))?;
        }
    }
    remove_temp_and_empty(&store.join(SAMPLES_DIR))?;
    remove_temp_and_empty(&store.join(SEGMENTS_DIR))?;
    Ok(())
}

/// Remove `*.tmp` files and empty directories below `dir` (keeps `dir` itself).
fn remove_temp_and_empty(dir: &Path) -> Result<bool, StoreError> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(false);
    };
    let mut empty = true;
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if remove_temp_and_empty(&path)? {
                fs::remove_dir(&path).map_err(|e| StoreError::io(&path, e))?;
            } else {
                empty = false;
            }
        } else if path.to_string_lossy().ends_with(TEMP_SUFFIX) {
            fs::remove_file(&path).map_err(|e| StoreError::io(&path, e))?;
        } else {
            empty = false;
        }
    }
    Ok(empty)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, run: Option<i64>, units: &str, format: &str) -> RunRow {
        RunRow {
            source_file: name.to_string(),
            status: "ok".to_string(),
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
            assert_eq!(r.status, DUPLICATE);
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
            assert_eq!(rows[name].status, "ok", "{name}");
        }
        // Already marked: nothing more to do.
        assert!(mark_duplicate_runs(&mut rows).is_empty());
    }
}
