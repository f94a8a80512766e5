//! The bench supply as the sweep sees it: set it, switch it, and know its regulation mode at
//! every step without stalling the rig link.
//!
//! A serial supply answers in tens of milliseconds (a Korad wants 50–80 ms between commands),
//! longer than the rig's 250 ms watchdog allows the host to look away at a fast simulated
//! rig. [`SupplyMonitor`] therefore owns the driver on its own thread: it carries out settings
//! on request and otherwise polls the regulation mode (and now and then the output), counting
//! polls and constant-current readings so that a sweep can ask "was the supply ever
//! current-limiting while this step was measured?" ([`SupplyStatus`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use supply::{
    KoradConfig, KoradSupply, Measurement, RegulationMode, ScpiConfig, ScpiSupply, SerialSettings,
    Supply, SupplyError,
};

use crate::error::{HostError, SupplyLoss};

/// The command set of a bench supply on a serial port.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Rigol/Siglent-style SCPI.
    Scpi,
    /// Korad/Tenma KA3005P.
    Korad,
}

impl std::str::FromStr for Dialect {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "scpi" | "rigol" | "siglent" => Ok(Self::Scpi),
            "korad" | "tenma" | "ka3005p" => Ok(Self::Korad),
            _ => Err(format!("unknown supply dialect {s:?} (scpi or korad)")),
        }
    }
}

impl std::fmt::Display for Dialect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Scpi => "scpi",
            Self::Korad => "korad",
        })
    }
}

/// Largest current limit the host sends to a supply, A (a guard, not the instrument's rating).
pub const MAX_CURRENT_LIMIT_A: f64 = 30.0;

/// Opens a supply driver on a serial port.
pub fn open_supply(path: &str, dialect: Dialect) -> Result<Box<dyn Supply + Send>, HostError> {
    let during = "to open";
    Ok(match dialect {
        Dialect::Scpi => Box::new(
            ScpiSupply::open(
                path,
                SerialSettings::default(),
                ScpiConfig {
                    max_current_a: MAX_CURRENT_LIMIT_A,
                    ..ScpiConfig::default()
                },
            )
            .map_err(|source| HostError::Supply {
                during,
                source: Box::new(source),
            })?,
        ),
        Dialect::Korad => Box::new(
            KoradSupply::open(
                path,
                SerialSettings::default(),
                KoradConfig {
                    max_current_a: MAX_CURRENT_LIMIT_A,
                    ..KoradConfig::default()
                },
            )
            .map_err(|source| HostError::Supply {
                during,
                source: Box::new(source),
            })?,
        ),
    })
}

/// What the monitor knows about the supply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyStatus {
    /// Regulation mode at the latest poll.
    pub mode: RegulationMode,
    /// Latest output reading, if any.
    pub measurement: Option<Measurement>,
    /// Polls started so far.
    pub polls_started: u64,
    /// Polls completed so far.
    pub polls_done: u64,
    /// Completed polls that found the supply not in constant-voltage mode.
    pub not_cv_polls: u64,
}

impl SupplyStatus {
    /// The worst regulation mode since `before`, once a poll that started after `before`
    /// has completed (`None` until then): constant current if any poll since found the
    /// supply not regulating its voltage, even if it is back in constant voltage now.
    pub fn mode_since(&self, before: &SupplyStatus) -> Option<RegulationMode> {
        if self.polls_done <= before.polls_started {
            return None;
        }
        Some(
            if self.not_cv_polls > before.not_cv_polls
                && self.mode == RegulationMode::ConstantVoltage
            {
                RegulationMode::ConstantCurrent
            } else {
                self.mode
            },
        )
    }

    /// Whether a poll that started after `before` has completed and found the output in
    /// constant-voltage mode within 5 % of `voltage_v`.
    pub fn regulating_at(&self, before: &SupplyStatus, voltage_v: f64) -> bool {
        let v_ok = self
            .measurement
            .is_some_and(|m| (m.voltage_v - voltage_v).abs() <= 0.05 * voltage_v);
        self.polls_done > before.polls_started
            && self.mode == RegulationMode::ConstantVoltage
            && v_ok
    }
}

/// The supply's status as a step's samples arrived, one mark per new poll, to know what it
/// was when the measurement window began.
#[derive(Debug, Clone, Default)]
pub struct StatusMarks {
    marks: Vec<(u64, SupplyStatus)>,
}

impl StatusMarks {
    /// Notes the status at a sample taken at `time_us` (rig time), if a poll started since
    /// the last mark.
    pub fn note(&mut self, time_us: u64, status: SupplyStatus) {
        if self
            .marks
            .last()
            .is_none_or(|(_, m)| m.polls_started != status.polls_started)
        {
            self.marks.push((time_us, status));
        }
    }

    /// The latest status noted before `time_us` (the first one when none is earlier;
    /// `None` when nothing was noted).
    pub fn at(&self, time_us: u64) -> Option<SupplyStatus> {
        self.marks
            .iter()
            .rev()
            .find(|(t, _)| *t < time_us)
            .or(self.marks.first())
            .map(|(_, m)| *m)
    }
}

/// A bench supply as a sweep drives it.
pub trait SupplyControl {
    /// The instrument's identification.
    fn identity(&self) -> String;
    /// Sets voltage and current limit (does not switch the output).
    fn apply(&mut self, voltage_v: f64, current_limit_a: f64) -> Result<(), HostError>;
    /// Switches the output.
    fn set_output(&mut self, on: bool) -> Result<(), HostError>;
    /// What is known now (an error once the supply stopped answering).
    fn status(&mut self) -> Result<SupplyStatus, HostError>;
}

/// A supply that is always at its set voltage (for in-process simulations and benchmarks
/// whose rig has its own ideal supply). Every status call counts as a fresh poll.
#[derive(Debug, Clone, Default)]
pub struct IdealSupply {
    voltage_v: f64,
    on: bool,
    polls: u64,
}

impl IdealSupply {
    /// An ideal supply, off.
    pub fn new() -> Self {
        Self::default()
    }
}

impl SupplyControl for IdealSupply {
    fn identity(&self) -> String {
        "ideal supply (simulation)".into()
    }
    fn apply(&mut self, voltage_v: f64, _current_limit_a: f64) -> Result<(), HostError> {
        self.voltage_v = voltage_v;
        Ok(())
    }
    fn set_output(&mut self, on: bool) -> Result<(), HostError> {
        self.on = on;
        Ok(())
    }
    fn status(&mut self) -> Result<SupplyStatus, HostError> {
        self.polls += 1;
        Ok(SupplyStatus {
            mode: if self.on {
                RegulationMode::ConstantVoltage
            } else {
                RegulationMode::Off
            },
            measurement: Some(Measurement {
                voltage_v: if self.on { self.voltage_v } else { 0.0 },
                current_a: 0.0,
            }),
            polls_started: self.polls,
            polls_done: self.polls,
            not_cv_polls: 0,
        })
    }
}

enum Request {
    Apply(f64, f64),
    Output(bool),
}

struct Shared {
    status: SupplyStatus,
    lost: Option<(u32, Arc<supply::SupplyError>)>,
}

/// Consecutive failed polls after which the supply counts as lost.
const LOST_AFTER: u32 = 3;
/// Pause between two polls.
const POLL_GAP: Duration = Duration::from_millis(5);
/// Output readings are taken every this many polls (the mode every poll).
const MEASURE_EVERY: u64 = 4;
/// Longest wait for a setting to be carried out.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);

/// A supply driver on its own thread; see the [module docs](self).
pub struct SupplyMonitor {
    identity: String,
    shared: Arc<Mutex<Shared>>,
    requests: mpsc::Sender<(Request, mpsc::Sender<Result<(), SupplyError>>)>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for SupplyMonitor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SupplyMonitor")
            .field("identity", &self.identity)
            .finish_non_exhaustive()
    }
}

impl SupplyMonitor {
    /// Identifies the supply and starts polling it.
    pub fn start(mut supply: Box<dyn Supply + Send>) -> Result<Self, HostError> {
        let identity = supply.identify().map_err(|source| HostError::Supply {
            during: "to identify itself",
            source: Box::new(source),
        })?;
        let mode = supply.mode().map_err(|source| HostError::Supply {
            during: "to report its regulation mode",
            source: Box::new(source),
        })?;
        let shared = Arc::new(Mutex::new(Shared {
            status: SupplyStatus {
                mode,
                measurement: None,
                polls_started: 0,
                polls_done: 0,
                not_cv_polls: 0,
            },
            lost: None,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let thread = {
            let shared = shared.clone();
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("supply-monitor".into())
                .spawn(move || monitor(supply, shared, rx, stop))
                .map_err(|e| HostError::SupplyLost(SupplyLoss::MonitorNotStarted(e)))?
        };
        Ok(Self {
            identity,
            shared,
            requests: tx,
            stop,
            thread: Some(thread),
        })
    }

    fn request(&self, r: Request) -> Result<(), HostError> {
        let (tx, rx) = mpsc::channel();
        self.requests
            .send((r, tx))
            .map_err(|_| HostError::SupplyLost(SupplyLoss::MonitorEnded))?;
        match rx.recv_timeout(REQUEST_TIMEOUT) {
            Ok(r) => r.map_err(|source| HostError::Supply {
                during: "to apply a setting",
                source: Box::new(source),
            }),
            Err(_) => Err(HostError::SupplyLost(SupplyLoss::NoAnswer(REQUEST_TIMEOUT))),
        }
    }
}

fn lock(s: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    s.lock().unwrap_or_else(PoisonError::into_inner)
}

fn monitor(
    mut supply: Box<dyn Supply + Send>,
    shared: Arc<Mutex<Shared>>,
    rx: mpsc::Receiver<(Request, mpsc::Sender<Result<(), SupplyError>>)>,
    stop: Arc<AtomicBool>,
) {
    let mut failures = 0u32;
    let mut n = 0u64;
    while !stop.load(Ordering::Relaxed) {
        while let Ok((r, reply)) = rx.try_recv() {
            let res = match r {
                Request::Apply(v, i) => supply.apply(v, i),
                Request::Output(on) => supply.set_output(on),
            };
            let _ = reply.send(res);
        }
        lock(&shared).status.polls_started += 1;
        let mode = supply.mode();
        let meas = if n % MEASURE_EVERY == 0 {
            Some(supply.measure())
        } else {
            None
        };
        n += 1;
        {
            let mut s = lock(&shared);
            match mode {
                Ok(m) => {
                    failures = 0;
                    s.status.mode = m;
                    s.status.polls_done += 1;
                    if m != RegulationMode::ConstantVoltage {
                        s.status.not_cv_polls += 1;
                    }
                }
                Err(e) => {
                    failures += 1;
                    if failures >= LOST_AFTER {
                        s.lost = Some((failures, Arc::new(e)));
                    }
                }
            }
            if let Some(Ok(m)) = meas {
                s.status.measurement = Some(m);
            }
        }
        if lock(&shared).lost.is_some() {
            // Keep serving requests (switching off may still work), but stop polling hard.
            std::thread::sleep(Duration::from_millis(50));
        }
        std::thread::sleep(POLL_GAP);
    }
    // Whatever happened, leave the output off when the monitor ends.
    let _ = supply.set_output(false);
}

impl SupplyControl for SupplyMonitor {
    fn identity(&self) -> String {
        self.identity.clone()
    }
    fn apply(&mut self, voltage_v: f64, current_limit_a: f64) -> Result<(), HostError> {
        self.request(Request::Apply(voltage_v, current_limit_a))
    }
    fn set_output(&mut self, on: bool) -> Result<(), HostError> {
        self.request(Request::Output(on))
    }
    fn status(&mut self) -> Result<SupplyStatus, HostError> {
        let s = lock(&self.shared);
        match &s.lost {
            Some((polls, e)) => Err(HostError::SupplyLost(SupplyLoss::Polls {
                polls: *polls,
                source: e.clone(),
            })),
            None => Ok(s.status),
        }
    }
}

impl Drop for SupplyMonitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(mode: RegulationMode, started: u64, done: u64, not_cv: u64) -> SupplyStatus {
        SupplyStatus {
            mode,
            measurement: Some(Measurement {
                voltage_v: 12.4,
                current_a: 1.0,
            }),
            polls_started: started,
            polls_done: done,
            not_cv_polls: not_cv,
        }
    }

    #[test]
    fn the_mode_since_waits_for_a_fresh_poll_and_remembers_current_limiting() {
        let cv = RegulationMode::ConstantVoltage;
        let before = status(cv, 5, 4, 0);
        assert_eq!(status(cv, 6, 5, 0).mode_since(&before), None);
        assert_eq!(status(cv, 7, 6, 0).mode_since(&before), Some(cv));
        // Current-limited in between, back in constant voltage now: still a limited step.
        assert_eq!(
            status(cv, 8, 7, 1).mode_since(&before),
            Some(RegulationMode::ConstantCurrent)
        );
        assert!(status(cv, 7, 6, 0).regulating_at(&before, 12.5));
        assert!(!status(cv, 7, 6, 0).regulating_at(&before, 14.0));
        assert!(!status(cv, 5, 5, 0).regulating_at(&before, 12.5));
    }

    #[test]
    fn marks_give_the_status_before_a_window() {
        let cv = RegulationMode::ConstantVoltage;
        let mut marks = StatusMarks::default();
        assert_eq!(marks.at(10), None);
        marks.note(100, status(cv, 1, 0, 0));
        marks.note(110, status(cv, 1, 1, 0)); // same poll: not a new mark
        marks.note(120, status(cv, 2, 1, 0));
        assert_eq!(marks.at(50).map(|s| s.polls_started), Some(1), "first");
        assert_eq!(
            marks.at(120).map(|s| s.polls_started),
            Some(1),
            "strictly before"
        );
        assert_eq!(marks.at(121).map(|s| s.polls_started), Some(2));
    }
}
