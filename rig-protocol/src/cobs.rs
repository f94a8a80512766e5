//! Consistent Overhead Byte Stuffing: removes every `0x00` from a frame so that
//! `0x00` can delimit frames on the wire and a receiver can resynchronise on it.

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
        /// Offset of the offending byte in the encoded input.
        at: usize,
    },
}

/// Worst-case encoded length of `len` raw bytes (without the delimiter).
pub const fn max_encoded_len(len: usize) -> usize {
    len + len / 254 + 1
}

/// Encodes `src` into `dst` (no trailing delimiter). Returns the encoded length.
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
    let mut code_at = 0usize;
    let mut out = 1usize;
    let mut code: u8 = 1;
    for &b in src {
        if b == 0 {
            dst[code_at] = code;
            code_at = out;
            out += 1;
            code = 1;
        } else {
            dst[out] = b;
            out += 1;
            code += 1;
            if code == 0xFF {
                dst[code_at] = code;
                code_at = out;
                out += 1;
                code = 1;
            }
        }
    }
    dst[code_at] = code;
    Ok(out)
}

/// Decodes COBS `src` (without the delimiter) into `dst`. Returns the decoded length.
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    let mut i = 0usize;
    let mut out = 0usize;
    while i < src.len() {
        let code = src[i];
        if code == 0 {
            return Err(CobsError::Invalid { at: i });
        }
        let run = usize::from(code - 1);
        let end = i + 1 + run;
        if end > src.len() {
            return Err(CobsError::Invalid { at: i });
        }
        for (k, &b) in src[i + 1..end].iter().enumerate() {
            if b == 0 {
                return Err(CobsError::Invalid { at: i + 1 + k });
            }
            if out >= dst.len() {
                return Err(CobsError::BufferTooSmall { needed: out + 1 });
            }
            dst[out] = b;
            out += 1;
        }
        i = end;
        if code != 0xFF && i < src.len() {
            if out >= dst.len() {
                return Err(CobsError::BufferTooSmall { needed: out + 1 });
            }
            dst[out] = 0;
            out += 1;
        }
    }
    Ok(out)
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
