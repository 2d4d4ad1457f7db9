//! Reader and writer tests: the hand-made corpus under `tests/fixtures/tir/` (variants modelled
//! on real files), the `bad/` set, exact write/read round trips (proptest) and no panic on
//! random or mutated input.
//!
//! In: fixture texts compiled in with `include_str!`/`include_bytes!`. Out: assertions.
//! Deliberately not here: physical checks (lint.rs) and the CLI (tests/tir.rs).

use proptest::prelude::*;

use super::{Entry, ExtraKey, ExtraLine, ExtraSection, ShapeTable, TirFile, TyrePressure, Value};
use crate::tire_model::params::{Coef, Coefs, N_COEFS};
use crate::tire_model::{Mode, SlipInput, Version};

macro_rules! fixture {
    ($path:literal) => {
        include_str!(concat!("../../../../tests/fixtures/", $path))
    };
}

const FSAE: &str = fixture!("reference/fsae-demo/fsae_demo_pac2002.tir");
const MFEVAL: &str = fixture!("reference/mfeval-sample/MagicFormula52_Parameters.tir");
const SUPPLIER: &str = fixture!("tir/pac2002_supplier_layout.tir");
const MF05_CRLF: &str = fixture!("tir/mf05_crlf_wrapped_comments.tir");
const MF52: &str = fixture!("tir/mf52_fittyp6.tir");
const EMPTY_VALUES: &str = fixture!("tir/empty_values_and_placeholders.tir");
const D_EXPONENTS: &str = fixture!("tir/d_exponents.tir");
const MM_DEG: &str = fixture!("tir/mm_deg_psi_units.tir");
const UNKNOWN_SECTIONS: &str = fixture!("tir/unknown_sections.tir");

fn read(text: &str) -> (TirFile, Vec<super::ReadWarning>) {
    TirFile::parse(text).unwrap_or_else(|e| panic!("should read: {e}"))
}

/// Every coefficient equal to the bit.
fn assert_same_coefs(a: &Coefs<f64>, b: &Coefs<f64>, what: &str) {
    for c in Coef::ALL {
        assert_eq!(
            a[*c].to_bits(),
            b[*c].to_bits(),
            "{what}: {} {} vs {}",
            c.name(),
            a[*c],
            b[*c]
        );
    }
}

/// Every coefficient within `rel` (relative to max(|b|, 1e-300)).
fn assert_close_coefs(a: &Coefs<f64>, b: &Coefs<f64>, rel: f64, what: &str) {
    for c in Coef::ALL {
        let (x, y) = (a[*c], b[*c]);
        assert!(
            (x - y).abs() <= rel * y.abs().max(1e-300),
            "{what}: {} {x} vs {y}",
            c.name()
        );
    }
}

#[test]
fn fsae_reference_reads_every_key_in_si() {
    let (f, warnings) = read(FSAE);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(f.coefs[Coef::FNOMIN], 1100.0);
    assert_eq!(f.coefs[Coef::PDY1], -2.5);
    assert_eq!(f.coefs[Coef::QSX11], 1.0);
    assert_eq!(
        f.declaration.property_file_format.as_deref(),
        Some("PAC2002")
    );
    assert_eq!(f.declaration.fittyp, None);
    assert_eq!(f.use_mode, Some(4));
    assert_eq!(f.tyre_side.as_deref(), Some("Right"));
    assert!(f.present[Coef::QSX4]);
    assert!(!f.present[Coef::PTX1], "no relaxation keys in the file");
    assert_eq!(f.header_comments.len(), 6, "{:?}", f.header_comments);
}

#[test]
fn supplier_layout_without_fittyp_reads() {
    let (f, warnings) = read(SUPPLIER);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(f.coefs[Coef::FNOMIN], 900.0);
    assert_eq!(f.coefs[Coef::PKY1], -38.5);
    assert_eq!(f.tyre_side.as_deref(), Some("Left"));
    // QSX4..11 absent: MFeval's defaults, which make the extra Mx terms vanish.
    assert!(!f.present[Coef::QSX4]);
    assert_eq!(f.coefs[Coef::QSX7], 0.0);
}

#[test]
fn mf05_crlf_wrapped_comments_read_like_the_lf_original() {
    assert!(MF05_CRLF.contains("\r\n"));
    let (f, warnings) = read(MF05_CRLF);
    let (reference, _) = read(FSAE);
    assert_same_coefs(&f.coefs, &reference.coefs, "MF_05 CRLF");
    assert_eq!(f.declaration.property_file_format.as_deref(), Some("MF_05"));
    assert_eq!(f.tyre_side.as_deref(), Some("RIGHT"), "unquoted string");
    let wrapped: Vec<_> = warnings
        .iter()
        .filter(|w| w.message.contains("wrapped end of a comment"))
        .collect();
    assert_eq!(wrapped.len(), 3, "{warnings:?}");
    assert_eq!(warnings.len(), 3, "{warnings:?}");
}

#[test]
fn mf52_fittyp6_with_shape_and_relaxation_reads() {
    let (f, warnings) = read(MF52);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(f.declaration.fittyp, Some(6));
    assert_eq!(f.use_mode, Some(14));
    let shape = f.shape.as_ref().expect("[SHAPE]");
    assert_eq!(shape.columns, ["radial", "width"]);
    assert_eq!(shape.rows.len(), 4);
    assert_eq!(f.coefs[Coef::PTX1], 1.1898);
    let extra: Vec<&str> = f.extra_keys.iter().map(|k| k.entry.key.as_str()).collect();
    assert_eq!(
        extra,
        [
            "USER_SUB_ID",
            "N_TIRE_STATES",
            "MFSAFE1",
            "MFSAFE2",
            "MFSAFE3"
        ]
    );
    let (sample, _) = read(MFEVAL);
    assert_same_coefs(&f.coefs, &sample.coefs, "MF52 vs MFeval sample");
}

#[test]
fn empty_values_use_defaults_with_a_warning_and_placeholders_stay() {
    let (f, warnings) = read(EMPTY_VALUES);
    assert!(!f.present[Coef::PEX4]);
    assert_eq!(f.coefs[Coef::PEX4], Coef::PEX4.default_value());
    assert!(!f.present[Coef::QTZ1]);
    assert_eq!(f.coefs[Coef::FZMAX], 1e30);
    assert!(
        warnings
            .iter()
            .any(|w| w.message.contains("PEX4 has no value"))
    );
    let mfsafe = f
        .extra_keys
        .iter()
        .find(|k| k.entry.key == "MFSAFE3")
        .expect("empty unknown key kept");
    assert_eq!(mfsafe.entry.value, Value::Empty);
    assert!(
        f.extra_keys
            .iter()
            .any(|k| k.entry.key == "QSX12" && k.section == "OVERTURNING_COEFFICIENTS")
    );
    assert!(
        f.extra_keys
            .iter()
            .any(|k| k.entry.key == "Q_A1" && k.section == "VERTICAL")
    );
}

#[test]
fn d_exponents_read_exactly() {
    let (f, warnings) = read(D_EXPONENTS);
    assert!(warnings.is_empty(), "{warnings:?}");
    let (reference, _) = read(FSAE);
    assert_same_coefs(&f.coefs, &reference.coefs, "D exponents");
}

#[test]
fn mm_deg_psi_units_convert_to_the_si_original() {
    let (f, warnings) = read(MM_DEG);
    let (reference, _) = read(FSAE);
    let mut expected = reference.coefs.clone();
    // The file states the ranges as 15 and 5 degrees exactly (the original rounds to 1e-6 rad).
    expected[Coef::ALPMIN] = -15f64.to_radians();
    expected[Coef::ALPMAX] = 15f64.to_radians();
    expected[Coef::CAMMIN] = -5f64.to_radians();
    expected[Coef::CAMMAX] = 5f64.to_radians();
    assert_close_coefs(&f.coefs, &expected, 1e-15, "mm/deg/psi");
    let ip = f.pressure.inflation_pa.expect("IP");
    assert!((ip - 82_737.087_518_021_6).abs() < 1e-6, "{ip}");
    assert!(
        warnings.iter().any(|w| w.message.contains("per radian")),
        "{warnings:?}"
    );
    // Same forces as the SI original inside the ranges.
    let input = SlipInput {
        fz_n: 1100.0,
        kappa: 0.05,
        alpha_rad: -0.08,
        gamma_rad: 0.03,
        vx_mps: 11.176,
    };
    let a = f.model().eval(&input, Mode::Limits);
    let b = reference.model().eval(&input, Mode::Limits);
    for (x, y) in [
        (a.fx_n, b.fx_n),
        (a.fy_n, b.fy_n),
        (a.mz_nm, b.mz_nm),
        (a.my_nm, b.my_nm),
    ] {
        assert!((x - y).abs() <= 1e-12 * y.abs().max(1.0), "{x} vs {y}");
    }
}

#[test]
fn unknown_sections_are_kept_in_order_and_written_back() {
    let (f, warnings) = read(UNKNOWN_SECTIONS);
    assert!(warnings.is_empty(), "{warnings:?}");
    let names: Vec<&str> = f.extra_sections.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["INERTIA", "DEFLECTION_LOAD_CURVE"]);
    assert_eq!(f.extra_sections[1].lines.len(), 5);
    assert_eq!(f.pressure.inflation_pa, Some(82737.0));
    assert_eq!(f.pressure.nominal_pa, Some(82737.0));
    assert!(f.shape.is_some());
    let text = f.render().unwrap();
    assert!(
        text.contains("[TYRE_CONDITIONS]\nIP "),
        "pressure mapped to Adams keys"
    );
    assert!(text.contains("[DEFLECTION_LOAD_CURVE]\n{pen       fz}\n0.000     0.0\n"));
    let (again, _) = read(&text);
    assert_eq!(again.extra_sections, f.extra_sections);
    assert_eq!(again.pressure, f.pressure);
    assert_eq!(again.shape, f.shape);
}

/// One bad file: the error is one line, names `line N`, and N is the expected line.
fn assert_bad(bytes: &[u8], line: usize, contains: &str) {
    let err = TirFile::parse_bytes(bytes).expect_err("must not read");
    let msg = err.to_string();
    assert!(!msg.contains('\n'), "one line: {msg}");
    assert!(msg.starts_with(&format!("line {line}: ")), "{msg}");
    assert_eq!(err.line(), line);
    assert!(msg.contains(contains), "{msg}");
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn bad_files_give_one_line_errors_naming_the_line() {
    let t = fixture!("tir/bad/unterminated_section.tir");
    assert_bad(
        t.as_bytes(),
        line_of(t, "[LATERAL_COEFFICIENTS"),
        "without closing ']'",
    );
    let t = fixture!("tir/bad/non_numeric_value.tir");
    assert_bad(
        t.as_bytes(),
        line_of(t, "PKY2 "),
        "PKY2: expected a finite number, found '1,75'",
    );
    let t = fixture!("tir/bad/fittyp7.tir");
    assert_bad(
        t.as_bytes(),
        line_of(t, "=  7 "),
        "FITTYP 7 (not a Magic Formula 5.2, 6.1 or 6.2 version number): not supported",
    );
    let t = fixture!("tir/bad/missing_fnomin.tir");
    assert_bad(t.as_bytes(), line_of(t, "[VERTICAL]"), "no FNOMIN");
    let t = fixture!("tir/bad/missing_unloaded_radius.tir");
    assert_bad(
        t.as_bytes(),
        line_of(t, "[DIMENSION]"),
        "no UNLOADED_RADIUS",
    );
    let t = fixture!("tir/bad/unknown_unit.tir");
    assert_bad(
        t.as_bytes(),
        line_of(t, "furlong"),
        "unknown LENGTH unit 'furlong'",
    );
    let garbage: &[u8] = include_bytes!("../../../../tests/fixtures/tir/bad/binary_garbage.tir");
    let err = TirFile::parse_bytes(garbage).expect_err("binary");
    assert!(err.to_string().contains("binary data"), "{err}");
    assert!(err.line() >= 3, "{err}");
}

#[test]
fn fittyp_decides_the_model_version() {
    let with = |model: &str| FSAE.replace("[MODEL]\n", &format!("[MODEL]\n{model}\n"));
    let (f, w) = TirFile::parse(&with("FITTYP = 61")).unwrap();
    assert_eq!(f.version, Version::Mf61);
    // The PAC2002-only keys of the FSAE file are kept, not used; PROPERTY_FILE_FORMAT disagrees.
    assert!(
        w.iter().any(|w| w.message.contains("FITTYP decides")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|w| w.message == "PHY3 is not a key of MF 6.1: kept as written, not used"),
        "{w:?}"
    );
    assert!(f.extra_keys.iter().any(|k| k.entry.key == "PHY3"));
    assert_eq!(f.coefs[Coef::PHY3], 0.0);
    let (f, _) = TirFile::parse(&with("FITTYP = 62")).unwrap();
    assert_eq!(f.version, Version::Mf62);
    let mf61 = FSAE.replace("'PAC2002'", "'MF_61'");
    assert_eq!(TirFile::parse(&mf61).unwrap().0.version, Version::Mf61);
    let err = TirFile::parse(&with("FITTYP = 2")).unwrap_err();
    assert!(err.to_string().contains("FITTYP 2"), "{err}");
    assert!(TirFile::parse(&with("FITTYP = 21")).is_ok());
    assert!(TirFile::parse(&with("fittyp = 6.0")).is_ok());
    let (_, w) = TirFile::parse(&with("FITTYP = 52")).unwrap();
    assert!(w.iter().any(|w| w.message.contains("FITTYP 52")), "{w:?}");
    let pac89 = FSAE.replace("'PAC2002'", "'PAC89'");
    assert!(
        TirFile::parse(&pac89)
            .unwrap_err()
            .to_string()
            .contains("PAC89")
    );
}

#[test]
fn tolerated_oddities_warn_but_read() {
    let odd = FSAE
        .replace("FNOMIN                   =  1100.0", "FNOMIN = '1100.0'")
        .replace("[UNITS]\n", "stray text before nothing\n[UNITS]\n")
        .replace(
            "QCZ1                     =  1.25",
            "QCZ1 = 1.25\nQCZ1 = 1.3 ! later wins",
        )
        .replace(
            "LONGVL                   =  11.176",
            "LONGVL = 11.176\nFZMIN = 100.0",
        )
        .replace(
            "FILE_FORMAT              = 'ASCII'",
            "FILE_FORMAT = 'ASCII'\nTYRESIDE = 'Left'",
        );
    let (f, w) = read(&odd);
    assert_eq!(f.coefs[Coef::FNOMIN], 1100.0);
    assert_eq!(f.coefs[Coef::QCZ1], 1.3);
    let text: Vec<String> = w.iter().map(|w| w.to_string()).collect();
    let has = |s: &str| text.iter().any(|t| t.contains(s));
    assert!(has("quoted number"), "{text:?}");
    assert!(has("QCZ1 repeated"), "{text:?}");
    assert!(has("FZMIN belongs in [VERTICAL_FORCE_RANGE]"), "{text:?}");
    assert!(has("wrapped end of a comment"), "{text:?}");
    assert!(has("TYRESIDE in [MDI_HEADER]"), "{text:?}");
    assert_eq!(
        f.tyre_side.as_deref(),
        Some("Right"),
        "the later [MODEL] value wins"
    );
    assert!(f.header.is_empty(), "{:?}", f.header);
}

#[test]
fn latin1_comments_read() {
    let mut bytes = FSAE.as_bytes().to_vec();
    let at = FSAE.find("$Minimum valid camber angle").unwrap() + 27;
    bytes.splice(at..at, b" [\xb0] tyre\x92s".iter().copied());
    let (f, _) = TirFile::parse_bytes(&bytes).expect("Latin-1 degree sign in a comment");
    assert_eq!(f.coefs[Coef::CAMMIN], -0.087266);
}

#[test]
fn written_file_layout() {
    let (f, _) = read(FSAE);
    let text = f.render().unwrap();
    assert!(!text.contains('\r'));
    assert!(text.starts_with("[MDI_HEADER]\n"));
    assert!(text.contains("PROPERTY_FILE_FORMAT     = 'PAC2002'"));
    assert!(text.contains("\nFITTYP                   =  6 "));
    let sections: Vec<&str> = text.lines().filter(|l| l.starts_with('[')).collect();
    assert_eq!(
        sections,
        [
            "[MDI_HEADER]",
            "[UNITS]",
            "[MODEL]",
            "[DIMENSION]",
            "[VERTICAL]",
            "[LONG_SLIP_RANGE]",
            "[SLIP_ANGLE_RANGE]",
            "[INCLINATION_ANGLE_RANGE]",
            "[VERTICAL_FORCE_RANGE]",
            "[SCALING_COEFFICIENTS]",
            "[LONGITUDINAL_COEFFICIENTS]",
            "[OVERTURNING_COEFFICIENTS]",
            "[LATERAL_COEFFICIENTS]",
            "[ROLLING_COEFFICIENTS]",
            "[ALIGNING_COEFFICIENTS]",
        ]
    );
    // No key twice, every coefficient once.
    let mut keys: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with(['$', '!', '[']))
        .filter_map(|l| l.split('=').next())
        .map(str::trim)
        .collect();
    let n = keys.len();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), n, "duplicate keys");
    for c in Coef::ALL {
        assert_eq!(
            keys.contains(&c.name()),
            c.carried_by(Version::Pac2002),
            "{}",
            c.name()
        );
    }
    assert!(
        text.contains(
            "PDY1                     = -2.5                     $Lateral friction Muy\n"
        )
    );
    let (again, w) = read(&text);
    assert!(w.is_empty(), "{w:?}");
    assert_same_coefs(&again.coefs, &f.coefs, "fsae round trip");
    assert_eq!(again.tyre_side, f.tyre_side);
    assert_eq!(again.header_comments, f.header_comments);
}

#[test]
fn writer_refuses_what_cannot_be_a_tir_file() {
    let mut f = TirFile::from_coefs(Coefs::defaults());
    let err = f.render().unwrap_err().to_string();
    assert!(err.contains("FNOMIN = 0 N"), "{err}");
    f.coefs[Coef::FNOMIN] = 1000.0;
    f.coefs[Coef::PCY1] = f64::NAN;
    assert!(f.render().unwrap_err().to_string().contains("PCY1"));
    f.coefs[Coef::PCY1] = 1.3;
    f.extra_keys.push(ExtraKey {
        section: "VERTICAL".into(),
        entry: Entry {
            key: "FNOMIN".into(),
            value: Value::Number(1.0),
        },
    });
    assert!(f.render().unwrap_err().to_string().contains("duplicates"));
}

#[test]
fn format_f64_is_shortest_and_exact() {
    use super::format_f64;
    assert_eq!(format_f64(1100.0), "1100");
    assert_eq!(format_f64(-2.5), "-2.5");
    assert_eq!(format_f64(1e30), "1e30");
    assert_eq!(format_f64(0.1 + 0.2), "0.30000000000000004");
    assert_eq!(format_f64(1.5e-7), "1.5e-7");
    assert_eq!(format_f64(0.0), "0");
}

// ---------------------------------------------------------------------------------------------
// Property tests.

/// Finite doubles of every magnitude, including subnormals and signed zero.
fn any_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL | proptest::num::f64::ZERO,
        -10.0..10.0f64,
        (-1e6..1e6f64).prop_map(|x| x.round()),
    ]
}

fn key() -> impl Strategy<Value = String> {
    "[A-Z][A-Z0-9_]{0,12}X".prop_filter("not a key the writer owns", |k| {
        Coef::from_name(k).is_none() && k != "IP_NOMX"
    })
}

fn text() -> impl Strategy<Value = String> {
    "[A-Za-z0-9 .,:;/()$!=\\[\\]{}+*-]{0,20}"
}

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any_value().prop_map(Value::Number),
        text().prop_map(Value::Text),
        Just(Value::Empty),
    ]
}

fn entry() -> impl Strategy<Value = Entry> {
    (key(), value()).prop_map(|(key, value)| Entry { key, value })
}

fn table_text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[a-z0-9.+-]{1,6}( [a-z0-9.+-]{1,6}){0,3}",
        "\\{[a-z]{1,5}( [a-z]{1,5}){0,2}\\}",
    ]
}

/// Sections that can hold extra keys, in the order the writer writes them.
const WRITER_ORDER: [&str; 7] = [
    "UNITS",
    "MODEL",
    "DIMENSION",
    "TYRE_CONDITIONS",
    "VERTICAL",
    "LATERAL_COEFFICIENTS",
    "ALIGNING_COEFFICIENTS",
];

fn tir_file() -> impl Strategy<Value = TirFile> {
    let coefs = proptest::collection::vec(any_value(), N_COEFS);
    let extra_keys = proptest::collection::vec(
        (proptest::sample::select(WRITER_ORDER.to_vec()), entry()),
        0..5,
    );
    let extra_sections = proptest::collection::vec(
        (
            "[A-Z]{2,8}_X",
            proptest::collection::vec(
                prop_oneof![
                    entry().prop_map(ExtraLine::Entry),
                    table_text().prop_map(ExtraLine::Text)
                ],
                0..4,
            ),
        ),
        0..3,
    );
    let shape = proptest::option::of((
        proptest::collection::vec("[a-z]{1,6}", 0..3),
        proptest::collection::vec(proptest::collection::vec(any_value(), 1..3), 0..4),
    ));
    (
        coefs,
        (1e-3..1e6f64),
        (-14i64..=14).prop_map(Some),
        proptest::option::of("(Left|Right|RIGHT|symmetric|)"),
        (
            proptest::option::of(1e3..1e6f64),
            proptest::option::of(1e3..1e6f64),
        ),
        proptest::collection::vec(entry(), 0..3),
        proptest::collection::vec("! : [A-Z]{1,8} : [a-z0-9 ]{0,10}[a-z0-9]", 0..3),
        shape,
        (extra_keys, proptest::sample::select(Version::ALL.to_vec())),
        extra_sections,
    )
        .prop_map(
            |(
                v,
                fnomin,
                use_mode,
                side,
                (ip, ip_nom),
                header,
                comments,
                shape,
                (keys, version),
                sections,
            )| {
                let mut coefs = Coefs::defaults();
                coefs.0.copy_from_slice(&v);
                coefs[Coef::FNOMIN] = fnomin;
                let mut f = TirFile::from_coefs_as(coefs, version);
                f.source_units = super::Units::written();
                f.use_mode = use_mode;
                f.tyre_side = side;
                if !version.is_mf6() {
                    f.pressure = TyrePressure {
                        inflation_pa: ip,
                        nominal_pa: ip_nom,
                    };
                }
                let mut seen = Vec::new();
                f.header = header
                    .into_iter()
                    .filter(|e| {
                        let fresh = !seen.contains(&e.key);
                        seen.push(e.key.clone());
                        fresh
                    })
                    .collect();
                f.header_comments = comments;
                f.shape = shape.map(|(columns, rows)| ShapeTable { columns, rows });
                let mut seen = Vec::new();
                let mut keys = keys;
                // The file order of sections is the writer's.
                keys.sort_by_key(|(s, _)| WRITER_ORDER.iter().position(|w| w == s));
                f.extra_keys = keys
                    .into_iter()
                    .filter(|(s, e)| {
                        let id = (s.to_string(), e.key.clone());
                        let fresh = !seen.contains(&id);
                        seen.push(id);
                        fresh
                    })
                    .map(|(s, entry)| ExtraKey {
                        section: s.to_string(),
                        entry,
                    })
                    .collect();
                f.extra_sections = sections
                    .into_iter()
                    .map(|(name, lines)| ExtraSection { name, lines })
                    .collect();
                f
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// read(write(x)) == x, every coefficient to the bit.
    #[test]
    fn write_then_read_is_exact(f in tir_file()) {
        let text = f.render().expect("renders");
        let (back, _) = TirFile::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        for c in Coef::ALL {
            prop_assert_eq!(back.coefs[*c].to_bits(), f.coefs[*c].to_bits(), "{}", c.name());
        }
        prop_assert_eq!(back, f);
    }

    /// Random text never panics; an error is one line naming a line that exists.
    #[test]
    fn random_text_never_panics(s in "(\\PC|[\\[\\]{}=$!'\"\r\n])*") {
        check_no_panic(s.as_bytes());
    }

    /// Random bytes never panic.
    #[test]
    fn random_bytes_never_panic(b in proptest::collection::vec(any::<u8>(), 0..400)) {
        check_no_panic(&b);
    }

    /// A real file with a few bytes overwritten, inserted or removed never panics.
    #[test]
    fn mutated_files_never_panic(
        edits in proptest::collection::vec((any::<proptest::sample::Index>(), any::<u8>(), 0u8..3), 1..8),
        which in 0usize..3,
    ) {
        let mut b = [FSAE, MF05_CRLF, UNKNOWN_SECTIONS][which].as_bytes().to_vec();
        for (at, byte, op) in edits {
            let i = at.index(b.len());
            match op {
                0 => b[i] = byte,
                1 => b.insert(i, byte),
                _ => { b.remove(i); }
            }
        }
        check_no_panic(&b);
    }
}

fn check_no_panic(bytes: &[u8]) {
    let lines = bytes
        .split(|&b| b == b'\n')
        .count()
        .max(bytes.split(|&b| b == b'\r').count());
    match TirFile::parse_bytes(bytes) {
        Ok((f, warnings)) => {
            for w in warnings {
                assert!(!w.to_string().contains('\n'), "{w}");
            }
            // Whatever reads must also write (unless its FNOMIN is not positive).
            if f.coefs[Coef::FNOMIN] > 0.0 {
                let _ = f.render();
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "{msg}");
            assert!(msg.starts_with("line "), "{msg}");
            assert!(
                e.line() >= 1 && e.line() <= lines + 1,
                "{msg} ({lines} lines)"
            );
        }
    }
}
