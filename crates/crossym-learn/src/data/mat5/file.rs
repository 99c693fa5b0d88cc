//! A whole MAT v5 file: the 128-byte header (text, version, byte order) and the top-level
//! data elements, `miMATRIX` variables and `miCOMPRESSED` streams of them.

use std::path::Path;

use super::element::{pad, type_name, Ctx, Element, MI_COMPRESSED, MI_MATRIX};
use super::error::Mat5Error;
use super::inflate::inflate;
use super::value::{MatValue, MatVariable};

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
        let (big, description) = header(bytes, origin)?;
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
                MI_COMPRESSED => compressed_variables(&ctx, &el, &mut variables)?,
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
                pos = skip_compressed_padding(bytes, &el, pos, big);
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

/// Checks the 128-byte header; returns whether the file is big-endian and its text.
fn header(bytes: &[u8], origin: &str) -> Result<(bool, String), Mat5Error> {
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
    Ok((big, description))
}

/// Inflates the top-level compressed element `el` and appends the variables it holds.
fn compressed_variables(
    ctx: &Ctx<'_>,
    el: &Element<'_>,
    variables: &mut Vec<MatVariable>,
) -> Result<(), Mat5Error> {
    let inflated = inflate(ctx.origin, el)?;
    let inner = Ctx {
        origin: ctx.origin,
        big: ctx.big,
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
    Ok(())
}

/// Where the element after the compressed element `el` starts, `pos` being the end of its
/// data: past the zero padding some writers add.
fn skip_compressed_padding(bytes: &[u8], el: &Element<'_>, pos: usize, big: bool) -> usize {
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
        padded
    } else {
        pos
    }
}
