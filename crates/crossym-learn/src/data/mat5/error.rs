//! What can go wrong while reading a MAT v5 file; every error names the byte offset.

use std::path::PathBuf;

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
