//! Sim-to-real gap diagnosis.
//!
//! The paper's model (a rig's thrust → power curve and eqs. 1–9) is the "sim"; flight logs are
//! the "real". This crate says where the two part, which unmodelled effect causes it, and how far
//! the gap shrinks once that effect is added. Its blind study lives apart, in the `gap-eval` crate,
//! on flights from the independent truth simulator `flight-sim` that it reads from their files.
//!
//! Main pieces:
//! - [`flight::FlightRecord`]: a flight's voltage, current, phases and altitude with what it
//!   carried; [`logs::record_from_log`] makes one from any log `flightlog` reads.
//! - [`battery::LearnedBattery`]: the pack's open-circuit curve, series resistance and RC
//!   pair, learned per battery type from the training flights (chemistry priors from PyBaMM's
//!   measured electrode curves, LiFePO₄'s from the published Afshar et al. 2017 formula, or a
//!   measured curve the user gives: the crate's one file read, in [`logs::record_from_log`],
//!   is such a curve named by a flight's `battery_ocv_csv` metadata).
//! - [`model::Model`]: the paper's power model driving the learned battery, with the library
//!   of candidate [`model::Effect`]s, each one bounded parameter.
//! - [`diagnose::diagnose`], in named steps: learns the batteries, localises the gap (by
//!   phase, state of charge, per-flight covariates), fits every candidate on the training
//!   flights, selects by BIC and cross-validation by flight, drops any effect that makes the
//!   held-out endurance worse, checks the selection's stability between the early and late
//!   halves of the flights, and reports the held-out gap before and after with each effect's
//!   Shapley share. `none` when the gap is within noise; `unexplained` (with the residual
//!   named, and why in words with numbers) when a significant gap remains that no candidate
//!   explains: by default ([`diagnose::UnexplainedRule::Systematic`]) a residual the flights
//!   share beyond their own scatter ([`systematic`]); with
//!   [`diagnose::UnexplainedRule::Chi2`], χ² left against fixed noise floors or an unstable
//!   effect.
//! - [`steps::step_resistances`]: the series resistance each pack's current steps show
//!   (reported beside the learned battery; no part of a verdict or prediction).
//! - [`logs::run`]: the same with a rig baseline or, for a robot nobody characterised, a hover
//!   power estimated from the training flights (their current, else their voltage's fall on a
//!   prior chosen by their resting level, [`battery::prior_by_resting_level`]).
//!
//! ```
//! use std::path::Path;
//! use flightlog::{Flight, FlightMeta, LogFormat};
//! use gap::logs::{Baseline, ConstantPower, record_from_log, run};
//! use gap::diagnose::DiagnoseOptions;
//!
//! // Three hovers of a 3S pack, read as `hoverbench gap` reads a folder.
//! let mut flights = Vec::new();
//! for (k, watts) in [(1, 100.0), (2, 101.0), (3, 99.0)] {
//!     let mut csv = String::from("time_s,voltage_v,current_a,phase\n");
//!     for s in 0..600 {
//!         let v = 12.4 - 2.0 * f64::from(s) / 600.0;
//!         csv.push_str(&format!("{s},{v:.3},{:.3},hover\n", watts / v));
//!     }
//!     let name = format!("hover-{k}.csv");
//!     let mut f = Flight::parse(csv.as_bytes(), Path::new(&name), LogFormat::Csv)?;
//!     f.meta = FlightMeta::parse(
//!         "cells = 3\nbattery_energy_wh = 16.0\nend = \"landed\"\n",
//!         Path::new("hover.toml"),
//!     )?;
//!     flights.push(record_from_log(&f)?);
//! }
//! let train: Vec<_> = flights[..2].iter().collect();
//! let heldout: Vec<_> = flights[2..].iter().collect();
//! // No rig characterisation: the hover power is estimated from the training flights.
//! let report = run(
//!     Baseline::<ConstantPower>::FromTraining,
//!     &train,
//!     &heldout,
//!     &DiagnoseOptions::default(),
//! )?;
//! assert_eq!(report.diagnosis.split.heldout, ["hover-3"]);
//! assert!((report.estimated_hover_power_w.unwrap() - 100.5).abs() < 3.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod battery;
pub mod diagnose;
pub mod flight;
pub mod lipo;
pub mod logs;
pub mod model;
pub mod params_link;
pub mod stats;
pub mod steps;
pub mod summary;
pub mod systematic;

/// What can go wrong in the diagnosis.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GapError {
    /// Fitting the rig curve failed.
    #[error("fitting the rig curve")]
    Fit(#[from] fit::FitError),
    /// The estimator refused the curve.
    #[error(transparent)]
    Estimate(#[from] estimator::EstimateError),
    /// A flight lacks metadata the diagnosis needs.
    #[error("flight {flight}: no {missing} in its sidecar NAME.toml or the folder's flights.toml")]
    Metadata {
        /// The flight.
        flight: String,
        /// What is missing.
        missing: String,
    },
    /// A flight's measured open-circuit curve (metadata `battery_ocv_csv`) does not read.
    #[error("flight {flight}: battery_ocv_csv = {} (set in {set_in}): {message}", csv.display())]
    BatteryCurve {
        /// The flight.
        flight: String,
        /// The curve's file, as the metadata names it (joined with the metadata file's folder).
        csv: std::path::PathBuf,
        /// The metadata file that set the key.
        set_in: String,
        /// What is wrong (with the CSV's line when it is in the file).
        message: String,
    },
    /// The flight's vehicle does not hover (a fixed-wing aircraft, a rover, a boat or a
    /// submarine): the paper's model does not describe it.
    #[error("flight {flight}: {why}")]
    NotHovering {
        /// The flight.
        flight: String,
        /// Which vehicle, and how the log says so.
        why: String,
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
