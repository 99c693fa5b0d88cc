//! `miCOMPRESSED` elements: a zlib stream inflated to further data elements, capped at
//! [`MAX_INFLATED_BYTES`].

use super::element::Element;
use super::error::Mat5Error;
use super::MAX_INFLATED_BYTES;

/// Inflates the zlib stream of the compressed element `el`; `origin` names the file.
pub(super) fn inflate(origin: &str, el: &Element<'_>) -> Result<Vec<u8>, Mat5Error> {
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
