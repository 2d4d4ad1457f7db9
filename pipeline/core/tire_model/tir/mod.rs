//! The `.tir` tire property file (Adams / MF-Tyre "TeimOrbit" layout) for PAC2002 / MF 5.2 and
//! MF 6.1 / 6.2.
//!
//! In: the text of a `.tir` file ([`TirFile::parse`], or [`TirFile::parse_bytes`] for raw bytes
//! that may be Latin-1). Out: a [`TirFile`] (its model [`Version`], every coefficient of that
//! version converted to SI, which keys the file carried, its string keys, pressures, `[SHAPE]`
//! table, and everything it did not understand kept in order), warnings about what was
//! tolerated, and [`TirFile::model`]. The other way: [`TirFile::render`] writes a complete file
//! of the same version (PAC2002 in the Adams layout, MF 6.x in the MF-Tyre 6.1 layout), so that
//! `parse(render(x)) == x` exactly; [`convert`] moves a model between versions.
//! [`lint`] reports physical problems over the file's envelope.
//!
//! Deliberately not here: reading from disk (callers pass text), turn-slip, inertia and
//! contact-patch parameters beyond keeping them, and any unit handling beyond `[UNITS]` (see
//! [`units`] for which keys carry a dimension; Magic Formula coefficients are dimensionless and
//! never converted).

pub mod convert;
mod lexer;
pub mod lint;
mod read;
pub mod units;
mod write;

pub use read::{ReadWarning, TirReadError};
pub use units::Units;
pub use write::{TirWriteError, format_f64};

use super::pac2002::MagicFormula;
use super::params::{Coef, Coefs, N_COEFS};
use super::version::Version;

/// A value of a key this module does not interpret (kept as read, written back as is).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A number (Fortran `D` exponents already turned into `f64`).
    Number(f64),
    /// A string, quoted or not in the source (written back quoted).
    Text(String),
    /// `KEY =` with nothing after it.
    Empty,
}

/// One `KEY = value` pair, key in upper case.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// The key, upper case.
    pub key: String,
    /// Its value.
    pub value: Value,
}

/// A key this module does not interpret, found in a section it does know.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraKey {
    /// The section name, upper case, without brackets.
    pub section: String,
    /// The key and its value (numbers are NOT unit-converted).
    pub entry: Entry,
}

/// One content line of a section this module does not know.
#[derive(Clone, Debug, PartialEq)]
pub enum ExtraLine {
    /// `KEY = value`.
    Entry(Entry),
    /// Anything else: a `{...}` table header or a table row, trimmed, comments removed.
    Text(String),
}

/// A section this module does not know (e.g. `[DEFLECTION_LOAD_CURVE]`), kept in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraSection {
    /// The section name, upper case, without brackets.
    pub name: String,
    /// Its content lines in order (comments dropped).
    pub lines: Vec<ExtraLine>,
}

/// The `[SHAPE]` table: a `{...}` header naming the columns, then rows of numbers
/// (dimensionless: radius and width relative to the tire's).
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeTable {
    /// Column names from the `{radial width}` header (lower case as written).
    pub columns: Vec<String>,
    /// The rows.
    pub rows: Vec<Vec<f64>>,
}

/// Inflation pressures of a PAC2002 file, Pa. Read from `[TYRE_CONDITIONS] IP / IP_NOM`
/// (Adams PAC2002) or `[OPERATING_CONDITIONS] INFLPRES / NOMPRES` (MF 6.x style); written as
/// the former. An MF 6.x file keeps its pressures as the coefficients `INFLPRES` and `NOMPRES`
/// instead (see [`TirFile::pressures`] for either).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TyrePressure {
    /// Inflation pressure of the test, Pa.
    pub inflation_pa: Option<f64>,
    /// Nominal inflation pressure, Pa.
    pub nominal_pa: Option<f64>,
}

/// How the file declared its model (as read; the writer declares its version's `FITTYP`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Declaration {
    /// `[MODEL] PROPERTY_FILE_FORMAT`, as written (e.g. `PAC2002`, `MF_05`, `USER`).
    pub property_file_format: Option<String>,
    /// `[MODEL] FITTYP` (6 or 21 for MF 5.2; absent in many Adams PAC2002 files).
    pub fittyp: Option<i64>,
}

/// A Magic Formula tire property file in memory. All coefficient values are SI (m, N, rad,
/// kg, s, Pa), whatever `[UNITS]` the source file declared.
#[derive(Clone, Debug, PartialEq)]
pub struct TirFile {
    /// Every coefficient; keys the file did not carry (and keys its version does not carry) hold
    /// [`super::params::Coef::default_value`].
    pub coefs: Coefs<f64>,
    /// Which coefficients the file carried (with a non-empty value).
    pub present: Coefs<bool>,
    /// The model version (from `FITTYP`, else `PROPERTY_FILE_FORMAT`).
    pub version: Version,
    /// The model declaration of the source file.
    pub declaration: Declaration,
    /// `[MODEL] USE_MODE` (Adams: 1 Fx, 2 Fy+Mz, 3 uncombined, 4 combined, +10 relaxation,
    /// negative = mirrored).
    pub use_mode: Option<i64>,
    /// `[MODEL] TYRESIDE` as written (`Left`, `Right`, ...).
    pub tyre_side: Option<String>,
    /// Inflation pressures of a PAC2002 file (an MF 6.x file keeps them as coefficients).
    pub pressure: TyrePressure,
    /// The units the source file was written in (values here are already SI).
    pub source_units: Units,
    /// `[MDI_HEADER]` keys other than `FILE_TYPE`, `FILE_VERSION`, `FILE_FORMAT`.
    pub header: Vec<Entry>,
    /// `! : NAME : text` metadata comment lines of `[MDI_HEADER]`, verbatim.
    pub header_comments: Vec<String>,
    /// The `[SHAPE]` table, if any.
    pub shape: Option<ShapeTable>,
    /// Keys not interpreted here, in known sections, in file order.
    pub extra_keys: Vec<ExtraKey>,
    /// Sections not known here, in file order.
    pub extra_sections: Vec<ExtraSection>,
}

impl TirFile {
    /// A PAC2002 file holding `coefs` (all marked present) and nothing else: what a fitter
    /// writes.
    pub fn from_coefs(coefs: Coefs<f64>) -> TirFile {
        TirFile::from_coefs_as(coefs, Version::Pac2002)
    }

    /// A `version` file holding `coefs` (keys the version does not carry reset to their
    /// defaults; the others marked present) and nothing else.
    pub fn from_coefs_as(coefs: Coefs<f64>, version: Version) -> TirFile {
        let mut present = Coefs([true; N_COEFS]);
        for c in Coef::ALL {
            present[*c] = c.carried_by(version);
        }
        TirFile {
            coefs: coefs.restricted_to(version),
            present,
            version,
            declaration: Declaration {
                property_file_format: Some(
                    if version.is_mf6() { "USER" } else { "PAC2002" }.to_string(),
                ),
                fittyp: Some(version.fittyp()),
            },
            use_mode: Some(4),
            tyre_side: None,
            pressure: TyrePressure::default(),
            source_units: Units::SI,
            header: Vec::new(),
            header_comments: Vec::new(),
            shape: None,
            extra_keys: Vec::new(),
            extra_sections: Vec::new(),
        }
    }

    /// Parse the text of a `.tir` file. Warnings name what was tolerated (wrapped comment lines,
    /// empty values, repeated keys, ...); the error names the line that could not be read.
    pub fn parse(text: &str) -> Result<(TirFile, Vec<ReadWarning>), TirReadError> {
        read::parse(text)
    }

    /// Parse raw bytes: UTF-8, or Latin-1 when the bytes are not valid UTF-8 (comments of
    /// European tools carry `°` and `µ` that way). Binary data is an error naming the line.
    pub fn parse_bytes(bytes: &[u8]) -> Result<(TirFile, Vec<ReadWarning>), TirReadError> {
        match std::str::from_utf8(bytes) {
            Ok(text) => read::parse(text),
            Err(_) => {
                let text: String = bytes.iter().map(|&b| char::from(b)).collect();
                read::parse(&text)
            }
        }
    }

    /// Render as a complete file of its version (LF endings, SI units).
    pub fn render(&self) -> Result<String, TirWriteError> {
        write::render(self)
    }

    /// The model of these coefficients (its version's equations).
    pub fn model(&self) -> MagicFormula {
        MagicFormula::with_version(self.coefs.clone(), self.version)
    }

    /// The inflation pressures, Pa, whichever version: `[TYRE_CONDITIONS]` of a PAC2002 file,
    /// the `INFLPRES` / `NOMPRES` coefficients of an MF 6.x file (`None` when not carried).
    pub fn pressures(&self) -> TyrePressure {
        if self.version.is_mf6() {
            let get = |c: Coef| self.present[c].then_some(self.coefs[c]);
            TyrePressure {
                inflation_pa: get(Coef::INFLPRES),
                nominal_pa: get(Coef::NOMPRES),
            }
        } else {
            self.pressure
        }
    }
}

#[cfg(test)]
mod reference_tests;
#[cfg(test)]
mod tests;
