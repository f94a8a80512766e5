//! When is a throttle step steady? Adaptive detection from the samples' statistics, or the
//! common stand default of a fixed dwell.
//!
//! [`SettleDetector`] takes the samples that follow a throttle command. With
//! [`SettlePolicy::Adaptive`] it waits until the output has reached the commanded throttle
//! (the firmware slews), then keeps a rolling window of the latest samples and declares the
//! step steady when, for thrust and for electrical power, the least-squares slope across the
//! window is indistinguishable from the noise (|slope| ≤ z · its standard error) or the drift
//! it implies across the window is below a resolution floor (a small fraction of the mean,
//! for channels much quieter than the accuracy asked of them). What is left of the transient
//! in that flat window would still bias its mean, so the measurement is a fresh window that
//! follows it, at least [`AdaptiveSettle::measure_s`] long and extended until the mean
//! power's standard error is small enough ([`AdaptiveSettle::power_precision`]) — short at
//! high power, longer for the noisy low-power steps. With [`SettlePolicy::FixedDwell`] it
//! waits a fixed time and averages a fixed number of samples, whatever the signal does.
//!
//! ```
//! use rig_host::settle::{SettleDetector, SettlePolicy};
//! use rig_protocol::Sample;
//!
//! // A first-order approach to 100 g (time constant 0.1 s), sampled at 200 Hz.
//! let mut detector = SettleDetector::new(SettlePolicy::default(), 1500);
//! let window = (0..2000)
//!     .find_map(|k| {
//!         let t = k as f64 * 0.005;
//!         let thrust = 100.0 * (1.0 - (-t / 0.1).exp());
//!         detector.push(Sample { time_us: (t * 1e6) as u64, thrust_g: thrust as f32,
//!                                current_a: (thrust / 80.0) as f32, voltage_v: 12.5,
//!                                throttle_us: 1500 })
//!     })
//!     .unwrap();
//! assert!(window.settle_s < 1.5);
//! assert!((window.power.mean / (100.0 / 80.0 * 12.5) - 1.0).abs() < 0.005);
//! ```

use std::collections::VecDeque;

use rig_protocol::Sample;

/// Adaptive steady-state detection (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveSettle {
    /// Span of the rolling window, s of rig time.
    pub window_s: f64,
    /// Fewest samples in the window.
    pub min_samples: usize,
    /// Slope significance: steady while |slope| ≤ `z` × its standard error.
    pub z: f64,
    /// Resolution floor: steady while the drift across the window is below this fraction of
    /// the window's mean (per channel) …
    pub relative_floor: f64,
    /// … or below this absolute thrust drift, g.
    pub thrust_floor_g: f64,
    /// Once the rolling window is flat, a fresh measurement window of at least this span
    /// is taken (so what is left of the transient in the flat window does not bias the
    /// mean), s …
    pub measure_s: f64,
    /// … and extended until the standard error of the mean power is at most this fraction
    /// of the mean …
    pub power_precision: f64,
    /// … or at most this many watts (for a motor at rest) …
    pub power_floor_w: f64,
    /// … or the window spans this long, s.
    pub max_window_s: f64,
}

impl Default for AdaptiveSettle {
    fn default() -> Self {
        Self {
            window_s: 0.25,
            min_samples: 16,
            z: 2.5,
            relative_floor: 0.002,
            thrust_floor_g: 0.1,
            measure_s: 0.2,
            power_precision: 0.0015,
            power_floor_w: 0.01,
            max_window_s: 2.0,
        }
    }
}

/// How a step's steady state is found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SettlePolicy {
    /// From the samples' statistics.
    Adaptive(AdaptiveSettle),
    /// Wait `dwell_s` after the command, then average `samples` samples (the common stand
    /// default is 3 s and 20 samples).
    FixedDwell {
        /// Wait after the throttle command, s of rig time.
        dwell_s: f64,
        /// Samples averaged.
        samples: usize,
    },
}

impl Default for SettlePolicy {
    fn default() -> Self {
        Self::Adaptive(AdaptiveSettle::default())
    }
}

impl SettlePolicy {
    /// The common stand default: 3 s settle, then 20 samples.
    pub const STAND_DEFAULT: SettlePolicy = SettlePolicy::FixedDwell {
        dwell_s: 3.0,
        samples: 20,
    };
}

/// Mean, spread and trend of one channel over a window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChannelStats {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 for one sample).
    pub std: f64,
    /// Least-squares slope, per second.
    pub slope_per_s: f64,
    /// Standard error of the slope, per second.
    pub slope_se_per_s: f64,
}

/// Statistics of `y` against time `t_s` (same length, at least one point).
pub fn channel_stats(t_s: &[f64], y: &[f64]) -> ChannelStats {
    let n = y.len().min(t_s.len());
    if n == 0 {
        return ChannelStats::default();
    }
    let nf = n as f64;
    let mean = y[..n].iter().sum::<f64>() / nf;
    let tm = t_s[..n].iter().sum::<f64>() / nf;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let dt = t_s[i] - tm;
        let dy = y[i] - mean;
        sxx += dt * dt;
        sxy += dt * dy;
        syy += dy * dy;
    }
    let std = if n > 1 {
        (syy / (nf - 1.0)).sqrt()
    } else {
        0.0
    };
    let (slope, se) = if n > 2 && sxx > 0.0 {
        let b = sxy / sxx;
        let resid = (syy - b * sxy).max(0.0) / (nf - 2.0);
        (b, (resid / sxx).sqrt())
    } else {
        (0.0, f64::INFINITY)
    };
    ChannelStats {
        mean,
        std,
        slope_per_s: slope,
        slope_se_per_s: se,
    }
}

/// A steady window: the samples and their statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// The samples of the window, oldest first.
    pub samples: Vec<Sample>,
    /// Thrust, g.
    pub thrust: ChannelStats,
    /// Current, A.
    pub current: ChannelStats,
    /// Voltage, V.
    pub voltage: ChannelStats,
    /// Electrical power (voltage × current per sample), W.
    pub power: ChannelStats,
    /// Rig time from the throttle command to the end of the window, s.
    pub settle_s: f64,
}

impl Window {
    /// A window over `samples` (non-empty), `settle_s` after the command.
    pub fn from_samples(samples: Vec<Sample>, settle_s: f64) -> Self {
        let t: Vec<f64> = samples.iter().map(|s| s.time_us as f64 * 1e-6).collect();
        let ch = |f: &dyn Fn(&Sample) -> f64| {
            let y: Vec<f64> = samples.iter().map(f).collect();
            channel_stats(&t, &y)
        };
        let thrust = ch(&|s| f64::from(s.thrust_g));
        let current = ch(&|s| f64::from(s.current_a));
        let voltage = ch(&|s| f64::from(s.voltage_v));
        let power = ch(&|s| f64::from(s.current_a) * f64::from(s.voltage_v));
        Self {
            samples,
            thrust,
            current,
            voltage,
            power,
            settle_s,
        }
    }

    /// Rig time of the window's first and last samples, µs.
    pub fn span_us(&self) -> (u64, u64) {
        (
            self.samples.first().map_or(0, |s| s.time_us),
            self.samples.last().map_or(0, |s| s.time_us),
        )
    }

    /// Whether a sample taken at `time_us` (rig time) falls within the window.
    pub fn contains(&self, time_us: u64) -> bool {
        let (a, b) = self.span_us();
        (a..=b).contains(&time_us)
    }
}

/// What a [`SettleDetector`] is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SettleState {
    /// The firmware is still slewing the output to the commanded throttle.
    Slewing,
    /// Filling or testing the rolling window (adaptive) or dwelling (fixed).
    Settling,
    /// Steady: the window is the measurement.
    Steady,
}

impl std::fmt::Display for SettleState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Slewing => "slewing",
            Self::Settling => "settling",
            Self::Steady => "steady",
        })
    }
}

/// Finds the steady state after one throttle command; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct SettleDetector {
    policy: SettlePolicy,
    throttle_us: u16,
    commanded_at_us: Option<u64>,
    last_us: u64,
    reached: bool,
    window: VecDeque<Sample>,
    state: SettleState,
    /// Adaptive: steady, now accumulating for precision.
    accumulating: bool,
}

impl SettleDetector {
    /// A detector for a step commanded to `throttle_us`; time starts at the first sample.
    pub fn new(policy: SettlePolicy, throttle_us: u16) -> Self {
        Self {
            policy,
            throttle_us,
            commanded_at_us: None,
            last_us: 0,
            reached: false,
            window: VecDeque::new(),
            state: SettleState::Slewing,
            accumulating: false,
        }
    }

    /// What the detector is doing.
    pub fn state(&self) -> SettleState {
        self.state
    }

    /// Rig time since the first sample after the command, s.
    pub fn elapsed_s(&self, now_us: u64) -> f64 {
        self.commanded_at_us
            .map_or(0.0, |t0| now_us.saturating_sub(t0) as f64 * 1e-6)
    }

    /// Rig time from the first sample after the command to the latest one, s (0 before
    /// the first sample). This is the clock a settle timeout runs on: a starved simulator
    /// slows rig time, not the physics.
    pub fn settling_for_s(&self) -> f64 {
        self.elapsed_s(self.last_us)
    }

    /// `Some(settling time)` once the step has been settling for longer than `timeout_s`
    /// of rig time ([`Self::settling_for_s`]) without becoming steady.
    pub fn timed_out(&self, timeout_s: f64) -> Option<f64> {
        let t = self.settling_for_s();
        (t > timeout_s && self.state != SettleState::Steady).then_some(t)
    }

    /// Takes the next sample; returns the measurement window once the step is steady.
    pub fn push(&mut self, s: Sample) -> Option<Window> {
        let t0 = *self.commanded_at_us.get_or_insert(s.time_us);
        self.last_us = s.time_us;
        let elapsed_s = s.time_us.saturating_sub(t0) as f64 * 1e-6;
        if self.reached && s.throttle_us != self.throttle_us {
            // The output left the commanded throttle (a fault cut it): start over.
            self.reached = false;
            self.accumulating = false;
            self.window.clear();
            self.state = SettleState::Slewing;
        }
        if !self.reached {
            if s.throttle_us != self.throttle_us {
                return None;
            }
            self.reached = true;
            self.state = SettleState::Settling;
        }
        match self.policy {
            SettlePolicy::FixedDwell { dwell_s, samples } => {
                if elapsed_s < dwell_s {
                    return None;
                }
                self.window.push_back(s);
                if self.window.len() >= samples.max(1) {
                    self.state = SettleState::Steady;
                    return Some(Window::from_samples(
                        self.window.drain(..).collect(),
                        elapsed_s,
                    ));
                }
                None
            }
            SettlePolicy::Adaptive(a) => {
                self.window.push_back(s);
                let span_us = |w: &VecDeque<Sample>| {
                    w.back().map_or(0, |b| b.time_us) - w.front().map_or(0, |f| f.time_us)
                };
                if self.accumulating {
                    let span_s = span_us(&self.window) as f64 * 1e-6;
                    if span_s < a.measure_s || self.window.len() < a.min_samples.max(3) {
                        return None;
                    }
                    let w = Window::from_samples(self.window.iter().copied().collect(), elapsed_s);
                    let se = w.power.std / (w.samples.len() as f64).sqrt();
                    let precise =
                        se <= (a.power_precision * w.power.mean.abs()).max(a.power_floor_w);
                    if precise || span_s >= a.max_window_s {
                        self.state = SettleState::Steady;
                        return Some(w);
                    }
                    return None;
                }
                let window_us = (a.window_s * 1e6) as u64;
                while self.window.len() > a.min_samples.max(2)
                    && self.window[self.window.len() - 1]
                        .time_us
                        .saturating_sub(self.window[1].time_us)
                        >= window_us
                {
                    self.window.pop_front();
                }
                if self.window.len() < a.min_samples.max(3) || span_us(&self.window) < window_us {
                    return None;
                }
                let w = Window::from_samples(self.window.iter().copied().collect(), elapsed_s);
                let span_s = span_us(&self.window) as f64 * 1e-6;
                let flat = |c: &ChannelStats, abs_floor: f64| {
                    let drift = (c.slope_per_s * span_s).abs();
                    c.slope_per_s.abs() <= a.z * c.slope_se_per_s
                        || drift <= (a.relative_floor * c.mean.abs()).max(abs_floor)
                };
                if flat(&w.thrust, a.thrust_floor_g) && flat(&w.power, a.power_floor_w) {
                    self.accumulating = true;
                    self.window.clear();
                }
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_s: f64, thrust: f64, throttle_us: u16) -> Sample {
        Sample {
            time_us: (t_s * 1e6) as u64,
            thrust_g: thrust as f32,
            current_a: (thrust / 10.0) as f32,
            voltage_v: 12.5,
            throttle_us,
        }
    }

    #[test]
    fn stats_of_a_line() {
        let t: Vec<f64> = (0..10).map(f64::from).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * t + 1.0).collect();
        let c = channel_stats(&t, &y);
        assert!((c.slope_per_s - 2.0).abs() < 1e-12);
        assert!((c.mean - 10.0).abs() < 1e-12);
        assert!(c.slope_se_per_s < 1e-6);
    }

    #[test]
    fn adaptive_waits_for_the_transient_and_the_slew() {
        let mut d = SettleDetector::new(SettlePolicy::default(), 1500);
        let mut steady_at = None;
        for k in 0..400 {
            let t = f64::from(k) * 0.0125;
            let thr = if t < 0.1 { 1400 } else { 1500 };
            let thrust = 100.0 * (1.0 - (-t / 0.15).exp());
            if let Some(w) = d.push(sample(t, thrust, thr)) {
                steady_at = Some((t, w));
                break;
            }
        }
        let (t, w) = steady_at.expect("settles");
        assert!(t > 0.6 && t < 2.0, "{t}");
        assert!((w.thrust.mean - 100.0).abs() < 0.3, "{:?}", w.thrust);
    }

    #[test]
    fn the_timeout_runs_on_rig_time_from_the_first_sample() {
        let mut d = SettleDetector::new(SettlePolicy::default(), 1500);
        assert_eq!(d.settling_for_s(), 0.0);
        assert_eq!(d.timed_out(0.5), None);
        // Never reaches the commanded throttle: slewing for ever.
        for k in 0..=100 {
            let t = 10.0 + f64::from(k) * 0.01;
            assert!(d.push(sample(t, 20.0, 1400)).is_none());
        }
        assert!((d.settling_for_s() - 1.0).abs() < 1e-6);
        assert_eq!(d.timed_out(1.5), None);
        let late = d.timed_out(0.5).expect("timed out");
        assert!((late - 1.0).abs() < 1e-6, "{late}");
    }

    #[test]
    fn a_window_knows_its_span() {
        let mut d = SettleDetector::new(SettlePolicy::STAND_DEFAULT, 1500);
        let w = (0..1000)
            .find_map(|k| d.push(sample(f64::from(k) * 0.0125, 50.0, 1500)))
            .unwrap();
        let (a, b) = w.span_us();
        assert_eq!((a, b), (w.samples[0].time_us, w.samples[19].time_us));
        assert!(w.contains(a) && w.contains(b) && !w.contains(a - 1) && !w.contains(b + 1));
        assert_eq!(d.timed_out(0.1), None, "a steady step does not time out");
    }

    #[test]
    fn fixed_dwell_takes_its_time() {
        let mut d = SettleDetector::new(SettlePolicy::STAND_DEFAULT, 1500);
        let mut done = None;
        for k in 0..1000 {
            let t = f64::from(k) * 0.0125;
            if let Some(w) = d.push(sample(t, 50.0, 1500)) {
                done = Some((t, w));
                break;
            }
        }
        let (t, w) = done.unwrap();
        assert!(t >= 3.0 + 19.0 * 0.0125 - 1e-9, "{t}");
        assert_eq!(w.samples.len(), 20);
    }
}
