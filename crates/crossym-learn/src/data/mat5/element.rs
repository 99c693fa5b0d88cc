//! Data elements of a MAT v5 file: the 8-byte tag (or the packed tag of a small element),
//! its data and padding, element type names and sizes, and the conversion of numeric
//! element data to `f64` in the file's byte order.

use super::error::Mat5Error;

/// Element types (miINT8 …).
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

/// Array flags: complex array.
pub(super) const FLAG_COMPLEX: u32 = 0x800;
/// Array flags: logical array.
pub(super) const FLAG_LOGICAL: u32 = 0x200;

/// Zero bytes after an element of `len` bytes, up to the next multiple of 8.
pub(super) fn pad(len: usize) -> usize {
    (8 - len % 8) % 8
}

/// MATLAB's name of an element type (`miDOUBLE`, …).
pub(super) fn type_name(ty: u32) -> String {
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
pub(super) struct Element<'a> {
    pub(super) ty: u32,
    pub(super) data: &'a [u8],
    /// Offset of the tag.
    pub(super) offset: usize,
    /// Offset of the data.
    pub(super) data_start: usize,
    /// Byte count from the tag.
    pub(super) len: usize,
    /// Offset of the next element (after padding).
    pub(super) next: usize,
}

/// Where a buffer comes from and how to read its numbers.
#[derive(Clone, Copy)]
pub(super) struct Ctx<'a> {
    pub(super) origin: &'a str,
    pub(super) big: bool,
    pub(super) inflated_from: Option<usize>,
}

impl Ctx<'_> {
    pub(super) fn malformed(&self, offset: usize, message: String) -> Mat5Error {
        Mat5Error::Malformed {
            origin: self.origin.to_string(),
            offset,
            inflated_from: self.inflated_from,
            message,
        }
    }

    pub(super) fn truncated(
        &self,
        offset: usize,
        what: String,
        needed: usize,
        available: usize,
    ) -> Mat5Error {
        Mat5Error::Truncated {
            origin: self.origin.to_string(),
            offset,
            inflated_from: self.inflated_from,
            what,
            needed: needed as u64,
            available: available as u64,
        }
    }

    pub(super) fn u32(&self, b: &[u8]) -> u32 {
        let w = [b[0], b[1], b[2], b[3]];
        if self.big {
            u32::from_be_bytes(w)
        } else {
            u32::from_le_bytes(w)
        }
    }

    /// Reads the element whose tag is at `pos` of `buf`; `what` names it in errors.
    pub(super) fn element<'b>(
        &self,
        buf: &'b [u8],
        pos: usize,
        what: &str,
    ) -> Result<Element<'b>, Mat5Error> {
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

    /// Converts the data of a numeric element to `f64`.
    pub(super) fn numbers(&self, el: &Element<'_>, what: &str) -> Result<Vec<f64>, Mat5Error> {
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
    pub(super) fn sub_element<'b>(
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
}
