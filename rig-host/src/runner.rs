//! The sweep runner: it only orchestrates. Set-points come from the pure
//! [`StepController`], steady state from [`SettleDetector`], the supply's mode at a window
//! from [`StatusMarks`]; the runner talks to the rig and the supply, recovers from host
//! timeouts, stops safely, and hands completed steps to the sink.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rig_protocol::{Clock, FaultCause, Identity, Rig};
use supply::RegulationMode;

use crate::bench_supply::{StatusMarks, SupplyControl, SupplyStatus};
use crate::config::{SweepConfig, SweepKind};
use crate::controller::{ControllerConfig, Decision, StepController};
use crate::error::{HostError, LinkError, SupplyLoss, rig_err};
use crate::events::{SweepEvent, SweepObserver};
use crate::log::{LoggedSample, StepRecord};
use crate::rig_ops::disarm_clean;
use crate::settle::{SettleDetector, Window};
use crate::sink::StepSink;
use crate::sweep::{SweepEnd, SweepEnv, SweepOutcome};

/// Host time without a single sample that ends a sweep, µs (of the host's clock). On a
/// simulated rig running faster than real time the host's clock is scaled too, so the same
/// time must also have passed on the wall ([`std::time::Instant`]): a loaded machine that
/// stalls the simulator for a second of wall time has not lost the rig.
const NO_SAMPLES_TIMEOUT_US: u64 = 5_000_000;

/// Runs one sweep on a connected rig; built by [`crate::sweep::run_sweep`].
pub(crate) struct Runner<'a, R: Rig> {
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

/// Which step an attempt belongs to.
#[derive(Debug, Clone, Copy)]
struct StepAt {
    /// Step number.
    step: usize,
    /// Thrust target of a nominal step, g.
    target_g: Option<f64>,
}

/// One settled throttle attempt.
struct Attempt {
    throttle_us: u16,
    window: Window,
    /// The supply's status when the measurement window began.
    supply_at_window: SupplyStatus,
}

impl<'a, R: Rig> Runner<'a, R>
where
    R::Error: LinkError,
{
    /// A runner for `config` on `rig`, with what [`SweepEnv`] gives it.
    pub(crate) fn new<'e: 'a>(rig: &'a mut R, env: SweepEnv<'e>, config: &SweepConfig) -> Self {
        let SweepEnv {
            clock,
            identity,
            supply,
            observer,
            stop,
        } = env;
        let now = clock.now_us();
        Self {
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
        }
    }

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
        let cause = if only_timeout {
            FaultCause::HostTimeout
        } else {
            st.faults
                .iter()
                .find(|&c| c != FaultCause::HostTimeout)
                .unwrap_or(cause)
        };
        // Reports of this fault still queued are the same event.
        while self
            .rig
            .take_fault()
            .map_err(rig_err("fault check"))?
            .is_some()
        {}
        // the status names the cause only, with no reading
        self.handle_fault(cause, None).map(|_| ())
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
        self.handle_fault(f.cause, Some((f.value, f.limit)))
    }

    /// A latched fault, with the reading and limit of its report when there is one.
    fn handle_fault(
        &mut self,
        cause: FaultCause,
        reading: Option<(f32, f32)>,
    ) -> Result<bool, HostError> {
        if cause == FaultCause::HostTimeout && self.recoveries < self.cfg.host_timeout_recoveries {
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
            cause,
            value: reading.map(|r| r.0),
            limit: reading.map(|r| r.1),
        })
    }

    /// Commands `throttle_us` and waits for steady state ([`SettleDetector`], which also
    /// keeps the settle timeout in rig time). Every sample goes to `log`, flagged when it
    /// is in the measurement window; a re-arm after a host timeout starts over.
    fn settle(
        &mut self,
        at: StepAt,
        throttle_us: u16,
        log: &mut Vec<LoggedSample>,
    ) -> Result<Attempt, HostError> {
        let StepAt { step, target_g } = at;
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
            let mut marks = StatusMarks::default();
            let mut last_sample_at = self.clock.now_us();
            let mut last_sample_wall = std::time::Instant::now();
            let mut thrust_g = None;
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
                        last_sample_wall = std::time::Instant::now();
                        self.first_sample_us.get_or_insert(s.time_us);
                        self.last_sample_us = s.time_us;
                        thrust_g = Some(f64::from(s.thrust_g));
                        marks.note(s.time_us, self.supply.status()?);
                        log.push(LoggedSample {
                            step,
                            attempt,
                            in_window: false,
                            sample: s,
                        });
                        if let Some(window) = det.push(s) {
                            for l in log.iter_mut().rev().take_while(|l| l.attempt == attempt) {
                                l.in_window |= window.contains(l.sample.time_us);
                            }
                            let supply_at_window = marks
                                .at(window.span_us().0)
                                .ok_or(HostError::SupplyLost(SupplyLoss::NoStatus))?;
                            return Ok(Attempt {
                                throttle_us,
                                window,
                                supply_at_window,
                            });
                        }
                    }
                    None if now.saturating_sub(last_sample_at) > NO_SAMPLES_TIMEOUT_US
                        && last_sample_wall.elapsed().as_micros()
                            > u128::from(NO_SAMPLES_TIMEOUT_US) =>
                    {
                        return Err(HostError::Timeout {
                            what: "no samples from the rig".into(),
                            seconds: NO_SAMPLES_TIMEOUT_US as f64 * 1e-6,
                        });
                    }
                    None => {}
                }
                if let Some(seconds) = det.timed_out(self.cfg.settle_timeout_s) {
                    return Err(HostError::Timeout {
                        what: format!("step {step} did not settle at {throttle_us} us"),
                        seconds,
                    });
                }
                if now.saturating_sub(self.last_progress_us) > 100_000 {
                    self.last_progress_us = now;
                    self.obs.event(SweepEvent::Progress {
                        step,
                        target_g,
                        throttle_us,
                        thrust_g,
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
            if let Some(mode) = self.supply.status()?.mode_since(before) {
                return Ok(mode);
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

    /// The log row of a settled attempt.
    fn record(at: StepAt, a: &Attempt, settle_s: f64, mode: RegulationMode) -> StepRecord {
        let w = &a.window;
        StepRecord {
            step: at.step,
            target_g: at.target_g,
            throttle_us: a.throttle_us,
            thrust_g: w.thrust.mean,
            thrust_std_g: Some(w.thrust.std),
            current_a: w.current.mean,
            current_std_a: Some(w.current.std),
            voltage_v: w.voltage.mean,
            voltage_std_v: Some(w.voltage.std),
            power_w: w.power.mean,
            power_std_w: Some(w.power.std),
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
        let at = StepAt {
            step,
            target_g: Some(target),
        };
        let mut control = StepController::new(self.controller(), target, history);
        let mut u = control.start();
        let mut best: Option<Attempt> = None;
        loop {
            let a = self.settle(at, u as u16, log)?;
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

    /// Throttle to minimum, disarm, stop the stream, supply off; errors are ignored (this
    /// runs after one).
    pub(crate) fn safe_stop(&mut self) {
        self.spin_down();
        let _ = self.rig.disarm();
        let _ = self.rig.stop_stream();
        let _ = self.supply.set_output(false);
    }

    /// Waits until a poll that started after now finds the supply regulating at its
    /// set-point.
    fn wait_supply(&mut self) -> Result<(), HostError> {
        let deadline = Instant::now() + self.cfg.supply_timeout;
        let before = self.supply.status()?;
        loop {
            let s = self.supply.status()?;
            if s.regulating_at(&before, self.cfg.voltage_v) {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(HostError::SupplyLost(SupplyLoss::NotRegulating {
                    voltage_v: self.cfg.voltage_v,
                    timeout: self.cfg.supply_timeout,
                    mode: s.mode,
                    measurement: s.measurement,
                }));
            }
            self.check()?;
            let _ = self
                .rig
                .take_fault()
                .map_err(rig_err("waiting for the supply"))?;
        }
    }

    /// The whole sweep: supply on, tare, arm, the steps, then a clean stop.
    pub(crate) fn run(
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
            let at = StepAt {
                step,
                target_g: Some(target),
            };
            let row = Self::record(at, &a, settle_s, mode);
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
            let at = StepAt {
                step,
                target_g: None,
            };
            let a = self.settle(at, u, &mut samples)?;
            let settle_s = self.clock.now_us().saturating_sub(t0) as f64 * 1e-6;
            let mode = self.supply_mode_since(&a.supply_at_window)?;
            let row = Self::record(at, &a, settle_s, mode);
            self.complete_step(row, &mut samples, rows, sink)?;
            if !row.valid {
                return Ok(SweepEnd::SupplyLimited { step });
            }
        }
        Ok(SweepEnd::Complete)
    }
}
