//! The sim-to-real gap on the thrust bench: where a motor–propeller–supply physics model
//! ([`motor_model`]) and a stand's measurements part, which unmodelled effect causes it, and how
//! far the held-out error shrinks once that effect is added.
//!
//! Main types: [`StandSweep`] (one run of a stand log, thrust-ordered steps with their
//! direction), [`diagnose::diagnose`] → [`diagnose::Diagnosis`] (verdict, effects with their
//! parameters, uncertainties and held-out errors before/after, where the residuals sit).
//! No I/O: the caller reads logs with [`import::stand::StandLog`] and hands them over.
//!
//! ```
//! use motor_model::{Params, Param, Point, predict_sweep};
//! use rig_gap::{StandSweep, StepMeta, diagnose::{diagnose, Options}};
//! // A stand on a sagging 0.15 Ω supply, simulated by the model itself for brevity.
//! let mut truth = Params::default();
//! truth.set_base(920.0, 0.12, 0.6, 0.95, 12.0, 0.001_2, 16.8);
//! truth.set(Param::SourceResistanceOhm, 0.15);
//! let run = |name: &str, offset: f64| {
//!     let pts: Vec<Point> = (0..12)
//!         .map(|i| Point { thrust_g: 100.0 + offset + 80.0 * i as f64, time_frac: i as f64 / 11.0, time_s: 4.0 * i as f64, tare_time_s: 0.0, measured_current_a: None })
//!         .collect();
//!     let pred = predict_sweep(&truth, &pts);
//!     StandSweep::from_predictions(name, &pts, &pred)
//! };
//! let d = diagnose(&[run("a", 0.0), run("b", 20.0)], &[run("c", 40.0)], &Options::default()).unwrap();
//! assert_eq!(d.verdict, vec!["supply_sag".to_string()]);
//! ```

pub mod diagnose;
mod sweeps;

pub use sweeps::{StandSweep, StepMeta, runs_of_log, split_default};

/// Why a diagnosis could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigGapError {
    /// A log has no usable steps.
    #[error("{source_name}: {message}")]
    Unusable {
        /// The log.
        source_name: String,
        /// What is missing.
        message: String,
    },
    /// Not enough data to train and check.
    #[error("{0}")]
    TooLittle(String),
}
