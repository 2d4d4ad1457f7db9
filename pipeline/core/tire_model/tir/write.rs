//! Writing a [`TirFile`] as a complete property file of its version.
//!
//! In: a [`TirFile`] (SI values). Out: the file text. PAC2002 (Adams layout): `[MDI_HEADER]`,
//! `[UNITS]` (SI), `[MODEL]` with `PROPERTY_FILE_FORMAT = 'PAC2002'` and `FITTYP = 6` (so MFeval
//! reads it too), `USE_MODE` (4 when unknown), `[DIMENSION]`, `[TYRE_CONDITIONS]` when a pressure
//! is known, `[SHAPE]` when present, `[VERTICAL]`, the four range sections,
//! `[SCALING_COEFFICIENTS]` and the five coefficient sections. MF 6.1 / 6.2 (MF-Tyre 6.1 layout,
//! as MFeval's samples): `[MODEL]` with `FITTYP = 61` / `62`, `[DIMENSION]`,
//! `[OPERATING_CONDITIONS]` (`INFLPRES`, `NOMPRES`), `[VERTICAL]`, `[STRUCTURAL]`,
//! `[INFLATION_PRESSURE_RANGE]`, the four range sections, the scaling and coefficient sections.
//! Then, for both, known sections holding only uninterpreted keys and the sections the reader
//! did not know, in their order. Every coefficient of the version is written (defaults where the
//! source had none), once, with its description as a `$` comment, except the geometry keys no
//! equation uses (`WIDTH`, `ASPECT_RATIO`, `RIM_RADIUS`, `RIM_WIDTH`), which are written only
//! when present; LF line endings; numbers in the shortest form that reads back to the same
//! `f64` ([`format_f64`]), so
//! `parse(render(x)) == x` bit for bit.
//! Deliberately not here: unit conversion (values are SI already) and any check of physical
//! sense beyond a positive `FNOMIN` (see `lint.rs`).

use std::fmt::Write as _;

use super::units::{UNIT_KEYS, Units};
use super::{Entry, ExtraLine, TirFile, Value};
use crate::tire_model::params::{Coef, Section};
use crate::tire_model::version::Version;

/// Why a [`TirFile`] cannot be written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TirWriteError {
    /// A value is NaN or infinite.
    #[error("{key}: value {value} is not finite; a .tir file can only hold finite numbers")]
    NotFinite {
        /// The key.
        key: String,
        /// The value.
        value: f64,
    },
    /// `FNOMIN <= 0`.
    #[error("FNOMIN = {value} N: the nominal load must be positive")]
    NonPositiveFnomin {
        /// The value.
        value: f64,
    },
    /// A string that cannot be quoted (holds both quote characters or a control character).
    #[error("{key}: text {text:?} cannot be written as a .tir string")]
    Unquotable {
        /// The key.
        key: String,
        /// The text.
        text: String,
    },
    /// An uninterpreted key that the writer already writes itself (it would appear twice).
    #[error("extra key {key} in [{section}] duplicates a key the writer writes itself")]
    Reserved {
        /// The key.
        key: String,
        /// The section it was kept for.
        section: String,
    },
    /// A key that would not read back as one key.
    #[error("key {key:?} is not a .tir key (letters, digits, underscores only)")]
    BadKey {
        /// The key.
        key: String,
    },
}

/// The shortest decimal text that parses back to exactly `x` (plain notation for
/// `1e-5 <= |x| < 1e16`, scientific otherwise, e.g. `1e30`).
pub fn format_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Unit names the writer declares (and [`Units::written`] holds).
const WRITTEN_UNITS: [&str; 6] = ["meter", "newton", "radians", "kg", "second", "pascal"];

impl Units {
    /// SI units as the writer declares them (what reading a written file gives back).
    pub fn written() -> Units {
        let mut u = Units::SI;
        for (key, name) in UNIT_KEYS.iter().zip(WRITTEN_UNITS) {
            // The written names are known SI names; set() cannot fail on them.
            let _ = u.set(key, name);
        }
        u
    }
}

/// Output buffer with the Adams column layout.
struct Out {
    text: String,
}

impl Out {
    fn line(&mut self, s: &str) {
        self.text.push_str(s);
        self.text.push('\n');
    }

    fn section(&mut self, name: &str) {
        let rule = format!("${:->70}", name.to_ascii_lowercase());
        self.line(&rule);
        self.line(&format!("[{name}]"));
    }

    fn pair(&mut self, key: &str, value: &str, comment: &str) {
        let mut s = format!("{key:<25}= {value}");
        if !comment.is_empty() {
            let width = 25 + 2 + 25;
            while s.len() < width {
                s.push(' ');
            }
            if !s.ends_with(' ') {
                s.push(' ');
            }
            let _ = write!(s, "${comment}");
        }
        self.line(&s);
    }
}

/// A finite number as text.
fn number(key: &str, x: f64) -> Result<String, TirWriteError> {
    if !x.is_finite() {
        return Err(TirWriteError::NotFinite {
            key: key.to_string(),
            value: x,
        });
    }
    let s = format_f64(x);
    // A space where the minus sign would be keeps the digits of a column aligned.
    Ok(if s.starts_with('-') {
        s
    } else {
        format!(" {s}")
    })
}

/// A string as a quoted `.tir` value.
fn quoted(key: &str, text: &str) -> Result<String, TirWriteError> {
    let bad = || TirWriteError::Unquotable {
        key: key.to_string(),
        text: text.to_string(),
    };
    if text.chars().any(char::is_control) {
        return Err(bad());
    }
    if !text.contains('\'') {
        Ok(format!("'{text}'"))
    } else if !text.contains('"') {
        Ok(format!("\"{text}\""))
    } else {
        Err(bad())
    }
}

fn check_key(key: &str) -> Result<(), TirWriteError> {
    if !key.is_empty() && key.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
        Ok(())
    } else {
        Err(TirWriteError::BadKey {
            key: key.to_string(),
        })
    }
}

/// An uninterpreted entry.
fn entry(out: &mut Out, e: &Entry) -> Result<(), TirWriteError> {
    check_key(&e.key)?;
    let value = match &e.value {
        Value::Number(x) => number(&e.key, *x)?,
        Value::Text(t) => quoted(&e.key, t)?,
        Value::Empty => String::new(),
    };
    if value.is_empty() {
        out.line(&format!("{:<25}=", e.key));
    } else {
        out.pair(&e.key, &value, "");
    }
    Ok(())
}

/// Render a whole file.
pub fn render(tir: &TirFile) -> Result<String, TirWriteError> {
    let fnomin = tir.coefs[Coef::FNOMIN];
    if fnomin.is_nan() || fnomin <= 0.0 {
        return Err(TirWriteError::NonPositiveFnomin { value: fnomin });
    }
    let mut out = Out {
        text: String::with_capacity(24 * 1024),
    };
    header(&mut out, tir)?;
    out.section("UNITS");
    for (key, name) in UNIT_KEYS.iter().zip(WRITTEN_UNITS) {
        out.pair(key, &format!("'{name}'"), "");
    }
    extras(&mut out, tir, "UNITS")?;
    model(&mut out, tir)?;
    coefficients(&mut out, tir, Section::Dimension)?;
    let mut written = vec!["UNITS", "MODEL", "DIMENSION", "TYRE_CONDITIONS"];
    let sections: &[Section] = if tir.version.is_mf6() {
        out.section("OPERATING_CONDITIONS");
        for c in [Coef::INFLPRES, Coef::NOMPRES] {
            out.pair(c.name(), &number(c.name(), tir.coefs[c])?, c.description());
        }
        extras(&mut out, tir, "TYRE_CONDITIONS")?;
        shape(&mut out, tir)?;
        &[
            Section::Vertical,
            Section::Structural,
            Section::InflationPressureRange,
            Section::VerticalForceRange,
            Section::LongSlipRange,
            Section::SlipAngleRange,
            Section::InclinationAngleRange,
            Section::Scaling,
            Section::Longitudinal,
            Section::Overturning,
            Section::Lateral,
            Section::Rolling,
            Section::Aligning,
        ]
    } else {
        conditions(&mut out, tir)?;
        shape(&mut out, tir)?;
        &[
            Section::Vertical,
            Section::LongSlipRange,
            Section::SlipAngleRange,
            Section::InclinationAngleRange,
            Section::VerticalForceRange,
            Section::Scaling,
            Section::Longitudinal,
            Section::Overturning,
            Section::Lateral,
            Section::Rolling,
            Section::Aligning,
        ]
    };
    for section in sections {
        coefficients(&mut out, tir, *section)?;
        written.push(section.tir_name());
    }
    // Known sections this version does not write but whose uninterpreted keys must survive
    // (e.g. `[STRUCTURAL]` of a PAC2002 file).
    let mut leftover: Vec<&str> = Vec::new();
    for k in &tir.extra_keys {
        if !written.contains(&k.section.as_str()) && !leftover.contains(&k.section.as_str()) {
            leftover.push(&k.section);
        }
    }
    for name in leftover {
        out.section(name);
        extras(&mut out, tir, name)?;
    }
    for s in &tir.extra_sections {
        out.section(&s.name);
        for l in &s.lines {
            match l {
                ExtraLine::Entry(e) => entry(&mut out, e)?,
                ExtraLine::Text(t) => out.line(t),
            }
        }
    }
    Ok(out.text)
}

fn header(out: &mut Out, tir: &TirFile) -> Result<(), TirWriteError> {
    out.line("[MDI_HEADER]");
    out.pair("FILE_TYPE", "'tir'", "");
    out.pair("FILE_VERSION", "3.0", "");
    out.pair("FILE_FORMAT", "'ASCII'", "");
    for e in &tir.header {
        if reserved(&e.key, tir.version) {
            return Err(TirWriteError::Reserved {
                key: e.key.clone(),
                section: "MDI_HEADER".to_string(),
            });
        }
        entry(out, e)?;
    }
    for c in &tir.header_comments {
        out.line(c);
    }
    let lines: &[&str] = if tir.version.is_mf6() {
        &[
            "!",
            "! Magic Formula 6.x: the force and moment coefficients carry the inflation pressure",
            "! (PPX*, PPY*, PPZ*, PPMX1, QSY8) relative to NOMPRES; set INFLPRES to evaluate at",
            "! another pressure.",
            "!",
            "! Written by tirebase. Values in SI units, ISO-W (TYDEX W) axes.",
            "!",
        ]
    } else {
        &[
            "!",
            "! USE_MODE specifies the type of calculation performed:",
            "!       0: Fz only, no Magic Formula evaluation",
            "!       1: Fx,My only",
            "!       2: Fy,Mx,Mz only",
            "!       3: Fx,Fy,Mx,My,Mz uncombined force/moment calculation",
            "!       4: Fx,Fy,Mx,My,Mz combined force/moment calculation",
            "!     +10: including relaxation behaviour",
            "!",
            "! Written by tirebase. Values in SI units, ISO-W (TYDEX W) axes.",
            "!",
        ]
    };
    for l in lines {
        out.line(l);
    }
    Ok(())
}

fn model(out: &mut Out, tir: &TirFile) -> Result<(), TirWriteError> {
    out.section("MODEL");
    let (format, fittyp) = match tir.version {
        Version::Pac2002 => ("'PAC2002'", "Magic Formula version number (6 = MF 5.2)"),
        Version::Mf61 => ("'USER'", "Magic Formula version number (61 = MF 6.1)"),
        Version::Mf62 => ("'USER'", "Magic Formula version number (62 = MF 6.2)"),
    };
    out.pair("PROPERTY_FILE_FORMAT", format, "Tyre model");
    out.pair("FITTYP", &format!(" {}", tir.version.fittyp()), fittyp);
    let use_mode = tir.use_mode.unwrap_or(4);
    out.pair(
        "USE_MODE",
        &format!("{}{use_mode}", if use_mode < 0 { "" } else { " " }),
        "Tyre use switch (IUSED)",
    );
    for c in Coef::ALL
        .iter()
        .filter(|c| c.section() == Section::Model && c.carried_by(tir.version))
    {
        out.pair(c.name(), &number(c.name(), tir.coefs[*c])?, c.description());
    }
    if let Some(side) = &tir.tyre_side {
        out.pair(
            "TYRESIDE",
            &quoted("TYRESIDE", side)?,
            "Mounted side of tyre at vehicle/test bench",
        );
    }
    extras(out, tir, "MODEL")
}

/// Geometry keys no equation uses: written only when the file carries them (a fitter that does
/// not know the section width leaves `WIDTH` out rather than writing 0).
const OPTIONAL_GEOMETRY: [Coef; 4] = [
    Coef::WIDTH,
    Coef::ASPECT_RATIO,
    Coef::RIM_RADIUS,
    Coef::RIM_WIDTH,
];

fn coefficients(out: &mut Out, tir: &TirFile, section: Section) -> Result<(), TirWriteError> {
    out.section(section.tir_name());
    for c in Coef::ALL
        .iter()
        .filter(|c| c.section() == section && c.carried_by(tir.version))
        .filter(|c| tir.present[**c] || !OPTIONAL_GEOMETRY.contains(c))
    {
        out.pair(c.name(), &number(c.name(), tir.coefs[*c])?, c.description());
    }
    extras(out, tir, section.tir_name())
}

fn conditions(out: &mut Out, tir: &TirFile) -> Result<(), TirWriteError> {
    let p = &tir.pressure;
    let has_extras = tir
        .extra_keys
        .iter()
        .any(|k| k.section == "TYRE_CONDITIONS");
    if p.inflation_pa.is_none() && p.nominal_pa.is_none() && !has_extras {
        return Ok(());
    }
    out.section("TYRE_CONDITIONS");
    if let Some(ip) = p.inflation_pa {
        out.pair("IP", &number("IP", ip)?, "Inflation pressure");
    }
    if let Some(ip) = p.nominal_pa {
        out.pair(
            "IP_NOM",
            &number("IP_NOM", ip)?,
            "Nominal inflation pressure",
        );
    }
    extras(out, tir, "TYRE_CONDITIONS")
}

fn shape(out: &mut Out, tir: &TirFile) -> Result<(), TirWriteError> {
    let Some(shape) = &tir.shape else {
        return Ok(());
    };
    out.section("SHAPE");
    out.line(&format!("{{{}}}", shape.columns.join(" ")));
    for row in &shape.rows {
        let cells = row
            .iter()
            .map(|x| number("SHAPE", *x))
            .collect::<Result<Vec<_>, _>>()?;
        out.line(&cells.join(" "));
    }
    Ok(())
}

/// Keys the writer writes itself: an uninterpreted key of the same name would be a duplicate
/// (a known coefficient of another version is not: it is kept as written).
fn reserved(key: &str, version: Version) -> bool {
    Coef::from_name(key).is_some_and(|c| c.carried_by(version))
        || UNIT_KEYS.contains(&key)
        || [
            "PROPERTY_FILE_FORMAT",
            "FITTYP",
            "USE_MODE",
            "TYRESIDE",
            "IP",
            "IP_NOM",
            "INFLPRES",
            "NOMPRES",
            "FILE_TYPE",
            "FILE_VERSION",
            "FILE_FORMAT",
        ]
        .contains(&key)
}

fn extras(out: &mut Out, tir: &TirFile, section: &str) -> Result<(), TirWriteError> {
    for k in tir.extra_keys.iter().filter(|k| k.section == section) {
        if reserved(&k.entry.key, tir.version) {
            return Err(TirWriteError::Reserved {
                key: k.entry.key.clone(),
                section: k.section.clone(),
            });
        }
        entry(out, &k.entry)?;
    }
    Ok(())
}
