//! # rig-firmware
//!
//! The firmware core of a thrust rig (paper section III-C): a load cell, a current/voltage
//! monitor and an ESC, sampled together and time-stamped by the rig clock, behind the
//! [`rig_protocol`] wire protocol, with safety owned by the firmware. `#![no_std]` and
//! allocation-free; runs on a microcontroller, on a Linux single-board computer and on the
//! simulated peripherals of the `sim` crate.
//!
//! Main types:
//! - [`Firmware`]: protocol handling, sampling loop and safety state machine ([`Config`]
//!   holds the board's limits and timing);
//! - the peripheral seams [`LoadCellAdc`], [`PowerMonitor`], [`ThrottleOutput`] and
//!   [`Watchdog`], implemented by the embedded-hal drivers in [`drivers`]:
//!   [`drivers::hx711::Hx711`] (bit-banged 24-bit ADC), [`drivers::ina226::Ina226`] (I²C
//!   current/voltage monitor), [`drivers::esc::Esc`] (1000–2000 µs PWM) and
//!   [`drivers::clock::MonotonicClock`];
//! - [`loadcell::LoadCell`]: tare and multi-point calibration.
//!
//! ```
//! use core::cell::Cell;
//! use rig_firmware::{Config, Firmware, LoadCellAdc, NoWatchdog, PowerMonitor, PowerReading, ThrottleOutput};
//! use rig_protocol::{frame::{encode_frame, Decoder}, Clock, Message, PROTOCOL_VERSION};
//!
//! struct Adc; impl LoadCellAdc for Adc { type Error = (); fn try_read_raw(&mut self) -> Result<Option<i32>, ()> { Ok(Some(0)) } }
//! struct Ina; impl PowerMonitor for Ina { type Error = (); fn read(&mut self) -> Result<PowerReading, ()> { Ok(PowerReading { voltage_v: 12.5, current_a: 0.1 }) } }
//! struct Esc; impl ThrottleOutput for Esc { type Error = (); fn set_throttle_us(&mut self, _: u16) -> Result<(), ()> { Ok(()) } }
//! struct Clk(Cell<u64>); impl Clock for Clk { fn now_us(&self) -> u64 { self.0.get() } }
//!
//! let clock = Clk(Cell::new(0));
//! let mut fw = Firmware::new(Adc, Ina, Esc, &clock, NoWatchdog, Config::default());
//! let mut to_host = Vec::new();
//! let mut wire = [0u8; 64];
//! for (seq, m) in [(1, Message::Hello { protocol_version: PROTOCOL_VERSION }), (2, Message::StartStream { rate_hz: 100 })] {
//!     let n = encode_frame(seq, &m, &mut wire).unwrap();
//!     fw.receive(&wire[..n], &mut |b: &[u8]| to_host.extend_from_slice(b));
//! }
//! for t in 0..50 { clock.0.set(t * 1000); fw.tick(&mut |b: &[u8]| to_host.extend_from_slice(b)); }
//! let mut dec = Decoder::new();
//! let samples = to_host.iter().filter_map(|&b| dec.push(b)).filter(|f| matches!(f, Ok(f) if matches!(f.message, Message::Sample(_)))).count();
//! assert_eq!(samples, 5); // 100 Hz for 50 ms
//! ```
//!
//! ## Building for a microcontroller
//!
//! The crate has no std in its dependency tree (`cargo tree -p rig-firmware -e normal`).
//! For a Cortex-M4F: `rustup target add thumbv7em-none-eabihf` and
//! `cargo build -p rig-firmware --target thumbv7em-none-eabihf`; for an RP2040:
//! `thumbv6m-none-eabi`. A board crate provides the HAL pins, I²C and PWM, a monotonic
//! counter for [`drivers::clock::MonotonicClock`], a [`Watchdog`] and the serial port, and
//! runs `fw.receive(..)` / `fw.tick(..)` in its main loop.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod core;
pub mod drivers;
pub mod loadcell;

pub use crate::core::{Config, Firmware, FirmwareStats};

/// A load-cell ADC that delivers raw conversions when they are ready.
pub trait LoadCellAdc {
    /// Driver error.
    type Error: ::core::fmt::Debug;
    /// A raw reading if a conversion is ready; never blocks.
    fn try_read_raw(&mut self) -> Result<Option<i32>, Self::Error>;
}

/// A supply voltage and current reading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PowerReading {
    /// Bus voltage, V.
    pub voltage_v: f32,
    /// Supply current, A.
    pub current_a: f32,
}

/// A current/voltage monitor.
pub trait PowerMonitor {
    /// Driver error.
    type Error: ::core::fmt::Debug;
    /// Reads bus voltage and current.
    fn read(&mut self) -> Result<PowerReading, Self::Error>;
}

/// The motor's ESC.
pub trait ThrottleOutput {
    /// Driver error.
    type Error: ::core::fmt::Debug;
    /// Outputs a pulse width, µs.
    fn set_throttle_us(&mut self, throttle_us: u16) -> Result<(), Self::Error>;
}

/// The board's hardware watchdog, fed once per main-loop pass.
pub trait Watchdog {
    /// Feeds the watchdog.
    fn feed(&mut self);
}

/// For boards without a watchdog.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoWatchdog;

impl Watchdog for NoWatchdog {
    fn feed(&mut self) {}
}
