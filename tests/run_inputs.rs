//! The nightly run is a function of its inputs (issue 20): `tirebase run` twice on one store,
//! with an input changed in between, must end with the version a fresh store builds from the
//! changed inputs (every table equal apart from wall-time columns, same `.tir` files, same group
//! input hashes, same runs/segments/samples in the store).
//!
//! Each test starts from one shared first run of a demo round (copied per test) and changes one
//! input: the catalog (item 1), the `[segment]` configuration (item 2), the set of input files
//! (item 3), a file that fails for an environmental reason and a store that cannot be written
//! (item 5), bad directory entries (item 6), a file cut in transfer and many problems at once
//! (item 7).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use polars::prelude::*;
use tirebase::manifest::{Manifest, ProblemKind};
use tirebase::store::tables::{self, RunRow, RunStatus};

use crate::harness::{bin, copy_tree, demo_published, ok, run, text};

/// A private copy of the baseline: (temp dir, input, store).
fn fork() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    copy_tree(demo_published(), tmp.path());
    let (input, store) = (tmp.path().join("input"), tmp.path().join("store"));
    (tmp, input, store)
}

/// A run on unchanged inputs: exit 0, "up to date".
fn assert_up_to_date(input: &Path, store: &Path) {
    let again = run(input, store, &[]);
    ok(&again, "run on unchanged inputs");
    let log = text(&again.stderr);
    assert!(log.contains("up to date"), "{log}");
}

/// A run stopped by a store error: exit 2, a store error naming `says`, no input file blamed,
/// no version after `latest_version`, the runs table as it was.
fn assert_stopped_on_store_error(
    o: &Output,
    store: &Path,
    says: &str,
    latest_version: u32,
    runs_before: &BTreeMap<String, RunRow>,
) {
    let log = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{log}");
    assert!(log.contains("store error") && log.contains(says), "{log}");
    assert!(!log.contains("failed file"), "{log}");
    assert_eq!(
        latest(store).0,
        latest_version,
        "no version after a store error"
    );
    assert_eq!(
        &tables::read_runs(store).unwrap(),
        runs_before,
        "runs table untouched: no input file blamed"
    );
}

fn latest(store: &Path) -> (u32, PathBuf) {
    tirebase::store::versions::latest(store).unwrap().unwrap()
}

/// Columns holding wall time, which no two runs share.
const TIMING_COLUMNS: [&str; 1] = ["seconds"];

/// Make a named pipe at `path` (a file the run must refuse to read, not wait on).
fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(status.success(), "mkfifo {}", path.display());
}

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
/// same input and arguments (which must succeed).
fn assert_equals_fresh(input: &Path, store: &Path, extra: &[&str]) {
    assert_equals_fresh_with_exit(input, store, extra, 0);
}

/// [`assert_equals_fresh`] where the fresh run exits with `code` (1: published with problems).
fn assert_equals_fresh_with_exit(input: &Path, store: &Path, extra: &[&str], code: i32) {
    let fresh_dir = tempfile::tempdir().unwrap();
    let fresh = fresh_dir.path().join("store");
    let o = run(input, &fresh, extra);
    assert_eq!(
        o.status.code(),
        Some(code),
        "fresh run: {}",
        text(&o.stderr)
    );
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
    assert_eq!(ma.problems, mb.problems, "problems of the version");
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
    ok(&second, "run after the catalog edit");
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
    assert_up_to_date(&input, &store);
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
    ok(&second, "run with the new [segment] config");
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
    ok(&second, "run without one file");
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

/// Item 5: a file that fails for an environmental reason (here a dangling symlink, as a
/// permission problem or an unmounted share would) is tried again every night: the night after
/// is not "up to date, exit 0", and once it reads, the version equals a fresh run.
#[test]
fn issue20_failed_file_is_retried_every_run() {
    let (tmp, input, store) = fork();
    let file = input.join("raw/B2410run2.dat");
    let outside = tmp.path().join("outside");
    fs::create_dir_all(&outside).unwrap();
    fs::rename(&file, outside.join("B2410run2.dat")).unwrap();
    std::os::unix::fs::symlink(outside.join("later.dat"), &file).unwrap();

    let second = run(&input, &store, &[]);
    let log = text(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{log}");
    assert!(log.contains("failed file: B2410run2.dat: "), "{log}");
    let m = Manifest::read(&latest(&store).1).unwrap();
    let failed: Vec<_> = m
        .problems
        .iter()
        .filter(|p| p.kind == ProblemKind::FailedFile)
        .collect();
    assert_eq!(failed.len(), 1, "{:?}", m.problems);
    assert!(failed[0].reason.contains("later.dat") || failed[0].reason.contains("No such file"));

    // Nothing changed: retried, fails again, said so, exit 1, no new version.
    let third = run(&input, &store, &[]);
    let log = text(&third.stderr);
    assert_eq!(third.status.code(), Some(1), "{log}");
    assert!(
        log.contains("up to date") && log.contains("still failed"),
        "{log}"
    );
    assert!(log.contains("failed file: B2410run2.dat: "), "{log}");
    assert_eq!(latest(&store).0, 2);

    // The share comes back: the file reads, a version equal to a fresh run.
    fs::rename(outside.join("B2410run2.dat"), outside.join("later.dat")).unwrap();
    let fourth = run(&input, &store, &[]);
    ok(&fourth, "run after the file came back");
    assert_eq!(latest(&store).0, 3);
    assert_equals_fresh(&input, &store, &[]);
}

/// Item 5: a store that cannot be written is a store error (exit 2, nothing recorded against
/// the input file), and the next run after the repair completes.
#[test]
fn issue20_store_write_error_is_a_store_error_not_a_failed_file() {
    let (_tmp, input, store) = fork();
    let catalog = input.join("catalog.toml");
    let (old, new) = ("Hoosier 16.0x7.5-10 R25B", "Hoosier 16.0x7.5-10 R25B v2");
    let text_before = fs::read_to_string(&catalog).unwrap();
    fs::write(&catalog, text_before.replace(old, new)).unwrap();
    // A file where the relabelled samples' partition directory must go.
    let blocker = store.join("samples/test=cornering").join(format!(
        "tire={}",
        tirebase::store::layout::hive_encode(new)
    ));
    fs::write(&blocker, b"not a directory").unwrap();
    let runs_before = tables::read_runs(&store).unwrap();

    let second = run(&input, &store, &[]);
    assert_stopped_on_store_error(&second, &store, "tire=", 1, &runs_before);

    fs::remove_file(&blocker).unwrap();
    ok(&run(&input, &store, &[]), "run after the repair");
    assert_equals_fresh(&input, &store, &[]);
}

/// `tirebase run` in the background, killed after `secs` (a hang fails the test, never blocks it).
fn run_with_deadline(input: &Path, store: &Path, secs: u64) -> Output {
    let child = bin()
        .arg("run")
        .arg("--input")
        .arg(input)
        .arg("--store")
        .arg(store)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let id = child.id();
    let watchdog = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_secs(secs));
        // SIGKILL by pid: only if the run is still going (the test then fails on its status).
        let _ = Command::new("kill").args(["-9", &id.to_string()]).status();
    });
    let out = child.wait_with_output().unwrap();
    drop(watchdog);
    assert!(out.status.code().is_some(), "killed after {secs} s: a hang");
    out
}

/// Item 6: a FIFO named `*.dat`, a directory symlink loop, a looping and a dangling file symlink
/// neither hang nor stop `run` or `ingest`: the FIFO and the loop are skipped with a line, each
/// symlink is one failed file, the rest is ingested.
#[test]
fn issue20_bad_directory_entries_neither_stop_nor_hang_run_or_ingest() {
    let (_tmp, input, store) = fork();
    let before = Manifest::read(&latest(&store).1).unwrap();
    let raw = input.join("raw");
    mkfifo(&raw.join("pipe.dat"));
    std::os::unix::fs::symlink("..", raw.join("loop")).unwrap();
    std::os::unix::fs::symlink("self.dat", raw.join("self.dat")).unwrap();
    std::os::unix::fs::symlink("/nonexistent/x.dat", raw.join("dangling.dat")).unwrap();

    let out = run_with_deadline(&input, &store, 600);
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(
        log.contains("pipe.dat: a FIFO, not a regular file"),
        "{log}"
    );
    assert!(log.contains("raw/loop: directory symlink"), "{log}");
    assert!(log.contains("failed file: dangling.dat: "), "{log}");
    assert!(log.contains("failed file: self.dat: "), "{log}");
    let m = Manifest::read(&latest(&store).1).unwrap();
    assert_eq!(m.counts.files_failed, 2, "{:?}", m.counts);
    assert_eq!(m.counts.entries_skipped, 2, "{:?}", m.counts);
    // Every file of the round still ingested.
    assert_eq!(m.counts.files_ok, before.counts.files_ok, "{:?}", m.counts);

    // `ingest` on the same entries, into a new store.
    let other = input.parent().unwrap().join("ingest-store");
    let mut child = bin()
        .arg("ingest")
        .arg(&raw)
        .arg("--store")
        .arg(&other)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if started.elapsed().as_secs() > 600 {
            child.kill().unwrap();
            panic!("ingest hangs");
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    let log = {
        use std::io::Read;
        let mut s = String::new();
        child.stderr.take().unwrap().read_to_string(&mut s).unwrap();
        s
    };
    assert_eq!(code, Some(1), "{log}");
    assert!(
        log.contains("skipped: ") && log.contains("pipe.dat: a FIFO"),
        "{log}"
    );
    assert!(log.contains("failed: dangling.dat: "), "{log}");
    assert!(log.contains("failed: self.dat: "), "{log}");
    assert!(
        log.contains(&format!("{} ingested", before.counts.files_ok)),
        "{log}"
    );
}

/// Item 7: a `.dat` cut in transfer is stored as a flagged partial file (never plain "ok"),
/// said on stderr and listed in the manifest; the version equals a fresh run of that input.
#[test]
fn issue20_file_cut_in_transfer_is_partial_and_said() {
    let (_tmp, input, store) = fork();
    let file = input.join("raw/B2410run7.dat");
    let bytes = fs::read(&file).unwrap();
    let mut cut = bytes.len() / 2;
    while bytes[cut - 1] == b'\n' || bytes[cut] == b'\n' {
        cut += 1;
    }
    fs::write(&file, &bytes[..cut]).unwrap();

    let second = run(&input, &store, &[]);
    let log = text(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{log}");
    assert!(
        log.contains("partial file: B2410run7.dat: rows stop early")
            && log.contains("truncated last line"),
        "{log}"
    );
    let runs = tables::read_runs(&store).unwrap();
    assert_eq!(runs["B2410run7.dat"].status, RunStatus::Partial);
    let m = Manifest::read(&latest(&store).1).unwrap();
    assert_eq!(m.counts.files_partial, 1);
    assert!(
        m.problems
            .iter()
            .any(|p| p.kind == ProblemKind::PartialFile && p.subject == "B2410run7.dat")
    );
    assert_equals_fresh_with_exit(&input, &store, &[], 1);
}

/// Item 7: with many problems nothing is truncated away: every failed file and every failed
/// inertia run is one stderr line under a counted heading and a manifest problem with its reason.
#[test]
fn issue20_every_problem_is_on_stderr_and_in_the_manifest() {
    let (_tmp, input, store) = fork();
    for k in 0..12 {
        fs::write(
            input.join(format!("raw/bad{k:02}.dat")),
            format!("not a TIRF file {k}\n"),
        )
        .unwrap();
    }
    let o = bin()
        .args(["synth", "inertia", "--out"])
        .arg(input.join("inertia"))
        .output()
        .unwrap();
    ok(&o, "synth inertia");
    // Every run of the yaw sessions loses its samples (header line kept).
    let mut broken = 0;
    let mut stack = vec![input.join("inertia")];
    while let Some(dir) = stack.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "csv")
                && path.display().to_string().contains("yaw")
            {
                let t = fs::read_to_string(&path).unwrap();
                fs::write(&path, format!("{}\n", t.lines().next().unwrap())).unwrap();
                broken += 1;
            }
        }
    }
    assert!(broken >= 7, "{broken}");

    let out = run(&input, &store, &[]);
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(log.contains("12 input files failed:"), "{log}");
    for k in 0..12 {
        assert!(
            log.contains(&format!("failed file: bad{k:02}.dat: ")),
            "{log}"
        );
    }
    assert!(!log.contains("more (see"), "{log}");
    let m = Manifest::read(&latest(&store).1).unwrap();
    let of = |k: ProblemKind| m.problems.iter().filter(|p| p.kind == k).count() as u64;
    assert_eq!(of(ProblemKind::FailedFile), 12);
    assert!(
        m.problems.iter().all(|p| !p.reason.is_empty()),
        "{:?}",
        m.problems
    );
    assert!(m.counts.inertia_failed_runs >= 7, "{:?}", m.counts);
    assert_eq!(of(ProblemKind::InertiaRun), m.counts.inertia_failed_runs);
    for p in m
        .problems
        .iter()
        .filter(|p| p.kind == ProblemKind::InertiaRun)
    {
        assert!(log.contains(&p.to_string()), "{p} not on stderr: {log}");
    }
    assert!(
        log.contains(&format!(
            "{} inertia runs failed:",
            m.counts.inertia_failed_runs
        )),
        "{log}"
    );
}

/// Item 4: two tires whose names differ only in case, at the same rim and pressures, get one
/// `.tir` each (they used to share a file name and overwrite each other), under names that say
/// which is which, and the run says so.
#[test]
fn issue20_tir_names_stay_unique_per_group() {
    let (_tmp, input, store) = fork();
    let before = Manifest::read(&latest(&store).1).unwrap();
    let catalog = input.join("catalog.toml");
    let text_before = fs::read_to_string(&catalog).unwrap();
    let (a, b) = ("Hoosier 20.5x7.0-13 R25B", "Hoosier 16.0x7.5-10 R25B");
    let lower = a.to_lowercase();
    fs::write(&catalog, text_before.replace(b, &lower)).unwrap();
    // The renaming keeps every group apart (names are compared case-sensitively) and makes the
    // groups of `a` and `b` at a shared (rim, pressure) collide: two per shared pair.
    let rim_pressures = |tire: &str| -> std::collections::BTreeSet<(i64, i64)> {
        before
            .groups
            .iter()
            .filter(|g| g.tire == tire)
            .map(|g| (g.rim_in, g.pressure_kpa))
            .collect()
    };
    let rims = |tire: &str| -> std::collections::BTreeSet<i64> {
        rim_pressures(tire).into_iter().map(|(r, _)| r).collect()
    };
    // ... and their MF 6.1 files (one per tire and rim) at a shared rim.
    let colliding = 2 * rim_pressures(a).intersection(&rim_pressures(b)).count()
        + 2 * rims(a).intersection(&rims(b)).count();
    assert!(colliding > 0, "{a} and {b} share no rim and pressure");
    let n_groups = before.groups.len();
    let n_models = n_groups
        + before
            .groups
            .iter()
            .map(|g| (g.tire.as_str(), g.rim_in))
            .collect::<std::collections::BTreeSet<_>>()
            .len();

    let out = run(&input, &store, &[]);
    let log = text(&out.stderr);
    ok(&out, "run with colliding tire names");
    assert!(log.contains(".tir file names disambiguated"), "{log}");
    let (_, dir) = latest(&store);
    let m = Manifest::read(&dir).unwrap();
    assert_eq!(m.counts.groups as usize, n_groups, "{:?}", m.groups);
    assert_eq!(m.counts.tir_files as usize, n_models, "{:?}", m.counts);
    let files = files_below(&dir.join("tir"));
    assert_eq!(files.len(), n_models, "{:?}", files.keys());
    assert_eq!(
        m.problems
            .iter()
            .filter(|p| p.kind == ProblemKind::TirName)
            .count(),
        colliding
    );
    // Each group's file holds that group's tire.
    let groups = tirebase::store::results::model_groups(&dir);
    let (mut names, _) = tirebase::store::results::tir_names(&groups);
    names.extend(
        tirebase::store::results::mf61_names(&tirebase::store::results::mf61_groups(&dir)).0,
    );
    for ((tire, _, p), name) in &names {
        let body = text(&files[name]);
        assert!(
            body.lines()
                .any(|l| l.trim_start_matches("! : TIRE :").trim() == tire.as_str()),
            "{name} ({tire}, {p} kPa) holds another tire"
        );
    }
    // The lint table points at files that exist.
    let lint = read_table(&dir.join("lint.parquet"));
    for f in lint.column("file").unwrap().str().unwrap().iter().flatten() {
        assert!(files.contains_key(f), "lint names {f}, not written");
    }
    assert_equals_fresh(&input, &store, &[]);
}

/// Other changes of the same kind, at once: a run moved to the other tire in the catalog, a run
/// dropped from the catalog (its file's own `Tire_Name=` applies again), a file renamed (same
/// bytes, new identity). Two runs on one store end where a fresh store does, and a third run is
/// up to date.
#[test]
fn issue20_mixed_input_changes_equal_a_fresh_run() {
    let (_tmp, input, store) = fork();
    let catalog = input.join("catalog.toml");
    let text_before = fs::read_to_string(&catalog).unwrap();
    let entry = |run: u32| {
        let head = format!("[[run]]\nproject = 2410\nrun = {run}\n");
        let start = text_before.find(&head).unwrap();
        let end = text_before[start + head.len()..]
            .find("[[run]]")
            .map_or(text_before.len(), |e| start + head.len() + e);
        text_before[start..end].to_string()
    };
    let (run3, run7) = (entry(3), entry(7));
    let edited = text_before
        .replace(
            &run3,
            &run3.replace("Hoosier 20.5x7.0-13 R25B", "Hoosier 16.0x7.5-10 R25B"),
        )
        .replace(&run7, "");
    fs::write(&catalog, edited).unwrap();
    fs::rename(
        input.join("raw/A2410run6.dat"),
        input.join("raw/A2410run6-resent.dat"),
    )
    .unwrap();

    let second = run(&input, &store, &[]);
    let log = text(&second.stderr);
    ok(&second, "run after the mixed changes");
    assert!(
        log.contains("relabelled") && log.contains("1 files removed"),
        "{log}"
    );
    let runs = tables::read_runs(&store).unwrap();
    assert_eq!(
        runs["B2410run3.mat"].tire.as_deref(),
        Some("Hoosier 16.0x7.5-10 R25B")
    );
    assert_eq!(
        runs["B2410run7.dat"].tire_source.as_deref(),
        Some("tire_name")
    );
    assert!(!runs.contains_key("A2410run6.dat"));
    assert_eq!(runs["A2410run6-resent.dat"].status, RunStatus::Ok);
    assert_equals_fresh(&input, &store, &[]);
    assert_up_to_date(&input, &store);
}

/// `tirebase run` as a user that file permissions apply to. Root reads and writes everything,
/// so under root the run drops to `nobody` through `setpriv` (util-linux), with `tree` (the
/// test's input and store) handed over to that user first.
fn run_unprivileged(tree: &Path, input: &Path, store: &Path, extra: &[&str]) -> Output {
    let uid = Command::new("id").arg("-u").output().unwrap();
    if text(&uid.stdout).trim() != "0" {
        return run(input, store, extra);
    }
    let chown = Command::new("chown")
        .args(["-R", "65534:65534"])
        .arg(tree)
        .status()
        .unwrap();
    assert!(chown.success());
    Command::new("setpriv")
        .args([
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
            "--",
            env!("CARGO_BIN_EXE_tirebase"),
            "run",
            "--input",
        ])
        .arg(input)
        .arg("--store")
        .arg(store)
        .args(extra)
        .output()
        .expect("setpriv (util-linux) is needed to run as an unprivileged user under root")
}

fn chmod(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    fs::set_permissions(path, fs::Permissions::from_mode(mode)).unwrap();
}

/// `chmod` every directory below `root` (and `root`).
fn chmod_dirs(root: &Path, mode: u32) {
    for entry in fs::read_dir(root).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            chmod_dirs(&path, mode);
        }
    }
    chmod(root, mode);
}

/// Item 5, with real permissions: a file re-sent unreadable (mode 000) is a failed file that
/// keeps its last good data, is read again every night (the night after is "still failed",
/// exit 1, no new version) and, once readable, gives a version equal to a fresh run; an input
/// directory that cannot be listed stops the run as an input error (exit 2, nothing published,
/// nothing pruned); a store whose part directories are read-only is a store error (exit 2,
/// nothing recorded against any input file, runs table untouched) and the run after the repair
/// equals a fresh run.
#[test]
fn issue20_permission_problems_are_retried_and_store_errors_are_not_blamed_on_inputs() {
    let (tmp, input, store) = fork();
    let file = input.join("raw/B2410run2.dat");
    fs::File::options()
        .write(true)
        .open(&file)
        .unwrap()
        .set_modified(std::time::SystemTime::now())
        .unwrap();
    chmod(&file, 0o000);
    let runs_before = tables::read_runs(&store).unwrap();

    let second = run_unprivileged(tmp.path(), &input, &store, &[]);
    let log = text(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{log}");
    assert!(
        log.contains("failed file: B2410run2.dat: ")
            && log.contains("Permission denied")
            && log.contains("rows of its last good content stay in the store and the models"),
        "{log}"
    );
    assert_eq!(latest(&store).0, 2, "{log}");
    let runs = tables::read_runs(&store).unwrap();
    assert_eq!(runs["B2410run2.dat"].status, RunStatus::Failed);
    assert_eq!(
        runs["B2410run2.dat"].data_sha256, runs_before["B2410run2.dat"].data_sha256,
        "the last good data of a file that cannot be read now stays"
    );

    // Nothing changed: read again, fails again, said so, exit 1, no new version.
    let third = run_unprivileged(tmp.path(), &input, &store, &[]);
    let log = text(&third.stderr);
    assert_eq!(third.status.code(), Some(1), "{log}");
    assert!(
        log.contains("still failed") && log.contains("Permission denied"),
        "{log}"
    );
    assert_eq!(latest(&store).0, 2);

    // An input directory that cannot be listed: an input error, the store as it was.
    let runs_before = tables::read_runs(&store).unwrap();
    chmod(&input.join("raw"), 0o000);
    let blocked = run_unprivileged(tmp.path(), &input, &store, &[]);
    let log = text(&blocked.stderr);
    assert_eq!(blocked.status.code(), Some(2), "{log}");
    assert!(
        log.contains("raw: cannot read the input") && log.contains("nothing published"),
        "{log}"
    );
    assert!(!log.contains("store error"), "{log}");
    assert_eq!(latest(&store).0, 2);
    assert_eq!(tables::read_runs(&store).unwrap(), runs_before);
    chmod(&input.join("raw"), 0o755);

    // The file is readable again: read, and the version equals a fresh run.
    chmod(&file, 0o644);
    let fourth = run_unprivileged(tmp.path(), &input, &store, &[]);
    ok(&fourth, "run after the file became readable");
    assert_eq!(latest(&store).0, 3);
    assert_equals_fresh(&input, &store, &[]);

    // A [segment] change must rewrite every file's parts, into read-only directories.
    let cfg = tmp.path().join("segment.toml");
    fs::write(&cfg, "[segment.activity]\nsa_active_deg = 1.5\n").unwrap();
    let cfg_arg = cfg.display().to_string();
    let extra = ["--config", cfg_arg.as_str()];
    let runs_before = tables::read_runs(&store).unwrap();
    for part in ["samples", "segments"] {
        chmod_dirs(&store.join(part), 0o555);
    }
    let blocked = run_unprivileged(tmp.path(), &input, &store, &extra);
    assert_stopped_on_store_error(&blocked, &store, "Permission denied", 3, &runs_before);

    for part in ["samples", "segments"] {
        chmod_dirs(&store.join(part), 0o755);
    }
    let repaired = run_unprivileged(tmp.path(), &input, &store, &extra);
    ok(&repaired, "run after the store repair");
    assert_eq!(latest(&store).0, 4);
    assert_equals_fresh(&input, &store, &extra);
}

/// Item 6 in rig sessions: an input of rig sessions only publishes (it used to stop at "not a
/// tirebase store"); a FIFO in a session, a FIFO in place of a run file and directory symlinks
/// back up the tree neither hang the run (hashing the FIFO blocked forever) nor make it hash the
/// tree again through the loop: each is a skipped entry with a line, the run file's run fails
/// with its reason, and the next night, up to date, still says what it skips; a FIFO catalog
/// is an input error.
#[test]
fn issue20_rig_session_entries_neither_hang_nor_stop_the_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (input, store) = (tmp.path().join("input"), tmp.path().join("store"));
    let o = bin()
        .args(["synth", "inertia", "--out"])
        .arg(input.join("inertia"))
        .output()
        .unwrap();
    ok(&o, "synth inertia");
    let first = run_with_deadline(&input, &store, 600);
    ok(&first, "run on rig sessions only");
    let m = Manifest::read(&latest(&store).1).unwrap();
    assert_eq!(m.counts.files, 0);
    assert!(m.counts.inertia_results > 0, "{:?}", m.counts);
    let hashed = m.inertia_files.len();

    let session = input.join("inertia/v2c_yaw_calibration_factor");
    let run_file = session.join("yaw/yaw-cal.csv");
    assert!(run_file.is_file());
    fs::remove_file(&run_file).unwrap();
    for fifo in [session.join("pipe.csv"), run_file.clone()] {
        mkfifo(&fifo);
    }
    std::os::unix::fs::symlink("..", session.join("loop")).unwrap();
    std::os::unix::fs::symlink("../..", session.join("loop2")).unwrap();

    let second = run_with_deadline(&input, &store, 600);
    let log = text(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{log}");
    for entry in ["loop: directory symlink", "loop2: directory symlink"] {
        assert!(log.contains(entry), "{entry}: {log}");
    }
    for fifo in ["pipe.csv: a FIFO", "yaw/yaw-cal.csv: a FIFO"] {
        assert!(log.contains(fifo), "{fifo}: {log}");
    }
    assert!(
        log.contains("failed inertia run: v2c_yaw_calibration_factor/yaw-cal: ")
            && log.contains("not a regular file"),
        "{log}"
    );
    let m = Manifest::read(&latest(&store).1).unwrap();
    assert_eq!(m.version, 2);
    assert_eq!(m.counts.entries_skipped, 4, "{:?}", m.problems);
    assert_eq!(
        m.inertia_files.len(),
        hashed - 1,
        "hashed once, not through the loops"
    );

    let third = run_with_deadline(&input, &store, 600);
    let log = text(&third.stderr);
    assert_eq!(third.status.code(), Some(0), "{log}");
    assert!(
        log.contains("up to date") && log.contains("4 input entries skipped:"),
        "{log}"
    );

    // A catalog.toml that is a FIFO is an input error (it used to be silently no catalog, and
    // hung the run when given by --catalog).
    mkfifo(&input.join("catalog.toml"));
    let fourth = run_with_deadline(&input, &store, 600);
    let log = text(&fourth.stderr);
    assert_eq!(fourth.status.code(), Some(2), "{log}");
    assert!(
        log.contains("catalog.toml: cannot read the input: not a regular file"),
        "{log}"
    );
    assert_eq!(latest(&store).0, 2);
}
