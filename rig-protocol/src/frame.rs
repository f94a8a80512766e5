//! Framing: sequence number, type, payload and CRC-32C, COBS-stuffed and
//! terminated by a `0x00` delimiter.
//!
//! ```text
//! raw   = seq (u16 LE) | type (u8) | payload (0..=MAX_PAYLOAD) | crc32c(seq..payload) (u32 LE)
//! wire  = COBS(raw) | 0x00
//! ```
//!
//! The [`Decoder`] takes bytes one at a time, never allocates and never panics. A corrupt,
//! truncated, oversized or unknown frame is dropped and counted in [`DecoderStats`]; the
//! decoder resynchronises on the next delimiter. Empty frames (back-to-back delimiters) are
//! ignored silently, so a sender may emit a delimiter first to flush a half-received frame.

use crate::cobs::{self, CobsError};
use crate::crc::crc32c;
use crate::message::{MAX_PAYLOAD, Message, MessageError};
use thiserror::Error;

/// Frame delimiter on the wire.
pub const DELIMITER: u8 = 0x00;
/// Largest raw (un-stuffed) frame: header, payload, CRC.
pub const MAX_RAW_FRAME: usize = 3 + MAX_PAYLOAD + 4;
/// Largest frame on the wire, delimiter included.
pub const MAX_WIRE_FRAME: usize = cobs::max_encoded_len(MAX_RAW_FRAME) + 1;
/// Smallest raw frame (no payload).
const MIN_RAW_FRAME: usize = 3 + 4;

/// A decoded frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The sender's sequence number (wrapping).
    pub seq: u16,
    /// The message.
    pub message: Message,
}

/// Why a frame was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum FrameError {
    /// More bytes than the largest frame arrived before a delimiter.
    #[error("frame longer than {max} bytes before a delimiter")]
    Oversize {
        /// The largest frame size.
        max: usize,
    },
    /// The COBS stuffing is invalid (bytes lost or flipped).
    #[error("bad COBS stuffing")]
    Cobs(#[from] CobsError),
    /// Fewer bytes than the smallest frame.
    #[error("truncated frame: {len} bytes, at least {min} needed")]
    Truncated {
        /// Raw length received.
        len: usize,
        /// Minimum raw length.
        min: usize,
    },
    /// The CRC does not match.
    #[error("CRC mismatch: frame says {expected:#010x}, computed {computed:#010x}")]
    Crc {
        /// CRC carried by the frame.
        expected: u32,
        /// CRC computed over the received bytes.
        computed: u32,
    },
    /// The CRC matched but the payload is not a valid message.
    #[error("invalid message")]
    Message(#[from] MessageError),
}

/// Encoding a frame failed (the output buffer is too small).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("output buffer of {got} bytes too small for a frame (need {needed})")]
pub struct EncodeError {
    /// Bytes available.
    pub got: usize,
    /// Bytes a worst-case frame needs.
    pub needed: usize,
}

/// Encodes `message` with sequence number `seq` into `out` (delimiter included).
/// Returns the number of bytes written. `out` must hold [`MAX_WIRE_FRAME`] bytes.
///
/// ```
/// use rig_protocol::frame::{encode_frame, Decoder, MAX_WIRE_FRAME};
/// use rig_protocol::Message;
/// let mut wire = [0u8; MAX_WIRE_FRAME];
/// let n = encode_frame(7, &Message::SetThrottle { throttle_us: 1500 }, &mut wire).unwrap();
/// let mut dec = Decoder::new();
/// let frames: Vec<_> = wire[..n].iter().filter_map(|&b| dec.push(b)).collect();
/// assert_eq!(frames.len(), 1);
/// let frame = frames[0].unwrap();
/// assert_eq!(frame.seq, 7);
/// assert_eq!(frame.message, Message::SetThrottle { throttle_us: 1500 });
/// ```
pub fn encode_frame(seq: u16, message: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    if out.len() < MAX_WIRE_FRAME {
        return Err(EncodeError {
            got: out.len(),
            needed: MAX_WIRE_FRAME,
        });
    }
    let mut raw = [0u8; MAX_RAW_FRAME];
    raw[..2].copy_from_slice(&seq.to_le_bytes());
    raw[2] = message.code();
    let mut payload = [0u8; MAX_PAYLOAD];
    let plen = message.encode_payload(&mut payload);
    raw[3..3 + plen].copy_from_slice(&payload[..plen]);
    let crc = crc32c(&raw[..3 + plen]);
    raw[3 + plen..7 + plen].copy_from_slice(&crc.to_le_bytes());
    let n = cobs::encode(&raw[..7 + plen], &mut out[..MAX_WIRE_FRAME - 1]).map_err(|_| {
        EncodeError {
            got: out.len(),
            needed: MAX_WIRE_FRAME,
        }
    })?;
    out[n] = DELIMITER;
    Ok(n + 1)
}

/// Decodes one raw (un-stuffed) frame body. Never panics.
pub fn decode_raw(raw: &[u8]) -> Result<Frame, FrameError> {
    if raw.len() < MIN_RAW_FRAME {
        return Err(FrameError::Truncated {
            len: raw.len(),
            min: MIN_RAW_FRAME,
        });
    }
    let (body, crc_bytes) = raw.split_at(raw.len() - 4);
    let expected = u32::from_le_bytes([crc_bytes[0], crc_bytes[1], crc_bytes[2], crc_bytes[3]]);
    let computed = crc32c(body);
    if expected != computed {
        return Err(FrameError::Crc { expected, computed });
    }
    let seq = u16::from_le_bytes([body[0], body[1]]);
    let message = Message::decode(body[2], &body[3..])?;
    Ok(Frame { seq, message })
}

/// Counters of a [`Decoder`]. Every dropped frame is counted in exactly one field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DecoderStats {
    /// Frames decoded successfully.
    pub frames_ok: u32,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u32,
    /// Frames dropped for bad stuffing or too few bytes.
    pub malformed: u32,
    /// Frames dropped for exceeding the largest frame size.
    pub oversize: u32,
    /// Frames with a valid CRC but an unknown type or invalid fields.
    pub invalid_message: u32,
}

impl DecoderStats {
    /// All dropped frames.
    pub fn dropped(&self) -> u32 {
        self.crc_errors
            .saturating_add(self.malformed)
            .saturating_add(self.oversize)
            .saturating_add(self.invalid_message)
    }
}

/// A streaming frame decoder with a fixed buffer.
#[derive(Debug, Clone)]
pub struct Decoder {
    buf: [u8; MAX_WIRE_FRAME],
    len: usize,
    overflow: bool,
    stats: DecoderStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder with an empty buffer.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_WIRE_FRAME],
            len: 0,
            overflow: false,
            stats: DecoderStats {
                frames_ok: 0,
                crc_errors: 0,
                malformed: 0,
                oversize: 0,
                invalid_message: 0,
            },
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Feeds one byte. Returns `Some` when a delimiter ends a non-empty frame: the frame, or
    /// why it was dropped (already counted).
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame, FrameError>> {
        if byte != DELIMITER {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflow, false) {
            self.stats.oversize = self.stats.oversize.saturating_add(1);
            return Some(Err(FrameError::Oversize {
                max: MAX_WIRE_FRAME,
            }));
        }
        if len == 0 {
            return None;
        }
        let mut raw = [0u8; MAX_RAW_FRAME];
        let result = cobs::decode(&self.buf[..len], &mut raw)
            .map_err(|e| match e {
                CobsError::BufferTooSmall { .. } => FrameError::Oversize {
                    max: MAX_WIRE_FRAME,
                },
                other => FrameError::Cobs(other),
            })
            .and_then(|n| decode_raw(&raw[..n]));
        let counter = match &result {
            Ok(_) => &mut self.stats.frames_ok,
            Err(FrameError::Crc { .. }) => &mut self.stats.crc_errors,
            Err(FrameError::Oversize { .. }) => &mut self.stats.oversize,
            Err(FrameError::Message(_)) => &mut self.stats.invalid_message,
            Err(FrameError::Cobs(_) | FrameError::Truncated { .. }) => &mut self.stats.malformed,
        };
        *counter = counter.saturating_add(1);
        Some(result)
    }
}
