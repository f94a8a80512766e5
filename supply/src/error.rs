//! What can go wrong talking to a bench supply.

use std::fmt;
use std::io;
use std::time::Duration;

use thiserror::Error;

/// Bytes shown in an error message: printable ASCII as is, anything else escaped (`\x06`,
/// `\n`), cut after 64 bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct Bytes(pub Vec<u8>);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const SHOWN: usize = 64;
        write!(f, "\"")?;
        for b in self.0.iter().take(SHOWN) {
            write!(f, "{}", b.escape_ascii())?;
        }
        if self.0.len() > SHOWN {
            write!(f, "…(+{} bytes)", self.0.len() - SHOWN)?;
        }
        write!(f, "\"")
    }
}

impl fmt::Debug for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl From<&[u8]> for Bytes {
    fn from(b: &[u8]) -> Self {
        Self(b.to_vec())
    }
}

/// Why a reply could not be understood (see [`SupplyError::BadReply`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum ReplyError {
    /// Nothing but whitespace.
    #[error("empty reply")]
    Empty,
    /// Not the number the command asks for.
    #[error("not a number")]
    NotANumber,
    /// A number, but not a finite one, or negative where that cannot be.
    #[error("number out of range")]
    OutOfRange,
    /// Fewer or more comma-separated fields than the command returns.
    #[error("wrong number of fields")]
    FieldCount,
    /// A word the command does not answer with (e.g. a mode other than `CV`/`CC`/`UR`).
    #[error("unknown keyword")]
    UnknownKeyword,
    /// Longer than any reply to this command.
    #[error("reply too long")]
    TooLong,
    /// A status reply of the wrong length.
    #[error("wrong length")]
    WrongLength,
}

/// What can go wrong talking to a bench supply. Every variant names the command it concerns.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SupplyError {
    /// The serial port could not be opened.
    #[error("cannot open serial port {path}")]
    Open {
        /// The port path.
        path: String,
        /// The serial library's error.
        #[source]
        source: serialport::Error,
    },
    /// Writing or reading the transport failed (not a timeout: the port is gone or broken).
    #[error("transport error on {command:?}")]
    Io {
        /// The command being sent or answered.
        command: String,
        /// The I/O error.
        #[source]
        source: io::Error,
    },
    /// No complete reply within the timeout, on every attempt.
    #[error(
        "no reply to {command:?} within {timeout:?} after {attempts} attempt(s) (last partial reply: {partial})"
    )]
    Timeout {
        /// The command.
        command: String,
        /// The per-attempt reply timeout.
        timeout: Duration,
        /// Attempts made.
        attempts: u32,
        /// What had arrived of the last attempt's reply (often nothing).
        partial: Bytes,
    },
    /// A reply arrived but could not be understood, on every attempt.
    #[error("bad reply to {command:?}: {reply} ({reason}) after {attempts} attempt(s)")]
    BadReply {
        /// The command.
        command: String,
        /// The last reply received, raw.
        reply: Bytes,
        /// Why it was refused.
        reason: ReplyError,
        /// Attempts made.
        attempts: u32,
    },
    /// A setting did not take: reading it back gave another value, on every attempt.
    #[error("{command:?} did not take: read back {readback} after {attempts} attempt(s)")]
    NotApplied {
        /// The setting command.
        command: String,
        /// What the supply reported afterwards.
        readback: String,
        /// Attempts made.
        attempts: u32,
    },
    /// A set-point outside what the driver was configured to allow (never sent).
    #[error("{quantity} {value} outside {min}..={max}")]
    OutOfRange {
        /// What was being set, with its unit (`"voltage_v"`, `"current_limit_a"`).
        quantity: &'static str,
        /// The value asked for.
        value: f64,
        /// The smallest value allowed.
        min: f64,
        /// The largest value allowed.
        max: f64,
    },
}

impl SupplyError {
    /// The command the error concerns, if any.
    pub fn command(&self) -> Option<&str> {
        match self {
            Self::Io { command, .. }
            | Self::Timeout { command, .. }
            | Self::BadReply { command, .. }
            | Self::NotApplied { command, .. } => Some(command),
            Self::Open { .. } | Self::OutOfRange { .. } => None,
        }
    }
}
