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
//!
//! Files: [`error`] (what can go wrong, with offsets), [`value`] (the [`MatValue`] tree),
//! `element` (data-element tags and numbers), `inflate` (`miCOMPRESSED` streams), `matrix`
//! (one `miMATRIX`: numeric, char, cell and struct arrays), [`mod@file`] (the header and the
//! top-level elements of a [`MatFile`]).

mod element;
pub mod error;
pub mod file;
mod inflate;
mod matrix;
pub mod value;

#[cfg(test)]
mod tests;

pub use error::Mat5Error;
pub use file::MatFile;
pub use value::{dims_string, MatValue, MatVariable, NumericClass};

/// Largest inflated size of one `miCOMPRESSED` element (bytes); larger streams are rejected.
pub const MAX_INFLATED_BYTES: usize = 1 << 30;

/// Deepest cell/struct nesting accepted (levels below a top-level variable).
pub const MAX_DEPTH: usize = 64;
