//! MAT-file level 5 decoder: bytes -> named [`MatValue`]s.
//!
//! In: the whole file. Out: [`MatFile`], or a [`TtcError`] naming the element (its variable name
//! once known, else `#index`) and the byte offset of its tag. Every length in the file is checked
//! against the bytes actually present before anything is sliced or allocated, nesting is limited,
//! and zlib streams must reach their end marker, so truncated, corrupt or hostile input yields an
//! error, never a panic or a huge allocation. Deliberately not here: v4 and v7.3 files, sparse
//! and object data (skipped as [`MatValue::Unsupported`]).

use flate2::{Decompress, FlushDecompress, Status};
use thiserror::Error;

use super::{MatValue, MatVariable, NumericClass};
use crate::ttc::TtcError;
use crate::ttc::error::{excerpt, printable};

/// Size of the MAT-file header.
pub(super) const HEADER_LEN: usize = 128;
/// Bytes of descriptive text at the start of the header.
pub(super) const HEADER_TEXT_LEN: usize = 116;
/// The HDF5 signature (v7.3 files carry it at byte 512).
const HDF5_SIGNATURE: &[u8; 8] = b"\x89HDF\r\n\x1a\n";
/// Deepest cell/struct nesting accepted (TTC files need 2).
const MAX_DEPTH: usize = 16;

// Data types.
pub(super) const MI_INT8: u32 = 1;
pub(super) const MI_UINT8: u32 = 2;
pub(super) const MI_INT16: u32 = 3;
pub(super) const MI_UINT16: u32 = 4;
pub(super) const MI_INT32: u32 = 5;
pub(super) const MI_UINT32: u32 = 6;
pub(super) const MI_SINGLE: u32 = 7;
pub(super) const MI_DOUBLE: u32 = 9;
pub(super) const MI_INT64: u32 = 12;
pub(super) const MI_UINT64: u32 = 13;
pub(super) const MI_MATRIX: u32 = 14;
pub(super) const MI_COMPRESSED: u32 = 15;
pub(super) const MI_UTF8: u32 = 16;
pub(super) const MI_UTF16: u32 = 17;
pub(super) const MI_UTF32: u32 = 18;

// Array classes.
pub(super) const MX_CELL: u8 = 1;
pub(super) const MX_STRUCT: u8 = 2;
pub(super) const MX_CHAR: u8 = 4;
/// Array-flags bit: complex data follows.
const FLAG_COMPLEX: u32 = 0x0800;

/// A decoded MAT-file.
#[derive(Clone, Debug, PartialEq)]
pub struct MatFile {
    /// The header's descriptive text, trailing blanks removed.
    pub header_text: String,
    /// Whether the file is big-endian (`MI`).
    pub big_endian: bool,
    /// Top-level variables in file order (a subsystem element appears with an empty name).
    pub variables: Vec<MatVariable>,
}

/// What is wrong with one element of a MAT-file (the message after
/// `element <name> at byte <offset>:` in [`TtcError::MatElement`]). `what` names the part being
/// read (`array flags`, `cell 3`, `field tireid`, ...); `Nested` prefixes the cell or struct
/// field the problem was found in.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum ElementProblem {
    #[error("{what}: tag needs 8 bytes, {left} left (truncated?)")]
    TagTruncated { what: String, left: usize },
    #[error("{what}: small element claims {len} bytes, at most 4 fit")]
    SmallTooLong { what: String, len: usize },
    #[error(
        "{what}: data type {data_type} ({}) claims {len} bytes, {left} left (truncated?)",
        type_name(*.data_type)
    )]
    DataTruncated {
        what: String,
        data_type: u32,
        len: usize,
        left: usize,
    },
    #[error(
        "compressed element holds data type {0} ({name}), expected miMATRIX",
        name = type_name(*.0)
    )]
    CompressedNotMatrix(u32),
    #[error(
        "unexpected top-level data type {0} ({name}); expected miMATRIX or miCOMPRESSED",
        name = type_name(*.0)
    )]
    UnexpectedTopLevel(u32),
    #[error("zlib stream ends before its end marker after {consumed} of {len} bytes (truncated?)")]
    ZlibTruncated { consumed: u64, len: usize },
    #[error("zlib stream is corrupt: {0}")]
    ZlibCorrupt(String),
    #[error("compressed element inflates to {0} bytes, less than a tag")]
    InflatesBelowTag(usize),
    #[error(
        "compressed element of {compressed} bytes declares {declared} bytes inflated, more than the {cap} accepted (a decompression bomb?)"
    )]
    DecompressionBomb {
        compressed: usize,
        declared: usize,
        cap: usize,
    },
    #[error(
        "compressed element declares {declared} bytes, but its dimensions and class need at most {limit}"
    )]
    DeclaredBeyondDimensions { declared: usize, limit: usize },
    #[error("zlib stream inflates beyond the {0} bytes its element declares")]
    InflatesBeyond(usize),
    #[error("cells/structs nested deeper than {MAX_DEPTH} levels")]
    TooDeep,
    #[error("array flags: expected 8 bytes of miUINT32, found {len} bytes of type {data_type}")]
    BadFlags { len: usize, data_type: u32 },
    #[error("array name has data type {0}, expected miINT8")]
    BadNameType(u32),
    #[error("unknown array class {0}")]
    UnknownClass(u8),
    #[error(
        "dimensions: expected at least two miINT32 values, found {len} bytes of type {data_type}"
    )]
    BadDimensions { len: usize, data_type: u32 },
    #[error("dimensions: negative size {0}")]
    NegativeDimension(i32),
    #[error("dimensions {0:?} overflow")]
    DimensionsOverflow(Vec<usize>),
    #[error("{what}: data type {data_type}, expected miMATRIX")]
    NestedNotMatrix { what: String, data_type: u32 },
    #[error("{what}: {problem}")]
    Nested {
        what: String,
        problem: Box<ElementProblem>,
    },
    #[error("field name length: expected one miINT32")]
    BadFieldNameLength,
    #[error("field names: expected miINT8 names of length {name_len} > 0, found type {data_type}")]
    BadFieldNames { name_len: usize, data_type: u32 },
    #[error("field names: {len} bytes is not a multiple of the name length {name_len}")]
    RaggedFieldNames { len: usize, name_len: usize },
    #[error("struct size overflows")]
    StructOverflow,
    #[error("char data has data type {0}, expected miUINT16")]
    CharType(u32),
    #[error("char data has {found} characters, dimensions {dims:?} say {count}")]
    CharCount {
        found: usize,
        dims: Vec<usize>,
        count: usize,
    },
    #[error("real part has {found} values, dimensions {dims:?} say {count}")]
    ValueCount {
        found: usize,
        dims: Vec<usize>,
        count: usize,
    },
    #[error("{what}: {len} bytes is not a whole number of {width}-byte values")]
    RaggedValues {
        what: String,
        len: usize,
        width: usize,
    },
    #[error(
        "numeric data has data type {0} ({name}), which is not numeric",
        name = type_name(*.0)
    )]
    NotNumeric(u32),
}

/// Whether bytes look like a MAT-file (level 5 text header or an HDF5 signature).
pub fn looks_like_mat(bytes: &[u8]) -> bool {
    bytes.starts_with(b"MATLAB") || bytes.starts_with(HDF5_SIGNATURE)
}

/// Decode a level 5 MAT-file.
pub fn parse_mat(bytes: &[u8], source_name: &str) -> Result<MatFile, TtcError> {
    let (header_text, big_endian) = check_header(bytes, source_name)?;
    let mut variables = Vec::new();
    let mut pos = HEADER_LEN;
    while pos < bytes.len() {
        let rest = &bytes[pos..];
        if rest.len() < 8 && rest.iter().all(|b| *b == 0) {
            break; // zero padding after the last element
        }
        let mut context = Context {
            source_name,
            index: variables.len(),
            offset: pos,
            name: None,
        };
        let (variable, consumed) = top_level_element(rest, big_endian, &mut context)
            .map_err(|problem| context.error(problem))?;
        variables.push(variable);
        pos += consumed;
    }
    Ok(MatFile {
        header_text,
        big_endian,
        variables,
    })
}

/// Check the 128-byte header; return its text and byte order.
fn check_header(bytes: &[u8], source_name: &str) -> Result<(String, bool), TtcError> {
    let header_error = |message: String| TtcError::MatHeader {
        source_name: source_name.to_string(),
        message,
    };
    let is_v73 = bytes.starts_with(b"MATLAB 7.3")
        || bytes.starts_with(HDF5_SIGNATURE)
        || bytes.get(512..520) == Some(&HDF5_SIGNATURE[..]);
    if is_v73 {
        return Err(TtcError::MatV73 {
            source_name: source_name.to_string(),
        });
    }
    if !bytes.starts_with(b"MATLAB") {
        return Err(header_error(format!(
            "header text does not start with \"MATLAB\" (found {:?})",
            excerpt(&bytes[..bytes.len().min(24)], 24)
        )));
    }
    if bytes.len() < HEADER_LEN {
        return Err(header_error(format!(
            "file is {} bytes, shorter than the {HEADER_LEN}-byte header (truncated?)",
            bytes.len()
        )));
    }
    let big_endian = match &bytes[126..128] {
        b"IM" => false,
        b"MI" => true,
        other => {
            return Err(header_error(format!(
                "endian indicator is {:?}, expected \"IM\" or \"MI\"",
                excerpt(other, 2)
            )));
        }
    };
    let text = String::from_utf8_lossy(&bytes[..HEADER_TEXT_LEN])
        .trim_end_matches(['\0', ' '])
        .to_string();
    Ok((text, big_endian))
}

/// Where in the file an error happened.
struct Context<'a> {
    source_name: &'a str,
    index: usize,
    offset: usize,
    name: Option<String>,
}

impl Context<'_> {
    fn error(&self, problem: ElementProblem) -> TtcError {
        TtcError::MatElement {
            source_name: self.source_name.to_string(),
            element: self
                .name
                .as_deref()
                .map_or_else(|| format!("#{}", self.index), printable),
            offset: self.offset,
            problem,
        }
    }
}

/// One top-level element (`miMATRIX`, or `miCOMPRESSED` holding one); returns the variable and
/// the bytes consumed including padding. On failure before the array name was read, the name
/// is recovered from whatever bytes are there, so the error can still name the variable.
fn top_level_element(
    rest: &[u8],
    big_endian: bool,
    context: &mut Context,
) -> Result<(MatVariable, usize), ElementProblem> {
    let result = decode_top_level(rest, big_endian, &mut context.name);
    if result.is_err() && context.name.is_none() {
        context.name = peek_name(rest, big_endian);
    }
    result
}

fn decode_top_level(
    rest: &[u8],
    big_endian: bool,
    name: &mut Option<String>,
) -> Result<(MatVariable, usize), ElementProblem> {
    let mut cursor = Cursor::new(rest, big_endian);
    let (data_type, data) = cursor.element("top-level element")?;
    let variable = match data_type {
        MI_MATRIX => matrix(data, big_endian, 0, name)?,
        MI_COMPRESSED => {
            let inflated = inflate_element(data, big_endian)?;
            let mut inner = Cursor::new(&inflated, big_endian);
            let (inner_type, inner_data) = inner.element("compressed element")?;
            if inner_type != MI_MATRIX {
                return Err(ElementProblem::CompressedNotMatrix(inner_type));
            }
            matrix(inner_data, big_endian, 0, name)?
        }
        other => {
            return Err(ElementProblem::UnexpectedTopLevel(other));
        }
    };
    // Compressed elements are not padded; miMATRIX lengths already are multiples of 8.
    let consumed = if data_type == MI_COMPRESSED {
        8 + data.len()
    } else {
        cursor.pos
    };
    Ok((variable, consumed))
}

/// Best-effort array name of a damaged top-level element (for error messages only).
fn peek_name(rest: &[u8], big_endian: bool) -> Option<String> {
    let head = Cursor::new(rest.get(..8)?, big_endian);
    let available = &rest[8..];
    let body = match head.u32_at(0) {
        MI_MATRIX => available.to_vec(),
        MI_COMPRESSED => {
            let declared = head.u32_at(4) as usize;
            let (inflated, _) = inflate(&available[..declared.min(available.len())], PEEK_BYTES);
            inflated.get(8..)?.to_vec()
        }
        _ => return None,
    };
    let mut cursor = Cursor::new(&body, big_endian);
    cursor.element("array flags").ok()?;
    cursor.element("dimensions").ok()?;
    let (data_type, name) = cursor.element("array name").ok()?;
    (matches!(data_type, MI_INT8 | MI_UINT8 | MI_UTF8) && !name.is_empty())
        .then(|| String::from_utf8_lossy(name).into_owned())
}

/// Bytes inflated to read an element's array header (flags, dimensions, name).
const PEEK_BYTES: usize = 4096;
/// A compressed element may inflate to this many bytes whatever its compressed size...
const INFLATE_FLOOR_BYTES: usize = 64 << 20;
/// ...and beyond that to this many times its compressed size. zlib reaches ~1000:1 on constant
/// data; a TTC channel that long and that constant (over 8 million samples, a day at 100 Hz) is
/// not a measurement, and refusing it keeps a decompression bomb from allocating gigabytes.
const INFLATE_RATIO: usize = 64;

/// Inflate one `miCOMPRESSED` element with a bound derived from what it declares: the inner
/// element's tag gives its length, which must fit the array's declared dimensions (numeric and
/// char arrays) and [`INFLATE_FLOOR_BYTES`] or [`INFLATE_RATIO`] times the compressed size; the
/// stream must then end exactly there. Nothing larger than the declared length is allocated.
fn inflate_element(data: &[u8], big_endian: bool) -> Result<Vec<u8>, ElementProblem> {
    let (head, status) = inflate(data, PEEK_BYTES);
    if head.len() < 8 {
        status?;
        return Err(ElementProblem::InflatesBelowTag(head.len()));
    }
    let tag = Cursor::new(&head, big_endian);
    let (inner_type, declared) = (tag.u32_at(0), tag.u32_at(4) as usize);
    if inner_type != MI_MATRIX {
        return Err(ElementProblem::CompressedNotMatrix(inner_type));
    }
    let total = declared.saturating_add(8);
    let cap = INFLATE_FLOOR_BYTES.max(data.len().saturating_mul(INFLATE_RATIO));
    if total > cap {
        return Err(ElementProblem::DecompressionBomb {
            compressed: data.len(),
            declared,
            cap,
        });
    }
    if let Some(limit) = header_bound(&head[8..], big_endian)
        && declared > limit
    {
        return Err(ElementProblem::DeclaredBeyondDimensions { declared, limit });
    }
    let (inflated, status) = inflate(data, total);
    if status? == Inflated::Beyond {
        return Err(ElementProblem::InflatesBeyond(total));
    }
    // A shorter stream leaves the inner element short of its tag's length: the element reader
    // names that.
    Ok(inflated)
}

/// Most bytes an `miMATRIX` body can hold given its array header (the start of the body): the
/// header itself plus the tags and data of the real and imaginary parts at the class's width.
/// `None` when the header cannot be read from `body` or the class has no fixed width (cells,
/// structs, objects).
fn header_bound(body: &[u8], big_endian: bool) -> Option<usize> {
    let mut cursor = Cursor::new(body, big_endian);
    let (_, flags) = cursor.element("array flags").ok()?;
    if flags.len() != 8 {
        return None;
    }
    let flags_word = Cursor::new(flags, big_endian).u32_at(0);
    let width = match (flags_word & 0xFF) as u8 {
        MX_CHAR => 4,
        6 | 14 | 15 => 8,
        7 | 12 | 13 => 4,
        10 | 11 => 2,
        8 | 9 => 1,
        _ => return None,
    };
    let dims = dimensions(&mut cursor).ok()?;
    cursor.element("array name").ok()?;
    let parts = if flags_word & FLAG_COMPLEX != 0 { 2 } else { 1 };
    let data = element_count(&dims)
        .ok()?
        .checked_mul(width)?
        .next_multiple_of(8);
    cursor.pos.checked_add(parts * (8 + data))
}

/// How an inflation within a limit ended.
#[derive(Debug, PartialEq)]
enum Inflated {
    /// The stream's end marker was reached.
    Ended,
    /// The limit was reached and the stream goes on.
    Beyond,
}

/// Inflate at most `limit` bytes of a zlib stream. Returns what was inflated even on failure
/// (used to recover a variable name for the message), and whether the stream ended or goes on
/// beyond the limit; an error for a corrupt stream or one that stops before its end marker.
fn inflate(data: &[u8], limit: usize) -> (Vec<u8>, Result<Inflated, ElementProblem>) {
    let mut decoder = Decompress::new(true);
    let mut out: Vec<u8> = Vec::new();
    let mut filled = 0;
    let truncated = |decoder: &Decompress| ElementProblem::ZlibTruncated {
        consumed: decoder.total_in(),
        len: data.len(),
    };
    loop {
        let consumed = usize::try_from(decoder.total_in())
            .unwrap_or(usize::MAX)
            .min(data.len());
        let (in_before, out_before) = (decoder.total_in(), decoder.total_out());
        if filled == limit {
            // Full: does the stream end here or go on?
            let mut probe = [0u8; 1];
            let status = decoder.decompress(&data[consumed..], &mut probe, FlushDecompress::None);
            out.truncate(filled);
            match status {
                Err(e) => return (out, Err(ElementProblem::ZlibCorrupt(e.to_string()))),
                _ if decoder.total_out() > out_before => return (out, Ok(Inflated::Beyond)),
                Ok(Status::StreamEnd) => return (out, Ok(Inflated::Ended)),
                _ if decoder.total_in() == in_before => return (out, Err(truncated(&decoder))),
                _ => continue,
            }
        }
        if filled == out.len() {
            let grow = out
                .len()
                .max(data.len().saturating_mul(4))
                .max(64)
                .min(limit - out.len());
            out.resize(out.len() + grow, 0);
        }
        let status = match decoder.decompress(
            &data[consumed..],
            &mut out[filled..],
            FlushDecompress::None,
        ) {
            Ok(status) => status,
            Err(e) => {
                // Keep what was inflated before the damage (it may name the variable).
                filled += usize::try_from(decoder.total_out() - out_before).unwrap_or(0);
                out.truncate(filled);
                return (out, Err(ElementProblem::ZlibCorrupt(e.to_string())));
            }
        };
        filled += usize::try_from(decoder.total_out() - out_before).unwrap_or(0);
        if status == Status::StreamEnd {
            out.truncate(filled);
            return (out, Ok(Inflated::Ended));
        }
        let progressed = decoder.total_in() != in_before || decoder.total_out() != out_before;
        if !progressed && filled < out.len() {
            out.truncate(filled);
            return (out, Err(truncated(&decoder)));
        }
    }
}

/// Reads consecutive data elements (tag + data + padding) from a byte slice.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8], big_endian: bool) -> Self {
        Cursor {
            bytes,
            pos: 0,
            big_endian,
        }
    }

    fn u32_at(&self, at: usize) -> u32 {
        let word: [u8; 4] = self.bytes[at..at + 4].try_into().expect("4 bytes");
        if self.big_endian {
            u32::from_be_bytes(word)
        } else {
            u32::from_le_bytes(word)
        }
    }

    /// The next element's data type and data; `what` names it in errors.
    fn element(&mut self, what: &str) -> Result<(u32, &'a [u8]), ElementProblem> {
        let left = self.bytes.len() - self.pos;
        if left < 8 {
            return Err(ElementProblem::TagTruncated {
                what: what.to_string(),
                left,
            });
        }
        let first = self.u32_at(self.pos);
        if first >> 16 != 0 {
            // Small data element: type and length in one word, up to 4 bytes of data.
            let (data_type, len) = (first & 0xFFFF, (first >> 16) as usize);
            if len > 4 {
                return Err(ElementProblem::SmallTooLong {
                    what: what.to_string(),
                    len,
                });
            }
            let data = &self.bytes[self.pos + 4..self.pos + 4 + len];
            self.pos += 8;
            return Ok((data_type, data));
        }
        let len = self.u32_at(self.pos + 4) as usize;
        let start = self.pos + 8;
        if len > self.bytes.len() - start {
            return Err(ElementProblem::DataTruncated {
                what: what.to_string(),
                data_type: first,
                len,
                left: self.bytes.len() - start,
            });
        }
        let data = &self.bytes[start..start + len];
        self.pos = (start + len.next_multiple_of(8)).min(self.bytes.len());
        Ok((first, data))
    }

    fn is_at_end(&self) -> bool {
        self.pos >= self.bytes.len()
    }
}

/// Decode the contents of one `miMATRIX` element. At depth 0 the array name is stored in `name`
/// as soon as it is read, so later errors can name the variable.
fn matrix(
    data: &[u8],
    big_endian: bool,
    depth: usize,
    name: &mut Option<String>,
) -> Result<MatVariable, ElementProblem> {
    if depth > MAX_DEPTH {
        return Err(ElementProblem::TooDeep);
    }
    if data.is_empty() {
        // MATLAB writes an empty matrix in a cell as an miMATRIX of length 0.
        return Ok(MatVariable {
            name: String::new(),
            value: MatValue::Numeric {
                class: NumericClass::Double,
                dims: vec![0, 0],
                data: Vec::new(),
            },
        });
    }
    let mut cursor = Cursor::new(data, big_endian);
    let (flags_type, flags) = cursor.element("array flags")?;
    if flags_type != MI_UINT32 || flags.len() != 8 {
        return Err(ElementProblem::BadFlags {
            len: flags.len(),
            data_type: flags_type,
        });
    }
    let flags_word = Cursor::new(flags, big_endian).u32_at(0);
    let class = (flags_word & 0xFF) as u8;
    let dims = dimensions(&mut cursor)?;
    let (name_type, name_bytes) = cursor.element("array name")?;
    if !matches!(name_type, MI_INT8 | MI_UINT8 | MI_UTF8) {
        return Err(ElementProblem::BadNameType(name_type));
    }
    let array_name = String::from_utf8_lossy(name_bytes).into_owned();
    if depth == 0 {
        *name = Some(array_name.clone());
    }
    let count = element_count(&dims)?;
    let value = match class {
        MX_CELL => cell(&mut cursor, dims, count, depth)?,
        MX_STRUCT => structure(&mut cursor, dims, count, depth)?,
        MX_CHAR => char_array(&mut cursor, dims, count)?,
        6..=15 => numeric(
            &mut cursor,
            dims,
            count,
            class,
            flags_word & FLAG_COMPLEX != 0,
        )?,
        3 => unsupported("object"),
        5 => unsupported("sparse array"),
        16 => unsupported("function handle"),
        17 => unsupported("opaque object (string, table, ...)"),
        other => return Err(ElementProblem::UnknownClass(other)),
    };
    Ok(MatVariable {
        name: array_name,
        value,
    })
}

fn unsupported(description: &str) -> MatValue {
    MatValue::Unsupported {
        description: description.to_string(),
    }
}

/// The dimensions subelement (`miINT32`, at least two values, none negative).
fn dimensions(cursor: &mut Cursor) -> Result<Vec<usize>, ElementProblem> {
    let (data_type, data) = cursor.element("dimensions")?;
    if data_type != MI_INT32 || data.len() < 8 || data.len() % 4 != 0 {
        return Err(ElementProblem::BadDimensions {
            len: data.len(),
            data_type,
        });
    }
    let words = Cursor::new(data, cursor.big_endian);
    (0..data.len() / 4)
        .map(|k| {
            let value = words.u32_at(4 * k) as i32;
            usize::try_from(value).map_err(|_| ElementProblem::NegativeDimension(value))
        })
        .collect()
}

/// Product of the dimensions, refusing overflow.
fn element_count(dims: &[usize]) -> Result<usize, ElementProblem> {
    dims.iter()
        .try_fold(1usize, |acc, d| acc.checked_mul(*d))
        .ok_or_else(|| ElementProblem::DimensionsOverflow(dims.to_vec()))
}

fn cell(
    cursor: &mut Cursor,
    dims: Vec<usize>,
    count: usize,
    depth: usize,
) -> Result<MatValue, ElementProblem> {
    let mut items = Vec::with_capacity(count.min(cursor.bytes.len() / 8));
    for k in 0..count {
        items.push(nested_matrix(cursor, depth, &format!("cell {}", k + 1))?);
    }
    Ok(MatValue::Cell { dims, items })
}

/// One nested `miMATRIX` element (a cell item or struct field value).
fn nested_matrix(
    cursor: &mut Cursor,
    depth: usize,
    what: &str,
) -> Result<MatValue, ElementProblem> {
    let (data_type, data) = cursor.element(what)?;
    if data_type != MI_MATRIX {
        return Err(ElementProblem::NestedNotMatrix {
            what: what.to_string(),
            data_type,
        });
    }
    matrix(data, cursor.big_endian, depth + 1, &mut None)
        .map(|v| v.value)
        .map_err(|problem| ElementProblem::Nested {
            what: what.to_string(),
            problem: Box::new(problem),
        })
}

fn structure(
    cursor: &mut Cursor,
    dims: Vec<usize>,
    count: usize,
    depth: usize,
) -> Result<MatValue, ElementProblem> {
    let (len_type, len_data) = cursor.element("field name length")?;
    if len_type != MI_INT32 || len_data.len() != 4 {
        return Err(ElementProblem::BadFieldNameLength);
    }
    let name_len = Cursor::new(len_data, cursor.big_endian).u32_at(0) as usize;
    let (names_type, names) = cursor.element("field names")?;
    if !matches!(names_type, MI_INT8 | MI_UINT8 | MI_UTF8) || name_len == 0 {
        return Err(ElementProblem::BadFieldNames {
            name_len,
            data_type: names_type,
        });
    }
    if names.len() % name_len != 0 {
        return Err(ElementProblem::RaggedFieldNames {
            len: names.len(),
            name_len,
        });
    }
    let fields: Vec<String> = names
        .chunks(name_len)
        .map(|chunk| {
            let end = chunk.iter().position(|b| *b == 0).unwrap_or(chunk.len());
            String::from_utf8_lossy(&chunk[..end]).into_owned()
        })
        .collect();
    let total = count
        .checked_mul(fields.len())
        .ok_or(ElementProblem::StructOverflow)?;
    let mut values = Vec::with_capacity(total.min(cursor.bytes.len() / 8));
    for k in 0..total {
        let field = &fields[k % fields.len()];
        values.push(nested_matrix(
            cursor,
            depth,
            &format!("field {}", printable(field)),
        )?);
    }
    Ok(MatValue::Struct {
        dims,
        fields,
        values,
    })
}

fn char_array(
    cursor: &mut Cursor,
    dims: Vec<usize>,
    count: usize,
) -> Result<MatValue, ElementProblem> {
    if cursor.is_at_end() && count == 0 {
        return Ok(MatValue::Char {
            dims,
            utf16: Vec::new(),
        });
    }
    let (data_type, data) = cursor.element("char data")?;
    let big_endian = cursor.big_endian;
    let utf16: Vec<u16> = match data_type {
        MI_UINT16 | MI_UTF16 | MI_INT16 => even_chunks::<2>(data, "char data")?
            .map(|c| {
                if big_endian {
                    u16::from_be_bytes(c)
                } else {
                    u16::from_le_bytes(c)
                }
            })
            .collect(),
        MI_UINT8 | MI_INT8 => data.iter().map(|b| u16::from(*b)).collect(),
        MI_UTF8 => crate::ttc::text::decode_text(data)
            .0
            .encode_utf16()
            .collect(),
        MI_UTF32 => even_chunks::<4>(data, "char data")?
            .map(|c| {
                if big_endian {
                    u32::from_be_bytes(c)
                } else {
                    u32::from_le_bytes(c)
                }
            })
            .map(|u| char::from_u32(u).unwrap_or(char::REPLACEMENT_CHARACTER))
            .collect::<String>()
            .encode_utf16()
            .collect(),
        other => {
            return Err(ElementProblem::CharType(other));
        }
    };
    if data_type != MI_UTF8 && utf16.len() != count {
        return Err(ElementProblem::CharCount {
            found: utf16.len(),
            dims,
            count,
        });
    }
    Ok(MatValue::Char { dims, utf16 })
}

fn numeric(
    cursor: &mut Cursor,
    dims: Vec<usize>,
    count: usize,
    class_code: u8,
    complex: bool,
) -> Result<MatValue, ElementProblem> {
    let class = match class_code {
        6 => NumericClass::Double,
        7 => NumericClass::Single,
        8 => NumericClass::Int8,
        9 => NumericClass::Uint8,
        10 => NumericClass::Int16,
        11 => NumericClass::Uint16,
        12 => NumericClass::Int32,
        13 => NumericClass::Uint32,
        14 => NumericClass::Int64,
        _ => NumericClass::Uint64,
    };
    if cursor.is_at_end() && count == 0 {
        return Ok(MatValue::Numeric {
            class,
            dims,
            data: Vec::new(),
        });
    }
    let (data_type, bytes) = cursor.element("real part")?;
    let data = numbers(data_type, bytes, cursor.big_endian)?;
    if data.len() != count {
        return Err(ElementProblem::ValueCount {
            found: data.len(),
            dims,
            count,
        });
    }
    if complex {
        return Ok(unsupported(&format!("complex {}", class.name())));
    }
    Ok(MatValue::Numeric { class, dims, data })
}

/// Exact chunks of `N` bytes, or an error when the length is not a multiple of `N`.
fn even_chunks<'a, const N: usize>(
    data: &'a [u8],
    what: &str,
) -> Result<impl Iterator<Item = [u8; N]> + 'a, ElementProblem> {
    if !data.len().is_multiple_of(N) {
        return Err(ElementProblem::RaggedValues {
            what: what.to_string(),
            len: data.len(),
            width: N,
        });
    }
    Ok(data
        .chunks_exact(N)
        .map(|c| <[u8; N]>::try_from(c).expect("exact chunk")))
}

/// Decode numeric storage of any MAT data type to `f64`.
fn numbers(data_type: u32, bytes: &[u8], big_endian: bool) -> Result<Vec<f64>, ElementProblem> {
    macro_rules! decode {
        ($ty:ty, $n:literal) => {
            even_chunks::<$n>(bytes, "numeric data")?
                .map(|c| {
                    if big_endian {
                        <$ty>::from_be_bytes(c) as f64
                    } else {
                        <$ty>::from_le_bytes(c) as f64
                    }
                })
                .collect()
        };
    }
    Ok(match data_type {
        MI_INT8 => decode!(i8, 1),
        MI_UINT8 => decode!(u8, 1),
        MI_INT16 => decode!(i16, 2),
        MI_UINT16 => decode!(u16, 2),
        MI_INT32 => decode!(i32, 4),
        MI_UINT32 => decode!(u32, 4),
        MI_SINGLE => decode!(f32, 4),
        MI_DOUBLE => decode!(f64, 8),
        MI_INT64 => decode!(i64, 8),
        MI_UINT64 => decode!(u64, 8),
        other => {
            return Err(ElementProblem::NotNumeric(other));
        }
    })
}

/// MATLAB's name for a data type, for messages.
fn type_name(data_type: u32) -> &'static str {
    match data_type {
        MI_INT8 => "miINT8",
        MI_UINT8 => "miUINT8",
        MI_INT16 => "miINT16",
        MI_UINT16 => "miUINT16",
        MI_INT32 => "miINT32",
        MI_UINT32 => "miUINT32",
        MI_SINGLE => "miSINGLE",
        MI_DOUBLE => "miDOUBLE",
        MI_INT64 => "miINT64",
        MI_UINT64 => "miUINT64",
        MI_MATRIX => "miMATRIX",
        MI_COMPRESSED => "miCOMPRESSED",
        MI_UTF8 => "miUTF8",
        MI_UTF16 => "miUTF16",
        MI_UTF32 => "miUTF32",
        _ => "unknown",
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use flate2::Compression;
    use flate2::write::ZlibEncoder;

    use super::*;

    /// A level 5 header (little-endian).
    fn header() -> Vec<u8> {
        let mut h = vec![b' '; HEADER_LEN];
        h[..6].copy_from_slice(b"MATLAB");
        h[124..126].copy_from_slice(&0x0100u16.to_le_bytes());
        h[126..128].copy_from_slice(b"IM");
        h
    }

    fn tag(data_type: u32, len: u32) -> Vec<u8> {
        [data_type.to_le_bytes(), len.to_le_bytes()].concat()
    }

    /// The body of a double column vector `name` of `values`.
    fn column_body(name: &str, values: &[f64]) -> Vec<u8> {
        let mut b = tag(MI_UINT32, 8);
        b.extend_from_slice(&[6, 0, 0, 0, 0, 0, 0, 0]);
        b.extend(tag(MI_INT32, 8));
        b.extend_from_slice(&(values.len() as u32).to_le_bytes());
        b.extend_from_slice(&1u32.to_le_bytes());
        b.extend(tag(MI_INT8, name.len() as u32));
        b.extend_from_slice(name.as_bytes());
        b.resize(b.len().next_multiple_of(8), 0);
        b.extend(tag(MI_DOUBLE, 8 * values.len() as u32));
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    /// A file of one compressed element: zlib of `inner_tag ++ body ++ trailing zeros`.
    fn compressed_file(inner_len: u32, body: &[u8], trailing_zeros: usize) -> Vec<u8> {
        let mut z = ZlibEncoder::new(Vec::new(), Compression::best());
        z.write_all(&tag(MI_MATRIX, inner_len)).unwrap();
        z.write_all(body).unwrap();
        let chunk = vec![0u8; 1 << 20];
        let mut left = trailing_zeros;
        while left > 0 {
            let n = left.min(chunk.len());
            z.write_all(&chunk[..n]).unwrap();
            left -= n;
        }
        let stream = z.finish().unwrap();
        let mut file = header();
        file.extend(tag(MI_COMPRESSED, stream.len() as u32));
        file.extend(stream);
        file
    }

    #[test]
    fn an_honest_compressed_element_reads() {
        let body = column_body("ET", &[0.0, 0.01, 0.02]);
        let file = compressed_file(body.len() as u32, &body, 0);
        let mat = parse_mat(&file, "ok.mat").unwrap();
        assert_eq!(mat.variables[0].name, "ET");
    }

    #[test]
    fn a_stream_longer_than_its_element_declares_stops_there() {
        // A 3-value column followed by 32 MiB of zeros in the same stream.
        let body = column_body("ET", &[0.0, 0.01, 0.02]);
        let file = compressed_file(body.len() as u32, &body, 32 << 20);
        assert!(file.len() < 400_000, "{}", file.len());
        let err = parse_mat(&file, "bomb.mat").unwrap_err().to_string();
        assert!(
            err.contains("element ET at byte 128")
                && err.contains("inflates beyond the 88 bytes its element declares"),
            "{err}"
        );
    }

    #[test]
    fn a_declared_size_the_dimensions_do_not_need_is_refused_before_inflating() {
        let body = column_body("ET", &[0.0, 0.01, 0.02]);
        let file = compressed_file(50 << 20, &body, 1 << 20);
        let err = parse_mat(&file, "bomb.mat").unwrap_err().to_string();
        assert!(
            err.contains("declares 52428800 bytes, but its dimensions and class need at most 80"),
            "{err}"
        );
    }

    #[test]
    fn a_gigabyte_element_from_kilobytes_is_refused_before_inflating() {
        // 256 MiB of zeros declared honestly (a 33554432 x 1 double "channel") from ~250 kB:
        // refused by the ratio bound without allocating it.
        let n = 32 << 20;
        let mut body = column_body("V", &[]);
        let dims_at = 16 + 8;
        body[dims_at..dims_at + 4].copy_from_slice(&(n as u32).to_le_bytes());
        let data_tag = body.len() - 8;
        body[data_tag + 4..].copy_from_slice(&((8 * n) as u32).to_le_bytes());
        let file = compressed_file((body.len() + 8 * n) as u32, &body, 8 * n);
        assert!(file.len() < 2_000_000, "{}", file.len());
        let err = parse_mat(&file, "bomb.mat").unwrap_err().to_string();
        assert!(err.contains("(a decompression bomb?)"), "{err}");
        assert!(err.contains("element V"), "{err}");
    }
}
