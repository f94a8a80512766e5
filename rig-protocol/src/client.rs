//! The host side of the protocol over any byte transport.
//!
//! [`Client`] implements [`Rig`] on top of a [`Transport`] (a serial port, a pseudo-terminal,
//! an in-process link to a simulator) and a [`Clock`] it waits with. It matches answers to
//! commands by sequence number, retries a command whose answer was lost (with the same
//! sequence number, so the rig carries it out once), queues streamed samples and fault reports
//! that arrive meanwhile, and sends a keep-alive so the rig's host timeout does not trip while
//! the host is polling. It never allocates.

use crate::frame::{Decoder, DecoderStats, MAX_WIRE_FRAME, encode_frame};
use crate::message::{
    FaultReport, Identity, Message, NackReason, PROTOCOL_VERSION, Sample, Status,
};
use crate::rig::{Calibration, Clock, Rig};
use heapless::Deque;
use thiserror::Error;

/// Capacity of the queue of received samples.
pub const SAMPLE_QUEUE: usize = 512;
/// Capacity of the queue of received fault reports.
pub const FAULT_QUEUE: usize = 16;

/// A bidirectional byte stream.
pub trait Transport {
    /// Transport error.
    type Error: core::fmt::Debug;
    /// Writes all of `bytes`.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
    /// Reads what has arrived into `buf`, waiting at most briefly; `Ok(0)` when nothing did.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error>;
}

impl<T: Transport + ?Sized> Transport for &mut T {
    type Error = T::Error;
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        (**self).write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        (**self).read(buf)
    }
}

/// Timing of a [`Client`], in the client clock's microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// How long to wait for an answer before resending.
    pub response_timeout_us: u64,
    /// Resends after the first attempt.
    pub retries: u8,
    /// Send a `Ping` when nothing was sent for this long (keep below the rig's 250 ms).
    pub keepalive_us: u64,
}

impl Default for ClientConfig {
    fn default() -> Self {
        Self {
            response_timeout_us: 400_000,
            retries: 3,
            keepalive_us: 80_000,
        }
    }
}

/// Counters of a [`Client`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ClientStats {
    /// Commands resent after a timeout.
    pub retries: u32,
    /// Commands that got no answer at all.
    pub timeouts: u32,
    /// Samples dropped because the queue was full.
    pub samples_overflowed: u32,
    /// Rig frames missing according to the rig's sequence numbers.
    pub rx_seq_gaps: u32,
    /// Samples accepted.
    pub samples_received: u32,
}

/// What can go wrong in a [`Client`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ClientError<E: core::fmt::Debug> {
    /// The transport failed.
    #[error("transport error: {0:?}")]
    Transport(E),
    /// No answer after all attempts.
    #[error("no answer to {command} after {attempts} attempts")]
    Timeout {
        /// The command.
        command: &'static str,
        /// Attempts made.
        attempts: u8,
    },
    /// The rig refused the command.
    #[error("rig refused {command}: {reason:?}")]
    Nack {
        /// The command.
        command: &'static str,
        /// The rig's reason.
        reason: NackReason,
    },
    /// Host and rig speak different protocol versions.
    #[error("protocol version mismatch: host {host}, rig {rig}")]
    VersionMismatch {
        /// Host version.
        host: u16,
        /// Rig version.
        rig: u16,
    },
    /// The rig answered with a message that does not fit the command.
    #[error("unexpected answer to {command}")]
    UnexpectedResponse {
        /// The command.
        command: &'static str,
    },
}

fn command_name(m: &Message) -> &'static str {
    match m {
        Message::Hello { .. } => "hello",
        Message::Identify => "identify",
        Message::Arm => "arm",
        Message::Disarm => "disarm",
        Message::Tare { .. } => "tare",
        Message::Calibrate { .. } => "calibrate",
        Message::SetThrottle { .. } => "set-throttle",
        Message::StartStream { .. } => "start-stream",
        Message::StopStream => "stop-stream",
        Message::GetStatus => "get-status",
        Message::Ping => "ping",
        _ => "response",
    }
}

/// The host side of the protocol; see the [module docs](self).
pub struct Client<T, C> {
    transport: T,
    clock: C,
    config: ClientConfig,
    decoder: Decoder,
    next_seq: u16,
    last_tx_us: u64,
    last_rx_seq: Option<u16>,
    samples: Deque<Sample, SAMPLE_QUEUE>,
    faults: Deque<FaultReport, FAULT_QUEUE>,
    stats: ClientStats,
    rig_version: Option<u16>,
}

impl<T: Transport, C: Clock> Client<T, C> {
    /// A client that has not shaken hands yet (see [`Client::handshake`]).
    pub fn new(transport: T, clock: C, config: ClientConfig) -> Self {
        let now = clock.now_us();
        Self {
            transport,
            clock,
            config,
            decoder: Decoder::new(),
            next_seq: 1,
            last_tx_us: now,
            last_rx_seq: None,
            samples: Deque::new(),
            faults: Deque::new(),
            stats: ClientStats::default(),
            rig_version: None,
        }
    }

    /// A client that has completed the version handshake.
    pub fn connect(
        transport: T,
        clock: C,
        config: ClientConfig,
    ) -> Result<Self, ClientError<T::Error>> {
        let mut c = Self::new(transport, clock, config);
        c.handshake()?;
        Ok(c)
    }

    /// Exchanges protocol versions; returns the rig's.
    pub fn handshake(&mut self) -> Result<u16, ClientError<T::Error>> {
        // A lone delimiter first flushes anything half-received on the rig side.
        self.transport
            .write_all(&[crate::frame::DELIMITER])
            .map_err(ClientError::Transport)?;
        let msg = Message::Hello {
            protocol_version: PROTOCOL_VERSION,
        };
        match self.request(msg)? {
            Message::HelloAck {
                protocol_version,
                accepted,
                ..
            } => {
                if !accepted || protocol_version != PROTOCOL_VERSION {
                    return Err(ClientError::VersionMismatch {
                        host: PROTOCOL_VERSION,
                        rig: protocol_version,
                    });
                }
                self.rig_version = Some(protocol_version);
                Ok(protocol_version)
            }
            _ => Err(ClientError::UnexpectedResponse { command: "hello" }),
        }
    }

    /// The rig's protocol version, once the handshake is done.
    pub fn rig_version(&self) -> Option<u16> {
        self.rig_version
    }

    /// Counters of the frame decoder (frames received, dropped and why).
    pub fn decoder_stats(&self) -> DecoderStats {
        self.decoder.stats()
    }

    /// Client counters.
    pub fn stats(&self) -> ClientStats {
        self.stats
    }

    /// The clock the client waits with.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// The transport.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Samples waiting in the queue.
    pub fn queued_samples(&self) -> usize {
        self.samples.len()
    }

    /// Reads and processes what has arrived, and sends a keep-alive if one is due.
    pub fn poll(&mut self) -> Result<(), ClientError<T::Error>> {
        self.keepalive()?;
        self.pump(None).map(|_| ())
    }

    /// Reads and processes what has arrived without sending anything (no keep-alive).
    pub fn drain(&mut self) -> Result<(), ClientError<T::Error>> {
        self.pump(None).map(|_| ())
    }

    /// Takes the next queued fault report without touching the transport.
    pub fn take_fault_queued(&mut self) -> Option<FaultReport> {
        self.faults.pop_front()
    }

    /// Takes the next queued sample without touching the transport.
    pub fn pop_sample(&mut self) -> Option<Sample> {
        self.samples.pop_front()
    }

    /// Sends a `Ping` if nothing was sent for `keepalive_us` (does not wait for the answer).
    pub fn keepalive(&mut self) -> Result<(), ClientError<T::Error>> {
        if self.clock.now_us().saturating_sub(self.last_tx_us) >= self.config.keepalive_us {
            let seq = self.alloc_seq();
            self.send(seq, &Message::Ping)?;
        }
        Ok(())
    }

    fn alloc_seq(&mut self) -> u16 {
        let s = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        s
    }

    fn send(&mut self, seq: u16, msg: &Message) -> Result<(), ClientError<T::Error>> {
        let mut wire = [0u8; MAX_WIRE_FRAME];
        // The buffer is MAX_WIRE_FRAME long, so encoding cannot fail.
        let n = encode_frame(seq, msg, &mut wire).unwrap_or(0);
        self.transport
            .write_all(&wire[..n])
            .map_err(ClientError::Transport)?;
        self.last_tx_us = self.clock.now_us();
        Ok(())
    }

    /// Reads once from the transport and processes the frames; returns the response to
    /// `awaiting` if it arrived.
    fn pump(&mut self, awaiting: Option<u16>) -> Result<Option<Message>, ClientError<T::Error>> {
        let mut buf = [0u8; 256];
        let n = self
            .transport
            .read(&mut buf)
            .map_err(ClientError::Transport)?;
        let mut found = None;
        for &b in &buf[..n.min(buf.len())] {
            let Some(Ok(frame)) = self.decoder.push(b) else {
                continue;
            };
            if let Some(last) = self.last_rx_seq {
                let gap = frame.seq.wrapping_sub(last.wrapping_add(1));
                if gap < u16::MAX / 2 {
                    self.stats.rx_seq_gaps = self.stats.rx_seq_gaps.saturating_add(u32::from(gap));
                }
            }
            self.last_rx_seq = Some(frame.seq);
            match frame.message {
                Message::Sample(s) => {
                    if self.samples.is_full() {
                        self.samples.pop_front();
                        self.stats.samples_overflowed =
                            self.stats.samples_overflowed.saturating_add(1);
                    }
                    let _ = self.samples.push_back(s);
                    self.stats.samples_received = self.stats.samples_received.saturating_add(1);
                }
                Message::Fault(f) => {
                    if self.faults.is_full() {
                        self.faults.pop_front();
                    }
                    let _ = self.faults.push_back(f);
                }
                m => {
                    if awaiting.is_some() && m.request_seq() == awaiting {
                        found = Some(m);
                    }
                }
            }
        }
        Ok(found)
    }

    /// Sends `msg` and waits for its answer, resending on timeout with the same sequence
    /// number (the rig answers a repeat without executing it again), and sending keep-alives
    /// while it waits. A `Nack` becomes [`ClientError::Nack`].
    pub fn request(&mut self, msg: Message) -> Result<Message, ClientError<T::Error>> {
        let command = command_name(&msg);
        let seq = self.alloc_seq();
        let attempts = self.config.retries.saturating_add(1);
        for attempt in 0..attempts {
            if attempt > 0 {
                self.stats.retries = self.stats.retries.saturating_add(1);
            }
            self.send(seq, &msg)?;
            let deadline = self
                .clock
                .now_us()
                .saturating_add(self.config.response_timeout_us);
            while self.clock.now_us() < deadline {
                if let Some(answer) = self.pump(Some(seq))? {
                    return match answer {
                        Message::Nack { reason, .. } => Err(ClientError::Nack { command, reason }),
                        m => Ok(m),
                    };
                }
            }
        }
        self.stats.timeouts = self.stats.timeouts.saturating_add(1);
        Err(ClientError::Timeout { command, attempts })
    }

    fn expect_ack(&mut self, msg: Message) -> Result<(), ClientError<T::Error>> {
        let command = command_name(&msg);
        match self.request(msg)? {
            Message::Ack { .. } => Ok(()),
            _ => Err(ClientError::UnexpectedResponse { command }),
        }
    }
}

impl<T: Transport, C: Clock> Rig for Client<T, C> {
    type Error = ClientError<T::Error>;

    fn identify(&mut self) -> Result<Identity, Self::Error> {
        match self.request(Message::Identify)? {
            Message::Identity { identity, .. } => Ok(identity),
            _ => Err(ClientError::UnexpectedResponse {
                command: "identify",
            }),
        }
    }

    fn arm(&mut self) -> Result<(), Self::Error> {
        self.expect_ack(Message::Arm)
    }

    fn disarm(&mut self) -> Result<(), Self::Error> {
        self.expect_ack(Message::Disarm)
    }

    fn tare(&mut self, samples: u16) -> Result<i32, Self::Error> {
        match self.request(Message::Tare { samples })? {
            Message::TareDone { offset_counts, .. } => Ok(offset_counts),
            _ => Err(ClientError::UnexpectedResponse { command: "tare" }),
        }
    }

    fn calibrate(&mut self, known_mass_g: f32) -> Result<Calibration, Self::Error> {
        match self.request(Message::Calibrate { known_mass_g })? {
            Message::Calibrated {
                scale_g_per_count,
                points,
                ..
            } => Ok(Calibration {
                scale_g_per_count,
                points,
            }),
            _ => Err(ClientError::UnexpectedResponse {
                command: "calibrate",
            }),
        }
    }

    fn set_throttle(&mut self, throttle_us: u16) -> Result<(), Self::Error> {
        self.expect_ack(Message::SetThrottle { throttle_us })
    }

    fn start_stream(&mut self, rate_hz: u16) -> Result<(), Self::Error> {
        self.expect_ack(Message::StartStream { rate_hz })
    }

    fn stop_stream(&mut self) -> Result<(), Self::Error> {
        self.expect_ack(Message::StopStream)
    }

    fn next_sample(&mut self) -> Result<Option<Sample>, Self::Error> {
        if self.samples.is_empty() {
            self.poll()?;
        } else {
            self.keepalive()?;
        }
        Ok(self.samples.pop_front())
    }

    fn status(&mut self) -> Result<Status, Self::Error> {
        match self.request(Message::GetStatus)? {
            Message::Status { status, .. } => Ok(status),
            _ => Err(ClientError::UnexpectedResponse {
                command: "get-status",
            }),
        }
    }

    fn take_fault(&mut self) -> Result<Option<FaultReport>, Self::Error> {
        if self.faults.is_empty() {
            self.poll()?;
        }
        Ok(self.faults.pop_front())
    }
}
