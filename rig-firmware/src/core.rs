//! The firmware core: protocol handling, synchronous sampling and the safety state machine.
//!
//! A board's main loop calls [`Firmware::receive`] with the bytes that arrived from the host
//! and [`Firmware::tick`] as often as it can (≥ 1 kHz is comfortable); both hand encoded
//! frames for the host to an output closure. All timing comes from the [`Clock`].
//!
//! Safety is owned here, whatever the host does:
//! - throttle commands are refused unless armed (after a version handshake);
//! - the output slews towards the target at most [`Config::slew_us_per_s`] in both directions
//!   (a bench supply cannot absorb a fast spin-down);
//! - no valid host frame for [`Config::host_timeout_us`] (250 ms) while armed → output to
//!   minimum and a latched [`FaultCause::HostTimeout`];
//! - current, thrust and supply-voltage limits, each a latched fault with its cause, value and
//!   limit (after [`Config::limit_debounce`] consecutive readings beyond the limit);
//! - a fault cuts the output to minimum at once, or ramps it down at
//!   [`Config::fault_ramp_us_per_s`] if that is non-zero; only re-arming clears it;
//! - the board's hardware watchdog is fed from every tick.

use crate::loadcell::LoadCell;
use crate::{LoadCellAdc, PowerMonitor, PowerReading, ThrottleOutput, Watchdog};
use rig_protocol::Clock;
use rig_protocol::frame::{Decoder, DecoderStats, MAX_WIRE_FRAME, encode_frame};
use rig_protocol::message::{
    FaultCause, FaultReport, FaultSet, Identity, Message, NackReason, PROTOCOL_VERSION, RigState,
    Sample, Status,
};

/// Firmware version reported in the identity.
pub const FIRMWARE_VERSION: [u8; 3] = [0, 1, 0];

/// Board configuration: limits and timing. Limits are the board's; the host cannot change them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Serial number reported in the identity.
    pub serial_number: u32,
    /// Board kind reported in the identity (0 sim, 1 Linux SBC, 2 MCU).
    pub board: u8,
    /// Lowest ESC pulse, µs (motor stopped).
    pub throttle_min_us: u16,
    /// Highest ESC pulse, µs.
    pub throttle_max_us: u16,
    /// Slew limit of the output, µs per second, both directions.
    pub slew_us_per_s: f32,
    /// Ramp-down rate after a fault, µs per second; 0 cuts to minimum at once.
    pub fault_ramp_us_per_s: f32,
    /// Silence from the host that latches a fault while armed, µs.
    pub host_timeout_us: u64,
    /// Current limit, A.
    pub max_current_a: f32,
    /// Thrust limit, g.
    pub max_thrust_g: f32,
    /// Under-voltage limit while armed, V.
    pub min_voltage_v: f32,
    /// Over-voltage limit, V.
    pub max_voltage_v: f32,
    /// Consecutive readings beyond a limit that latch its fault (≥ 1).
    pub limit_debounce: u8,
    /// Highest stream rate, Hz.
    pub max_stream_rate_hz: u16,
    /// Interval between power-monitor reads, µs.
    pub power_period_us: u64,
    /// Scale until the first calibration, g per count.
    pub nominal_scale_g_per_count: f32,
    /// Readings averaged per calibration point.
    pub calibration_samples: u16,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            serial_number: 0,
            board: 2,
            throttle_min_us: 1000,
            throttle_max_us: 2000,
            slew_us_per_s: 2000.0,
            fault_ramp_us_per_s: 0.0,
            host_timeout_us: 250_000,
            max_current_a: 30.0,
            max_thrust_g: 2000.0,
            min_voltage_v: 6.0,
            max_voltage_v: 26.0,
            limit_debounce: 3,
            max_stream_rate_hz: 1000,
            power_period_us: 2000,
            nominal_scale_g_per_count: 1.0,
            calibration_samples: 10,
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum PendingKind {
    Tare,
    Calibrate { mass_g: f32 },
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    seq: u16,
    kind: PendingKind,
    wanted: u16,
    count: u16,
    sum: i64,
}

/// Counters the firmware keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FirmwareStats {
    /// Frames sent to the host.
    pub frames_sent: u32,
    /// Samples sent.
    pub samples_sent: u32,
    /// Host commands that repeated the previous sequence number (answered, not re-executed).
    pub duplicate_commands: u32,
    /// Load-cell conversions read.
    pub adc_readings: u32,
}

const LIMIT_CAUSES: [FaultCause; 4] = [
    FaultCause::OverCurrent,
    FaultCause::OverThrust,
    FaultCause::UnderVoltage,
    FaultCause::OverVoltage,
];

/// The firmware core; see the [module docs](self).
pub struct Firmware<A, P, E, C, W> {
    adc: A,
    power: P,
    esc: E,
    clock: C,
    watchdog: W,
    cfg: Config,
    decoder: Decoder,
    tx_seq: u16,
    state: RigState,
    faults: FaultSet,
    handshake_done: bool,
    target_us: u16,
    output_us: f32,
    last_output_written: Option<u16>,
    last_tick_us: u64,
    last_host_frame_us: u64,
    stream_rate_hz: u16,
    next_sample_us: u64,
    stream_anchor_pending: bool,
    load_cell: LoadCell,
    last_raw: Option<i32>,
    thrust_g: f32,
    power_reading: PowerReading,
    next_power_us: u64,
    pending: Option<Pending>,
    last_command: Option<(u16, u8, Option<Message>)>,
    debounce: [u8; 4],
    stats: FirmwareStats,
}

impl<A, P, E, C, W> Firmware<A, P, E, C, W>
where
    A: LoadCellAdc,
    P: PowerMonitor,
    E: ThrottleOutput,
    C: Clock,
    W: Watchdog,
{
    /// A firmware core on initialised peripherals. Writes the minimum pulse to the ESC.
    pub fn new(adc: A, power: P, mut esc: E, clock: C, watchdog: W, cfg: Config) -> Self {
        let now = clock.now_us();
        let written = esc
            .set_throttle_us(cfg.throttle_min_us)
            .ok()
            .map(|()| cfg.throttle_min_us);
        Self {
            adc,
            power,
            esc,
            clock,
            watchdog,
            cfg,
            decoder: Decoder::new(),
            tx_seq: 0,
            state: RigState::Disarmed,
            faults: FaultSet::EMPTY,
            handshake_done: false,
            target_us: cfg.throttle_min_us,
            output_us: f32::from(cfg.throttle_min_us),
            last_output_written: written,
            last_tick_us: now,
            last_host_frame_us: now,
            stream_rate_hz: 0,
            next_sample_us: now,
            stream_anchor_pending: false,
            load_cell: LoadCell::new(cfg.nominal_scale_g_per_count),
            last_raw: None,
            thrust_g: 0.0,
            power_reading: PowerReading::default(),
            next_power_us: now,
            pending: None,
            last_command: None,
            debounce: [0; 4],
            stats: FirmwareStats::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The safety state.
    pub fn state(&self) -> RigState {
        self.state
    }

    /// Latched faults.
    pub fn faults(&self) -> FaultSet {
        self.faults
    }

    /// Pulse width being output, µs.
    pub fn output_us(&self) -> u16 {
        libm::roundf(self.output_us) as u16
    }

    /// Target pulse width, µs.
    pub fn target_us(&self) -> u16 {
        self.target_us
    }

    /// Latest calibrated thrust, g.
    pub fn thrust_g(&self) -> f32 {
        self.thrust_g
    }

    /// The load-cell zero and scale.
    pub fn load_cell(&self) -> &LoadCell {
        &self.load_cell
    }

    /// Counters of frames received from the host.
    pub fn rx_stats(&self) -> DecoderStats {
        self.decoder.stats()
    }

    /// Firmware counters.
    pub fn stats(&self) -> FirmwareStats {
        self.stats
    }

    /// The clock.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// The peripherals, for a board (or simulator) that needs to reach them.
    pub fn peripherals_mut(&mut self) -> (&mut A, &mut P, &mut E, &mut W) {
        (
            &mut self.adc,
            &mut self.power,
            &mut self.esc,
            &mut self.watchdog,
        )
    }

    /// A status snapshot.
    pub fn status(&self) -> Status {
        let rx = self.decoder.stats();
        Status {
            time_us: self.clock.now_us(),
            state: self.state,
            faults: self.faults,
            throttle_us: self.output_us(),
            target_throttle_us: self.target_us,
            stream_rate_hz: self.stream_rate_hz,
            rx_frames_ok: rx.frames_ok,
            rx_frames_dropped: rx.dropped(),
            calibration_points: self.load_cell.points() as u8,
        }
    }

    fn identity(&self) -> Identity {
        Identity {
            protocol_version: PROTOCOL_VERSION,
            firmware_version: FIRMWARE_VERSION,
            serial_number: self.cfg.serial_number,
            board: self.cfg.board,
            throttle_min_us: self.cfg.throttle_min_us,
            throttle_max_us: self.cfg.throttle_max_us,
            max_stream_rate_hz: self.cfg.max_stream_rate_hz,
        }
    }

    fn send(&mut self, msg: &Message, out: &mut impl FnMut(&[u8])) {
        let mut wire = [0u8; MAX_WIRE_FRAME];
        if let Ok(n) = encode_frame(self.tx_seq, msg, &mut wire) {
            self.tx_seq = self.tx_seq.wrapping_add(1);
            self.stats.frames_sent = self.stats.frames_sent.saturating_add(1);
            out(&wire[..n]);
        }
    }

    /// For a board whose reset cause was its watchdog: latches [`FaultCause::Watchdog`] so the
    /// host learns of it; re-arming clears it like any fault.
    pub fn report_watchdog_reset(&mut self, out: &mut impl FnMut(&[u8])) {
        self.latch(FaultCause::Watchdog, 1.0, 0.0, out);
    }

    /// Feeds bytes received from the host; answers go to `out`.
    pub fn receive(&mut self, bytes: &[u8], out: &mut impl FnMut(&[u8])) {
        for &b in bytes {
            if let Some(Ok(frame)) = self.decoder.push(b) {
                // Only commands count as host frames: a looped-back rig frame must not
                // keep the rig alive.
                if frame.message.is_command() {
                    self.last_host_frame_us = self.clock.now_us();
                    self.handle(frame.seq, frame.message, out);
                }
            }
        }
    }

    fn handle(&mut self, seq: u16, msg: Message, out: &mut impl FnMut(&[u8])) {
        if let Message::Hello { .. } = msg {
            // A new session: sequence numbers start afresh.
            self.last_command = None;
        }
        if let Some((last_seq, last_code, answer)) = self.last_command {
            if last_seq == seq && last_code == msg.code() {
                self.stats.duplicate_commands = self.stats.duplicate_commands.saturating_add(1);
                if let Some(a) = answer {
                    self.send(&a, out);
                }
                return;
            }
        }
        let answer = self.execute(seq, msg);
        // Queries are idempotent and interleave with retries (keep-alives): only commands
        // with effects are remembered for duplicate detection.
        if !matches!(
            msg,
            Message::Hello { .. } | Message::Ping | Message::GetStatus | Message::Identify
        ) {
            self.last_command = Some((seq, msg.code(), answer));
        }
        if let Some(a) = answer {
            self.send(&a, out);
        }
    }

    fn execute(&mut self, seq: u16, msg: Message) -> Option<Message> {
        let nack = |reason| {
            Some(Message::Nack {
                request_seq: seq,
                reason,
            })
        };
        let ack = Some(Message::Ack { request_seq: seq });
        match msg {
            Message::Hello { protocol_version } => {
                let accepted = protocol_version == PROTOCOL_VERSION;
                self.handshake_done = accepted;
                Some(Message::HelloAck {
                    request_seq: seq,
                    protocol_version: PROTOCOL_VERSION,
                    accepted,
                })
            }
            Message::Identify => Some(Message::Identity {
                request_seq: seq,
                identity: self.identity(),
            }),
            Message::Ping => ack,
            Message::GetStatus => Some(Message::Status {
                request_seq: seq,
                status: self.status(),
            }),
            _ if !self.handshake_done => nack(NackReason::HandshakeRequired),
            Message::Arm => {
                if self.pending.is_some() {
                    return nack(NackReason::Busy);
                }
                self.faults = FaultSet::EMPTY;
                self.debounce = [0; 4];
                self.state = RigState::Armed;
                self.target_us = self.cfg.throttle_min_us;
                ack
            }
            Message::Disarm => {
                if self.state == RigState::Armed {
                    self.state = RigState::Disarmed;
                }
                self.target_us = self.cfg.throttle_min_us;
                ack
            }
            Message::SetThrottle { throttle_us } => match self.state {
                RigState::Faulted => nack(NackReason::Faulted),
                RigState::Disarmed => nack(NackReason::NotArmed),
                RigState::Armed => {
                    if !(self.cfg.throttle_min_us..=self.cfg.throttle_max_us).contains(&throttle_us)
                    {
                        return nack(NackReason::BadArgument);
                    }
                    self.target_us = throttle_us;
                    ack
                }
            },
            Message::StartStream { rate_hz } => {
                if rate_hz == 0 || rate_hz > self.cfg.max_stream_rate_hz {
                    return nack(NackReason::BadArgument);
                }
                self.stream_rate_hz = rate_hz;
                // The schedule starts at the next tick, so samples are evenly spaced.
                self.stream_anchor_pending = true;
                ack
            }
            Message::StopStream => {
                self.stream_rate_hz = 0;
                ack
            }
            Message::Tare { samples } => self.begin_pending(seq, PendingKind::Tare, samples),
            Message::Calibrate { known_mass_g } => {
                if !(known_mass_g.is_finite() && known_mass_g > 0.0) {
                    return nack(NackReason::BadArgument);
                }
                if !self.load_cell.is_tared() {
                    return nack(NackReason::NotTared);
                }
                let n = self.cfg.calibration_samples.max(1);
                self.begin_pending(
                    seq,
                    PendingKind::Calibrate {
                        mass_g: known_mass_g,
                    },
                    n,
                )
            }
            // Responses are never commands; `receive` filters them out.
            _ => None,
        }
    }

    fn begin_pending(&mut self, seq: u16, kind: PendingKind, samples: u16) -> Option<Message> {
        let nack = |reason| {
            Some(Message::Nack {
                request_seq: seq,
                reason,
            })
        };
        if self.state != RigState::Disarmed {
            return nack(if self.state == RigState::Armed {
                NackReason::Armed
            } else {
                NackReason::Faulted
            });
        }
        if self.pending.is_some() {
            return nack(NackReason::Busy);
        }
        if samples == 0 || samples > 1000 {
            return nack(NackReason::BadArgument);
        }
        self.pending = Some(Pending {
            seq,
            kind,
            wanted: samples,
            count: 0,
            sum: 0,
        });
        None // answered when the readings are in
    }

    fn latch(&mut self, cause: FaultCause, value: f32, limit: f32, out: &mut impl FnMut(&[u8])) {
        let first = !self.faults.contains(cause);
        self.faults.insert(cause);
        self.state = RigState::Faulted;
        self.target_us = self.cfg.throttle_min_us;
        if self.cfg.fault_ramp_us_per_s <= 0.0 {
            self.output_us = f32::from(self.cfg.throttle_min_us);
            self.write_output();
        }
        if first {
            let report = FaultReport {
                time_us: self.clock.now_us(),
                cause,
                value,
                limit,
            };
            self.send(&Message::Fault(report), out);
        }
    }

    fn check_limit(
        &mut self,
        idx: usize,
        beyond: bool,
        value: f32,
        limit: f32,
        out: &mut impl FnMut(&[u8]),
    ) {
        if beyond {
            self.debounce[idx] = self.debounce[idx].saturating_add(1);
            if self.debounce[idx] >= self.cfg.limit_debounce.max(1) {
                self.latch(LIMIT_CAUSES[idx], value, limit, out);
            }
        } else {
            self.debounce[idx] = 0;
        }
    }

    fn write_output(&mut self) {
        let us = self.output_us();
        if self.last_output_written != Some(us) {
            // An ESC write error leaves `last_output_written` stale so the next tick retries.
            if self.esc.set_throttle_us(us).is_ok() {
                self.last_output_written = Some(us);
            }
        }
    }

    /// One pass of the main loop: read sensors, enforce safety, slew the output, stream.
    pub fn tick(&mut self, out: &mut impl FnMut(&[u8])) {
        let now = self.clock.now_us();
        let dt_s = now.saturating_sub(self.last_tick_us) as f32 * 1e-6;
        self.last_tick_us = now;
        self.watchdog.feed();

        // Host silence.
        if self.state == RigState::Armed {
            let silent_us = now.saturating_sub(self.last_host_frame_us);
            if silent_us >= self.cfg.host_timeout_us {
                self.latch(
                    FaultCause::HostTimeout,
                    silent_us as f32 * 1e-3,
                    self.cfg.host_timeout_us as f32 * 1e-3,
                    out,
                );
            }
        }

        // Load cell.
        match self.adc.try_read_raw() {
            Ok(Some(raw)) => {
                self.stats.adc_readings = self.stats.adc_readings.saturating_add(1);
                self.last_raw = Some(raw);
                self.thrust_g = self.load_cell.grams(raw);
                self.on_raw(raw, out);
                let t = self.thrust_g;
                let armed_or_faulted = self.state != RigState::Disarmed;
                self.check_limit(
                    1,
                    armed_or_faulted && t > self.cfg.max_thrust_g,
                    t,
                    self.cfg.max_thrust_g,
                    out,
                );
            }
            Ok(None) => {}
            Err(_) => self.latch(FaultCause::SensorFailure, 0.0, 0.0, out),
        }

        // Current and voltage.
        if now >= self.next_power_us {
            self.next_power_us = now + self.cfg.power_period_us.max(1);
            self.read_power(out);
        }

        // Output slew.
        let target = f32::from(self.target_us);
        let rate = if self.state == RigState::Faulted && self.cfg.fault_ramp_us_per_s > 0.0 {
            self.cfg.fault_ramp_us_per_s
        } else {
            self.cfg.slew_us_per_s
        };
        let step = rate * dt_s;
        let delta = (target - self.output_us).clamp(-step, step);
        self.output_us += delta;
        if self.state != RigState::Armed {
            // Never above the target outside Armed.
            self.output_us = self.output_us.min(f32::from(self.cfg.throttle_max_us));
        }
        self.write_output();

        // Stream.
        if core::mem::take(&mut self.stream_anchor_pending) {
            self.next_sample_us = now;
        }
        if self.stream_rate_hz > 0 && now >= self.next_sample_us {
            let period = 1_000_000 / u64::from(self.stream_rate_hz);
            self.next_sample_us += period;
            if self.next_sample_us <= now {
                self.next_sample_us = now + period;
            }
            // Current and voltage read at the sampling instant, with the latest thrust.
            self.read_power(out);
            let sample = Sample {
                time_us: now,
                thrust_g: self.thrust_g,
                current_a: self.power_reading.current_a,
                voltage_v: self.power_reading.voltage_v,
                throttle_us: self.output_us(),
            };
            self.send(&Message::Sample(sample), out);
            self.stats.samples_sent = self.stats.samples_sent.saturating_add(1);
        }
    }

    fn read_power(&mut self, out: &mut impl FnMut(&[u8])) {
        match self.power.read() {
            Ok(r) => {
                self.power_reading = r;
                let c = &self.cfg;
                let (imax, vmin, vmax) = (c.max_current_a, c.min_voltage_v, c.max_voltage_v);
                self.check_limit(0, r.current_a > imax, r.current_a, imax, out);
                self.check_limit(
                    2,
                    self.state == RigState::Armed && r.voltage_v < vmin,
                    r.voltage_v,
                    vmin,
                    out,
                );
                self.check_limit(3, r.voltage_v > vmax, r.voltage_v, vmax, out);
            }
            Err(_) => self.latch(FaultCause::SensorFailure, 0.0, 0.0, out),
        }
    }

    fn on_raw(&mut self, raw: i32, out: &mut impl FnMut(&[u8])) {
        let Some(mut p) = self.pending else { return };
        p.sum += i64::from(raw);
        p.count += 1;
        if p.count < p.wanted {
            self.pending = Some(p);
            return;
        }
        self.pending = None;
        let mean = p.sum as f64 / f64::from(p.count);
        let answer = match p.kind {
            PendingKind::Tare => {
                let offset = libm::round(mean) as i32;
                self.load_cell.tare(offset);
                Message::TareDone {
                    request_seq: p.seq,
                    offset_counts: offset,
                }
            }
            PendingKind::Calibrate { mass_g } => {
                match self.load_cell.add_point(mean as f32, mass_g) {
                    Ok(scale) => Message::Calibrated {
                        request_seq: p.seq,
                        scale_g_per_count: scale,
                        points: self.load_cell.points() as u8,
                    },
                    Err(_) => Message::Nack {
                        request_seq: p.seq,
                        reason: NackReason::BadArgument,
                    },
                }
            }
        };
        // The thrust shown from now on uses the new zero / scale.
        if let Some(raw) = self.last_raw {
            self.thrust_g = self.load_cell.grams(raw);
        }
        if let Some((seq, _, slot)) = &mut self.last_command {
            if *seq == p.seq {
                *slot = Some(answer);
            }
        }
        self.send(&answer, out);
    }
}
