//! Consistent Overhead Byte Stuffing: removes every `0x00` from a frame so that
//! `0x00` can delimit frames on the wire and a receiver can resynchronise on it. The coding is
//! the `cobs` crate's (no_std); this module keeps the protocol's error type and bounds.

use thiserror::Error;

/// COBS encoding or decoding failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum CobsError {
    /// The output buffer is too small for the result.
    #[error("COBS output buffer too small (need at least {needed} bytes)")]
    BufferTooSmall {
        /// Bytes the operation needed.
        needed: usize,
    },
    /// The encoded input is not valid COBS (a zero byte, or a code running past the end).
    #[error("invalid COBS data at byte {at}")]
    Invalid {
        /// Where decoding stopped: the offset of a zero byte in the encoded input, or the
        /// number of bytes decoded before a code ran past the end.
        at: usize,
    },
}

/// Worst-case encoded length of `len` raw bytes (without the delimiter).
pub const fn max_encoded_len(len: usize) -> usize {
    len + len / 254 + 1
}

/// Encodes `src` into `dst` (no trailing delimiter). Returns the encoded length.
///
/// A thin wrapper over the `cobs` crate that keeps this crate's error type and its
/// up-front size check.
///
/// ```
/// let mut out = [0u8; 8];
/// let n = rig_protocol::cobs::encode(&[0x11, 0x00, 0x22], &mut out).unwrap();
/// assert_eq!(&out[..n], &[0x02, 0x11, 0x02, 0x22]);
/// ```
pub fn encode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    let needed = max_encoded_len(src.len());
    if dst.len() < needed {
        return Err(CobsError::BufferTooSmall { needed });
    }
    cobs::try_encode(src, dst).map_err(|_| CobsError::BufferTooSmall { needed })
}

/// Decodes COBS `src` (without the delimiter) into `dst`. Returns the decoded length.
///
/// A zero byte anywhere in `src` is invalid (the delimiter is not part of a frame); the
/// decoding itself is the `cobs` crate's.
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    if let Some(at) = src.iter().position(|&b| b == 0) {
        return Err(CobsError::Invalid { at });
    }
    if src.is_empty() {
        return Ok(0);
    }
    match cobs::decode(src, dst) {
        Ok(report) if report.parsed_size() == src.len() => Ok(report.frame_size()),
        Ok(report) => Err(CobsError::Invalid {
            at: report.parsed_size(),
        }),
        Err(cobs::DecodeError::TargetBufTooSmall) => Err(CobsError::BufferTooSmall {
            needed: dst.len() + 1,
        }),
        Err(cobs::DecodeError::InvalidFrame { decoded_bytes }) => {
            Err(CobsError::Invalid { at: decoded_bytes })
        }
        Err(cobs::DecodeError::EmptyFrame) => Ok(0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_vectors() {
        let cases: &[(&[u8], &[u8])] = &[
            (&[], &[0x01]),
            (&[0x00], &[0x01, 0x01]),
            (&[0x00, 0x00], &[0x01, 0x01, 0x01]),
            (&[0x11, 0x22, 0x00, 0x33], &[0x03, 0x11, 0x22, 0x02, 0x33]),
            (&[0x11, 0x00, 0x00, 0x00], &[0x02, 0x11, 0x01, 0x01, 0x01]),
        ];
        for (raw, enc) in cases {
            let mut buf = [0u8; 16];
            let n = encode(raw, &mut buf).unwrap();
            assert_eq!(&buf[..n], *enc);
            let mut dec = [0u8; 16];
            let m = decode(enc, &mut dec).unwrap();
            assert_eq!(&dec[..m], *raw);
        }
    }

    proptest! {
        #[test]
        fn round_trip(raw in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut enc = [0u8; 700];
            let n = encode(&raw, &mut enc).unwrap();
            prop_assert!(!enc[..n].contains(&0));
            prop_assert!(n <= max_encoded_len(raw.len()));
            let mut dec = [0u8; 700];
            let m = decode(&enc[..n], &mut dec).unwrap();
            prop_assert_eq!(&dec[..m], &raw[..]);
        }

        #[test]
        fn decode_never_panics(src in proptest::collection::vec(any::<u8>(), 0..300)) {
            let mut dec = [0u8; 64];
            let _ = decode(&src, &mut dec);
        }
    }
}
