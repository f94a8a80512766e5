//! # rig-protocol
//!
//! The contract between a thrust-rig's firmware, the host that drives it and the simulator
//! that stands in for it (section III-C of the paper: thrust, current and voltage sampled
//! together at controlled throttle steps). `no_std`, allocation-free, never panics on bytes
//! from outside.
//!
//! Main types:
//! - [`Message`]: every message (identify, handshake, arm/disarm, tare, calibrate, set
//!   throttle, start/stop stream, sample, status, fault, ack/nack);
//! - [`frame`]: framing — sequence number, CRC-32C, COBS stuffing with `0x00` delimiters —
//!   with [`frame::encode_frame`] and the streaming [`frame::Decoder`], which drops and counts
//!   corrupt, truncated and unknown frames and resynchronises on the next delimiter;
//! - [`Rig`] and [`Clock`]: the host-side view of a rig, implemented alike by hardware and
//!   by the simulator;
//! - [`client::Client`]: the host side of the protocol over any [`client::Transport`]
//!   (serial port, pseudo-terminal, in-process link), implementing [`Rig`].
//!
//! ```
//! use rig_protocol::frame::{encode_frame, Decoder, MAX_WIRE_FRAME};
//! use rig_protocol::{Message, Sample};
//!
//! let sample = Sample { time_us: 1_250_000, thrust_g: 101.5, current_a: 1.31,
//!                       voltage_v: 12.49, throttle_us: 1420 };
//! let mut wire = [0u8; MAX_WIRE_FRAME];
//! let n = encode_frame(42, &Message::Sample(sample), &mut wire).unwrap();
//! assert!(!wire[..n - 1].contains(&0)); // only the delimiter is zero
//!
//! // A corrupted copy is rejected and counted; the decoder recovers on the next frame.
//! let mut bad = wire;
//! bad[5] ^= 0x10;
//! let mut dec = Decoder::new();
//! let got: Vec<_> = bad[..n].iter().chain(&wire[..n]).filter_map(|&b| dec.push(b)).collect();
//! assert!(got[0].is_err());
//! assert_eq!(got[1].unwrap().message, Message::Sample(sample));
//! assert_eq!(dec.stats().dropped(), 1);
//! ```
//!
//! The [`client::Client`] handles sequence numbers, retries and keep-alives; see its docs.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod client;
pub mod cobs;
pub mod crc;
pub mod frame;
pub mod message;
pub mod rig;

pub use client::{Client, ClientConfig, ClientError, Transport};
pub use frame::{Decoder, DecoderStats, Frame, FrameError};
pub use message::{
    FaultCause, FaultReport, FaultSet, Identity, Message, NackReason, PROTOCOL_VERSION, RigState,
    Sample, Status,
};
pub use rig::{Calibration, Clock, Rig};
