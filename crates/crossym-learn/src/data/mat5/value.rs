//! The values of a MAT v5 file: numeric, char, cell and struct arrays ([`MatValue`]).

/// mxCELL_CLASS.
pub(super) const MX_CELL: u8 = 1;
/// mxSTRUCT_CLASS.
pub(super) const MX_STRUCT: u8 = 2;
/// mxOBJECT_CLASS.
pub(super) const MX_OBJECT: u8 = 3;
/// mxCHAR_CLASS.
pub(super) const MX_CHAR: u8 = 4;
/// mxSPARSE_CLASS.
pub(super) const MX_SPARSE: u8 = 5;

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
    pub(super) fn from_class(c: u8) -> Option<Self> {
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
