//! The messages of the protocol and their little-endian payload encoding.
//!
//! Every message has a one-byte type code. Codes `0x01..=0x7F` travel from the host to the
//! rig (commands), codes `0x80..=0xFF` from the rig to the host (responses and unsolicited
//! reports). Each response names the sequence number of the command it answers
//! (`request_seq`), so a host can match answers to questions on a lossy link.

use thiserror::Error;

/// Version of this protocol, exchanged in the [`Message::Hello`] handshake.
pub const PROTOCOL_VERSION: u16 = 1;

/// Largest payload of any message, in bytes.
pub const MAX_PAYLOAD: usize = 40;

/// A payload could not be decoded into a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum MessageError {
    /// The type code is not one this protocol version knows.
    #[error("unknown message type 0x{code:02x}")]
    UnknownType {
        /// The type code received.
        code: u8,
    },
    /// The payload length does not match the message type.
    #[error("message type 0x{code:02x}: payload of {got} bytes, expected {expected}")]
    BadLength {
        /// The type code received.
        code: u8,
        /// Payload length received.
        got: usize,
        /// Payload length this type has.
        expected: usize,
    },
    /// A field holds a value outside its enumeration.
    #[error("message type 0x{code:02x}: invalid value {value} in field `{field}`")]
    BadField {
        /// The type code received.
        code: u8,
        /// Name of the field.
        field: &'static str,
        /// The raw value received.
        value: u32,
    },
}

/// Why a rig latched a fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum FaultCause {
    /// No valid host frame arrived within the host timeout (250 ms) while armed.
    HostTimeout = 0,
    /// Supply current above the current limit.
    OverCurrent = 1,
    /// Measured thrust above the thrust limit.
    OverThrust = 2,
    /// Supply voltage below the under-voltage limit while armed.
    UnderVoltage = 3,
    /// Supply voltage above the over-voltage limit.
    OverVoltage = 4,
    /// A sensor stopped answering or returned invalid data.
    SensorFailure = 5,
    /// The board's watchdog reported a reset or a missed feed.
    Watchdog = 6,
}

impl FaultCause {
    /// All causes, in bit order.
    pub const ALL: [FaultCause; 7] = [
        FaultCause::HostTimeout,
        FaultCause::OverCurrent,
        FaultCause::OverThrust,
        FaultCause::UnderVoltage,
        FaultCause::OverVoltage,
        FaultCause::SensorFailure,
        FaultCause::Watchdog,
    ];

    fn from_u8(v: u8) -> Option<Self> {
        Self::ALL.get(usize::from(v)).copied()
    }

    /// Bit of this cause in a [`FaultSet`].
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// A set of latched fault causes (a bit field).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct FaultSet(pub u8);

impl FaultSet {
    /// No fault.
    pub const EMPTY: FaultSet = FaultSet(0);

    /// Whether `cause` is in the set.
    pub const fn contains(self, cause: FaultCause) -> bool {
        self.0 & cause.bit() != 0
    }

    /// Adds `cause`.
    pub fn insert(&mut self, cause: FaultCause) {
        self.0 |= cause.bit();
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Iterates over the causes in the set.
    pub fn iter(self) -> impl Iterator<Item = FaultCause> {
        FaultCause::ALL
            .into_iter()
            .filter(move |c| self.contains(*c))
    }
}

/// The safety state of a rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u8)]
pub enum RigState {
    /// Motor output held at minimum; throttle commands refused.
    #[default]
    Disarmed = 0,
    /// Throttle commands accepted (slew-limited).
    Armed = 1,
    /// A fault is latched; output at minimum until the host re-arms.
    Faulted = 2,
}

impl RigState {
    fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Disarmed),
            1 => Some(Self::Armed),
            2 => Some(Self::Faulted),
            _ => None,
        }
    }
}

/// Why a rig refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum NackReason {
    /// The command needs the rig armed.
    NotArmed = 0,
    /// The command needs the rig disarmed (tare, calibration).
    Armed = 1,
    /// A fault is latched; re-arm first.
    Faulted = 2,
    /// The host has not completed the version handshake.
    HandshakeRequired = 3,
    /// An argument is out of range or not finite.
    BadArgument = 4,
    /// The rig is busy with a previous command (tare, calibration).
    Busy = 5,
    /// Calibration needs a tare first.
    NotTared = 6,
    /// The protocol versions of host and rig are incompatible.
    VersionMismatch = 7,
    /// A sensor did not answer.
    SensorFailure = 8,
}

impl NackReason {
    fn from_u8(v: u8) -> Option<Self> {
        use NackReason::*;
        [
            NotArmed,
            Armed,
            Faulted,
            HandshakeRequired,
            BadArgument,
            Busy,
            NotTared,
            VersionMismatch,
            SensorFailure,
        ]
        .get(usize::from(v))
        .copied()
    }
}

/// One synchronous measurement, time-stamped by the rig clock.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sample {
    /// Rig clock at the moment of sampling, µs since rig start.
    pub time_us: u64,
    /// Calibrated thrust, grams-force.
    pub thrust_g: f32,
    /// Supply current, A.
    pub current_a: f32,
    /// Supply (bus) voltage, V.
    pub voltage_v: f32,
    /// ESC pulse width applied at the moment of sampling, µs.
    pub throttle_us: u16,
}

/// A snapshot of the rig's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Status {
    /// Rig clock, µs.
    pub time_us: u64,
    /// Safety state.
    pub state: RigState,
    /// Latched faults.
    pub faults: FaultSet,
    /// ESC pulse width being applied, µs.
    pub throttle_us: u16,
    /// Pulse width the host asked for, µs (the output slews towards it).
    pub target_throttle_us: u16,
    /// Stream rate, Hz (0 = not streaming).
    pub stream_rate_hz: u16,
    /// Valid frames the rig received.
    pub rx_frames_ok: u32,
    /// Corrupt, truncated or unknown frames the rig dropped.
    pub rx_frames_dropped: u32,
    /// Calibration points collected since the last tare.
    pub calibration_points: u8,
}

/// Who the rig is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Identity {
    /// Protocol version the rig speaks.
    pub protocol_version: u16,
    /// Firmware version `[major, minor, patch]`.
    pub firmware_version: [u8; 3],
    /// Board serial number.
    pub serial_number: u32,
    /// Board kind: 0 = simulated, 1 = Linux single-board computer, 2 = microcontroller.
    pub board: u8,
    /// Lowest ESC pulse width, µs.
    pub throttle_min_us: u16,
    /// Highest ESC pulse width, µs.
    pub throttle_max_us: u16,
    /// Highest stream rate, Hz.
    pub max_stream_rate_hz: u16,
}

/// A fault as the rig reports it when it latches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultReport {
    /// Rig clock when the fault latched, µs.
    pub time_us: u64,
    /// The cause.
    pub cause: FaultCause,
    /// The measured value that tripped the limit (A, g or V; silence in ms for a host timeout).
    pub value: f32,
    /// The limit it was compared with (same unit as `value`).
    pub limit: f32,
}

/// Every message of the protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    // ---- host -> rig ----
    /// Version handshake; the rig answers [`Message::HelloAck`].
    Hello {
        /// The host's protocol version.
        protocol_version: u16,
    },
    /// Ask who the rig is; answered by [`Message::Identity`].
    Identify,
    /// Arm (and clear latched faults); answered by [`Message::Ack`].
    Arm,
    /// Disarm: output to minimum.
    Disarm,
    /// Zero the load cell from the mean of `samples` readings; answered by [`Message::TareDone`].
    Tare {
        /// Number of raw readings to average (1..=255 recommended at 10 SPS).
        samples: u16,
    },
    /// Add a calibration point with `known_mass_g` on the load cell and refit the scale;
    /// answered by [`Message::Calibrated`]. A tare clears the points.
    Calibrate {
        /// The known mass on the load cell, g.
        known_mass_g: f32,
    },
    /// Set the target ESC pulse width, µs (slew-limited by the rig).
    SetThrottle {
        /// Target pulse width, µs.
        throttle_us: u16,
    },
    /// Stream samples at `rate_hz`.
    StartStream {
        /// Rate, Hz.
        rate_hz: u16,
    },
    /// Stop streaming.
    StopStream,
    /// Ask for a [`Message::Status`].
    GetStatus,
    /// Keep-alive; answered by [`Message::Ack`].
    Ping,

    // ---- rig -> host ----
    /// Answer to [`Message::Hello`].
    HelloAck {
        /// Sequence number of the `Hello`.
        request_seq: u16,
        /// The rig's protocol version.
        protocol_version: u16,
        /// Whether the rig accepts the host's version.
        accepted: bool,
    },
    /// Answer to [`Message::Identify`].
    Identity {
        /// Sequence number of the request.
        request_seq: u16,
        /// The identity.
        identity: Identity,
    },
    /// A command was carried out.
    Ack {
        /// Sequence number of the command.
        request_seq: u16,
    },
    /// A command was refused.
    Nack {
        /// Sequence number of the command.
        request_seq: u16,
        /// Why.
        reason: NackReason,
    },
    /// Answer to [`Message::Tare`].
    TareDone {
        /// Sequence number of the request.
        request_seq: u16,
        /// The new zero, in raw ADC counts.
        offset_counts: i32,
    },
    /// Answer to [`Message::Calibrate`].
    Calibrated {
        /// Sequence number of the request.
        request_seq: u16,
        /// Fitted scale, grams per ADC count.
        scale_g_per_count: f32,
        /// Points in the fit.
        points: u8,
    },
    /// A streamed sample.
    Sample(Sample),
    /// Answer to [`Message::GetStatus`].
    Status {
        /// Sequence number of the request.
        request_seq: u16,
        /// The status.
        status: Status,
    },
    /// A fault latched (unsolicited).
    Fault(FaultReport),
}

/// Type codes.
mod code {
    pub const HELLO: u8 = 0x01;
    pub const IDENTIFY: u8 = 0x02;
    pub const ARM: u8 = 0x03;
    pub const DISARM: u8 = 0x04;
    pub const TARE: u8 = 0x05;
    pub const CALIBRATE: u8 = 0x06;
    pub const SET_THROTTLE: u8 = 0x07;
    pub const START_STREAM: u8 = 0x08;
    pub const STOP_STREAM: u8 = 0x09;
    pub const GET_STATUS: u8 = 0x0A;
    pub const PING: u8 = 0x0B;
    pub const HELLO_ACK: u8 = 0x81;
    pub const IDENTITY: u8 = 0x82;
    pub const ACK: u8 = 0x83;
    pub const NACK: u8 = 0x84;
    pub const TARE_DONE: u8 = 0x85;
    pub const CALIBRATED: u8 = 0x86;
    pub const SAMPLE: u8 = 0x87;
    pub const STATUS: u8 = 0x88;
    pub const FAULT: u8 = 0x89;
}

struct Writer<'a> {
    buf: &'a mut [u8; MAX_PAYLOAD],
    len: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        // Payload sizes are fixed per type and all fit MAX_PAYLOAD (checked by tests).
        self.buf[self.len..self.len + b.len()].copy_from_slice(b);
        self.len += b.len();
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }
}

struct Reader<'a> {
    code: u8,
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        // Length is validated up front against the fixed size of each type.
        let mut out = [0u8; N];
        out.copy_from_slice(&self.buf[self.pos..self.pos + N]);
        self.pos += N;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn bool(&mut self, field: &'static str) -> Result<bool, MessageError> {
        match self.u8() {
            0 => Ok(false),
            1 => Ok(true),
            v => Err(self.bad(field, v)),
        }
    }
    fn bad(&self, field: &'static str, value: u8) -> MessageError {
        MessageError::BadField {
            code: self.code,
            field,
            value: u32::from(value),
        }
    }
}

const SAMPLE_LEN: usize = 8 + 4 + 4 + 4 + 2;
const STATUS_LEN: usize = 2 + 8 + 1 + 1 + 2 + 2 + 2 + 4 + 4 + 1;
const IDENTITY_LEN: usize = 2 + 2 + 3 + 4 + 1 + 2 + 2 + 2;
const FAULT_LEN: usize = 8 + 1 + 4 + 4;

fn payload_len(code: u8) -> Option<usize> {
    use code::*;
    Some(match code {
        HELLO => 2,
        IDENTIFY | ARM | DISARM | STOP_STREAM | GET_STATUS | PING => 0,
        TARE => 2,
        CALIBRATE => 4,
        SET_THROTTLE | START_STREAM => 2,
        HELLO_ACK => 5,
        IDENTITY => IDENTITY_LEN,
        ACK => 2,
        NACK => 3,
        TARE_DONE => 6,
        CALIBRATED => 7,
        SAMPLE => SAMPLE_LEN,
        STATUS => STATUS_LEN,
        FAULT => FAULT_LEN,
        _ => return None,
    })
}

impl Message {
    /// The one-byte type code of this message.
    pub fn code(&self) -> u8 {
        use code::*;
        match self {
            Message::Hello { .. } => HELLO,
            Message::Identify => IDENTIFY,
            Message::Arm => ARM,
            Message::Disarm => DISARM,
            Message::Tare { .. } => TARE,
            Message::Calibrate { .. } => CALIBRATE,
            Message::SetThrottle { .. } => SET_THROTTLE,
            Message::StartStream { .. } => START_STREAM,
            Message::StopStream => STOP_STREAM,
            Message::GetStatus => GET_STATUS,
            Message::Ping => PING,
            Message::HelloAck { .. } => HELLO_ACK,
            Message::Identity { .. } => IDENTITY,
            Message::Ack { .. } => ACK,
            Message::Nack { .. } => NACK,
            Message::TareDone { .. } => TARE_DONE,
            Message::Calibrated { .. } => CALIBRATED,
            Message::Sample(_) => SAMPLE,
            Message::Status { .. } => STATUS,
            Message::Fault(_) => FAULT,
        }
    }

    /// Whether this message travels from the host to the rig.
    pub fn is_command(&self) -> bool {
        self.code() < 0x80
    }

    /// The `request_seq` of a response, if this is one.
    pub fn request_seq(&self) -> Option<u16> {
        match *self {
            Message::HelloAck { request_seq, .. }
            | Message::Identity { request_seq, .. }
            | Message::Ack { request_seq }
            | Message::Nack { request_seq, .. }
            | Message::TareDone { request_seq, .. }
            | Message::Calibrated { request_seq, .. }
            | Message::Status { request_seq, .. } => Some(request_seq),
            _ => None,
        }
    }

    /// Writes the payload into `buf`; returns its length.
    pub fn encode_payload(&self, buf: &mut [u8; MAX_PAYLOAD]) -> usize {
        let mut w = Writer { buf, len: 0 };
        match *self {
            Message::Hello { protocol_version } => w.u16(protocol_version),
            Message::Identify
            | Message::Arm
            | Message::Disarm
            | Message::StopStream
            | Message::GetStatus
            | Message::Ping => {}
            Message::Tare { samples } => w.u16(samples),
            Message::Calibrate { known_mass_g } => w.f32(known_mass_g),
            Message::SetThrottle { throttle_us } => w.u16(throttle_us),
            Message::StartStream { rate_hz } => w.u16(rate_hz),
            Message::HelloAck {
                request_seq,
                protocol_version,
                accepted,
            } => {
                w.u16(request_seq);
                w.u16(protocol_version);
                w.u8(u8::from(accepted));
            }
            Message::Identity {
                request_seq,
                identity: id,
            } => {
                w.u16(request_seq);
                w.u16(id.protocol_version);
                w.bytes(&id.firmware_version);
                w.u32(id.serial_number);
                w.u8(id.board);
                w.u16(id.throttle_min_us);
                w.u16(id.throttle_max_us);
                w.u16(id.max_stream_rate_hz);
            }
            Message::Ack { request_seq } => w.u16(request_seq),
            Message::Nack {
                request_seq,
                reason,
            } => {
                w.u16(request_seq);
                w.u8(reason as u8);
            }
            Message::TareDone {
                request_seq,
                offset_counts,
            } => {
                w.u16(request_seq);
                w.i32(offset_counts);
            }
            Message::Calibrated {
                request_seq,
                scale_g_per_count,
                points,
            } => {
                w.u16(request_seq);
                w.f32(scale_g_per_count);
                w.u8(points);
            }
            Message::Sample(s) => {
                w.u64(s.time_us);
                w.f32(s.thrust_g);
                w.f32(s.current_a);
                w.f32(s.voltage_v);
                w.u16(s.throttle_us);
            }
            Message::Status {
                request_seq,
                status: s,
            } => {
                w.u16(request_seq);
                w.u64(s.time_us);
                w.u8(s.state as u8);
                w.u8(s.faults.0);
                w.u16(s.throttle_us);
                w.u16(s.target_throttle_us);
                w.u16(s.stream_rate_hz);
                w.u32(s.rx_frames_ok);
                w.u32(s.rx_frames_dropped);
                w.u8(s.calibration_points);
            }
            Message::Fault(f) => {
                w.u64(f.time_us);
                w.u8(f.cause as u8);
                w.f32(f.value);
                w.f32(f.limit);
            }
        }
        w.len
    }

    /// Decodes a message of type `code` from `payload`. Never panics.
    pub fn decode(code: u8, payload: &[u8]) -> Result<Message, MessageError> {
        use code::*;
        let expected = payload_len(code).ok_or(MessageError::UnknownType { code })?;
        if payload.len() != expected {
            return Err(MessageError::BadLength {
                code,
                got: payload.len(),
                expected,
            });
        }
        let mut r = Reader {
            code,
            buf: payload,
            pos: 0,
        };
        Ok(match code {
            HELLO => Message::Hello {
                protocol_version: r.u16(),
            },
            IDENTIFY => Message::Identify,
            ARM => Message::Arm,
            DISARM => Message::Disarm,
            TARE => Message::Tare { samples: r.u16() },
            CALIBRATE => Message::Calibrate {
                known_mass_g: r.f32(),
            },
            SET_THROTTLE => Message::SetThrottle {
                throttle_us: r.u16(),
            },
            START_STREAM => Message::StartStream { rate_hz: r.u16() },
            STOP_STREAM => Message::StopStream,
            GET_STATUS => Message::GetStatus,
            PING => Message::Ping,
            HELLO_ACK => Message::HelloAck {
                request_seq: r.u16(),
                protocol_version: r.u16(),
                accepted: r.bool("accepted")?,
            },
            IDENTITY => Message::Identity {
                request_seq: r.u16(),
                identity: Identity {
                    protocol_version: r.u16(),
                    firmware_version: r.take(),
                    serial_number: r.u32(),
                    board: r.u8(),
                    throttle_min_us: r.u16(),
                    throttle_max_us: r.u16(),
                    max_stream_rate_hz: r.u16(),
                },
            },
            ACK => Message::Ack {
                request_seq: r.u16(),
            },
            NACK => {
                let request_seq = r.u16();
                let v = r.u8();
                let reason = NackReason::from_u8(v).ok_or(r.bad("reason", v))?;
                Message::Nack {
                    request_seq,
                    reason,
                }
            }
            TARE_DONE => Message::TareDone {
                request_seq: r.u16(),
                offset_counts: r.i32(),
            },
            CALIBRATED => Message::Calibrated {
                request_seq: r.u16(),
                scale_g_per_count: r.f32(),
                points: r.u8(),
            },
            SAMPLE => Message::Sample(Sample {
                time_us: r.u64(),
                thrust_g: r.f32(),
                current_a: r.f32(),
                voltage_v: r.f32(),
                throttle_us: r.u16(),
            }),
            STATUS => {
                let request_seq = r.u16();
                let time_us = r.u64();
                let sv = r.u8();
                let state = RigState::from_u8(sv).ok_or(r.bad("state", sv))?;
                let faults = r.u8();
                if faults >> FaultCause::ALL.len() != 0 {
                    return Err(r.bad("faults", faults));
                }
                Message::Status {
                    request_seq,
                    status: Status {
                        time_us,
                        state,
                        faults: FaultSet(faults),
                        throttle_us: r.u16(),
                        target_throttle_us: r.u16(),
                        stream_rate_hz: r.u16(),
                        rx_frames_ok: r.u32(),
                        rx_frames_dropped: r.u32(),
                        calibration_points: r.u8(),
                    },
                }
            }
            FAULT => {
                let time_us = r.u64();
                let cv = r.u8();
                let cause = FaultCause::from_u8(cv).ok_or(r.bad("cause", cv))?;
                Message::Fault(FaultReport {
                    time_us,
                    cause,
                    value: r.f32(),
                    limit: r.f32(),
                })
            }
            _ => return Err(MessageError::UnknownType { code }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_payloads_fit() {
        for code in 0..=255u8 {
            if let Some(len) = payload_len(code) {
                assert!(len <= MAX_PAYLOAD, "code {code:#x}");
            }
        }
    }

    #[test]
    fn unknown_and_bad_fields_are_errors() {
        assert_eq!(
            Message::decode(0x7E, &[]),
            Err(MessageError::UnknownType { code: 0x7E })
        );
        assert!(matches!(
            Message::decode(code::ACK, &[1]),
            Err(MessageError::BadLength { .. })
        ));
        assert!(matches!(
            Message::decode(code::NACK, &[0, 0, 200]),
            Err(MessageError::BadField {
                field: "reason",
                ..
            })
        ));
    }
}
