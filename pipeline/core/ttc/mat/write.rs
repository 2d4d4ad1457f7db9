//! MAT-file level 5 encoder: named [`MatValue`]s -> bytes that MATLAB, scipy and [`parse_mat`]
//! read.
//!
//! In: variables pushed one by one (numeric arrays of any class, char arrays, cells, structs),
//! each optionally zlib-compressed. Out: the file as `Vec<u8>`, little-endian, deterministic
//! (same input, same bytes: no timestamp unless the caller puts one in the header text).
//! Written the way MATLAB does: numeric data in the class's own type (`miDOUBLE` for double,
//! `miUINT8` for uint8, ...), char data as `miUINT16`, names as small elements when they fit,
//! struct field names in 32-byte slots. Deliberately not here: files on disk, complex, sparse,
//! logical and object arrays.
//!
//! [`parse_mat`]: super::parse_mat

use std::io::Write;

use flate2::write::ZlibEncoder;
use thiserror::Error;

use super::read::{
    HEADER_LEN, HEADER_TEXT_LEN, MI_COMPRESSED, MI_DOUBLE, MI_INT8, MI_INT16, MI_INT32, MI_INT64,
    MI_MATRIX, MI_SINGLE, MI_UINT8, MI_UINT16, MI_UINT32, MI_UINT64, MX_CELL, MX_CHAR, MX_STRUCT,
};
use super::{MatValue, NumericClass};

/// Whether an element is stored as is or zlib-compressed (`miCOMPRESSED`, as `save -v7` does).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Compression {
    None,
    Zlib,
}

/// A value the writer refuses (the file so far is unchanged).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MatWriteError {
    #[error("MAT writer: variable {name:?}: {problem}")]
    Invalid { name: String, problem: ValueProblem },
}

/// What is wrong with a value (or a part of it: the `In*` variants say where).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ValueProblem {
    #[error("{0:?} is not a MATLAB name (a letter, then letters, digits or _, at most 63)")]
    BadName(String),
    #[error("a variable of this name was already written")]
    AlreadyWritten,
    #[error("dimensions overflow")]
    DimensionsOverflow,
    #[error("dimensions {0:?}: need at least two, each below 2^31")]
    BadDimensions(Vec<usize>),
    #[error("cannot write an unsupported value ({0})")]
    Unsupported(String),
    #[error("{found} values, but dimensions {dims:?} need {expected}")]
    Count {
        found: usize,
        expected: usize,
        dims: Vec<usize>,
    },
    #[error("value {value} at index {index} does not fit {class}")]
    DoesNotFit {
        value: f64,
        index: usize,
        class: &'static str,
    },
    #[error("a struct needs at least one field")]
    NoFields,
    #[error("element larger than 4 GiB")]
    TooLarge,
    #[error("zlib compression failed: {0}")]
    Zlib(String),
    #[error("field name: {0}")]
    FieldName(Box<ValueProblem>),
    #[error("cell {index}: {problem}")]
    InCell {
        index: usize,
        problem: Box<ValueProblem>,
    },
    #[error("field {field}: {problem}")]
    InField {
        field: String,
        problem: Box<ValueProblem>,
    },
}

/// Builds a MAT-file in memory.
///
/// ```
/// use tirebase_core::ttc::mat::{Compression, MatWriter, parse_mat};
/// let mut writer = MatWriter::new("MATLAB 5.0 MAT-file, Platform: tirebase");
/// writer.push_column("ET", &[0.0, 0.01], Compression::None).unwrap();
/// writer.push_text("tireid", "Hoosier 43100 18.0x6.0-10 R20, 7 inch rim", Compression::Zlib).unwrap();
/// let file = parse_mat(&writer.finish(), "doc.mat").unwrap();
/// assert_eq!(file.variables[0].value.as_vector(), Some(&[0.0, 0.01][..]));
/// ```
#[derive(Clone, Debug)]
pub struct MatWriter {
    bytes: Vec<u8>,
    names: Vec<String>,
}

impl MatWriter {
    /// Start a file. `header_text` (ASCII, at most 116 bytes are kept) should start with
    /// `MATLAB 5.0 MAT-file`; MATLAB itself writes `MATLAB 5.0 MAT-file, Platform: PCWIN64,
    /// Created on: Mon Aug  1 19:19:00 2018`.
    /// Text not starting with `MATLAB` gets `MATLAB 5.0 MAT-file, ` put in front (readers
    /// require it).
    pub fn new(header_text: &str) -> MatWriter {
        let mut bytes = Vec::with_capacity(1 << 16);
        let header_text = if header_text.starts_with("MATLAB") {
            header_text.to_string()
        } else {
            format!("MATLAB 5.0 MAT-file, {header_text}")
        };
        let text: Vec<u8> = header_text
            .bytes()
            .map(|b| if b.is_ascii() && b >= b' ' { b } else { b'?' })
            .take(HEADER_TEXT_LEN)
            .collect();
        bytes.extend_from_slice(&text);
        bytes.resize(HEADER_TEXT_LEN, b' ');
        bytes.extend_from_slice(&[0; 8]); // no subsystem data
        bytes.extend_from_slice(&0x0100u16.to_le_bytes()); // version
        bytes.extend_from_slice(b"IM"); // little-endian
        debug_assert_eq!(bytes.len(), HEADER_LEN);
        MatWriter {
            bytes,
            names: Vec::new(),
        }
    }

    /// Append any supported value as a top-level variable.
    pub fn push(
        &mut self,
        name: &str,
        value: &MatValue,
        compression: Compression,
    ) -> Result<(), MatWriteError> {
        let invalid = |problem: ValueProblem| MatWriteError::Invalid {
            name: name.to_string(),
            problem,
        };
        check_name(name).map_err(invalid)?;
        if self.names.iter().any(|n| n == name) {
            return Err(invalid(ValueProblem::AlreadyWritten));
        }
        let mut element = Vec::new();
        encode_matrix(&mut element, name, value).map_err(invalid)?;
        match compression {
            Compression::None => self.bytes.extend_from_slice(&element),
            Compression::Zlib => {
                let mut encoder = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                encoder
                    .write_all(&element)
                    .and_then(|()| encoder.finish())
                    .map(|compressed| {
                        push_tag(&mut self.bytes, MI_COMPRESSED, compressed.len());
                        self.bytes.extend_from_slice(&compressed);
                    })
                    .map_err(|e| invalid(ValueProblem::Zlib(e.to_string())))?;
            }
        }
        self.names.push(name.to_string());
        Ok(())
    }

    /// An N x 1 double column.
    pub fn push_column(
        &mut self,
        name: &str,
        values: &[f64],
        compression: Compression,
    ) -> Result<(), MatWriteError> {
        self.push(name, &MatValue::column(values.to_vec()), compression)
    }

    /// An N x 1 uint8 column (how TTC files store `RUN`).
    pub fn push_uint8_column(
        &mut self,
        name: &str,
        values: &[u8],
        compression: Compression,
    ) -> Result<(), MatWriteError> {
        let value = MatValue::Numeric {
            class: NumericClass::Uint8,
            dims: vec![values.len(), 1],
            data: values.iter().map(|v| f64::from(*v)).collect(),
        };
        self.push(name, &value, compression)
    }

    /// A 1 x N char array.
    pub fn push_text(
        &mut self,
        name: &str,
        text: &str,
        compression: Compression,
    ) -> Result<(), MatWriteError> {
        self.push(name, &MatValue::text(text), compression)
    }

    /// A 1 x 1 struct whose fields are 1 x K cell arrays of char (the TTC `channel` struct:
    /// `[("name", names), ("units", units)]`).
    pub fn push_struct_of_text_cells(
        &mut self,
        name: &str,
        fields: &[(&str, &[&str])],
        compression: Compression,
    ) -> Result<(), MatWriteError> {
        let value = MatValue::Struct {
            dims: vec![1, 1],
            fields: fields.iter().map(|(f, _)| f.to_string()).collect(),
            values: fields
                .iter()
                .map(|(_, texts)| MatValue::text_cells(texts))
                .collect(),
        };
        self.push(name, &value, compression)
    }

    /// The finished file.
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

/// MATLAB identifiers: a letter, then letters, digits or `_`, at most 63 characters.
fn check_name(name: &str) -> Result<(), ValueProblem> {
    let mut chars = name.chars();
    let valid = chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && name.len() <= 63;
    if valid {
        Ok(())
    } else {
        Err(ValueProblem::BadName(name.to_string()))
    }
}

/// Append a full `miMATRIX` element (tag included) for `value`.
fn encode_matrix(out: &mut Vec<u8>, name: &str, value: &MatValue) -> Result<(), ValueProblem> {
    let tag_at = out.len();
    push_tag(out, MI_MATRIX, 0);
    let dims = value.dims().to_vec();
    let count = dims
        .iter()
        .try_fold(1usize, |acc, d| acc.checked_mul(*d))
        .ok_or(ValueProblem::DimensionsOverflow)?;
    if dims.len() < 2 || dims.iter().any(|d| i32::try_from(*d).is_err()) {
        return Err(ValueProblem::BadDimensions(dims));
    }
    let class = match value {
        MatValue::Numeric { class, .. } => numeric_class_code(*class),
        MatValue::Char { .. } => MX_CHAR,
        MatValue::Cell { .. } => MX_CELL,
        MatValue::Struct { .. } => MX_STRUCT,
        MatValue::Unsupported { description } => {
            return Err(ValueProblem::Unsupported(description.clone()));
        }
    };
    push_element(
        out,
        MI_UINT32,
        &[u32::from(class).to_le_bytes(), [0; 4]].concat(),
    );
    let dim_bytes: Vec<u8> = dims
        .iter()
        .flat_map(|d| (*d as i32).to_le_bytes())
        .collect();
    push_element(out, MI_INT32, &dim_bytes);
    push_element(out, MI_INT8, name.as_bytes());
    match value {
        MatValue::Numeric { class, data, .. } => {
            expect_count(data.len(), count, &dims)?;
            let (data_type, bytes) = numeric_storage(*class, data)?;
            push_element(out, data_type, &bytes);
        }
        MatValue::Char { utf16, .. } => {
            expect_count(utf16.len(), count, &dims)?;
            let bytes: Vec<u8> = utf16.iter().flat_map(|u| u.to_le_bytes()).collect();
            push_element(out, MI_UINT16, &bytes);
        }
        MatValue::Cell { items, .. } => {
            expect_count(items.len(), count, &dims)?;
            for (k, item) in items.iter().enumerate() {
                encode_matrix(out, "", item).map_err(|e| ValueProblem::InCell {
                    index: k + 1,
                    problem: Box::new(e),
                })?;
            }
        }
        MatValue::Struct { fields, values, .. } => {
            encode_struct_fields(out, fields)?;
            expect_count(values.len(), count * fields.len(), &dims)?;
            for (k, item) in values.iter().enumerate() {
                let field = &fields[k % fields.len().max(1)];
                encode_matrix(out, "", item).map_err(|e| ValueProblem::InField {
                    field: field.clone(),
                    problem: Box::new(e),
                })?;
            }
        }
        MatValue::Unsupported { .. } => unreachable!("rejected above"),
    }
    let len = out.len() - tag_at - 8;
    let len = u32::try_from(len).map_err(|_| ValueProblem::TooLarge)?;
    out[tag_at + 4..tag_at + 8].copy_from_slice(&len.to_le_bytes());
    Ok(())
}

/// Field name length (small element) and the names in fixed-width NUL-padded slots.
fn encode_struct_fields(out: &mut Vec<u8>, fields: &[String]) -> Result<(), ValueProblem> {
    if fields.is_empty() {
        return Err(ValueProblem::NoFields);
    }
    for field in fields {
        check_name(field).map_err(|e| ValueProblem::FieldName(Box::new(e)))?;
    }
    let longest = fields.iter().map(String::len).max().unwrap_or(0);
    let slot = if longest < 32 { 32 } else { 64 };
    push_element(out, MI_INT32, &(slot as i32).to_le_bytes());
    let mut names = Vec::with_capacity(slot * fields.len());
    for field in fields {
        names.extend_from_slice(field.as_bytes());
        names.resize(names.len() + slot - field.len(), 0);
    }
    push_element(out, MI_INT8, &names);
    Ok(())
}

fn expect_count(found: usize, expected: usize, dims: &[usize]) -> Result<(), ValueProblem> {
    if found == expected {
        Ok(())
    } else {
        Err(ValueProblem::Count {
            found,
            expected,
            dims: dims.to_vec(),
        })
    }
}

fn numeric_class_code(class: NumericClass) -> u8 {
    match class {
        NumericClass::Double => 6,
        NumericClass::Single => 7,
        NumericClass::Int8 => 8,
        NumericClass::Uint8 => 9,
        NumericClass::Int16 => 10,
        NumericClass::Uint16 => 11,
        NumericClass::Int32 => 12,
        NumericClass::Uint32 => 13,
        NumericClass::Int64 => 14,
        NumericClass::Uint64 => 15,
    }
}

/// The class's own storage type and the little-endian bytes. Integer classes require integral
/// values in range; single rounds to `f32`.
fn numeric_storage(class: NumericClass, data: &[f64]) -> Result<(u32, Vec<u8>), ValueProblem> {
    fn integers<const N: usize>(
        data: &[f64],
        min: f64,
        max: f64,
        class: NumericClass,
        to_bytes: impl Fn(f64) -> [u8; N],
    ) -> Result<Vec<u8>, ValueProblem> {
        let mut bytes = Vec::with_capacity(data.len() * N);
        for (k, v) in data.iter().enumerate() {
            if !(v.fract() == 0.0 && *v >= min && *v <= max) {
                return Err(ValueProblem::DoesNotFit {
                    value: *v,
                    index: k,
                    class: class.name(),
                });
            }
            bytes.extend_from_slice(&to_bytes(*v));
        }
        Ok(bytes)
    }
    use NumericClass as C;
    Ok(match class {
        C::Double => (
            MI_DOUBLE,
            data.iter().flat_map(|v| v.to_le_bytes()).collect(),
        ),
        C::Single => (
            MI_SINGLE,
            data.iter()
                .flat_map(|v| (*v as f32).to_le_bytes())
                .collect(),
        ),
        C::Int8 => (
            MI_INT8,
            integers(data, -128.0, 127.0, class, |v| (v as i8).to_le_bytes())?,
        ),
        C::Uint8 => (
            MI_UINT8,
            integers(data, 0.0, 255.0, class, |v| (v as u8).to_le_bytes())?,
        ),
        C::Int16 => (
            MI_INT16,
            integers(data, -32768.0, 32767.0, class, |v| (v as i16).to_le_bytes())?,
        ),
        C::Uint16 => (
            MI_UINT16,
            integers(data, 0.0, 65535.0, class, |v| (v as u16).to_le_bytes())?,
        ),
        C::Int32 => (
            MI_INT32,
            integers(data, -2147483648.0, 2147483647.0, class, |v| {
                (v as i32).to_le_bytes()
            })?,
        ),
        C::Uint32 => (
            MI_UINT32,
            integers(data, 0.0, 4294967295.0, class, |v| (v as u32).to_le_bytes())?,
        ),
        C::Int64 => (
            MI_INT64,
            integers(data, -9.2e18, 9.2e18, class, |v| (v as i64).to_le_bytes())?,
        ),
        C::Uint64 => (
            MI_UINT64,
            integers(data, 0.0, 1.8e19, class, |v| (v as u64).to_le_bytes())?,
        ),
    })
}

fn push_tag(out: &mut Vec<u8>, data_type: u32, len: usize) {
    out.extend_from_slice(&data_type.to_le_bytes());
    out.extend_from_slice(&(len as u32).to_le_bytes());
}

/// A data element: small format when the data fits in 4 bytes, else tag + data + padding to 8.
fn push_element(out: &mut Vec<u8>, data_type: u32, data: &[u8]) {
    if !data.is_empty() && data.len() <= 4 {
        out.extend_from_slice(&(data_type | ((data.len() as u32) << 16)).to_le_bytes());
        out.extend_from_slice(data);
        out.resize(out.len() + 4 - data.len(), 0);
    } else {
        push_tag(out, data_type, data.len());
        out.extend_from_slice(data);
        out.resize(out.len().next_multiple_of(8), 0);
    }
}
