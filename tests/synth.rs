//! `tirebase synth round` end to end: the real binary writes a demo round into temp dirs.
//!
//! Checks the directory layout, that the bytes do not depend on `--jobs`, that the catalog and
//! truth files are well-formed, that `--defects` records every kind, and that `--config` keys are
//! validated by name. The physics is tested in `tirebase_core::synth` (unit tests).

use crate::harness::{bin, synth_round, tree};

#[test]
fn demo_round_is_complete_and_identical_for_any_thread_count() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    synth_round(a.path(), &["--jobs", "1"]);
    synth_round(b.path(), &["--jobs", "2"]);
    let ta = tree(a.path());
    let tb = tree(b.path());
    assert_eq!(ta.keys().collect::<Vec<_>>(), tb.keys().collect::<Vec<_>>());
    for (name, bytes) in &ta {
        assert!(
            bytes == &tb[name],
            "{name} differs between --jobs 1 and --jobs 2"
        );
    }
    let raw: Vec<&String> = ta.keys().filter(|k| k.starts_with("raw/")).collect();
    // 4 tire/rim combinations x 2 pressures x (cornering, drive/brake).
    assert_eq!(raw.len(), 16, "{raw:?}");
    for ext in [".dat", ".mat"] {
        assert!(raw.iter().any(|k| k.ends_with(ext)), "no {ext}");
    }
    assert!(raw.iter().any(|k| k.contains("raw/A")) && raw.iter().any(|k| k.contains("raw/B")));
    assert!(
        raw.iter()
            .any(|k| k.contains("raw") && k.matches("raw").count() == 2)
    );
    let tirs = ta.keys().filter(|k| k.starts_with("truth/tir/")).count();
    assert_eq!(tirs, 8);
    // The demo car's rig sessions, with their known answers.
    for session in ["car_yaw", "car_pitch", "wheel_trifilar"] {
        for file in ["session.toml", "expected.toml"] {
            let key = format!("inertia/{session}/{file}");
            assert!(ta.contains_key(&key), "no {key}");
        }
    }

    let catalog: toml::Table =
        toml::from_str(std::str::from_utf8(&ta["catalog.toml"]).unwrap()).unwrap();
    let runs = catalog["run"].as_array().unwrap();
    assert_eq!(runs.len(), 16);
    let combos: std::collections::BTreeSet<(String, i64)> = runs
        .iter()
        .map(|r| {
            (
                r["tire"].as_str().unwrap().to_string(),
                r["rim_in"].as_integer().unwrap(),
            )
        })
        .collect();
    assert_eq!(combos.len(), 4, "{combos:?}");
    for r in runs {
        let keys: Vec<&String> = r.as_table().unwrap().keys().collect();
        assert_eq!(keys, ["kind", "project", "rim_in", "run", "tire"]);
    }

    let segments = std::str::from_utf8(&ta["truth/segments.csv"]).unwrap();
    let header = segments.lines().next().unwrap();
    assert!(header.starts_with(
        "file,project,run,kind,et_start_s,et_end_s,pressure_kpa_nom,ia_deg_nom,fz_n_nom,alpha_deg_nom,speed_kph_nom"
    ));
    for kind in [
        "spring_rate_static",
        "spring_rate_dynamic",
        "cold_to_warm",
        "conditioning",
        "cornering",
        "drive_brake",
        "combined",
        "step_steer",
        "ia_sweep",
        "speed_sweep",
    ] {
        assert!(segments.contains(&format!(",{kind},")), "no {kind} segment");
    }

    let truth: toml::Table = toml::from_str(
        std::str::from_utf8(&ta["truth/hoosier_20.5x7.0-13_r25b__7in.toml"]).unwrap(),
    )
    .unwrap();
    assert_eq!(truth["tire"].as_str(), Some("Hoosier 20.5x7.0-13 R25B"));
    let thermal = truth["thermal"].as_table().unwrap();
    assert!(thermal["t_peak_c"].as_float().unwrap() > 30.0);
    assert!((thermal["gain_peak_over_cold"].as_float().unwrap() - 0.35).abs() < 1e-12);
    let p = &truth["pressure"].as_array().unwrap()[0];
    assert!(p["vertical_stiffness_static_n_per_m"].as_float().unwrap() > 50_000.0);
}

#[test]
fn defects_are_injected_and_recorded() {
    let d = tempfile::tempdir().unwrap();
    synth_round(d.path(), &["--defects", "--ideal", "--seed", "5"]);
    let csv = std::fs::read_to_string(d.path().join("truth/defects.csv")).unwrap();
    let kinds: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    for kind in [
        "duplicated_et",
        "non_monotonic_et",
        "zero_pressure",
        "zeroed_channel",
        "truncated_last_line",
        "spreadsheet_resaved",
    ] {
        assert!(kinds.contains(&kind), "{kind} missing from {csv}");
    }
    let round = std::fs::read_to_string(d.path().join("truth/round.toml")).unwrap();
    assert!(
        round.contains("defects = true") && round.contains("noise_scale = 0.0"),
        "{round}"
    );
}

#[test]
fn unknown_config_key_is_an_error_naming_it() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("bad.toml");
    std::fs::write(&cfg, "[synth]\nseed = 1\n[synth.realism]\nnoise = 2.0\n").unwrap();
    let output = bin()
        .args(["synth", "round", "--out"])
        .arg(d.path().join("round"))
        .arg("--config")
        .arg(&cfg)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("noise"), "{err}");
}
