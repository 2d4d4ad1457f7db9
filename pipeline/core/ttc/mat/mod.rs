//! MATLAB level 5 MAT-files: a general decoder and encoder, and the TTC `.mat` -> [`RunTable`]
//! mapping.
//!
//! In: MAT-file bytes (uncompressed `miMATRIX` and zlib `miCOMPRESSED` elements, either byte
//! order). Out: [`MatFile`] (named [`MatValue`]s: numeric arrays as `f64`, char arrays, cells,
//! structs) and, from a TTC file's variable set, a [`RunTable`]. [`MatWriter`] writes the same
//! subset (what the virtual test machine needs). Deliberately not here: MATLAB v4 files, v7.3
//! (HDF5) files (a clear error says to re-save with `-v7`), sparse arrays, objects, function
//! handles (decoded as [`MatValue::Unsupported`] and ignored with a warning), complex data.

mod read;
mod write;

pub use read::{ElementProblem, MatFile, looks_like_mat, parse_mat};
pub use write::{Compression, MatWriteError, MatWriter, ValueProblem};

use super::build::{SourceColumn, build};
use super::error::printable;
use super::{ColumnInfo, RunMeta, RunTable, SourceFormat, TtcChannel, TtcError, Unit};

/// The class a numeric array had in MATLAB (storage may use a smaller type; values are `f64`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum NumericClass {
    Double,
    Single,
    Int8,
    Uint8,
    Int16,
    Uint16,
    Int32,
    Uint32,
    Int64,
    Uint64,
}

impl NumericClass {
    /// MATLAB's name for the class.
    pub fn name(self) -> &'static str {
        match self {
            NumericClass::Double => "double",
            NumericClass::Single => "single",
            NumericClass::Int8 => "int8",
            NumericClass::Uint8 => "uint8",
            NumericClass::Int16 => "int16",
            NumericClass::Uint16 => "uint16",
            NumericClass::Int32 => "int32",
            NumericClass::Uint32 => "uint32",
            NumericClass::Int64 => "int64",
            NumericClass::Uint64 => "uint64",
        }
    }
}

/// A decoded MATLAB array. Multi-element data is column-major, as in the file.
#[derive(Clone, Debug, PartialEq)]
pub enum MatValue {
    /// A real numeric (or logical) array, every value converted to `f64` (64-bit integers above
    /// 2^53 lose precision).
    Numeric {
        class: NumericClass,
        dims: Vec<usize>,
        data: Vec<f64>,
    },
    /// A char array as UTF-16 code units.
    Char { dims: Vec<usize>, utf16: Vec<u16> },
    /// A cell array.
    Cell {
        dims: Vec<usize>,
        items: Vec<MatValue>,
    },
    /// A struct array: `values[element * fields.len() + field]`.
    Struct {
        dims: Vec<usize>,
        fields: Vec<String>,
        values: Vec<MatValue>,
    },
    /// A class this decoder skips (sparse, object, function handle, complex numeric, ...).
    Unsupported { description: String },
}

impl MatValue {
    /// An N x 1 double column.
    pub fn column(data: Vec<f64>) -> MatValue {
        MatValue::Numeric {
            class: NumericClass::Double,
            dims: vec![data.len(), 1],
            data,
        }
    }

    /// A 1 x N char array.
    pub fn text(text: &str) -> MatValue {
        let utf16: Vec<u16> = text.encode_utf16().collect();
        MatValue::Char {
            dims: vec![1, utf16.len()],
            utf16,
        }
    }

    /// A 1 x K cell array of 1 x N char arrays.
    pub fn text_cells<S: AsRef<str>>(texts: &[S]) -> MatValue {
        MatValue::Cell {
            dims: vec![1, texts.len()],
            items: texts.iter().map(|t| MatValue::text(t.as_ref())).collect(),
        }
    }

    /// The dimensions (empty for [`MatValue::Unsupported`]).
    pub fn dims(&self) -> &[usize] {
        match self {
            MatValue::Numeric { dims, .. }
            | MatValue::Char { dims, .. }
            | MatValue::Cell { dims, .. }
            | MatValue::Struct { dims, .. } => dims,
            MatValue::Unsupported { .. } => &[],
        }
    }

    /// The data of a numeric vector (N x 1, 1 x N, or any shape with one non-singleton
    /// dimension); `None` for matrices and non-numeric values.
    pub fn as_vector(&self) -> Option<&[f64]> {
        match self {
            MatValue::Numeric { dims, data, .. }
                if dims.iter().filter(|d| **d != 1).count() <= 1 =>
            {
                Some(data)
            }
            _ => None,
        }
    }

    /// A char array as text: rows joined by `\n`, trailing blanks of each row trimmed.
    pub fn as_text(&self) -> Option<String> {
        let MatValue::Char { dims, utf16 } = self else {
            return None;
        };
        let rows = dims.first().copied().unwrap_or(0);
        if rows <= 1 {
            return Some(String::from_utf16_lossy(utf16));
        }
        let cols = utf16.len() / rows;
        let text_rows: Vec<String> = (0..rows)
            .map(|r| {
                let row: Vec<u16> = (0..cols).map(|c| utf16[r + c * rows]).collect();
                String::from_utf16_lossy(&row).trim_end().to_string()
            })
            .collect();
        Some(text_rows.join("\n"))
    }

    /// A field of a 1 x 1 struct.
    pub fn field(&self, name: &str) -> Option<&MatValue> {
        match self {
            MatValue::Struct { fields, values, .. } if values.len() == fields.len() => fields
                .iter()
                .position(|f| f == name)
                .map(|index| &values[index]),
            _ => None,
        }
    }

    /// Short description for messages: `double 1000x1`, `cell 1x22`, `sparse`.
    pub fn describe(&self) -> String {
        let class = match self {
            MatValue::Numeric { class, .. } => class.name(),
            MatValue::Char { .. } => "char",
            MatValue::Cell { .. } => "cell",
            MatValue::Struct { .. } => "struct",
            MatValue::Unsupported { description } => return description.clone(),
        };
        let dims: Vec<String> = self.dims().iter().map(usize::to_string).collect();
        format!("{class} {}", dims.join("x"))
    }
}

/// A top-level variable.
#[derive(Clone, Debug, PartialEq)]
pub struct MatVariable {
    pub name: String,
    pub value: MatValue,
}

/// Variables of a TTC `.mat` that are metadata, not channels.
const META_VARIABLES: [&str; 4] = ["channel", "source", "testid", "tireid"];

/// Parse a TTC `.mat` file into a run.
pub fn read_mat(bytes: &[u8], source_name: &str) -> Result<RunTable, TtcError> {
    if bytes.is_empty() {
        return Err(TtcError::Empty {
            source_name: source_name.to_string(),
        });
    }
    let file = parse_mat(bytes, source_name)?;
    run_from_variables(file.variables, source_name)
}

/// Map the TTC variable set (channels, `RUN`, `channel`, `source`, `testid`, `tireid`) to a run.
fn run_from_variables(
    variables: Vec<MatVariable>,
    source_name: &str,
) -> Result<RunTable, TtcError> {
    let variable_error = |name: &str, message: String| TtcError::MatVariable {
        source_name: source_name.to_string(),
        name: printable(name),
        message,
    };
    let mut meta = RunMeta::new(source_name, SourceFormat::Mat);
    let units = channel_units(&variables, source_name)?;
    let text_of = |name: &str| {
        variables
            .iter()
            .find(|v| v.name == name)
            .and_then(|v| v.value.as_text())
    };
    meta.source = text_of("source");
    meta.testid = text_of("testid");
    meta.tireid = text_of("tireid");
    if let Some(tireid) = &meta.tireid {
        let (tire, rim) = split_tireid(tireid);
        meta.tire_name = Some(tire);
        meta.rim_width_in = rim;
    }

    let rows = variables
        .iter()
        .find(|v| TtcChannel::from_name(&v.name) == Some(TtcChannel::Et))
        .ok_or_else(|| TtcError::MissingChannel {
            source_name: source_name.to_string(),
            location: "variables".to_string(),
            channel: "ET".to_string(),
        })?;
    let rows = rows
        .value
        .as_vector()
        .ok_or_else(|| {
            variable_error(
                &rows.name,
                format!("expected an N x 1 vector, found {}", rows.value.describe()),
            )
        })?
        .len();
    if rows == 0 {
        return Err(variable_error("ET", "has no samples".to_string()));
    }

    let mut columns: Vec<SourceColumn> = Vec::new();
    let mut assumed = Vec::new();
    for variable in variables {
        let MatVariable { name, value } = variable;
        if name.is_empty() || META_VARIABLES.contains(&name.as_str()) {
            continue;
        }
        let channel = TtcChannel::from_name(&name);
        let Some(data) = value.as_vector().filter(|d| d.len() == rows) else {
            let found = value.describe();
            if channel.is_some() {
                return Err(variable_error(
                    &name,
                    format!("expected a {rows} x 1 numeric vector like ET, found {found}"),
                ));
            }
            meta.warnings.push(format!(
                "variable {} ({found}) ignored: not a {rows} x 1 vector",
                printable(&name)
            ));
            continue;
        };
        if let Some(other) = columns
            .iter()
            .find(|c| c.info.channel.is_some() && c.info.channel == channel)
        {
            return Err(variable_error(
                &name,
                format!(
                    "channel given twice (also variable {})",
                    printable(&other.info.name)
                ),
            ));
        }
        let from_file = units.iter().find(|u| u.name.eq_ignore_ascii_case(&name));
        let (unit_raw, unit) = match (channel, from_file) {
            (Some(channel), Some(entry)) => {
                let unit = channel
                    .parse_unit(&entry.unit)
                    .map_err(|message| TtcError::Unit {
                        source_name: source_name.to_string(),
                        location: format!("variable channel, units{{{}}}", entry.index + 1),
                        channel: printable(&name),
                        message: Box::new(message),
                    })?;
                (entry.unit.clone(), Some(unit))
            }
            (Some(channel), None) => {
                assumed.push(channel.name());
                (
                    channel.si_fallback_spelling().to_string(),
                    Some(channel.si_fallback_unit()),
                )
            }
            (None, Some(entry)) => (entry.unit.clone(), Unit::parse(&entry.unit)),
            (None, None) => (String::new(), None),
        };
        columns.push(SourceColumn {
            info: ColumnInfo {
                name,
                channel,
                unit_raw,
                unit,
                system: unit.map(Unit::system),
                unit_from_file: from_file.is_some(),
            },
            values: data.to_vec(),
        });
    }
    if units.is_empty() {
        meta.warnings.push(
            "no unit metadata (no channel struct): every channel read in the SI .mat units \
             (s, km/h, rpm, deg, cm, kPa, N, N m, degC) and cross-checked"
                .to_string(),
        );
    } else if !assumed.is_empty() {
        meta.warnings.push(format!(
            "no unit in the channel struct for {}: assumed the SI .mat spellings",
            assumed.join(" ")
        ));
    }
    build(meta, columns, "variables")
}

/// One entry of the `channel` struct: channel name, unit string, 0-based cell index.
struct UnitEntry {
    name: String,
    unit: String,
    index: usize,
}

/// The `channel` struct's `name`/`units` cells, if the file has one.
fn channel_units(variables: &[MatVariable], source_name: &str) -> Result<Vec<UnitEntry>, TtcError> {
    let Some(channel) = variables.iter().find(|v| v.name == "channel") else {
        return Ok(Vec::new());
    };
    let bad = |message: String| TtcError::MatVariable {
        source_name: source_name.to_string(),
        name: "channel".to_string(),
        message,
    };
    let texts = |field: &str| -> Result<Vec<String>, TtcError> {
        let value = channel.value.field(field).ok_or_else(|| {
            bad(format!(
                "expected a 1 x 1 struct with fields name and units, found {} without {field:?}",
                channel.value.describe()
            ))
        })?;
        let MatValue::Cell { items, .. } = value else {
            return Err(bad(format!(
                "field {field}: expected a cell array, found {}",
                value.describe()
            )));
        };
        items
            .iter()
            .enumerate()
            .map(|(k, item)| {
                item.as_text().ok_or_else(|| {
                    bad(format!(
                        "{field}{{{}}}: expected char, found {}",
                        k + 1,
                        item.describe()
                    ))
                })
            })
            .collect()
    };
    let names = texts("name")?;
    let units = texts("units")?;
    if names.len() != units.len() {
        return Err(bad(format!(
            "name has {} cells but units has {}",
            names.len(),
            units.len()
        )));
    }
    Ok(names
        .into_iter()
        .zip(units)
        .enumerate()
        .map(|(index, (name, unit))| UnitEntry {
            name: name.trim().to_string(),
            unit,
            index,
        })
        .collect())
}

/// `Hoosier 43100 18.0x6.0-10 R20, 7 inch rim` -> (`Hoosier 43100 18.0x6.0-10 R20`, Some(7.0)).
fn split_tireid(tireid: &str) -> (String, Option<f64>) {
    if let Some((tire, rim)) = tireid.rsplit_once(',') {
        let rim = rim.trim().to_ascii_lowercase();
        if let Some(width) = rim
            .strip_suffix("rim")
            .map(str::trim_end)
            .and_then(|r| r.strip_suffix("inch").or_else(|| r.strip_suffix("in")))
            .and_then(|w| w.trim().trim_end_matches('-').trim().parse::<f64>().ok())
        {
            return (tire.trim().to_string(), Some(width));
        }
    }
    (tireid.trim().to_string(), None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tireid_gives_tire_and_rim() {
        assert_eq!(
            split_tireid("Hoosier 43100 18.0x6.0-10 R20, 7 inch rim"),
            ("Hoosier 43100 18.0x6.0-10 R20".to_string(), Some(7.0))
        );
        assert_eq!(
            split_tireid("Goodyear D2696, 6.5 inch rim"),
            ("Goodyear D2696".to_string(), Some(6.5))
        );
        assert_eq!(
            split_tireid("Avon 7.0/16.0-10"),
            ("Avon 7.0/16.0-10".to_string(), None)
        );
    }
}
