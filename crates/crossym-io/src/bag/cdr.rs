//! CDR payloads with the 4-byte encapsulation header used by ROS 2 (`rmw` XCDR1):
//! `00 01 00 00` = CDR little endian, `00 00 00 00` = CDR big endian. Alignment counts from
//! after the header.

use byteorder::{BigEndian, LittleEndian};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Encapsulation header of little-endian CDR.
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// Serialises `m` as little-endian CDR with its encapsulation header.
pub fn encode<M: Serialize>(m: &M) -> Result<Vec<u8>, String> {
    let mut out = CDR_LE.to_vec();
    cdr_encoding::to_writer::<M, LittleEndian, _>(&mut out, m).map_err(|e| e.to_string())?;
    Ok(out)
}

/// Deserialises a CDR payload (either byte order) after checking its header.
pub fn decode<M: DeserializeOwned>(data: &[u8]) -> Result<M, String> {
    if data.len() < 4 {
        return Err(format!("payload of {} bytes has no CDR header", data.len()));
    }
    let body = &data[4..];
    let r = match (data[0], data[1]) {
        (0, 1) => cdr_encoding::from_bytes::<M, LittleEndian>(body),
        (0, 0) => cdr_encoding::from_bytes::<M, BigEndian>(body),
        (a, b) => {
            return Err(format!(
            "encapsulation {a:#04x}{b:02x} is not plain CDR (XCDR2 and PL_CDR are not supported)"
        ))
        }
    };
    r.map(|(m, _)| m).map_err(|e| e.to_string())
}
