//! A small, defensive reader for MATLAB MAT-files, Level 5 (`save -v6` / `-v7`).
//!
//! Layout (MathWorks, "MAT-File Format", Level 5):
//!
//! - A 128-byte header: 116 bytes of descriptive text, 8 bytes of subsystem offset, a
//!   2-byte version (`0x0100`) and a 2-byte endian indicator: the characters `MI` written
//!   as a 16-bit integer, so a little-endian file reads `IM` and a big-endian one `MI`.
//!   Both byte orders are supported. Version `0x0200` (v7.3) is HDF5 and is rejected.
//! - Then data elements, each an 8-byte tag (`u32` type, `u32` byte count) followed by
//!   the data, padded to a multiple of 8 bytes. A *small* element packs byte count
//!   (≤ 4, upper 16 bits of the first word) and type (lower 16 bits) into one word and
//!   its data into the second one.
//! - A top-level element is `miMATRIX` (14), one variable, or `miCOMPRESSED` (15), a zlib
//!   stream that inflates to `miMATRIX` elements. MATLAB does not pad compressed elements;
//!   zero padding after one is tolerated.
//! - An `miMATRIX` holds sub-elements: array flags (`miUINT32` × 2: class in the low byte,
//!   complex `0x800`, global `0x400`, logical `0x200`), dimensions (`miINT32`, at least 2),
//!   the array name (`miINT8`), then per class: the real (and imaginary) part of a numeric
//!   array, stored as any numeric type (`miUINT8`, `miINT16`, `miDOUBLE`, …) whatever the
//!   class; the characters of a char array; one `miMATRIX` per element of a cell array;
//!   for a struct array the field-name length (`miINT32`), the NUL-padded fixed-width field
//!   names (`miINT8`) and one `miMATRIX` per field per element.
//!
//! Values are returned as a [`MatValue`] tree. Numeric arrays of every class are converted
//! to `f64` (`int64`/`uint64` beyond 2⁵³ lose precision), column-major as in MATLAB. Sparse,
//! object, function-handle and opaque arrays are skipped as [`MatValue::Unsupported`].
//!
//! Every malformed input yields a [`Mat5Error`] with the byte offset where it was found;
//! nothing panics and no allocation is sized from a length field before that length has
//! been checked against the bytes actually present (inflated output is capped at
//! [`MAX_INFLATED_BYTES`] per element, nesting at [`MAX_DEPTH`]).

use std::path::{Path, PathBuf};

/// Largest inflated size of one `miCOMPRESSED` element (bytes); larger streams are rejected.
pub const MAX_INFLATED_BYTES: usize = 1 << 30;

/// Deepest cell/struct nesting accepted (levels below a top-level variable).
pub const MAX_DEPTH: usize = 64;

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;
const MI_UTF16: u32 = 17;
const MI_UTF32: u32 = 18;

const MX_CELL: u8 = 1;
const MX_STRUCT: u8 = 2;
const MX_OBJECT: u8 = 3;
const MX_CHAR: u8 = 4;
const MX_SPARSE: u8 = 5;

const FLAG_COMPLEX: u32 = 0x800;
const FLAG_LOGICAL: u32 = 0x200;

/// What can go wrong while reading a MAT v5 file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Mat5Error {
    /// The file could not be read from disk.
    #[error("cannot read MAT file {path}: {source}")]
    Io {
        /// File that was being read.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The 128-byte header is missing or is not a supported MAT v5 header.
    #[error("{origin}: not a readable MAT v5 file: {message}")]
    Header {
        /// File name, or `<bytes>` when parsed from memory.
        origin: String,
        /// What is wrong with the header.
        message: String,
    },
    /// A tag or length points past the end of the available bytes.
    #[error("{origin}: {}: truncated {what}: needs {needed} bytes, only {available} left", at(.offset, .inflated_from))]
    Truncated {
        /// File name, or `<bytes>`.
        origin: String,
        /// Byte offset of the element (in the file, or in the inflated data, see `inflated_from`).
        offset: usize,
        /// File offset of the compressed element whose inflated data `offset` refers to.
        inflated_from: Option<usize>,
        /// What was being read.
        what: String,
        /// Bytes it needs (bytes).
        needed: u64,
        /// Bytes actually left (bytes).
        available: u64,
    },
    /// An element is present but inconsistent (wrong type, bad dimensions, bad count, …).
    #[error("{origin}: {}: {message}", at(.offset, .inflated_from))]
    Malformed {
        /// File name, or `<bytes>`.
        origin: String,
        /// Byte offset of the element (in the file, or in the inflated data, see `inflated_from`).
        offset: usize,
        /// File offset of the compressed element whose inflated data `offset` refers to.
        inflated_from: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A `miCOMPRESSED` element is not a valid zlib stream.
    #[error("{origin}: byte {offset}: cannot inflate compressed element of {compressed} bytes: {message}")]
    Inflate {
        /// File name, or `<bytes>`.
        origin: String,
        /// File offset of the compressed element's tag.
        offset: usize,
        /// Length of its zlib stream (bytes).
        compressed: usize,
        /// Inflater message.
        message: String,
    },
}

fn at(offset: &usize, inflated_from: &Option<usize>) -> String {
    match inflated_from {
        None => format!("byte {offset}"),
        Some(c) => {
            format!("byte {offset} of the data inflated from the compressed element at byte {c}")
        }
    }
}

/// Class of a numeric MATLAB array (its values are always returned as `f64`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum NumericClass {
    /// `double` (mxDOUBLE_CLASS, 6).
    Double,
    /// `single` (mxSINGLE_CLASS, 7).
    Single,
    /// `int8` (mxINT8_CLASS, 8).
    Int8,
    /// `uint8` (mxUINT8_CLASS, 9); also MATLAB `logical`.
    UInt8,
    /// `int16` (mxINT16_CLASS, 10).
    Int16,
    /// `uint16` (mxUINT16_CLASS, 11).
    UInt16,
    /// `int32` (mxINT32_CLASS, 12).
    Int32,
    /// `uint32` (mxUINT32_CLASS, 13).
    UInt32,
    /// `int64` (mxINT64_CLASS, 14).
    Int64,
    /// `uint64` (mxUINT64_CLASS, 15).
    UInt64,
}

impl NumericClass {
    fn from_class(c: u8) -> Option<Self> {
        Some(match c {
            6 => Self::Double,
            7 => Self::Single,
            8 => Self::Int8,
            9 => Self::UInt8,
            10 => Self::Int16,
            11 => Self::UInt16,
            12 => Self::Int32,
            13 => Self::UInt32,
            14 => Self::Int64,
            15 => Self::UInt64,
            _ => return None,
        })
    }

    /// MATLAB's name for the class (`"double"`, `"int16"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::Double => "double",
            Self::Single => "single",
            Self::Int8 => "int8",
            Self::UInt8 => "uint8",
            Self::Int16 => "int16",
            Self::UInt16 => "uint16",
            Self::Int32 => "int32",
            Self::UInt32 => "uint32",
            Self::Int64 => "int64",
            Self::UInt64 => "uint64",
        }
    }
}

/// One MATLAB array. Element order is column-major; `dims` has at least two entries.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum MatValue {
    /// A numeric or logical array, converted to `f64`.
    Numeric {
        /// Storage class in the file.
        class: NumericClass,
        /// Dimensions (at least 2).
        dims: Vec<usize>,
        /// Real parts, column-major, `numel` values.
        real: Vec<f64>,
        /// Imaginary parts of a complex array, column-major.
        imag: Option<Vec<f64>>,
        /// True for a MATLAB `logical` array.
        logical: bool,
    },
    /// A char array; a matrix of several rows is joined row by row with `'\n'`.
    Char {
        /// Dimensions (at least 2).
        dims: Vec<usize>,
        /// The characters.
        text: String,
    },
    /// A cell array.
    Cell {
        /// Dimensions (at least 2).
        dims: Vec<usize>,
        /// The cells, column-major.
        items: Vec<MatValue>,
    },
    /// A struct array.
    Struct {
        /// Dimensions (at least 2).
        dims: Vec<usize>,
        /// Field names, in file order.
        fields: Vec<String>,
        /// Field values, element-major: element `e`, field `f` is `values[e * fields.len() + f]`.
        values: Vec<MatValue>,
    },
    /// A class this reader skips (sparse, object, function handle, opaque).
    Unsupported {
        /// MATLAB array class number (mxCLASS).
        class: u8,
        /// Dimensions as stored.
        dims: Vec<usize>,
    },
}

/// Formats dimensions as MATLAB does, e.g. `2×1000`.
pub fn dims_string(dims: &[usize]) -> String {
    dims.iter()
        .map(|d| d.to_string())
        .collect::<Vec<_>>()
        .join("×")
}

impl MatValue {
    /// Dimensions of the array.
    pub fn dims(&self) -> &[usize] {
        match self {
            Self::Numeric { dims, .. }
            | Self::Char { dims, .. }
            | Self::Cell { dims, .. }
            | Self::Struct { dims, .. }
            | Self::Unsupported { dims, .. } => dims,
        }
    }

    /// Number of elements (product of the dimensions, saturating).
    pub fn numel(&self) -> usize {
        self.dims().iter().fold(1usize, |a, &d| a.saturating_mul(d))
    }

    /// Short description for messages, e.g. `double 2×1000` or `cell 1×7`.
    pub fn describe(&self) -> String {
        let kind = match self {
            Self::Numeric {
                class,
                logical: true,
                ..
            } if *class == NumericClass::UInt8 => "logical",
            Self::Numeric {
                class,
                imag: Some(_),
                ..
            } => return format!("complex {} {}", class.name(), dims_string(self.dims())),
            Self::Numeric { class, .. } => class.name(),
            Self::Char { .. } => "char",
            Self::Cell { .. } => "cell",
            Self::Struct { .. } => "struct",
            Self::Unsupported {
                class: MX_SPARSE, ..
            } => "sparse",
            Self::Unsupported { .. } => "unsupported",
        };
        format!("{kind} {}", dims_string(self.dims()))
    }

    /// Real parts of a real numeric array (column-major); `None` for other values or complex arrays.
    pub fn as_real(&self) -> Option<&[f64]> {
        match self {
            Self::Numeric {
                real, imag: None, ..
            } => Some(real),
            _ => None,
        }
    }

    /// The value of a real 1×1 numeric array.
    pub fn scalar(&self) -> Option<f64> {
        match self.as_real() {
            Some([v]) => Some(*v),
            _ => None,
        }
    }

    /// The text of a char array.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Self::Char { text, .. } => Some(text),
            _ => None,
        }
    }

    /// The cells of a cell array (column-major).
    pub fn cell_items(&self) -> Option<&[MatValue]> {
        match self {
            Self::Cell { items, .. } => Some(items),
            _ => None,
        }
    }

    /// Field names of a struct array.
    pub fn field_names(&self) -> Option<&[String]> {
        match self {
            Self::Struct { fields, .. } => Some(fields),
            _ => None,
        }
    }

    /// Field `name` of element `element` (column-major index) of a struct array.
    pub fn field_of(&self, element: usize, name: &str) -> Option<&MatValue> {
        match self {
            Self::Struct { fields, values, .. } => {
                let f = fields.iter().position(|n| n == name)?;
                values.get(element.checked_mul(fields.len())?.checked_add(f)?)
            }
            _ => None,
        }
    }

    /// Field `name` of the first element of a struct array (`s.name` for a 1×1 struct).
    pub fn field(&self, name: &str) -> Option<&MatValue> {
        self.field_of(0, name)
    }
}

/// One named top-level variable.
#[derive(Debug, Clone, PartialEq)]
pub struct MatVariable {
    /// Variable name.
    pub name: String,
    /// Its value.
    pub value: MatValue,
}

/// A parsed MAT v5 file: header text and variables in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct MatFile {
    /// Header text (up to 116 bytes, trailing blanks removed).
    pub description: String,
    /// True when the file is big-endian (`MI`).
    pub big_endian: bool,
    /// The variables, in file order.
    pub variables: Vec<MatVariable>,
}

impl MatFile {
    /// Reads and parses the file at `path`; errors name the file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, Mat5Error> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| Mat5Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&bytes, &path.display().to_string())
    }

    /// Parses an in-memory MAT v5 file; `origin` names it in errors.
    pub fn parse(bytes: &[u8], origin: &str) -> Result<Self, Mat5Error> {
        let header_err = |message: String| Mat5Error::Header {
            origin: origin.to_string(),
            message,
        };
        if bytes.len() < 128 {
            return Err(header_err(format!(
                "the file has {} bytes, a MAT v5 header alone has 128",
                bytes.len()
            )));
        }
        let big = match &bytes[126..128] {
            b"IM" => false,
            b"MI" => true,
            other => {
                return Err(header_err(format!(
                    "endian indicator at byte 126 is {:?}, expected \"IM\" or \"MI\"",
                    String::from_utf8_lossy(other)
                )))
            }
        };
        let version = if big {
            u16::from_be_bytes([bytes[124], bytes[125]])
        } else {
            u16::from_le_bytes([bytes[124], bytes[125]])
        };
        if version == 0x0200 {
            return Err(header_err(
                "version 0x0200 is MAT v7.3 (HDF5), which is not supported; save with -v7".into(),
            ));
        }
        if version != 0x0100 {
            return Err(header_err(format!(
                "version 0x{version:04x}, expected 0x0100"
            )));
        }
        if bytes[..4].contains(&0) {
            return Err(header_err(
                "the first 4 header bytes contain a zero (a MAT v4 file?)".into(),
            ));
        }
        let description = String::from_utf8_lossy(&bytes[..116])
            .trim_end_matches([' ', '\0'])
            .to_string();
        let ctx = Ctx {
            origin,
            big,
            inflated_from: None,
        };
        let mut variables = Vec::new();
        let mut pos = 128;
        while pos < bytes.len() {
            if bytes.len() - pos < 8 && bytes[pos..].iter().all(|&b| b == 0) {
                break; // trailing padding
            }
            let el = ctx.element(bytes, pos, "data element")?;
            match el.ty {
                MI_MATRIX => variables.push(ctx.variable(bytes, &el)?),
                MI_COMPRESSED => {
                    let inflated = inflate(origin, &el)?;
                    let inner = Ctx {
                        origin,
                        big,
                        inflated_from: Some(el.offset),
                    };
                    let mut p = 0;
                    while p < inflated.len() {
                        let sub = inner.element(&inflated, p, "compressed data element")?;
                        if sub.ty != MI_MATRIX {
                            return Err(inner.malformed(
                                p,
                                format!(
                                    "expected miMATRIX in compressed element, found {}",
                                    type_name(sub.ty)
                                ),
                            ));
                        }
                        variables.push(inner.variable(&inflated, &sub)?);
                        p = sub.next;
                    }
                }
                t => {
                    return Err(ctx.malformed(
                        pos,
                        format!(
                            "expected miMATRIX or miCOMPRESSED at top level, found {}",
                            type_name(t)
                        ),
                    ))
                }
            }
            pos = el.next;
            if el.ty == MI_COMPRESSED {
                // MATLAB does not pad compressed elements; other writers may. A top-level tag
                // (type 14 or 15) starts with a non-zero byte when little-endian and has a zero
                // word only if preceded by padding when big-endian, so zeros there are padding.
                let padded = (el.data_start + el.len + pad(el.len)).min(bytes.len());
                let is_padding = if big {
                    bytes.get(pos..pos + 4).is_none_or(|w| w == [0; 4])
                } else {
                    bytes.get(pos) == Some(&0)
                };
                if padded > pos && is_padding && bytes[pos..padded].iter().all(|&b| b == 0) {
                    pos = padded;
                }
            }
        }
        Ok(Self {
            description,
            big_endian: big,
            variables,
        })
    }

    /// The value of the first variable called `name`.
    pub fn get(&self, name: &str) -> Option<&MatValue> {
        self.variables
            .iter()
            .find(|v| v.name == name)
            .map(|v| &v.value)
    }

    /// Names of the variables, in file order.
    pub fn names(&self) -> Vec<&str> {
        self.variables.iter().map(|v| v.name.as_str()).collect()
    }
}

fn pad(len: usize) -> usize {
    (8 - len % 8) % 8
}

fn type_name(ty: u32) -> String {
    let n = match ty {
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
        _ => return format!("unknown element type {ty}"),
    };
    n.to_string()
}

/// Size in bytes of one value of a numeric element type.
fn type_size(ty: u32) -> Option<usize> {
    Some(match ty {
        MI_INT8 | MI_UINT8 | MI_UTF8 => 1,
        MI_INT16 | MI_UINT16 | MI_UTF16 => 2,
        MI_INT32 | MI_UINT32 | MI_SINGLE | MI_UTF32 => 4,
        MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
        _ => return None,
    })
}

/// One data element, located in a buffer.
struct Element<'a> {
    ty: u32,
    data: &'a [u8],
    /// Offset of the tag.
    offset: usize,
    /// Offset of the data.
    data_start: usize,
    /// Byte count from the tag.
    len: usize,
    /// Offset of the next element (after padding).
    next: usize,
}

/// Where a buffer comes from and how to read its numbers.
#[derive(Clone, Copy)]
struct Ctx<'a> {
    origin: &'a str,
    big: bool,
    inflated_from: Option<usize>,
}

fn inflate(origin: &str, el: &Element<'_>) -> Result<Vec<u8>, Mat5Error> {
    miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(el.data, MAX_INFLATED_BYTES).map_err(
        |e| {
            let message = match e.status {
                miniz_oxide::inflate::TINFLStatus::HasMoreOutput => {
                    format!("inflates to more than {MAX_INFLATED_BYTES} bytes")
                }
                _ => e.to_string(),
            };
            Mat5Error::Inflate {
                origin: origin.to_string(),
                offset: el.offset,
                compressed: el.len,
                message,
            }
        },
    )
}

impl Ctx<'_> {
    fn malformed(&self, offset: usize, message: String) -> Mat5Error {
        Mat5Error::Malformed {
            origin: self.origin.to_string(),
            offset,
            inflated_from: self.inflated_from,
            message,
        }
    }

    fn truncated(&self, offset: usize, what: String, needed: usize, available: usize) -> Mat5Error {
        Mat5Error::Truncated {
            origin: self.origin.to_string(),
            offset,
            inflated_from: self.inflated_from,
            what,
            needed: needed as u64,
            available: available as u64,
        }
    }

    fn u32(&self, b: &[u8]) -> u32 {
        let w = [b[0], b[1], b[2], b[3]];
        if self.big {
            u32::from_be_bytes(w)
        } else {
            u32::from_le_bytes(w)
        }
    }

    /// Reads the element whose tag is at `pos` of `buf`; `what` names it in errors.
    fn element<'b>(&self, buf: &'b [u8], pos: usize, what: &str) -> Result<Element<'b>, Mat5Error> {
        let rem = buf.len().saturating_sub(pos);
        if rem < 8 {
            return Err(self.truncated(pos, format!("{what} tag"), 8, rem));
        }
        let w = self.u32(&buf[pos..pos + 4]);
        if w >> 16 != 0 {
            let (len, ty) = ((w >> 16) as usize, w & 0xffff);
            if len > 4 {
                return Err(self.malformed(
                    pos,
                    format!(
                        "small {what} ({}) claims {len} bytes, at most 4 fit",
                        type_name(ty)
                    ),
                ));
            }
            return Ok(Element {
                ty,
                data: &buf[pos + 4..pos + 4 + len],
                offset: pos,
                data_start: pos + 4,
                len,
                next: pos + 8,
            });
        }
        if w == 0 {
            return Err(self.malformed(pos, format!("{what} has type 0 (not a data element)")));
        }
        let len = self.u32(&buf[pos + 4..pos + 8]) as usize;
        let avail = rem - 8;
        if len > avail {
            return Err(self.truncated(pos, format!("{what} ({})", type_name(w)), len, avail));
        }
        let data_start = pos + 8;
        let end = data_start + len;
        let next = if w == MI_COMPRESSED {
            end
        } else {
            (end + pad(len)).min(buf.len())
        };
        Ok(Element {
            ty: w,
            data: &buf[data_start..end],
            offset: pos,
            data_start,
            len,
            next,
        })
    }

    /// Parses a top-level `miMATRIX` element into a named variable.
    fn variable(&self, buf: &[u8], el: &Element<'_>) -> Result<MatVariable, Mat5Error> {
        let (name, value) = self.matrix(buf, el, 0)?;
        Ok(MatVariable { name, value })
    }

    /// Converts the data of a numeric element to `f64`.
    fn numbers(&self, el: &Element<'_>, what: &str) -> Result<Vec<f64>, Mat5Error> {
        let size = match el.ty {
            MI_INT8 | MI_UINT8 | MI_INT16 | MI_UINT16 | MI_INT32 | MI_UINT32 | MI_SINGLE
            | MI_DOUBLE | MI_INT64 | MI_UINT64 => type_size(el.ty).unwrap_or(8),
            t => {
                return Err(self.malformed(
                    el.offset,
                    format!("{what}: {} is not a numeric type", type_name(t)),
                ))
            }
        };
        if el.data.len() % size != 0 {
            return Err(self.malformed(
                el.offset,
                format!(
                    "{what}: {} data of {} bytes is not a multiple of {size}",
                    type_name(el.ty),
                    el.data.len()
                ),
            ));
        }
        let big = self.big;
        let out = el
            .data
            .chunks_exact(size)
            .map(|c| {
                macro_rules! conv {
                    ($t:ty, $n:literal) => {{
                        let mut a = [0u8; $n];
                        a.copy_from_slice(c);
                        (if big {
                            <$t>::from_be_bytes(a)
                        } else {
                            <$t>::from_le_bytes(a)
                        }) as f64
                    }};
                }
                match el.ty {
                    MI_INT8 => c[0] as i8 as f64,
                    MI_UINT8 => c[0] as f64,
                    MI_INT16 => conv!(i16, 2),
                    MI_UINT16 => conv!(u16, 2),
                    MI_INT32 => conv!(i32, 4),
                    MI_UINT32 => conv!(u32, 4),
                    MI_SINGLE => conv!(f32, 4),
                    MI_INT64 => conv!(i64, 8),
                    MI_UINT64 => conv!(u64, 8),
                    _ => conv!(f64, 8),
                }
            })
            .collect();
        Ok(out)
    }

    /// Reads the next sub-element of the array whose tag is at `owner`; `body` ends with the array.
    fn sub_element<'b>(
        &self,
        body: &'b [u8],
        owner: usize,
        pos: &mut usize,
        what: &str,
    ) -> Result<Element<'b>, Mat5Error> {
        if *pos >= body.len() {
            return Err(self.truncated(owner, format!("array: missing {what}"), 8, 0));
        }
        let e = self.element(body, *pos, what)?;
        *pos = e.next;
        Ok(e)
    }

    /// Parses the `miMATRIX` element `el` of `buf` (name, value); `depth` is the nesting level.
    fn matrix(
        &self,
        buf: &[u8],
        el: &Element<'_>,
        depth: usize,
    ) -> Result<(String, MatValue), Mat5Error> {
        if depth > MAX_DEPTH {
            return Err(self.malformed(
                el.offset,
                format!("cells/structs nested deeper than {MAX_DEPTH} levels"),
            ));
        }
        // Sub-elements live in buf[start..end]; offsets stay relative to `buf` for messages.
        let (start, end) = (el.data_start, el.data_start + el.len);
        if el.len == 0 {
            // MATLAB writes empty cells as zero-length miMATRIX elements.
            return Ok((
                String::new(),
                MatValue::Numeric {
                    class: NumericClass::Double,
                    dims: vec![0, 0],
                    real: vec![],
                    imag: None,
                    logical: false,
                },
            ));
        }
        let body = &buf[..end];
        let mut pos = start;
        let next = |what: &str, pos: &mut usize| self.sub_element(body, el.offset, pos, what);

        let flags = next("array flags", &mut pos)?;
        if flags.ty != MI_UINT32 || flags.data.len() != 8 {
            return Err(self.malformed(
                flags.offset,
                format!(
                    "array flags: expected miUINT32 of 8 bytes, found {} of {} bytes",
                    type_name(flags.ty),
                    flags.data.len()
                ),
            ));
        }
        let word = self.u32(flags.data);
        let class = (word & 0xff) as u8;
        let complex = word & FLAG_COMPLEX != 0;
        let logical = word & FLAG_LOGICAL != 0;

        let dims_el = next("dimensions", &mut pos)?;
        if dims_el.ty != MI_INT32 || dims_el.data.len() % 4 != 0 || dims_el.data.len() < 8 {
            return Err(self.malformed(
                dims_el.offset,
                format!(
                    "dimensions: expected miINT32 with at least 2 values, found {} of {} bytes",
                    type_name(dims_el.ty),
                    dims_el.data.len()
                ),
            ));
        }
        let mut dims = Vec::with_capacity(dims_el.data.len() / 4);
        for c in dims_el.data.chunks_exact(4) {
            let d = self.u32(c) as i32;
            if d < 0 {
                return Err(self.malformed(
                    dims_el.offset,
                    format!("dimensions: negative dimension {d}"),
                ));
            }
            dims.push(d as usize);
        }
        let numel = dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .ok_or_else(|| {
                self.malformed(
                    dims_el.offset,
                    format!("dimensions {} overflow", dims_string(&dims)),
                )
            })?;

        let name_el = next("array name", &mut pos)?;
        if !matches!(name_el.ty, MI_INT8 | MI_UINT8 | MI_UTF8) {
            return Err(self.malformed(
                name_el.offset,
                format!(
                    "array name: expected miINT8, found {}",
                    type_name(name_el.ty)
                ),
            ));
        }
        let name = String::from_utf8_lossy(name_el.data)
            .trim_end_matches('\0')
            .to_string();

        let value = match class {
            MX_CELL => {
                let mut items = Vec::new();
                for k in 0..numel {
                    let e = next("cell element", &mut pos)?;
                    if e.ty != MI_MATRIX {
                        return Err(self.malformed(
                            e.offset,
                            format!(
                                "cell element {}: expected miMATRIX, found {}",
                                k + 1,
                                type_name(e.ty)
                            ),
                        ));
                    }
                    items.push(self.matrix(body, &e, depth + 1)?.1);
                }
                MatValue::Cell { dims, items }
            }
            MX_STRUCT => {
                let len_el = next("field name length", &mut pos)?;
                if len_el.ty != MI_INT32 || len_el.data.len() != 4 {
                    return Err(self.malformed(
                        len_el.offset,
                        format!(
                            "field name length: expected one miINT32, found {} of {} bytes",
                            type_name(len_el.ty),
                            len_el.data.len()
                        ),
                    ));
                }
                let width = self.u32(len_el.data) as i32;
                let names_el = next("field names", &mut pos)?;
                if !matches!(names_el.ty, MI_INT8 | MI_UINT8 | MI_UTF8) {
                    return Err(self.malformed(
                        names_el.offset,
                        format!(
                            "field names: expected miINT8, found {}",
                            type_name(names_el.ty)
                        ),
                    ));
                }
                let n = names_el.data.len();
                if width < 0 || (width == 0 && n > 0) || (width > 0 && n % width as usize != 0) {
                    return Err(self.malformed(
                        names_el.offset,
                        format!("field names: {n} bytes do not split into names of width {width}"),
                    ));
                }
                let fields: Vec<String> = if n == 0 {
                    Vec::new()
                } else {
                    names_el
                        .data
                        .chunks(width as usize)
                        .map(|c| {
                            let c = c.split(|&b| b == 0).next().unwrap_or(&[]);
                            String::from_utf8_lossy(c).into_owned()
                        })
                        .collect()
                };
                let mut values = Vec::new();
                for e_idx in 0..numel {
                    for f in &fields {
                        let e = next("struct field", &mut pos)?;
                        if e.ty != MI_MATRIX {
                            return Err(self.malformed(
                                e.offset,
                                format!(
                                    "field `{f}` of element {}: expected miMATRIX, found {}",
                                    e_idx + 1,
                                    type_name(e.ty)
                                ),
                            ));
                        }
                        values.push(self.matrix(body, &e, depth + 1)?.1);
                    }
                }
                MatValue::Struct {
                    dims,
                    fields,
                    values,
                }
            }
            MX_CHAR => {
                let e = next("characters", &mut pos)?;
                let units: Vec<char> = match e.ty {
                    MI_UTF8 => String::from_utf8_lossy(e.data).chars().collect(),
                    MI_INT8 | MI_UINT8 => e.data.iter().map(|&b| b as char).collect(),
                    MI_UINT16 | MI_UTF16 | MI_INT16 => {
                        let v: Vec<u16> = self
                            .numbers(&Element { ty: MI_UINT16, ..e }, "characters")?
                            .into_iter()
                            .map(|x| x as u16)
                            .collect();
                        // One unit per character in MATLAB; decode each independently.
                        v.iter()
                            .map(|&u| char::from_u32(u as u32).unwrap_or('\u{fffd}'))
                            .collect()
                    }
                    MI_UINT32 | MI_UTF32 | MI_INT32 => self
                        .numbers(&Element { ty: MI_UINT32, ..e }, "characters")?
                        .into_iter()
                        .map(|x| char::from_u32(x as u32).unwrap_or('\u{fffd}'))
                        .collect(),
                    t => {
                        return Err(self.malformed(
                            e.offset,
                            format!("characters: {} is not a character type", type_name(t)),
                        ))
                    }
                };
                if units.len() != numel {
                    return Err(self.malformed(
                        e.offset,
                        format!(
                            "char array {} needs {numel} characters, found {}",
                            dims_string(&dims),
                            units.len()
                        ),
                    ));
                }
                let rows = dims[0];
                let text = if rows <= 1 || dims.len() != 2 {
                    units.into_iter().collect()
                } else {
                    let cols = dims[1];
                    (0..rows)
                        .map(|r| (0..cols).map(|c| units[c * rows + r]).collect::<String>())
                        .collect::<Vec<_>>()
                        .join("\n")
                };
                MatValue::Char { dims, text }
            }
            c if NumericClass::from_class(c).is_some() => {
                let class = NumericClass::from_class(c).unwrap_or(NumericClass::Double);
                let re_el = next("real part", &mut pos)?;
                let real = self.numbers(&re_el, "real part")?;
                if real.len() != numel {
                    return Err(self.malformed(
                        re_el.offset,
                        format!(
                            "real part has {} values, dimensions {} need {numel}",
                            real.len(),
                            dims_string(&dims)
                        ),
                    ));
                }
                let imag = if complex {
                    let im_el = next("imaginary part", &mut pos)?;
                    let im = self.numbers(&im_el, "imaginary part")?;
                    if im.len() != numel {
                        return Err(self.malformed(
                            im_el.offset,
                            format!(
                                "imaginary part has {} values, dimensions {} need {numel}",
                                im.len(),
                                dims_string(&dims)
                            ),
                        ));
                    }
                    Some(im)
                } else {
                    None
                };
                MatValue::Numeric {
                    class,
                    dims,
                    real,
                    imag,
                    logical,
                }
            }
            MX_OBJECT | MX_SPARSE | 16..=18 => MatValue::Unsupported { class, dims },
            c => {
                return Err(self.malformed(
                    flags.offset,
                    format!("array flags: unknown array class {c}"),
                ))
            }
        };
        Ok((name, value))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Builds MAT v5 bytes by hand, in either byte order.
    struct W {
        big: bool,
    }

    impl W {
        fn u32(&self, v: u32) -> [u8; 4] {
            if self.big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        }
        fn header(&self) -> Vec<u8> {
            let mut h = b"MATLAB 5.0 MAT-file, hand-made test".to_vec();
            h.resize(116, b' ');
            h.extend([0u8; 8]);
            h.extend(if self.big {
                0x0100u16.to_be_bytes()
            } else {
                0x0100u16.to_le_bytes()
            });
            h.extend(if self.big { b"MI" } else { b"IM" });
            h
        }
        fn el(&self, ty: u32, data: &[u8]) -> Vec<u8> {
            let mut v = Vec::new();
            v.extend(self.u32(ty));
            v.extend(self.u32(data.len() as u32));
            v.extend(data);
            v.resize(v.len() + pad(data.len()), 0);
            v
        }
        fn small(&self, ty: u32, data: &[u8]) -> Vec<u8> {
            assert!(data.len() <= 4);
            let mut v = Vec::new();
            v.extend(self.u32(((data.len() as u32) << 16) | ty));
            v.extend(data);
            v.resize(8, 0);
            v
        }
        fn matrix(&self, class: u32, dims: &[i32], name: &str, body: &[Vec<u8>]) -> Vec<u8> {
            let mut d = Vec::new();
            d.extend(self.el(MI_UINT32, &[self.u32(class), [0; 4]].concat()));
            let dd: Vec<u8> = dims.iter().flat_map(|&x| self.u32(x as u32)).collect();
            d.extend(self.el(MI_INT32, &dd));
            d.extend(self.el(MI_INT8, name.as_bytes()));
            for b in body {
                d.extend(b);
            }
            self.el(MI_MATRIX, &d)
        }
        fn doubles(&self, v: &[f64]) -> Vec<u8> {
            let b: Vec<u8> = v
                .iter()
                .flat_map(|x| {
                    if self.big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                })
                .collect();
            self.el(MI_DOUBLE, &b)
        }
    }

    fn sample(w: &W) -> Vec<u8> {
        let mut f = w.header();
        // a = [1 2 3; 4 5 6] (column-major 1 4 2 5 3 6), stored as miDOUBLE.
        f.extend(w.matrix(
            6,
            &[2, 3],
            "a",
            &[w.doubles(&[1.0, 4.0, 2.0, 5.0, 3.0, 6.0])],
        ));
        // c = {int16 -7 stored as miINT16 small element, 'hi'}.
        let i16b: Vec<u8> = if w.big {
            (-7i16).to_be_bytes().to_vec()
        } else {
            (-7i16).to_le_bytes().to_vec()
        };
        let scalar = w.matrix(10, &[1, 1], "", &[w.small(MI_INT16, &i16b)]);
        let text = w.matrix(4, &[1, 2], "", &[w.el(MI_UTF8, b"hi")]);
        f.extend(w.matrix(1, &[1, 2], "c", &[scalar, text]));
        // s = struct('pos', uint8 [1;2]) with fixed-width names.
        let pos = w.matrix(6, &[2, 1], "", &[w.el(MI_UINT8, &[1, 2])]);
        let mut names = b"pos\0dt\0\0".to_vec();
        names.truncate(8);
        let dt = w.matrix(6, &[1, 1], "", &[w.doubles(&[0.5])]);
        f.extend(w.matrix(
            2,
            &[1, 1],
            "s",
            &[w.small(MI_INT32, &w.u32(4)), w.el(MI_INT8, &names), pos, dt],
        ));
        f
    }

    fn check(m: &MatFile) {
        assert_eq!(m.names(), vec!["a", "c", "s"]);
        let a = m.get("a").unwrap();
        assert_eq!(a.dims(), &[2, 3]);
        assert_eq!(a.as_real().unwrap(), &[1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
        let c = m.get("c").unwrap().cell_items().unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].scalar(), Some(-7.0));
        assert!(matches!(
            c[0],
            MatValue::Numeric {
                class: NumericClass::Int16,
                ..
            }
        ));
        assert_eq!(c[1].as_str(), Some("hi"));
        let s = m.get("s").unwrap();
        assert_eq!(
            s.field_names().unwrap(),
            &["pos".to_string(), "dt".to_string()]
        );
        assert_eq!(s.field("pos").unwrap().as_real().unwrap(), &[1.0, 2.0]);
        assert_eq!(s.field("dt").unwrap().scalar(), Some(0.5));
        assert!(s.field("vel").is_none());
    }

    #[test]
    fn hand_made_uncompressed_little_and_big_endian() {
        for big in [false, true] {
            let w = W { big };
            let m = MatFile::parse(&sample(&w), "<test>").unwrap();
            assert_eq!(m.big_endian, big);
            assert!(m.description.starts_with("MATLAB 5.0"));
            check(&m);
        }
    }

    #[test]
    fn hand_made_compressed_unpadded_and_padded() {
        for big in [false, true] {
            let w = W { big };
            let plain = sample(&w);
            let body = &plain[128..];
            // Compress each variable separately, as MATLAB does, with and without padding.
            let mut spans = Vec::new();
            let mut p = 0;
            while p < body.len() {
                let b: [u8; 4] = body[p + 4..p + 8].try_into().unwrap();
                let n = if big {
                    u32::from_be_bytes(b)
                } else {
                    u32::from_le_bytes(b)
                } as usize;
                spans.push(&body[p..p + 8 + n]);
                p += 8 + n;
            }
            let mut unaligned = 0;
            for padded in [false, true] {
                let mut f = w.header();
                for s in &spans {
                    let z = miniz_oxide::deflate::compress_to_vec_zlib(s, 6);
                    unaligned += usize::from(z.len() % 8 != 0);
                    f.extend(w.u32(MI_COMPRESSED));
                    f.extend(w.u32(z.len() as u32));
                    f.extend(&z);
                    if padded {
                        f.resize(f.len() + pad(z.len()), 0);
                    }
                }
                let m = MatFile::parse(&f, "<test>").unwrap();
                assert_eq!(m.big_endian, big);
                check(&m);
            }
            assert!(
                unaligned > 0,
                "the test needs compressed lengths that are not multiples of 8"
            );
        }
    }

    #[test]
    fn every_truncation_is_an_error() {
        let f = sample(&W { big: false });
        let ends: Vec<usize> = {
            // Cuts exactly between variables are valid files with fewer variables.
            let mut v = vec![128];
            let mut p = 128;
            while p < f.len() {
                p += 8 + u32::from_le_bytes(f[p + 4..p + 8].try_into().unwrap()) as usize;
                v.push(p);
            }
            v
        };
        for cut in 0..f.len() {
            let r = MatFile::parse(&f[..cut], "<cut>");
            if ends.contains(&cut) {
                assert!(r.is_ok(), "cut {cut}: {r:?}");
            } else {
                let e = r.expect_err(&format!("cut at {cut} must fail"));
                assert!(e.to_string().starts_with("<cut>"), "{e}");
            }
        }
    }

    #[test]
    fn bad_dims_class_and_counts_are_errors() {
        let w = W { big: false };
        let mut f = w.header();
        f.extend(w.matrix(6, &[2, 2], "a", &[w.doubles(&[1.0, 2.0, 3.0])]));
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(
            e.contains("real part has 3 values, dimensions 2×2 need 4"),
            "{e}"
        );

        let mut f = w.header();
        f.extend(w.matrix(6, &[2, -1], "a", &[w.doubles(&[])]));
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(e.contains("negative dimension"), "{e}");

        let mut f = w.header();
        f.extend(w.matrix(99, &[1, 1], "a", &[w.doubles(&[1.0])]));
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(e.contains("unknown array class 99"), "{e}");

        // A cell claiming 2^31-1 × 2^31-1 elements but holding none: an error, no huge allocation.
        let mut f = w.header();
        f.extend(w.matrix(1, &[i32::MAX, i32::MAX], "c", &[]));
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(e.contains("missing cell element"), "{e}");

        // A small element claiming more than 4 bytes.
        let mut f = w.header();
        f.extend(w.u32((7 << 16) | MI_INT8));
        f.extend([0u8; 4]);
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(e.contains("claims 7 bytes"), "{e}");

        // Deep nesting is bounded.
        let mut v = w.matrix(6, &[1, 1], "", &[w.doubles(&[1.0])]);
        for _ in 0..(MAX_DEPTH + 2) {
            v = w.matrix(1, &[1, 1], "", &[v]);
        }
        let mut f = w.header();
        f.extend(v);
        let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
        assert!(e.contains("nested deeper"), "{e}");
    }

    #[test]
    fn headers_are_checked() {
        let w = W { big: false };
        let good = sample(&w);
        let e = MatFile::parse(&good[..100], "h.mat")
            .unwrap_err()
            .to_string();
        assert!(e.contains("128"), "{e}");
        let mut bad = good.clone();
        bad[126..128].copy_from_slice(b"XX");
        let e = MatFile::parse(&bad, "h.mat").unwrap_err().to_string();
        assert!(e.contains("endian indicator"), "{e}");
        let mut v73 = good.clone();
        v73[124..126].copy_from_slice(&0x0200u16.to_le_bytes());
        let e = MatFile::parse(&v73, "h.mat").unwrap_err().to_string();
        assert!(e.contains("v7.3"), "{e}");
    }
}
