//! How a sweep runs: what it steps through ([`SweepKind`]) and its settings
//! ([`SweepConfig`]), checked before the rig moves ([`SweepConfig::validate`]).

use std::time::Duration;

use crate::log::{LIMIT_COLUMNS, NOMINAL_COLUMNS};
use crate::settle::SettlePolicy;

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
