//! Sim-to-real gap diagnosis.
//!
//! The paper's model (a rig's thrust → power curve and eqs. 1–9) is the "sim"; flight logs are
//! the "real". This crate says where the two part, which unmodelled effect causes it, and how far
//! the gap shrinks once that effect is added — and checks itself blind on simulated flights whose
//! truth it never reads.
//!
//! Main pieces:
//! - [`flight::FlightRecord`]: a flight's voltage, current, phases and altitude with what it
//!   carried; [`logs::record_from_log`] makes one from any log `flightlog` reads.
//! - [`battery::LearnedBattery`]: the pack's open-circuit curve, series resistance and RC
//!   pair, learned per battery type from the training flights (chemistry priors from measured
//!   PyBaMM curves, or a measured curve the user gives).
//! - [`model::Model`]: the paper's power model driving the learned battery, with the library
//!   of candidate [`model::Effect`]s, each one bounded parameter.
//! - [`diagnose::diagnose`], in named steps: learns the batteries, localises the gap (by
//!   phase, state of charge, per-flight covariates), fits every candidate on the training
//!   flights, selects by BIC and cross-validation by flight, drops any effect that makes the
//!   held-out endurance worse, checks the selection's stability between the early and late
//!   halves of the flights, and reports the held-out gap before and after with each effect's
//!   Shapley share. `none` when the gap is within noise; `unexplained` (with the residual
//!   named) when a significant gap remains that no candidate explains.
//! - [`logs::run`]: the same with a rig baseline or, for a robot nobody characterised, a hover
//!   power estimated from the training flights.
//! - [`truth`] and [`eval`]: the truth simulator and the blind study.
//!
//! ```
//! use gap::diagnose::{DiagnoseOptions, diagnose};
//! use gap::eval::{generate, rig_curve};
//! use gap::model::{Effect, Model};
//! use gap::truth::{Robot, TruthEffect};
//!
//! // Simulate flights of the paper's robot whose pack has 60 mΩ more resistance than nominal.
//! let robot = Robot::paper();
//! let curve = rig_curve(&robot)?;
//! let set = generate(&robot, 3, TruthEffect::Library(Effect::InternalResistance, 0.06));
//! let train: Vec<_> = set.train.iter().collect();
//! let heldout: Vec<_> = set.heldout.iter().collect();
//! // Diagnose blind: only the flights and the rig curve go in.
//! let d = diagnose(Model { curve: &curve, rotor_count: 4 }, &train, &heldout, &DiagnoseOptions::default())?;
//! assert_eq!(d.verdict, [Effect::InternalResistance]);
//! assert!(d.after.heldout.headline() < d.baseline.heldout.headline());
//! # Ok::<(), gap::GapError>(())
//! ```

pub mod battery;
pub mod diagnose;
pub mod eval;
pub mod flight;
pub mod lipo;
pub mod logs;
pub mod model;
pub mod stats;
pub mod summary;
pub mod truth;
pub mod write;

/// What can go wrong in the diagnosis.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GapError {
    /// Fitting the rig curve failed.
    #[error("fitting the rig curve: {0}")]
    Fit(#[from] fit::FitError),
    /// The estimator refused the curve.
    #[error("{0}")]
    Estimate(#[from] estimator::EstimateError),
    /// A flight lacks metadata the diagnosis needs.
    #[error("flight {flight}: no {missing} in its sidecar NAME.toml or the folder's flights.toml")]
    Metadata {
        /// The flight.
        flight: String,
        /// What is missing.
        missing: String,
    },
    /// No flights to train on or to check against.
    #[error("no {0} flights: the diagnosis needs at least one")]
    NoFlights(&'static str),
    /// Options the diagnosis cannot honour.
    #[error("diagnosis options: {0}")]
    Options(String),
    /// The flights fail a plausibility check; the diagnosis stops instead of printing absurd
    /// numbers.
    #[error("implausible input: {0}")]
    Implausible(String),
}
