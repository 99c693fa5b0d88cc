//! CDR payloads with the 4-byte encapsulation header used by ROS 2 (`rmw` XCDR1):
//! `00 01 00 00` = CDR little endian, `00 00 00 00` = CDR big endian. Alignment counts from
//! after the header.

use byteorder::{BigEndian, LittleEndian};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Encapsulation header of little-endian CDR.
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// Why a message could not be encoded or a payload decoded as CDR.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CdrError {
    /// The serialiser refused the message.
    #[error("{message}")]
    Encode {
        /// The serialiser's message.
        message: String,
    },
    /// The payload is shorter than the 4-byte encapsulation header.
    #[error("payload of {len} bytes has no CDR header")]
    NoHeader {
        /// Payload length (bytes).
        len: usize,
    },
    /// The encapsulation is not plain CDR.
    #[error(
        "encapsulation {:#04x}{:02x} is not plain CDR (XCDR2 and PL_CDR are not supported)",
        .id[0],
        .id[1]
    )]
    Encapsulation {
        /// The first two header bytes (the representation identifier).
        id: [u8; 2],
    },
    /// The payload does not deserialise to the message type.
    #[error("{message}")]
    Decode {
        /// The deserialiser's message.
        message: String,
    },
}

/// Serialises `m` as little-endian CDR with its encapsulation header.
pub fn encode<M: Serialize>(m: &M) -> Result<Vec<u8>, CdrError> {
    let mut out = CDR_LE.to_vec();
    cdr_encoding::to_writer::<M, LittleEndian, _>(&mut out, m).map_err(|e| CdrError::Encode {
        message: e.to_string(),
    })?;
    Ok(out)
}

/// Deserialises a CDR payload (either byte order) after checking its header.
pub fn decode<M: DeserializeOwned>(data: &[u8]) -> Result<M, CdrError> {
    if data.len() < 4 {
        return Err(CdrError::NoHeader { len: data.len() });
    }
    let body = &data[4..];
    let r = match (data[0], data[1]) {
        (0, 1) => cdr_encoding::from_bytes::<M, LittleEndian>(body),
        (0, 0) => cdr_encoding::from_bytes::<M, BigEndian>(body),
        (a, b) => return Err(CdrError::Encapsulation { id: [a, b] }),
    };
    r.map(|(m, _)| m).map_err(|e| CdrError::Decode {
        message: e.to_string(),
    })
}
