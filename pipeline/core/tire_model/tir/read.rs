//! Reading `.tir` text into a [`TirFile`].
//!
//! In: the whole text (LF, CRLF or CR line endings). Out: a [`TirFile`] with every coefficient
//! in SI plus [`ReadWarning`]s, or one [`TirReadError`] whose message is one line starting with
//! `line N:`. Two passes: the first lexes every line and collects raw values per section; the
//! second resolves `[UNITS]`, checks the model declaration (PAC2002 / MF 5.2, MF 6.1 or MF 6.2:
//! `FITTYP` decides, else `PROPERTY_FILE_FORMAT`) and converts. A known coefficient the declared
//! version does not carry (`PHY3` in an MF 6.1 file, `PPY1` in a PAC2002 file) is kept as an
//! uninterpreted key, in file order, and written back as read (with a warning when its value is
//! not the default the version assumes). MF 6.x pressures
//! (`[OPERATING_CONDITIONS] INFLPRES / NOMPRES`) are coefficients; a missing or blank `INFLPRES`
//! takes `NOMPRES` (with a warning), a missing `NOMPRES` MFeval's 220 kPa (with a warning).
//!
//! Tolerated (with a warning): a text line without `=` inside a key/value section (taken as the
//! wrapped tail of the previous line's comment; real files have them), empty values (the default
//! is used), repeated keys (the later value wins, as in MFeval), quoted numbers, coefficients in
//! an unexpected known section, content before the first section. Refused: binary data,
//! unterminated `[`/`{`/quotes, a coefficient whose value is not a finite number, unknown unit
//! names, non-Magic-Formula models and Magic Formula versions other than 5.2 / 6.1 / 6.2, and
//! files without `FNOMIN` or `UNLOADED_RADIUS`.
//! Deliberately not here: physical plausibility (see `lint.rs`).

use super::lexer::{self, LexError, Line, RawValue, parse_number};
use super::units::{self, Dim, Units};
use super::{
    Declaration, Entry, ExtraKey, ExtraLine, ExtraSection, ShapeTable, TirFile, TyrePressure, Value,
};
use crate::tire_model::params::{Coef, Coefs, N_COEFS, Section};
use crate::tire_model::version::Version;

/// A `.tir` file that cannot be read. Every message is one line naming the line number.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TirReadError {
    /// Control characters: not a text file.
    #[error("line {line}: binary data (control character U+{code:04X}); not a .tir text file")]
    Binary {
        /// 1-based line number.
        line: usize,
        /// The offending character.
        code: u32,
    },
    /// `[NAME` without `]`.
    #[error("line {line}: section header without closing ']'")]
    UnterminatedSection {
        /// 1-based line number.
        line: usize,
    },
    /// `{...` without `}`.
    #[error("line {line}: table header without closing '}}'")]
    UnterminatedTable {
        /// 1-based line number.
        line: usize,
    },
    /// A quote without its closing quote.
    #[error("line {line}: string value without closing quote")]
    UnterminatedQuote {
        /// 1-based line number.
        line: usize,
    },
    /// A numeric key whose value is not a finite number.
    #[error("line {line}: {key}: expected a finite number, found '{found}'")]
    NotANumber {
        /// 1-based line number.
        line: usize,
        /// The key.
        key: String,
        /// The value as written.
        found: String,
    },
    /// An unknown `[UNITS]` name.
    #[error("line {line}: {reason}")]
    UnknownUnit {
        /// 1-based line number.
        line: usize,
        /// What is unknown and what is accepted.
        reason: units::UnknownUnit,
    },
    /// A model other than PAC2002 / MF 5.2 / MF 6.1 / MF 6.2.
    #[error(
        "line {line}: {what}: not supported; tirebase reads PAC2002 / MF 5.2 (FITTYP 6 or 21, or \
         PROPERTY_FILE_FORMAT 'PAC2002' / 'MF_05'), MF 6.1 (FITTYP 61) and MF 6.2 (FITTYP 62) files"
    )]
    Unsupported {
        /// 1-based line number.
        line: usize,
        /// What the file declared.
        what: String,
    },
    /// A required key is absent (or empty).
    #[error("line {line}: no {key} ({description}) in [{section}]; the model needs it")]
    Missing {
        /// The section header's line, or the last line when the section is absent.
        line: usize,
        /// The key.
        key: &'static str,
        /// What it is.
        description: &'static str,
        /// Where it belongs.
        section: &'static str,
    },
    /// A `[SHAPE]` row that is not all numbers.
    #[error("line {line}: [SHAPE] row: '{found}' is not a number")]
    ShapeRow {
        /// 1-based line number.
        line: usize,
        /// The offending token.
        found: String,
    },
    /// No `[SECTION]` at all.
    #[error("line {line}: no [SECTION] header in the text; not a .tir file")]
    NoSections {
        /// Last line of the text.
        line: usize,
    },
}

impl TirReadError {
    /// The 1-based line the error names.
    pub fn line(&self) -> usize {
        match self {
            TirReadError::Binary { line, .. }
            | TirReadError::UnterminatedSection { line }
            | TirReadError::UnterminatedTable { line }
            | TirReadError::UnterminatedQuote { line }
            | TirReadError::NotANumber { line, .. }
            | TirReadError::UnknownUnit { line, .. }
            | TirReadError::Unsupported { line, .. }
            | TirReadError::Missing { line, .. }
            | TirReadError::ShapeRow { line, .. }
            | TirReadError::NoSections { line } => *line,
        }
    }
}

/// Something the reader tolerated.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadWarning {
    /// 1-based line number.
    pub line: usize,
    /// What was tolerated and what was done.
    pub message: String,
}

impl std::fmt::Display for ReadWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

/// Which kind of section the reader is in.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Before the first `[SECTION]`.
    Preamble,
    Header,
    Units,
    Model,
    /// A coefficient section other than `[MODEL]`.
    Coefficients(Section),
    /// `[TYRE_CONDITIONS]` (Adams PAC2002) or `[OPERATING_CONDITIONS]` (MF 6.x).
    Conditions,
    Shape,
    /// Index into the extra sections.
    Unknown(usize),
}

/// Upper-case section name -> kind (unknown names are handled by the caller).
fn known_kind(name: &str) -> Option<Kind> {
    let kind = match name {
        "MDI_HEADER" => Kind::Header,
        "UNITS" => Kind::Units,
        "MODEL" => Kind::Model,
        "SHAPE" => Kind::Shape,
        "TYRE_CONDITIONS" | "TIRE_CONDITIONS" | "OPERATING_CONDITIONS" => Kind::Conditions,
        _ => {
            let section = Coef::ALL
                .iter()
                .map(|c| c.section())
                .find(|s| s.tir_name() == name && *s != Section::Model)?;
            Kind::Coefficients(section)
        }
    };
    Some(kind)
}

/// A value as read, before units are known.
#[derive(Clone, Debug)]
struct Raw {
    value: f64,
    line: usize,
}

/// A coefficient as read, before units and the model version are known.
#[derive(Clone, Debug)]
struct RawCoef {
    /// `None`: `KEY =` with nothing after it.
    value: Option<f64>,
    line: usize,
    /// The section it was found in.
    section: Section,
}

/// Everything collected by the first pass.
#[derive(Default)]
struct Collected {
    coefs: Vec<Option<RawCoef>>,
    units: Units,
    unit_lines: Vec<(usize, String)>,
    property_file_format: Option<(String, usize)>,
    fittyp: Option<(i64, usize)>,
    use_mode: Option<(i64, usize)>,
    tyre_side: Option<String>,
    inflation: Option<Raw>,
    nominal: Option<Raw>,
    header: Vec<Entry>,
    header_comments: Vec<String>,
    shape: Option<ShapeTable>,
    extra_keys: Vec<(ExtraKey, usize)>,
    extra_sections: Vec<ExtraSection>,
    section_lines: Vec<(Kind, usize)>,
    sections_seen: usize,
    last_line: usize,
    warnings: Vec<ReadWarning>,
}

/// Parse a whole `.tir` text.
pub fn parse(text: &str) -> Result<(TirFile, Vec<ReadWarning>), TirReadError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut col = Collected {
        coefs: vec![None; N_COEFS],
        ..Collected::default()
    };
    let mut kind = Kind::Preamble;
    for (i, raw_line) in split_lines(text).enumerate() {
        let line = i + 1;
        col.last_line = line;
        let lexed = lexer::lex(raw_line).map_err(|e| lex_error(e, line))?;
        kind = col.take(lexed, kind, line)?;
    }
    if col.sections_seen == 0 {
        return Err(TirReadError::NoSections {
            line: col.last_line.max(1),
        });
    }
    col.finish()
}

/// Lines split on LF (CR before it removed), or on CR alone for old Mac files.
fn split_lines(text: &str) -> Box<dyn Iterator<Item = &str> + '_> {
    if !text.contains('\n') && text.contains('\r') {
        Box::new(text.split('\r'))
    } else {
        Box::new(text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l)))
    }
}

fn lex_error(e: LexError, line: usize) -> TirReadError {
    match e {
        LexError::Binary(code) => TirReadError::Binary { line, code },
        LexError::UnterminatedSection => TirReadError::UnterminatedSection { line },
        LexError::UnterminatedTable => TirReadError::UnterminatedTable { line },
        LexError::UnterminatedQuote => TirReadError::UnterminatedQuote { line },
    }
}

/// `[MODEL]` keys that are not coefficients.
const MODEL_STRING_KEYS: [&str; 5] = [
    "PROPERTY_FILE_FORMAT",
    "FITTYP",
    "USE_MODE",
    "TYRESIDE",
    "TIRESIDE",
];

/// A key made of letters, digits and underscores.
fn valid_key(key: &str) -> bool {
    !key.is_empty() && key.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
}

/// A value not interpreted here, as kept.
fn extra_value(v: &RawValue<'_>) -> Value {
    match v {
        RawValue::Empty => Value::Empty,
        RawValue::Quoted(s) => Value::Text((*s).to_string()),
        RawValue::Bare(s) => match parse_number(s) {
            Some(x) => Value::Number(x),
            None => Value::Text((*s).to_string()),
        },
    }
}

/// The text of a value (quotes removed), or `None` when empty.
fn text_of<'a>(v: &RawValue<'a>) -> Option<&'a str> {
    match v {
        RawValue::Empty => None,
        RawValue::Quoted(s) | RawValue::Bare(s) => Some(s),
    }
}

impl Collected {
    fn warn(&mut self, line: usize, message: impl Into<String>) {
        self.warnings.push(ReadWarning {
            line,
            message: message.into(),
        });
    }

    /// Take one lexed line in section `kind`; returns the section kind after it.
    fn take(&mut self, lexed: Line<'_>, kind: Kind, line: usize) -> Result<Kind, TirReadError> {
        match lexed {
            Line::Blank => {}
            Line::Comment { marker, text } => {
                if kind == Kind::Header && marker == '!' && text.trim_start().starts_with(':') {
                    self.header_comments.push(format!("!{}", text.trim_end()));
                }
            }
            Line::Section(name) => return Ok(self.open_section(name, line)),
            Line::TableHeader(inner) => self.table_header(kind, inner, line),
            Line::KeyValue { key, value } => {
                if valid_key(key) {
                    self.key_value(kind, &key.to_ascii_uppercase(), &value, line)?;
                } else {
                    self.warn(line, format!("malformed key '{key}'; line ignored"));
                }
            }
            Line::Text(text) => self.text(kind, text, line)?,
        }
        Ok(kind)
    }

    fn open_section(&mut self, name: &str, line: usize) -> Kind {
        self.sections_seen += 1;
        let name = name.to_ascii_uppercase();
        let kind = known_kind(&name).unwrap_or_else(|| {
            self.extra_sections.push(ExtraSection {
                name,
                lines: Vec::new(),
            });
            Kind::Unknown(self.extra_sections.len() - 1)
        });
        if !self.section_lines.iter().any(|(k, _)| *k == kind) {
            self.section_lines.push((kind, line));
        }
        kind
    }

    fn table_header(&mut self, kind: Kind, inner: &str, line: usize) {
        match kind {
            Kind::Shape => {
                if self.shape.as_ref().is_some_and(|s| !s.rows.is_empty()) {
                    self.warn(
                        line,
                        "second [SHAPE] table header; the rows before it are replaced",
                    );
                }
                self.shape = Some(ShapeTable {
                    columns: inner.split_whitespace().map(str::to_string).collect(),
                    rows: Vec::new(),
                });
            }
            Kind::Unknown(i) => self.extra_sections[i]
                .lines
                .push(ExtraLine::Text(format!("{{{inner}}}"))),
            _ => self.warn(
                line,
                format!("table header '{{{inner}}}' outside a table section; ignored"),
            ),
        }
    }

    fn text(&mut self, kind: Kind, text: &str, line: usize) -> Result<(), TirReadError> {
        match kind {
            Kind::Shape => {
                let row = text
                    .split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|t| !t.is_empty())
                    .map(|t| {
                        parse_number(t).ok_or_else(|| TirReadError::ShapeRow {
                            line,
                            found: t.to_string(),
                        })
                    })
                    .collect::<Result<Vec<f64>, _>>()?;
                if row.is_empty() {
                    return Ok(());
                }
                self.shape
                    .get_or_insert_with(|| ShapeTable {
                        columns: Vec::new(),
                        rows: Vec::new(),
                    })
                    .rows
                    .push(row);
            }
            Kind::Unknown(i) => self.extra_sections[i]
                .lines
                .push(ExtraLine::Text(text.to_string())),
            Kind::Preamble => self.warn(line, "text before the first [SECTION]; ignored"),
            _ => self.warn(
                line,
                format!("'{text}' has no '='; taken as the wrapped end of a comment and ignored"),
            ),
        }
        Ok(())
    }

    fn key_value(
        &mut self,
        kind: Kind,
        key: &str,
        value: &RawValue<'_>,
        line: usize,
    ) -> Result<(), TirReadError> {
        match kind {
            Kind::Preamble => self.warn(line, format!("{key} before the first [SECTION]; ignored")),
            Kind::Header if Coef::from_name(key).is_some() || MODEL_STRING_KEYS.contains(&key) => {
                self.warn(
                    line,
                    format!("{key} in [MDI_HEADER]; used as if in its own section"),
                );
                match Coef::from_name(key) {
                    Some(c) => self.coefficient(c.section(), key, value, line)?,
                    None => self.model_key(key, value, line)?,
                }
            }
            Kind::Header => {
                if !matches!(key, "FILE_TYPE" | "FILE_VERSION" | "FILE_FORMAT") {
                    let entry = Entry {
                        key: key.to_string(),
                        value: extra_value(value),
                    };
                    upsert(&mut self.header, entry);
                }
            }
            Kind::Units if !units::UNIT_KEYS.contains(&key) => {
                self.extra(kind, "UNITS", key, value, line);
            }
            Kind::Units => match text_of(value) {
                Some(v) => {
                    self.units
                        .set(key, v)
                        .map_err(|reason| TirReadError::UnknownUnit { line, reason })?;
                    self.unit_lines.push((line, key.to_string()));
                }
                None => self.warn(line, format!("{key} is empty; SI assumed")),
            },
            Kind::Model => self.model_key(key, value, line)?,
            Kind::Coefficients(section) => self.coefficient(section, key, value, line)?,
            Kind::Conditions => {
                let slot = match key {
                    "IP" | "INFLPRES" => Some(&mut self.inflation),
                    "IP_NOM" | "NOMPRES" => Some(&mut self.nominal),
                    _ => None,
                };
                match slot {
                    Some(slot) => {
                        let v = number(key, value, line, &mut self.warnings)?;
                        if let Some(v) = v {
                            *slot = Some(Raw { value: v, line });
                        }
                    }
                    None => self.extra(kind, "TYRE_CONDITIONS", key, value, line),
                }
            }
            Kind::Shape => self.warn(line, format!("{key} = ... inside [SHAPE]; ignored")),
            Kind::Unknown(i) => {
                if Coef::from_name(key).is_some() {
                    let name = self.extra_sections[i].name.clone();
                    self.warn(
                        line,
                        format!("{key} in unknown section [{name}] is kept but not used as a coefficient"),
                    );
                }
                let entry = Entry {
                    key: key.to_string(),
                    value: extra_value(value),
                };
                self.extra_sections[i].lines.push(ExtraLine::Entry(entry));
            }
        }
        Ok(())
    }

    fn model_key(
        &mut self,
        key: &str,
        value: &RawValue<'_>,
        line: usize,
    ) -> Result<(), TirReadError> {
        match key {
            "PROPERTY_FILE_FORMAT" => {
                self.property_file_format = text_of(value).map(|s| (s.to_string(), line));
            }
            "TYRESIDE" | "TIRESIDE" => self.tyre_side = text_of(value).map(str::to_string),
            "FITTYP" | "USE_MODE" => {
                let v = integer(key, value, line, &mut self.warnings)?;
                let slot = if key == "FITTYP" {
                    &mut self.fittyp
                } else {
                    &mut self.use_mode
                };
                *slot = v.map(|v| (v, line));
            }
            _ => self.coefficient(Section::Model, key, value, line)?,
        }
        Ok(())
    }

    fn coefficient(
        &mut self,
        section: Section,
        key: &str,
        value: &RawValue<'_>,
        line: usize,
    ) -> Result<(), TirReadError> {
        let Some(c) = Coef::from_name(key) else {
            self.extra(
                Kind::Coefficients(section),
                section.tir_name(),
                key,
                value,
                line,
            );
            return Ok(());
        };
        if c.section() != section {
            self.warn(
                line,
                format!(
                    "{key} belongs in [{}], found in [{}]; used",
                    c.section().tir_name(),
                    section.tir_name()
                ),
            );
        }
        let slot = &mut self.coefs[c.index()];
        if matches!(value, RawValue::Empty) {
            // Whether the default is used or the key is kept uninterpreted is decided once the
            // model version is known (`finish`).
            if slot.is_none() {
                *slot = Some(RawCoef {
                    value: None,
                    line,
                    section,
                });
            }
            return Ok(());
        }
        let v = number(key, value, line, &mut self.warnings)?;
        if let Some(prev) = &self.coefs[c.index()]
            && prev.value.is_some()
        {
            let first = prev.line;
            self.warn(
                line,
                format!("{key} repeated (first at line {first}); this later value is used"),
            );
        }
        self.coefs[c.index()] = Some(RawCoef {
            value: v,
            line,
            section,
        });
        Ok(())
    }

    /// Keep a key this module does not interpret.
    fn extra(&mut self, _kind: Kind, section: &str, key: &str, value: &RawValue<'_>, line: usize) {
        let entry = Entry {
            key: key.to_string(),
            value: extra_value(value),
        };
        if let Some((existing, first)) = self
            .extra_keys
            .iter_mut()
            .find(|(e, _)| e.section == section && e.entry.key == entry.key)
        {
            let first = *first;
            existing.entry = entry;
            self.warn(
                line,
                format!("{key} repeated (first at line {first}); this later value is kept"),
            );
            return;
        }
        self.extra_keys.push((
            ExtraKey {
                section: section.to_string(),
                entry,
            },
            line,
        ));
    }

    /// The line of a known section's header, or the last line.
    fn section_line(&self, kind: Kind) -> usize {
        self.section_lines
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or(self.last_line, |(_, l)| *l)
    }

    /// Second pass: declaration, units, required keys.
    fn finish(mut self) -> Result<(TirFile, Vec<ReadWarning>), TirReadError> {
        let (declaration, version) = self.check_declaration()?;
        self.set_aside_foreign_keys(version);
        if version.is_mf6() {
            self.pressures_as_coefficients(version);
        }
        for (c, section_kind) in [
            (Coef::FNOMIN, Kind::Coefficients(Section::Vertical)),
            (
                Coef::UNLOADED_RADIUS,
                Kind::Coefficients(Section::Dimension),
            ),
        ] {
            if self.coefs[c.index()]
                .as_ref()
                .and_then(|r| r.value)
                .is_none()
            {
                return Err(TirReadError::Missing {
                    line: self.section_line(section_kind),
                    key: c.name(),
                    description: c.description(),
                    section: c.section().tir_name(),
                });
            }
        }
        let units = self.units.clone();
        self.warn_units(&units);
        let mut coefs = Coefs::defaults();
        let mut present = Coefs([false; N_COEFS]);
        for c in Coef::ALL {
            let Some(raw) = &self.coefs[c.index()] else {
                continue;
            };
            match raw.value {
                Some(v) => {
                    coefs[*c] = units.to_si(v, units::dimension(*c));
                    present[*c] = true;
                }
                None => self.warnings.push(ReadWarning {
                    line: raw.line,
                    message: format!("{} has no value; the default is used", c.name()),
                }),
            }
        }
        if version.is_mf6() && !present[Coef::INFLPRES] {
            coefs[Coef::INFLPRES] = coefs[Coef::NOMPRES];
        }
        let pressure = TyrePressure {
            inflation_pa: self
                .inflation
                .as_ref()
                .map(|r| units.to_si(r.value, Dim::Pressure)),
            nominal_pa: self
                .nominal
                .as_ref()
                .map(|r| units.to_si(r.value, Dim::Pressure)),
        };
        let file = TirFile {
            coefs,
            present,
            version,
            declaration,
            use_mode: self.use_mode.map(|(v, _)| v),
            tyre_side: self.tyre_side,
            pressure,
            source_units: units,
            header: self.header,
            header_comments: self.header_comments,
            shape: self.shape,
            extra_keys: self.extra_keys.into_iter().map(|(k, _)| k).collect(),
            extra_sections: self.extra_sections,
        };
        Ok((file, self.warnings))
    }

    /// Warnings about what `[UNITS]` does not convert.
    fn warn_units(&mut self, units: &Units) {
        if units.is_si() {
            return;
        }
        if (units.angle_rad - 1.0).abs() > 1e-15 {
            let line = self
                .unit_lines
                .iter()
                .find(|(_, k)| k == "ANGLE")
                .map_or(0, |(l, _)| *l);
            self.warn(
                line,
                "ANGLE is not radians: the angle ranges are converted; Magic Formula \
                 coefficients are per radian by definition and are read as written",
            );
        }
        let unconverted: Vec<(usize, String)> = self
            .extra_keys
            .iter()
            .filter(|(k, _)| matches!(k.entry.value, Value::Number(_)) && k.section != "UNITS")
            .map(|(k, l)| (*l, k.entry.key.clone()))
            .collect();
        for (line, key) in unconverted {
            self.warn(
                line,
                format!("{key} is not a PAC2002 key: kept as written, not unit-converted"),
            );
        }
    }

    /// Which Magic Formula is this? `FITTYP` decides when present (it is the version switch
    /// MFeval and MF-Tyre use); `PROPERTY_FILE_FORMAT` otherwise.
    fn check_declaration(&mut self) -> Result<(Declaration, Version), TirReadError> {
        let pff = self.property_file_format.clone();
        let fittyp = self.fittyp;
        let mut version = match fittyp {
            Some((6 | 21, _)) => Some(Version::Pac2002),
            Some((v @ (5 | 52), line)) => {
                self.warn(
                    line,
                    format!("FITTYP {v} (MF-Tyre 5.x export) read as MF 5.2 (FITTYP 6)"),
                );
                Some(Version::Pac2002)
            }
            Some((61, _)) => Some(Version::Mf61),
            Some((62, _)) => Some(Version::Mf62),
            Some((v, line)) => {
                return Err(TirReadError::Unsupported {
                    line,
                    what: format!(
                        "FITTYP {v} (not a Magic Formula 5.2, 6.1 or 6.2 version number)"
                    ),
                });
            }
            None if pff.is_none() => {
                let line = self.section_line(Kind::Model);
                self.warn(
                    line,
                    "neither FITTYP nor PROPERTY_FILE_FORMAT; read as PAC2002",
                );
                None
            }
            None => None,
        };
        if let Some((name, line)) = &pff {
            let line = *line;
            let norm: String = name
                .to_ascii_uppercase()
                .chars()
                .filter(|c| c.is_ascii_alphanumeric())
                .collect();
            let rejected = [
                "PAC89", "PAC94", "PACMC", "PACTIME", "FIALA", "UA", "UATIRE", "FTIRE", "SWIFT",
                "MFSWIFT", "5PT",
            ];
            if rejected.contains(&norm.as_str()) {
                return Err(TirReadError::Unsupported {
                    line,
                    what: format!("PROPERTY_FILE_FORMAT '{name}'"),
                });
            }
            let declared = match norm.as_str() {
                "PAC2002" | "MF05" | "MF5" | "MF52" | "MFTYRE" | "MFTYRE52" | "MFTYRE5" => {
                    Some(Version::Pac2002)
                }
                "MF61" | "MF6" | "MFTYRE61" | "MFTYRE6" => Some(Version::Mf61),
                "MF62" | "MFTYRE62" => Some(Version::Mf62),
                _ => None,
            };
            match (version, declared) {
                (Some(v), Some(d)) if v != d => self.warn(
                    line,
                    format!(
                        "PROPERTY_FILE_FORMAT '{name}' says {d}, FITTYP says {v}; FITTYP decides"
                    ),
                ),
                (None, Some(d)) => version = Some(d),
                (None, None) => self.warn(
                    line,
                    format!(
                        "PROPERTY_FILE_FORMAT '{name}' is not known and there is no FITTYP; read as PAC2002"
                    ),
                ),
                _ => {}
            }
        }
        let declaration = Declaration {
            property_file_format: pff.map(|(s, _)| s),
            fittyp: fittyp.map(|(v, _)| v),
        };
        Ok((declaration, version.unwrap_or(Version::Pac2002)))
    }

    /// Known coefficients the version does not carry become uninterpreted keys of the section
    /// they were found in, in file order (written back as read, not used).
    fn set_aside_foreign_keys(&mut self, version: Version) {
        let mut moved = Vec::new();
        for c in Coef::ALL {
            if c.carried_by(version) {
                continue;
            }
            let Some(raw) = self.coefs[c.index()].take() else {
                continue;
            };
            let value = raw.value.map_or(Value::Empty, Value::Number);
            moved.push((
                ExtraKey {
                    section: raw.section.tir_name().to_string(),
                    entry: Entry {
                        key: c.name().to_string(),
                        value,
                    },
                },
                raw.line,
            ));
            // A value that differs from what the version would assume matters; a default one
            // (LGAY = 1 in an MF 6.x file, QSX12 = 0 in a PAC2002 file) does not.
            if raw.value.is_some_and(|v| v != c.default_value()) {
                self.warnings.push(ReadWarning {
                    line: raw.line,
                    message: format!(
                        "{} is not a key of {version}: kept as written, not used",
                        c.name()
                    ),
                });
            }
        }
        if moved.is_empty() {
            return;
        }
        self.extra_keys.extend(moved);
        self.extra_keys.sort_by_key(|(_, line)| *line);
    }

    /// MF 6.x keeps its pressures as the coefficients `INFLPRES` and `NOMPRES`.
    fn pressures_as_coefficients(&mut self, version: Version) {
        let conditions = self.section_line(Kind::Conditions);
        for (slot, coef) in [
            (self.inflation.take(), Coef::INFLPRES),
            (self.nominal.take(), Coef::NOMPRES),
        ] {
            if let Some(raw) = slot {
                self.coefs[coef.index()] = Some(RawCoef {
                    value: Some(raw.value),
                    line: raw.line,
                    section: Section::OperatingConditions,
                });
            }
        }
        if self.coefs[Coef::NOMPRES.index()]
            .as_ref()
            .and_then(|r| r.value)
            .is_none()
        {
            self.warn(
                conditions,
                format!(
                    "no NOMPRES (nominal inflation pressure) for {version}; MFeval's default \
                     220000 Pa is used"
                ),
            );
        }
        if self.coefs[Coef::INFLPRES.index()]
            .as_ref()
            .and_then(|r| r.value)
            .is_none()
        {
            self.warn(
                conditions,
                "no INFLPRES (inflation pressure); NOMPRES is the default pressure",
            );
        }
    }
}

/// Replace an entry with the same key, or append.
fn upsert(entries: &mut Vec<Entry>, entry: Entry) {
    match entries.iter_mut().find(|e| e.key == entry.key) {
        Some(e) => *e = entry,
        None => entries.push(entry),
    }
}

/// A numeric value: `Ok(None)` (with a warning) when empty.
fn number(
    key: &str,
    value: &RawValue<'_>,
    line: usize,
    warnings: &mut Vec<ReadWarning>,
) -> Result<Option<f64>, TirReadError> {
    let bad = |found: &str| TirReadError::NotANumber {
        line,
        key: key.to_string(),
        found: found.to_string(),
    };
    match value {
        RawValue::Empty => {
            warnings.push(ReadWarning {
                line,
                message: format!("{key} has no value; the default is used"),
            });
            Ok(None)
        }
        RawValue::Bare(s) => parse_number(s).map(Some).ok_or_else(|| bad(s)),
        RawValue::Quoted(s) => {
            let v = parse_number(s).ok_or_else(|| bad(s))?;
            warnings.push(ReadWarning {
                line,
                message: format!("{key} is a quoted number; read as {v}"),
            });
            Ok(Some(v))
        }
    }
}

/// An integer value (`6`, `6.0`, `'6'`).
fn integer(
    key: &str,
    value: &RawValue<'_>,
    line: usize,
    warnings: &mut Vec<ReadWarning>,
) -> Result<Option<i64>, TirReadError> {
    let Some(v) = number(key, value, line, warnings)? else {
        return Ok(None);
    };
    if v.fract() != 0.0 || v.abs() > 1e9 {
        return Err(TirReadError::NotANumber {
            line,
            key: key.to_string(),
            found: format!("{v} (an integer is expected)"),
        });
    }
    Ok(Some(v as i64))
}
