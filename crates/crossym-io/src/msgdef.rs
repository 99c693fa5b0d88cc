//! A parser for ROS 2 `.msg` interface definitions (the subset rosidl accepts for
//! messages): `type name [default]` fields, `type NAME=value` constants, `#` comments,
//! unbounded (`T[]`), fixed (`T[N]`) and bounded (`T[<=N]`) arrays, bounded strings
//! (`string<=N`). Used to check that the Rust mirrors in [`super::msg`] keep the
//! field names, types and order (the CDR layout) of the shipped `msgs/msg/*.msg` files.

use std::fmt;

/// Errors while parsing a `.msg` file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MsgDefError {
    /// A line is not a field, a constant, a comment or blank.
    #[error("line {line}: {message}")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Why a field type (`float64[<=4]`, …) is refused ([`FieldType::parse`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FieldTypeError {
    /// `[` without a closing `]`.
    #[error("unterminated array type `{ty}`")]
    Unterminated {
        /// The type as written.
        ty: String,
    },
    /// The bound of `T[<=N]` is not a number.
    #[error("bad bound in `{ty}`")]
    BadBound {
        /// The type as written.
        ty: String,
    },
    /// The size of `T[N]` is not a number.
    #[error("bad size in `{ty}`")]
    BadSize {
        /// The type as written.
        ty: String,
    },
    /// The base type is empty or has characters a type cannot have.
    #[error("bad type `{ty}`")]
    BadType {
        /// The type as written.
        ty: String,
    },
}

/// Array-ness of a field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArrayKind {
    /// A single value.
    Scalar,
    /// `T[]`: a sequence of any length.
    Unbounded,
    /// `T[N]`: exactly `N` elements.
    Fixed(usize),
    /// `T[<=N]`: at most `N` elements.
    Bounded(usize),
}

/// A field's type: base type (`float64`, `string<=10`, `std_msgs/Header`) and array-ness.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldType {
    /// Base type as written (with a string bound if any).
    pub base: String,
    /// Array-ness.
    pub array: ArrayKind,
}

impl FieldType {
    /// Parses `float64`, `string[]`, `int8[3]`, `std_msgs/Header[<=4]`.
    pub fn parse(s: &str) -> Result<Self, FieldTypeError> {
        let (base, array) = match s.find('[') {
            None => (s, ArrayKind::Scalar),
            Some(i) => {
                let inner = s[i + 1..]
                    .strip_suffix(']')
                    .ok_or_else(|| FieldTypeError::Unterminated { ty: s.to_string() })?;
                let array = if inner.is_empty() {
                    ArrayKind::Unbounded
                } else if let Some(n) = inner.strip_prefix("<=") {
                    ArrayKind::Bounded(
                        n.parse()
                            .map_err(|_| FieldTypeError::BadBound { ty: s.to_string() })?,
                    )
                } else {
                    ArrayKind::Fixed(
                        inner
                            .parse()
                            .map_err(|_| FieldTypeError::BadSize { ty: s.to_string() })?,
                    )
                };
                (&s[..i], array)
            }
        };
        let ok =
            |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '/' || c == '<' || c == '=';
        if base.is_empty() || !base.chars().all(ok) {
            return Err(FieldTypeError::BadType { ty: s.to_string() });
        }
        Ok(Self {
            base: base.to_string(),
            array,
        })
    }

    /// True for the primitive types of the ROS IDL (numbers, bool, byte, char, strings).
    pub fn is_primitive(&self) -> bool {
        let b = self.base.split("<=").next().unwrap_or("");
        matches!(
            b,
            "bool"
                | "byte"
                | "char"
                | "float32"
                | "float64"
                | "int8"
                | "uint8"
                | "int16"
                | "uint16"
                | "int32"
                | "uint32"
                | "int64"
                | "uint64"
                | "string"
                | "wstring"
        )
    }
}

impl fmt::Display for FieldType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.base)?;
        match self.array {
            ArrayKind::Scalar => Ok(()),
            ArrayKind::Unbounded => f.write_str("[]"),
            ArrayKind::Fixed(n) => write!(f, "[{n}]"),
            ArrayKind::Bounded(n) => write!(f, "[<={n}]"),
        }
    }
}

/// One field of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldDef {
    /// Type.
    pub ty: FieldType,
    /// Field name (snake_case).
    pub name: String,
    /// Default value as written, if any.
    pub default: Option<String>,
    /// Comment lines directly above plus the trailing comment, joined by newlines.
    pub comment: String,
}

/// One constant of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConstantDef {
    /// Type (primitive, scalar).
    pub ty: FieldType,
    /// Name (UPPER_CASE).
    pub name: String,
    /// Value as written (trimmed).
    pub value: String,
    /// Comment lines directly above plus the trailing comment.
    pub comment: String,
}

/// A parsed `.msg` file: fields in declaration (CDR) order and constants.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MsgDef {
    /// Fields in declaration order.
    pub fields: Vec<FieldDef>,
    /// Constants in declaration order.
    pub constants: Vec<ConstantDef>,
}

impl MsgDef {
    /// Parses the text of a `.msg` file.
    pub fn parse(text: &str) -> Result<Self, MsgDefError> {
        let mut def = Self::default();
        let mut pending: Vec<String> = Vec::new();
        for (k, raw) in text.lines().enumerate() {
            let line = k + 1;
            let err = |message: String| MsgDefError::Syntax { line, message };
            let trimmed = raw.trim();
            if trimmed.is_empty() {
                pending.clear();
                continue;
            }
            if let Some(c) = trimmed.strip_prefix('#') {
                pending.push(c.trim().to_string());
                continue;
            }
            let (ty_str, rest) = trimmed
                .split_once(char::is_whitespace)
                .ok_or_else(|| err(format!("expected `type name`, got `{trimmed}`")))?;
            let ty = FieldType::parse(ty_str).map_err(|e| err(e.to_string()))?;
            let rest = rest.trim_start();
            let is_string = ty.base.starts_with("string") || ty.base.starts_with("wstring");
            // Constant: NAME=value (string constants keep '#' in their value).
            let name_end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            let name = &rest[..name_end];
            if name.is_empty() || !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
                return Err(err(format!("bad name in `{trimmed}`")));
            }
            let after = rest[name_end..].trim_start();
            let mut comment = std::mem::take(&mut pending);
            if let Some(value) = after.strip_prefix('=') {
                let (value, trailing) = if is_string {
                    (value.trim(), None)
                } else {
                    split_comment(value)
                };
                if let Some(t) = trailing {
                    comment.push(t);
                }
                if value.is_empty() {
                    return Err(err(format!("constant {name} has no value")));
                }
                if ty.array != ArrayKind::Scalar || !ty.is_primitive() {
                    return Err(err(format!("constant {name} must be a primitive scalar")));
                }
                def.constants.push(ConstantDef {
                    ty,
                    name: name.to_string(),
                    value: value.to_string(),
                    comment: comment.join("\n"),
                });
            } else {
                let (default, trailing) = split_comment(after);
                if let Some(t) = trailing {
                    comment.push(t);
                }
                if name.chars().any(|c| c.is_ascii_uppercase()) {
                    return Err(err(format!("field name {name} must be lower case")));
                }
                def.fields.push(FieldDef {
                    ty,
                    name: name.to_string(),
                    default: (!default.is_empty()).then(|| default.to_string()),
                    comment: comment.join("\n"),
                });
            }
        }
        Ok(def)
    }

    /// The field named `name`.
    pub fn field(&self, name: &str) -> Option<&FieldDef> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// The constant named `name`.
    pub fn constant(&self, name: &str) -> Option<&ConstantDef> {
        self.constants.iter().find(|c| c.name == name)
    }
}

/// Splits `value  # comment` into the trimmed value and the comment.
fn split_comment(s: &str) -> (&str, Option<String>) {
    match s.find('#') {
        Some(i) => (s[..i].trim(), Some(s[i + 1..].trim().to_string())),
        None => (s.trim(), None),
    }
}
