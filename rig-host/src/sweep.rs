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

use std::sync::atomic::AtomicBool;

use rig_protocol::{Clock, Identity, Rig};

use crate::bench_supply::SupplyControl;
use crate::error::HostError;
use crate::log::{StepRecord, SweepLog};
use crate::runner::Runner;

pub use crate::config::{SweepConfig, SweepKind};
pub use crate::error::{LinkError, safe_state};
pub use crate::events::{SweepEvent, SweepObserver};
pub use crate::header::sweep_header;
pub use crate::rig_ops::{MassPlacer, calibrate, disarm_clean, idle};
pub use crate::sink::{MemorySink, StepSink};

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
    let mut runner = Runner::new(rig, env, config);
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
            // The log's last line names the error and its causes.
            let why: Vec<String> =
                std::iter::successors(Some(e as &dyn std::error::Error), |c| c.source())
                    .map(ToString::to_string)
                    .collect();
            let _ = log.finish(&format!("stopped: {}", why.join(": ")));
        }
    }
    r
}
