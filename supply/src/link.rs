//! Command/reply exchange shared by the drivers: pacing, reply framing, deadlines, retries.

use std::io::{self, ErrorKind};
use std::thread;
use std::time::{Duration, Instant};

use crate::error::{Bytes, ReplyError, SupplyError};
use crate::transport::Transport;

/// Timing of a driver: how long it waits, how often it tries, how it paces commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// How long to wait for a complete reply before trying again.
    pub reply_timeout: Duration,
    /// Further attempts after the first, for a query that timed out or was garbled (and for a
    /// setting whose read-back disagreed).
    pub retries: u32,
    /// Least time between the end of one exchange (last byte written or read) and the next
    /// command. Korad/Tenma supplies drop commands that follow each other too closely.
    pub pacing: Duration,
    /// For unterminated replies: the reply is complete once nothing more arrived for this long
    /// (or once it has its expected length).
    pub quiet_gap: Duration,
}

/// How a reply ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ReplyEnd {
    /// A line ending in `\n` (a `\r` before it is dropped).
    Line,
    /// This many bytes, or fewer followed by a quiet gap.
    Length(usize),
    /// A quiet gap after at least one byte.
    Quiet,
}

/// Longest reply accepted.
pub(crate) const MAX_REPLY: usize = 256;
/// Longest wait of any kind: longer timings are taken as this (no `Instant` overflow).
const LONGEST: Duration = Duration::from_secs(24 * 3600);

/// Checks a set-point against `0..=max` before anything is sent.
pub(crate) fn check_range(quantity: &'static str, value: f64, max: f64) -> Result<(), SupplyError> {
    if value.is_finite() && (0.0..=max).contains(&value) {
        Ok(())
    } else {
        Err(SupplyError::OutOfRange {
            quantity,
            value,
            min: 0.0,
            max,
        })
    }
}

enum Failure {
    Timeout(Vec<u8>),
    Bad(Vec<u8>, ReplyError),
}

/// A transport plus the pacing state.
pub(crate) struct Link<T> {
    pub(crate) transport: T,
    pub(crate) timing: Timing,
    last_activity: Option<Instant>,
}

impl<T: Transport> Link<T> {
    pub(crate) fn new(transport: T, timing: Timing) -> Self {
        Self {
            transport,
            timing,
            last_activity: None,
        }
    }

    fn io_error(command: &str, source: io::Error) -> SupplyError {
        SupplyError::Io {
            command: command.to_owned(),
            source,
        }
    }

    /// Waits out the pacing interval since the last exchange.
    fn pace(&self) {
        if let Some(last) = self.last_activity {
            let ready = last + self.timing.pacing.min(LONGEST);
            let now = Instant::now();
            if ready > now {
                thread::sleep(ready - now);
            }
        }
    }

    /// Sends one command (no reply expected): pacing, stale input discarded, `command` and
    /// `terminator` written in one write.
    pub(crate) fn send(&mut self, command: &str, terminator: &[u8]) -> Result<(), SupplyError> {
        self.pace();
        self.transport
            .discard_input()
            .map_err(|e| Self::io_error(command, e))?;
        let mut wire = Vec::with_capacity(command.len() + terminator.len());
        wire.extend_from_slice(command.as_bytes());
        wire.extend_from_slice(terminator);
        self.transport
            .write_all(&wire)
            .and_then(|()| self.transport.flush())
            .map_err(|e| Self::io_error(command, e))?;
        self.last_activity = Some(Instant::now());
        Ok(())
    }

    /// Reads one reply, within the reply timeout.
    fn read_reply(
        &mut self,
        command: &str,
        end: ReplyEnd,
    ) -> Result<Vec<u8>, Result<Failure, SupplyError>> {
        let start = Instant::now();
        let deadline = start + self.timing.reply_timeout.min(LONGEST);
        let gap = self
            .timing
            .quiet_gap
            .clamp(Duration::from_millis(1), LONGEST);
        let mut buf = Vec::new();
        let mut chunk = [0u8; 64];
        let mut last_byte: Option<Instant> = None;
        loop {
            let now = Instant::now();
            match end {
                ReplyEnd::Line => {
                    if let Some(pos) = buf.iter().position(|&b| b == b'\n') {
                        buf.truncate(pos);
                        if buf.last() == Some(&b'\r') {
                            buf.pop();
                        }
                        return Ok(buf);
                    }
                }
                ReplyEnd::Length(n) if buf.len() >= n => return Ok(buf),
                ReplyEnd::Length(_) | ReplyEnd::Quiet => {
                    if let Some(t) = last_byte {
                        if now.duration_since(t) >= gap {
                            return Ok(buf);
                        }
                    }
                }
            }
            if buf.len() > MAX_REPLY {
                return Err(Ok(Failure::Bad(buf, ReplyError::TooLong)));
            }
            if now >= deadline {
                return Err(Ok(Failure::Timeout(buf)));
            }
            let mut wait = deadline - now;
            if let (Some(t), ReplyEnd::Length(_) | ReplyEnd::Quiet) = (last_byte, end) {
                wait = wait.min((t + gap).saturating_duration_since(now));
            }
            let wait = wait.max(Duration::from_millis(1));
            self.transport
                .set_read_timeout(wait)
                .map_err(|e| Err(Self::io_error(command, e)))?;
            let want = match end {
                ReplyEnd::Length(n) => n.saturating_sub(buf.len()).clamp(1, chunk.len()),
                _ => chunk.len(),
            };
            match self.transport.read(&mut chunk[..want]) {
                Ok(0) => thread::sleep(wait.min(Duration::from_millis(1))),
                Ok(n) => {
                    buf.extend_from_slice(&chunk[..n]);
                    let t = Instant::now();
                    last_byte = Some(t);
                    self.last_activity = Some(t);
                }
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::Interrupted) => {}
                // A non-blocking transport: do not spin.
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    thread::sleep(wait.min(Duration::from_millis(1)));
                }
                Err(e) => return Err(Err(Self::io_error(command, e))),
            }
        }
    }

    /// Sends `command` and parses its reply, retrying on a timeout or a reply `parse` refuses.
    pub(crate) fn query<R>(
        &mut self,
        command: &str,
        terminator: &[u8],
        end: ReplyEnd,
        parse: impl Fn(&[u8]) -> Result<R, ReplyError>,
    ) -> Result<R, SupplyError> {
        let attempts = self.timing.retries.saturating_add(1);
        let mut last = Failure::Timeout(Vec::new());
        for _ in 0..attempts {
            self.send(command, terminator)?;
            match self.read_reply(command, end) {
                Ok(reply) => match parse(&reply) {
                    Ok(r) => return Ok(r),
                    Err(reason) => last = Failure::Bad(reply, reason),
                },
                Err(Ok(failure)) => last = failure,
                Err(Err(fatal)) => return Err(fatal),
            }
        }
        Err(match last {
            Failure::Timeout(partial) => SupplyError::Timeout {
                command: command.to_owned(),
                timeout: self.timing.reply_timeout,
                attempts,
                partial: Bytes(partial),
            },
            Failure::Bad(reply, reason) => SupplyError::BadReply {
                command: command.to_owned(),
                reply: Bytes(reply),
                reason,
                attempts,
            },
        })
    }
}
