//! A simulated bench supply speaking both dialects.
//!
//! - [`Device`]: the simulated instrument — settings, the [`Load`] it feeds, fault injection
//!   and counters. Cheap to clone (a shared handle); the rig simulator keeps one to read the
//!   bus voltage ([`Device::output`]) and to plug its motor in ([`Device::set_load`]).
//! - [`SimulatedSupply`] (Unix): the device served on a real pseudo-terminal by a thread; a
//!   driver opens [`SimulatedSupply::port_path`] with `serialport`, exactly as it would a USB
//!   port. Dropping it stops the thread and closes the terminal.
//! - [`InProcessTransport`]: the device behind an in-memory [`crate::Transport`], for tests
//!   and examples that need no terminal.
//!
//! The electrical model ([`solve`]): constant voltage behind a source resistance
//! (`V_out = V_set − I·R`) until the load would draw more than the current limit, then
//! constant current (the output voltage drops until `I = limit`, mode `CC`). The dialects are
//! those the drivers speak ([`crate::scpi`], [`crate::korad`]); the Korad side frames
//! unterminated commands by syntax and quiet gaps, and drops a command that arrives less than
//! [`SimConfig::min_command_gap`] after the previous exchange (as the real instrument does),
//! counting it in [`SimStats::pacing_violations`].

mod engine;
mod model;
#[cfg(unix)]
mod pty;

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

pub use model::{ConstantPowerLoad, Load, Output, ResistiveLoad, Settings, solve};
#[cfg(unix)]
pub use pty::SimulatedSupply;

use crate::transport::Transport;
use engine::Engine;

/// The command set a simulated supply speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Rigol/Siglent-style SCPI, newline-terminated (see [`crate::scpi`]).
    Scpi,
    /// Korad/Tenma KA3005P: unterminated commands and replies, raw status byte (see
    /// [`crate::korad`]).
    Korad,
}

/// Configuration of a simulated supply.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// `*IDN?` answer; `None`: a typical one for the dialect.
    pub identity: Option<String>,
    /// Settings at power-up.
    pub initial: Settings,
    /// Largest voltage set-point accepted, V (larger ones are refused and leave the setting).
    pub rating_voltage_v: f64,
    /// Largest current limit accepted, A.
    pub rating_current_a: f64,
    /// Korad: least time between the end of one exchange (last byte received or reply sent)
    /// and the first byte of the next command. Shorter gaps are counted as pacing violations.
    pub min_command_gap: Duration,
    /// Korad: drop a command that violates [`SimConfig::min_command_gap`] (the instrument's
    /// behaviour); when false it is only counted.
    pub strict_pacing: bool,
    /// Korad: a set command (`VSET1:12.50`) ends at the next non-digit or after this quiet time.
    pub frame_gap: Duration,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            identity: None,
            initial: Settings {
                voltage_v: 0.0,
                current_limit_a: 1.0,
                output_on: false,
                source_resistance_ohm: 0.0,
            },
            rating_voltage_v: 30.0,
            rating_current_a: 5.0,
            min_command_gap: Duration::from_millis(40),
            strict_pacing: true,
            frame_gap: Duration::from_millis(10),
        }
    }
}

/// Faults to inject, counted down as they are used (see [`Device::set_faults`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Faults {
    /// Ignore everything received (neither execute nor answer) while set.
    pub silent: bool,
    /// Execute the next this many queries but send no reply.
    pub drop_replies: u32,
    /// Ignore the next this many commands entirely.
    pub ignore_commands: u32,
    /// Answer the next this many queries with garbage (`?#!%&`).
    pub corrupt_replies: u32,
}

/// Counters of a simulated supply.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimStats {
    /// Commands executed.
    pub commands: u64,
    /// Replies sent.
    pub replies: u64,
    /// Unrecognised commands and discarded bytes runs.
    pub unknown: u64,
    /// Korad commands that arrived too soon after the previous exchange.
    pub pacing_violations: u64,
    /// Commands not executed: ignored on purpose, while silent, or for pacing in strict mode.
    pub ignored: u64,
    /// Replies withheld or garbled on purpose.
    pub faulted_replies: u64,
    /// Shortest gap seen between one exchange and the next command (Korad).
    pub min_command_gap: Option<Duration>,
}

/// Length of the command log kept by a device.
const LOG_LEN: usize = 1024;

pub(crate) struct Inner {
    settings: Settings,
    load: Box<dyn Load>,
    faults: Faults,
    stats: SimStats,
    log: VecDeque<String>,
    scpi_errors: VecDeque<String>,
}

/// A simulated supply (shared handle); see the [module docs](self).
#[derive(Clone)]
pub struct Device {
    dialect: Dialect,
    config: Arc<SimConfig>,
    inner: Arc<Mutex<Inner>>,
}

impl Device {
    /// A device speaking `dialect`, feeding `load`.
    pub fn new(dialect: Dialect, load: impl Load + 'static, config: SimConfig) -> Self {
        Self {
            dialect,
            inner: Arc::new(Mutex::new(Inner {
                settings: config.initial,
                load: Box::new(load),
                faults: Faults::default(),
                stats: SimStats::default(),
                log: VecDeque::new(),
                scpi_errors: VecDeque::new(),
            })),
            config: Arc::new(config),
        }
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The dialect.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The current settings (as set by the driver).
    pub fn settings(&self) -> Settings {
        self.lock().settings
    }

    /// Changes the settings as from the front panel.
    pub fn set_settings(&self, settings: Settings) {
        self.lock().settings = settings;
    }

    /// Sets the source resistance (supply, leads and connectors), Ω.
    pub fn set_source_resistance_ohm(&self, resistance_ohm: f64) {
        self.lock().settings.source_resistance_ohm = resistance_ohm;
    }

    /// Replaces the load.
    pub fn set_load(&self, load: impl Load + 'static) {
        self.lock().load = Box::new(load);
    }

    /// The operating point now: output voltage, current and mode.
    ///
    /// Calls the load while holding the device's lock: a load must not call back into the
    /// device, and a caller must not hold a lock its load takes.
    pub fn output(&self) -> Output {
        let mut inner = self.lock();
        let settings = inner.settings;
        solve(&settings, inner.load.as_mut())
    }

    /// Sets the faults to inject (replacing those pending).
    pub fn set_faults(&self, faults: Faults) {
        self.lock().faults = faults;
    }

    /// The faults still pending.
    pub fn faults(&self) -> Faults {
        self.lock().faults
    }

    /// Counters.
    pub fn stats(&self) -> SimStats {
        self.lock().stats
    }

    /// The last commands executed (up to 1024), oldest first, as received (bytes escaped).
    pub fn command_log(&self) -> Vec<String> {
        self.lock().log.iter().cloned().collect()
    }

    /// An in-memory transport to this device (see [`InProcessTransport`]).
    pub fn connect(&self) -> InProcessTransport {
        InProcessTransport {
            engine: Engine::new(self.clone()),
            pending: VecDeque::new(),
            timeout: Duration::from_millis(10),
        }
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("dialect", &self.dialect)
            .field("settings", &self.settings())
            .finish_non_exhaustive()
    }
}

/// A load that a rig simulator updates with its latest operating point; it behaves as the
/// resistance `V/I` through that point (a linearisation, so constant-current mode is only
/// approximate: implement [`Load`] directly for the exact coupling). Clones share the state.
#[derive(Debug, Clone, Default)]
pub struct SharedLoad {
    conductance_s: Arc<Mutex<f64>>,
}

impl SharedLoad {
    /// A load drawing nothing until the first report.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records that the load drew `current_a` at `bus_voltage_v`.
    pub fn report(&self, bus_voltage_v: f64, current_a: f64) {
        let g = if bus_voltage_v > 0.0 && current_a.is_finite() && current_a > 0.0 {
            current_a / bus_voltage_v
        } else {
            0.0
        };
        *self
            .conductance_s
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = g;
    }

    /// Makes the load a resistance, Ω (non-positive: open circuit).
    pub fn set_resistance_ohm(&self, resistance_ohm: f64) {
        let g = if resistance_ohm > 0.0 {
            1.0 / resistance_ohm
        } else {
            0.0
        };
        *self
            .conductance_s
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = g;
    }
}

impl Load for SharedLoad {
    fn current_a(&mut self, bus_voltage_v: f64) -> f64 {
        *self
            .conductance_s
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            * bus_voltage_v
    }
}

/// An in-memory [`Transport`] to a [`Device`]: what is written is executed at once (in the
/// writer's thread, timestamped when written, so pacing is checked exactly), replies wait to
/// be read. `flush` ends a Korad burst (an unterminated set command takes effect); a read with
/// nothing to return sleeps for the read timeout, as a silent port would.
pub struct InProcessTransport {
    engine: Engine,
    pending: VecDeque<u8>,
    timeout: Duration,
}

impl InProcessTransport {
    /// The device behind this transport.
    pub fn device(&self) -> &Device {
        self.engine.device()
    }
}

impl Read for InProcessTransport {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pending.is_empty() {
            // The host is waiting for an answer: whatever it sent is complete.
            let reply = self.engine.flush(Instant::now());
            self.pending.extend(reply);
        }
        if self.pending.is_empty() {
            // A zero timeout polls: it must not give up the thread's time slice.
            if !self.timeout.is_zero() {
                thread::sleep(self.timeout);
            }
            return Err(io::ErrorKind::TimedOut.into());
        }
        let n = buf.len().min(self.pending.len());
        for (dst, src) in buf.iter_mut().zip(self.pending.drain(..n)) {
            *dst = src;
        }
        Ok(n)
    }
}

impl Write for InProcessTransport {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let reply = self.engine.feed(buf, Instant::now());
        self.pending.extend(reply);
        Ok(buf.len())
    }
    /// Korad: ends the burst, so an unterminated set command written before takes effect now
    /// (on a serial line the quiet gap after it does that).
    fn flush(&mut self) -> io::Result<()> {
        if self.engine.device().dialect == Dialect::Korad {
            let reply = self.engine.flush(Instant::now());
            self.pending.extend(reply);
        }
        Ok(())
    }
}

impl Transport for InProcessTransport {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.timeout = timeout;
        Ok(())
    }
    fn discard_input(&mut self) -> io::Result<()> {
        self.pending.clear();
        Ok(())
    }
}
