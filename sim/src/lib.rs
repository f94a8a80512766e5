//! # sim
//!
//! A physics-backed simulated thrust rig (paper section III-C) that a host cannot tell from
//! the real one: the real `rig-firmware` core and drivers run against simulated peripherals
//! (a bit-banged HX711, an INA226 on I²C, an ESC PWM channel) over a simulated bench, on a
//! simulated clock that can run faster than real time.
//!
//! Main types:
//! - [`physics::Propulsion`]: motor–propeller–ESC with a mechanical time constant, fed by a
//!   [`physics::Supply`] whose voltage sags under load; thrust and current follow throttle
//!   and bus voltage physically;
//! - [`world::World`]: the bench — physics plus load-cell (noise, creep, quantisation) and
//!   current/voltage sensor (noise, offsets) models;
//! - [`presets`]: `paper` (calibrated to land on the paper's targets, not physical),
//!   `paper-physical` (the same platform from physical values) and `ctu-2312-9450` (a real
//!   motor from physical values and the CTU-MRS table);
//! - [`SimRig`]: the firmware on the simulated bench; [`SimRig::into_client`] gives an
//!   in-process [`rig_protocol::Client`] (a [`rig_protocol::Rig`]) that runs in simulated time;
//! - [`pty::PtyRig`]: the same behind a real pseudo-terminal (`hoverbench sim-rig`), with
//!   [`pty::HostPort`], [`pty::WallClock`] and [`pty::CorruptingProxy`] for hosts and tests.
//!
//! ```
//! use rig_protocol::{ClientConfig, Rig};
//!
//! let rig = sim::SimRig::new(&sim::presets::paper(), 1).unwrap();
//! let mut host = rig.into_client(ClientConfig::default());
//! host.handshake().unwrap();
//! host.arm().unwrap();
//! host.start_stream(100).unwrap();
//! host.set_throttle(1500).unwrap();
//! let mut last = None;
//! use sim::ClientClockExt;
//! while host.clock_now_us() < 3_000_000 {
//!     if let Some(s) = host.next_sample().unwrap() { last = Some(s); }
//! }
//! let s = last.unwrap();
//! assert!(s.throttle_us == 1500 && s.current_a > 0.5 && (12.0..12.6).contains(&s.voltage_v));
//! ```
pub mod noise;
pub mod peripherals;
pub mod physics;
pub mod presets;
pub mod pty;
pub mod rig;
pub mod world;

pub use presets::Preset;
pub use rig::{SimLink, SimRig};

/// Simulated time of a host connected through [`SimRig::into_client`].
pub trait ClientClockExt {
    /// The host's clock, µs.
    fn clock_now_us(&self) -> u64;
}

impl<T: rig_protocol::Transport, C: rig_protocol::Clock> ClientClockExt
    for rig_protocol::Client<T, C>
{
    fn clock_now_us(&self) -> u64 {
        self.clock().now_us()
    }
}
