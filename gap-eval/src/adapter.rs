//! The only module that calls into the `gap` diagnosis.
//!
//! Everything the study needs from the diagnosis goes through [`diagnose_blind`]: flights read
//! from their files by `flightlog`, converted by `gap::logs::record_from_log`, diagnosed by
//! `gap::diagnose::diagnose` against the rig curve, and the result reduced to plain names and
//! numbers ([`Outcome`]). No label, seed or family crosses here: only flights (whose metadata
//! carries the site's ceiling height, `ceiling_height_m`), the rig curve and the rotor count.

use estimator::PolyCurve;
use flightlog::Flight;
use flightlog::summary::error_chain;
use gap::diagnose::{DiagnoseOptions, diagnose};
use gap::flight::FlightRecord;
use gap::logs::record_from_log;
use gap::model::Model;

use crate::EvalError;

/// What the diagnosis said, as names and numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Selected effects by name (empty: none).
    pub verdict: Vec<String>,
    /// A significant gap remains that no candidate explains.
    pub unexplained: bool,
    /// Each selected effect's share of the held-out gap.
    pub shares: Vec<(String, f64)>,
    /// Held-out mean absolute endurance error before any effect, % (cut-off flights).
    pub heldout_endurance_before_pct: Option<f64>,
    /// The same with the selected effects, %.
    pub heldout_endurance_after_pct: Option<f64>,
    /// The diagnosis's headline held-out gap before and after (endurance %, else phase power
    /// %, else voltage RMSE V).
    pub heldout_headline: (f64, f64),
}

/// Diagnoses `train` against `heldout` with the rig curve as baseline.
pub fn diagnose_blind(
    train: &[Flight],
    heldout: &[Flight],
    curve: &PolyCurve,
    rotor_count: u8,
) -> Result<Outcome, EvalError> {
    let convert = |fs: &[Flight]| -> Result<Vec<FlightRecord>, EvalError> {
        fs.iter()
            .map(|f| record_from_log(f).map_err(|e| EvalError::Diagnosis(error_chain(&e))))
            .collect()
    };
    let tr = convert(train)?;
    let he = convert(heldout)?;
    let tr: Vec<&FlightRecord> = tr.iter().collect();
    let he: Vec<&FlightRecord> = he.iter().collect();
    let d = diagnose(
        Model { curve, rotor_count },
        &tr,
        &he,
        &DiagnoseOptions::default(),
    )
    .map_err(|e| EvalError::Diagnosis(error_chain(&e)))?;
    Ok(Outcome {
        verdict: d.verdict.iter().map(|e| e.name().to_owned()).collect(),
        unexplained: d.unexplained,
        shares: d
            .effects
            .iter()
            .map(|e| (e.effect.name().to_owned(), e.share_of_gap))
            .collect(),
        heldout_endurance_before_pct: d.baseline.heldout.endurance_pct,
        heldout_endurance_after_pct: d.after.heldout.endurance_pct,
        heldout_headline: (d.baseline.heldout.headline(), d.after.heldout.headline()),
    })
}
