//! # supply
//!
//! The programmable bench supply of the thrust rig (section III-C of the paper: a high-current
//! DC supply regulates the input power; the sweep at the minimum battery voltage gives the
//! thrust limit). Host side only; std.
//!
//! Main types:
//! - [`Supply`]: the contract — set voltage and current limit, switch the output, measure
//!   voltage and current, read the [`RegulationMode`] (CV / CC / off), identify. Object-safe
//!   with one error type, [`SupplyError`], whose variants carry the command, the reply, the
//!   timeout and the attempt count.
//! - Drivers over any [`Transport`] (a serial port from [`open_serial`], a pseudo-terminal, an
//!   in-memory link): [`ScpiSupply`] for Rigol/Siglent-style SCPI, [`KoradSupply`] for the
//!   Korad/Tenma KA3005P dialect with its unterminated replies, raw status byte and command
//!   pacing. Both time out, retry a bounded number of times and read settings back.
//! - [`parse`]: the reply parsers, which never panic on any bytes.
//! - [`sim`]: a simulated supply speaking both dialects — set-point, current limit with
//!   constant-current mode, output switch, source resistance, a pluggable [`sim::Load`] — on a
//!   real pseudo-terminal ([`sim::SimulatedSupply`]) or in memory
//!   ([`sim::InProcessTransport`]).
//!
//! ```
//! use supply::sim::{Device, Dialect, ResistiveLoad, SimConfig};
//! use supply::{RegulationMode, ScpiConfig, ScpiSupply, Supply};
//!
//! // A 4 Ω load on a simulated SCPI supply, reached in memory.
//! let sim = Device::new(Dialect::Scpi, ResistiveLoad { resistance_ohm: 4.0 }, SimConfig::default());
//! let mut psu = ScpiSupply::new(sim.connect(), ScpiConfig::default());
//! assert!(psu.identify()?.starts_with("RIGOL"));
//! psu.apply(12.0, 5.0)?;
//! psu.set_output(true)?;
//! let m = psu.measure()?;
//! assert_eq!((m.voltage_v, m.current_a), (12.0, 3.0));
//! assert_eq!(psu.mode()?, RegulationMode::ConstantVoltage);
//!
//! // Below the 3 A it would draw, the limit holds: constant current at 2 A × 4 Ω = 8 V.
//! psu.set_current_limit(2.0)?;
//! assert_eq!(psu.mode()?, RegulationMode::ConstantCurrent);
//! assert_eq!(psu.measure()?.voltage_v, 8.0);
//! # Ok::<(), supply::SupplyError>(())
//! ```
//!
//! On a real port, `ScpiSupply::open("/dev/ttyUSB0", SerialSettings::default(),
//! ScpiConfig::default())`; in tests, the same on [`sim::SimulatedSupply::port_path`].

mod error;
pub mod korad;
mod link;
pub mod parse;
pub mod scpi;
pub mod sim;
mod supply;
mod transport;

pub use error::{Bytes, ReplyError, SupplyError};
pub use korad::{KoradConfig, KoradSupply};
pub use link::Timing;
pub use parse::KoradStatus;
pub use scpi::{ScpiConfig, ScpiSupply};
pub use supply::{Measurement, RegulationMode, Supply};
pub use transport::{SerialSettings, Transport, open_serial};
