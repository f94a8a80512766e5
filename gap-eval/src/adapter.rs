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
use gap::diagnose::{DiagnoseOptions, UnexplainedRule, diagnose};
use gap::flight::FlightRecord;
use gap::logs::record_from_log;
use gap::model::Model;

use serde::Serialize;

use crate::EvalError;

/// What the diagnosis said, as names and numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Selected effects by name (empty: none).
    pub verdict: Vec<String>,
    /// A significant gap remains that no candidate explains (by the rule the study runs).
    pub unexplained: bool,
    /// Why, in the diagnosis's words with its numbers (empty when not unexplained).
    pub unexplained_reasons: Vec<String>,
    /// What the χ² rule says, whichever rule is set.
    pub unexplained_by_chi2: bool,
    /// What the systematic rule says, whichever rule is set.
    pub unexplained_by_systematic: bool,
    /// Each selected effect's share of the held-out gap.
    pub shares: Vec<(String, f64)>,
    /// Held-out mean absolute endurance error before any effect, % (cut-off flights).
    pub heldout_endurance_before_pct: Option<f64>,
    /// The same with the selected effects, %.
    pub heldout_endurance_after_pct: Option<f64>,
    /// The diagnosis's headline held-out gap before and after (endurance %, else phase power
    /// %, else voltage RMSE V).
    pub heldout_headline: (f64, f64),
    /// What the effect search saw, for the study's account of its misses.
    pub search: SearchEvidence,
    /// Effects outside the verdict that the flights cannot tell from it (the diagnosis's
    /// `look_alikes`), best first.
    pub look_alikes: Vec<String>,
    /// The hover power the diagnosis estimated from the training flights, W (only without the
    /// rig, [`diagnose_blind_without_rig`]).
    pub estimated_hover_power_w: Option<f64>,
}

/// What the effect search saw on one scenario: each effect fitted alone, what was dropped on
/// the held-out flights, and whether a selected resistance was kept unnamed. Read from the
/// diagnosis's own `candidates`, `rejected` and `healthy_resistance`; nothing here feeds back.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SearchEvidence {
    /// The baseline's training χ² is within noise, so the search selects nothing.
    pub within_noise: bool,
    /// Training χ² of the baseline (no effect).
    pub baseline_chi2: f64,
    /// Cross-validated χ² of the baseline.
    pub baseline_cv_chi2: Option<f64>,
    /// The smallest drop of χ² (and of the BIC and the cross-validated χ²) the search takes
    /// for an effect.
    pub min_delta_chi2: f64,
    /// Every effect observable on the training flights, fitted alone, best training χ² first.
    pub singles: Vec<SingleEvidence>,
    /// Every model of two or more effects the search tried, in the order tried.
    pub combinations: Vec<CombinationEvidence>,
    /// Effects selected on the training flights and dropped on the held-out ones.
    pub dropped_on_heldout: Vec<String>,
    /// A selected `internal_resistance` stayed within a healthy pack's band (kept in the model,
    /// not named).
    pub resistance_kept_unnamed: bool,
}

/// A model of two or more effects the search tried on the training flights.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationEvidence {
    /// Effect names, in the order added.
    pub effects: Vec<String>,
    /// Training χ².
    pub chi2: f64,
    /// Cross-validated χ² (computed when the BIC was promising).
    pub cv_chi2: Option<f64>,
    /// Held-out mean absolute endurance error with these effects, %.
    pub heldout_endurance_pct: Option<f64>,
}

/// One effect fitted alone on the training flights.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SingleEvidence {
    /// Effect name.
    pub effect: String,
    /// Training χ².
    pub chi2: f64,
    /// Cross-validated χ² (only the three best singles get one, when promising).
    pub cv_chi2: Option<f64>,
    /// Held-out mean absolute endurance error with this effect alone, %.
    pub heldout_endurance_pct: Option<f64>,
}

/// Diagnoses `train` against `heldout` with the rig curve as baseline (the default rule for
/// `unexplained`).
pub fn diagnose_blind(
    train: &[Flight],
    heldout: &[Flight],
    curve: &PolyCurve,
    rotor_count: u8,
) -> Result<Outcome, EvalError> {
    diagnose_blind_with(
        train,
        heldout,
        curve,
        rotor_count,
        UnexplainedRule::default(),
    )
}

/// [`diagnose_blind`] with the rule that sets `unexplained`.
pub fn diagnose_blind_with(
    train: &[Flight],
    heldout: &[Flight],
    curve: &PolyCurve,
    rotor_count: u8,
    rule: UnexplainedRule,
) -> Result<Outcome, EvalError> {
    let (tr, he) = (records(train)?, records(heldout)?);
    let tr: Vec<&FlightRecord> = tr.iter().collect();
    let he: Vec<&FlightRecord> = he.iter().collect();
    let d = diagnose(Model { curve, rotor_count }, &tr, &he, &options(rule))
        .map_err(|e| EvalError::Diagnosis(error_chain(&e)))?;
    Ok(outcome_of(&d, None))
}

/// [`diagnose_blind_with`] without the rig: the baseline's hover power estimated from the
/// training flights (their logged current, else their voltage's fall), as `hoverbench gap`
/// does without `--params`.
pub fn diagnose_blind_without_rig(
    train: &[Flight],
    heldout: &[Flight],
    rule: UnexplainedRule,
) -> Result<Outcome, EvalError> {
    let (tr, he) = (records(train)?, records(heldout)?);
    let tr: Vec<&FlightRecord> = tr.iter().collect();
    let he: Vec<&FlightRecord> = he.iter().collect();
    let report = gap::logs::run_from_training(&tr, &he, &options(rule))
        .map_err(|e| EvalError::Diagnosis(error_chain(&e)))?;
    Ok(outcome_of(
        &report.diagnosis,
        report.estimated_hover_power_w,
    ))
}

/// The diagnosis's default options with the rule that sets `unexplained`.
fn options(rule: UnexplainedRule) -> DiagnoseOptions {
    DiagnoseOptions {
        unexplained_rule: rule,
        ..DiagnoseOptions::default()
    }
}

/// The flights as the diagnosis reads them.
fn records(fs: &[Flight]) -> Result<Vec<FlightRecord>, EvalError> {
    fs.iter()
        .map(|f| record_from_log(f).map_err(|e| EvalError::Diagnosis(error_chain(&e))))
        .collect()
}

fn outcome_of(d: &gap::diagnose::Diagnosis, estimated_hover_power_w: Option<f64>) -> Outcome {
    Outcome {
        verdict: d.verdict.iter().map(|e| e.name().to_owned()).collect(),
        unexplained: d.unexplained,
        unexplained_reasons: d.unexplained_reasons.clone(),
        unexplained_by_chi2: d.unexplained_by_chi2,
        unexplained_by_systematic: d.unexplained_by_systematic,
        shares: d
            .effects
            .iter()
            .map(|e| (e.effect.name().to_owned(), e.share_of_gap))
            .collect(),
        heldout_endurance_before_pct: d.baseline.heldout.endurance_pct,
        heldout_endurance_after_pct: d.after.heldout.endurance_pct,
        heldout_headline: (d.baseline.heldout.headline(), d.after.heldout.headline()),
        search: search_evidence(d),
        look_alikes: d
            .look_alikes
            .iter()
            .map(|l| l.effect.name().to_owned())
            .collect(),
        estimated_hover_power_w,
    }
}

fn search_evidence(d: &gap::diagnose::Diagnosis) -> SearchEvidence {
    let baseline = d.candidates.iter().find(|c| c.effects.is_empty());
    let mut singles: Vec<SingleEvidence> = d
        .candidates
        .iter()
        .filter(|c| c.effects.len() == 1)
        .map(|c| SingleEvidence {
            effect: c.effects[0].name().to_owned(),
            chi2: c.chi2,
            cv_chi2: c.cv_chi2,
            heldout_endurance_pct: c.heldout.endurance_pct,
        })
        .collect();
    singles.sort_by(|a, b| a.chi2.total_cmp(&b.chi2));
    SearchEvidence {
        within_noise: d.within_noise,
        baseline_chi2: baseline.map_or(f64::NAN, |c| c.chi2),
        baseline_cv_chi2: baseline.and_then(|c| c.cv_chi2),
        min_delta_chi2: DiagnoseOptions::default().thresholds.min_delta_bic,
        singles,
        combinations: d
            .candidates
            .iter()
            .filter(|c| c.effects.len() > 1)
            .map(|c| CombinationEvidence {
                effects: c.effects.iter().map(|e| e.name().to_owned()).collect(),
                chi2: c.chi2,
                cv_chi2: c.cv_chi2,
                heldout_endurance_pct: c.heldout.endurance_pct,
            })
            .collect(),
        dropped_on_heldout: d
            .rejected
            .iter()
            .map(|r| r.effect.name().to_owned())
            .collect(),
        resistance_kept_unnamed: d.healthy_resistance.is_some(),
    }
}

/// One battery type's curve as the diagnosis learned it from the training flights.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedCurve {
    /// Battery type (the diagnosis's name).
    pub battery_type: String,
    /// State of charge the training flights covered (lowest, highest).
    pub soc_covered: (f64, f64),
    /// RMS of the fit's voltage residual, V per cell.
    pub rmse_cell_v: f64,
    /// Learned series resistance of one cell, Ω (before the baseline's cap at the nominal).
    pub series_resistance_cell_ohm: f64,
    /// Learned resistance of the RC pair of one cell, Ω.
    pub rc_resistance_cell_ohm: f64,
    /// The series resistance of one cell the diagnosis's baseline flies, Ω.
    pub baseline_series_resistance_cell_ohm: f64,
    battery: gap::battery::LearnedBattery,
}

impl LearnedCurve {
    /// The learned open-circuit voltage of one cell at state of charge `soc`, V.
    pub fn ocv_cell_v(&self, soc: f64) -> f64 {
        self.battery.ocv_cell_v(soc)
    }
}

/// The batteries the diagnosis learns from `train` (its first step, with its default options),
/// one per battery type.
pub fn learned_batteries(
    train: &[Flight],
    curve: &PolyCurve,
    rotor_count: u8,
) -> Result<Vec<LearnedCurve>, EvalError> {
    let tr: Vec<FlightRecord> = train
        .iter()
        .map(|f| record_from_log(f).map_err(|e| EvalError::Diagnosis(error_chain(&e))))
        .collect::<Result<_, _>>()?;
    let tr: Vec<&FlightRecord> = tr.iter().collect();
    let set = gap::diagnose::learn_batteries(
        Model { curve, rotor_count },
        &tr,
        &DiagnoseOptions::default(),
    );
    Ok(set
        .fits
        .iter()
        .zip(&set.baselines)
        .map(|(f, b)| LearnedCurve {
            battery_type: f.battery_type.clone(),
            soc_covered: f.soc_covered,
            rmse_cell_v: f.rmse_cell_v,
            series_resistance_cell_ohm: f.battery.series_resistance_cell_ohm,
            rc_resistance_cell_ohm: f.battery.rc_resistance_cell_ohm,
            baseline_series_resistance_cell_ohm: b.series_resistance_cell_ohm,
            battery: f.battery,
        })
        .collect())
}
