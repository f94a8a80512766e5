//! The diagnosis, in named steps: [`learn_batteries`] (the nuisance model), [`localise`] (where
//! the gap sits), [`fit_candidates`] (every observable effect on the training flights),
//! [`select`] (information criterion and cross-validation by flight, greedily up to
//! `max_effects`), [`judge_on_heldout`] (an effect that makes the held-out endurance worse, or
//! whose share is negative, is dropped), [`check_stability`] (early against late half) and
//! [`attribute_shares`] (Shapley shares of the held-out gap). It says honestly when nothing
//! (or nothing known) explains the gap, and names the residual that remains.

use estimator::PowerCurve;
use serde::Serialize;

use crate::GapError;
use crate::battery::{
    BatteryData, BatteryFit, Chemistry, CurrentSource, LearnedBattery, battery_type, fit_battery,
};
use crate::flight::{FlightRecord, Phase};
use crate::model::{Effect, EffectParams, FlightConsts, Model, Prediction};
use crate::stats::{golden_min, mean, pearson};
use crate::systematic::{self, CheckOptions, SystematicCheck};

/// Noise floors: how closely the model can be expected to follow a flight even when nothing is
/// missing from it (sensor noise, control activity, battery dynamics the model leaves out).
/// Residuals are measured against these.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoiseFloors {
    /// Voltage, V.
    pub voltage_v: f64,
    /// Energy of a phase, as a fraction of the flight's energy.
    pub power_fraction: f64,
    /// Drift of the measured-over-predicted power within a phase, from the early to the late
    /// half of a flight, as a fraction: the smallest shared drift the `systematic` rule flags.
    /// Below the energy's floor, as the current sensor's per-flight scale and offset, which
    /// the energy carries, cancel in a drift (1 %: on the tuning families 0.5 and 1 % flag
    /// the same runs, the energy's 1.5 % one fewer).
    pub power_drift_fraction: f64,
    /// Endurance, as a fraction.
    pub endurance_fraction: f64,
}

/// Decision thresholds. They were tuned on blind-study seeds 1000–1199 and are reported on
/// seeds 0–199 (see `eval`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    /// Baseline χ² per observation at or below which the gap is "within noise".
    pub none_chi2_per_obs: f64,
    /// BIC improvement an effect (or a second effect) must bring to be selected.
    pub min_delta_bic: f64,
    /// χ² per observation left after the selected effects above which the gap was called
    /// "unexplained" before session 9; now reported only (see [`crate::systematic`]: the flag
    /// judges what the flights share against their own scatter, not χ² against fixed floors).
    pub unexplained_chi2_per_obs: f64,
    /// Largest |t| (mean over flights / its standard error from the flights' own scatter) of
    /// a residual pattern that is still scatter; above it, and above the noise floor, the
    /// pattern is systematic and the gap `unexplained` (see [`crate::systematic`]).
    pub systematic_t: f64,
    /// A flight whose endurance the model misses by more than this fraction makes the gap
    /// `unexplained` by itself.
    pub gross_miss_fraction: f64,
    /// Largest difference, in standard errors, between a selected effect's parameter fitted on
    /// the early and on the late half of the flights before the model counts as misspecified.
    pub stability_z: f64,
}

/// Which rule sets the diagnosis's `unexplained` flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum UnexplainedRule {
    /// χ² per observation left on the training flights above
    /// [`Thresholds::unexplained_chi2_per_obs`] against the fixed [`NoiseFloors`], or a
    /// selected effect whose early- and late-half fits differ by more than
    /// [`Thresholds::stability_z`] standard errors (from the same floors). The default until
    /// session 10. On flights that scatter more than the floors (per-flight packs and sensors)
    /// it fires on nearly every set: on the blind study's tuning families, seeds 0–399, on 398
    /// of 400 runs, so as a classifier of "outside the library" its balanced accuracy is 0.50.
    Chi2,
    /// A residual pattern the flights share beyond their own scatter, or a flight missed by
    /// more than half ([`crate::systematic`]). Instability is reported but does not set it.
    /// The default: on the blind study's tuning families, seeds 0–399, it flags 57 of 68
    /// runs outside the library and 63 of the 332 others (balanced accuracy 0.82, against
    /// 0.50 for [`Self::Chi2`]).
    #[default]
    Systematic,
}

/// How the diagnosis runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DiagnoseOptions {
    /// Noise floors.
    pub floors: NoiseFloors,
    /// Decision thresholds.
    pub thresholds: Thresholds,
    /// Predicted points per flight (flights are thinned to about this many samples).
    pub points_per_flight: usize,
    /// Effective observations a flight's voltage trajectory counts as (its residuals are
    /// strongly correlated in time, so they are not that many independent observations).
    pub voltage_obs_per_flight: f64,
    /// Most effects combined.
    pub max_effects: usize,
    /// Folds of the cross-validation by flight.
    pub cv_folds: usize,
    /// A measured open-circuit curve that overrides the learned one's shape (every battery
    /// type), from `--battery-ocv-csv`.
    pub measured_ocv: Option<LearnedBattery>,
    /// Which rule sets `unexplained`.
    pub unexplained_rule: UnexplainedRule,
    /// The packs' chemistry when known (`--chemistry`): only its prior is tried. Unknown, the
    /// priors matching the flights' full resting voltage are tried and the best-fitting kept
    /// (see [`crate::battery`]).
    pub chemistry: Option<Chemistry>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            floors: NoiseFloors {
                voltage_v: 0.04,
                power_fraction: 0.015,
                power_drift_fraction: 0.01,
                endurance_fraction: 0.01,
            },
            thresholds: Thresholds {
                none_chi2_per_obs: 2.0,
                min_delta_bic: 12.0,
                unexplained_chi2_per_obs: 3.0,
                systematic_t: 3.5,
                gross_miss_fraction: 0.5,
                stability_z: 4.0,
            },
            cv_folds: 4,
            points_per_flight: 160,
            voltage_obs_per_flight: 8.0,
            max_effects: 2,
            measured_ocv: None,
            unexplained_rule: UnexplainedRule::Systematic,
            chemistry: None,
        }
    }
}

/// Residuals of one flight against a prediction, by level.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightResiduals {
    /// Flight name.
    pub name: String,
    /// Predicted minus measured endurance, relative, when the flight ended at the cut-off.
    pub endurance_error: Option<f64>,
    /// Predicted and measured endurance.
    pub endurance: Endurance,
    /// Mean power per phase, measured and predicted, when current is logged.
    pub phase_power: Vec<PhasePower>,
    /// RMS of measured minus predicted voltage, V.
    pub voltage_rmse_v: f64,
    /// Mean voltage residual (measured minus predicted) in thirds of the discharge (early,
    /// middle, late by predicted state of charge), V.
    pub voltage_by_charge_v: [Option<f64>; 3],
    /// Mean voltage residual by phase.
    pub voltage_by_phase_v: Vec<PhaseVoltage>,
    /// Measured over predicted battery power in the late half of the flight minus the same
    /// ratio in the early half, within each phase flown in both halves and averaged over them
    /// (weighted by `1/(1/n_early + 1/n_late)` samples; flights with current, whole-flight
    /// window; each phase also weighted by its predicted power squared, as a ratio's noise goes
    /// as the current sensor's over the current): a drift of the power within the flight that
    /// the model does not follow (a per-flight current-sensor scale cancels in it, and so does
    /// the model's error on one phase against another when a flight's halves fly different
    /// phases).
    pub power_drift: Option<f64>,
    /// χ² contribution and observation count.
    pub chi2: f64,
    /// Observations.
    pub n_obs: f64,
}

/// Predicted and measured endurance of a flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Endurance {
    /// Predicted, s.
    pub predicted_s: f64,
    /// Measured (the log's duration), s.
    pub measured_s: f64,
}

/// Mean battery power of one phase of a flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhasePower {
    /// The phase.
    pub phase: Phase,
    /// Measured mean power, W.
    pub measured_w: f64,
    /// Predicted mean power, W.
    pub predicted_w: f64,
    /// Time in the phase, s.
    pub time_s: f64,
}

/// Mean voltage residual (measured − predicted) in one phase.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseVoltage {
    /// The phase.
    pub phase: Phase,
    /// Mean residual, V.
    pub residual_v: f64,
}

/// Mean voltage residual of held-out flights in one phase, before and after the selected
/// effects (for the residual-by-phase plot).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseBeforeAfter {
    /// The phase.
    pub phase: Phase,
    /// Baseline mean residual, V.
    pub before_v: f64,
    /// Mean residual with the selected effects, V.
    pub after_v: f64,
}

/// Which part of each flight residuals are counted over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// The whole flight.
    All,
    /// The first half of the log, without the endurance: every sample of it is compared with
    /// the prediction, a sample past the predicted cut-off with the cut-off voltage (on a
    /// flight that ended at the cut-off too), so that a fit over it cannot shed the samples it
    /// misfits by predicting the flight to end before them.
    Early,
    /// The second half of the log (and the endurance).
    Late,
}

impl Window {
    fn contains(self, f: &FlightRecord, i: usize) -> bool {
        let half = f.time_s[0] + 0.5 * f.duration_s();
        match self {
            Window::All => true,
            Window::Early => f.time_s[i] < half,
            Window::Late => f.time_s[i] >= half,
        }
    }
}

/// Compares a flight with a prediction over a window of it.
pub fn residuals(
    f: &FlightRecord,
    pred: &Prediction,
    opts: &DiagnoseOptions,
    window: Window,
) -> FlightResiduals {
    residuals_with(f, pred, opts, window, &phase_times_s(f))
}

/// Time a flight spends in each phase of [`Phase::ALL`], s: the sum of the sample intervals
/// that start in it.
fn phase_times_s(f: &FlightRecord) -> [f64; Phase::ALL.len()] {
    Phase::ALL.map(|phase| {
        f.phase
            .iter()
            .zip(f.time_s.windows(2))
            .filter(|(p, _)| **p == phase)
            .map(|(_, w)| w[1] - w[0])
            .sum()
    })
}

/// [`residuals`] with the flight's [`phase_times_s`] computed once.
fn residuals_with(
    f: &FlightRecord,
    pred: &Prediction,
    opts: &DiagnoseOptions,
    window: Window,
    phase_times: &[f64; Phase::ALL.len()],
) -> FlightResiduals {
    let fl = &opts.floors;
    let measured_s = f.duration_s();
    let mut chi2 = 0.0;
    let mut n_obs = 0.0;
    // The endurance is counted in the windows that hold the flight's end. It then also counts
    // the samples the model did not reach; in the early window those are paid for one by one
    // below instead.
    let endurance_counted = f.info.ended_at_cutoff && window != Window::Early;
    let endurance_error = endurance_counted.then(|| {
        let e = (pred.endurance_s - measured_s) / measured_s;
        chi2 += (e / fl.endurance_fraction).powi(2);
        n_obs += 1.0;
        e
    });
    // Voltage. Running sums, each in sample order from −0.0 as `Iterator::sum` adds (the
    // same numbers as summing collected residuals, without the allocations).
    let phase_slot = |p: Phase| Phase::ALL.iter().position(|x| *x == p).unwrap_or(0);
    let mut dv_n = 0usize;
    let mut dv_sq = -0.0;
    let mut dv_chi = -0.0;
    let mut push_dv = |r: f64| {
        dv_n += 1;
        dv_sq += r * r;
        dv_chi += (r / fl.voltage_v).powi(2);
    };
    let mut by_charge = [(-0.0, 0usize); 3];
    // (phase, sum, count) in the order the phases first appear.
    let mut by_phase = [(Phase::Ground, -0.0, 0usize); Phase::ALL.len()];
    let mut by_phase_len = 0;
    // Per phase of `Phase::ALL`: measured and predicted power sums, count.
    let mut power_sums = [(-0.0, -0.0, 0usize); Phase::ALL.len()];
    // Measured and predicted power sums and counts per phase of `Phase::ALL` in the early and
    // the late half of the log.
    let half_s = f.time_s[0] + 0.5 * f.duration_s();
    let mut halves = [[(0.0, 0.0, 0usize); Phase::ALL.len()]; 2];
    let cur = f.current_a.as_ref();
    for (k, &i) in pred.index.iter().enumerate() {
        if !window.contains(f, i) {
            continue;
        }
        let r = f.voltage_v[i] - pred.voltage_v[k];
        push_dv(r);
        let third = ((1.0 - pred.soc[k]) * 3.0).floor().clamp(0.0, 2.0) as usize;
        by_charge[third].0 += r;
        by_charge[third].1 += 1;
        let phase = f.phase[i];
        match by_phase[..by_phase_len]
            .iter_mut()
            .find(|(p, _, _)| *p == phase)
        {
            Some(slot) => {
                slot.1 += r;
                slot.2 += 1;
            }
            None => {
                by_phase[by_phase_len] = (phase, r, 1);
                by_phase_len += 1;
            }
        }
        if let Some(cur) = cur {
            let slot = &mut power_sums[phase_slot(phase)];
            slot.0 += f.voltage_v[i] * cur[i];
            slot.1 += pred.power_w[k];
            slot.2 += 1;
            let h = &mut halves[usize::from(f.time_s[i] >= half_s)][phase_slot(phase)];
            h.0 += f.voltage_v[i] * cur[i];
            h.1 += pred.power_w[k];
            h.2 += 1;
        }
    }
    let ratio = |(meas, predp, n): (f64, f64, usize)| (n >= 3 && predp > 0.0).then(|| meas / predp);
    // The drift within each phase flown in both halves, weighted by the samples it rests on
    // (1/(1/n_early + 1/n_late)): a flight that hovers early and perches late does not read
    // the model's error on one phase against the other as a drift.
    let mut drift = (0.0, 0.0);
    for (early, late) in halves[0].iter().zip(&halves[1]) {
        if let (Some(e), Some(l)) = (ratio(*early), ratio(*late)) {
            // A ratio's noise goes as the current sensor's over the current: a low-power
            // phase (perched, on the ground) weighs by its power squared.
            let p = (early.1 + late.1) / (early.2 + late.2) as f64;
            let w = p * p / (1.0 / early.2 as f64 + 1.0 / late.2 as f64);
            drift.0 += w * (l - e);
            drift.1 += w;
        }
    }
    let power_drift = match window {
        Window::All if drift.1 > 0.0 => Some(drift.0 / drift.1),
        _ => None,
    };
    // A flight that the model empties first (one that landed with charge left, or any flight
    // in the early window, which has no endurance term): past the predicted cut-off the
    // model's voltage is the cut-off, so it pays for every sample it missed. (Where the
    // endurance is counted, its residual already says it.)
    if endurance_counted {
        // The endurance residual already counts what the model missed.
    } else if let Some(&last) = pred.index.last() {
        let stride = if pred.index.len() > 1 {
            pred.index[1] - pred.index[0]
        } else {
            1
        };
        let mut i = last + stride.max(1);
        while i < f.time_s.len() {
            if window.contains(f, i) {
                push_dv(f.voltage_v[i] - f.info.cutoff_voltage_v);
            }
            i += stride.max(1);
        }
    } else {
        let stride = (f.time_s.len() / opts.points_per_flight.max(1)).max(1);
        (0..f.time_s.len())
            .step_by(stride)
            .filter(|&i| window.contains(f, i))
            .for_each(|i| push_dv(f.voltage_v[i] - f.info.cutoff_voltage_v));
    }
    let voltage_rmse_v = if dv_n > 0 {
        (dv_sq / dv_n as f64).sqrt()
    } else {
        0.0
    };
    if dv_n > 0 {
        let m = dv_n as f64;
        chi2 += dv_chi / m * opts.voltage_obs_per_flight;
        n_obs += opts.voltage_obs_per_flight;
    }
    // Energy per phase, when current is logged: each phase's energy error (mean power error ×
    // time in the phase) as a share of the flight's measured energy, so that a short, low-power
    // phase whose mean is noisy weighs as little as the energy it holds.
    let mut phase_power = Vec::new();
    if cur.is_some() {
        for ((phase, &time), &(meas, predp, n)) in
            Phase::ALL.iter().copied().zip(phase_times).zip(&power_sums)
        {
            if n >= 3 {
                phase_power.push(PhasePower {
                    phase,
                    measured_w: meas / n as f64,
                    predicted_w: predp / n as f64,
                    time_s: time,
                });
            }
        }
        let total: f64 = phase_power.iter().map(|p| p.measured_w * p.time_s).sum();
        if total > 0.0 {
            for p in &phase_power {
                let e = (p.predicted_w - p.measured_w) * p.time_s / total;
                chi2 += (e / fl.power_fraction).powi(2);
                n_obs += 1.0;
            }
        }
    }
    let mean_of = |(sum, n): (f64, usize)| (n > 0).then(|| sum / n as f64);
    FlightResiduals {
        name: f.name.clone(),
        endurance_error,
        endurance: Endurance {
            predicted_s: pred.endurance_s,
            measured_s,
        },
        phase_power,
        voltage_rmse_v,
        voltage_by_charge_v: by_charge.map(mean_of),
        voltage_by_phase_v: by_phase[..by_phase_len]
            .iter()
            .filter_map(|&(phase, sum, n)| {
                mean_of((sum, n)).map(|residual_v| PhaseVoltage { phase, residual_v })
            })
            .collect(),
        power_drift,
        chi2,
        n_obs,
    }
}

/// Errors of a model on a set of flights, by level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct LevelErrors {
    /// Mean absolute endurance error over cut-off flights, %.
    pub endurance_pct: Option<f64>,
    /// Mean over flights of the absolute energy error summed over phases, as a share of the
    /// flight's measured energy, % (flights with current).
    pub phase_energy_pct: Option<f64>,
    /// RMS voltage error, V.
    pub voltage_rmse_v: Option<f64>,
    /// χ² per observation.
    pub chi2_per_obs: f64,
}

impl LevelErrors {
    /// The errors of a set of per-flight residuals.
    pub fn of(res: &[FlightResiduals]) -> Self {
        let end: Vec<f64> = res
            .iter()
            .filter_map(|r| r.endurance_error.map(|e| e.abs() * 100.0))
            .collect();
        let pow: Vec<f64> = res
            .iter()
            .filter_map(|r| {
                let total: f64 = r.phase_power.iter().map(|p| p.measured_w * p.time_s).sum();
                (total > 0.0).then(|| {
                    r.phase_power
                        .iter()
                        .map(|p| ((p.predicted_w - p.measured_w) * p.time_s).abs())
                        .sum::<f64>()
                        / total
                        * 100.0
                })
            })
            .collect();
        let v: Vec<f64> = res
            .iter()
            .map(|r| r.voltage_rmse_v * r.voltage_rmse_v)
            .collect();
        let chi2: f64 = res.iter().map(|r| r.chi2).sum();
        let n: f64 = res.iter().map(|r| r.n_obs).sum();
        Self {
            endurance_pct: mean(&end),
            phase_energy_pct: mean(&pow),
            voltage_rmse_v: mean(&v).map(f64::sqrt),
            chi2_per_obs: if n > 0.0 { chi2 / n } else { 0.0 },
        }
    }

    /// The headline gap, judged on what the effects physically change: the endurance error if
    /// measured, else the phase-power (energy per phase) error, else the voltage RMSE.
    pub fn headline(&self) -> f64 {
        self.headline_level().1
    }

    /// The headline gap with its level.
    pub fn headline_level(&self) -> (Level, f64) {
        if let Some(v) = self.endurance_pct {
            (Level::Endurance, v)
        } else if let Some(v) = self.phase_energy_pct {
            (Level::PhaseEnergy, v)
        } else {
            (Level::Voltage, self.voltage_rmse_v.unwrap_or(0.0))
        }
    }
}

/// The level a gap is measured at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    /// Endurance of cut-off flights, %.
    Endurance,
    /// Energy per phase, as a share of the flight's energy, %.
    PhaseEnergy,
    /// Voltage trajectory RMSE, V.
    Voltage,
}

impl Level {
    /// The unit the level's gap is in.
    pub fn unit(self) -> &'static str {
        match self {
            Level::Endurance | Level::PhaseEnergy => "%",
            Level::Voltage => "V",
        }
    }
}

/// Errors on the training and on the held-out flights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct TrainHeld {
    /// On the training flights.
    pub training: LevelErrors,
    /// On the held-out flights.
    pub heldout: LevelErrors,
}

/// The held-out headline gap before and after the selected effects, at one level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadlineGap {
    /// The level (endurance, else phase power, else voltage).
    pub level: Level,
    /// Before, in the level's unit (% or V).
    pub before: f64,
    /// After, in the level's unit.
    pub after: f64,
}

/// A fitted effect in the result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedEffect {
    /// The effect.
    pub effect: Effect,
    /// Its parameter.
    pub parameter: Parameter,
    /// Approximate standard error of the parameter (from the curvature of χ²).
    pub std_error: f64,
    /// Share of the held-out headline gap this effect closes (Shapley value over insertion
    /// orders), 0..1.
    pub share_of_gap: f64,
    /// Held-out endurance (else phase-power) error before any effect, %; `None` when the
    /// held-out flights measure neither (then the shares are of the voltage RMSE).
    pub heldout_error_before_pct: Option<f64>,
    /// The same with the selected effects, %.
    pub heldout_error_after_pct: Option<f64>,
}

/// A named parameter value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// Name with unit.
    pub name: String,
    /// Value.
    pub value: f64,
}

/// An effect selected on the training flights and then dropped, with why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rejected {
    /// The effect.
    pub effect: Effect,
    /// Why.
    pub reason: String,
}

/// A selected parameter fitted on the early and on the late half of the flights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stability {
    /// The effect.
    pub effect: Effect,
    /// Fitted on the early half.
    pub early: f64,
    /// Fitted on the late half.
    pub late: f64,
    /// Difference in standard errors (from the χ² curvature against the fixed noise floors).
    pub z: f64,
    /// The same with each half's standard error scaled by √(χ²/obs) of its fit when above 1:
    /// against the flights' own scatter. Above the stability threshold the effect is unstable
    /// and the gap `unexplained`.
    pub z_scatter: f64,
}

/// Training and held-out flight names.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct Split {
    /// Training flights.
    pub train: Vec<String>,
    /// Held-out flights.
    pub heldout: Vec<String>,
}

/// Share of the energy gap in one phase.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseShare {
    /// The phase.
    pub phase: Phase,
    /// Share, 0..1.
    pub share: f64,
}

/// The voltage residual in one third of the discharge.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChargeThird {
    /// Which third.
    pub part: String,
    /// Mean residual (measured − predicted), V.
    pub residual_v: f64,
    /// Share of the squared residual, 0..1.
    pub share: f64,
}

/// A per-flight covariate against the per-flight error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CovariateCorrelation {
    /// Covariate.
    pub name: String,
    /// Pearson correlation.
    pub r: f64,
    /// Share of the between-flight variance it explains (r²).
    pub r2: f64,
}

/// What remains after the selected effects, named.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Residual {
    /// Where the remaining gap sits, in words.
    pub description: String,
    /// Held-out voltage RMSE left, V.
    pub voltage_rmse_v: Option<f64>,
    /// Mean held-out voltage residual in the early, middle and late third of the discharge, V.
    pub by_state_of_charge_v: [Option<f64>; 3],
}

/// One candidate model tried.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// Effects in it.
    pub effects: Vec<Effect>,
    /// Fitted values.
    pub values: Vec<f64>,
    /// Training χ².
    pub chi2: f64,
    /// BIC = χ² + k·ln(n).
    pub bic: f64,
    /// Cross-validated χ² (flights left out in folds), for the models that were promising.
    pub cv_chi2: Option<f64>,
    /// Held-out errors.
    pub heldout: LevelErrors,
}

/// Where the gap sits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Where {
    /// Share of the energy gap by phase (flights with current).
    pub by_phase: Vec<PhaseShare>,
    /// Mean voltage residual by phase.
    pub voltage_by_phase_v: Vec<PhaseVoltage>,
    /// Mean voltage residual in the early, middle and late discharge.
    pub by_state_of_charge: Vec<ChargeThird>,
    /// Per-flight covariates against the endurance (or voltage) error.
    pub by_covariate: Vec<CovariateCorrelation>,
}

/// The diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// Selected effect names (empty when none).
    pub verdict: Vec<Effect>,
    /// A significant gap remains that the selected effects do not explain, by the rule in
    /// `unexplained_rule` (never when the gap is within noise).
    pub unexplained: bool,
    /// The rule that set `unexplained`.
    pub unexplained_rule: UnexplainedRule,
    /// Why the gap is `unexplained`, in words with the numbers (empty when it is not).
    pub unexplained_reasons: Vec<String>,
    /// What does not set the flag under the rule set but a user should know, in words: under
    /// the systematic rule, each selected effect unstable between the early and the late half
    /// (by more than the stability threshold against the flights' own scatter).
    pub cautions: Vec<String>,
    /// What the χ² rule says (see [`UnexplainedRule::Chi2`]), whichever rule is set.
    pub unexplained_by_chi2: bool,
    /// What the systematic rule says (see [`UnexplainedRule::Systematic`]), whichever rule is
    /// set.
    pub unexplained_by_systematic: bool,
    /// The gap is within noise.
    pub within_noise: bool,
    /// The test of the systematic rule: the residual patterns the flights share, against their
    /// own scatter, and gross misses, with the numbers (computed whichever rule is set).
    pub systematic: SystematicCheck,
    /// Selected effects with parameters, shares and held-out errors.
    pub effects: Vec<FittedEffect>,
    /// An extra series resistance the search selected that stays within what healthy packs of
    /// the fits' chemistries and sizes have: kept in the model (the predictions after the
    /// effects use it) but not named in `verdict` or `effects` ([`healthy_resistance`]).
    pub healthy_resistance: Option<HealthyResistanceFound>,
    /// Where the baseline gap sits.
    pub r#where: Where,
    /// The batteries learned from the training flights, one per battery type.
    pub batteries: Vec<BatteryFit>,
    /// The series resistance each training battery type's current steps show
    /// ([`crate::steps`]; types with a logged current and enough steps): reported beside the
    /// learned battery, not part of the verdict or of any prediction.
    pub step_resistances: Vec<crate::steps::StepResistance>,
    /// Baseline errors (learned battery, no effect), training and held-out.
    pub baseline: TrainHeld,
    /// Errors with the selected effects, training and held-out.
    pub after: TrainHeld,
    /// The held-out headline gap before and after, at the level the shares are of.
    pub headline: HeadlineGap,
    /// Every model tried.
    pub candidates: Vec<Candidate>,
    /// Effects selected on the training flights but dropped on the held-out ones.
    pub rejected: Vec<Rejected>,
    /// Effects not in the verdict that these flights cannot tell from it ([`look_alikes`]).
    pub look_alikes: Vec<LookAlike>,
    /// Stability of each selected parameter between the early and the late half.
    pub stability: Vec<Stability>,
    /// What remains after the selected effects (when the gap is not within noise).
    pub residual: Option<Residual>,
    /// Training and held-out flight names.
    pub split: Split,
    /// Per-flight residuals of the baseline on held-out flights.
    pub heldout_baseline: Vec<FlightResiduals>,
    /// Per-flight residuals of the selected model on held-out flights.
    pub heldout_after: Vec<FlightResiduals>,
}

impl Diagnosis {
    /// Held-out mean voltage residual per phase, before and after the selected effects.
    pub fn heldout_voltage_by_phase(&self) -> Vec<PhaseBeforeAfter> {
        let phase_mean = |res: &[FlightResiduals], p: Phase| {
            let v: Vec<f64> = res
                .iter()
                .flat_map(|r| {
                    r.voltage_by_phase_v
                        .iter()
                        .filter(|x| x.phase == p)
                        .map(|x| x.residual_v)
                })
                .collect();
            mean(&v)
        };
        Phase::ALL
            .into_iter()
            .filter_map(|phase| {
                Some(PhaseBeforeAfter {
                    phase,
                    before_v: phase_mean(&self.heldout_baseline, phase)?,
                    after_v: phase_mean(&self.heldout_after, phase)?,
                })
            })
            .collect()
    }

    /// The effect parameters of the selected model.
    pub fn selected_params(&self) -> EffectParams {
        let mut p = EffectParams::baseline();
        if let Some(h) = &self.healthy_resistance {
            p.set(Effect::InternalResistance, h.extra_ohm);
        }
        for e in &self.effects {
            p.set(e.effect, e.parameter.value);
        }
        p
    }
}

/// An effect outside the verdict that the flights cannot tell from it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LookAlike {
    /// The effect.
    pub effect: Effect,
    /// How much it lowers the training χ² fitted alone.
    pub training_chi2_drop: f64,
    /// The same for the effect that fits the training flights best alone.
    pub best_single: Effect,
    /// Its drop of the training χ².
    pub best_single_chi2_drop: f64,
    /// The held-out headline error (endurance %, else energy per phase %, else voltage V)
    /// before any effect, and with this effect alone.
    pub heldout_before: f64,
    /// With this effect alone.
    pub heldout_alone: f64,
}

/// Effects the flights cannot tell from the verdict: fitted alone, each lowers the training χ²
/// by more than the search's step (`min_delta_chi2`) and by at least half as much as the
/// effect that fits best alone, and alone it also lowers the held-out headline error. The
/// search names one of several such effects, and with eight flights of one pack flown alike
/// the choice often rests on the voltage's level rather than on what the effects physically
/// change (a fade, a Peukert loss and a healthy pack's own resistance all shorten a flight; the
/// blind study's `outranked` misses, issue 9, session 18). An extra series resistance kept
/// unnamed as a healthy pack's (`resistance_kept_unnamed`) is in the model already, so it is not
/// listed. Read from the search's own candidates: nothing is fitted again. Best first.
pub fn look_alikes(
    candidates: &[Candidate],
    verdict: &[Effect],
    resistance_kept_unnamed: bool,
    min_delta_chi2: f64,
) -> Vec<LookAlike> {
    let Some(base) = candidates.iter().find(|c| c.effects.is_empty()) else {
        return Vec::new();
    };
    let level_of = |e: &LevelErrors| e.endurance_pct.or(e.phase_energy_pct).or(e.voltage_rmse_v);
    let Some(before) = level_of(&base.heldout) else {
        return Vec::new();
    };
    let singles: Vec<&Candidate> = candidates.iter().filter(|c| c.effects.len() == 1).collect();
    let Some(best) = singles.iter().min_by(|a, b| a.chi2.total_cmp(&b.chi2)) else {
        return Vec::new();
    };
    let best_drop = base.chi2 - best.chi2;
    let mut out: Vec<LookAlike> = singles
        .iter()
        .filter(|c| !verdict.contains(&c.effects[0]))
        .filter(|c| !(resistance_kept_unnamed && c.effects[0] == Effect::InternalResistance))
        .filter_map(|c| {
            let drop = base.chi2 - c.chi2;
            let alone = level_of(&c.heldout)?;
            (drop > min_delta_chi2 && drop >= 0.5 * best_drop && alone < before).then(|| {
                LookAlike {
                    effect: c.effects[0],
                    training_chi2_drop: drop,
                    best_single: best.effects[0],
                    best_single_chi2_drop: best_drop,
                    heldout_before: before,
                    heldout_alone: alone,
                }
            })
        })
        .collect();
    out.sort_by(|a, b| b.training_chi2_drop.total_cmp(&a.training_chi2_drop));
    out
}

/// The series resistance of one battery type in the selected model against what a healthy
/// pack of its chemistry and size has.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TypeResistance {
    /// The battery type.
    pub battery_type: String,
    /// The chemistry of its fit (its prior).
    pub chemistry: Chemistry,
    /// Its rated capacity, Ah.
    pub rated_capacity_ah: f64,
    /// Series resistance per cell in the selected model (the baseline's plus the extra over
    /// the cells), Ω.
    pub model_cell_ohm: f64,
    /// The highest series resistance per cell of a healthy pack of this chemistry and size
    /// ([`crate::model::healthy_cell_resistance_ohm`]), Ω.
    pub healthy_top_cell_ohm: f64,
}

/// An `internal_resistance` the search selected whose total stays within the healthy band of
/// every battery type with logged current ([`healthy_resistance`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HealthyResistanceFound {
    /// The extra pack resistance kept in the model, Ω (the `internal_resistance` parameter).
    pub extra_ohm: f64,
    /// Per battery type with logged current, the model's resistance against the healthy top.
    pub types: Vec<TypeResistance>,
}

/// Whether a selected `internal_resistance` (`params`) is the pack's own, healthy resistance
/// rather than an effect: the baseline holds the series resistance at the nominal 5 mΩ per
/// cell at most ([`crate::model::baseline_cell_resistance_ohm`]), so the search also finds the
/// resistance a healthy pack has above that (cylindrical Li-ion and LiFePO₄ cells of drone
/// pack sizes have several times it). A resistance all flights of a pack share cannot be told
/// from a healthy pack of higher resistance by the flights alone, so the healthy band comes
/// from published cell data by chemistry and rated capacity
/// ([`crate::battery::Chemistry::healthy_resistance`]). `Some` when the extra is positive and,
/// for every training battery type with logged current (at least one), the baseline's
/// resistance per cell plus the extra over its cells stays at or under the healthy top; the
/// extra then stays in the model but is not named. A measured curve (no chemistry) or a fit
/// without a rated capacity has the nominal as its top, so any extra is named there, as
/// before.
pub fn healthy_resistance(
    batteries: &BatterySet,
    train: &[&FlightRecord],
    verdict: &[Effect],
    params: &EffectParams,
) -> Option<HealthyResistanceFound> {
    let extra_ohm = params.get(Effect::InternalResistance);
    if !verdict.contains(&Effect::InternalResistance) || extra_ohm <= 0.0 {
        return None;
    }
    let mut types = Vec::new();
    for (fit, base) in batteries.fits.iter().zip(&batteries.baselines) {
        if fit.current != CurrentSource::Logged {
            continue;
        }
        let cells = train
            .iter()
            .find(|f| battery_type(f) == fit.battery_type)
            .map(|f| f64::from(f.info.cells.max(1)))?;
        types.push(TypeResistance {
            battery_type: fit.battery_type.clone(),
            chemistry: fit.prior,
            rated_capacity_ah: fit.rated_capacity_ah,
            model_cell_ohm: base.series_resistance_cell_ohm + extra_ohm / cells,
            healthy_top_cell_ohm: crate::model::healthy_cell_resistance_ohm(
                fit.prior,
                fit.rated_capacity_ah,
            ),
        });
    }
    let healthy = !types.is_empty()
        && types
            .iter()
            .all(|t| t.model_cell_ohm <= t.healthy_top_cell_ohm);
    healthy.then_some(HealthyResistanceFound { extra_ohm, types })
}

/// The learned batteries of a flight set, by battery type, with the pooled one for types no
/// training flight had, and the baseline's version of each (its series resistance from
/// [`crate::model::baseline_cell_resistance_ohm`]).
#[derive(Debug, Clone, PartialEq)]
pub struct BatterySet {
    /// One fit per battery type among the training flights.
    pub fits: Vec<BatteryFit>,
    /// The baseline battery of each fit, in the same order.
    pub baselines: Vec<LearnedBattery>,
    /// Learned on every training flight together (baseline version).
    pub pooled: LearnedBattery,
}

impl BatterySet {
    /// The same battery for every flight (no learning).
    pub fn fixed(b: LearnedBattery) -> Self {
        Self {
            fits: Vec::new(),
            baselines: Vec::new(),
            pooled: b,
        }
    }

    /// The baseline battery of a flight.
    pub fn for_flight(&self, f: &FlightRecord) -> &LearnedBattery {
        let t = battery_type(f);
        self.fits
            .iter()
            .position(|b| b.battery_type == t)
            .map_or(&self.pooled, |k| &self.baselines[k])
    }
}

fn baseline_of(fit: &BatteryFit) -> LearnedBattery {
    let mut b = fit.battery;
    b.series_resistance_cell_ohm = crate::model::baseline_cell_resistance_ohm(
        &fit.battery,
        fit.current == CurrentSource::Logged,
    );
    b
}

/// Step 0: learns each battery type's open-circuit curve, series resistance and RC pair from
/// the training flights (see [`crate::battery`]). Flights without a current log get the
/// current the model's baseline power draws at their measured voltage.
pub fn learn_batteries<C: PowerCurve>(
    model: Model<'_, C>,
    train: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> BatterySet {
    let data: Vec<BatteryData<'_>> = train
        .iter()
        .map(|f| match &f.current_a {
            Some(c) => BatteryData {
                flight: f,
                current_a: c.clone(),
                source: CurrentSource::Logged,
            },
            None => {
                let w = model.power_series_w(f, &EffectParams::baseline());
                BatteryData {
                    flight: f,
                    current_a: w
                        .iter()
                        .zip(&f.voltage_v)
                        .map(|(w, v)| w / v.max(0.1))
                        .collect(),
                    source: CurrentSource::PowerModel,
                }
            }
        })
        .collect();
    let mut types: Vec<String> = data.iter().map(|d| battery_type(d.flight)).collect();
    types.sort();
    types.dedup();
    // A measured curve: `--battery-ocv-csv` for every type, else the one a type's flights name
    // in their metadata (`battery_ocv_csv`; the first flight's when they differ).
    let measured_of = |ds: &[BatteryData<'_>]| -> (Option<LearnedBattery>, bool) {
        if let Some(m) = opts.measured_ocv {
            return (Some(m), false);
        }
        let mut given = ds.iter().filter_map(|d| d.flight.info.measured_ocv);
        let first = given.next();
        let differ = first.is_some_and(|a| given.any(|b| b != a));
        (first, differ)
    };
    let mut fits: Vec<BatteryFit> = types
        .iter()
        .map(|t| {
            let mine: Vec<BatteryData<'_>> = data
                .iter()
                .filter(|d| battery_type(d.flight) == *t)
                .cloned()
                .collect();
            let (measured, differ) = measured_of(&mine);
            let mut fit = fit_battery(t, &mine, measured.as_ref(), opts.chemistry);
            if differ {
                fit.note.push_str(
                    "; its flights name different measured curves (battery_ocv_csv): the first flight's is used",
                );
            }
            fit
        })
        .collect();
    let pooled_fit = if fits.len() == 1 {
        fits[0].clone()
    } else {
        // Pooled over types, a measured curve only when every flight names the same one.
        let (measured, differ) = measured_of(&data);
        let all_named = opts.measured_ocv.is_some()
            || data.iter().all(|d| d.flight.info.measured_ocv.is_some());
        let measured = measured.filter(|_| all_named && !differ);
        fit_battery(
            "all training flights",
            &data,
            measured.as_ref(),
            opts.chemistry,
        )
    };
    let pooled = pooled_fit.battery;
    // A type whose own data could not teach the shape borrows the pooled shape.
    for f in &mut fits {
        if f.samples < crate::battery::MIN_SAMPLES && f.prior != crate::battery::Chemistry::Measured
        {
            f.battery.ocv_cell_v = pooled.ocv_cell_v;
            f.note
                .push_str("; the curve's shape from all training flights pooled");
        }
    }
    BatterySet {
        baselines: fits.iter().map(baseline_of).collect(),
        fits,
        pooled: baseline_of(&pooled_fit),
    }
}

/// Evaluates effect parameters on flights: the model with the learned batteries.
pub struct Evaluator<'a, C> {
    model: Model<'a, C>,
    batteries: &'a BatterySet,
    opts: DiagnoseOptions,
    /// What does not change with the effect parameters, per flight given to
    /// [`Self::with_flights`] (other flights have it computed at every call).
    known: Vec<Known<'a>>,
}

/// A flight's battery and the parts of its prediction and residuals that do not depend on the
/// effect parameters.
struct Known<'a> {
    flight: &'a FlightRecord,
    battery: &'a LearnedBattery,
    mean_ocv_cell_v: f64,
    consts: FlightConsts,
    phase_times_s: [f64; Phase::ALL.len()],
    /// Residuals already computed, by window and effect parameters (the searches try the same
    /// parameters on the same flight again and again: a fold of the cross-validation starts
    /// from the full fit and scans the same grid).
    memo: std::sync::Mutex<std::collections::HashMap<MemoKey, FlightResiduals>>,
}

/// A window and the bits of every effect's parameter (in [`Effect::ALL`] order): the
/// prediction of a flight depends on nothing else.
type MemoKey = (u8, [u64; Effect::ALL.len()]);

fn memo_key(p: &EffectParams, window: Window) -> MemoKey {
    let w = match window {
        Window::All => 0,
        Window::Early => 1,
        Window::Late => 2,
    };
    (w, Effect::ALL.map(|e| p.get(e).to_bits()))
}

impl<'a, C: PowerCurve> Evaluator<'a, C> {
    /// An evaluator of `model` with `batteries`.
    pub fn new(model: Model<'a, C>, batteries: &'a BatterySet, opts: &DiagnoseOptions) -> Self {
        Self::with_flights(model, batteries, opts, &[])
    }

    /// An evaluator that prepares `flights` once (their battery and whatever of their
    /// prediction does not depend on the effect parameters): the same results as
    /// [`Self::new`], faster on those flights.
    pub fn with_flights(
        model: Model<'a, C>,
        batteries: &'a BatterySet,
        opts: &DiagnoseOptions,
        flights: &[&'a FlightRecord],
    ) -> Self {
        let mut known: Vec<Known<'a>> = Vec::with_capacity(flights.len());
        for &f in flights {
            if known.iter().any(|k| std::ptr::eq(k.flight, f)) {
                continue;
            }
            let battery = batteries.for_flight(f);
            // One battery is shared by many flights: its mean is the same number each time.
            let mean_ocv_cell_v = known
                .iter()
                .find(|k| std::ptr::eq(k.battery, battery))
                .map_or_else(|| battery.mean_ocv_cell_v(), |k| k.mean_ocv_cell_v);
            known.push(Known {
                flight: f,
                battery,
                mean_ocv_cell_v,
                consts: FlightConsts::new(&model, f, true),
                phase_times_s: phase_times_s(f),
                memo: std::sync::Mutex::default(),
            });
        }
        Self {
            model,
            batteries,
            opts: *opts,
            known,
        }
    }

    fn known(&self, f: &FlightRecord) -> Option<&Known<'a>> {
        // The known flights are borrowed for 'a: the same address is the same, unchanged
        // flight.
        self.known.iter().find(|k| std::ptr::eq(k.flight, f))
    }

    fn stride(&self, f: &FlightRecord) -> usize {
        (f.time_s.len() / self.opts.points_per_flight.max(1)).max(1)
    }

    /// The prediction for one flight.
    pub fn predict(&self, f: &FlightRecord, p: &EffectParams, stride: usize) -> Prediction {
        match self.known(f) {
            Some(k) => {
                self.model
                    .predict_with(f, k.battery, k.mean_ocv_cell_v, &k.consts, p, stride)
            }
            None => self
                .model
                .predict(f, self.batteries.for_flight(f), p, stride),
        }
    }

    /// `with` applied to the residuals of `f` under `p` over `window`.
    fn with_residuals<R>(
        &self,
        f: &FlightRecord,
        p: &EffectParams,
        window: Window,
        with: impl FnOnce(&FlightResiduals) -> R,
    ) -> R {
        let Some(k) = self.known(f) else {
            let pred = self.predict(f, p, self.stride(f));
            return with(&residuals(f, &pred, &self.opts, window));
        };
        let key = memo_key(p, window);
        let lock = || {
            k.memo
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some(r) = lock().get(&key) {
            return with(r);
        }
        let pred = self.predict(f, p, self.stride(f));
        let r = residuals_with(f, &pred, &self.opts, window, &k.phase_times_s);
        let out = with(&r);
        lock().insert(key, r);
        out
    }

    /// Residuals of every flight.
    pub fn residuals(&self, flights: &[&FlightRecord], p: &EffectParams) -> Vec<FlightResiduals> {
        self.residuals_in(flights, p, Window::All)
    }

    fn residuals_in(
        &self,
        flights: &[&FlightRecord],
        p: &EffectParams,
        window: Window,
    ) -> Vec<FlightResiduals> {
        flights
            .iter()
            .map(|f| self.with_residuals(f, p, window, FlightResiduals::clone))
            .collect()
    }

    fn chi2(&self, flights: &[&FlightRecord], p: &EffectParams) -> f64 {
        self.chi2_in(flights, p, Window::All)
    }

    fn chi2_in(&self, flights: &[&FlightRecord], p: &EffectParams, window: Window) -> f64 {
        flights
            .iter()
            .map(|f| self.with_residuals(f, p, window, |r| r.chi2))
            .sum()
    }

    /// Minimises χ² over the parameters of `effects` within their bounds (a coarse scan then a
    /// golden section per coordinate; a few sweeps for several effects).
    fn fit_in(
        &self,
        flights: &[&FlightRecord],
        effects: &[Effect],
        start: &EffectParams,
        window: Window,
    ) -> (EffectParams, f64) {
        let mut p = start.clone();
        for &e in effects {
            if !p.values.iter().any(|(x, _)| *x == e) {
                p.set(e, e.neutral());
            }
        }
        let sweeps = if effects.len() > 1 { 3 } else { 1 };
        let mut best = self.chi2_in(flights, &p, window);
        for _ in 0..sweeps {
            for &e in effects {
                let (lo, hi) = e.bounds();
                let f = |x: f64| {
                    let mut q = p.clone();
                    q.set(e, x);
                    self.chi2_in(flights, &q, window)
                };
                let steps = 12;
                let mut bx = p.get(e);
                let mut bv = best;
                for s in 0..=steps {
                    let x = lo + (hi - lo) * f64::from(s) / f64::from(steps);
                    let v = f(x);
                    if v < bv {
                        bv = v;
                        bx = x;
                    }
                }
                let w = (hi - lo) / f64::from(steps);
                let (a, b) = ((bx - w).max(lo), (bx + w).min(hi));
                let (x, v) = golden_min(&f, a, b, 30);
                if v < bv {
                    bv = v;
                    bx = x;
                }
                if bv <= best {
                    best = bv;
                    p.set(e, bx);
                }
            }
        }
        (p, best)
    }

    fn fit(
        &self,
        flights: &[&FlightRecord],
        effects: &[Effect],
        start: &EffectParams,
    ) -> (EffectParams, f64) {
        self.fit_in(flights, effects, start, Window::All)
    }

    /// Standard error of one parameter from the χ² curvature (Δχ² = 1).
    fn std_error_in(
        &self,
        flights: &[&FlightRecord],
        p: &EffectParams,
        e: Effect,
        window: Window,
    ) -> f64 {
        let (lo, hi) = e.bounds();
        let h = (hi - lo) * 1e-3;
        let x = p.get(e).clamp(lo + h, hi - h);
        let at = |v: f64| {
            let mut q = p.clone();
            q.set(e, v);
            self.chi2_in(flights, &q, window)
        };
        let c = (at(x + h) - 2.0 * at(x) + at(x - h)) / (h * h);
        if c > 0.0 {
            (2.0 / c).sqrt()
        } else {
            f64::INFINITY
        }
    }

    /// Cross-validated χ² of a model: flights split round-robin into folds, each fold
    /// predicted with parameters fitted on the others (warm-started from `full`).
    fn cv_chi2(&self, flights: &[&FlightRecord], effects: &[Effect], full: &EffectParams) -> f64 {
        let folds = self.opts.cv_folds.min(flights.len()).max(2);
        let mut total = 0.0;
        for k in 0..folds {
            let in_fold = |i: &usize| i % folds == k;
            let fit_on: Vec<&FlightRecord> = flights
                .iter()
                .enumerate()
                .filter(|(i, _)| !in_fold(i))
                .map(|(_, f)| *f)
                .collect();
            let test: Vec<&FlightRecord> = flights
                .iter()
                .enumerate()
                .filter(|(i, _)| in_fold(i))
                .map(|(_, f)| *f)
                .collect();
            let p = if effects.is_empty() || fit_on.is_empty() {
                full.clone()
            } else {
                self.fit(&fit_on, effects, full).0
            };
            total += self.chi2(&test, &p);
        }
        total
    }
}

/// A per-flight covariate: its name and how to read it.
type Covariate = (&'static str, fn(&FlightRecord) -> Option<f64>);

/// Step 1: where the gap sits, from the baseline residuals of every flight.
pub fn localise(flights: &[&FlightRecord], res: &[FlightResiduals]) -> Where {
    // Energy gap by phase: (measured − predicted) power × time.
    let mut by_phase: Vec<PhaseShare> = Vec::new();
    for r in res {
        for pp in &r.phase_power {
            let e = ((pp.measured_w - pp.predicted_w) * pp.time_s).abs();
            match by_phase.iter_mut().find(|x| x.phase == pp.phase) {
                Some(x) => x.share += e,
                None => by_phase.push(PhaseShare {
                    phase: pp.phase,
                    share: e,
                }),
            }
        }
    }
    let total: f64 = by_phase.iter().map(|x| x.share).sum();
    if total > 0.0 {
        for x in &mut by_phase {
            x.share /= total;
        }
    }
    let mut vp: Vec<(Phase, Vec<f64>)> = Vec::new();
    for r in res {
        for x in &r.voltage_by_phase_v {
            match vp.iter_mut().find(|(p, _)| *p == x.phase) {
                Some((_, l)) => l.push(x.residual_v),
                None => vp.push((x.phase, vec![x.residual_v])),
            }
        }
    }
    let per_third = thirds_of(res);
    let sq: f64 = per_third.iter().map(|v| v.unwrap_or(0.0).powi(2)).sum();
    let by_state_of_charge = THIRDS
        .iter()
        .zip(&per_third)
        .map(|(n, v)| {
            let v = v.unwrap_or(0.0);
            ChargeThird {
                part: (*n).to_owned(),
                residual_v: v,
                share: if sq > 0.0 { v * v / sq } else { 0.0 },
            }
        })
        .collect();
    let err: Vec<f64> = res
        .iter()
        .map(|r| r.endurance_error.map_or(r.voltage_rmse_v, |e| e * 100.0))
        .collect();
    let covs: [Covariate; 7] = [
        ("payload_mass_kg", |f| Some(f.info.payload_mass_kg)),
        ("payload_power_w", |f| Some(f.info.payload_power_w)),
        ("battery_energy_wh", |f| Some(f.info.battery_energy_wh)),
        ("battery_cycles", |f| f.info.battery_cycles.map(f64::from)),
        ("ambient_temperature_c", |f| f.info.ambient_temperature_c),
        ("air_density_kg_m3", |f| f.info.air_density_kg_m3),
        ("time_attached_fraction", |f| {
            let a = f.phase.iter().filter(|p| **p == Phase::Attached).count();
            Some(a as f64 / f.phase.len().max(1) as f64)
        }),
    ];
    let mut by_covariate = Vec::new();
    for (name, get) in covs.iter() {
        let (x, y): (Vec<f64>, Vec<f64>) = flights
            .iter()
            .zip(&err)
            .filter_map(|(f, e)| get(f).map(|x| (x, *e)))
            .unzip();
        if let Some(r) = pearson(&x, &y) {
            by_covariate.push(CovariateCorrelation {
                name: (*name).to_owned(),
                r,
                r2: r * r,
            });
        }
    }
    Where {
        by_phase,
        voltage_by_phase_v: vp
            .into_iter()
            .filter_map(|(phase, v)| mean(&v).map(|residual_v| PhaseVoltage { phase, residual_v }))
            .collect(),
        by_state_of_charge,
        by_covariate,
    }
}

const THIRDS: [&str; 3] = ["early (full to 2/3)", "middle", "late (last third)"];

fn thirds_of(res: &[FlightResiduals]) -> [Option<f64>; 3] {
    let m = |k: usize| {
        mean(
            &res.iter()
                .filter_map(|r| r.voltage_by_charge_v[k])
                .collect::<Vec<_>>(),
        )
    };
    [m(0), m(1), m(2)]
}

/// One effect fitted alone on the training flights.
#[derive(Debug, Clone, PartialEq)]
pub struct SingleFit {
    /// The effect.
    pub effect: Effect,
    /// Fitted parameters.
    pub params: EffectParams,
    /// Training χ².
    pub chi2: f64,
}

/// Step 2: fits every observable effect alone on the training flights, best first.
pub fn fit_candidates<C: PowerCurve>(
    ev: &Evaluator<'_, C>,
    train: &[&FlightRecord],
) -> Vec<SingleFit> {
    let base = EffectParams::baseline();
    let mut singles: Vec<SingleFit> = Effect::ALL
        .into_iter()
        .filter(|e| e.observable(train))
        .map(|effect| {
            let (params, chi2) = ev.fit(train, &[effect], &base);
            SingleFit {
                effect,
                params,
                chi2,
            }
        })
        .collect();
    singles.sort_by(|a, b| a.chi2.total_cmp(&b.chi2));
    singles
}

/// The outcome of the selection on the training flights.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Selected effects, in the order they were added.
    pub effects: Vec<Effect>,
    /// Their fitted parameters.
    pub params: EffectParams,
    /// Every model tried.
    pub candidates: Vec<Candidate>,
}

/// Step 3: forward selection: the single that most lowers the cross-validated χ² (and the
/// BIC) by at least `min_delta_bic`, then each further effect among the three best singles
/// that does the same on top, up to `max_effects`.
pub fn select<C: PowerCurve>(
    ev: &Evaluator<'_, C>,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    singles: &[SingleFit],
    within_noise: bool,
) -> Selection {
    let opts = &ev.opts;
    let th = opts.thresholds;
    let base = EffectParams::baseline();
    let base_res = ev.residuals(train, &base);
    let n_obs: f64 = base_res.iter().map(|r| r.n_obs).sum::<f64>().max(1.0);
    let ln_n = n_obs.ln();
    let chi2_0: f64 = base_res.iter().map(|r| r.chi2).sum();
    let candidate = |effects: &[Effect], p: &EffectParams, chi2: f64, cv: Option<f64>| Candidate {
        effects: effects.to_vec(),
        values: effects.iter().map(|e| p.get(*e)).collect(),
        chi2,
        bic: chi2 + effects.len() as f64 * ln_n,
        cv_chi2: cv,
        heldout: LevelErrors::of(&ev.residuals(heldout, p)),
    };
    let base_cv = ev.cv_chi2(train, &[], &base);
    let mut candidates = vec![candidate(&[], &base, chi2_0, Some(base_cv))];
    let mut chosen: Vec<Effect> = Vec::new();
    let mut params = base.clone();
    let (mut best_cv, mut best_bic) = (base_cv, chi2_0);
    for (rank, s) in singles.iter().enumerate() {
        let promising = opts.max_effects >= 1
            && rank < 3
            && chi2_0 - s.chi2 > th.min_delta_bic
            && !within_noise;
        let cv = promising.then(|| ev.cv_chi2(train, &[s.effect], &s.params));
        candidates.push(candidate(&[s.effect], &s.params, s.chi2, cv));
        if let Some(cv) = cv {
            let bic = s.chi2 + ln_n;
            if best_cv - cv >= th.min_delta_bic && best_bic - bic >= th.min_delta_bic {
                best_cv = cv;
                best_bic = bic;
                chosen = vec![s.effect];
                params = s.params.clone();
            }
        }
    }
    // Further effects, one at a time, among the three best singles.
    while !chosen.is_empty() && chosen.len() < opts.max_effects {
        let mut step: Option<(Effect, EffectParams, f64, f64)> = None;
        for s in singles
            .iter()
            .take(3)
            .filter(|s| !chosen.contains(&s.effect))
        {
            let mut set = chosen.clone();
            set.push(s.effect);
            let (p, chi2) = ev.fit(train, &set, &params);
            let bic = chi2 + set.len() as f64 * ln_n;
            let cv = (best_bic - bic >= th.min_delta_bic).then(|| ev.cv_chi2(train, &set, &p));
            candidates.push(candidate(&set, &p, chi2, cv));
            if let Some(cv) = cv {
                if best_cv - cv >= th.min_delta_bic && step.as_ref().is_none_or(|x| cv < x.2) {
                    step = Some((s.effect, p, cv, bic));
                }
            }
        }
        match step {
            Some((e, p, cv, bic)) => {
                chosen.push(e);
                params = p;
                best_cv = cv;
                best_bic = bic;
            }
            None => break,
        }
    }
    Selection {
        effects: chosen,
        params,
        candidates,
    }
}

fn with_only(params: &EffectParams, set: &[Effect]) -> EffectParams {
    let mut q = EffectParams::baseline();
    for e in set {
        q.set(*e, params.get(*e));
    }
    q
}

/// Step 4: judges the selection on what it physically changes on the held-out flights: an
/// effect without which the held-out endurance (else phase-power) error is lower is dropped,
/// and so is one whose share of the gap is negative. Returns the kept effects and the dropped
/// ones with the reason.
pub fn judge_on_heldout<C: PowerCurve>(
    ev: &Evaluator<'_, C>,
    heldout: &[&FlightRecord],
    selection: &Selection,
) -> (Vec<Effect>, Vec<Rejected>) {
    // Endurance first, else energy per phase; only when the held-out flights measure neither,
    // the voltage trajectory.
    let physical = |set: &[Effect]| {
        let e = LevelErrors::of(&ev.residuals(heldout, &with_only(&selection.params, set)));
        e.endurance_pct.or(e.phase_energy_pct).or(e.voltage_rmse_v)
    };
    let base_errors = LevelErrors::of(&ev.residuals(heldout, &EffectParams::baseline()));
    let unit = if base_errors.endurance_pct.is_some() {
        "endurance (%)"
    } else if base_errors.phase_energy_pct.is_some() {
        "energy-per-phase (%)"
    } else {
        "voltage (V)"
    };
    let mut kept = selection.effects.clone();
    let mut rejected = Vec::new();
    while let Some(with) = physical(&kept) {
        let mut worst: Option<(Effect, f64, String)> = None;
        for &e in &kept {
            let without: Vec<Effect> = kept.iter().copied().filter(|x| *x != e).collect();
            let wo = physical(&without).unwrap_or(with);
            let base = physical(&[]).unwrap_or(with);
            let alone = physical(&[e]).unwrap_or(base);
            let reason = if wo < with {
                Some(format!(
                    "held-out {unit} error {wo:.3} without it, {with:.3} with it"
                ))
            } else if alone > base {
                Some(format!(
                    "negative share: alone it takes the held-out {unit} error from {base:.3} to {alone:.3}"
                ))
            } else {
                None
            };
            if let Some(r) = reason {
                let harm = with - wo;
                if worst.as_ref().is_none_or(|w| harm > w.1) {
                    worst = Some((e, harm, r));
                }
            }
        }
        match worst {
            Some((e, _, reason)) => {
                kept.retain(|x| *x != e);
                rejected.push(Rejected { effect: e, reason });
            }
            None => break,
        }
    }
    (kept, rejected)
}

/// Step 5: a right model explains the early and the late half of the flights with the same
/// parameters; an effect standing in for something else drifts between them.
///
/// Each half is fitted on every sample in it: the late half with the endurance, the early half
/// with the samples past a predicted cut-off compared with the cut-off voltage
/// ([`Window::Early`]). Without that, an early-half fit of a cut-off flight could empty its
/// window by predicting the pack empty at once and pay nothing: an extra series resistance
/// fitted there ran to about 0.33 Ω (against about 0.03 Ω on the late half and the whole
/// flight) on most sets of the blind study's tuning families, and was called unstable whatever
/// the truth.
pub fn check_stability<C: PowerCurve>(
    ev: &Evaluator<'_, C>,
    train: &[&FlightRecord],
    effects: &[Effect],
    params: &EffectParams,
) -> Vec<Stability> {
    effects
        .iter()
        .map(|&e| {
            let (pe, _) = ev.fit_in(train, &[e], params, Window::Early);
            let (pl, _) = ev.fit_in(train, &[e], params, Window::Late);
            let se = ev.std_error_in(train, &pe, e, Window::Early);
            let sl = ev.std_error_in(train, &pl, e, Window::Late);
            let z = (pe.get(e) - pl.get(e)).abs() / (se * se + sl * sl).sqrt();
            // Each half's reduced χ² (≥ 1): how far its residuals exceed the noise floors.
            let reduced = |p: &EffectParams, window: Window| {
                let res = ev.residuals_in(train, p, window);
                let n: f64 = res.iter().map(|r| r.n_obs).sum();
                let c: f64 = res.iter().map(|r| r.chi2).sum();
                if n > 0.0 { (c / n).max(1.0) } else { 1.0 }
            };
            let (ke, kl) = (reduced(&pe, Window::Early), reduced(&pl, Window::Late));
            let z_scatter = (pe.get(e) - pl.get(e)).abs() / (se * se * ke + sl * sl * kl).sqrt();
            Stability {
                effect: e,
                early: pe.get(e),
                late: pl.get(e),
                z: if z.is_finite() { z } else { 0.0 },
                z_scatter: if z_scatter.is_finite() {
                    z_scatter
                } else {
                    0.0
                },
            }
        })
        .collect()
}

/// "internal_resistance is unstable: 0.3100 fitted on the early half …".
pub fn unstable_sentence(s: &Stability) -> String {
    format!(
        "{} is unstable: {:.4} fitted on the early half of the flights, {:.4} on the late half ({:.1} standard errors apart against the fixed noise floors, {:.1} against the flights' own scatter)",
        s.effect.name(),
        s.early,
        s.late,
        s.z,
        s.z_scatter
    )
}

/// Step 6: each effect's Shapley share of the held-out headline gap (the mean, over every
/// order of adding the effects, of the gap it closes when added).
pub fn attribute_shares<C: PowerCurve>(
    ev: &Evaluator<'_, C>,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    effects: &[Effect],
    params: &EffectParams,
    level: Level,
) -> Vec<FittedEffect> {
    let n = effects.len();
    let gap_of = |mask: usize| -> f64 {
        let set: Vec<Effect> = (0..n)
            .filter(|k| mask & (1 << k) != 0)
            .map(|k| effects[k])
            .collect();
        let e = LevelErrors::of(&ev.residuals(heldout, &with_only(params, &set)));
        match level {
            Level::Endurance => e.endurance_pct.unwrap_or(0.0),
            Level::PhaseEnergy => e.phase_energy_pct.unwrap_or(0.0),
            Level::Voltage => e.voltage_rmse_v.unwrap_or(0.0),
        }
    };
    let gaps: Vec<f64> = (0..(1usize << n)).map(gap_of).collect();
    let g0 = gaps[0];
    let all = gaps[(1 << n) - 1];
    let fact = |k: usize| (1..=k).map(|x| x as f64).product::<f64>();
    let pct = |v: f64| (level != Level::Voltage).then_some(v);
    effects
        .iter()
        .enumerate()
        .map(|(k, &e)| {
            // Shapley: Σ over subsets S without k of |S|!(n−|S|−1)!/n! · (g(S) − g(S∪k)).
            let mut share = 0.0;
            for mask in 0..(1usize << n) {
                if mask & (1 << k) != 0 {
                    continue;
                }
                let s = mask.count_ones() as usize;
                let w = fact(s) * fact(n - s - 1) / fact(n);
                share += w * (gaps[mask] - gaps[mask | (1 << k)]);
            }
            FittedEffect {
                effect: e,
                parameter: Parameter {
                    name: e.parameter_name().to_owned(),
                    value: params.get(e),
                },
                std_error: ev.std_error_in(train, params, e, Window::All),
                share_of_gap: if g0 > 0.0 { share / g0 } else { 0.0 },
                heldout_error_before_pct: pct(g0),
                heldout_error_after_pct: pct(all),
            }
        })
        .collect()
}

/// Names what is left of the gap after the selected effects, from the held-out residuals.
pub fn describe_residual(after: &[FlightResiduals], errors: &LevelErrors) -> Residual {
    let thirds = thirds_of(after);
    let mut parts = Vec::new();
    if let Some(e) = errors.endurance_pct {
        let bias = mean(
            &after
                .iter()
                .filter_map(|r| r.endurance_error.map(|x| x * 100.0))
                .collect::<Vec<_>>(),
        )
        .unwrap_or(0.0);
        parts.push(format!(
            "endurance off by {e:.2} % (the model flies {} on average)",
            if bias > 0.0 { "longer" } else { "shorter" }
        ));
    }
    if let Some(p) = errors.phase_energy_pct {
        parts.push(format!(
            "energy per phase off by {p:.2} % of the flight's energy"
        ));
    }
    let named: Vec<(usize, f64)> = thirds
        .iter()
        .enumerate()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect();
    if let Some(&(k, v)) = named.iter().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())) {
        let what = match (k, v < 0.0) {
            (2, true) => {
                "the late-discharge knee comes earlier or falls steeper than the learned curve's"
            }
            (2, false) => {
                "the voltage holds up longer at the end of the discharge than the learned curve says"
            }
            (0, true) => {
                "the voltage sags more at the start than the model says (early dynamics or a cold pack)"
            }
            (0, false) => "the pack starts higher than the learned curve says",
            (_, true) => "the voltage sits lower mid-discharge than the model says",
            (_, false) => "the voltage sits higher mid-discharge than the model says",
        };
        parts.push(format!(
            "voltage residual largest in the {} ({v:+.3} V): {what}",
            THIRDS[k]
        ));
    }
    Residual {
        description: parts.join("; "),
        voltage_rmse_v: errors.voltage_rmse_v,
        by_state_of_charge_v: thirds,
    }
}

/// Diagnoses the gap between the model and the flights: learns the batteries on `train`, fits
/// and selects on `train`, judges and reports on `heldout`. Errors when `max_effects` is above
/// the number of library effects.
pub fn diagnose<C: PowerCurve>(
    model: Model<'_, C>,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, GapError> {
    let batteries = learn_batteries(model, train, opts);
    diagnose_with(model, &batteries, train, heldout, opts)
}

/// [`diagnose`] with batteries already learned.
pub fn diagnose_with<C: PowerCurve>(
    model: Model<'_, C>,
    batteries: &BatterySet,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, GapError> {
    if opts.max_effects > Effect::ALL.len() {
        return Err(GapError::Options(format!(
            "max_effects {} is more than the {} effects in the library",
            opts.max_effects,
            Effect::ALL.len()
        )));
    }
    if train.is_empty() {
        return Err(GapError::NoFlights("training"));
    }
    if heldout.is_empty() {
        return Err(GapError::NoFlights("held-out"));
    }
    let all: Vec<&FlightRecord> = train.iter().chain(heldout).copied().collect();
    let ev = Evaluator::with_flights(model, batteries, opts, &all);
    let base = EffectParams::baseline();
    let base_train = ev.residuals(train, &base);
    let base_held = ev.residuals(heldout, &base);
    let baseline = TrainHeld {
        training: LevelErrors::of(&base_train),
        heldout: LevelErrors::of(&base_held),
    };
    let th = opts.thresholds;
    let within_noise = baseline.training.chi2_per_obs <= th.none_chi2_per_obs;

    let all_res: Vec<FlightResiduals> = base_train.iter().chain(&base_held).cloned().collect();
    let r#where = localise(&all, &all_res);

    let singles = fit_candidates(&ev, train);
    let selection = select(&ev, train, heldout, &singles, within_noise);
    let (verdict, rejected) = judge_on_heldout(&ev, heldout, &selection);
    let params = with_only(&selection.params, &verdict);
    let after_train = ev.residuals(train, &params);
    let after_held = ev.residuals(heldout, &params);
    let after = TrainHeld {
        training: LevelErrors::of(&after_train),
        heldout: LevelErrors::of(&after_held),
    };
    let stability = check_stability(&ev, train, &verdict, &params);
    let systematic = systematic::check(
        &after_train,
        &after_held,
        &CheckOptions {
            endurance_pct: opts.floors.endurance_fraction * 100.0,
            power_pct: opts.floors.power_fraction * 100.0,
            drift_pct: opts.floors.power_drift_fraction * 100.0,
            voltage_v: opts.floors.voltage_v,
            t_max: th.systematic_t,
            gross_miss_fraction: th.gross_miss_fraction,
        },
    );
    // The χ² rule: χ² left against the fixed floors, or an unstable effect.
    let fl = opts.floors;
    let mut chi2_reasons = Vec::new();
    if after.training.chi2_per_obs > th.unexplained_chi2_per_obs {
        chi2_reasons.push(format!(
            "χ² per observation left on the training flights is {:.2} against the fixed noise floors (voltage {} V, energy per phase {} %, endurance {} %), above {:.1}",
            after.training.chi2_per_obs,
            fl.voltage_v,
            fl.power_fraction * 100.0,
            fl.endurance_fraction * 100.0,
            th.unexplained_chi2_per_obs
        ));
    }
    for s in stability.iter().filter(|s| s.z > th.stability_z) {
        chi2_reasons.push(unstable_sentence(s));
    }
    let unexplained_by_chi2 = !within_noise && !chi2_reasons.is_empty();
    let unexplained_by_systematic = !within_noise && systematic.unexplained();
    let (unexplained, unexplained_reasons) = match opts.unexplained_rule {
        UnexplainedRule::Chi2 => (unexplained_by_chi2, chi2_reasons),
        UnexplainedRule::Systematic => (unexplained_by_systematic, systematic.reasons.clone()),
    };
    let cautions = match opts.unexplained_rule {
        UnexplainedRule::Chi2 => Vec::new(),
        UnexplainedRule::Systematic => stability
            .iter()
            .filter(|s| s.z_scatter > th.stability_z)
            .map(|s| format!("{} (not part of the systematic rule)", unstable_sentence(s)))
            .collect(),
    };
    let unexplained_reasons = if unexplained {
        unexplained_reasons
    } else {
        Vec::new()
    };
    let (level, before_h) = baseline.heldout.headline_level();
    let after_h = match level {
        Level::Endurance => after.heldout.endurance_pct,
        Level::PhaseEnergy => after.heldout.phase_energy_pct,
        Level::Voltage => after.heldout.voltage_rmse_v,
    }
    .unwrap_or(0.0);
    let effects = attribute_shares(&ev, train, heldout, &verdict, &params, level);
    // An extra resistance within what healthy packs of this chemistry and size have stays in
    // the model (`params`, so every prediction after the effects is unchanged) but is the
    // pack's own, not an effect.
    let healthy_resistance = healthy_resistance(batteries, train, &verdict, &params);
    let (verdict, effects) = if healthy_resistance.is_some() {
        (
            verdict
                .into_iter()
                .filter(|e| *e != Effect::InternalResistance)
                .collect(),
            effects
                .into_iter()
                .filter(|e| e.effect != Effect::InternalResistance)
                .collect(),
        )
    } else {
        (verdict, effects)
    };
    let residual = (!within_noise).then(|| describe_residual(&after_held, &after.heldout));
    let look_alikes = if within_noise {
        Vec::new()
    } else {
        look_alikes(
            &selection.candidates,
            &verdict,
            healthy_resistance.is_some(),
            th.min_delta_bic,
        )
    };
    Ok(Diagnosis {
        verdict,
        unexplained,
        unexplained_rule: opts.unexplained_rule,
        unexplained_reasons,
        cautions,
        unexplained_by_chi2,
        unexplained_by_systematic,
        within_noise,
        systematic,
        effects,
        healthy_resistance,
        r#where,
        batteries: batteries.fits.clone(),
        step_resistances: crate::steps::step_resistances(batteries, train),
        baseline,
        after,
        headline: HeadlineGap {
            level,
            before: before_h,
            after: after_h,
        },
        candidates: selection.candidates,
        look_alikes,
        rejected,
        stability,
        residual,
        split: Split {
            train: train.iter().map(|f| f.name.clone()).collect(),
            heldout: heldout.iter().map(|f| f.name.clone()).collect(),
        },
        heldout_baseline: base_held,
        heldout_after: after_held,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::FlightInfo;

    /// A 4S hover of 600 s at 1 Hz, from 16.4 V down to the 13.0 V cut-off it ended at.
    fn cutoff_flight() -> FlightRecord {
        let n = 601;
        let time_s: Vec<f64> = (0..n).map(f64::from).collect();
        FlightRecord {
            name: "hover".into(),
            voltage_v: time_s.iter().map(|t| 16.4 - 3.4 * t / 600.0).collect(),
            current_a: Some(vec![10.0; n as usize]),
            phase: vec![Phase::Hover; n as usize],
            time_s,
            altitude_m: None,
            info: FlightInfo {
                structure_mass_kg: f64::NAN,
                battery_mass_kg: f64::NAN,
                battery_energy_wh: 50.0,
                cells: 4,
                payload_mass_kg: 0.0,
                payload_power_w: 0.0,
                avionics_power_w: 2.0,
                battery_id: None,
                battery_cycles: None,
                ambient_temperature_c: None,
                air_density_kg_m3: None,
                cutoff_voltage_v: 13.0,
                ended_at_cutoff: true,
                ceiling_height_m: None,
                measured_ocv: None,
            },
        }
    }

    /// A fit of battery type `id` (prior `chemistry`, `rated_capacity_ah`, current `current`)
    /// whose baseline holds `baseline_cell_ohm` per cell.
    fn typed_fit(
        id: &str,
        chemistry: Chemistry,
        rated_capacity_ah: f64,
        current: CurrentSource,
        baseline_cell_ohm: f64,
    ) -> (BatteryFit, LearnedBattery) {
        let mut battery = LearnedBattery::lipo();
        battery.series_resistance_cell_ohm = 0.02;
        let mut base = battery;
        base.series_resistance_cell_ohm = baseline_cell_ohm;
        let fit = BatteryFit {
            battery_type: id.into(),
            battery,
            prior: chemistry,
            flights: 4,
            samples: 2400,
            soc_covered: (0.2, 1.0),
            rmse_cell_v: 0.02,
            current,
            note: String::new(),
            rated_capacity_ah,
            usable_capacity_ah: None,
            warnings: Vec::new(),
        };
        (fit, base)
    }

    fn set_of(fits: Vec<(BatteryFit, LearnedBattery)>) -> BatterySet {
        let (fits, baselines): (Vec<_>, Vec<_>) = fits.into_iter().unzip();
        BatterySet {
            pooled: baselines[0],
            fits,
            baselines,
        }
    }

    /// A 4S flight of battery type `id`.
    fn flight_of(id: &str) -> FlightRecord {
        let mut f = cutoff_flight();
        f.info.battery_id = Some(id.into());
        f
    }

    /// 0.06 Ω of extra pack resistance on a 4S, 3 Ah pack at a 5 mΩ baseline is 20 mΩ per
    /// cell: within a healthy cylindrical Li-ion pack of that size (up to 53 mΩ), far above a
    /// healthy LiPo (8 mΩ). Only the first is kept unnamed; a measured curve (no chemistry),
    /// flights without current, an effect not selected, or one type above its band leave it
    /// named.
    #[test]
    fn an_extra_resistance_within_the_healthy_band_is_the_packs_own() {
        use CurrentSource::{Logged, PowerModel};
        let f_a = flight_of("A");
        let f_b = flight_of("B");
        let train = [&f_a, &f_b];
        let mut p = EffectParams::baseline();
        p.set(Effect::InternalResistance, 0.06);
        let selected = [Effect::InternalResistance, Effect::Peukert];
        let nmc = |id| typed_fit(id, Chemistry::LiIonNmc, 3.0, Logged, 0.005);
        let lipo = |id| typed_fit(id, Chemistry::Lipo, 3.0, Logged, 0.005);
        let h = healthy_resistance(&set_of(vec![nmc("A"), nmc("B")]), &train, &selected, &p)
            .expect("within the band");
        assert_eq!(h.extra_ohm, 0.06);
        assert_eq!(h.types.len(), 2);
        let t = &h.types[0];
        assert!((t.model_cell_ohm - 0.020).abs() < 1e-12, "{t:?}");
        assert!((t.healthy_top_cell_ohm - 0.16 / 3.0).abs() < 1e-12, "{t:?}");
        // One type above its band: named.
        assert!(
            healthy_resistance(&set_of(vec![nmc("A"), lipo("B")]), &train, &selected, &p).is_none()
        );
        // A measured curve says no chemistry: the nominal is the top.
        let measured = typed_fit("A", Chemistry::Measured, 3.0, Logged, 0.005);
        assert!(healthy_resistance(&set_of(vec![measured]), &train, &selected, &p).is_none());
        // No type with logged current, or the effect not selected: nothing to keep.
        let no_current = typed_fit("A", Chemistry::LiIonNmc, 3.0, PowerModel, 0.005);
        assert!(healthy_resistance(&set_of(vec![no_current]), &train, &selected, &p).is_none());
        assert!(
            healthy_resistance(
                &set_of(vec![nmc("A"), nmc("B")]),
                &train,
                &[Effect::Peukert],
                &p
            )
            .is_none()
        );
        // Twice the extra (35 mΩ per cell) is still healthy for 3 Ah of NMC; 0.3 Ω (80 mΩ)
        // is not.
        p.set(Effect::InternalResistance, 0.12);
        assert!(healthy_resistance(&set_of(vec![nmc("A")]), &train, &selected, &p).is_some());
        p.set(Effect::InternalResistance, 0.3);
        assert!(healthy_resistance(&set_of(vec![nmc("A")]), &train, &selected, &p).is_none());
    }

    /// A prediction at `index` with the flight's voltage plus `offset_v` and `endurance_s`.
    fn prediction(
        f: &FlightRecord,
        index: Vec<usize>,
        offset_v: f64,
        endurance_s: f64,
    ) -> Prediction {
        let n = index.len();
        Prediction {
            voltage_v: index.iter().map(|&i| f.voltage_v[i] + offset_v).collect(),
            current_a: vec![10.0; n],
            power_w: index.iter().map(|&i| f.voltage_v[i] * 10.0).collect(),
            soc: index.iter().map(|&i| 1.0 - i as f64 / 600.0).collect(),
            index,
            endurance_s,
        }
    }

    /// The power drift is read within each phase: a flight that hovers and perches in turn,
    /// more of its first half hovering, whose model is 10 % low on the hover and right on the
    /// perch, has no drift (all samples pooled it would read one); one whose hover power rises
    /// by 6 % in the second half has +6.6 % (1.1 → 1.166; the perch, drawing a twentieth of
    /// the hover's power and steady, weighs next to nothing).
    #[test]
    fn the_power_drift_is_read_within_each_phase() {
        let mut f = cutoff_flight();
        let (hover_w, perched_w) = (160.0, 8.0);
        // At 1 Hz: hover 0–249 s, perched 250–349 s, hover 350–449 s, perched 450–600 s.
        let hovering = |i: usize| i < 250 || (350..450).contains(&i);
        f.phase = (0..601)
            .map(|i| {
                if hovering(i) {
                    Phase::Hover
                } else {
                    Phase::Attached
                }
            })
            .collect();
        let index: Vec<usize> = (0..601).collect();
        let mut pred = prediction(&f, index.clone(), 0.0, 600.0);
        pred.power_w = index
            .iter()
            .map(|&i| if hovering(i) { hover_w } else { perched_w })
            .collect();
        let measured = |drift: f64| -> Vec<f64> {
            index
                .iter()
                .map(|&i| {
                    let p = if !hovering(i) {
                        perched_w
                    } else if i >= 300 {
                        1.1 * hover_w * (1.0 + drift)
                    } else {
                        1.1 * hover_w
                    };
                    p / f.voltage_v[i]
                })
                .collect()
        };
        let opts = DiagnoseOptions::default();
        f.current_a = Some(measured(0.0));
        let steady = residuals(&f, &pred, &opts, Window::All);
        assert!(
            steady.power_drift.unwrap().abs() < 1e-9,
            "{:?}",
            steady.power_drift
        );
        f.current_a = Some(measured(0.06));
        let d = residuals(&f, &pred, &opts, Window::All)
            .power_drift
            .unwrap();
        assert!((d - 0.066).abs() < 1e-3, "{d}");
        // Not on a window: the drift needs both halves of the whole flight.
        assert_eq!(residuals(&f, &pred, &opts, Window::Early).power_drift, None);
    }

    /// The bias `check_stability` had: in the early half (no endurance term) a prediction
    /// that empties the pack at the first sample paid nothing for the samples it never
    /// reached, so it beat one that follows the whole flight within a few floors.
    #[test]
    fn the_early_window_pays_for_samples_past_the_predicted_cutoff() {
        let f = cutoff_flight();
        let opts = DiagnoseOptions::default();
        let empty_at_once = prediction(&f, vec![0], 0.0, 0.0);
        let close = prediction(&f, (0..601).collect(), 0.05, 600.0);
        let early_empty = residuals(&f, &empty_at_once, &opts, Window::Early);
        let early_close = residuals(&f, &close, &opts, Window::Early);
        // 0.05 V off against the 0.04 V floor: (0.05 / 0.04)² per voltage observation.
        let expected_close = opts.voltage_obs_per_flight * (0.05_f64 / 0.04).powi(2);
        assert!((early_close.chi2 - expected_close).abs() < 1e-6 * expected_close);
        assert!(
            early_empty.chi2 > 10.0 * early_close.chi2,
            "{} against {}",
            early_empty.chi2,
            early_close.chi2
        );
        assert_eq!(early_empty.endurance_error, None);
        // The early half's samples (16.4 V down to 14.7 V) against the 13.0 V cut-off.
        assert!(early_empty.voltage_rmse_v > 1.7 && early_empty.voltage_rmse_v < 3.4);
    }

    /// Flights of a 4S pack with 0.05 Ω of series resistance beyond the nominal, hovering
    /// until the cut-off, drawn from the model itself (`internal_resistance` = 0.05) with a
    /// dip mid-discharge that the learned curve lacks (0.1 V at its deepest, none at the start
    /// and at the cut-off). On such flights the early half's fit used to empty its window by
    /// predicting the pack empty as the rotors start (0.33 Ω); both halves must now find the
    /// resistance.
    #[test]
    fn a_true_extra_resistance_is_stable_between_the_halves() {
        use crate::battery::LearnedBattery;
        use crate::logs::ConstantPower;
        let curve = ConstantPower {
            hover_power_w: 150.0,
            reference_mass_kg: f64::NAN,
        };
        let model = Model {
            curve: &curve,
            rotor_count: 1,
        };
        let batteries = BatterySet::fixed(LearnedBattery::lipo());
        let mut truth = EffectParams::baseline();
        truth.set(Effect::InternalResistance, 0.05);
        let flights: Vec<FlightRecord> = (0..6)
            .map(|k| {
                let mut f = cutoff_flight();
                f.name = format!("hover{k}");
                let n = 3600;
                f.time_s = (0..n).map(f64::from).collect();
                f.phase = (0..n)
                    .map(|i| if i < 10 { Phase::Ground } else { Phase::Hover })
                    .collect();
                f.voltage_v = vec![16.8 - 0.02 * f64::from(k); n as usize];
                f.current_a = Some(vec![0.0; n as usize]);
                f.info.battery_energy_wh = 20.0 + f64::from(k);
                let pred = model.predict(&f, batteries.for_flight(&f), &truth, 1);
                let end = pred.index.len();
                assert!(end > 300 && end < 3000, "{end} samples");
                f.time_s.truncate(end);
                f.phase.truncate(end);
                let last_s = f.time_s[end - 1];
                f.voltage_v = pred
                    .voltage_v
                    .iter()
                    .zip(&f.time_s)
                    .map(|(v, t)| v - 0.1 * (std::f64::consts::PI * t / last_s).sin())
                    .collect();
                f.current_a = Some(pred.current_a.clone());
                f
            })
            .collect();
        let train: Vec<&FlightRecord> = flights.iter().collect();
        let ev = Evaluator::with_flights(model, &batteries, &DiagnoseOptions::default(), &train);
        let (params, _) = ev.fit(&train, &[Effect::InternalResistance], &truth);
        let s = check_stability(&ev, &train, &[Effect::InternalResistance], &params);
        assert!((s[0].early - 0.05).abs() < 0.01, "{s:?}");
        assert!((s[0].late - 0.05).abs() < 0.01, "{s:?}");
        let th = DiagnoseOptions::default().thresholds;
        assert!(s[0].z < th.stability_z, "{s:?}");
    }

    /// Where the endurance is counted (the whole flight, the late half) it alone pays for the
    /// samples the model did not reach: they are not counted twice.
    #[test]
    fn windows_with_the_endurance_do_not_count_missed_samples_twice() {
        let f = cutoff_flight();
        let opts = DiagnoseOptions::default();
        let empty_at_once = prediction(&f, vec![0], 0.0, 0.0);
        for window in [Window::All, Window::Late] {
            let r = residuals(&f, &empty_at_once, &opts, window);
            assert_eq!(r.endurance_error, Some(-1.0));
            let endurance_chi2 = (1.0 / opts.floors.endurance_fraction).powi(2);
            assert!(
                (r.chi2 - endurance_chi2).abs() < 1e-9 * endurance_chi2,
                "{window:?}"
            );
        }
    }

    #[test]
    fn look_alikes_fit_nearly_as_well_and_close_the_held_out_gap_too() {
        let cand = |effects: &[Effect], chi2: f64, heldout_pct: f64| Candidate {
            effects: effects.to_vec(),
            values: vec![0.1; effects.len()],
            chi2,
            bic: chi2,
            cv_chi2: None,
            heldout: LevelErrors {
                endurance_pct: Some(heldout_pct),
                phase_energy_pct: None,
                voltage_rmse_v: None,
                chi2_per_obs: 1.0,
            },
        };
        let candidates = vec![
            cand(&[], 1000.0, 6.0),
            cand(&[Effect::InternalResistance], 200.0, 4.0),
            // Half the best drop or more, and closes held-out: a look-alike.
            cand(&[Effect::Peukert], 550.0, 4.5),
            cand(&[Effect::CapacityFade], 400.0, 3.0),
            // Under half the best drop.
            cand(&[Effect::AirDensity], 700.0, 3.0),
            // Fits, but alone makes the held-out flights worse.
            cand(&[Effect::ControlOverhead], 300.0, 6.5),
            cand(&[Effect::InternalResistance, Effect::Peukert], 150.0, 3.5),
        ];
        let names = |v: Vec<LookAlike>| v.iter().map(|l| l.effect).collect::<Vec<_>>();
        let verdict = [Effect::InternalResistance];
        let l = look_alikes(&candidates, &verdict, false, 12.0);
        assert_eq!(names(l.clone()), [Effect::CapacityFade, Effect::Peukert]);
        assert_eq!(l[0].best_single, Effect::InternalResistance);
        assert!((l[0].best_single_chi2_drop - 800.0).abs() < 1e-9);
        assert!((l[0].training_chi2_drop - 600.0).abs() < 1e-9);
        assert_eq!((l[0].heldout_before, l[0].heldout_alone), (6.0, 3.0));
        // An empty verdict lists the best single too, unless it is a healthy pack's resistance
        // kept in the model.
        assert_eq!(
            names(look_alikes(&candidates, &[], false, 12.0)),
            [
                Effect::InternalResistance,
                Effect::CapacityFade,
                Effect::Peukert
            ]
        );
        assert_eq!(
            names(look_alikes(&candidates, &[], true, 12.0)),
            [Effect::CapacityFade, Effect::Peukert]
        );
        // A drop under the search's step is never a look-alike.
        assert!(look_alikes(&candidates, &verdict, false, 700.0).is_empty());
        // No baseline candidate: nothing to compare with.
        assert!(look_alikes(&candidates[1..], &verdict, false, 12.0).is_empty());
    }
}
