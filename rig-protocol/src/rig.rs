//! The contracts: what a rig can do ([`Rig`]) and what time it is ([`Clock`]).
//!
//! Hardware rigs (through [`crate::client::Client`] on a serial port), the simulated rig and
//! any test double implement [`Rig`]; code written against it cannot tell them apart.

use crate::message::{FaultReport, Identity, Sample, Status};

/// A monotonic clock in microseconds.
///
/// On a rig it is the rig clock (samples are stamped with it); on a host it is whatever the
/// host waits with. A simulator supplies a simulated clock that can run faster than real time.
pub trait Clock {
    /// Microseconds since an arbitrary fixed origin; never decreases.
    fn now_us(&self) -> u64;
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now_us(&self) -> u64 {
        (**self).now_us()
    }
}

/// Result of adding a calibration point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Fitted scale, grams per ADC count.
    pub scale_g_per_count: f32,
    /// Points in the fit.
    pub points: u8,
}

/// The host-side view of a thrust rig.
pub trait Rig {
    /// What can go wrong talking to the rig.
    type Error: core::fmt::Debug;

    /// Who the rig is.
    fn identify(&mut self) -> Result<Identity, Self::Error>;
    /// Arms the rig (clearing latched faults); throttle commands are refused until then.
    fn arm(&mut self) -> Result<(), Self::Error>;
    /// Disarms: output to minimum.
    fn disarm(&mut self) -> Result<(), Self::Error>;
    /// Zeros the load cell from the mean of `samples` readings; returns the offset in counts.
    fn tare(&mut self, samples: u16) -> Result<i32, Self::Error>;
    /// Adds a calibration point with `known_mass_g` on the load cell and refits the scale.
    fn calibrate(&mut self, known_mass_g: f32) -> Result<Calibration, Self::Error>;
    /// Sets the target ESC pulse width (the rig slews towards it).
    fn set_throttle(&mut self, throttle_us: u16) -> Result<(), Self::Error>;
    /// Starts streaming samples at `rate_hz`.
    fn start_stream(&mut self, rate_hz: u16) -> Result<(), Self::Error>;
    /// Stops streaming.
    fn stop_stream(&mut self) -> Result<(), Self::Error>;
    /// The next streamed sample, if one has arrived (does not wait long).
    fn next_sample(&mut self) -> Result<Option<Sample>, Self::Error>;
    /// The rig's status.
    fn status(&mut self) -> Result<Status, Self::Error>;
    /// The next fault report the rig sent, if any.
    fn take_fault(&mut self) -> Result<Option<FaultReport>, Self::Error>;
}
