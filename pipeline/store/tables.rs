//! The store's tables: the one place that reads and writes the runs table and the segments and
//! samples parts (written by ingest, relabelled without a parse), says which of them are live,
//! reads the live segments as typed rows and collects garbage.
//!
//! In: a store root. Out: [`RunRow`]s (the runs table, `schemas/runs.toml`), [`SegmentRecord`]s
//! (the live rows of the segments table, `schemas/segments.toml`), the paths of live part files
//! and columns of a samples file ([`read_sample_columns`]).
//!
//! The live rule, stated once: every ingested file's samples and segments are written under one
//! part name, `<source>-<key12>.parquet` ([`RunRow::part_name`]), where the key is
//! [`parts_sha256`] of everything the parts were derived from (content, tire, rim, segmentation
//! settings, tool version). A part file is live when the runs table names it; anything else
//! below `segments/` and `samples/` (a crashed ingest's parts, a superseded derivation) is
//! invisible to every reader and removed by [`collect_garbage`]. Deliberately not here: how the
//! parts are computed (ingest) or what the stages do with them.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use polars_arrow::record_batch::RecordBatchT;

use super::columns::{opt_f64, opt_i64, opt_str, polars_at, req_bool, req_f64, req_i64, req_str};
use super::files::{
    Durability, ensure_dir, parquet_files_below, parquet_files_in, read_parquet, sha256_bytes,
    write_arrow_parquet_atomic_with, write_parquet_atomic_with,
};
use super::layout::{
    PartitionKey, SAMPLES_DIR, SEGMENTS_DIR, TEMP_SUFFIX, partition_dir, runs_file,
    source_part_name,
};
use super::{IoOp, StoreError, layout};
use crate::schema::{self, TableName};

/// `runs.status`: what the store holds for an input file.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RunStatus {
    /// Its data are stored and complete.
    Ok,
    /// Its rows stop early (a truncated transfer): stored, flagged.
    Partial,
    /// Its last attempt failed (an earlier stored version stays).
    #[default]
    Failed,
    /// Another file holds its run (no data of its own).
    Duplicate,
}

impl RunStatus {
    /// The name in the runs table and the manifest.
    pub const fn as_str(self) -> &'static str {
        match self {
            RunStatus::Ok => "ok",
            RunStatus::Partial => "partial",
            RunStatus::Failed => "failed",
            RunStatus::Duplicate => "duplicate",
        }
    }

    /// The status named `name`, if any.
    pub fn parse(name: &str) -> Option<RunStatus> {
        [
            RunStatus::Ok,
            RunStatus::Partial,
            RunStatus::Failed,
            RunStatus::Duplicate,
        ]
        .into_iter()
        .find(|s| s.as_str() == name)
    }
}

impl std::fmt::Display for RunStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One row of the runs table (see `schemas/runs.toml`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunRow {
    pub source_file: String,
    pub source_path: String,
    pub sha256: String,
    pub data_sha256: Option<String>,
    pub status: RunStatus,
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
    pub run_class: Option<String>,
    pub et_start_s: Option<f64>,
    pub et_end_s: Option<f64>,
    pub segment_config_sha256: Option<String>,
    pub tool_version: Option<String>,
    pub parts_sha256: Option<String>,
}

impl RunRow {
    /// File name of this row's stored parts (`segments/<name>` and one file per samples
    /// partition); `None` when the store holds no data for it. Rows written before the parts key
    /// existed name their parts by the content hash.
    pub fn part_name(&self) -> Option<String> {
        let data = self.data_sha256.as_deref()?;
        let key = self.parts_sha256.as_deref().unwrap_or(data);
        Some(source_part_name(&self.source_file, key))
    }

    /// The data are stored (status ok or partial, with a stored version).
    pub fn has_live_data(&self) -> bool {
        self.data_sha256.is_some()
    }
}

/// The key naming a file's parts: SHA-256 of everything they were derived from. Samples depend
/// on the content, the segmentation settings and the tool; the segments table and the samples'
/// partition directories also on the tire and rim the file is labelled with.
///
/// ```
/// use tirebase::store::tables::parts_sha256;
/// let a = parts_sha256("c0ffee", "Hoosier R25B", Some(7), "seg1", "0.1.0");
/// assert_eq!(a, parts_sha256("c0ffee", "Hoosier R25B", Some(7), "seg1", "0.1.0"));
/// assert_ne!(a, parts_sha256("c0ffee", "Hoosier R20", Some(7), "seg1", "0.1.0"));
/// assert_ne!(a, parts_sha256("c0ffee", "Hoosier R25B", Some(7), "seg2", "0.1.0"));
/// ```
pub fn parts_sha256(
    data_sha256: &str,
    tire: &str,
    rim_in: Option<i64>,
    segment_config_sha256: &str,
    tool_version: &str,
) -> String {
    let rim = rim_in.map_or("-".to_string(), |r| r.to_string());
    sha256_bytes(
        format!(
            "content {data_sha256}\ntire {tire}\nrim_in {rim}\nsegment {segment_config_sha256}\ntool {tool_version}\n"
        )
        .as_bytes(),
    )
}

/// The runs table by source file (empty for a new store). Columns added after a store was
/// written read as nulls (every such file is then re-derived once).
pub fn read_runs(store: &Path) -> Result<BTreeMap<String, RunRow>, StoreError> {
    let path = store.join(runs_file());
    if !path.exists() {
        return Ok(BTreeMap::new());
    }
    let df = read_parquet(&path)?;
    let n = df.height();
    let s = |name: &str| req_str(&df, name, &path);
    let i = |name: &str| req_i64(&df, name, &path);
    let os = |name: &str| -> Result<Vec<Option<String>>, StoreError> {
        Ok(opt_str(&df, name, &path)?.unwrap_or_else(|| vec![None; n]))
    };
    let oi = |name: &str| -> Result<Vec<Option<i64>>, StoreError> {
        Ok(opt_i64(&df, name, &path)?.unwrap_or_else(|| vec![None; n]))
    };
    let of = |name: &str| -> Result<Vec<Option<f64>>, StoreError> {
        Ok(opt_f64(&df, name, &path)?.unwrap_or_else(|| vec![None; n]))
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
    let rate = req_f64(&df, "sample_rate_hz", &path)?;
    let (size_bytes, mtime_ns) = (oi("size_bytes")?, oi("mtime_ns")?);
    let (run_class, segment_config_sha256, tool_version, parts) = (
        os("run_class")?,
        os("segment_config_sha256")?,
        os("tool_version")?,
        os("parts_sha256")?,
    );
    let (et_start_s, et_end_s) = (of("et_start_s")?, of("et_end_s")?);
    let mut out = BTreeMap::new();
    for k in 0..n {
        let status_name = status[k].as_deref().unwrap_or_default();
        let run_status = RunStatus::parse(status_name).ok_or_else(|| StoreError::Schema {
            table: path.display().to_string(),
            message: format!("row {}: unknown status {status_name:?}", k + 1),
        })?;
        let row = RunRow {
            source_file: source_file[k].clone().unwrap_or_default(),
            source_path: source_path[k].clone().unwrap_or_default(),
            sha256: sha256[k].clone().unwrap_or_default(),
            data_sha256: data_sha256[k].clone(),
            status: run_status,
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
            run_class: run_class[k].clone(),
            et_start_s: et_start_s[k],
            et_end_s: et_end_s[k],
            segment_config_sha256: segment_config_sha256[k].clone(),
            tool_version: tool_version[k].clone(),
            parts_sha256: parts[k].clone(),
        };
        out.insert(row.source_file.clone(), row);
    }
    Ok(out)
}

/// The store has a runs table (something was ingested into it).
pub fn has_runs(store: &Path) -> bool {
    store.join(runs_file()).is_file()
}

/// SHA-256 of the runs table file ("" without one): what a version records of the data it
/// was computed from.
pub fn runs_sha256(store: &Path) -> Result<String, StoreError> {
    let path = store.join(runs_file());
    if path.exists() {
        super::files::sha256_file(&path)
    } else {
        Ok(String::new())
    }
}

/// The runs table as stored, for SQL (`query`): every column, an empty table with the schema's
/// columns for a new store.
pub fn runs_frame(store: &Path) -> Result<DataFrame, StoreError> {
    let path = store.join(runs_file());
    if !path.exists() {
        return Ok(DataFrame::empty_with_schema(
            &schema::table(TableName::Runs).file_schema(),
        ));
    }
    read_parquet(&path)
}

/// Rewrite the runs table atomically (the commit point of every change to the store's data).
pub fn write_runs(store: &Path, rows: &BTreeMap<String, RunRow>) -> Result<(), StoreError> {
    let path = store.join(runs_file());
    let r: Vec<&RunRow> = rows.values().collect();
    let s = |f: fn(&RunRow) -> Option<String>| r.iter().map(|x| f(x)).collect::<Vec<_>>();
    let df = df!(
        "source_file" => r.iter().map(|x| x.source_file.as_str()).collect::<Vec<_>>(),
        "source_path" => r.iter().map(|x| x.source_path.as_str()).collect::<Vec<_>>(),
        "sha256" => r.iter().map(|x| x.sha256.as_str()).collect::<Vec<_>>(),
        "data_sha256" => s(|x| x.data_sha256.clone()),
        "status" => r.iter().map(|x| x.status.as_str()).collect::<Vec<_>>(),
        "error" => s(|x| x.error.clone()),
        "project" => r.iter().map(|x| x.project).collect::<Vec<_>>(),
        "run" => r.iter().map(|x| x.run).collect::<Vec<_>>(),
        "format" => s(|x| x.format.clone()),
        "round_style" => s(|x| x.round_style.clone()),
        "units" => s(|x| x.units.clone()),
        "sample_rate_hz" => r.iter().map(|x| x.sample_rate_hz).collect::<Vec<_>>(),
        "rows" => r.iter().map(|x| x.rows).collect::<Vec<_>>(),
        "n_segments" => r.iter().map(|x| x.n_segments).collect::<Vec<_>>(),
        "tire" => s(|x| x.tire.clone()),
        "rim_in" => r.iter().map(|x| x.rim_in).collect::<Vec<_>>(),
        "tire_source" => s(|x| x.tire_source.clone()),
        "kind_hint" => s(|x| x.kind_hint.clone()),
        "warnings" => s(|x| x.warnings.clone()),
        "size_bytes" => r.iter().map(|x| x.size_bytes).collect::<Vec<_>>(),
        "mtime_ns" => r.iter().map(|x| x.mtime_ns).collect::<Vec<_>>(),
        "run_class" => s(|x| x.run_class.clone()),
        "et_start_s" => r.iter().map(|x| x.et_start_s).collect::<Vec<_>>(),
        "et_end_s" => r.iter().map(|x| x.et_end_s).collect::<Vec<_>>(),
        "segment_config_sha256" => s(|x| x.segment_config_sha256.clone()),
        "tool_version" => s(|x| x.tool_version.clone()),
        "parts_sha256" => s(|x| x.parts_sha256.clone()),
    )
    .map_err(polars_at(IoOp::Write, &path))?;
    let mut df = schema::table(TableName::Runs).conform(df)?;
    super::files::write_parquet_atomic(&path, &mut df)
}

/// Part file names the runs table commits (the live rule).
pub fn live_parts(rows: &BTreeMap<String, RunRow>) -> BTreeSet<String> {
    rows.values().filter_map(RunRow::part_name).collect()
}

fn file_name(path: &Path) -> &str {
    path.file_name().and_then(|n| n.to_str()).unwrap_or("")
}

/// Live files of the segments table, sorted.
pub fn live_segment_files(store: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let live = live_parts(&read_runs(store)?);
    Ok(parquet_files_in(&store.join(SEGMENTS_DIR))?
        .into_iter()
        .filter(|p| live.contains(file_name(p)))
        .collect())
}

/// [`StoreError::OldLayout`] when one of the segments `files` was written with the old
/// inclination key (for readers that scan the files instead of [`read_segment_file`], which
/// checks its own).
pub fn refuse_old_segment_files(files: &[PathBuf]) -> Result<(), StoreError> {
    for path in files {
        let file = fs::File::open(path).map_err(|e| StoreError::io(IoOp::Read, path, e))?;
        let schema = ParquetReader::new(file)
            .schema()
            .map_err(polars_at(IoOp::Read, path))?;
        refuse_old_layout(path, |c| schema.contains(c))?;
    }
    Ok(())
}

/// [`StoreError::OldLayout`] when the segments file `path` (whose columns `has` tells) keys the
/// inclination the old way.
fn refuse_old_layout(path: &Path, has: impl Fn(&str) -> bool) -> Result<(), StoreError> {
    if has(layout::IA_KEY) || !has(layout::OLD_IA_KEY) {
        return Ok(());
    }
    let root = path
        .parent()
        .and_then(Path::parent)
        .unwrap_or(Path::new("."));
    Err(StoreError::OldLayout {
        root: root.to_path_buf(),
        file: path.to_path_buf(),
        what: "its segments and samples key the inclination as ia_deg_nom (whole degrees, -1 for \
               swept), this version as ia_cdeg_nom (hundredths of a degree, null for swept)",
    })
}

/// Live files of the samples table (every partition), sorted; [`StoreError::OldLayout`] when
/// one of them sits in a partition of the previous layout (a swept pressure or load keyed `-1`,
/// [`layout::OLD_SWEPT_DIRS`]).
pub fn live_sample_files(store: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let live = live_parts(&read_runs(store)?);
    let files: Vec<PathBuf> = parquet_files_below(&store.join(SAMPLES_DIR))?
        .into_iter()
        .filter(|p| live.contains(file_name(p)))
        .collect();
    let old = files.iter().find(|p| {
        p.components()
            .any(|c| layout::OLD_SWEPT_DIRS.iter().any(|d| c.as_os_str() == *d))
    });
    match old {
        Some(file) => Err(StoreError::OldLayout {
            root: store.to_path_buf(),
            file: file.clone(),
            what: "its samples partitions key a swept or unheld pressure or load as -1 \
                   (pressure_kpa_nom=-1, fz_n_nom=-1), this version as the hive null \
                   (__HIVE_DEFAULT_PARTITION__)",
        }),
        None => Ok(files),
    }
}

/// One live row of the segments table, typed (`schemas/segments.toml`), with the name of the
/// part it was read from (which also names its samples file).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SegmentRecord {
    pub part: String,
    pub segment_id: String,
    pub source_file: String,
    pub source_sha256: String,
    pub segment_index: i64,
    pub kind: String,
    pub tire: String,
    pub rim_in: i64,
    /// Nominal pressure, kPa; `None` when not held.
    pub pressure_kpa_nom: Option<i64>,
    /// Nominal inclination, hundredths of a degree; `None` when swept or unlevelled.
    pub ia_cdeg_nom: Option<i64>,
    pub fz_n_nom: Option<i64>,
    pub alpha_deg_nom: Option<i64>,
    pub speed_kph_nom: Option<i64>,
    pub fz_n_mean: f64,
    pub ia_deg_mean: f64,
    pub speed_kph_mean: f64,
    pub alpha_deg_mean: f64,
    pub alpha_deg_min: f64,
    pub alpha_deg_max: f64,
    pub kappa_min: f64,
    pub kappa_max: f64,
    pub sample_start: i64,
    pub sample_end: i64,
    pub qc_flags: String,
    pub qc_ok: bool,
}

impl SegmentRecord {
    /// The samples partition holding this segment's rows.
    pub fn partition(&self) -> PartitionKey {
        PartitionKey {
            test: self.kind.clone(),
            tire: self.tire.clone(),
            rim_in: self.rim_in,
            pressure_kpa_nom: self.pressure_kpa_nom,
            ia_cdeg_nom: self.ia_cdeg_nom,
            fz_n_nom: self.fz_n_nom,
        }
    }

    /// The samples file holding this segment's rows, relative to the store root.
    pub fn samples_file(&self) -> PathBuf {
        partition_dir(&self.partition()).join(&self.part)
    }
}

/// Rows of one segments file.
pub fn read_segment_file(path: &Path) -> Result<Vec<SegmentRecord>, StoreError> {
    let df = read_parquet(path)?;
    refuse_old_layout(path, |c| df.schema().contains(c))?;
    let part = file_name(path).to_string();
    let s = |n: &str| req_str(&df, n, path);
    let i = |n: &str| req_i64(&df, n, path);
    let f = |n: &str| req_f64(&df, n, path);
    let (id, file, sha, kind, tire, flags) = (
        s("segment_id")?,
        s("source_file")?,
        s("source_sha256")?,
        s("kind")?,
        s("tire")?,
        s("qc_flags")?,
    );
    let (index, rim, p_nom, ia_nom, fz_nom, alpha_nom, v_nom, start, end) = (
        i("segment_index")?,
        i("rim_in")?,
        i("pressure_kpa_nom")?,
        i(layout::IA_KEY)?,
        i("fz_n_nom")?,
        i("alpha_deg_nom")?,
        i("speed_kph_nom")?,
        i("sample_start")?,
        i("sample_end")?,
    );
    let (fz_mean, ia_mean, v_mean, a_mean) = (
        f("fz_n_mean")?,
        f("ia_deg_mean")?,
        f("speed_kph_mean")?,
        f("alpha_deg_mean")?,
    );
    let (a_min, a_max, k_min, k_max) = (
        f("alpha_deg_min")?,
        f("alpha_deg_max")?,
        f("kappa_min")?,
        f("kappa_max")?,
    );
    let qc_ok = req_bool(&df, "qc_ok", path)?;
    let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
    Ok((0..df.height())
        .map(|k| SegmentRecord {
            part: part.clone(),
            segment_id: id[k].clone().unwrap_or_default(),
            source_file: file[k].clone().unwrap_or_default(),
            source_sha256: sha[k].clone().unwrap_or_default(),
            segment_index: index[k].unwrap_or(0),
            kind: kind[k].clone().unwrap_or_default(),
            tire: tire[k].clone().unwrap_or_default(),
            rim_in: rim[k].unwrap_or(0),
            pressure_kpa_nom: p_nom[k],
            ia_cdeg_nom: ia_nom[k],
            fz_n_nom: fz_nom[k],
            alpha_deg_nom: alpha_nom[k],
            speed_kph_nom: v_nom[k],
            fz_n_mean: nan(fz_mean[k]),
            ia_deg_mean: nan(ia_mean[k]),
            speed_kph_mean: nan(v_mean[k]),
            alpha_deg_mean: nan(a_mean[k]),
            alpha_deg_min: nan(a_min[k]),
            alpha_deg_max: nan(a_max[k]),
            kappa_min: nan(k_min[k]),
            kappa_max: nan(k_max[k]),
            sample_start: start[k].unwrap_or(0),
            sample_end: end[k].unwrap_or(i64::MAX),
            qc_flags: flags[k].clone().unwrap_or_default(),
            qc_ok: qc_ok[k].unwrap_or(false),
        })
        .collect())
}

/// Every live segment of the store, in file order (files sorted by name, rows as stored);
/// [`StoreError::OldLayout`] for a store of an older layout (segments or samples partitions).
pub fn live_segments(store: &Path) -> Result<Vec<SegmentRecord>, StoreError> {
    // The segments of layout 2 read the same as layout 3; their samples sit elsewhere.
    live_sample_files(store)?;
    let mut out = Vec::new();
    for path in live_segment_files(store)? {
        out.extend(read_segment_file(&path)?);
    }
    Ok(out)
}

/// Some columns of one samples file (a path from [`SegmentRecord::samples_file`] under the
/// store root), in file order. `parallel` lets polars use its own thread pool (callers already
/// reading several files in parallel pass false).
pub fn read_sample_columns(
    path: &Path,
    columns: &[&str],
    optional: &[&str],
    parallel: bool,
) -> Result<DataFrame, StoreError> {
    let file = fs::File::open(path).map_err(|e| StoreError::io(IoOp::Read, path, e))?;
    let mut reader = ParquetReader::new(file);
    let schema = reader.schema().map_err(polars_at(IoOp::Read, path))?;
    let wanted = columns
        .iter()
        .chain(optional.iter().filter(|c| schema.contains(c)))
        .map(|c| c.to_string())
        .collect();
    let reader = reader.with_columns(Some(wanted));
    let reader = if parallel {
        reader
    } else {
        reader.read_parallel(ParallelStrategy::None)
    };
    reader.finish().map_err(polars_at(IoOp::Read, path))
}

/// Write one file's part of the segments table (`segments/<part>`), conformed to its schema.
/// Not durable until the caller syncs the filesystem (the runs table commits it).
pub fn write_segments_part(store: &Path, part: &str, df: DataFrame) -> Result<(), StoreError> {
    let mut df = schema::table(TableName::Segments).conform(df)?;
    write_parquet_atomic_with(
        &store.join(SEGMENTS_DIR).join(part),
        Durability::Deferred,
        &mut df,
    )
}

/// Write one file's samples of one partition (`samples/<partition>/<part>`), conformed to the
/// samples schema. Not durable until the caller syncs the filesystem.
pub fn write_samples_part(
    store: &Path,
    key: &PartitionKey,
    part: &str,
    rows: usize,
    arrays: Vec<(&str, ArrayRef)>,
) -> Result<(), StoreError> {
    let (schema, arrays) = schema::table(TableName::Samples).conform_arrays(arrays)?;
    let batch = RecordBatchT::try_new(rows, Arc::new(schema.clone()), arrays)
        .map_err(|e| StoreError::polars(IoOp::Write, store, e))?;
    let dir = store.join(partition_dir(key));
    ensure_dir(&dir)?;
    write_arrow_parquet_atomic_with(&dir.join(part), Durability::Deferred, schema, batch)
}

/// Relabel a file's stored parts with a new tire and rim without recomputing them: the segments
/// part is rewritten as `new_part` with the new labels, the samples files (whose content does
/// not name the tire) are linked into the new partitions under `new_part`. False (nothing
/// written) when a part of `old_part` is missing.
pub fn relabel_parts(
    store: &Path,
    old_part: &str,
    new_part: &str,
    tire: &str,
    rim_in: i64,
) -> Result<bool, StoreError> {
    let old_segments = store.join(SEGMENTS_DIR).join(old_part);
    if !old_segments.is_file() {
        return Ok(false);
    }
    let records = read_segment_file(&old_segments)?;
    let mut links: BTreeMap<PathBuf, PathBuf> = BTreeMap::new();
    for r in &records {
        let mut key = r.partition();
        let from = store.join(partition_dir(&key)).join(old_part);
        key.tire = tire.to_string();
        key.rim_in = rim_in;
        links.insert(from, store.join(partition_dir(&key)).join(new_part));
    }
    if links.keys().any(|from| !from.is_file()) {
        return Ok(false);
    }
    let mut df = read_parquet(&old_segments)?;
    let n = df.height();
    df.with_column(Column::new("tire".into(), vec![tire; n]))
        .and_then(|df| df.with_column(Column::new("rim_in".into(), vec![rim_in; n])))
        .map_err(polars_at(IoOp::Write, &old_segments))?;
    write_segments_part(store, new_part, df)?;
    for (from, to) in &links {
        if let Some(dir) = to.parent() {
            ensure_dir(dir)?;
        }
        if to.exists() {
            fs::remove_file(to).map_err(|e| StoreError::io(IoOp::Remove, to, e))?;
        }
        if fs::hard_link(from, to).is_err() {
            fs::copy(from, to).map_err(|e| StoreError::io(IoOp::Copy, to, e))?;
        }
    }
    Ok(true)
}

/// Delete parts that are not live (superseded derivations, leftovers of a crashed ingest), stale
/// temporary files, and empty partition directories. Call with the store lock held.
pub fn collect_garbage(store: &Path, rows: &BTreeMap<String, RunRow>) -> Result<(), StoreError> {
    let live = live_parts(rows);
    let mut candidates = parquet_files_in(&store.join(SEGMENTS_DIR))?;
    candidates.extend(parquet_files_below(&store.join(SAMPLES_DIR))?);
    for path in candidates {
        if !live.contains(file_name(&path)) {
            fs::remove_file(&path).map_err(|e| StoreError::io(IoOp::Remove, &path, e))?;
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
                fs::remove_dir(&path).map_err(|e| StoreError::io(IoOp::Remove, &path, e))?;
            } else {
                empty = false;
            }
        } else if path.to_string_lossy().ends_with(TEMP_SUFFIX) {
            fs::remove_file(&path).map_err(|e| StoreError::io(IoOp::Remove, &path, e))?;
        } else {
            empty = false;
        }
    }
    Ok(empty)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, data: Option<&str>, parts: Option<&str>) -> RunRow {
        RunRow {
            source_file: name.into(),
            status: RunStatus::Ok,
            data_sha256: data.map(String::from),
            parts_sha256: parts.map(String::from),
            ..RunRow::default()
        }
    }

    #[test]
    fn part_names_follow_the_parts_key_and_fall_back_to_the_content_hash() {
        assert_eq!(
            row("a.dat", Some("0123456789abcdef"), Some("fedcba9876543210")).part_name(),
            Some("a_dat-fedcba987654.parquet".to_string())
        );
        assert_eq!(
            row("a.dat", Some("0123456789abcdef"), None).part_name(),
            Some("a_dat-0123456789ab.parquet".to_string())
        );
        assert_eq!(row("a.dat", None, Some("ff")).part_name(), None);
    }

    #[test]
    fn runs_round_trip_through_the_table_and_garbage_is_only_what_no_row_names() {
        let root = tempfile::tempdir().unwrap();
        let mut rows = BTreeMap::new();
        let mut a = row("a.dat", Some("aaaaaaaaaaaaaaaa"), Some("1111111111111111"));
        a.et_start_s = Some(0.5);
        a.tool_version = Some("0.1.0".into());
        rows.insert(a.source_file.clone(), a);
        rows.insert("b.dat".into(), row("b.dat", None, None));
        write_runs(root.path(), &rows).unwrap();
        assert_eq!(read_runs(root.path()).unwrap(), rows);

        let seg = root.path().join(SEGMENTS_DIR);
        fs::create_dir_all(&seg).unwrap();
        for name in ["a_dat-111111111111.parquet", "a_dat-aaaaaaaaaaaa.parquet"] {
            fs::write(seg.join(name), b"x").unwrap();
        }
        assert_eq!(
            live_segment_files(root.path()).unwrap(),
            vec![seg.join("a_dat-111111111111.parquet")]
        );
        collect_garbage(root.path(), &rows).unwrap();
        assert!(seg.join("a_dat-111111111111.parquet").exists());
        assert!(!seg.join("a_dat-aaaaaaaaaaaa.parquet").exists());
    }
}
