//! Thrust-targeted sweeps.
//!
//! A **nominal** sweep ([`SweepKind::Nominal`]) sets the supply, tares, arms and then closes
//! the loop on throttle to hit each thrust target (0, 10, 20 … g) within the tolerance: the
//! first guess comes from inverse interpolation through the steps already measured, each
//! correction from the local slope (a secant through the last two settled points), and every
//! attempt waits for steady state ([`crate::settle`]). Zero thrust is the tare, so the
//! first target is one step. It ends at the rotor's maximum: the
//! throttle at its top with the target still out of reach, or more throttle that brings no
//! more thrust (the plateau). A **limit** sweep ([`SweepKind::Limit`]) steps the throttle to
//! the top instead, for [`fit::thrust_limit`].
//!
//! Every step's supply mode is checked with the supply polls that started after its
//! measurement window began (at least one); a step whose window saw the supply not
//! regulating its voltage (constant current) is recorded with `valid = false` and ends the
//! sweep (the rig backs off to zero throttle).
//!
//! On an error — a fault, a timeout, a lost link or supply, an interrupt — the runner brings
//! the throttle to minimum, disarms, switches the supply off and returns the error; the
//! caller closes the log with the reason ([`run_logged`] does both).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use rig_protocol::{ClientError, Clock, FaultCause, Identity, Rig, RigState};
use supply::RegulationMode;

use crate::bench_supply::{SupplyControl, SupplyStatus};
use crate::controller::{ControllerConfig, Decision, StepController};
use crate::error::{HostError, SupplyLoss};
use crate::log::{LIMIT_COLUMNS, LogHeader, LoggedSample, NOMINAL_COLUMNS, StepRecord, SweepLog};
use crate::settle::{SettleDetector, SettlePolicy, SettleState, Window};

/// What a sweep steps through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SweepKind {
    /// Thrust targets every `step_g` from `step_g` up to the rotor's maximum (or
    /// `max_target_g`); zero thrust is the tare.
    Nominal {
        /// Thrust step, g.
        step_g: f64,
        /// Last target, g (`None`: up to the plateau).
        max_target_g: Option<f64>,
    },
    /// Throttle steps of `step_us` up to and including full throttle (strictly increasing,
    /// as [`fit::thrust_limit`] wants them).
    Limit {
        /// Throttle step, µs.
        step_us: u16,
    },
}

impl SweepKind {
    /// The columns of its log.
    pub fn columns(&self) -> &'static str {
        match self {
            Self::Nominal { .. } => NOMINAL_COLUMNS,
            Self::Limit { .. } => LIMIT_COLUMNS,
        }
    }

    /// A one-line description (also the log's `sweep` key).
    pub fn describe(&self) -> String {
        match self {
            Self::Nominal {
                step_g,
                max_target_g: None,
            } => format!("nominal, thrust targets every {step_g} g to the plateau"),
            Self::Nominal {
                step_g,
                max_target_g: Some(m),
            } => format!("nominal, thrust targets every {step_g} g to {m} g"),
            Self::Limit { step_us } => format!("limit, throttle steps of {step_us} us to the top"),
        }
    }
}

/// Host time without a single sample that ends a sweep, µs (of the host's clock).
const NO_SAMPLES_TIMEOUT_US: u64 = 5_000_000;

/// How a sweep runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepConfig {
    /// The steps.
    pub kind: SweepKind,
    /// Supply voltage set-point, V.
    pub voltage_v: f64,
    /// Supply current limit, A.
    pub current_limit_a: f64,
    /// Thrust tolerance of a nominal step, ± g.
    pub tolerance_g: f64,
    /// Sample stream rate, Hz.
    pub stream_rate_hz: u16,
    /// Steady-state detection.
    pub settle: SettlePolicy,
    /// Longest settle of one throttle attempt, s of rig time (from the samples' clock).
    pub settle_timeout_s: f64,
    /// Throttle attempts per nominal step before the closest is taken.
    pub max_attempts: usize,
    /// Load-cell readings averaged by the tare.
    pub tare_samples: u16,
    /// Largest throttle change of one correction, µs.
    pub max_correction_us: f64,
    /// First probe of a nominal sweep, as a fraction of the throttle range.
    pub probe_fraction: f64,
    /// Host-timeout faults recovered from (re-arm and retry the step) before giving up.
    pub host_timeout_recoveries: u32,
    /// Longest wait for the supply (settings, a fresh mode poll), real time.
    pub supply_timeout: Duration,
}

impl Default for SweepConfig {
    fn default() -> Self {
        Self {
            kind: SweepKind::Nominal {
                step_g: 10.0,
                max_target_g: None,
            },
            voltage_v: 12.5,
            current_limit_a: 10.0,
            tolerance_g: 1.0,
            stream_rate_hz: 200,
            settle: SettlePolicy::default(),
            settle_timeout_s: 15.0,
            max_attempts: 10,
            tare_samples: 40,
            max_correction_us: 150.0,
            probe_fraction: 0.12,
            host_timeout_recoveries: 5,
            supply_timeout: Duration::from_secs(10),
        }
    }
}

impl SweepConfig {
    /// Checks the settings before the rig moves: what would fail mid-sweep fails here.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{what} must be a positive number, got {v}"))
            }
        };
        match self.kind {
            SweepKind::Nominal {
                step_g,
                max_target_g,
            } => {
                positive("thrust step (g)", step_g)?;
                if let Some(m) = max_target_g {
                    positive("highest thrust target (g)", m)?;
                }
            }
            SweepKind::Limit { step_us: 0 } => {
                return Err("throttle step must be at least 1 µs, got 0".into());
            }
            SweepKind::Limit { .. } => {}
        }
        positive("supply voltage (V)", self.voltage_v)?;
        positive("supply current limit (A)", self.current_limit_a)?;
        positive("thrust tolerance (g)", self.tolerance_g)?;
        if self.stream_rate_hz == 0 {
            return Err("sample stream rate must be at least 1 Hz, got 0".into());
        }
        positive("settle timeout (s)", self.settle_timeout_s)?;
        if self.max_attempts == 0 {
            return Err("at least one throttle attempt per step is needed".into());
        }
        if self.tare_samples == 0 {
            return Err("the tare needs at least one reading".into());
        }
        positive("largest throttle correction (µs)", self.max_correction_us)?;
        if self.probe_fraction.is_nan() || self.probe_fraction <= 0.0 || self.probe_fraction >= 1.0
        {
            return Err(format!(
                "first probe must be a fraction of the throttle range in (0, 1), got {}",
                self.probe_fraction
            ));
        }
        Ok(())
    }
}

/// Something a sweep reports while it runs (the binary renders these).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SweepEvent<'a> {
    /// The sweep started (after `resumed_steps` steps of an earlier run).
    Started {
        /// The steps.
        kind: &'a SweepKind,
        /// Steps already in the log.
        resumed_steps: usize,
        /// Steps expected in all, when known.
        expected_steps: Option<usize>,
    },
    /// Settling a step.
    Progress {
        /// Step number.
        step: usize,
        /// Thrust target, g.
        target_g: Option<f64>,
        /// Throttle commanded, µs.
        throttle_us: u16,
        /// Latest thrust, g.
        thrust_g: f64,
        /// Detector state.
        state: SettleState,
    },
    /// A step was completed and logged.
    Step(&'a StepRecord),
    /// Something worth telling.
    Note(&'a str),
}

/// Receives [`SweepEvent`]s.
pub trait SweepObserver {
    /// One event.
    fn event(&mut self, event: SweepEvent<'_>);
}

impl<F: FnMut(SweepEvent<'_>)> SweepObserver for F {
    fn event(&mut self, event: SweepEvent<'_>) {
        self(event)
    }
}

/// Where completed steps go.
pub trait StepSink {
    /// One completed step and its samples (must be durable when this returns).
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError>;
    /// A remark.
    fn comment(&mut self, text: &str) -> Result<(), HostError>;
}

impl StepSink for SweepLog {
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError> {
        self.append_step(row, samples)
    }
    fn comment(&mut self, text: &str) -> Result<(), HostError> {
        SweepLog::comment(self, text)
    }
}

/// Steps kept in memory (benchmarks, tests).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MemorySink {
    /// The steps.
    pub rows: Vec<StepRecord>,
    /// Their samples.
    pub samples: Vec<LoggedSample>,
    /// Remarks.
    pub comments: Vec<String>,
}

impl StepSink for MemorySink {
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError> {
        self.rows.push(*row);
        self.samples.extend_from_slice(samples);
        Ok(())
    }
    fn comment(&mut self, text: &str) -> Result<(), HostError> {
        self.comments.push(text.to_owned());
        Ok(())
    }
}

/// How a sweep ended (without error).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SweepEnd {
    /// Every target or throttle step done.
    Complete,
    /// The rotor's maximum was reached: throttle at the top or no more thrust, at this
    /// thrust, g.
    Plateau {
        /// Highest thrust reached, g.
        thrust_g: f64,
    },
    /// The supply stopped regulating its voltage (current limit) at this step; the sweep
    /// backed off.
    SupplyLimited {
        /// The step.
        step: usize,
    },
}

impl std::fmt::Display for SweepEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Complete => f.write_str("complete"),
            Self::Plateau { thrust_g } => write!(f, "complete (plateau at {thrust_g:.1} g)"),
            Self::SupplyLimited { step } => write!(
                f,
                "supply current-limited at step {step} (row marked invalid); backed off"
            ),
        }
    }
}

/// What a finished sweep did.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepOutcome {
    /// All steps (including resumed ones).
    pub rows: Vec<StepRecord>,
    /// Steps taken from an earlier run.
    pub resumed_steps: usize,
    /// How it ended.
    pub end: SweepEnd,
    /// Rig time from arming to the end of the last step, s.
    pub rig_time_s: f64,
    /// Throttle attempts made.
    pub attempts: usize,
}

/// What the sweep needs to know about a rig connection's errors.
pub trait LinkError: std::error::Error + Send + Sync + 'static {
    /// Whether the transport failed (as opposed to a timeout or a refusal).
    fn is_transport(&self) -> bool;
    /// Whether the rig refused a command because a fault is latched.
    fn is_faulted(&self) -> bool;
}

impl<E: std::fmt::Debug + Send + Sync + 'static> LinkError for ClientError<E> {
    fn is_transport(&self) -> bool {
        matches!(self, ClientError::Transport(_))
    }
    fn is_faulted(&self) -> bool {
        matches!(
            self,
            ClientError::Nack {
                reason: rig_protocol::NackReason::Faulted,
                ..
            }
        )
    }
}

fn rig_err<E: LinkError>(during: &'static str) -> impl Fn(E) -> HostError {
    move |e| {
        if e.is_transport() {
            HostError::LinkLost {
                during,
                source: Box::new(e),
            }
        } else {
            HostError::Rig {
                during,
                source: Box::new(e),
            }
        }
    }
}

/// The comment block of a sweep log.
pub fn sweep_header(
    config: &SweepConfig,
    identity: &Identity,
    calibration_points: u8,
    calibration: &str,
    supply_identity: &str,
) -> LogHeader {
    let mut h = LogHeader::default();
    h.push("hoverbench", "sweep log");
    h.push("sweep", config.kind.describe());
    let fw = identity.firmware_version;
    h.push(
        "rig",
        format!(
            "serial 0x{:08x}, board {}, firmware {}.{}.{}, protocol {}, throttle {}-{} us",
            identity.serial_number,
            identity.board,
            fw[0],
            fw[1],
            fw[2],
            identity.protocol_version,
            identity.throttle_min_us,
            identity.throttle_max_us
        ),
    );
    h.push("calibration_points", calibration_points.to_string());
    h.push("calibration", calibration);
    h.push("supply", supply_identity);
    h.push("supply_voltage_v", format!("{}", config.voltage_v));
    h.push("current_limit_a", format!("{}", config.current_limit_a));
    let settle = match config.settle {
        SettlePolicy::Adaptive(a) => format!(
            "adaptive: window {} s, >= {} samples, |slope| <= {} se or drift <= {} of mean",
            a.window_s, a.min_samples, a.z, a.relative_floor
        ),
        SettlePolicy::FixedDwell { dwell_s, samples } => {
            format!("fixed dwell {dwell_s} s, then {samples} samples")
        }
    };
    h.push("settle", settle);
    h.push("tolerance_g", format!("{}", config.tolerance_g));
    h.push("stream_rate_hz", config.stream_rate_hz.to_string());
    h.push(
        "tool",
        format!("hoverbench rig-host {}", env!("CARGO_PKG_VERSION")),
    );
    h.push("started", jiff::Timestamp::now().to_string());
    h
}

/// Things that must be known to place masses on the load cell during a calibration.
pub trait MassPlacer {
    /// Puts `mass_g` on the load cell (0: removes everything) and returns when it is there.
    fn place(&mut self, mass_g: f64) -> Result<(), HostError>;
}

/// Brings the rig to `Disarmed` whatever its state (a latched fault, for instance the host
/// timeout left by a host that was killed, is cleared by re-arming, then disarmed); returns
/// the faults that were latched.
pub fn disarm_clean<R: Rig>(rig: &mut R) -> Result<rig_protocol::FaultSet, HostError>
where
    R::Error: LinkError,
{
    let st = rig.status().map_err(rig_err("status"))?;
    if st.state == RigState::Faulted {
        rig.arm()
            .map_err(rig_err("re-arm to clear a latched fault"))?;
    }
    if st.state != RigState::Disarmed {
        rig.disarm().map_err(rig_err("disarm"))?;
    }
    while rig.take_fault().map_err(rig_err("fault check"))?.is_some() {}
    Ok(if st.state == RigState::Faulted {
        st.faults
    } else {
        rig_protocol::FaultSet::EMPTY
    })
}

/// Waits `seconds` of rig time while keeping the link alive.
pub fn idle<R: Rig>(rig: &mut R, clock: &dyn Clock, seconds: f64) -> Result<(), HostError>
where
    R::Error: LinkError,
{
    let end = clock.now_us() + (seconds * 1e6) as u64;
    while clock.now_us() < end {
        rig.next_sample().map_err(rig_err("idle"))?;
    }
    Ok(())
}

/// Tares, then calibrates the load cell with known masses (0, then each of `masses_g`);
/// returns the calibration and a description for the log.
pub fn calibrate<R: Rig>(
    rig: &mut R,
    clock: &dyn Clock,
    masses_g: &[f64],
    placer: &mut dyn MassPlacer,
    tare_samples: u16,
) -> Result<(rig_protocol::Calibration, String), HostError>
where
    R::Error: LinkError,
{
    disarm_clean(rig)?;
    placer.place(0.0)?;
    idle(rig, clock, 0.5)?;
    rig.tare(tare_samples).map_err(rig_err("tare"))?;
    let mut cal = None;
    for &m in masses_g {
        placer.place(m)?;
        idle(rig, clock, 0.5)?;
        cal = Some(rig.calibrate(m as f32).map_err(rig_err("calibrate"))?);
    }
    placer.place(0.0)?;
    idle(rig, clock, 0.5)?;
    let cal =
        cal.ok_or_else(|| HostError::Invalid("calibration needs at least one mass".into()))?;
    let text = format!(
        "{} points ({} g), {:.7} g/count",
        cal.points,
        masses_g
            .iter()
            .map(|m| format!("{m}"))
            .collect::<Vec<_>>()
            .join(", "),
        cal.scale_g_per_count
    );
    Ok((cal, text))
}

struct Runner<'a, R: Rig> {
    rig: &'a mut R,
    clock: &'a dyn Clock,
    supply: &'a mut dyn SupplyControl,
    cfg: SweepConfig,
    obs: &'a mut dyn SweepObserver,
    stop: &'a AtomicBool,
    ident: Identity,
    recoveries: u32,
    attempts: usize,
    last_progress_us: u64,
    last_fault_check_us: u64,
    first_sample_us: Option<u64>,
    last_sample_us: u64,
    /// Samples older than this rig time are stale (from before the last arming).
    fresh_after_us: u64,
}

/// One settled throttle attempt.
struct Attempt {
    throttle_us: u16,
    window: Window,
    /// The supply's status when the measurement window began.
    supply_at_window: SupplyStatus,
}

impl<R: Rig> Runner<'_, R>
where
    R::Error: LinkError,
{
    fn umin(&self) -> f64 {
        f64::from(self.ident.throttle_min_us)
    }
    fn umax(&self) -> f64 {
        f64::from(self.ident.throttle_max_us)
    }

    fn check(&mut self) -> Result<(), HostError> {
        if self.stop.load(Ordering::Relaxed) {
            return Err(HostError::Interrupted);
        }
        Ok(())
    }

    /// The rig refused a command for a latched fault: recover as [`Self::faults`] does if
    /// it is only a host timeout, else fail with it.
    fn recover_refused(&mut self) -> Result<(), HostError> {
        let st = self.rig.status().map_err(rig_err("status"))?;
        let cause = st.faults.iter().next().unwrap_or(FaultCause::HostTimeout);
        let only_timeout = st.faults.iter().all(|c| c == FaultCause::HostTimeout);
        let report = rig_protocol::FaultReport {
            time_us: st.time_us,
            cause: if only_timeout {
                FaultCause::HostTimeout
            } else {
                st.faults
                    .iter()
                    .find(|&c| c != FaultCause::HostTimeout)
                    .unwrap_or(cause)
            },
            value: f32::NAN,
            limit: f32::NAN,
        };
        // Reports of this fault still queued are the same event.
        while self
            .rig
            .take_fault()
            .map_err(rig_err("fault check"))?
            .is_some()
        {}
        self.handle_fault(report).map(|_| ())
    }

    /// Looks for a latched fault; recovers from a host timeout (re-arm) when allowed.
    /// Returns true when the rig was re-armed (the attempt must start over).
    fn faults(&mut self) -> Result<bool, HostError> {
        let now = self.clock.now_us();
        if now.saturating_sub(self.last_fault_check_us) < 20_000 {
            return Ok(false);
        }
        self.last_fault_check_us = now;
        let Some(f) = self.rig.take_fault().map_err(rig_err("fault check"))? else {
            return Ok(false);
        };
        self.handle_fault(f)
    }

    fn handle_fault(&mut self, f: rig_protocol::FaultReport) -> Result<bool, HostError> {
        if f.cause == FaultCause::HostTimeout && self.recoveries < self.cfg.host_timeout_recoveries
        {
            self.recoveries += 1;
            let msg = format!(
                "host timeout latched by the rig (the host was late); re-armed ({} of {})",
                self.recoveries, self.cfg.host_timeout_recoveries
            );
            self.obs.event(SweepEvent::Note(&msg));
            self.rig.arm().map_err(rig_err("re-arm"))?;
            self.fresh_after_us = self.rig.status().map_err(rig_err("status"))?.time_us;
            return Ok(true);
        }
        Err(HostError::Fault {
            cause: f.cause,
            value: f.value,
            limit: f.limit,
        })
    }

    /// Commands `throttle_us` and waits for steady state.
    fn settle(
        &mut self,
        throttle_us: u16,
        step: usize,
        target_g: Option<f64>,
        log: &mut Vec<LoggedSample>,
    ) -> Result<Attempt, HostError> {
        let attempt = self.attempts;
        self.attempts += 1;
        'restart: loop {
            match self.rig.set_throttle(throttle_us) {
                Ok(()) => {}
                Err(e) if e.is_faulted() => {
                    self.recover_refused()?;
                    continue 'restart;
                }
                Err(e) => return Err(rig_err("set throttle")(e)),
            }
            let mut det = SettleDetector::new(self.cfg.settle, throttle_us);
            let started = self.clock.now_us();
            // Rig time of the first sample after the command (the settle timeout is in rig
            // time: a starved simulator slows rig time, not the physics).
            let mut first_rig_us: Option<u64> = None;
            let mut last_rig_us = 0u64;
            // The supply's status as each sample arrived (when it changed), to know what it
            // was when the measurement window began.
            let mut marks: Vec<(u64, SupplyStatus)> = Vec::new();
            let mut last_sample_at = started;
            let mut thrust = f64::NAN;
            loop {
                self.check()?;
                if self.faults()? {
                    continue 'restart;
                }
                let now = self.clock.now_us();
                match self.rig.next_sample().map_err(rig_err("sampling"))? {
                    Some(s) if s.time_us < self.fresh_after_us => {}
                    Some(s) => {
                        last_sample_at = now;
                        first_rig_us.get_or_insert(s.time_us);
                        last_rig_us = s.time_us;
                        self.first_sample_us.get_or_insert(s.time_us);
                        self.last_sample_us = s.time_us;
                        thrust = f64::from(s.thrust_g);
                        let st = self.supply.status()?;
                        if marks
                            .last()
                            .is_none_or(|(_, m)| m.polls_started != st.polls_started)
                        {
                            marks.push((s.time_us, st));
                        }
                        log.push(LoggedSample {
                            step,
                            attempt,
                            in_window: false,
                            sample: s,
                        });
                        if let Some(w) = det.push(s) {
                            let (a, b) = (
                                w.samples.first().map_or(0, |s| s.time_us),
                                w.samples.last().map_or(0, |s| s.time_us),
                            );
                            for l in log.iter_mut().rev() {
                                if l.attempt != attempt {
                                    break;
                                }
                                if (a..=b).contains(&l.sample.time_us) {
                                    l.in_window = true;
                                }
                            }
                            // The latest status recorded before the window's first sample.
                            let supply_at_window = marks
                                .iter()
                                .rev()
                                .find(|(t, _)| *t < a)
                                .or(marks.first())
                                .map(|(_, m)| *m)
                                .ok_or_else(|| HostError::SupplyLost(SupplyLoss::NoStatus))?;
                            return Ok(Attempt {
                                throttle_us,
                                window: w,
                                supply_at_window,
                            });
                        }
                    }
                    None => {
                        if now.saturating_sub(last_sample_at) > NO_SAMPLES_TIMEOUT_US {
                            return Err(HostError::Timeout {
                                what: "no samples from the rig".into(),
                                seconds: NO_SAMPLES_TIMEOUT_US as f64 * 1e-6,
                            });
                        }
                    }
                }
                let elapsed =
                    first_rig_us.map_or(0, |t| last_rig_us.saturating_sub(t)) as f64 * 1e-6;
                if elapsed > self.cfg.settle_timeout_s {
                    return Err(HostError::Timeout {
                        what: format!("step {step} did not settle at {throttle_us} us"),
                        seconds: elapsed,
                    });
                }
                if now.saturating_sub(self.last_progress_us) > 100_000 {
                    self.last_progress_us = now;
                    self.obs.event(SweepEvent::Progress {
                        step,
                        target_g,
                        throttle_us,
                        thrust_g: thrust,
                        state: det.state(),
                    });
                }
            }
        }
    }

    /// The worst supply mode since `before`, waiting for a poll that started after it.
    fn supply_mode_since(&mut self, before: &SupplyStatus) -> Result<RegulationMode, HostError> {
        let deadline = Instant::now() + self.cfg.supply_timeout;
        loop {
            let s = self.supply.status()?;
            if s.polls_done > before.polls_started {
                return Ok(if s.not_cv_polls > before.not_cv_polls {
                    if s.mode == RegulationMode::ConstantVoltage {
                        RegulationMode::ConstantCurrent
                    } else {
                        s.mode
                    }
                } else {
                    s.mode
                });
            }
            if Instant::now() > deadline {
                return Err(HostError::SupplyLost(SupplyLoss::NoMode(
                    self.cfg.supply_timeout,
                )));
            }
            self.check()?;
            self.faults()?;
            self.rig.next_sample().map_err(rig_err("sampling"))?;
        }
    }

    fn record(
        &self,
        step: usize,
        target_g: Option<f64>,
        a: &Attempt,
        settle_s: f64,
        mode: RegulationMode,
    ) -> StepRecord {
        let w = &a.window;
        StepRecord {
            step,
            target_g,
            throttle_us: a.throttle_us,
            thrust_g: w.thrust.mean,
            thrust_std_g: w.thrust.std,
            current_a: w.current.mean,
            current_std_a: w.current.std,
            voltage_v: w.voltage.mean,
            voltage_std_v: w.voltage.std,
            power_w: w.power.mean,
            power_std_w: w.power.std,
            samples: w.samples.len(),
            settle_s,
            time_s: w.samples.last().map_or(0.0, |s| s.time_us as f64 * 1e-6),
            supply_mode: mode,
            valid: mode == RegulationMode::ConstantVoltage,
        }
    }

    /// The throttle controller's settings for this sweep.
    fn controller(&self) -> ControllerConfig {
        ControllerConfig {
            umin: self.umin(),
            umax: self.umax(),
            tolerance_g: self.cfg.tolerance_g,
            max_correction_us: self.cfg.max_correction_us,
            probe_fraction: self.cfg.probe_fraction,
            max_attempts: self.cfg.max_attempts,
        }
    }

    /// Hits `target` within the tolerance; returns the attempt, the settle time and whether
    /// the rotor's maximum was reached. The set-points come from the pure
    /// [`StepController`]; this only settles the rig at each and reports back.
    fn hit_target(
        &mut self,
        step: usize,
        target: f64,
        history: &[(f64, f64)],
        log: &mut Vec<LoggedSample>,
    ) -> Result<(Attempt, f64, bool), HostError> {
        let t_start = self.clock.now_us();
        let mut control = StepController::new(self.controller(), target, history);
        let mut u = control.start();
        let mut best: Option<Attempt> = None;
        loop {
            let a = self.settle(u as u16, step, Some(target), log)?;
            let w = &a.window;
            let se = w.thrust.std / (w.samples.len() as f64).sqrt();
            let decision = control.observe(u, w.thrust.mean, se);
            let settle_s = self.clock.now_us().saturating_sub(t_start) as f64 * 1e-6;
            match decision {
                Decision::Hit => return Ok((a, settle_s, false)),
                Decision::Maximum => return Ok((a, settle_s, true)),
                Decision::Next {
                    throttle_us,
                    best: b,
                } => {
                    if b {
                        best = Some(a);
                    }
                    u = throttle_us;
                }
                Decision::Missed { best: b } => {
                    if b {
                        best = Some(a);
                    }
                    break;
                }
            }
        }
        let settle_s = self.clock.now_us().saturating_sub(t_start) as f64 * 1e-6;
        let a = best.ok_or_else(|| HostError::Timeout {
            what: format!("step {step}: no attempt"),
            seconds: settle_s,
        })?;
        let msg = format!(
            "step {step}: target {target} g missed ({:.2} g after {} attempts); closest kept",
            a.window.thrust.mean,
            control.attempts()
        );
        self.obs.event(SweepEvent::Note(&msg));
        Ok((a, settle_s, false))
    }

    /// Brings the throttle to minimum and waits (bounded) until the output is there.
    fn spin_down(&mut self) {
        let min = self.ident.throttle_min_us;
        if self.rig.set_throttle(min).is_err() {
            return;
        }
        let end = self.clock.now_us() + 3_000_000;
        let mut at_min_since = None;
        while self.clock.now_us() < end {
            match self.rig.next_sample() {
                Ok(Some(s)) if s.throttle_us <= min => {
                    let t = *at_min_since.get_or_insert(s.time_us);
                    if s.time_us.saturating_sub(t) > 300_000 {
                        return;
                    }
                }
                Ok(_) => {}
                Err(_) => return,
            }
        }
    }

    fn safe_stop(&mut self) {
        self.spin_down();
        let _ = self.rig.disarm();
        let _ = self.rig.stop_stream();
        let _ = self.supply.set_output(false);
    }

    fn wait_supply(&mut self) -> Result<(), HostError> {
        let deadline = Instant::now() + self.cfg.supply_timeout;
        let before = self.supply.status()?;
        loop {
            let s = self.supply.status()?;
            let v_ok = s.measurement.is_some_and(|m| {
                (m.voltage_v - self.cfg.voltage_v).abs() <= 0.05 * self.cfg.voltage_v
            });
            if s.polls_done > before.polls_started
                && s.mode == RegulationMode::ConstantVoltage
                && v_ok
            {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(HostError::SupplyLost(SupplyLoss::NotRegulating {
                    voltage_v: self.cfg.voltage_v,
                    timeout: self.cfg.supply_timeout,
                    mode: format!("{:?}", s.mode),
                    measurement: format!("{:?}", s.measurement),
                }));
            }
            self.check()?;
            let _ = self
                .rig
                .take_fault()
                .map_err(rig_err("waiting for the supply"))?;
        }
    }

    fn run(
        &mut self,
        resumed: &[StepRecord],
        sink: &mut dyn StepSink,
    ) -> Result<SweepOutcome, HostError> {
        // Motor stopped and disarmed before anything else.
        let old = disarm_clean(self.rig)?;
        if !old.is_empty() {
            let causes: Vec<String> = old.iter().map(|c| format!("{c:?}")).collect();
            let msg = format!(
                "the rig had a latched fault from before ({}); cleared",
                causes.join(", ")
            );
            self.obs.event(SweepEvent::Note(&msg));
        }
        self.supply
            .apply(self.cfg.voltage_v, self.cfg.current_limit_a)?;
        self.supply.set_output(true)?;
        self.wait_supply()?;
        self.rig
            .tare(self.cfg.tare_samples)
            .map_err(rig_err("tare"))?;
        self.rig
            .start_stream(self.cfg.stream_rate_hz)
            .map_err(rig_err("start stream"))?;
        self.rig.arm().map_err(rig_err("arm"))?;
        // Drop a fault latched before this session (re-arming cleared it), and ignore any
        // sample older than now (stale ones still queued from an earlier session).
        while self
            .rig
            .take_fault()
            .map_err(rig_err("fault check"))?
            .is_some()
        {}
        self.fresh_after_us = self.rig.status().map_err(rig_err("status"))?.time_us;

        let mut rows: Vec<StepRecord> = resumed.to_vec();
        let expected = match self.cfg.kind {
            SweepKind::Nominal {
                step_g,
                max_target_g: Some(m),
            } => Some((m / step_g + 1e-9).floor() as usize),
            SweepKind::Nominal { .. } => None,
            SweepKind::Limit { step_us } => Some(self.limit_throttles(step_us).len()),
        };
        self.obs.event(SweepEvent::Started {
            kind: &self.cfg.kind,
            resumed_steps: resumed.len(),
            expected_steps: expected,
        });
        let end = match self.cfg.kind {
            SweepKind::Nominal {
                step_g,
                max_target_g,
            } => self.nominal(step_g, max_target_g, &mut rows, sink)?,
            SweepKind::Limit { step_us } => self.limit(step_us, &mut rows, sink)?,
        };
        let rig_time_s = self
            .first_sample_us
            .map_or(0.0, |t| self.last_sample_us.saturating_sub(t) as f64 * 1e-6);
        self.spin_down();
        self.rig.disarm().map_err(rig_err("disarm"))?;
        self.rig.stop_stream().map_err(rig_err("stop stream"))?;
        self.supply.set_output(false)?;
        Ok(SweepOutcome {
            rows,
            resumed_steps: resumed.len(),
            end,
            rig_time_s,
            attempts: self.attempts,
        })
    }

    fn complete_step(
        &mut self,
        row: StepRecord,
        samples: &mut Vec<LoggedSample>,
        rows: &mut Vec<StepRecord>,
        sink: &mut dyn StepSink,
    ) -> Result<(), HostError> {
        sink.step(&row, samples)?;
        samples.clear();
        rows.push(row);
        self.obs.event(SweepEvent::Step(&row));
        Ok(())
    }

    fn nominal(
        &mut self,
        step_g: f64,
        max_target_g: Option<f64>,
        rows: &mut Vec<StepRecord>,
        sink: &mut dyn StepSink,
    ) -> Result<SweepEnd, HostError> {
        if !(step_g.is_finite() && step_g > 0.0) {
            return Err(HostError::Invalid(format!("thrust step {step_g} g")));
        }
        let mut samples = Vec::new();
        loop {
            // Targets from one step up: zero thrust is the tare itself.
            let step = rows.len();
            let target = (step + 1) as f64 * step_g;
            if max_target_g.is_some_and(|m| target > m + 1e-9) {
                return Ok(SweepEnd::Complete);
            }
            let history: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (f64::from(r.throttle_us), r.thrust_g))
                .collect();
            let (a, settle_s, top) = self.hit_target(step, target, &history, &mut samples)?;
            let mode = self.supply_mode_since(&a.supply_at_window)?;
            let row = self.record(step, Some(target), &a, settle_s, mode);
            self.complete_step(row, &mut samples, rows, sink)?;
            if !row.valid {
                return Ok(SweepEnd::SupplyLimited { step });
            }
            if top {
                return Ok(SweepEnd::Plateau {
                    thrust_g: row.thrust_g,
                });
            }
        }
    }

    fn limit_throttles(&self, step_us: u16) -> Vec<u16> {
        let (lo, hi) = (self.ident.throttle_min_us, self.ident.throttle_max_us);
        let mut v = Vec::new();
        let mut u = lo.saturating_add(step_us.max(1));
        while u < hi {
            v.push(u);
            u = u.saturating_add(step_us.max(1));
        }
        v.push(hi);
        v
    }

    fn limit(
        &mut self,
        step_us: u16,
        rows: &mut Vec<StepRecord>,
        sink: &mut dyn StepSink,
    ) -> Result<SweepEnd, HostError> {
        let plan = self.limit_throttles(step_us);
        let mut samples = Vec::new();
        for (step, &u) in plan.iter().enumerate().skip(rows.len()) {
            let t0 = self.clock.now_us();
            let a = self.settle(u, step, None, &mut samples)?;
            let settle_s = self.clock.now_us().saturating_sub(t0) as f64 * 1e-6;
            let mode = self.supply_mode_since(&a.supply_at_window)?;
            let row = self.record(step, None, &a, settle_s, mode);
            self.complete_step(row, &mut samples, rows, sink)?;
            if !row.valid {
                return Ok(SweepEnd::SupplyLimited { step });
            }
        }
        Ok(SweepEnd::Complete)
    }
}

/// What state an error leaves the bench in, after the runner's safe stop (one sentence for
/// the operator).
pub fn safe_state(e: &HostError) -> &'static str {
    match e {
        HostError::LinkLost { .. } => {
            "the link to the rig is gone, so its firmware watchdog cuts the throttle within 250 ms; \
             the supply output was switched off"
        }
        HostError::SupplyLost(_) | HostError::Supply { .. } => {
            "throttle set to zero and rig disarmed; the supply did not answer: check that its \
             output is off"
        }
        _ => "throttle set to zero, rig disarmed and supply output switched off",
    }
}

/// What a sweep runs with besides the rig: the rig's clock and identity, the bench supply,
/// who hears its events, and the flag that stops it.
pub struct SweepEnv<'a> {
    /// The rig's clock.
    pub clock: &'a dyn Clock,
    /// The rig (from the handshake).
    pub identity: &'a Identity,
    /// The bench supply.
    pub supply: &'a mut dyn SupplyControl,
    /// Who hears the sweep's events.
    pub observer: &'a mut dyn SweepObserver,
    /// Set to stop the sweep safely.
    pub stop: &'a AtomicBool,
}

/// Runs a sweep on a connected rig (handshake done); see the [module docs](self).
///
/// `resumed` are the steps of an interrupted run (from [`SweepLog::resume`]); the sweep
/// continues after them. On error the rig is brought to a safe state before returning.
pub fn run_sweep<R: Rig>(
    rig: &mut R,
    env: SweepEnv<'_>,
    config: &SweepConfig,
    resumed: &[StepRecord],
    sink: &mut dyn StepSink,
) -> Result<SweepOutcome, HostError>
where
    R::Error: LinkError,
{
    let SweepEnv {
        clock,
        identity,
        supply,
        observer,
        stop,
    } = env;
    let now = clock.now_us();
    let mut runner = Runner {
        rig,
        clock,
        supply,
        cfg: *config,
        obs: observer,
        stop,
        ident: *identity,
        recoveries: 0,
        attempts: 0,
        last_progress_us: now,
        last_fault_check_us: now,
        first_sample_us: None,
        last_sample_us: 0,
        fresh_after_us: 0,
    };
    match runner.run(resumed, sink) {
        Ok(o) => Ok(o),
        Err(e) => {
            runner.safe_stop();
            Err(e)
        }
    }
}

/// [`run_sweep`] into a [`SweepLog`], which is closed with the outcome or the error as its
/// last line (`# end: complete`, `# end: stopped: <reason>`).
pub fn run_logged<R: Rig>(
    rig: &mut R,
    env: SweepEnv<'_>,
    config: &SweepConfig,
    resumed: &[StepRecord],
    mut log: SweepLog,
) -> Result<SweepOutcome, HostError>
where
    R::Error: LinkError,
{
    let r = run_sweep(rig, env, config, resumed, &mut log);
    match &r {
        Ok(o) => {
            if let SweepEnd::Plateau { thrust_g } = o.end {
                log.comment(&format!("plateau: rotor maximum {thrust_g:.2} g"))?;
            }
            if let SweepEnd::SupplyLimited { step } = o.end {
                log.comment(&format!(
                    "supply current-limited at step {step}: row marked invalid, sweep backed off"
                ))?;
            }
            log.finish(match o.end {
                SweepEnd::SupplyLimited { .. } => "stopped: supply current-limited",
                _ => "complete",
            })?;
        }
        Err(e) => {
            let _ = log.finish(&format!("stopped: {e}"));
        }
    }
    r
}
