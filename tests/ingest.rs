//! `tirebase ingest` end to end (issue 4, "Done when"): the real binary ingests into temp stores.
//!
//! In: the malformed corpus `tests/fixtures/bad/` (its README table says what each file must
//! give), the small valid fixtures `tests/fixtures/ttc/`, and a demo virtual round written by
//! `tirebase synth round`. Checked: exit codes (0, 1 when some file failed, 2 on usage errors),
//! one stderr line per bad file naming it and its line/element, the runs table, QC flags,
//! idempotent and incremental re-ingest (same bytes, only a changed file's parts replaced), a failed
//! re-ingest keeping the stored version, the cheap size/mtime up-to-date check and `--rehash`, and
//! a hive-partitioned read-back of STORE/samples with polars. Deliberately not here: reader and
//! segmentation details (unit tests in `tirebase_core::ttc` and `tirebase_core::segment`).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::SystemTime;

use polars::prelude::*;

use crate::harness::{bin, demo_round, files_below, tirebase};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn ingest(store: &Path, inputs: &[&Path], extra: &[&str]) -> Output {
    let mut cmd = bin();
    cmd.arg("ingest").args(inputs).arg("--store").arg(store);
    cmd.args(extra).output().expect("run tirebase ingest")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Rows of `tirebase query --format csv`, as column -> text maps.
fn query(store: &Path, sql: &str) -> Vec<BTreeMap<String, String>> {
    let out = bin()
        .args(["query", "--format", "csv", sql, "--store"])
        .arg(store)
        .output()
        .expect("run tirebase");
    assert!(out.status.success(), "query {sql:?}: {}", stderr(&out));
    let mut reader = csv::Reader::from_reader(out.stdout.as_slice());
    let header: Vec<String> = reader
        .headers()
        .unwrap()
        .iter()
        .map(str::to_string)
        .collect();
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            header
                .iter()
                .cloned()
                .zip(r.iter().map(str::to_string))
                .collect()
        })
        .collect()
}

/// Every file below `root` (except the lock file, which every command touches) with its bytes
/// and modification time.
fn tree(root: &Path) -> BTreeMap<String, (Vec<u8>, SystemTime)> {
    files_below(root)
        .into_iter()
        .filter(|(_, path)| path.file_name().is_some_and(|n| n != "store.lock"))
        .map(|(rel, path)| {
            let mtime = fs::metadata(&path).unwrap().modified().unwrap();
            (rel, (fs::read(&path).unwrap(), mtime))
        })
        .collect()
}

/// One row of `tests/fixtures/bad/README.md`.
struct CorpusCase {
    file: String,
    outcome: String,
    /// error: message substring; qc: the flag in `segments.qc_flags`; warning: warning text.
    expected: String,
}

fn corpus_cases() -> Vec<CorpusCase> {
    let readme = fs::read_to_string(repo().join("tests/fixtures/bad/README.md")).unwrap();
    readme
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|line| {
            let cells: Vec<&str> = line.trim_matches('|').split(" | ").map(str::trim).collect();
            let last = cells[2];
            // qc rows describe the defect and end with the flag in backticks.
            let expected = match last.rfind(": `") {
                Some(at) if cells[1] == "qc" => &last[at + 2..],
                _ => last,
            };
            CorpusCase {
                file: cells[0].trim_matches('`').to_string(),
                outcome: cells[1].to_string(),
                expected: expected.trim_matches('`').to_string(),
            }
        })
        .collect()
}

/// stderr lines that name `file` (as a path component followed by `:`).
fn lines_naming<'a>(stderr: &'a str, file: &str) -> Vec<&'a str> {
    stderr
        .lines()
        .filter(|l| l.contains(&format!(" {file}:")) || l.contains(&format!("/{file}:")))
        .collect()
}

const GOOD_DAT: &str = "tests/fixtures/ttc/example_A1965run51.dat";
const GOOD_MAT: &str = "tests/fixtures/ttc/example_B1320run16_compressed.mat";

#[test]
fn bad_corpus_with_good_files_one_line_per_bad_file_exit_1_rest_stored() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let bad = repo().join("tests/fixtures/bad");
    let (good_dat, good_mat) = (repo().join(GOOD_DAT), repo().join(GOOD_MAT));
    // The corpus files are variants of one run (project 1965, run 51): each is kept to be
    // checked on its own.
    let out = ingest(
        &store,
        &[&bad, &good_dat, &good_mat],
        &["--jobs", "2", "--keep-duplicate-runs"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");

    let cases = corpus_cases();
    assert!(cases.len() >= 20, "corpus has {} rows", cases.len());
    let errors = cases.iter().filter(|c| c.outcome == "error").count();
    assert_eq!(
        err.lines().filter(|l| l.starts_with("failed: ")).count(),
        errors,
        "{err}"
    );
    let runs: BTreeMap<String, BTreeMap<String, String>> = query(&store, "SELECT * FROM runs")
        .into_iter()
        .map(|r| (r["source_file"].clone(), r))
        .collect();
    assert_eq!(runs.len(), cases.len() + 2, "{:?}", runs.keys());
    let segments = query(&store, "SELECT source_file, qc_flags FROM segments");
    for case in &cases {
        let named = lines_naming(&err, &case.file);
        let row = &runs[&case.file];
        match case.outcome.as_str() {
            "error" => {
                assert_eq!(named.len(), 1, "{}: {named:?}", case.file);
                assert!(
                    named[0].contains(&case.expected),
                    "{}: {:?} lacks {:?}",
                    case.file,
                    named[0],
                    case.expected
                );
                assert_eq!(row["status"], "failed", "{}", case.file);
                assert!(row["error"].contains(&case.expected), "{row:?}");
                assert_eq!(row["data_sha256"], "", "{}: no stored version", case.file);
                assert_eq!(row["rows"], "0", "{}", case.file);
            }
            "warning" => {
                // Issue 20: a file whose rows stop early is stored but flagged (never plain
                // "ok") and said on stderr, once.
                let partial: Vec<_> = named
                    .iter()
                    .filter(|l| !l.starts_with("warning: "))
                    .collect();
                assert_eq!(partial.len(), 1, "{}: {named:?}", case.file);
                assert!(partial[0].starts_with("partial: "), "{named:?}");
                assert!(partial[0].contains(&case.expected), "{named:?}");
                assert_eq!(row["status"], "partial", "{row:?}");
                assert!(row["error"].contains(&case.expected), "{row:?}");
                assert!(row["warnings"].contains(&case.expected), "{row:?}");
            }
            "qc" => {
                // Stored; its reader and segmentation warnings (if any) are said on stderr.
                assert!(
                    named.iter().all(|l| l.starts_with("warning: ")),
                    "{}: {named:?}",
                    case.file
                );
                assert_eq!(row["status"], "ok", "{row:?}");
                assert_eq!(row["error"], "", "{row:?}");
                let flags: Vec<&str> = segments
                    .iter()
                    .filter(|s| s["source_file"] == case.file)
                    .flat_map(|s| s["qc_flags"].split(','))
                    .collect();
                assert!(
                    flags.contains(&case.expected.as_str()),
                    "{}: qc flags {flags:?} lack {:?}",
                    case.file,
                    case.expected
                );
            }
            other => panic!("{}: unknown outcome {other}", case.file),
        }
    }

    let stored: BTreeMap<String, i64> = query(
        &store,
        "SELECT source_file, COUNT(*) AS n FROM samples GROUP BY source_file",
    )
    .into_iter()
    .map(|r| (r["source_file"].clone(), r["n"].parse().unwrap()))
    .collect();
    for good in [&good_dat, &good_mat] {
        let name = good.file_name().unwrap().to_str().unwrap();
        let row = &runs[name];
        assert_eq!(row["status"], "ok", "{row:?}");
        let rows: i64 = row["rows"].parse().unwrap();
        assert!(rows >= 10, "{row:?}");
        assert_eq!(stored.get(name), Some(&rows), "{name}: samples {stored:?}");
        assert!(segments.iter().any(|s| s["source_file"] == name), "{name}");
    }
    // Every ok file's samples are stored, every failed file has none.
    for (name, row) in &runs {
        let stored_data = row["status"] == "ok" || row["status"] == "partial";
        let expected = stored_data.then(|| row["rows"].parse::<i64>().unwrap());
        assert_eq!(stored.get(name).copied(), expected, "{name}");
    }
}

/// Copy the valid fixtures into `dir`.
fn good_raw(dir: &Path) -> Vec<PathBuf> {
    fs::create_dir_all(dir).unwrap();
    [
        GOOD_DAT,
        GOOD_MAT,
        "tests/fixtures/ttc/example_B1320run15.mat",
    ]
    .iter()
    .map(|f| {
        let to = dir.join(Path::new(f).file_name().unwrap());
        fs::copy(repo().join(f), &to).unwrap();
        to
    })
    .collect()
}

fn summary_line(out: &Output) -> String {
    let err = stderr(out);
    err.lines()
        .rev()
        .find(|l| l.contains(" files: "))
        .unwrap_or_else(|| panic!("no summary in {err}"))
        .to_string()
}

/// Store files that belong to the source file `stem` (its parts are `<stem>_<ext>-<sha12>`).
fn parts_of(tree: &BTreeMap<String, (Vec<u8>, SystemTime)>, stem: &str) -> Vec<String> {
    tree.keys()
        .filter(|k| k.rsplit('/').next().unwrap().starts_with(stem))
        .cloned()
        .collect()
}

#[test]
fn reingest_unchanged_writes_nothing_and_a_changed_file_replaces_only_its_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    let files = good_raw(&raw);
    let first = ingest(&store, &[&raw], &[]);
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    let before = tree(&store);

    // Unchanged: nothing written (same files, same bytes, same modification times).
    for extra in [&[][..], &["--rehash"][..]] {
        let again = ingest(&store, &[&raw], extra);
        assert_eq!(again.status.code(), Some(0), "{}", stderr(&again));
        assert!(
            summary_line(&again).contains("0 ingested, 3 unchanged, 0 failed"),
            "{extra:?}: {}",
            summary_line(&again)
        );
        assert!(tree(&store) == before, "{extra:?}: the store changed");
    }

    // Change one file: only its parts are replaced.
    let dat = &files[0];
    let text = fs::read_to_string(dat).unwrap();
    let changed = text.replacen("\t370.00\t", "\t371.00\t", 1);
    assert_ne!(changed, text);
    fs::write(dat, changed).unwrap();
    let third = ingest(&store, &[&raw], &[]);
    assert_eq!(third.status.code(), Some(0), "{}", stderr(&third));
    assert!(
        summary_line(&third).contains("1 ingested, 2 unchanged"),
        "{}",
        summary_line(&third)
    );
    let after = tree(&store);
    let stem = "example_A1965run51_dat-";
    let (old, new) = (parts_of(&before, stem), parts_of(&after, stem));
    assert!(!old.is_empty() && !new.is_empty());
    for part in &old {
        assert!(!after.contains_key(part), "old part {part} still there");
    }
    for part in &new {
        assert!(!before.contains_key(part), "{part} was not rewritten");
    }
    for (path, content) in &before {
        if path.starts_with("runs/") || old.contains(path) {
            continue;
        }
        assert!(after.get(path) == Some(content), "{path} was touched");
    }
    let shas = query(
        &store,
        "SELECT DISTINCT source_sha256 FROM samples WHERE source_file = 'example_A1965run51.dat'",
    );
    let runs = query(
        &store,
        "SELECT sha256, data_sha256 FROM runs WHERE source_file = 'example_A1965run51.dat'",
    );
    assert_eq!(shas.len(), 1, "{shas:?}");
    assert_eq!(shas[0]["source_sha256"], runs[0]["data_sha256"]);
    assert_eq!(runs[0]["sha256"], runs[0]["data_sha256"]);

    // Only the modification time changes: hashed again, found unchanged, no data rewritten.
    let f = fs::File::options().write(true).open(&files[1]).unwrap();
    f.set_modified(SystemTime::now()).unwrap();
    drop(f);
    let touched = ingest(&store, &[&raw], &[]);
    assert!(
        summary_line(&touched).contains("0 ingested, 3 unchanged"),
        "{}",
        summary_line(&touched)
    );
    let last = tree(&store);
    for (path, content) in &after {
        if !path.starts_with("runs/") {
            assert!(last.get(path) == Some(content), "{path} was touched");
        }
    }
}

#[test]
fn store_bytes_do_not_depend_on_the_thread_count() {
    let tmp = tempfile::tempdir().unwrap();
    let raw = tmp.path().join("raw");
    good_raw(&raw);
    for qc in ["qc_zeroed_fy.dat", "qc_duplicated_et.dat"] {
        fs::copy(repo().join("tests/fixtures/bad").join(qc), raw.join(qc)).unwrap();
    }
    let stores: Vec<PathBuf> = ["1", "3"]
        .iter()
        .map(|jobs| {
            let store = tmp.path().join(format!("store-{jobs}"));
            let out = ingest(&store, &[&raw], &["--jobs", jobs, "--keep-duplicate-runs"]);
            assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
            store
        })
        .collect();
    let bytes = |store: &Path| -> BTreeMap<String, Vec<u8>> {
        tree(store).into_iter().map(|(k, (b, _))| (k, b)).collect()
    };
    let (a, b) = (bytes(&stores[0]), bytes(&stores[1]));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, content) in &a {
        assert!(
            content == &b[name],
            "{name} differs between --jobs 1 and --jobs 3"
        );
    }
}

/// The same run in several files (the consortium ships `.dat` and `.mat`, US and SI): stored
/// once; the others are `duplicate` (not a failure), keep no rows, and stay so on a re-ingest.
#[test]
fn the_same_run_in_several_files_is_stored_once() {
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    good_raw(&raw);
    // A copy of the US-customary .dat under a later name.
    fs::copy(
        raw.join("example_A1965run51.dat"),
        raw.join("example_A1965run51_copy.dat"),
    )
    .unwrap();
    let first = ingest(&store, &[&raw], &[]);
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    assert!(
        summary_line(&first).contains("3 ingested, 0 unchanged, 0 failed, 1 duplicate runs"),
        "{}",
        summary_line(&first)
    );
    let status = |store: &Path| -> BTreeMap<String, (String, String)> {
        query(store, "SELECT source_file, status, error FROM runs")
            .into_iter()
            .map(|r| {
                (
                    r["source_file"].clone(),
                    (r["status"].clone(), r["error"].clone()),
                )
            })
            .collect()
    };
    let samples = |store: &Path| -> BTreeMap<String, String> {
        query(
            store,
            "SELECT source_file, COUNT(*) AS n FROM samples GROUP BY source_file",
        )
        .into_iter()
        .map(|r| (r["source_file"].clone(), r["n"].clone()))
        .collect()
    };
    let s = status(&store);
    assert_eq!(s["example_A1965run51.dat"].0, "ok");
    let (st, why) = &s["example_A1965run51_copy.dat"];
    assert_eq!(st, "duplicate");
    assert!(
        why.contains("same run as example_A1965run51.dat (project 1965, run 51)"),
        "{why}"
    );
    let n = samples(&store);
    assert!(!n.contains_key("example_A1965run51_copy.dat"), "{n:?}");
    assert!(n.contains_key("example_A1965run51.dat"), "{n:?}");

    // Re-ingest: nothing changes, the copy stays a duplicate.
    let before = tree(&store);
    let again = ingest(&store, &[&raw], &[]);
    assert_eq!(again.status.code(), Some(0), "{}", stderr(&again));
    assert!(
        summary_line(&again).contains("0 ingested, 3 unchanged, 0 failed, 1 duplicate runs"),
        "{}",
        summary_line(&again)
    );
    assert!(tree(&store) == before, "the store changed");
}

#[test]
fn failed_reingest_of_a_good_file_keeps_its_stored_rows_and_lists_the_failure() {
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    let files = good_raw(&raw);
    let dat = &files[0];
    let good_bytes = fs::read(dat).unwrap();
    let first = ingest(&store, &[&raw], &[]);
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    let sql_runs = "SELECT * FROM runs WHERE source_file = 'example_A1965run51.dat'";
    let good_row = query(&store, sql_runs).remove(0);
    let count_sql =
        "SELECT COUNT(*) AS n FROM samples WHERE source_file = 'example_A1965run51.dat'";
    let good_count = query(&store, count_sql).remove(0)["n"].clone();
    let data_before: BTreeMap<_, _> = tree(&store)
        .into_iter()
        .filter(|(k, _)| !k.starts_with("runs/"))
        .collect();

    fs::copy(repo().join("tests/fixtures/bad/nan_cell.dat"), dat).unwrap();
    let second = ingest(&store, &[&raw], &[]);
    let err = stderr(&second);
    assert_eq!(second.status.code(), Some(1), "{err}");
    let named = lines_naming(&err, "example_A1965run51.dat");
    assert_eq!(named.len(), 1, "{err}");
    assert!(named[0].contains("line 8, column 11 (FZ)"), "{err}");

    let row = query(&store, sql_runs).remove(0);
    assert_eq!(row["status"], "failed");
    assert!(row["error"].contains("non-finite value"), "{row:?}");
    assert_ne!(
        row["sha256"], good_row["sha256"],
        "sha256 is the failed content's"
    );
    assert_eq!(
        row["data_sha256"], good_row["sha256"],
        "stored version kept"
    );
    assert_eq!(row["rows"], good_row["rows"]);
    assert_eq!(query(&store, count_sql).remove(0)["n"], good_count);
    let data_after: BTreeMap<_, _> = tree(&store)
        .into_iter()
        .filter(|(k, _)| !k.starts_with("runs/"))
        .collect();
    assert!(data_after == data_before, "samples/segments changed");

    // Repairing the file brings the row back to ok.
    fs::write(dat, &good_bytes).unwrap();
    let third = ingest(&store, &[&raw], &[]);
    assert_eq!(third.status.code(), Some(0), "{}", stderr(&third));
    let row = query(&store, sql_runs).remove(0);
    assert_eq!(row["status"], "ok");
    assert_eq!(row["error"], "");
    assert_eq!(row["sha256"], good_row["sha256"]);
}

#[test]
fn unchanged_size_and_mtime_skip_hashing_and_rehash_forces_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    let files = good_raw(&raw);
    let dat = &files[0];
    assert_eq!(ingest(&store, &[&raw], &[]).status.code(), Some(0));
    let runs = query(
        &store,
        "SELECT size_bytes, mtime_ns FROM runs WHERE source_file = 'example_A1965run51.dat'",
    );
    let size = fs::metadata(dat).unwrap().len();
    assert_eq!(runs[0]["size_bytes"], size.to_string());
    assert!(runs[0]["mtime_ns"].parse::<i64>().unwrap() > 0, "{runs:?}");

    // Same size, same mtime, different content: taken as unchanged without reading...
    let mtime = fs::metadata(dat).unwrap().modified().unwrap();
    let text = fs::read_to_string(dat).unwrap();
    let edited = text.replacen("\t370.00\t", "\t371.00\t", 1);
    assert_eq!(edited.len(), text.len());
    fs::write(dat, edited).unwrap();
    let f = fs::File::options().write(true).open(dat).unwrap();
    f.set_modified(mtime).unwrap();
    drop(f);
    let quick = ingest(&store, &[&raw], &[]);
    assert!(
        summary_line(&quick).contains("0 ingested, 3 unchanged"),
        "{}",
        summary_line(&quick)
    );
    // ...and --rehash finds the change.
    let full = ingest(&store, &[&raw], &["--rehash"]);
    assert_eq!(full.status.code(), Some(0), "{}", stderr(&full));
    assert!(
        summary_line(&full).contains("1 ingested, 2 unchanged"),
        "{}",
        summary_line(&full)
    );
}

#[test]
fn usage_errors_exit_2_and_create_no_store() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let good = repo().join(GOOD_DAT);
    let missing = tmp.path().join("no-such-dir");
    let cases: Vec<(&str, Output)> = vec![
        ("missing path", ingest(&store, &[&good, &missing], &[])),
        ("unknown flag", ingest(&store, &[&good], &["--bogus"])),
        ("bad --jobs", ingest(&store, &[&good], &["--jobs", "many"])),
        ("no --store", tirebase(&[Path::new("ingest"), &good])),
        (
            "no path",
            tirebase(&[Path::new("ingest"), Path::new("--store"), &store]),
        ),
        (
            "missing catalog",
            ingest(&store, &[&good], &["--catalog", "/no/such/catalog.toml"]),
        ),
    ];
    for (what, out) in cases {
        assert_eq!(out.status.code(), Some(2), "{what}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(!err.trim().is_empty(), "{what}: silent");
        assert!(!store.join("runs").exists(), "{what}: wrote a store");
    }
    let err = stderr(&ingest(&store, &[&good, &missing], &[]));
    assert!(
        err.contains("no-such-dir: no such file or directory"),
        "{err}"
    );
}

/// The lazily scanned samples table of a store, hive partitions parsed from the directories.
fn scan_samples(store: &Path) -> LazyFrame {
    let args = ScanArgsParquet {
        hive_options: HiveOptions::new_enabled(),
        ..Default::default()
    };
    let root = format!("{}/", store.join("samples").display());
    LazyFrame::scan_parquet(PlRefPath::new(root), args).expect("scan samples")
}

#[test]
fn store_reads_back_with_polars_hive_partitioning_in_si_iso_w() {
    let round = demo_round();
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    // A2410run1: round-4 style, US customary, 50 Hz, cornering with 250 lb (1112 N) steps.
    let dat = round.join("raw/A2410run1.dat");
    let catalog = round.join("catalog.toml");
    let out = ingest(&store, &[&dat], &["--catalog", catalog.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));

    let df = scan_samples(&store).collect().unwrap();
    let names: Vec<&str> = df.get_column_names().iter().map(|s| s.as_str()).collect();
    for required in [
        "test",
        "tire",
        "rim_in",
        "pressure_kpa_nom",
        "ia_cdeg_nom",
        "fz_n_nom",
        "segment_id",
        "source_file",
        "source_sha256",
        "run",
        "sample_index",
        "et_s",
        "fx_n",
        "fy_n",
        "fz_n",
        "mx_nm",
        "mz_nm",
        "alpha_rad",
        "kappa",
        "gamma_rad",
        "pressure_kpa",
        "speed_kph",
    ] {
        assert!(
            names.contains(&required),
            "{required} missing from {names:?}"
        );
    }
    for int_key in ["rim_in", "pressure_kpa_nom", "ia_cdeg_nom", "fz_n_nom"] {
        assert!(
            df.column(int_key).unwrap().dtype().is_integer(),
            "{int_key}: {:?}",
            df.column(int_key).unwrap().dtype()
        );
    }
    let rows: i64 = query(&store, "SELECT rows FROM runs").remove(0)["rows"]
        .parse()
        .unwrap();
    assert_eq!(df.height() as i64, rows, "every sample in some partition");
    let tires = df.column("tire").unwrap().unique().unwrap();
    assert_eq!(tires.len(), 1);
    assert_eq!(
        tires.str().unwrap().get(0),
        Some("Hoosier 20.5x7.0-13 R25B"),
        "hive value percent-decoded"
    );

    // The 250 lb cornering sweeps: measured Fz (ISO-W, positive) ~1112 N in the nominal partition.
    let stats = scan_samples(&store)
        .filter(
            col("test")
                .eq(lit("cornering"))
                .and(col("fz_n_nom").eq(lit(1112))),
        )
        .select([
            len().alias("n"),
            col("fz_n").mean().alias("fz_mean"),
            col("fz_n").min().alias("fz_min"),
            col("pressure_kpa").mean().alias("p_mean"),
            col("pressure_kpa_nom").first().alias("p_nom"),
            col("speed_kph").mean().alias("v_mean"),
            col("alpha_rad").min().alias("alpha_min"),
            col("alpha_rad").max().alias("alpha_max"),
            col("rim_in").first().alias("rim_in"),
        ])
        .collect()
        .unwrap();
    let get = |name: &str| -> f64 {
        let c = stats
            .column(name)
            .unwrap()
            .cast(&DataType::Float64)
            .unwrap();
        c.f64().unwrap().get(0).unwrap()
    };
    assert!(get("n") > 1000.0, "{stats}");
    assert!((get("fz_mean") - 1112.06).abs() < 15.0, "{stats}");
    assert!(get("fz_min") > 0.0, "Fz > 0 in ISO-W: {stats}");
    assert!((get("p_mean") - get("p_nom")).abs() < 3.0, "{stats}");
    assert!((get("p_nom") - 83.0).abs() < 0.5, "12 psi: {stats}");
    assert!((get("v_mean") - 40.2).abs() < 2.0, "25 mph: {stats}");
    assert!(
        get("alpha_min") < -0.15 && get("alpha_max") > 0.15,
        "{stats}"
    );
    assert!((get("rim_in") - 7.0).abs() < 0.5, "{stats}");

    // Inclination: each IA partition's measured gamma sits at its nominal level.
    let ia = scan_samples(&store)
        .filter(col("test").eq(lit("cornering")))
        .filter(col("ia_cdeg_nom").is_not_null())
        .group_by([col("ia_cdeg_nom")])
        .agg([col("gamma_rad").mean().alias("gamma_mean")])
        .collect()
        .unwrap();
    assert!(ia.height() >= 3, "{ia}");
    let nominal = ia
        .column("ia_cdeg_nom")
        .unwrap()
        .cast(&DataType::Float64)
        .unwrap();
    let measured = ia.column("gamma_mean").unwrap();
    for (n, m) in nominal
        .f64()
        .unwrap()
        .iter()
        .zip(measured.f64().unwrap().iter())
    {
        let (n, m) = (n.unwrap() / 100.0, m.unwrap().to_degrees());
        // The label is the level's measured centre rounded to 0.1 deg.
        assert!((n - m).abs() < 0.06, "IA {n} deg measured {m} deg: {ia}");
    }
}

/// Issue 20 item 10: a copy of a run that holds other data (fewer rows, another time range) is
/// still stored once, but the disagreement is said on stderr and kept in the copy's warnings.
#[test]
fn issue20_copies_of_one_run_that_disagree_are_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    good_raw(&raw);
    let text = fs::read_to_string(raw.join("example_A1965run51.dat")).unwrap();
    // Header (3 lines) and the first 6 of its 12 data rows, cut at a line end.
    let short: Vec<&str> = text.lines().take(9).collect();
    fs::write(
        raw.join("example_A1965run51_copy.dat"),
        format!("{}\n", short.join("\n")),
    )
    .unwrap();
    let out = ingest(&store, &[&raw], &[]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let named = lines_naming(&err, "example_A1965run51_copy.dat");
    assert_eq!(named.len(), 1, "{err}");
    assert!(
        named[0].starts_with("warning: ")
            && named[0].contains("copies of project 1965, run 51 disagree")
            && named[0].contains("example_A1965run51.dat has 12 rows over ET 0.000..0.110 s")
            && named[0].contains("example_A1965run51_copy.dat has 6 rows over ET 0.000..0.050 s"),
        "{named:?}"
    );
    let rows = query(
        &store,
        "SELECT status, warnings FROM runs WHERE source_file = 'example_A1965run51_copy.dat'",
    );
    assert_eq!(rows[0]["status"], "duplicate");
    assert!(rows[0]["warnings"].contains("disagree"), "{rows:?}");
    // An agreeing copy (the same bytes under another name) is no news.
    fs::remove_file(raw.join("example_A1965run51_copy.dat")).unwrap();
    fs::copy(
        raw.join("example_A1965run51.dat"),
        raw.join("example_A1965run51_same.dat"),
    )
    .unwrap();
    let out = ingest(&store, &[&raw], &[]);
    assert!(
        !stderr(&out).contains("disagree") || stderr(&out).contains("_copy.dat"),
        "{}",
        stderr(&out)
    );
    assert!(lines_naming(&stderr(&out), "example_A1965run51_same.dat").is_empty());
}

/// Issue 17: a run whose file names no tire (an R4 header) and has no catalog entry is stored as
/// an unknown tire named after the file; a later catalog entry for its project and run re-labels
/// the stored runs, segments and samples rows without parsing the file again.
#[test]
fn issue17_an_unknown_tire_is_relabelled_by_a_later_catalog_entry() {
    let round = demo_round();
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    fs::create_dir_all(&raw).unwrap();
    fs::copy(round.join("raw/A2410run1.dat"), raw.join("A2410run1.dat")).unwrap();
    let first = ingest(&store, &[&raw], &[]);
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    let runs = query(&store, "SELECT tire, rim_in, tire_source FROM runs");
    assert_eq!(runs.len(), 1, "{runs:?}");
    assert_eq!(
        (
            runs[0]["tire"].as_str(),
            runs[0]["rim_in"].as_str(),
            runs[0]["tire_source"].as_str()
        ),
        ("unknown (A2410run1)", "", "unknown")
    );
    let count = |table: &str, tire: &str| -> usize {
        query(
            &store,
            &format!("SELECT count(*) AS n FROM {table} WHERE tire = '{tire}'"),
        )[0]["n"]
            .parse()
            .unwrap()
    };
    let (segments, samples) = (
        count("segments", "unknown (A2410run1)"),
        count("samples", "unknown (A2410run1)"),
    );
    assert!(segments > 10 && samples > 1000, "{segments} {samples}");

    let catalog = tmp.path().join("catalog.toml");
    fs::write(
        &catalog,
        "[[run]]\nproject = 2410\nrun = 1\ntire = \"Test 20.5x7.0-13\"\nrim_in = 7\n",
    )
    .unwrap();
    let second = ingest(&store, &[&raw], &["--catalog", catalog.to_str().unwrap()]);
    assert_eq!(second.status.code(), Some(0), "{}", stderr(&second));
    let summary = summary_line(&second);
    assert!(
        summary.contains("0 ingested") && summary.contains("1 relabelled"),
        "{summary}"
    );
    let runs = query(&store, "SELECT tire, rim_in, tire_source FROM runs");
    assert_eq!(
        (
            runs[0]["tire"].as_str(),
            runs[0]["rim_in"].as_str(),
            runs[0]["tire_source"].as_str()
        ),
        ("Test 20.5x7.0-13", "7", "catalog")
    );
    assert_eq!(count("segments", "Test 20.5x7.0-13"), segments);
    assert_eq!(count("samples", "Test 20.5x7.0-13"), samples);
    assert_eq!(count("segments", "unknown (A2410run1)"), 0);
}

/// A file whose name and header name no tire (renamed off the Calspan pattern, as the real
/// `drivebrake.mat`) is warned about with the catalog entry that names it; an entry keyed by the
/// file name relabels it, and the warning goes. Fitted before that, its `.tir` says the rim is
/// unknown rather than 0 in.
#[test]
fn an_unnamed_file_is_warned_about_and_a_file_keyed_catalog_entry_names_it() {
    let round = demo_round();
    let tmp = tempfile::tempdir().unwrap();
    let (raw, store) = (tmp.path().join("raw"), tmp.path().join("store"));
    fs::create_dir_all(&raw).unwrap();
    fs::copy(round.join("raw/A2410run1.dat"), raw.join("drivebrake.dat")).unwrap();
    let first = ingest(&store, &[&raw], &[]);
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    let warned = lines_naming(&stderr(&first), "drivebrake.dat").join("\n");
    assert!(
        warned.contains("tire and rim unknown")
            && warned.contains("file = \"drivebrake.dat\" (or project = 2410, run = 1)"),
        "{}",
        stderr(&first)
    );

    let out = tmp.path().join("fit");
    let fit = tirebase(&[
        "fit",
        "--store",
        store.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--stages",
        "pac2002",
    ]);
    let tirs: Vec<PathBuf> = files_below(&out.join("tir"))
        .into_iter()
        .map(|(_, path)| path)
        .collect();
    assert!(!tirs.is_empty(), "{}", stderr(&fit));
    for tir in &tirs {
        let text = fs::read_to_string(tir).unwrap();
        assert!(
            text.contains("on an unknown rim")
                && !text.contains("0 in rim")
                && !text.contains("RIM_WIDTH"),
            "{}: {text}",
            tir.display()
        );
    }

    let catalog = tmp.path().join("catalog.toml");
    fs::write(
        &catalog,
        "[[run]]\nfile = \"drivebrake.dat\"\ntire = \"Test 20.5x7.0-13\"\nrim_in = 7\n",
    )
    .unwrap();
    let second = ingest(&store, &[&raw], &["--catalog", catalog.to_str().unwrap()]);
    assert_eq!(second.status.code(), Some(0), "{}", stderr(&second));
    assert!(
        summary_line(&second).contains("1 relabelled"),
        "{}",
        stderr(&second)
    );
    let runs = query(
        &store,
        "SELECT tire, rim_in, tire_source, warnings FROM runs",
    );
    assert_eq!(
        (
            runs[0]["tire"].as_str(),
            runs[0]["rim_in"].as_str(),
            runs[0]["tire_source"].as_str()
        ),
        ("Test 20.5x7.0-13", "7", "catalog")
    );
    assert!(!runs[0]["warnings"].contains("unknown"), "{runs:?}");
}
