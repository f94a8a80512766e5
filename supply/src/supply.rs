//! The contract: what a programmable bench supply can do ([`Supply`]).

use crate::error::SupplyError;

/// How the output is regulated at the moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RegulationMode {
    /// Constant voltage: the load draws less than the current limit.
    ConstantVoltage,
    /// Constant current: the load would draw more than the limit, so the supply lowers its
    /// output voltage until the current equals the limit. Samples taken like this are not at
    /// the set voltage (the sweep marks them `valid = false`).
    ConstantCurrent,
    /// Neither (SCPI `UR`, e.g. while the output settles or is overloaded).
    Unregulated,
    /// The output is switched off.
    Off,
}

impl RegulationMode {
    /// Whether the output is at its set voltage (constant-voltage regulation).
    pub fn is_constant_voltage(self) -> bool {
        self == Self::ConstantVoltage
    }
}

/// One reading of the output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Output voltage, V.
    pub voltage_v: f64,
    /// Output current, A.
    pub current_a: f64,
}

impl Measurement {
    /// Output power, W.
    pub fn power_w(&self) -> f64 {
        self.voltage_v * self.current_a
    }
}

/// The host-side view of a programmable bench supply, one channel of it.
///
/// Implemented by [`crate::ScpiSupply`] (Rigol/Siglent-style SCPI), [`crate::KoradSupply`]
/// (Korad/Tenma KA3005P) and any test double. It is **object-safe** and uses one concrete
/// error type, [`SupplyError`], so code that drives a rig can hold a `Box<dyn Supply>` chosen
/// at run time from a configuration file; the drivers are generic over their transport, the
/// trait is not.
///
/// Setters return once the supply has taken the setting (drivers can read it back and retry,
/// see their configurations); they do not wait for the output to settle.
pub trait Supply {
    /// The instrument's identification string (`*IDN?`), trimmed.
    fn identify(&mut self) -> Result<String, SupplyError>;
    /// Sets the output voltage set-point, V.
    fn set_voltage(&mut self, voltage_v: f64) -> Result<(), SupplyError>;
    /// Sets the current limit, A.
    fn set_current_limit(&mut self, current_a: f64) -> Result<(), SupplyError>;
    /// Switches the output on or off.
    fn set_output(&mut self, on: bool) -> Result<(), SupplyError>;
    /// Measures the output voltage and current.
    fn measure(&mut self) -> Result<Measurement, SupplyError>;
    /// The regulation mode; [`RegulationMode::Off`] when the output is off.
    fn mode(&mut self) -> Result<RegulationMode, SupplyError>;

    /// Sets the voltage and then the current limit.
    fn apply(&mut self, voltage_v: f64, current_limit_a: f64) -> Result<(), SupplyError> {
        self.set_voltage(voltage_v)?;
        self.set_current_limit(current_limit_a)
    }
    /// Measures the output voltage, V.
    fn measure_voltage(&mut self) -> Result<f64, SupplyError> {
        self.measure().map(|m| m.voltage_v)
    }
    /// Measures the output current, A.
    fn measure_current(&mut self) -> Result<f64, SupplyError> {
        self.measure().map(|m| m.current_a)
    }
}

/// Forwards every [`Supply`] method through a pointer to a supply.
macro_rules! forward_supply {
    ($($pointer:ty),*) => {$(
        impl<S: Supply + ?Sized> Supply for $pointer {
            fn identify(&mut self) -> Result<String, SupplyError> {
                (**self).identify()
            }
            fn set_voltage(&mut self, voltage_v: f64) -> Result<(), SupplyError> {
                (**self).set_voltage(voltage_v)
            }
            fn set_current_limit(&mut self, current_a: f64) -> Result<(), SupplyError> {
                (**self).set_current_limit(current_a)
            }
            fn set_output(&mut self, on: bool) -> Result<(), SupplyError> {
                (**self).set_output(on)
            }
            fn measure(&mut self) -> Result<Measurement, SupplyError> {
                (**self).measure()
            }
            fn mode(&mut self) -> Result<RegulationMode, SupplyError> {
                (**self).mode()
            }
            fn apply(&mut self, voltage_v: f64, current_limit_a: f64) -> Result<(), SupplyError> {
                (**self).apply(voltage_v, current_limit_a)
            }
        }
    )*};
}

forward_supply!(&mut S, Box<S>);

/// Sends a setting with `send`, then (when `verify`) reads it back with `check` — `None` when it
/// took, else what was read — and sends it again until it took, at most `attempts` times.
/// Shared by the instrument drivers.
pub(crate) fn send_until_applied<D>(
    dev: &mut D,
    command: &str,
    attempts: u32,
    verify: bool,
    send: impl Fn(&mut D) -> Result<(), SupplyError>,
    check: impl Fn(&mut D) -> Result<Option<String>, SupplyError>,
) -> Result<(), SupplyError> {
    let mut readback = String::new();
    for _ in 0..attempts {
        send(dev)?;
        if !verify {
            return Ok(());
        }
        match check(dev)? {
            None => return Ok(()),
            Some(r) => readback = r,
        }
    }
    Err(SupplyError::NotApplied {
        command: command.to_owned(),
        readback,
        attempts,
    })
}
