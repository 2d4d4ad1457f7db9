//! Reader tests: every round layout, unit spelling and damage variant of the format doc, the
//! malformed corpus in `tests/fixtures/bad/`, MAT write -> read round trips, and a few thousand
//! random mutations of valid files (no panic, errors stay one line and name the source).

use std::path::PathBuf;

use super::dat::{DatColumn, render_dat};
use super::example::{ExampleStyle, example_columns, example_dat, example_mat, example_value};
use super::mat::{Compression, MatValue, MatWriter, NumericClass, parse_mat};
use super::*;
use crate::numerics::random::SplitMix64;

/// Repository root (the core crate lives at `pipeline/core`).
fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Relative tolerance check with a readable failure.
fn assert_close(what: &str, got: f64, want: f64, abs_tol: f64) {
    assert!(
        (got - want).abs() <= abs_tol,
        "{what}: got {got}, want {want} (tolerance {abs_tol})"
    );
}

/// The canonical-unit column a RunTable holds for `channel`, in the file's frame convention
/// undone (i.e. back in SAE) so it compares with `example_value`.
fn sae_column(run: &RunTable, channel: TtcChannel) -> Vec<f64> {
    let neg = |v: &[f64]| v.iter().map(|x| -x).collect::<Vec<_>>();
    let t = &run.tire;
    match channel {
        TtcChannel::Et => run.et_s.clone(),
        TtcChannel::V => run.speed_kph.clone(),
        TtcChannel::N => run.wheel_speed_rpm.clone().unwrap(),
        TtcChannel::Sa => neg(&t.alpha_rad),
        TtcChannel::Ia => t.gamma_rad.clone(),
        TtcChannel::Rl => run.loaded_radius_m.clone().unwrap(),
        TtcChannel::Re => run.effective_radius_m.clone().unwrap(),
        TtcChannel::P => run.pressure_kpa.clone(),
        TtcChannel::Fx => t.fx_n.clone(),
        TtcChannel::Fy => neg(&t.fy_n),
        TtcChannel::Fz => neg(&t.fz_n),
        TtcChannel::Mx => t.mx_nm.clone(),
        TtcChannel::Mz => neg(&t.mz_nm),
        TtcChannel::Nfx => run.nfx.clone().unwrap(),
        TtcChannel::Nfy => run.nfy.clone().unwrap(),
        TtcChannel::Rst => run.road_temp_c.clone().unwrap(),
        TtcChannel::Tsti => run.tread_inner_temp_c.clone().unwrap(),
        TtcChannel::Tstc => run.tread_centre_temp_c.clone().unwrap(),
        TtcChannel::Tsto => run.tread_outer_temp_c.clone().unwrap(),
        TtcChannel::Ambtmp => run.ambient_temp_c.clone().unwrap(),
        TtcChannel::Sr => run.sr.clone().unwrap(),
        TtcChannel::Sl => run.sl.clone().unwrap(),
    }
}

#[test]
fn every_round_style_reads_back_in_si_and_iso_w() {
    for style in ExampleStyle::ALL {
        for with_sl in [false, true] {
            let rows = 300;
            let bytes = example_dat(style, rows, with_sl);
            let run = read_dat(&bytes, "example.dat").unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(run.len(), rows);
            let rate = style.sample_rate_hz();
            for column in example_columns(style, rows, with_sl) {
                let channel = TtcChannel::from_name(&column.name).unwrap();
                let unit = Unit::parse(&column.unit).unwrap();
                // Half a unit in the last written decimal, converted to canonical units.
                let step = 0.5 * 10f64.powi(-(column.decimals as i32));
                let tol = (unit.to_canonical(step) - unit.to_canonical(0.0)).abs() * 1.000_001;
                let got = sae_column(&run, channel);
                for i in (0..rows).step_by(37) {
                    let want = example_value(channel, i, rate);
                    assert_close(&format!("{style:?} {channel:?} row {i}"), got[i], want, tol);
                }
            }
            let fz_mean = run.tire.fz_n.iter().sum::<f64>() / rows as f64;
            assert!(
                fz_mean > 1000.0,
                "{style:?}: ISO-W Fz must be positive, mean {fz_mean}"
            );
            assert_close("sample rate", run.meta.sample_rate_hz.unwrap(), rate, 1e-6);
            let expected_kappa = if with_sl {
                KappaSource::Sl
            } else {
                KappaSource::NoSl
            };
            assert_eq!(run.meta.kappa_source, expected_kappa);
            if with_sl {
                assert_eq!(run.tire.kappa, run.sl.clone().unwrap());
            } else {
                assert!(run.tire.kappa.iter().all(|k| *k == 0.0));
                assert!(run.sl.is_none());
            }
            assert!(run.meta.warnings.is_empty(), "{:?}", run.meta.warnings);
        }
    }
}

#[test]
fn header_fields_and_unit_systems_per_round() {
    let r4 = read_dat(
        &example_dat(ExampleStyle::R4Uscs, 5, false),
        "A1320run125.dat",
    )
    .unwrap();
    assert_eq!((r4.meta.project, r4.meta.run), (Some(1320), Some(125)));
    assert_eq!(r4.meta.iso_flag, None);
    assert_eq!(r4.meta.unit_system(), Some(UnitSystem::Uscs));
    assert_eq!(r4.meta.format, SourceFormat::Dat);

    // Round-4 SI: every unit SI except AMBTMP in deg F -> mixed, and per-column systems say so.
    let r4si = read_dat(
        &example_dat(ExampleStyle::R4Si, 5, false),
        "B1320run125.dat",
    )
    .unwrap();
    assert_eq!(r4si.meta.unit_system(), None);
    let amb = r4si
        .meta
        .columns
        .iter()
        .find(|c| c.name == "AMBTMP")
        .unwrap();
    assert_eq!(
        (amb.unit, amb.system),
        (Some(Unit::DegF), Some(UnitSystem::Uscs))
    );
    assert_close(
        "AMBTMP degC",
        r4si.ambient_temp_c.as_ref().unwrap()[0],
        24.0,
        0.003,
    );

    let r8 = read_dat(&example_dat(ExampleStyle::R8Uscs, 5, false), "x.dat").unwrap();
    assert_eq!((r8.meta.project, r8.meta.run), (Some(1965), Some(51)));
    assert_eq!(r8.meta.date.as_deref(), Some("08-01-2018"));
    assert_eq!(r8.meta.time.as_deref(), Some("19:19"));
    assert_eq!(r8.meta.iso_flag, Some(false));
    assert_eq!(r8.meta.id.as_deref(), Some("3Scoi1N"));
    assert!(r8.meta.columns.iter().any(|c| c.name == "AmbTmp"));

    let r9 = read_dat(&example_dat(ExampleStyle::R9Si, 5, false), "x.dat").unwrap();
    assert_eq!(
        r9.meta.tire_name.as_deref(),
        Some("Example 16.0X7.5-10, R20, C2000")
    );
    assert_eq!(r9.meta.rim_width_in, Some(7.0));
    assert_eq!(r9.meta.unit_system(), Some(UnitSystem::Si));
}

/// A hand-written R4 US-customary file: the "250 lb step reads ~1112 N" check.
const R4_USCS_TWO_ROWS: &str = "TIRF Data File: Project 1320; Run 125\n\
ET\tV\tN\tSA\tIA\tRL\tRE\tP\tFX\tFY\tFZ\tMX\tMZ\tNFX\tNFY\tRST\tTSTI\tTSTC\tTSTO\tAMBTMP\tSR\n\
sec\tmph\trpm\tdeg\tdeg\tin\tin\tpsi\tlb\tlb\tlb\tft-lb\tft-lb\tnone\tnone\tdeg F\tdeg F\tdeg F\tdeg F\tdeg F\tnone\n\
26.840\t25.00\t370.12\t-4.000\t2.000\t8.50\t8.80\t12.00\t3.00\t-150.00\t-250.00\t10.00\t-5.00\t-0.0120\t0.6000\t86.00\t140.00\t135.00\t130.00\t77.00\t0.0000\n\
26.860\t25.00\t370.12\t-3.992\t2.000\t8.50\t8.80\t12.00\t3.00\t-150.00\t-250.00\t10.00\t-5.00\t-0.0120\t0.6000\t86.00\t140.00\t135.00\t130.00\t77.00\t0.0000\n";

#[test]
fn us_customary_values_convert_to_si_iso_w() {
    let run = read_dat(R4_USCS_TWO_ROWS.as_bytes(), "A1320run125.dat").unwrap();
    let t = &run.tire;
    assert_close("Fz 250 lb", t.fz_n[0], 1_112.055_403_815_125, 1e-9);
    assert_close("Fy", t.fy_n[0], 150.0 * 4.448_221_615_260_5, 1e-9);
    assert_close("Fx", t.fx_n[0], 3.0 * 4.448_221_615_260_5, 1e-9);
    assert_close("Mx", t.mx_nm[0], 10.0 * 1.355_817_948_331_400_4, 1e-9);
    assert_close("Mz", t.mz_nm[0], 5.0 * 1.355_817_948_331_400_4, 1e-9);
    assert_close("alpha = -SA", t.alpha_rad[0], 4f64.to_radians(), 1e-15);
    assert_close("gamma = IA", t.gamma_rad[0], 2f64.to_radians(), 1e-15);
    assert_close("V", run.speed_kph[0], 40.2336, 1e-9);
    assert_close("P", run.pressure_kpa[0], 82.737_087_518_020_33, 1e-9);
    assert_close(
        "RL",
        run.loaded_radius_m.as_ref().unwrap()[0],
        0.2159,
        1e-12,
    );
    assert_close(
        "TSTC",
        run.tread_centre_temp_c.as_ref().unwrap()[0],
        57.222_222_222,
        1e-6,
    );
    assert_close(
        "AMBTMP",
        run.ambient_temp_c.as_ref().unwrap()[0],
        25.0,
        1e-12,
    );
    assert_close("ET start", run.et_s[0], 26.84, 1e-12);
    assert_eq!(run.meta.kappa_source, KappaSource::NoSl);
    assert!(t.my_nm.is_empty());
    // NFX, NFY and SR stay as measured.
    assert_eq!(run.nfy.as_ref().unwrap()[0], 0.6);
    assert_eq!(run.sr.as_ref().unwrap()[0], 0.0);
}

#[test]
fn iso_true_file_is_taken_as_iso_w_without_flipping() {
    let text = R4_USCS_TWO_ROWS
        .replace("Run 125", "Run 125; ISO True")
        .replace("-250.00", "250.00");
    let run = read_dat(text.as_bytes(), "iso.dat").unwrap();
    assert_eq!(run.meta.iso_flag, Some(true));
    assert_close("Fz kept", run.tire.fz_n[0], 1_112.055_403_815_125, 1e-9);
    assert_close(
        "alpha kept",
        run.tire.alpha_rad[0],
        -4f64.to_radians(),
        1e-15,
    );
    assert!(run.meta.warnings.is_empty(), "{:?}", run.meta.warnings);
    // The same file flagged ISO but with SAE loads is suspicious, and says so.
    let wrong = R4_USCS_TWO_ROWS.replace("Run 125", "Run 125; ISO True");
    let run = read_dat(wrong.as_bytes(), "iso.dat").unwrap();
    assert!(
        run.meta.warnings.iter().any(|w| w.contains("FZ")),
        "{:?}",
        run.meta.warnings
    );
}

#[test]
fn spreadsheet_damage_crlf_bom_and_missing_final_newline_are_accepted() {
    let clean = read_dat(&example_dat(ExampleStyle::R8Uscs, 50, false), "clean.dat").unwrap();
    let text = String::from_utf8(example_dat(ExampleStyle::R8Uscs, 50, false)).unwrap();
    // Spreadsheet re-save: line 1 and line 2/3 padded with tabs, trailing zeros dropped
    // (`0.000` -> `0`, `25.00` -> `25`, `8.20` -> `8.2`), CRLF, BOM, no final newline.
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(k, line)| match k {
            0..=2 => format!("{line}\t\t\t"),
            _ => line
                .split('\t')
                .map(|cell| {
                    let t = cell.trim_end_matches('0');
                    t.strip_suffix('.').unwrap_or(t).to_string()
                })
                .map(|c| {
                    if c.is_empty() || c == "-" {
                        "0".to_string()
                    } else {
                        c
                    }
                })
                .collect::<Vec<_>>()
                .join("\t"),
        })
        .collect();
    let damaged = format!("\u{feff}{}", lines.join("\r\n"));
    let run = read_dat(damaged.as_bytes(), "damaged.dat").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(run.len(), clean.len());
    assert_eq!(run.meta.project, clean.meta.project);
    assert_eq!(run.meta.id, clean.meta.id);
    // Same numbers (exact: "25" and "25.00" parse to the same f64).
    assert_eq!(run.tire, clean.tire);
    assert_eq!(run.et_s, clean.et_s);
    assert!(run.meta.warnings.is_empty(), "{:?}", run.meta.warnings);
}

#[test]
fn columns_in_any_order_any_case_with_extra_channels_kept() {
    let mut columns = example_columns(ExampleStyle::R9Si, 20, true);
    columns.reverse();
    for column in &mut columns {
        column.name = column.name.to_ascii_lowercase();
    }
    columns.insert(
        5,
        DatColumn {
            name: "HUMID".into(),
            unit: "%".into(),
            decimals: 1,
            values: (0..20).map(|i| 40.0 + f64::from(i)).collect(),
        },
    );
    let bytes = render_dat(&ExampleStyle::R9Si.line1(), &columns);
    let run = read_dat(&bytes, "shuffled.dat").unwrap_or_else(|e| panic!("{e}"));
    let reference = read_dat(&example_dat(ExampleStyle::R9Si, 20, true), "ref.dat").unwrap();
    assert_eq!(run.tire, reference.tire);
    assert_eq!(run.ambient_temp_c, reference.ambient_temp_c);
    assert_eq!(run.sl, reference.sl);
    assert_eq!(run.meta.columns.len(), 23);
    assert_eq!(run.extras.len(), 1);
    assert_eq!(run.extras[0].name, "HUMID");
    assert_eq!(run.extras[0].unit, "%");
    assert_eq!(run.extras[0].values[3], 43.0);
}

#[test]
fn truncated_last_line_is_dropped_with_a_warning_and_elsewhere_is_an_error() {
    let text = String::from_utf8(example_dat(ExampleStyle::R8Uscs, 10, false)).unwrap();
    let full = read_dat(text.as_bytes(), "t.dat").unwrap();
    let trimmed = text.trim_end();
    for cut in [8, 20, 60] {
        let truncated = &trimmed[..trimmed.len() - cut];
        let run = read_dat(truncated.as_bytes(), "t.dat").unwrap_or_else(|e| panic!("{e}"));
        // A cut that happens to leave a full-width, valid last row is undetectable; these cuts
        // all remove whole cells.
        assert_eq!(run.len(), 9, "cut {cut}");
        assert_eq!(run.et_s[..], full.et_s[..9]);
        assert_eq!(run.meta.warnings.len(), 1, "{:?}", run.meta.warnings);
        assert!(run.meta.warnings[0].starts_with("line 13: truncated last line"));
    }
    // A last line ending in an empty cell (cut right after a tab) is also a truncation.
    let tab_cut = &trimmed[..trimmed.rfind('\t').unwrap() + 1];
    assert_eq!(read_dat(tab_cut.as_bytes(), "t.dat").unwrap().len(), 9);
    // The same short row in the middle is an error naming its line.
    let mut lines: Vec<&str> = text.lines().collect();
    let short = &lines[12][..lines[12].len() - 20];
    lines.insert(6, short);
    let err = read_dat(lines.join("\n").as_bytes(), "t.dat").unwrap_err();
    assert!(
        err.to_string()
            .starts_with("t.dat: line 7: expected 21 cells, found"),
        "{err}"
    );
}

#[test]
fn a_large_file_parsed_in_two_halves_equals_and_errs_like_one_pass() {
    // Over 1 MiB of rows: parsed in two halves on two threads.
    let text = String::from_utf8(example_dat(ExampleStyle::R8Uscs, 12_000, false)).unwrap();
    assert!(text.len() > 1 << 20, "{} bytes", text.len());
    let run = read_dat(text.as_bytes(), "big.dat").unwrap();
    assert_eq!(run.len(), 12_000);
    assert!(
        run.et_s.windows(2).all(|w| w[1] > w[0]),
        "rows out of order"
    );
    let small = read_dat(
        example_dat(ExampleStyle::R8Uscs, 10, false).as_slice(),
        "small.dat",
    )
    .unwrap();
    assert_eq!(run.tire.fy_n[..10], small.tire.fy_n[..]);
    // A bad cell in either half names its own line of the whole file (line 4 is row 1).
    let lines: Vec<&str> = text.lines().collect();
    for row in [100, 9_000] {
        let mut bad = lines.clone();
        let broken = bad[3 + row].replacen('\t', "\tx", 1);
        bad[3 + row] = &broken;
        let err = read_dat(bad.join("\n").as_bytes(), "big.dat").unwrap_err();
        let want = format!("big.dat: line {}, column 2 ", 4 + row);
        assert!(err.to_string().starts_with(&want), "{err} (want {want})");
    }
    // A truncated last line still warns with its line number.
    let cut = &text.trim_end()[..text.trim_end().len() - 30];
    let run = read_dat(cut.as_bytes(), "big.dat").unwrap();
    assert_eq!(run.len(), 11_999);
    assert!(run.meta.warnings[0].starts_with("line 12003: truncated last line"));
}

#[test]
fn blank_trailing_lines_are_ignored() {
    let mut bytes = example_dat(ExampleStyle::R4Uscs, 10, false);
    bytes.extend_from_slice(b"\n\r\n  \n");
    let run = read_dat(&bytes, "t.dat").unwrap();
    assert_eq!(run.len(), 10);
    assert!(run.meta.warnings.is_empty());
}

#[test]
fn file_name_fills_project_and_run_when_line1_lacks_them() {
    let text = R4_USCS_TWO_ROWS.replace("Project 1320; Run 125", "");
    let run = read_dat(text.as_bytes(), "some/dir/B1464raw7.dat").unwrap();
    assert_eq!((run.meta.project, run.meta.run), (Some(1464), Some(7)));
    let name = run.meta.file_name.unwrap();
    assert_eq!((name.prefix, name.raw), (Some('B'), true));
}

mod cell_exactness {
    use super::*;
    use proptest::prelude::*;

    /// A numeric cell as TIRF or a spreadsheet might write it: fixed decimals, a bare integer,
    /// a leading `+`, an exponent, or a long mantissa.
    fn cell() -> impl Strategy<Value = String> {
        prop_oneof![
            8 => (any::<bool>(), 0u64..100_000, 0u32..6, any::<u64>()).prop_map(|(neg, int, dec, frac)| {
                let sign = if neg { "-" } else { "" };
                if dec == 0 {
                    format!("{sign}{int}")
                } else {
                    let frac = frac % 10u64.pow(dec);
                    format!("{sign}{int}.{frac:0width$}", width = dec as usize)
                }
            }),
            1 => any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| format!("{v:e}")),
            1 => any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| format!("+{}", v.abs())),
            1 => "[0-9]{15,25}\\.[0-9]{1,10}",
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Every cell of a file (kept unconverted as an extra channel) is bit-identical to
        /// `str::parse::<f64>` of its text.
        #[test]
        fn every_cell_equals_std_parse(
            cells in proptest::collection::vec(proptest::collection::vec(cell(), 6), 1..40),
        ) {
            let required = "ET\tV\tP\tSA\tIA\tFX\tFY\tFZ\tMX\tMZ";
            let units = "s\tkph\tkPa\tdeg\tdeg\tN\tN\tN\tNm\tNm";
            let mut text = format!(
                "TIRF Data File: Project 1; Run 1\n{required}\tX1\tX2\tX3\tX4\tX5\tX6\n\
                 {units}\tnone\tnone\tnone\tnone\tnone\tnone\n"
            );
            for row in &cells {
                text.push_str("0.010\t40.0\t83.0\t1.0\t0.0\t1.0\t2.0\t-3.0\t4.0\t5.0");
                for cell in row {
                    text.push('\t');
                    text.push_str(cell);
                }
                text.push('\n');
            }
            let run = read_dat(text.as_bytes(), "p.dat").map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(run.extras.len(), 6);
            for (r, row) in cells.iter().enumerate() {
                for (c, cell) in row.iter().enumerate() {
                    let want: f64 = cell.parse().unwrap();
                    let got = run.extras[c].values[r];
                    prop_assert_eq!(got.to_bits(), want.to_bits(), "cell {:?}", cell);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// MAT

fn sample_values() -> Vec<MatValue> {
    vec![
        MatValue::column(vec![0.0, -1.5, 1e300, f64::MIN_POSITIVE, -0.0]),
        MatValue::Numeric {
            class: NumericClass::Uint8,
            dims: vec![4, 1],
            data: vec![0.0, 1.0, 200.0, 255.0],
        },
        MatValue::Numeric {
            class: NumericClass::Int16,
            dims: vec![1, 3],
            data: vec![-32768.0, 0.0, 32767.0],
        },
        MatValue::Numeric {
            class: NumericClass::Double,
            dims: vec![2, 3],
            data: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        },
        MatValue::text("Hoosier 43100 18.0x6.0-10 R20, 7 inch rim"),
        MatValue::text("Drive/Brake/Combined \u{00b0}C"),
        MatValue::text(""),
        MatValue::text_cells(&["ET", "AMBTMP", "SL"]),
        MatValue::Struct {
            dims: vec![1, 1],
            fields: vec!["name".into(), "units".into()],
            values: vec![
                MatValue::text_cells(&["ET", "FZ"]),
                MatValue::text_cells(&["sec", "N"]),
            ],
        },
        MatValue::Cell {
            dims: vec![1, 2],
            items: vec![
                MatValue::column(vec![]),
                MatValue::Cell {
                    dims: vec![1, 1],
                    items: vec![MatValue::text("nested")],
                },
            ],
        },
    ]
}

#[test]
fn mat_writer_round_trips_through_the_reader() {
    for compression in [Compression::None, Compression::Zlib] {
        let mut writer = MatWriter::new("MATLAB 5.0 MAT-file, Platform: tirebase test");
        let values = sample_values();
        for (k, value) in values.iter().enumerate() {
            writer.push(&format!("v{k}"), value, compression).unwrap();
        }
        let bytes = writer.finish();
        let file = parse_mat(&bytes, "rt.mat").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            file.header_text,
            "MATLAB 5.0 MAT-file, Platform: tirebase test"
        );
        assert!(!file.big_endian);
        assert_eq!(file.variables.len(), values.len());
        for (k, (variable, value)) in file.variables.iter().zip(&values).enumerate() {
            assert_eq!(variable.name, format!("v{k}"));
            // Bit-exact (including -0.0): compare the f64 bit patterns.
            assert_eq!(
                format!("{:?}", variable.value),
                format!("{value:?}"),
                "v{k}"
            );
            assert_eq!(&variable.value, value, "v{k}");
        }
    }
}

#[test]
fn mat_writer_is_deterministic_and_validates() {
    let make = || {
        let mut writer = MatWriter::new("MATLAB 5.0 MAT-file");
        for (k, value) in sample_values().iter().enumerate() {
            writer
                .push(&format!("v{k}"), value, Compression::Zlib)
                .unwrap();
        }
        writer.finish()
    };
    assert_eq!(make(), make());
    let mut writer = MatWriter::new("MATLAB 5.0 MAT-file");
    assert!(
        writer
            .push("1bad", &MatValue::text("x"), Compression::None)
            .is_err()
    );
    assert!(writer.push_column("ET", &[1.0], Compression::None).is_ok());
    assert!(writer.push_column("ET", &[1.0], Compression::None).is_err());
    let out_of_range = MatValue::Numeric {
        class: NumericClass::Uint8,
        dims: vec![1, 1],
        data: vec![256.0],
    };
    let err = writer
        .push("RUN", &out_of_range, Compression::None)
        .unwrap_err();
    assert!(err.to_string().contains("does not fit uint8"), "{err}");
    let wrong_dims = MatValue::Numeric {
        class: NumericClass::Double,
        dims: vec![3, 1],
        data: vec![1.0],
    };
    assert!(writer.push("X", &wrong_dims, Compression::None).is_err());
}

#[test]
fn mat_run_equals_the_dat_run_of_the_same_data() {
    let dat = read_dat(
        &example_dat(ExampleStyle::R4Si, 400, true),
        "B1320run125.dat",
    )
    .unwrap();
    for compression in [Compression::None, Compression::Zlib] {
        let mat = read_mat(&example_mat(400, compression), "B1320run125.mat")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mat.meta.format, SourceFormat::Mat);
        assert_eq!(mat.tire, dat.tire);
        assert_eq!(mat.et_s, dat.et_s);
        assert_eq!(mat.ambient_temp_c, dat.ambient_temp_c);
        assert_eq!(mat.sl, dat.sl);
        assert_eq!(mat.sr, dat.sr);
        assert_eq!(mat.meta.testid.as_deref(), Some("Cornering"));
        assert_eq!(
            mat.meta.tire_name.as_deref(),
            Some("Example 18.0x6.0-10 R20")
        );
        assert_eq!(mat.meta.rim_width_in, Some(7.0));
        assert_eq!(mat.meta.source.as_deref(), Some("example"));
        assert_eq!((mat.meta.project, mat.meta.run), (Some(1320), Some(125)));
        assert_eq!(mat.extras.len(), 1);
        assert_eq!(mat.extras[0].name, "RUN");
        assert!(mat.extras[0].values.iter().all(|v| *v == 7.0));
        assert!(
            mat.meta
                .columns
                .iter()
                .all(|c| c.unit_from_file == c.channel.is_some())
        );
        assert!(mat.meta.warnings.is_empty(), "{:?}", mat.meta.warnings);
    }
}

#[test]
fn mat_without_channel_struct_falls_back_to_si_and_says_so() {
    let mut writer = MatWriter::new("MATLAB 5.0 MAT-file");
    for channel in TtcChannel::ALL {
        let values: Vec<f64> = (0..5)
            .map(|i| {
                channel
                    .si_fallback_unit()
                    .from_canonical(example_value(channel, i, 100.0))
            })
            .collect();
        writer
            .push_column(channel.name(), &values, Compression::None)
            .unwrap();
    }
    let run = read_mat(&writer.finish(), "nounits.mat").unwrap();
    assert!(run.meta.columns.iter().all(|c| !c.unit_from_file));
    assert_eq!(run.meta.unit_system(), Some(UnitSystem::Si));
    let unit_lines: Vec<&String> = run
        .meta
        .warnings
        .iter()
        .filter(|w| w.contains("unit"))
        .collect();
    assert_eq!(unit_lines.len(), 1, "said once: {unit_lines:?}");
    assert!(unit_lines[0].contains("no unit metadata (no channel struct)"));
    // SL present but all zero would give SlAllZero; here it is the example slip, so Sl.
    assert_eq!(run.meta.kappa_source, KappaSource::Sl);
    assert_close("Fz", run.tire.fz_n[0], 1112.06, 1e-9);
}

#[test]
fn mat_sl_all_zero_means_kappa_not_measured() {
    let mut writer = MatWriter::new("MATLAB 5.0 MAT-file");
    for channel in TtcChannel::ALL {
        let values: Vec<f64> = (0..5)
            .map(|i| match channel {
                TtcChannel::Sl => 0.0,
                _ => channel
                    .si_fallback_unit()
                    .from_canonical(example_value(channel, i, 100.0)),
            })
            .collect();
        writer
            .push_column(channel.name(), &values, Compression::Zlib)
            .unwrap();
    }
    let run = read_mat(&writer.finish(), "cornering.mat").unwrap();
    assert_eq!(run.meta.kappa_source, KappaSource::SlAllZero);
    assert!(!run.meta.kappa_source.is_measured());
    assert!(run.tire.kappa.iter().all(|k| *k == 0.0));
    // SR is not used as kappa even though it is non-zero.
    assert!(run.sr.as_ref().unwrap().iter().any(|s| *s != 0.0));
}

/// A big-endian file written by hand: one 2 x 1 double and one char array.
#[test]
fn big_endian_files_decode() {
    let mut bytes = b"MATLAB 5.0 MAT-file, big endian".to_vec();
    bytes.resize(116, b' ');
    bytes.extend_from_slice(&[0; 8]);
    bytes.extend_from_slice(&0x0100u16.to_be_bytes());
    bytes.extend_from_slice(b"MI");
    let be = |v: u32| v.to_be_bytes();
    let mut element = Vec::new();
    element.extend(be(6)); // flags: miUINT32, 8 bytes
    element.extend(be(8));
    element.extend(be(6)); // double class
    element.extend(be(0));
    element.extend(be(5)); // dims: miINT32, 8 bytes
    element.extend(be(8));
    element.extend(be(2));
    element.extend(be(1));
    element.extend(be((2 << 16) | 1)); // name: small miINT8, 2 bytes
    element.extend(b"ET\0\0");
    element.extend(be(9)); // miDOUBLE, 16 bytes
    element.extend(be(16));
    element.extend(1.5f64.to_be_bytes());
    element.extend((-2.25f64).to_be_bytes());
    bytes.extend(be(14));
    bytes.extend(be(element.len() as u32));
    bytes.extend(&element);
    let file = parse_mat(&bytes, "be.mat").unwrap_or_else(|e| panic!("{e}"));
    assert!(file.big_endian);
    assert_eq!(file.variables[0].name, "ET");
    assert_eq!(file.variables[0].value.as_vector(), Some(&[1.5, -2.25][..]));
}

/// A fixture file read from disk and parsed with [`read_run`] (the library reads no files).
fn read_path(path: &std::path::Path) -> Result<RunTable, TtcError> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    read_run(&bytes, &path.display().to_string())
}

#[test]
fn files_from_the_independent_python_encoder_read_correctly() {
    let dir = repo_root().join("tests/fixtures/ttc");
    let dat = read_path(&dir.join("example_A1965run51.dat")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(dat.len(), 12);
    assert_close("Fz", dat.tire.fz_n[0], 250.0 * 4.448_221_615_260_5, 1e-9);
    for name in [
        "example_B1320run15.mat",
        "example_B1320run16_compressed.mat",
    ] {
        let mat = read_path(&dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mat.len(), 12, "{name}");
        assert_eq!(
            mat.meta.tire_name.as_deref(),
            Some("Example 18.0x6.0-10 R20")
        );
        assert_eq!(mat.meta.kappa_source, KappaSource::SlAllZero);
        assert_eq!(mat.extras[0].name, "RUN");
        // The same signal as the .dat, written in SI: agreement to the written decimals.
        for i in 0..12 {
            assert_close(
                "Fz",
                mat.tire.fz_n[i],
                dat.tire.fz_n[i],
                0.005 + 0.005 * 4.45,
            );
            assert_close("alpha", mat.tire.alpha_rad[i], dat.tire.alpha_rad[i], 1e-5);
            assert_close(
                "amb",
                mat.ambient_temp_c.as_ref().unwrap()[i],
                23.888_9,
                1e-3,
            );
        }
    }
}

/// Files written by scipy.io.savemat (an encoder we share nothing with); see
/// tests/fixtures/ttc/README.md for the script.
#[test]
fn files_written_by_scipy_decode() {
    let dir = repo_root().join("tests/fixtures/ttc");
    let bytes = std::fs::read(dir.join("scipy_savemat_compressed.mat")).unwrap();
    let file = parse_mat(&bytes, "scipy.mat").unwrap_or_else(|e| panic!("{e}"));
    let get = |name: &str| {
        &file
            .variables
            .iter()
            .find(|v| v.name == name)
            .unwrap()
            .value
    };
    assert_eq!(get("ET").as_vector(), Some(&[0.0, 1.0, 2.0, 3.0, 4.0][..]));
    assert!(matches!(
        get("RUN"),
        MatValue::Numeric {
            class: NumericClass::Uint8,
            ..
        }
    ));
    assert_eq!(get("RUN").as_vector(), Some(&[3.0; 5][..]));
    assert_eq!(
        get("tireid").as_text().as_deref(),
        Some("Hoosier X, 7 inch rim")
    );
    let channel = get("channel");
    let MatValue::Cell { items, .. } = channel.field("units").unwrap() else {
        panic!("units is not a cell: {channel:?}");
    };
    assert_eq!(items[0].as_text().as_deref(), Some("sec"));

    let bytes = std::fs::read(dir.join("scipy_savemat_plain.mat")).unwrap();
    let file = parse_mat(&bytes, "scipy.mat").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file.variables.len(), 2);
    assert_eq!(file.variables[1].value, MatValue::text_cells(&["ET", "FZ"]));
}

// ---------------------------------------------------------------------------------------------
// The malformed corpus

/// One row of `tests/fixtures/bad/README.md`.
struct CorpusCase {
    file: String,
    outcome: String,
    expected: String,
}

fn corpus_cases() -> Vec<CorpusCase> {
    let readme = std::fs::read_to_string(repo_root().join("tests/fixtures/bad/README.md"))
        .expect("bad corpus README");
    readme
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|line| {
            let cells: Vec<&str> = line.trim_matches('|').split(" | ").map(str::trim).collect();
            let unquote = |s: &str| s.trim_matches('`').to_string();
            CorpusCase {
                file: unquote(cells[0]),
                outcome: cells[1].to_string(),
                expected: unquote(cells[2]),
            }
        })
        .collect()
}

#[test]
fn bad_corpus_every_file_gives_its_documented_outcome() {
    let dir = repo_root().join("tests/fixtures/bad");
    let cases = corpus_cases();
    assert!(cases.len() >= 20, "corpus has {} rows", cases.len());
    for case in &cases {
        let source_name = format!("tests/fixtures/bad/{}", case.file);
        let bytes = std::fs::read(dir.join(&case.file)).expect(&case.file);
        let result = read_run(&bytes, &source_name);
        match (case.outcome.as_str(), result) {
            ("error", Err(e)) => {
                let message = e.to_string();
                println!("{message}");
                assert!(!message.contains('\n'), "{message}");
                assert!(
                    message.starts_with(&format!("{source_name}: ")),
                    "{message}"
                );
                assert!(
                    message.contains(&case.expected),
                    "{}: message {message:?} lacks {:?}",
                    case.file,
                    case.expected
                );
            }
            ("qc", Ok(run)) => {
                assert!(run.len() >= 10, "{}", case.file);
                assert!(
                    run.meta.warnings.is_empty(),
                    "{}: {:?}",
                    case.file,
                    run.meta.warnings
                );
            }
            ("warning", Ok(run)) => {
                assert!(
                    run.meta.warnings.iter().any(|w| w.contains(&case.expected)),
                    "{}: {:?}",
                    case.file,
                    run.meta.warnings
                );
            }
            (outcome, result) => panic!(
                "{}: documented as {outcome}, got {:?}",
                case.file,
                result.map(|r| r.meta.warnings)
            ),
        }
    }
}

#[test]
fn bad_corpus_readme_lists_every_file() {
    let listed: Vec<String> = corpus_cases().into_iter().map(|c| c.file).collect();
    let dir = repo_root().join("tests/fixtures/bad");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "README.md")
        .collect();
    on_disk.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(on_disk, sorted);
}

// ---------------------------------------------------------------------------------------------
// Mutation fuzzing (deterministic)

/// The seeded generator that drives mutations reproducibly, with an index draw.
struct SplitMix(SplitMix64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Apply 1-4 random edits: flip bits, overwrite bytes with interesting values, insert, delete,
/// truncate, duplicate a span.
fn mutate(seed: &[u8], rng: &mut SplitMix) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    let interesting = [
        0u8, 0xFF, 0x7F, 0x80, b'\t', b'\n', b'-', b'.', b'0', b'9', b'e', 14, 15,
    ];
    for _ in 0..1 + rng.below(4) {
        if bytes.is_empty() {
            bytes.push(rng.next() as u8);
            continue;
        }
        let at = rng.below(bytes.len());
        match rng.below(7) {
            0 => bytes[at] ^= 1 << rng.below(8),
            1 => bytes[at] = interesting[rng.below(interesting.len())],
            2 => bytes.insert(at, rng.next() as u8),
            3 => {
                bytes.remove(at);
            }
            4 => bytes.truncate(at),
            5 => {
                let end = (at + 1 + rng.below(64)).min(bytes.len());
                let span = bytes[at..end].to_vec();
                let to = rng.below(bytes.len());
                bytes.splice(to..to, span);
            }
            _ => {
                // Overwrite a 4-byte word (lengths, types, dims in MAT-files) with a random value.
                let end = (at + 4).min(bytes.len());
                let word = rng.next().to_le_bytes();
                bytes[at..end].copy_from_slice(&word[..end - at]);
            }
        }
    }
    bytes
}

fn check_no_panic_and_sane(bytes: &[u8], name: &str) {
    match read_run(bytes, name) {
        Ok(run) => {
            let n = run.len();
            assert!(n > 0);
            assert_eq!(run.et_s.len(), n);
            assert_eq!(run.tire.fz_n.len(), n);
            assert_eq!(run.tire.kappa.len(), n);
            assert!(run.extras.iter().all(|e| e.values.len() == n));
            assert!(
                run.meta.warnings.iter().all(|w| !w.contains('\n')),
                "{:?}",
                run.meta.warnings
            );
            assert!(run.et_s.iter().all(|v| v.is_finite()) || name.ends_with(".mat"));
        }
        Err(e) => {
            let message = e.to_string();
            assert!(message.starts_with(name), "{message}");
            assert!(!message.contains('\n'), "{message:?}");
            assert!(message.len() < 600, "{message}");
        }
    }
}

#[test]
fn random_mutations_of_valid_files_never_panic() {
    let seeds: Vec<(&str, Vec<u8>)> = vec![
        ("m.dat", example_dat(ExampleStyle::R4Uscs, 6, false)),
        ("m.dat", example_dat(ExampleStyle::R9Si, 6, true)),
        ("m.mat", example_mat(6, Compression::None)),
        ("m.mat", example_mat(6, Compression::Zlib)),
    ];
    let mut rng = SplitMix(SplitMix64::new(0x7715_ba5e));
    let mut outcomes = [0usize; 2];
    for round in 0..4000 {
        let (name, seed) = &seeds[round % seeds.len()];
        let mutated = mutate(seed, &mut rng);
        check_no_panic_and_sane(&mutated, name);
        outcomes[usize::from(read_run(&mutated, name).is_ok())] += 1;
    }
    // Both outcomes must occur, or the mutations are not exercising anything.
    assert!(outcomes[0] > 100 && outcomes[1] > 100, "{outcomes:?}");
}

#[test]
fn every_truncation_of_a_mat_file_is_an_error_naming_an_element() {
    for compression in [Compression::None, Compression::Zlib] {
        let bytes = example_mat(3, compression);
        for len in 0..bytes.len() {
            let err = read_mat(&bytes[..len], "cut.mat");
            // Cutting exactly between elements leaves a valid (shorter) file only once the
            // channels are complete; any earlier cut must fail.
            if let Err(e) = err {
                let message = e.to_string();
                assert!(message.starts_with("cut.mat: "), "{message}");
            }
        }
    }
}
