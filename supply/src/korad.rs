//! Driver for Korad/Tenma KA3005P-style supplies (and the many rebadged clones).
//!
//! | operation | command | reply (unterminated) |
//! | --- | --- | --- |
//! | identify | `*IDN?` | `KORAD KA3005P V5.8 SN:…` (any length: read until a quiet gap) |
//! | set voltage | `VSET1:12.50` | — |
//! | set current limit | `ISET1:5.000` | — |
//! | read set-points | `VSET1?` / `ISET1?` | `12.50` / `5.000` (5 bytes) |
//! | output switch | `OUT1` / `OUT0` | — |
//! | measure | `VOUT1?` then `IOUT1?` | `12.50` / `1.234` (5 bytes each) |
//! | status | `STATUS?` | **one raw byte**, see [`KoradStatus`] |
//!
//! Commands carry no terminator and replies none either: a reply is complete when it has its
//! expected length or nothing more arrived for [`Timing::quiet_gap`]. The instrument drops a
//! command that follows the previous exchange too closely, so the driver waits
//! [`Timing::pacing`] (60 ms by default) between exchanges, and by default reads every
//! setting back and sends it again if it did not take. A measurement is two queries, so its
//! voltage and current are some 100 ms apart.

use std::time::Duration;

use serialport::SerialPort;

use crate::error::SupplyError;
use crate::link::{Link, ReplyEnd, Timing, check_range};
use crate::parse::{self, KoradStatus};
use crate::supply::{Measurement, RegulationMode, Supply};
use crate::transport::{SerialSettings, Transport, open_serial};

/// Width of a numeric reply (`12.50`, `1.234`).
const NUMBER_REPLY_LEN: usize = 5;

/// Configuration of a [`KoradSupply`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KoradConfig {
    /// Timeouts, retries, pacing and the quiet gap that ends an unterminated reply.
    pub timing: Timing,
    /// Output channel, 1-based (the KA3005P has one).
    pub channel: u8,
    /// Read every setting back (`VSET1?`, `ISET1?`, `STATUS?`) and send it again if it did not
    /// take.
    pub verify_settings: bool,
    /// Largest voltage set-point the driver sends, V.
    pub max_voltage_v: f64,
    /// Largest current limit the driver sends, A.
    pub max_current_a: f64,
}

impl Default for KoradConfig {
    fn default() -> Self {
        Self {
            timing: Timing {
                reply_timeout: Duration::from_millis(500),
                retries: 2,
                pacing: Duration::from_millis(60),
                quiet_gap: Duration::from_millis(30),
            },
            channel: 1,
            verify_settings: true,
            max_voltage_v: 30.0,
            max_current_a: 5.0,
        }
    }
}

/// A Korad/Tenma supply over a [`Transport`]; see the [module docs](self).
pub struct KoradSupply<T> {
    link: Link<T>,
    config: KoradConfig,
}

impl KoradSupply<Box<dyn SerialPort>> {
    /// Opens the serial port at `path` (9600 baud for a KA3005P) and drives the supply on it.
    pub fn open(
        path: &str,
        settings: SerialSettings,
        config: KoradConfig,
    ) -> Result<Self, SupplyError> {
        Ok(Self::new(open_serial(path, settings)?, config))
    }
}

impl<T: Transport> KoradSupply<T> {
    /// A driver on `transport` (nothing is sent yet).
    pub fn new(transport: T, config: KoradConfig) -> Self {
        Self {
            link: Link::new(transport, config.timing),
            config,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &KoradConfig {
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

    fn query_number(&mut self, command: &str) -> Result<f64, SupplyError> {
        self.link.query(
            command,
            b"",
            ReplyEnd::Length(NUMBER_REPLY_LEN),
            parse::korad_number,
        )
    }

    /// The raw status byte (`STATUS?`).
    pub fn status(&mut self) -> Result<KoradStatus, SupplyError> {
        self.link
            .query("STATUS?", b"", ReplyEnd::Length(1), parse::korad_status)
    }

    /// The voltage set-point, V (`VSET1?`).
    pub fn voltage_setpoint(&mut self) -> Result<f64, SupplyError> {
        let cmd = format!("VSET{}?", self.config.channel);
        self.query_number(&cmd)
    }

    /// The current limit, A (`ISET1?`).
    pub fn current_limit(&mut self) -> Result<f64, SupplyError> {
        let cmd = format!("ISET{}?", self.config.channel);
        self.query_number(&cmd)
    }

    /// Sends a setting, then (if configured) reads it back with `check` — `None` when it took,
    /// else what was read — and sends it again until it took.
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
            |d| d.link.send(command, b""),
            check,
        )
    }
}

impl<T: Transport> Supply for KoradSupply<T> {
    fn identify(&mut self) -> Result<String, SupplyError> {
        self.link
            .query("*IDN?", b"", ReplyEnd::Quiet, parse::identity)
    }

    fn set_voltage(&mut self, voltage_v: f64) -> Result<(), SupplyError> {
        check_range("voltage_v", voltage_v, self.config.max_voltage_v)?;
        let value = format!("{voltage_v:05.2}");
        let sent: f64 = value.parse().unwrap_or(voltage_v);
        let cmd = format!("VSET{}:{value}", self.config.channel);
        self.set_checked(&cmd, |s| {
            let r = s.voltage_setpoint()?;
            Ok(((r - sent).abs() > 0.005).then(|| format!("{r} V")))
        })
    }

    fn set_current_limit(&mut self, current_a: f64) -> Result<(), SupplyError> {
        check_range("current_limit_a", current_a, self.config.max_current_a)?;
        let value = format!("{current_a:.3}");
        let sent: f64 = value.parse().unwrap_or(current_a);
        let cmd = format!("ISET{}:{value}", self.config.channel);
        self.set_checked(&cmd, |s| {
            let r = s.current_limit()?;
            Ok(((r - sent).abs() > 0.0005).then(|| format!("{r} A")))
        })
    }

    fn set_output(&mut self, on: bool) -> Result<(), SupplyError> {
        let cmd = if on { "OUT1" } else { "OUT0" };
        self.set_checked(cmd, |s| {
            let st = s.status()?;
            Ok((st.output_on() != on).then(|| format!("status {:#04x}", st.0)))
        })
    }

    fn measure(&mut self) -> Result<Measurement, SupplyError> {
        let v_cmd = format!("VOUT{}?", self.config.channel);
        let i_cmd = format!("IOUT{}?", self.config.channel);
        let voltage_v = self.query_number(&v_cmd)?;
        let current_a = self.query_number(&i_cmd)?;
        Ok(Measurement {
            voltage_v,
            current_a,
        })
    }

    fn mode(&mut self) -> Result<RegulationMode, SupplyError> {
        self.status().map(KoradStatus::mode)
    }
}
