//! `tirebase synth inertia` and `tirebase inertia`, end to end through the real binary: synthetic
//! sessions are recovered within their expected tolerances, the written Parquet matches
//! `schemas/inertia.toml`, and malformed sessions give one clear error per failed run while the
//! other runs still produce results.

use std::fs;
use std::path::{Path, PathBuf};
use tirebase::schema::TableName;

use polars::prelude::*;

use crate::harness::{bin, copy_tree, tirebase};

fn synth(dir: &Path) -> Vec<PathBuf> {
    let out = tirebase(&[
        "synth",
        "inertia",
        "--out",
        dir.to_str().unwrap(),
        "--seed",
        "7",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut dirs: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    dirs.sort();
    dirs
}

fn read_table(path: &Path) -> DataFrame {
    ParquetReader::new(fs::File::open(path).unwrap())
        .finish()
        .unwrap()
}

struct Row {
    session: String,
    run: String,
    quantity: String,
    method: String,
    value: f64,
}

fn rows(df: &DataFrame) -> Vec<Row> {
    let s = |name: &str| df.column(name).unwrap().str().unwrap().clone();
    let (session, run, quantity, method) = (s("session"), s("run"), s("quantity"), s("method"));
    let value = df.column("value").unwrap().f64().unwrap().clone();
    (0..df.height())
        .map(|i| Row {
            session: session.get(i).unwrap().into(),
            run: run.get(i).unwrap().into(),
            quantity: quantity.get(i).unwrap().into(),
            method: method.get(i).unwrap().into(),
            value: value.get(i).unwrap(),
        })
        .collect()
}

#[derive(serde::Deserialize)]
struct ExpectedFile {
    expected: Vec<Expected>,
}

#[derive(serde::Deserialize)]
struct Expected {
    run: String,
    quantity: String,
    method: String,
    value: f64,
    tolerance: f64,
    note: String,
}

#[test]
fn synthetic_sessions_are_recovered_within_tolerance() {
    let tmp = tempfile::tempdir().unwrap();
    let sessions = synth(&tmp.path().join("syn"));
    assert!(sessions.len() >= 20, "{sessions:?}");
    let out_dir = tmp.path().join("out");
    let mut args = vec!["inertia".to_string()];
    args.extend(sessions.iter().map(|p| p.display().to_string()));
    args.extend(["--out".into(), out_dir.display().to_string()]);
    let out = bin().args(&args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("v4a_pendulum") && stdout.contains("cg_height"),
        "{stdout}"
    );
    let table = rows(&read_table(&out_dir.join("inertia.parquet")));
    let mut checked = 0;
    for dir in &sessions {
        let name = dir.file_name().unwrap().to_str().unwrap();
        let expected: ExpectedFile =
            toml::from_str(&fs::read_to_string(dir.join("expected.toml")).unwrap()).unwrap();
        for e in expected.expected {
            let row = table
                .iter()
                .find(|r| {
                    r.session == name
                        && r.run == e.run
                        && r.quantity == e.quantity
                        && r.method == e.method
                })
                .unwrap_or_else(|| panic!("{name}: no row {} {} {}", e.run, e.quantity, e.method));
            assert!(
                (row.value - e.value).abs() <= e.tolerance,
                "{name}: {} = {} vs {} +- {} ({})",
                e.quantity,
                row.value,
                e.value,
                e.tolerance,
                e.note
            );
            checked += 1;
        }
    }
    assert!(checked >= 30, "only {checked} expectations checked");
}

#[test]
fn written_parquet_matches_schema() {
    // Snapshot of schemas/inertia.toml against the file the command writes.
    let tmp = tempfile::tempdir().unwrap();
    let sessions = synth(&tmp.path().join("syn"));
    let v1 = sessions.iter().find(|p| p.ends_with("v1_yaw")).unwrap();
    let out_dir = tmp.path().join("out");
    let out = tirebase(&[
        "inertia",
        v1.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let df = read_table(&out_dir.join("inertia.parquet"));
    let conformed = tirebase::schema::table(TableName::Inertia)
        .conform(df.clone())
        .unwrap();
    assert_eq!(
        conformed, df,
        "written table must already be in schema order and dtypes"
    );
    let found: Vec<String> = df
        .columns()
        .iter()
        .map(|c| format!("{}:{}", c.name(), c.dtype()))
        .collect();
    assert_eq!(
        found,
        [
            "session:str",
            "run:str",
            "object:str",
            "axis:str",
            "quantity:str",
            "method:str",
            "value:f64",
            "uncertainty:f64",
            "units:str",
            "diagnostics:str"
        ]
    );
}

#[test]
fn same_inputs_give_identical_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let sessions = synth(&tmp.path().join("syn"));
    let pick: Vec<String> = sessions
        .iter()
        .filter(|p| !p.ends_with("v2a_yaw_raw_encoder"))
        .take(6)
        .map(|p| p.display().to_string())
        .collect();
    let mut bytes = Vec::new();
    for (k, order) in [pick.clone(), pick.iter().rev().cloned().collect()]
        .into_iter()
        .enumerate()
    {
        let out_dir = tmp.path().join(format!("out{k}"));
        let mut args = vec!["inertia".to_string()];
        args.extend(order);
        args.extend(["--out".into(), out_dir.display().to_string()]);
        let out = bin().args(&args).output().unwrap();
        assert!(out.status.success());
        bytes.push(fs::read(out_dir.join("inertia.parquet")).unwrap());
    }
    assert!(
        bytes[0] == bytes[1],
        "argument order changed the output bytes"
    );
}

fn edit(path: &Path, from: &str, to: &str) {
    let text = fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "{}: no {from:?}", path.display());
    fs::write(path, text.replacen(from, to, 1)).unwrap();
}

#[test]
fn malformed_sessions_give_one_clear_error_per_run_and_others_continue() {
    let tmp = tempfile::tempdir().unwrap();
    let sessions = synth(&tmp.path().join("syn"));
    let find = |name: &str| sessions.iter().find(|p| p.ends_with(name)).unwrap().clone();
    let bad = tmp.path().join("bad");

    // 1. yaw: the vehicle run references a missing file; the calibration run has a negative
    //    falling mass; the tare run is fine (its acceleration is still reported).
    let yaw = bad.join("yaw_missing_file_negative_mass");
    copy_tree(&find("v2a_yaw_tare_calibration"), &yaw);
    edit(
        &yaw.join("session.toml"),
        "file = \"yaw/yaw-veh.csv\"",
        "file = \"yaw/does-not-exist.csv\"",
    );
    edit(
        &yaw.join("session.toml"),
        "falling_mass_kg = { v = 6, u = 0.0 }\ncalibration_body",
        "falling_mass_kg = { v = -6, u = 0.0 }\ncalibration_body",
    );

    // 2. yaw: too few encoder edges in the vehicle run (first 5 events only).
    let few = bad.join("yaw_too_few_edges");
    copy_tree(&find("v1_yaw"), &few);
    let csv = few.join("yaw/yaw-veh.csv");
    let text = fs::read_to_string(&csv).unwrap();
    fs::write(&csv, text.lines().take(7).collect::<Vec<_>>().join("\n")).unwrap();

    // 3. trifilar: the object record is a slow ramp (no oscillation); the platform run still works.
    let flat = bad.join("trifilar_no_period");
    copy_tree(&find("v3a_trifilar_noisy"), &flat);
    let csv = flat.join("trifilar/trifilar-object.csv");
    let mut body = String::from("t_s,angle_deg\n");
    for i in 0..2000 {
        body.push_str(&format!(
            "{:.3},{:.6}\n",
            i as f64 * 0.01,
            0.1 + 1e-4 * i as f64
        ));
    }
    fs::write(&csv, body).unwrap();

    // 4. pendulum: a unit error in a key (pivot_to_deck_mm) and a CSV column in the wrong unit.
    let units = bad.join("pendulum_bad_units");
    copy_tree(&find("v4a_pendulum"), &units);
    edit(
        &units.join("pendulum/pitch-veh-swing.csv"),
        "t_s,angle_deg",
        "t_ms,angle_deg",
    );

    let units_key = bad.join("pendulum_bad_key");
    copy_tree(&find("v4a_pendulum"), &units_key);
    edit(
        &units_key.join("session.toml"),
        "pivot_to_deck_m =",
        "pivot_to_deck_mm =",
    );
    edit(
        &units_key.join("session.toml"),
        "id = \"v4a_pendulum\"",
        "id = \"v4a_pendulum_bad_key\"",
    );

    // 5. a directory without session.toml
    let empty = bad.join("not_a_session");
    fs::create_dir_all(&empty).unwrap();

    let good = find("v3b_trifilar_10deg_trifilar");
    let out_dir = tmp.path().join("out");
    let out = tirebase(&[
        "inertia",
        yaw.to_str().unwrap(),
        few.to_str().unwrap(),
        flat.to_str().unwrap(),
        units.to_str().unwrap(),
        units_key.to_str().unwrap(),
        empty.to_str().unwrap(),
        good.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    let has = |session: &str, run: &str, needle: &str| {
        errors
            .iter()
            .any(|l| l.contains(&format!("{session}: run {run}: ")) && l.contains(needle))
    };
    assert!(
        has("v2a_yaw_tare_calibration", "yaw-veh", "does-not-exist.csv"),
        "{stderr}"
    );
    assert!(
        has(
            "v2a_yaw_tare_calibration",
            "yaw-cal",
            "session.toml: falling_mass_kg: must be > 0, got -6"
        ),
        "{stderr}"
    );
    assert!(
        has("v1_yaw", "yaw-veh", "too few encoder edges: found 5"),
        "{stderr}"
    );
    assert!(
        has("v3a_trifilar_noisy", "trifilar-object", "period not found"),
        "{stderr}"
    );
    assert!(
        has(
            "v4a_pendulum",
            "pitch-veh-swing",
            "missing column `t_s` (found: t_ms, angle_deg)"
        ),
        "{stderr}"
    );
    assert!(
        has(
            "v4a_pendulum_bad_key",
            "pitch-plat-static",
            "unknown field `pivot_to_deck_mm`"
        ),
        "{stderr}"
    );
    assert!(
        has("not_a_session", "session.toml", "session.toml"),
        "{stderr}"
    );
    // one error per failed run: no run is reported twice
    let mut keys: Vec<String> = errors
        .iter()
        .map(|l| l.split(": ").take(3).collect::<Vec<_>>().join(": "))
        .collect();
    let n = keys.len();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), n, "a run was reported twice:\n{stderr}");

    // the other runs still produced results
    let table = rows(&read_table(&out_dir.join("inertia.parquet")));
    let present = |session: &str, run: &str, quantity: &str| {
        table
            .iter()
            .any(|r| r.session == session && r.run == run && r.quantity == quantity)
    };
    assert!(present(
        "v2a_yaw_tare_calibration",
        "yaw-empty",
        "angular_acceleration"
    ));
    assert!(!present("v1_yaw", "yaw-veh", "inertia"));
    assert!(present(
        "v3a_trifilar_noisy",
        "trifilar-platform",
        "period_natural"
    ));
    assert!(present(
        "v4a_pendulum",
        "pitch-plat-static+pitch-veh-static",
        "cg_height"
    ));
    assert!(present(
        "v3b_trifilar_10deg_trifilar",
        "trifilar-object",
        "inertia"
    ));
}
