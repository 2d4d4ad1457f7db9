//! The shared test harness of the integration tests: the `tirebase` binary, output checks, temp
//! directories and the demo round, generated once per test process.
//!
//! In: nothing but the binary under test (`TIREBASE_TEST_BIN` overrides cargo's, for a developer
//! whose shared target directory's `tirebase` may be replaced by another worktree's build
//! mid-test). Out: command outputs and read-only fixtures. The cached fixtures ([`demo_round`],
//! [`demo_published`]) live in temp directories until the process exits; a test that changes
//! them works on a copy ([`copy_tree`]), e.g. with QC flags added to segments of its store
//! ([`flag_segments`]). Deliberately not here: what a test checks.

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use polars::prelude::{
    DataFrame, DataType, IntoLazy, NamedFrom, ParquetReader, SerReader, Series, lit,
};
use tirebase::core::tire_model::SlipInput;

/// The binary under test, as a command to add arguments to.
pub fn bin() -> Command {
    let path = std::env::var_os("TIREBASE_TEST_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_tirebase")));
    Command::new(path)
}

/// `tirebase ARGS...`, run to completion.
pub fn tirebase<S: AsRef<OsStr>>(args: &[S]) -> Output {
    bin().args(args).output().expect("run tirebase")
}

/// Bytes as text (stderr, stdout), invalid UTF-8 replaced.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Assert that `what` exited 0, showing its exit code and stderr otherwise.
pub fn ok(output: &Output, what: &str) {
    assert!(
        output.status.success(),
        "{what} failed ({:?}): {}",
        output.status.code(),
        text(&output.stderr)
    );
}

/// CSV rows (header dropped) of a command's stdout.
pub fn csv_rows(o: &Output) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_reader(o.stdout.as_slice());
    r.records()
        .map(|rec| rec.unwrap().iter().map(str::to_string).collect())
        .collect()
}

/// A path as an argument string (temp paths are UTF-8).
pub fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}

/// `tirebase synth round --out OUT [extra]`, asserted to succeed.
pub fn synth_round(out: &Path, extra: &[&str]) -> Output {
    let o = bin()
        .args(["synth", "round", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("run tirebase");
    ok(&o, "synth round");
    o
}

/// `tirebase ingest RAW --store STORE [--catalog CATALOG]`, asserted to succeed.
pub fn ingest(raw: &Path, store: &Path, catalog: Option<&Path>) -> Output {
    let mut cmd = bin();
    cmd.arg("ingest").arg(raw).arg("--store").arg(store);
    if let Some(catalog) = catalog {
        cmd.arg("--catalog").arg(catalog);
    }
    let o = cmd.output().expect("run tirebase");
    ok(&o, "ingest");
    o
}

/// `tirebase run --input INPUT --store STORE [extra]` (not asserted: exit codes are checked).
pub fn run(input: &Path, store: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg("--input")
        .arg(input)
        .arg("--store")
        .arg(store)
        .args(extra)
        .output()
        .expect("run tirebase")
}

/// The default demo round (`synth round` without flags), generated once per process. Read-only:
/// copy it ([`copy_tree`]) to change it.
pub fn demo_round() -> &'static Path {
    static ROUND: OnceLock<tempfile::TempDir> = OnceLock::new();
    ROUND
        .get_or_init(|| {
            let dir = tempfile::tempdir().expect("temp dir");
            synth_round(dir.path(), &[]);
            dir
        })
        .path()
}

/// Below one temp directory: `input/`, the default demo round, and `store/`, the store after one
/// `tirebase run` on it (first version published). Made once per process; read-only (copy the
/// directory with [`copy_tree`] to run again on it).
pub fn demo_published() -> &'static Path {
    static BASE: OnceLock<tempfile::TempDir> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = tempfile::tempdir().expect("temp dir");
        let (input, store) = (dir.path().join("input"), dir.path().join("store"));
        copy_tree(demo_round(), &input);
        ok(&run(&input, &store, &[]), "first run of the demo round");
        dir
    })
    .path()
}

/// Copy a directory tree; files keep their modification times (the store fingerprints them).
pub fn copy_tree(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for entry in fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&src, &dst);
        } else {
            fs::copy(&src, &dst).unwrap();
            let mtime = fs::metadata(&src).unwrap().modified().unwrap();
            fs::File::options()
                .write(true)
                .open(&dst)
                .unwrap()
                .set_modified(mtime)
                .unwrap();
        }
    }
}

/// Column `col` of `df` as text (cast; null as the empty string).
pub fn strs(df: &DataFrame, col: &str) -> Vec<String> {
    let c = df
        .column(col)
        .unwrap_or_else(|_| panic!("no column {col}"))
        .cast(&DataType::String)
        .unwrap();
    c.str()
        .unwrap()
        .iter()
        .map(|v| v.unwrap_or_default().to_string())
        .collect()
}

/// Column `col` of `df` as numbers (cast; null as NaN).
pub fn f64s(df: &DataFrame, col: &str) -> Vec<f64> {
    let c = df
        .column(col)
        .unwrap_or_else(|_| panic!("no column {col}"))
        .cast(&DataType::Float64)
        .unwrap();
    c.f64()
        .unwrap()
        .iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect()
}

/// Add the QC flag `flag` to the rows of a store's segments table that `hit` picks (given one
/// part file's rows, one bool per row) and clear their `qc_ok`, as a segmenter would for a bad
/// sweep; returns how many rows were flagged. A flag that spoils the forces (or one the fit does
/// not know) keeps those segments out of every force fit.
pub fn flag_segments(store: &Path, flag: &str, hit: impl Fn(&DataFrame) -> Vec<bool>) -> usize {
    let mut flagged = 0;
    for entry in fs::read_dir(store.join("segments")).unwrap() {
        let path = entry.unwrap().path();
        let df = ParquetReader::new(fs::File::open(&path).unwrap())
            .finish()
            .unwrap();
        let hit = hit(&df);
        let n = hit.iter().filter(|h| **h).count();
        if n == 0 {
            continue;
        }
        flagged += n;
        let flags: Vec<String> = strs(&df, "qc_flags")
            .into_iter()
            .zip(&hit)
            .map(|(f, h)| match (*h, f.is_empty()) {
                (false, _) => f,
                (true, true) => flag.to_string(),
                (true, false) => format!("{f},{flag}"),
            })
            .collect();
        let qc_ok: Vec<bool> = df
            .column("qc_ok")
            .unwrap()
            .bool()
            .unwrap()
            .iter()
            .zip(&hit)
            .map(|(q, h)| q.unwrap_or(false) && !*h)
            .collect();
        let mut df = df
            .lazy()
            .with_columns([
                lit(Series::new("qc_flags".into(), flags)).alias("qc_flags"),
                lit(Series::new("qc_ok".into(), qc_ok)).alias("qc_ok"),
            ])
            .collect()
            .unwrap();
        tirebase::store::files::write_parquet_atomic(&path, &mut df).unwrap();
    }
    flagged
}

/// Every file below `root`: its `/`-separated relative path and its path.
pub fn files_below(root: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                out.push((rel, path));
            }
        }
    }
    out
}

/// Every file below `root` with its bytes, keyed by its `/`-separated relative path.
pub fn tree(root: &Path) -> BTreeMap<String, Vec<u8>> {
    files_below(root)
        .into_iter()
        .map(|(rel, path)| (rel, fs::read(&path).unwrap()))
        .collect()
}

/// The `segments` columns [`envelope_points`] reads, in its order, for a query's select list.
pub const ENVELOPE_COLUMNS: &str = "kind, fz_n_nom, ia_cdeg_nom, alpha_deg_nom, alpha_deg_min, \
                                    alpha_deg_max, kappa_min, kappa_max";

/// The `segments` filter of a tested envelope: force-clean cornering, drive/brake and combined
/// segments with a nominal pressure, load and inclination.
pub const ENVELOPE_WHERE: &str = "qc_ok AND kind IN ('cornering', 'drive_brake', 'combined') \
                                  AND pressure_kpa_nom IS NOT NULL AND fz_n_nom IS NOT NULL \
                                  AND ia_cdeg_nom IS NOT NULL";

/// The operating points one tested segment covers, read from a CSV record whose columns
/// [`ENVELOPE_COLUMNS`] start at index `at`: a cornering sweep over its slip-angle range (every
/// 0.25 deg), any other segment over its slip-ratio range (41 points) at its held slip angle, all
/// at its nominal load and inclination.
pub fn envelope_points(r: &csv::StringRecord, at: usize) -> Vec<SlipInput> {
    let num = |i: usize| r[at + i].parse::<f64>().unwrap_or(f64::NAN);
    let (fz, gamma) = (num(1), (num(2) / 100.0).to_radians());
    let mut points = Vec::new();
    if &r[at] == "cornering" {
        let (lo, hi) = (num(4), num(5));
        let n = ((hi - lo) / 0.25).ceil().max(1.0) as usize;
        for k in 0..=n {
            points.push(SlipInput {
                fz_n: fz,
                kappa: 0.0,
                alpha_rad: (lo + (hi - lo) * k as f64 / n as f64).to_radians(),
                gamma_rad: gamma,
                vx_mps: 0.0,
            });
        }
    } else {
        let alpha = num(3);
        let alpha = if alpha.is_finite() { alpha } else { 0.0 };
        let (lo, hi) = (num(6), num(7));
        for k in 0..=40 {
            points.push(SlipInput {
                fz_n: fz,
                kappa: lo + (hi - lo) * k as f64 / 40.0,
                alpha_rad: alpha.to_radians(),
                gamma_rad: gamma,
                vx_mps: 0.0,
            });
        }
    }
    points
}
