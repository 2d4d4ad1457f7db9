//! The nightly run is a function of its inputs (issue 20): `tirebase run` twice on one store,
//! with an input changed in between, must end with the version a fresh store builds from the
//! changed inputs (every table equal apart from wall-time columns, same `.tir` files, same group
//! input hashes, same runs/segments/samples in the store).
//!
//! Each test starts from one shared first run of a demo round (copied per test) and changes one
//! input: the catalog (item 1), the `[segment]` configuration (item 2), the set of input files
//! (item 3).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use polars::prelude::*;
use tirebase::manifest::Manifest;
use tirebase::store::tables;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tirebase"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `tirebase run --input INPUT --store STORE [extra]`.
fn run(input: &Path, store: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg("--input")
        .arg(input)
        .arg("--store")
        .arg(store)
        .args(extra)
        .output()
        .unwrap()
}

fn check(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what} failed ({:?}): {}",
        o.status.code(),
        text(&o.stderr)
    );
}

/// Copy a directory tree (files keep their modification times).
fn copy_tree(from: &Path, to: &Path) {
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

/// A demo round (input/) and a store after one run on it (store/), made once per process.
fn baseline() -> &'static Path {
    static BASE: OnceLock<tempfile::TempDir> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let o = bin()
            .args(["synth", "round", "--out"])
            .arg(dir.path().join("input"))
            .output()
            .unwrap();
        check(&o, "synth round");
        check(
            &run(&dir.path().join("input"), &dir.path().join("store"), &[]),
            "first run",
        );
        dir
    })
    .path()
}

/// A private copy of the baseline: (temp dir, input, store).
fn fork() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    copy_tree(baseline(), tmp.path());
    let (input, store) = (tmp.path().join("input"), tmp.path().join("store"));
    (tmp, input, store)
}

fn latest(store: &Path) -> (u32, PathBuf) {
    tirebase::store::versions::latest(store).unwrap().unwrap()
}

/// Columns holding wall time, which no two runs share.
const TIMING_COLUMNS: [&str; 1] = ["seconds"];

fn read_table(path: &Path) -> DataFrame {
    let mut df = tirebase::store::files::read_parquet(path).unwrap();
    for c in TIMING_COLUMNS {
        if df.column(c).is_ok() {
            df.drop_in_place(c).unwrap();
        }
    }
    df
}

fn files_below(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(root).unwrap().display().to_string();
                out.insert(rel, fs::read(&path).unwrap());
            }
        }
    }
    out
}

/// Group records without the version that computed them.
fn groups(m: &Manifest) -> Vec<(String, i64, i64, String, u64)> {
    m.groups
        .iter()
        .map(|g| {
            (
                g.tire.clone(),
                g.rim_in,
                g.pressure_kpa,
                g.input_sha256.clone(),
                g.n_segments,
            )
        })
        .collect()
}

/// The latest version of `store` and its store tables equal what a fresh store builds from the
/// same input and arguments.
fn assert_equals_fresh(input: &Path, store: &Path, extra: &[&str]) {
    let fresh_dir = tempfile::tempdir().unwrap();
    let fresh = fresh_dir.path().join("store");
    check(&run(input, &fresh, extra), "fresh run");
    let ((_, a), (_, b)) = (latest(store), latest(&fresh));
    let (ma, mb) = (Manifest::read(&a).unwrap(), Manifest::read(&b).unwrap());

    assert_eq!(
        groups(&ma),
        groups(&mb),
        "fit groups and their input hashes"
    );
    assert_eq!(ma.tables, mb.tables, "rows per published table");
    assert_eq!(
        ma.counts.segments_by_kind, mb.counts.segments_by_kind,
        "live segments"
    );
    assert_eq!(ma.config, mb.config, "resolved configuration");
    assert_eq!(
        (ma.counts.files, ma.counts.files_ok, ma.counts.tir_files),
        (mb.counts.files, mb.counts.files_ok, mb.counts.tir_files)
    );
    for table in mb.tables.keys() {
        let name = format!("{table}.parquet");
        let (x, y) = (read_table(&a.join(&name)), read_table(&b.join(&name)));
        assert!(
            x.equals_missing(&y),
            "{table} differs from a fresh run:\n{x}\n{y}"
        );
    }
    assert_eq!(
        files_below(&a.join("tir")),
        files_below(&b.join("tir")),
        ".tir files differ from a fresh run"
    );

    // The store itself: runs rows, live segments (typed), live samples (bytes).
    assert_eq!(
        tables::read_runs(store).unwrap(),
        tables::read_runs(&fresh).unwrap(),
        "runs table"
    );
    let segments = |s: &Path| -> Vec<String> {
        let mut v: Vec<String> = tables::live_segments(s)
            .unwrap()
            .iter()
            .map(|r| format!("{r:?}"))
            .collect();
        v.sort();
        v
    };
    assert_eq!(segments(store), segments(&fresh), "live segments");
    let samples = |s: &Path| -> BTreeMap<String, Vec<u8>> {
        tables::live_sample_files(s)
            .unwrap()
            .into_iter()
            .map(|p| {
                let rel = p.strip_prefix(s).unwrap().display().to_string();
                (rel, fs::read(&p).unwrap())
            })
            .collect()
    };
    let (sa, sb) = (samples(store), samples(&fresh));
    assert_eq!(
        sa.keys().collect::<Vec<_>>(),
        sb.keys().collect::<Vec<_>>(),
        "live sample files"
    );
    assert!(sa == sb, "live sample bytes differ");
    // Nothing but live parts is left in the store.
    let parts = |s: &Path| -> Vec<String> {
        let mut v: Vec<String> = files_below(&s.join("samples"))
            .into_keys()
            .chain(files_below(&s.join("segments")).into_keys())
            .collect();
        v.sort();
        v
    };
    assert_eq!(parts(store), parts(&fresh), "part files on disk");
}

/// Item 1: a tire renamed in the catalog reaches the stored runs, segments and samples (by a
/// relabel: no file is parsed again) and the published models.
#[test]
fn issue20_catalog_edit_relabels_the_store_and_the_models() {
    let (_tmp, input, store) = fork();
    let catalog = input.join("catalog.toml");
    let old = "Hoosier 20.5x7.0-13 R25B";
    let new = "Hoosier 20.5x7.0-13 R25B (2024 build)";
    let text_before = fs::read_to_string(&catalog).unwrap();
    assert!(text_before.contains(old));
    fs::write(&catalog, text_before.replace(old, new)).unwrap();

    let second = run(&input, &store, &[]);
    check(&second, "run after the catalog edit");
    let log = text(&second.stderr);
    assert!(log.contains("catalog changed"), "{log}");
    assert!(log.contains("relabelled"), "no relabel: {log}");
    let (n, dir) = latest(&store);
    assert_eq!(n, 2);
    let m = Manifest::read(&dir).unwrap();
    assert!(m.groups.iter().any(|g| g.tire == new), "{:?}", m.groups);
    assert!(m.groups.iter().all(|g| g.tire != old), "{:?}", m.groups);
    assert_eq!(m.counts.files_ingested, 0, "a relabel parses nothing");
    let runs = tables::read_runs(&store).unwrap();
    assert!(runs.values().all(|r| r.tire.as_deref() != Some(old)));
    assert_equals_fresh(&input, &store, &[]);

    // Unchanged since: up to date.
    let third = run(&input, &store, &[]);
    check(&third, "third run");
    assert!(
        text(&third.stderr).contains("up to date"),
        "{}",
        text(&third.stderr)
    );
}

/// Item 2: a `[segment]` change re-segments every file and refits.
#[test]
fn issue20_segment_config_edit_resegments_and_refits() {
    let (tmp, input, store) = fork();
    let cfg = tmp.path().join("segment.toml");
    fs::write(&cfg, "[segment.activity]\nsa_active_deg = 1.5\n").unwrap();
    let cfg_arg = cfg.display().to_string();
    let extra = ["--config", cfg_arg.as_str()];
    let before = Manifest::read(&latest(&store).1).unwrap();

    let second = run(&input, &store, &extra);
    check(&second, "run with the new [segment] config");
    let log = text(&second.stderr);
    assert!(log.contains("config changed"), "{log}");
    assert!(log.contains("re-segmented"), "{log}");
    let after = Manifest::read(&latest(&store).1).unwrap();
    assert_ne!(
        before.counts.segments_by_kind, after.counts.segments_by_kind,
        "the new threshold must change the segmentation of the demo round"
    );
    assert_eq!(after.counts.groups_fitted, after.counts.groups);
    assert_equals_fresh(&input, &store, &extra);
}

/// Item 3: a removed input file leaves the store and every model it fed.
#[test]
fn issue20_removed_input_file_leaves_the_store_and_the_models() {
    let (_tmp, input, store) = fork();
    let gone = input.join("raw/B2410raw5.mat");
    assert!(gone.is_file());
    fs::remove_file(&gone).unwrap();

    let second = run(&input, &store, &[]);
    check(&second, "run without one file");
    let log = text(&second.stderr);
    assert!(log.contains("1 files removed"), "{log}");
    let runs = tables::read_runs(&store).unwrap();
    assert!(!runs.contains_key("B2410raw5.mat"), "{:?}", runs.keys());
    assert!(
        tables::live_segments(&store)
            .unwrap()
            .iter()
            .all(|s| s.source_file != "B2410raw5.mat")
    );
    assert_equals_fresh(&input, &store, &[]);
}
