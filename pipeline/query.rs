//! SQL over a store: every table as a polars-sql table, lazily scanned.
//!
//! In: a store root and a SQL string. Out: a DataFrame (printed as an aligned table or CSV by
//! the command layer). Tables:
//! - `runs`, `segments`, `samples`: the tire database. `segments` and `samples` are the part
//!   files the runs table names (`store::tables`' live rule: parts of a crashed or superseded
//!   ingest are never visible here, even before they are garbage-collected).
//! - every published result table (`coefficients`, `fit_quality`, `spring_rate`, `thermal`,
//!   `thermal_fit`, `relaxation`, `inertia`, ...) across all versions with a `version` column,
//!   plus `<table>_latest`, the newest version only; and `versions` (one row per version with
//!   its date, counts and change summary from the manifest).
//!
//! Deliberately not here: writing anything.

use std::io::Write;
use std::path::Path;

use polars::prelude::*;
use polars::sql::SQLContext;

use crate::manifest::Manifest;
use crate::schema::{self, TableName, TableSchema};
use crate::store::layout::{SAMPLES_DIR, runs_file};
use crate::store::{StoreError, results, tables, versions};

/// Query errors.
#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    /// The store could not be read.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The SQL failed to plan or execute.
    #[error("query failed: {0}")]
    Sql(#[from] PolarsError),
    /// The path is not a store.
    #[error("{0} is not a tirebase store (no runs/ or versions/ directory)")]
    NotAStore(String),
}

/// An empty frame with a table's file columns (used when a table has no files yet).
fn empty_frame(table: &TableSchema) -> LazyFrame {
    DataFrame::empty_with_schema(&table.file_schema()).lazy()
}

fn pl_path(path: &Path) -> PlRefPath {
    PlRefPath::new(path.to_string_lossy().into_owned())
}

/// Scan a list of Parquet files; with `hive`, the partition columns `hive` defines are parsed
/// from their paths with the schema's types (not inferred: a scan whose inclination keys are
/// all the hive null would otherwise read them as strings).
fn scan_files(files: &[std::path::PathBuf], hive: Option<&TableSchema>) -> PolarsResult<LazyFrame> {
    let paths: Vec<PlRefPath> = files.iter().map(|p| pl_path(p)).collect();
    let hive_options = match hive {
        Some(table) => HiveOptions {
            schema: Some(Arc::new(
                table
                    .columns
                    .iter()
                    .filter(|c| c.partition)
                    .map(|c| Field::new(c.name.as_str().into(), c.dtype.polars()))
                    .collect(),
            )),
            ..HiveOptions::new_enabled()
        },
        None => HiveOptions::new_disabled(),
    };
    let args = ScanArgsParquet {
        hive_options,
        ..Default::default()
    };
    LazyFrame::scan_parquet_files(paths.into_iter().collect(), args)
}

/// Build a SQL context with every table of the store registered.
pub fn context(root: &Path) -> Result<SQLContext, QueryError> {
    let runs_path = root.join(runs_file());
    let has_versions = root.join(crate::store::layout::VERSIONS_DIR).is_dir();
    if !runs_path.exists() && !has_versions && !root.join(SAMPLES_DIR).is_dir() {
        return Err(QueryError::NotAStore(root.display().to_string()));
    }
    let mut ctx = SQLContext::new();

    ctx.register("runs", tables::runs_frame(root)?.lazy());

    // Only the part files the runs table names are scanned (`store::tables`' live rule).
    let seg_files = tables::live_segment_files(root)?;
    tables::refuse_old_segment_files(&seg_files)?;
    let segments = if seg_files.is_empty() {
        empty_frame(schema::table(TableName::Segments))
    } else {
        scan_files(&seg_files, None)?
    };
    ctx.register("segments", segments);

    let sample_files = tables::live_sample_files(root)?;
    let samples = if sample_files.is_empty() {
        empty_frame(schema::table(TableName::Samples))
    } else {
        scan_files(&sample_files, Some(schema::table(TableName::Samples)))?
    };
    ctx.register("samples", samples);

    register_versions(&mut ctx, root)?;
    Ok(ctx)
}

/// Register every result table of every version (`<table>` with a `version` column and
/// `<table>_latest`, the rows of the newest version only: empty when the newest version has no
/// such table) and the `versions` listing (one row per version, from the manifests).
fn register_versions(ctx: &mut SQLContext, root: &Path) -> Result<(), QueryError> {
    let all = versions::list(root)?;
    let newest = all.last().map_or(0, |(n, _)| *n as i64);
    let mut tables: std::collections::BTreeMap<String, Vec<DataFrame>> = Default::default();
    for (n, dir) in &all {
        for name in results::table_names(dir)? {
            // Read eagerly: result tables are small, and polars 0.55 fails `count(*)` over a
            // union of lazy Parquet scans ("casting from UInt32 to UInt128").
            let Some(mut df) = results::read_table(dir, &name)? else {
                continue;
            };
            df.with_column(Column::new("version".into(), vec![*n as i64; df.height()]))?;
            tables.entry(name).or_default().push(df);
        }
    }
    for (name, frames) in tables {
        let union = union_frames(frames)?.lazy();
        ctx.register(
            &format!("{name}_latest"),
            union.clone().filter(col("version").eq(lit(newest))),
        );
        ctx.register(&name, union);
    }
    ctx.register("versions", versions_frame(&all)?.lazy());
    Ok(())
}

/// Stack the versions' frames: one in-memory frame (polars 0.55 miscounts over a lazy union),
/// columns that changed type between versions cast to a common supertype.
fn union_frames(frames: Vec<DataFrame>) -> PolarsResult<DataFrame> {
    let mut it = frames.into_iter();
    let Some(mut acc) = it.next() else {
        return Ok(DataFrame::empty());
    };
    for df in it {
        match acc.vstack(&df) {
            Ok(stacked) => acc = stacked,
            Err(_) => {
                acc = concat(
                    [acc.lazy(), df.lazy()],
                    UnionArgs {
                        to_supertypes: true,
                        diagonal: true,
                        ..Default::default()
                    },
                )?
                .collect()?;
            }
        }
    }
    acc.rechunk_mut();
    Ok(acc)
}

/// One row per version: number, date, tool, counts and the change summary of its manifest
/// (nulls when a manifest cannot be read).
fn versions_frame(all: &[(u32, std::path::PathBuf)]) -> PolarsResult<DataFrame> {
    let manifests: Vec<Option<Manifest>> =
        all.iter().map(|(_, d)| Manifest::read(d).ok()).collect();
    let text = |f: fn(&Manifest) -> String| -> Vec<Option<String>> {
        manifests.iter().map(|m| m.as_ref().map(f)).collect()
    };
    let count = |f: fn(&Manifest) -> u64| -> Vec<Option<i64>> {
        manifests
            .iter()
            .map(|m| m.as_ref().map(|m| f(m) as i64))
            .collect()
    };
    df!(
        "version" => all.iter().map(|(n, _)| *n as i64).collect::<Vec<_>>(),
        "created_utc" => text(|m| m.created_utc.clone()),
        "tool_version" => text(|m| m.tool_version.clone()),
        "files" => count(|m| m.counts.files),
        "files_failed" => count(|m| m.counts.files_failed),
        "groups" => count(|m| m.counts.groups),
        "groups_fitted" => count(|m| m.counts.groups_fitted),
        "groups_reused" => count(|m| m.counts.groups_reused),
        "fit_failures" => count(|m| m.counts.fit_failures),
        "tir_files" => count(|m| m.counts.tir_files),
        "summary" => text(|m| m.summary.clone()),
    )
}

/// Run one SQL statement against the store.
pub fn run(root: &Path, sql: &str) -> Result<DataFrame, QueryError> {
    let mut ctx = context(root)?;
    Ok(ctx.execute(sql)?.collect()?)
}

/// Write a frame as CSV (header, full float precision).
pub fn write_csv(df: &mut DataFrame, out: &mut dyn Write) -> PolarsResult<()> {
    CsvWriter::new(out).include_header(true).finish(df)
}

/// Render a frame as an aligned text table (every row; floats to 6 significant digits).
pub fn format_table(df: &DataFrame) -> String {
    aligned_text(df, |v| format!("{v:.6}"))
}

/// A frame as text: a header line, a rule, then one line per row, columns padded to their widest
/// cell and separated by two spaces; floats through `float`, nulls empty.
pub fn aligned_text(df: &DataFrame, float: impl Fn(f64) -> String) -> String {
    let names: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut cells: Vec<Vec<String>> = vec![names.clone()];
    for i in 0..df.height() {
        let row = df
            .columns()
            .iter()
            .map(|c| match c.get(i) {
                Ok(AnyValue::Null) => String::new(),
                Ok(AnyValue::Float64(v)) => float(v),
                Ok(AnyValue::String(s)) => s.to_string(),
                Ok(v) => v.to_string(),
                Err(_) => String::new(),
            })
            .collect();
        cells.push(row);
    }
    let widths: Vec<usize> = (0..names.len())
        .map(|j| {
            cells
                .iter()
                .map(|r| r[j].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for (k, row) in cells.iter().enumerate() {
        let line: Vec<String> = row
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        out.push_str(line.join("  ").trim_end());
        out.push('\n');
        if k == 0 {
            let rule: Vec<String> = widths.iter().map(|w| "-".repeat(*w)).collect();
            out.push_str(&rule.join("  "));
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use std::fs;

    use crate::store::files::write_parquet_atomic;
    use crate::store::layout::{self, PartitionKey, partition_dir};
    use crate::store::tables::{RunRow, RunStatus};

    /// A two-file store where one file's data is live and the other's was superseded.
    fn tiny_store(root: &Path) {
        let rows: BTreeMap<String, RunRow> = [
            RunRow {
                source_file: "a.dat".into(),
                data_sha256: Some("aaa".into()),
                parts_sha256: Some("111111111111".into()),
                status: RunStatus::Ok,
                ..RunRow::default()
            },
            RunRow {
                source_file: "b.dat".into(),
                status: RunStatus::Failed,
                ..RunRow::default()
            },
        ]
        .into_iter()
        .map(|r| (r.source_file.clone(), r))
        .collect();
        tables::write_runs(root, &rows).unwrap();
        let key = PartitionKey {
            test: "cornering".into(),
            tire: "Hoosier 20.5x7.0-13 R25B".into(),
            rim_in: 7,
            pressure_kpa_nom: Some(83),
            ia_cdeg_nom: Some(0),
            fz_n_nom: Some(1112),
        };
        // The live part, and a superseded derivation of the same content.
        for (part, fz) in [("111111111111", 1100.0), ("222222222222", 9999.0)] {
            let mut df = df!("source_sha256" => ["aaa", "aaa"], "fz_n" => [fz, fz + 20.0]).unwrap();
            let path = root
                .join(partition_dir(&key))
                .join(format!("a_dat-{part}.parquet"));
            write_parquet_atomic(&path, &mut df).unwrap();
        }
    }

    #[test]
    fn samples_are_hive_decoded_and_filtered_to_live_data() {
        let root = tempfile::tempdir().unwrap();
        tiny_store(root.path());
        let df = run(
            root.path(),
            "SELECT tire, rim_in, fz_n_nom, fz_n FROM samples ORDER BY fz_n",
        )
        .unwrap();
        assert_eq!(df.height(), 2, "{df}");
        let tire = df
            .column("tire")
            .unwrap()
            .str()
            .unwrap()
            .get(0)
            .unwrap()
            .to_string();
        assert_eq!(tire, "Hoosier 20.5x7.0-13 R25B");
        let fz: Vec<f64> = df
            .column("fz_n")
            .unwrap()
            .f64()
            .unwrap()
            .into_no_null_iter()
            .collect();
        assert_eq!(
            fz,
            vec![1100.0, 1120.0],
            "measured fz_n must not be shadowed"
        );
        assert_eq!(
            df.column("fz_n_nom")
                .unwrap()
                .cast(&DataType::Int64)
                .unwrap()
                .i64()
                .unwrap()
                .get(0),
            Some(1112)
        );
    }

    /// Every number is a held level: a held -1 deg reads back as -100; a swept inclination or
    /// load and an unheld pressure (the hive null) read back as a null of the integer column, even
    /// when no partition holds a number.
    #[test]
    fn swept_levels_read_back_as_null_and_negative_camber_as_a_level() {
        // (pressure_kpa_nom, ia_cdeg_nom, fz_n_nom) of each partition.
        type Levels = (Option<i64>, Option<i64>, Option<i64>);
        let cases: [Vec<Levels>; 3] = [
            vec![
                (Some(83), Some(-100), Some(1112)),
                (Some(83), None, Some(1112)),
            ],
            vec![(None, None, None)],
            vec![(Some(83), Some(0), None), (None, Some(160), Some(667))],
        ];
        for levels in cases {
            let root = tempfile::tempdir().unwrap();
            tiny_store(root.path());
            fs::remove_dir_all(root.path().join(SAMPLES_DIR)).unwrap();
            for (k, &(p, ia, fz)) in levels.iter().enumerate() {
                let key = PartitionKey {
                    test: "cornering".into(),
                    tire: "T".into(),
                    rim_in: 7,
                    pressure_kpa_nom: p,
                    ia_cdeg_nom: ia,
                    fz_n_nom: fz,
                };
                let mut df = df!("fz_n" => [1000.0 + k as f64]).unwrap();
                let path = root
                    .path()
                    .join(partition_dir(&key))
                    .join("a_dat-111111111111.parquet");
                write_parquet_atomic(&path, &mut df).unwrap();
            }
            let df = run(
                root.path(),
                "SELECT pressure_kpa_nom, ia_cdeg_nom, fz_n_nom FROM samples ORDER BY fz_n",
            )
            .unwrap();
            let column = |name: &str| -> Vec<Option<i64>> {
                let c = df.column(name).unwrap();
                assert_eq!(c.dtype(), &DataType::Int64, "{name}: {df}");
                c.i64().unwrap().iter().collect()
            };
            let got: Vec<Levels> = (column("pressure_kpa_nom").into_iter())
                .zip(column("ia_cdeg_nom"))
                .zip(column("fz_n_nom"))
                .map(|((p, ia), fz)| (p, ia, fz))
                .collect();
            assert_eq!(got, levels, "{df}");
        }
    }

    /// A store whose live segments key the inclination the old way is refused, naming the fix.
    #[test]
    fn a_store_of_the_old_layout_asks_for_a_re_ingest() {
        let root = tempfile::tempdir().unwrap();
        tiny_store(root.path());
        let mut df = df!("segment_id" => ["a-0"], "ia_deg_nom" => [-1i64]).unwrap();
        write_parquet_atomic(
            &root.path().join("segments/a_dat-111111111111.parquet"),
            &mut df,
        )
        .unwrap();
        let err = run(root.path(), "SELECT 1").unwrap_err().to_string();
        assert!(
            err.contains("ia_deg_nom") && err.contains("tirebase ingest --store"),
            "{err}"
        );
    }

    /// A store whose samples key a swept load or an unheld pressure `-1` (layout 2) is refused by
    /// the query and by every reader of the live segments, naming the fix.
    #[test]
    fn a_store_with_minus_one_for_swept_is_refused() {
        for old in layout::OLD_SWEPT_DIRS {
            let root = tempfile::tempdir().unwrap();
            tiny_store(root.path());
            let dir = root
                .path()
                .join("samples/test=cornering/tire=T/rim_in=7/pressure_kpa_nom=83/ia_cdeg_nom=0");
            let dir = if old.starts_with("fz") {
                dir.join(old)
            } else {
                root.path()
                    .join("samples/test=cornering/tire=T/rim_in=7")
                    .join(old)
                    .join("ia_cdeg_nom=0/fz_n_nom=1112")
            };
            let mut df = df!("fz_n" => [1000.0]).unwrap();
            write_parquet_atomic(&dir.join("a_dat-111111111111.parquet"), &mut df).unwrap();
            let err = run(root.path(), "SELECT 1").unwrap_err().to_string();
            assert!(
                err.contains(old) && err.contains("tirebase ingest --store"),
                "{err}"
            );
            let err = tables::live_segments(root.path()).unwrap_err();
            assert!(matches!(err, StoreError::OldLayout { .. }), "{err}");
        }
    }

    #[test]
    fn not_a_store_is_a_clear_error() {
        let root = tempfile::tempdir().unwrap();
        let err = run(root.path(), "SELECT 1").unwrap_err().to_string();
        assert!(err.contains("not a tirebase store"), "{err}");
    }

    #[test]
    fn table_format_aligns_columns() {
        let df = df!("a" => [1.5, 22.0], "name" => ["x", "yy"]).unwrap();
        let text = format_table(&df);
        assert_eq!(text.lines().count(), 4);
        assert!(text.starts_with("a          name\n"), "{text}");
    }
}
