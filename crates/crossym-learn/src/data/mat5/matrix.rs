//! One `miMATRIX` element: array flags, dimensions and name, then the data of a numeric,
//! char, cell or struct array (cells and struct fields are nested `miMATRIX` elements).

use super::element::{
    type_name, Ctx, Element, FLAG_COMPLEX, FLAG_LOGICAL, MI_INT16, MI_INT32, MI_INT8, MI_MATRIX,
    MI_UINT16, MI_UINT32, MI_UINT8, MI_UTF16, MI_UTF32, MI_UTF8,
};
use super::error::Mat5Error;
use super::value::{
    dims_string, MatValue, MatVariable, NumericClass, MX_CELL, MX_CHAR, MX_OBJECT, MX_SPARSE,
    MX_STRUCT,
};
use super::MAX_DEPTH;

/// The sub-elements of one `miMATRIX` being read: `body` ends with the array, `owner` is
/// the offset of its tag, `pos` the offset of the next sub-element.
struct Cursor<'b> {
    body: &'b [u8],
    owner: usize,
    pos: usize,
}

/// Dimensions of an array and their product.
struct Shape {
    dims: Vec<usize>,
    numel: usize,
}

impl Ctx<'_> {
    /// Parses a top-level `miMATRIX` element into a named variable.
    pub(super) fn variable(&self, buf: &[u8], el: &Element<'_>) -> Result<MatVariable, Mat5Error> {
        let (name, value) = self.matrix(buf, el, 0)?;
        Ok(MatVariable { name, value })
    }

    /// Reads the next sub-element of the array at `cur`; `what` names it in errors.
    fn next<'b>(&self, cur: &mut Cursor<'b>, what: &str) -> Result<Element<'b>, Mat5Error> {
        self.sub_element(cur.body, cur.owner, &mut cur.pos, what)
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
        let mut cur = Cursor {
            body: &buf[..end],
            owner: el.offset,
            pos: start,
        };

        let flags = self.next(&mut cur, "array flags")?;
        let (class, complex, logical) = self.array_flags(&flags)?;
        let dims_el = self.next(&mut cur, "dimensions")?;
        let shape = self.dimensions(&dims_el)?;
        let name_el = self.next(&mut cur, "array name")?;
        let name = self.array_name(&name_el)?;

        let value = match class {
            MX_CELL => self.cell(&mut cur, shape, depth)?,
            MX_STRUCT => self.structure(&mut cur, shape, depth)?,
            MX_CHAR => {
                let e = self.next(&mut cur, "characters")?;
                self.char_array(e, shape)?
            }
            c if NumericClass::from_class(c).is_some() => {
                let class = NumericClass::from_class(c).unwrap_or(NumericClass::Double);
                self.numeric(&mut cur, class, shape, complex, logical)?
            }
            MX_OBJECT | MX_SPARSE | 16..=18 => MatValue::Unsupported {
                class,
                dims: shape.dims,
            },
            c => {
                return Err(self.malformed(
                    flags.offset,
                    format!("array flags: unknown array class {c}"),
                ))
            }
        };
        Ok((name, value))
    }

    /// The array flags sub-element: class, complex, logical.
    fn array_flags(&self, flags: &Element<'_>) -> Result<(u8, bool, bool), Mat5Error> {
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
        Ok((class, complex, logical))
    }

    /// The dimensions sub-element: at least 2 non-negative `miINT32`, product not overflowing.
    fn dimensions(&self, dims_el: &Element<'_>) -> Result<Shape, Mat5Error> {
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
        Ok(Shape { dims, numel })
    }

    /// The array name sub-element (NUL padding removed).
    fn array_name(&self, name_el: &Element<'_>) -> Result<String, Mat5Error> {
        if !matches!(name_el.ty, MI_INT8 | MI_UINT8 | MI_UTF8) {
            return Err(self.malformed(
                name_el.offset,
                format!(
                    "array name: expected miINT8, found {}",
                    type_name(name_el.ty)
                ),
            ));
        }
        Ok(String::from_utf8_lossy(name_el.data)
            .trim_end_matches('\0')
            .to_string())
    }

    /// A cell array: one `miMATRIX` per element.
    fn cell(
        &self,
        cur: &mut Cursor<'_>,
        shape: Shape,
        depth: usize,
    ) -> Result<MatValue, Mat5Error> {
        let mut items = Vec::new();
        for k in 0..shape.numel {
            let e = self.next(cur, "cell element")?;
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
            items.push(self.matrix(cur.body, &e, depth + 1)?.1);
        }
        Ok(MatValue::Cell {
            dims: shape.dims,
            items,
        })
    }

    /// A struct array: field-name width, field names, one `miMATRIX` per field per element.
    fn structure(
        &self,
        cur: &mut Cursor<'_>,
        shape: Shape,
        depth: usize,
    ) -> Result<MatValue, Mat5Error> {
        let fields = self.field_names(cur)?;
        let mut values = Vec::new();
        for e_idx in 0..shape.numel {
            for f in &fields {
                let e = self.next(cur, "struct field")?;
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
                values.push(self.matrix(cur.body, &e, depth + 1)?.1);
            }
        }
        Ok(MatValue::Struct {
            dims: shape.dims,
            fields,
            values,
        })
    }

    /// The field-name length and the NUL-padded fixed-width field names of a struct array.
    fn field_names(&self, cur: &mut Cursor<'_>) -> Result<Vec<String>, Mat5Error> {
        let len_el = self.next(cur, "field name length")?;
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
        let names_el = self.next(cur, "field names")?;
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
        Ok(if n == 0 {
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
        })
    }

    /// A char array from its characters element `e`; several rows are joined with `'\n'`.
    fn char_array(&self, e: Element<'_>, shape: Shape) -> Result<MatValue, Mat5Error> {
        let Shape { dims, numel } = shape;
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
        Ok(MatValue::Char { dims, text })
    }

    /// A numeric array: the real part and, for a complex array, the imaginary part.
    fn numeric(
        &self,
        cur: &mut Cursor<'_>,
        class: NumericClass,
        shape: Shape,
        complex: bool,
        logical: bool,
    ) -> Result<MatValue, Mat5Error> {
        let Shape { dims, numel } = shape;
        let re_el = self.next(cur, "real part")?;
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
            let im_el = self.next(cur, "imaginary part")?;
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
        Ok(MatValue::Numeric {
            class,
            dims,
            real,
            imag,
            logical,
        })
    }
}
