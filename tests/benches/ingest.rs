//! Ingest throughput (issue 4 benchmark): `.dat` -> store, against polars merely reading the same
//! file as CSV, in the same process and the same build.
//!
//! In: `.dat` files given as arguments, else the `.dat` files of a demo virtual round written by
//! `tirebase synth round` into a temp dir (never real TTC data). Out, per file and in total on
//! stdout: MB/s (1 MB = 10^6 bytes of raw file) of
//! - `ingest`: `tirebase::ingest::run` on that one file into a fresh (empty) store: lock, stat,
//!   SHA-256, parse, unit conversion and ISO-W frame, segmentation, Parquet write of samples and
//!   segments (Snappy), `syncfs`, runs table commit (the store's removal afterwards is not
//!   timed);
//! - `parse`: `tirebase_core::ttc::read_run` alone (parse + convert);
//! - `polars_csv`: polars' CSV reader reading the file into a DataFrame (tab separator, line 1
//!   skipped, names from line 2, the units line skipped, every column parsed as f64 by a given
//!   schema, so no type inference);
//!
//! and the ratio ingest / polars_csv (target >= 1.0); then all files as one ingest call (files
//! in parallel, as a round is ingested) against polars reading them in turn. Each figure is the
//! median of `REPS`
//! (env `TIREBASE_BENCH_REPS`, default 5) timed runs after one warm-up, interleaved.
//!
//! Run: `cargo bench --profile dev --bench ingest` (the numeric core is optimised even in dev;
//! polars is not, which slows both polars_csv and our Parquet writing) or, for release figures,
//! `cargo bench --bench ingest`. Deliberately not a criterion bench: the point is the ratio of
//! two measurements of the same file, which criterion does not report.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use polars::prelude::*;
use tirebase::ingest::{self, IngestOptions};
use tirebase::progress::Silent;
use tirebase::store::lock::LockWait;
use tirebase_core::numerics::stats::median_high;
use tirebase_core::segment::SegmentConfig;

/// Seconds of one call.
fn time(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

/// The median of one timing's repetitions (the upper one of an even count).
fn median(mut v: Vec<f64>) -> f64 {
    median_high(&mut v).unwrap_or(f64::NAN)
}

/// Seconds of a full ingest of one file into a fresh store below `scratch`.
fn ingest_once(file: &Path, scratch: &Path, segment: &SegmentConfig) -> f64 {
    ingest_batch(std::slice::from_ref(&file.to_path_buf()), scratch, segment)
}

/// Seconds of one ingest call over `files` (in parallel, as a round is ingested) into a fresh
/// store. Timed: the call alone. Not timed: creating the empty store directory, and removing
/// the store afterwards plus a `sync`, so the next run's `syncfs` does not flush this run's
/// deletions (neither is part of an ingest).
fn ingest_batch(files: &[PathBuf], scratch: &Path, segment: &SegmentConfig) -> f64 {
    let store = tempfile::tempdir_in(scratch).expect("temp store");
    let opts = IngestOptions {
        store: store.path(),
        catalog: None,
        segment,
        jobs: 0,
        lock_wait: LockWait::Refuse,
        rehash: false,
        keep_duplicate_runs: false,
        prune: false,
    };
    let start = Instant::now();
    let report = ingest::run(files, &opts, &Silent).expect("ingest");
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(
        report.count(|s| *s == ingest::FileStatus::Ingested),
        files.len()
    );
    drop(store);
    // SAFETY: `sync` takes no arguments and cannot fail.
    unsafe { libc::sync() };
    seconds
}

fn parse_once(file: &Path) {
    let bytes = std::fs::read(file).expect("read");
    let run = tirebase_core::ttc::read_run(&bytes, &file.display().to_string()).expect("parse");
    assert!(!run.is_empty());
}

/// Every column of a `.dat` as f64, named from line 2 (so polars need not infer types).
fn dat_schema(file: &Path) -> SchemaRef {
    let text = std::fs::read_to_string(file).expect("read");
    let names = text.lines().nth(1).expect("line 2");
    let fields = names
        .split('\t')
        .map(|n| Field::new(n.trim().into(), DataType::Float64));
    Arc::new(Schema::from_iter(fields))
}

fn polars_once(file: &Path, schema: &SchemaRef) {
    let df = CsvReadOptions::default()
        .with_has_header(true)
        .with_skip_rows(1)
        .with_skip_rows_after_header(1)
        .with_schema(Some(schema.clone()))
        .with_parse_options(CsvParseOptions::default().with_separator(b'\t'))
        .try_into_reader_with_file_path(Some(file.to_path_buf()))
        .expect("csv reader")
        .finish()
        .expect("polars csv read");
    assert!(df.height() > 0 && df.width() >= 21);
}

/// The `.dat` files of a demo round written by the binary.
fn demo_round(dir: &Path) -> Vec<PathBuf> {
    let status = Command::new(env!("CARGO_BIN_EXE_tirebase"))
        .args(["synth", "round", "--out"])
        .arg(dir)
        .status()
        .expect("run tirebase synth round");
    assert!(status.success());
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("raw"))
        .expect("raw dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "dat"))
        .collect();
    files.sort();
    files
}

fn main() {
    let reps: usize = std::env::var("TIREBASE_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5)
        .max(1);
    let scratch = tempfile::tempdir().expect("scratch dir");
    // `cargo bench` passes `--bench`; every other argument is a file.
    let given: Vec<PathBuf> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .map(PathBuf::from)
        .collect();
    let files = if given.is_empty() {
        demo_round(&scratch.path().join("round"))
    } else {
        given
    };
    let segment = SegmentConfig::default();
    let profile = if cfg!(debug_assertions) {
        "dev"
    } else {
        "release"
    };
    println!("ingest bench ({profile} profile, median of {reps} runs), MB/s of raw file:");
    println!(
        "{:<24} {:>8} {:>10} {:>10} {:>11} {:>7}",
        "file", "MB", "ingest", "parse", "polars_csv", "ratio"
    );
    let (mut total_mb, mut total) = (0.0, [0.0f64; 3]);
    for file in &files {
        let mb = std::fs::metadata(file).expect("stat").len() as f64 / 1e6;
        let schema = dat_schema(file);
        ingest_once(file, scratch.path(), &segment);
        polars_once(file, &schema);
        let mut t = [Vec::new(), Vec::new(), Vec::new()];
        for _ in 0..reps {
            t[0].push(ingest_once(file, scratch.path(), &segment));
            t[1].push(time(|| parse_once(file)));
            t[2].push(time(|| polars_once(file, &schema)));
        }
        let s = t.map(median);
        println!(
            "{:<24} {:>8.2} {:>10.1} {:>10.1} {:>11.1} {:>6.2}x",
            file.file_name().unwrap_or_default().to_string_lossy(),
            mb,
            mb / s[0],
            mb / s[1],
            mb / s[2],
            s[2] / s[0]
        );
        total_mb += mb;
        for k in 0..3 {
            total[k] += s[k];
        }
    }
    println!(
        "{:<24} {:>8.2} {:>10.1} {:>10.1} {:>11.1} {:>6.2}x",
        "all (file by file)",
        total_mb,
        total_mb / total[0],
        total_mb / total[1],
        total_mb / total[2],
        total[2] / total[0]
    );
    // The same files as one ingest call (files in parallel, fixed per-call costs once), against
    // polars reading them one after the other (each read already uses every core).
    let schemas: Vec<SchemaRef> = files.iter().map(|f| dat_schema(f)).collect();
    let mut t = [Vec::new(), Vec::new()];
    for _ in 0..reps {
        t[0].push(ingest_batch(&files, scratch.path(), &segment));
        t[1].push(time(|| {
            for (f, schema) in files.iter().zip(&schemas) {
                polars_once(f, schema);
            }
        }));
    }
    let s = t.map(median);
    println!(
        "{:<24} {:>8.2} {:>10.1} {:>10} {:>11.1} {:>6.2}x",
        "all (one ingest call)",
        total_mb,
        total_mb / s[0],
        "",
        total_mb / s[1],
        s[1] / s[0]
    );
}
