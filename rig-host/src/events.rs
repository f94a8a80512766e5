//! What a sweep reports while it runs ([`SweepEvent`]) and who hears it
//! ([`SweepObserver`]); the library never prints, the binary renders these.

use crate::config::SweepKind;
use crate::log::StepRecord;
use crate::settle::SettleState;

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
        /// Latest thrust, g (`None` before the first sample of the attempt).
        thrust_g: Option<f64>,
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
