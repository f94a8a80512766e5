//! Driver for SCPI bench supplies (Rigol DP800 style; Siglent's `:APPL`-capable models alike).
//!
//! | operation | command | reply |
//! | --- | --- | --- |
//! | identify | `*IDN?` | `RIGOL TECHNOLOGIES,DP832,…` |
//! | set voltage and limit | `:APPL CH1,12.5,5` | — |
//! | read set-points | `:APPL? CH1` | `CH1:30V/5A,12.500,5.000` |
//! | output switch | `:OUTP CH1,ON` / `:OUTP CH1,OFF` | — |
//! | output state | `:OUTP? CH1` | `ON` / `OFF` |
//! | measure | `:MEAS:ALL? CH1` | `12.500,1.234,15.425` (V, A, W) |
//! | regulation mode | `:OUTP:MODE? CH1` | `CV` / `CC` / `UR` |
//!
//! Every command and reply ends in `\n`. `:APPL` sets voltage and current limit together, so
//! the driver remembers the set-points (reading them with `:APPL?` the first time) to change
//! one of them.

use std::time::Duration;

use serialport::SerialPort;

use crate::error::SupplyError;
use crate::link::{Link, ReplyEnd, Timing, check_range};
use crate::parse;
use crate::supply::{Measurement, RegulationMode, Supply};
use crate::transport::{SerialSettings, Transport, open_serial};

/// Configuration of a [`ScpiSupply`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScpiConfig {
    /// Timeouts, retries and pacing.
    pub timing: Timing,
    /// Output channel, 1-based (`CH1`).
    pub channel: u8,
    /// Read every setting back (`:APPL?`, `:OUTP?`) and send it again if it did not take.
    pub verify_settings: bool,
    /// Largest voltage set-point the driver sends, V (a guard for the rig, not the
    /// instrument's rating).
    pub max_voltage_v: f64,
    /// Largest current limit the driver sends, A.
    pub max_current_a: f64,
    /// Voltage set-point resolution of the instrument, V: a read-back this close to what was
    /// sent counts as taken.
    pub resolution_v: f64,
    /// Current-limit resolution of the instrument, A.
    pub resolution_a: f64,
}

impl Default for ScpiConfig {
    fn default() -> Self {
        Self {
            timing: Timing {
                reply_timeout: Duration::from_millis(1000),
                retries: 2,
                pacing: Duration::ZERO,
                quiet_gap: Duration::from_millis(20),
            },
            channel: 1,
            verify_settings: true,
            max_voltage_v: 30.0,
            max_current_a: 5.0,
            resolution_v: 0.01,
            resolution_a: 0.001,
        }
    }
}

/// Formats a set-point with at most three decimals and no trailing zeros (`12.5`, `5`).
fn scpi_number(x: f64) -> String {
    let r = (x * 1000.0).round() / 1000.0;
    format!("{}", r + 0.0) // + 0.0 turns -0 into 0
}

/// A SCPI bench supply over a [`Transport`]; see the [module docs](self).
pub struct ScpiSupply<T> {
    link: Link<T>,
    config: ScpiConfig,
    setpoints: Option<(f64, f64)>,
}

impl ScpiSupply<Box<dyn SerialPort>> {
    /// Opens the serial port at `path` and drives the supply on it.
    pub fn open(
        path: &str,
        settings: SerialSettings,
        config: ScpiConfig,
    ) -> Result<Self, SupplyError> {
        Ok(Self::new(open_serial(path, settings)?, config))
    }
}

impl<T: Transport> ScpiSupply<T> {
    /// A driver on `transport` (nothing is sent yet).
    pub fn new(transport: T, config: ScpiConfig) -> Self {
        Self {
            link: Link::new(transport, config.timing),
            config,
            setpoints: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ScpiConfig {
        &self.config
    }

    /// The transport.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.link.transport
    }

    /// The transport, giving up the driver.
    pub fn into_inner(self) -> T {
        self.link.transport
    }

    fn query<R>(
        &mut self,
        command: &str,
        parse: impl Fn(&[u8]) -> Result<R, crate::ReplyError>,
    ) -> Result<R, SupplyError> {
        self.link.query(command, b"\n", ReplyEnd::Line, parse)
    }

    /// The voltage and current-limit set-points, `(V, A)`, read from the supply (`:APPL?`).
    pub fn setpoints(&mut self) -> Result<(f64, f64), SupplyError> {
        let cmd = format!(":APPL? CH{}", self.config.channel);
        let sp = self.query(&cmd, parse::scpi_applied)?;
        self.setpoints = Some(sp);
        Ok(sp)
    }

    /// Whether the output is on (`:OUTP?`).
    pub fn output_on(&mut self) -> Result<bool, SupplyError> {
        let cmd = format!(":OUTP? CH{}", self.config.channel);
        self.query(&cmd, parse::scpi_output_state)
    }

    /// Sends a setting, then (if configured) reads it back with `check` — `None` when it took,
    /// else a description of what was read — and sends it again until it took.
    fn set_checked(
        &mut self,
        command: &str,
        check: impl Fn(&mut Self) -> Result<Option<String>, SupplyError>,
    ) -> Result<(), SupplyError> {
        let attempts = self.config.timing.retries.saturating_add(1);
        let verify = self.config.verify_settings;
        crate::supply::send_until_applied(
            self,
            command,
            attempts,
            verify,
            |d| d.link.send(command, b"\n"),
            check,
        )
    }

    fn apply_both(&mut self, voltage_v: f64, current_a: f64) -> Result<(), SupplyError> {
        check_range("voltage_v", voltage_v, self.config.max_voltage_v)?;
        check_range("current_limit_a", current_a, self.config.max_current_a)?;
        let (v, i) = (scpi_number(voltage_v), scpi_number(current_a));
        let cmd = format!(":APPL CH{},{v},{i}", self.config.channel);
        let (want_v, want_i) = (
            v.parse().unwrap_or(voltage_v),
            i.parse().unwrap_or(current_a),
        );
        let (tol_v, tol_i) = (self.config.resolution_v, self.config.resolution_a);
        self.set_checked(&cmd, |s| {
            let (rv, ri) = s.setpoints()?;
            let ok = (rv - want_v).abs() <= tol_v + 1e-9 && (ri - want_i).abs() <= tol_i + 1e-9;
            Ok((!ok).then(|| format!("{rv} V, {ri} A")))
        })?;
        self.setpoints = Some((want_v, want_i));
        Ok(())
    }

    fn known_setpoints(&mut self) -> Result<(f64, f64), SupplyError> {
        match self.setpoints {
            Some(sp) => Ok(sp),
            None => self.setpoints(),
        }
    }
}

impl<T: Transport> Supply for ScpiSupply<T> {
    fn identify(&mut self) -> Result<String, SupplyError> {
        self.query("*IDN?", parse::identity)
    }

    fn set_voltage(&mut self, voltage_v: f64) -> Result<(), SupplyError> {
        check_range("voltage_v", voltage_v, self.config.max_voltage_v)?;
        let (_, i) = self.known_setpoints()?;
        self.apply_both(voltage_v, i)
    }

    fn set_current_limit(&mut self, current_a: f64) -> Result<(), SupplyError> {
        check_range("current_limit_a", current_a, self.config.max_current_a)?;
        let (v, _) = self.known_setpoints()?;
        self.apply_both(v, current_a)
    }

    fn apply(&mut self, voltage_v: f64, current_limit_a: f64) -> Result<(), SupplyError> {
        self.apply_both(voltage_v, current_limit_a)
    }

    fn set_output(&mut self, on: bool) -> Result<(), SupplyError> {
        let cmd = format!(
            ":OUTP CH{},{}",
            self.config.channel,
            if on { "ON" } else { "OFF" }
        );
        self.set_checked(&cmd, |s| {
            let state = s.output_on()?;
            Ok((state != on).then(|| if state { "ON" } else { "OFF" }.to_owned()))
        })
    }

    fn measure(&mut self) -> Result<Measurement, SupplyError> {
        let cmd = format!(":MEAS:ALL? CH{}", self.config.channel);
        self.query(&cmd, parse::scpi_measure_all)
    }

    fn mode(&mut self) -> Result<RegulationMode, SupplyError> {
        if !self.output_on()? {
            return Ok(RegulationMode::Off);
        }
        let cmd = format!(":OUTP:MODE? CH{}", self.config.channel);
        self.query(&cmd, parse::scpi_mode)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_points_are_formatted_briefly() {
        assert_eq!(scpi_number(12.5), "12.5");
        assert_eq!(scpi_number(5.0), "5");
        assert_eq!(scpi_number(0.0), "0");
        assert_eq!(scpi_number(1.23456), "1.235");
    }
}
