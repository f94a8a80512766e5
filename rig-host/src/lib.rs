//! # rig-host
//!
//! The host half of the thrust rig (section III-C of the paper): drive a programmable bench
//! supply and the rig, take thrust, current and voltage at every 10 g thrust increment at the
//! nominal voltage, repeat at the minimum battery voltage for the thrust limit, fit, and emit
//! parameters. Nothing else in hoverbench touches a serial port.
//!
//! Main types:
//! - [`link::SerialLink`] (the rig's [`rig_protocol::Transport`] over `serialport`),
//!   [`link::ScaledClock`] (host time in rig time for a faster-than-real-time simulator),
//!   [`link::list_ports`] (serial ports with USB ids);
//! - [`bench_supply::SupplyMonitor`]: a bench-supply driver on its own thread that carries
//!   out settings and polls the regulation mode, so every step knows whether the supply was
//!   current-limiting ([`bench_supply::SupplyControl`]);
//! - [`settle::SettleDetector`]: steady state from the samples' statistics (rolling mean and
//!   slope against the noise), or a fixed dwell for comparison;
//! - [`sweep::run_sweep`] / [`sweep::run_logged`]: thrust-targeted nominal sweeps (closed loop
//!   on throttle, ±1 g) and throttle-stepped limit sweeps, with safe stops; configured by
//!   [`config::SweepConfig`], reporting [`events::SweepEvent`]s, writing to a
//!   [`sink::StepSink`]; the runner behind them only orchestrates;
//! - [`controller::StepController`]: the pure throttle controller of a thrust-targeted step
//!   (secants in √thrust; state in, set-point out);
//! - [`rig_ops`]: clean disarm, idling and load-cell calibration outside a sweep;
//!   [`header::sweep_header`]: a sweep log's comment block;
//! - [`log::SweepLog`]: crash-safe CSV logs (fsynced per step, raw samples beside, comment
//!   block, `--resume`);
//! - [`session::characterise`]: the whole job into a session folder;
//! - [`simbench::SimBench`]: the simulated rig and supply on pseudo-terminals, coupled.
//!
//! The library never prints: progress arrives as [`sweep::SweepEvent`]s.
//!
//! ```
//! use rig_host::bench_supply::IdealSupply;
//! use rig_host::sweep::{run_sweep, MemorySink, SweepConfig, SweepEnv, SweepKind};
//! use rig_protocol::{ClientConfig, Rig};
//! use std::sync::atomic::AtomicBool;
//!
//! // The simulated `paper` rig in process, on its simulated clock.
//! let rig = sim::SimRig::new(&sim::presets::paper(), 7).unwrap();
//! let clock = rig.clock();
//! let mut host = rig.into_client(ClientConfig::default());
//! host.handshake().unwrap();
//! let identity = host.identify().unwrap();
//! let config = SweepConfig {
//!     kind: SweepKind::Nominal { step_g: 10.0, max_target_g: Some(20.0) },
//!     ..SweepConfig::default()
//! };
//! let mut sink = MemorySink::default();
//! let env = SweepEnv {
//!     clock: &clock,
//!     identity: &identity,
//!     supply: &mut IdealSupply::new(),
//!     observer: &mut |_e: rig_host::sweep::SweepEvent<'_>| {},
//!     stop: &AtomicBool::new(false),
//! };
//! let outcome = run_sweep(&mut host, env, &config, &[], &mut sink).unwrap();
//! assert_eq!(outcome.rows.len(), 2); // 10 and 20 g (zero thrust is the tare)
//! // The load cell is uncalibrated here (its nominal scale is 4 % off), yet each target is
//! // hit within ±1 g of what it reads.
//! for (row, target) in outcome.rows.iter().zip([10.0, 20.0]) {
//!     assert!((row.thrust_g - target).abs() <= 1.0, "{row:?}");
//! }
//! ```

pub mod bench_supply;
pub mod config;
pub mod controller;
pub mod error;
pub mod events;
pub mod header;
pub mod link;
pub mod log;
pub mod rig_ops;
mod runner;
pub mod session;
pub mod settle;
#[cfg(unix)]
pub mod simbench;
pub mod sink;
pub mod sweep;

pub use error::{HostError, SupplyLoss};

/// The wire protocol crate (the [`rig_protocol::Rig`] trait the sweeps drive).
pub use rig_protocol;
/// The bench-supply crate (drivers and the simulated supply).
pub use supply;
