//! The diagnosis: fit the base model on the training runs, localise its residuals (thrust
//! region, time within the run, step direction, supply voltage), fit every candidate effect,
//! select by held-out error, a training information criterion, a per-run no-harm rule and a
//! stability check, and say honestly when the gap is within noise or unexplained.

use std::collections::BTreeMap;

use motor_model::fit::{self, NoiseFloors, Prior, Scale};
use motor_model::lm::LmOptions;
use motor_model::{Effect, Param, Params, Prediction, Quantity, Sweep};
use serde::Serialize;

use crate::{RigGapError, StandSweep};

/// Decision thresholds and fit settings. The thresholds and forms were tuned on blind-study
/// seeds 1000–1099, 0–99 and 2000–2099 (`hoverbench rig-gap-eval --seed 1000` …) and are
/// reported on the held-out seeds 7000–7199.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Options {
    /// Measurement noise floors residuals are normalised by when the data are too few to
    /// measure their scatter.
    pub floors: NoiseFloors,
    /// The least noise floors a measured scatter can lower them to.
    pub min_floors: NoiseFloors,
    /// Huber threshold, in noise σ.
    pub huber_delta: f64,
    /// Held-out χ² per observation at or below which the gap is within noise.
    pub none_chi2_per_obs: f64,
    /// Share by which an effect must cut the held-out χ² per observation.
    pub min_relative_gain: f64,
    /// Training BIC improvement an effect must bring.
    pub min_delta_bic: f64,
    /// Held-out χ² per observation added per extra parameter when ranking candidates.
    pub penalty_per_param: f64,
    /// Held-out χ² per observation left after the selected effects above which the gap is
    /// unexplained.
    pub unexplained_chi2_per_obs: f64,
    /// Largest difference, in standard errors, between an effect's parameters fitted on the two
    /// halves of the training data before the selection counts as unstable.
    pub stability_z: f64,
    /// Most effects combined.
    pub max_effects: usize,
    /// The candidate effects.
    pub candidates: Vec<Effect>,
    /// Base parameters held at known values instead of fitted (a [`crate::presets::Preset`]).
    pub fixed: Vec<(Param, f64)>,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            floors: NoiseFloors::default(),
            min_floors: NoiseFloors {
                power: (0.003, 0.002),
                voltage: (0.000_5, 0.000_5),
                speed: (0.002, 0.001),
                torque: (0.01, 0.005),
            },
            huber_delta: 3.0,
            none_chi2_per_obs: 3.0,
            min_relative_gain: 0.25,
            min_delta_bic: 6.0,
            penalty_per_param: 0.1,
            unexplained_chi2_per_obs: 6.0,
            stability_z: 5.0,
            max_effects: 2,
            candidates: Effect::ALL.to_vec(),
            fixed: Vec::new(),
        }
    }
}

/// A parameter's value and standard error; serialised as `{value, std_error, identified}`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Value.
    pub value: f64,
    /// Standard error (infinite when the data cannot determine it, 0 at a bound).
    pub std_error: f64,
}

impl Estimate {
    /// Whether the data determine it: a finite standard error no larger than the value's
    /// magnitude. Otherwise the fit is nearly flat in it, and the other parameters can take
    /// up what it would explain.
    pub fn identified(&self) -> bool {
        self.std_error.is_finite() && self.std_error <= self.value.abs()
    }
}

impl Serialize for Estimate {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct as _;
        let mut st = serializer.serialize_struct("Estimate", 3)?;
        st.serialize_field("value", &self.value)?;
        st.serialize_field("std_error", &self.std_error)?;
        st.serialize_field("identified", &self.identified())?;
        st.end()
    }
}

/// A fitted model and its errors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelReport {
    /// The effects in it.
    pub effects: Vec<Effect>,
    /// Fitted parameters.
    pub parameters: BTreeMap<&'static str, Estimate>,
    /// Training χ² per observation.
    pub train_chi2_per_obs: f64,
    /// Held-out χ² per observation.
    pub heldout_chi2_per_obs: f64,
    /// Held-out RMS error per quantity, % of the measured value (floored at 10 % of the
    /// quantity's largest value).
    pub heldout_error_pct: BTreeMap<&'static str, f64>,
    /// Held-out χ² per observation of every held-out run.
    pub heldout_chi2_by_run: Vec<(String, f64)>,
    /// Held-out χ² per observation of every quantity; the largest decides `none` and
    /// `unexplained`.
    pub heldout_chi2_by_quantity: BTreeMap<&'static str, f64>,
    #[serde(skip)]
    params: Params,
    #[serde(skip)]
    train_cost: f64,
    #[serde(skip)]
    train_n: usize,
}

/// One candidate's scores.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// The effects (the selected ones so far plus this candidate).
    pub effects: Vec<Effect>,
    /// Training BIC improvement over the model it extends.
    pub delta_bic: f64,
    /// Held-out χ² per observation.
    pub heldout_chi2_per_obs: f64,
    /// Held-out χ² per observation of every quantity.
    pub heldout_chi2_by_quantity: BTreeMap<&'static str, f64>,
    /// The fitted parameters of its effects.
    pub parameters: BTreeMap<&'static str, Estimate>,
    /// Whether it passed every selection rule.
    pub eligible: bool,
    /// Why not, if not.
    pub rejected_because: Option<String>,
}

/// A selected effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectReport {
    /// Its name.
    pub effect: &'static str,
    /// Its parameters with standard errors.
    pub parameters: BTreeMap<&'static str, Estimate>,
    /// Share of the held-out excess χ² (above noise) it removed.
    pub share_of_gap: f64,
    /// Held-out error per quantity before it was added, %.
    pub heldout_error_before_pct: BTreeMap<&'static str, f64>,
    /// Held-out error per quantity after, %.
    pub heldout_error_after_pct: BTreeMap<&'static str, f64>,
    /// Its parameters' largest disagreement between the two training halves, in σ.
    pub stability_z: Option<f64>,
}

/// Mean and RMS residual of one region, % of the measured value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Region {
    /// The region.
    pub region: &'static str,
    /// Mean residual (predicted − measured), %.
    pub mean_pct: f64,
    /// RMS residual, %.
    pub rms_pct: f64,
    /// Steps in it.
    pub steps: usize,
}

/// Where one quantity's residuals sit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QuantityWhere {
    /// The quantity.
    pub quantity: &'static str,
    /// Low, middle and top third of the thrust range.
    pub by_thrust: Vec<Region>,
    /// First and second half of each run (drift).
    pub by_time: Vec<Region>,
    /// Up and down steps.
    pub by_direction: Vec<Region>,
    /// Slope of the residual against the measured supply voltage, % per V.
    pub voltage_slope_pct_per_v: Option<f64>,
    /// Correlation of the residual with the measured supply voltage.
    pub voltage_correlation: Option<f64>,
}

/// Where the base model and the selected model part from the measurements (all runs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Where {
    /// Base model.
    pub before: Vec<QuantityWhere>,
    /// With the selected effects.
    pub after: Vec<QuantityWhere>,
}

/// One step's residuals, for plots.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepResidual {
    /// The run.
    pub run: String,
    /// Whether the run is held out.
    pub heldout: bool,
    /// The quantity.
    pub quantity: &'static str,
    /// Thrust reading, g.
    pub thrust_g: f64,
    /// Measured value.
    pub measured: f64,
    /// Base model residual, %.
    pub before_pct: f64,
    /// Selected model residual, %.
    pub after_pct: f64,
}

/// The diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// `["none"]`, `["unexplained"]`, or the selected effects' names.
    pub verdict: Vec<String>,
    /// Whether a significant residual is left that no candidate explains.
    pub unexplained: bool,
    /// Whether the base model is within noise on the held-out runs.
    pub within_noise: bool,
    /// The selected effects (also listed, as partial explanations, when `unexplained`).
    pub effects: Vec<EffectReport>,
    /// Where the residuals sit.
    pub r#where: Where,
    /// The base model.
    pub baseline: ModelReport,
    /// The selected model.
    pub after: ModelReport,
    /// Every candidate tried.
    pub candidates: Vec<Candidate>,
    /// Quantities compared.
    pub quantities: Vec<&'static str>,
    /// Training runs.
    pub train: Vec<String>,
    /// Held-out runs.
    pub heldout: Vec<String>,
    /// Per-step residuals before and after.
    pub steps: Vec<StepResidual>,
    /// What a user should know (unobservable parameters, …).
    pub notes: Vec<String>,
}

struct Ctx<'a> {
    train: Vec<&'a Sweep>,
    held: Vec<&'a Sweep>,
    qs: Vec<Quantity>,
    scale: Scale,
    opts: &'a Options,
    floors: NoiseFloors,
    priors: Vec<Prior>,
    lm: LmOptions,
}

fn huber2(r: f64, d: f64) -> f64 {
    let a = r.abs();
    if a <= d { r * r } else { 2.0 * d * a - d * d }
}

impl Ctx<'_> {
    fn chi2(&self, p: &Params, sweeps: &[&Sweep]) -> (f64, usize) {
        let mut r = Vec::new();
        fit::residuals(p, sweeps, &self.qs, &self.floors, &self.scale, &mut r);
        let n = r.len();
        (r.iter().map(|v| huber2(*v, self.opts.huber_delta)).sum(), n)
    }

    fn per_obs_of(&self, p: &Params, sweeps: &[&Sweep], q: Quantity) -> f64 {
        let mut r = Vec::new();
        fit::residuals(p, sweeps, &[q], &self.floors, &self.scale, &mut r);
        if r.is_empty() {
            0.0
        } else {
            r.iter()
                .map(|v| huber2(*v, self.opts.huber_delta))
                .sum::<f64>()
                / r.len() as f64
        }
    }

    fn per_obs(&self, p: &Params, sweeps: &[&Sweep]) -> f64 {
        let (c, n) = self.chi2(p, sweeps);
        if n == 0 { 0.0 } else { c / n as f64 }
    }

    fn error_pct(&self, p: &Params, sweeps: &[&Sweep]) -> BTreeMap<&'static str, f64> {
        let mut out = BTreeMap::new();
        for &q in &self.qs {
            let mut s = 0.0;
            let mut n = 0;
            for sw in sweeps {
                for (o, pr) in sw.steps.iter().zip(sw.predict(p)) {
                    if let Some(m) = o.measured(q) {
                        s += rel_pct(q.predicted(&pr), m, self.scale.max(q)).powi(2);
                        n += 1;
                    }
                }
            }
            if n > 0 {
                out.insert(q.name(), (s / n as f64).sqrt());
            }
        }
        out
    }

    fn fit(
        &self,
        sweeps: &[&Sweep],
        start: &Params,
        effects: &[Effect],
        short: &[Effect],
    ) -> fit::FitResult {
        let mut free: Vec<Param> = Param::BASE
            .iter()
            .copied()
            .filter(|p| !self.opts.fixed.iter().any(|f| f.0 == *p))
            .collect();
        for e in effects {
            free.extend_from_slice(if short.contains(e) {
                e.short_params()
            } else {
                e.params()
            });
        }
        // Several starts for the nonlinear effects; the best training cost wins.
        let mut starts = vec![*start];
        if effects.contains(&Effect::WindingHeating)
            && start.get(Param::ThermalResistanceKPerW) == 0.0
        {
            starts.clear();
            for (rth, tau) in [(3.0, 3.0), (3.0, 30.0)] {
                let mut s = *start;
                s.set(Param::ThermalResistanceKPerW, rth);
                s.set(Param::ThermalTauS, tau * self.scale.step_s);
                starts.push(s);
            }
        }
        if effects.contains(&Effect::LoadcellDrift) && start.get(Param::LoadcellRateGPerS) == 0.0 {
            let r = 0.002 * self.scale.max_thrust_g / self.scale.step_s;
            starts = starts
                .iter()
                .flat_map(|s| {
                    [(5.0, r), (50.0, r), (5.0, -r), (50.0, -r)].map(|(tau, rate)| {
                        let mut s = *s;
                        s.set(Param::LoadcellTauS, tau * self.scale.step_s);
                        s.set(Param::LoadcellRateGPerS, rate);
                        s
                    })
                })
                .collect();
        }
        // (In the short form with the polarisation branch off, its resistance 0 and not fitted,
        // its time constant changes no prediction: a second start would repeat the first fit.)
        let branch_off =
            short.contains(&Effect::SupplySag) && start.get(Param::PolarisationOhm) == 0.0;
        if effects.contains(&Effect::SupplySag)
            && start.get(Param::SourceResistanceOhm) == 0.0
            && !branch_off
        {
            starts = starts
                .iter()
                .flat_map(|s| {
                    [2.0, 10.0].map(|tau| {
                        let mut s = *s;
                        s.set(Param::PolarisationTauS, tau * self.scale.step_s);
                        s
                    })
                })
                .collect();
        }
        for s in &mut starts {
            for e in effects {
                for &p in e.params() {
                    if s.get(p) == 0.0 {
                        let (lo, hi) = fit::bounds(p, &self.scale);
                        let v = match p {
                            Param::SourceResistanceOhm => 0.05 * hi,
                            Param::EscPartialLoss => 0.05,
                            Param::BlockageFraction => 0.02,
                            _ => 0.0,
                        };
                        s.set(p, v.clamp(lo, hi));
                    }
                }
            }
        }
        starts
            .iter()
            .map(|s| fit::fit(sweeps, s, &free, &self.priors, &self.floors, &self.lm))
            .min_by(|a, b| a.data_cost.total_cmp(&b.data_cost))
            .expect("at least one start")
    }

    fn report(&self, effects: &[Effect], r: &fit::FitResult) -> ModelReport {
        let (c, n) = self.chi2(&r.params, &self.train);
        let mut parameters = BTreeMap::new();
        for &(p, se) in &r.std_errors {
            parameters.insert(
                p.name(),
                Estimate {
                    value: r.params.get(p),
                    std_error: se,
                },
            );
        }
        ModelReport {
            effects: effects.to_vec(),
            parameters,
            train_chi2_per_obs: if n == 0 { 0.0 } else { c / n as f64 },
            heldout_chi2_per_obs: self.per_obs(&r.params, &self.held),
            heldout_error_pct: self.error_pct(&r.params, &self.held),
            heldout_chi2_by_quantity: self
                .qs
                .iter()
                .map(|&q| (q.name(), self.per_obs_of(&r.params, &self.held, q)))
                .collect(),
            heldout_chi2_by_run: self
                .held
                .iter()
                .map(|s| (s.name.clone(), self.per_obs(&r.params, &[*s])))
                .collect(),
            params: r.params,
            train_cost: c,
            train_n: n,
        }
    }
}

/// The first of an effect's fitted parameters (of its short form when `short`) pinned at the
/// edge of its physical range. A time constant of a drift at its long end is a steady linear
/// drift, and a polarisation time constant at either end is a plain resistance or a discharge:
/// neither counts; nor does a bound at the neutral value 0 ("this part of the effect is off").
fn pinned_param(e: Effect, short: bool, p: &Params, scale: &Scale) -> Option<Param> {
    let ps = if short { e.short_params() } else { e.params() };
    ps.iter()
        .filter(|p| !matches!(p, Param::LoadcellTauS | Param::PolarisationTauS))
        .find(|&&q| {
            let (lo, hi) = fit::bounds(q, scale);
            let v = p.get(q);
            let span = hi - lo;
            ((v - lo).abs() < 1e-6 * span && lo != 0.0) || (hi - v).abs() < 1e-6 * span
        })
        .copied()
}

/// Largest winding temperature rise above the start a fitted heating extension may imply, K
/// (enamelled copper is rated to about 180–220 °C).
const MAX_WINDING_RISE_K: f64 = 160.0;

/// Largest step-to-step scatter (share of the largest value) of a usable quantity.
const MAX_SCATTER: f64 = 0.05;

/// Spearman rank correlation.
fn spearman(x: &[f64], y: &[f64]) -> f64 {
    fn ranks(v: &[f64]) -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|a, b| v[*a].total_cmp(&v[*b]));
        let mut r = vec![0.0; v.len()];
        for (k, i) in idx.into_iter().enumerate() {
            r[i] = k as f64;
        }
        r
    }
    let (rx, ry) = (ranks(x), ranks(y));
    let mx = mean(&rx);
    let my = mean(&ry);
    let sxy: f64 = rx.iter().zip(&ry).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = rx.iter().map(|a| (a - mx).powi(2)).sum();
    let syy: f64 = ry.iter().map(|b| (b - my).powi(2)).sum();
    if sxx <= 0.0 || syy <= 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

/// The quantities to compare: those [`fit::quantities`] finds, less any (other than voltage)
/// that does not rise with thrust in the training runs (rank correlation below 0.7) — a sensor
/// below its resolution, such as a torque cell on a 25 g rotor, carries no information.
fn usable_quantities(tr: &[&Sweep], notes: &mut Vec<String>) -> Vec<Quantity> {
    fit::quantities(tr)
        .into_iter()
        .filter(|&q| {
            if q == Quantity::VoltageV {
                return true;
            }
            let (x, y): (Vec<f64>, Vec<f64>) = tr
                .iter()
                .flat_map(|s| &s.steps)
                .filter_map(|o| o.measured(q).map(|m| (o.thrust_g, m)))
                .unzip();
            let rho = spearman(&x, &y);
            // Scatter of the measured values themselves about a smooth curve in thrust, within
            // each run (two runs may differ by a real effect, which is not scatter): each step's
            // distance from the line through its two neighbours in thrust, relative to the
            // largest value; for equal spacing its variance is 1.5 σ².
            let ymax = y.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            let mut d2: Vec<f64> = Vec::new();
            for s in tr {
                let mut pts: Vec<(f64, f64)> = s
                    .steps
                    .iter()
                    .filter_map(|o| o.measured(q).map(|m| (o.thrust_g, m)))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                d2.extend(pts.windows(3).filter(|w| w[2].0 > w[0].0).map(|w| {
                    let lin = w[0].1 + (w[2].1 - w[0].1) * (w[1].0 - w[0].0) / (w[2].0 - w[0].0);
                    ((w[1].1 - lin) / ymax).powi(2)
                }));
            }
            d2.sort_by(f64::total_cmp);
            let scatter = if d2.is_empty() {
                0.0
            } else {
                (d2[d2.len() / 2] / (1.5 * 0.455)).sqrt()
            };
            // (Only with enough steps: over a few coarse steps curvature is not scatter.)
            if d2.len() >= 6 && scatter > MAX_SCATTER {
                notes.push(format!(
                    "{} left out: its steps scatter by {:.0} % of its largest value about a smooth \
                     curve; the sensor is likely below its resolution",
                    q.name(),
                    100.0 * scatter
                ));
                return false;
            }
            let ok = x.len() >= 3 && rho >= 0.7;
            if !ok {
                notes.push(format!(
                    "{} left out: it does not follow thrust (rank correlation {rho:.2}); the \
                     sensor is likely below its resolution",
                    q.name()
                ));
            }
            ok
        })
        .collect()
}

/// Sets each quantity's relative noise floor to the step-to-step scatter of the base model's
/// residuals on every run (a property of the sensors, not of the model): third differences of
/// the residuals in step order over steps moving one way, /√20 — a smooth systematic gap nearly
/// cancels in them, measurement noise does not.
fn scatter_floors(
    tr: &[&Sweep],
    p: &Params,
    qs: &[Quantity],
    defaults: &NoiseFloors,
    least: &NoiseFloors,
    scale: &Scale,
    notes: &mut Vec<String>,
) -> NoiseFloors {
    let mut floors = *defaults;
    for &q in qs {
        let mut d2 = Vec::new();
        for s in tr {
            let pred = s.predict(p);
            // In the order the steps were taken, over three steps in one direction: an effect
            // that builds up in time (heating, drift) is smooth there, while up and down steps
            // sorted by thrust would interleave two branches.
            let pts: Vec<(f64, f64)> = s
                .steps
                .iter()
                .zip(&pred)
                .filter_map(|(o, pr)| {
                    o.measured(q).map(|m| {
                        (
                            o.thrust_g,
                            (q.predicted(pr) - m) / m.abs().max(0.1 * scale.max(q)),
                        )
                    })
                })
                .collect();
            // Third differences over four steps moving one way: a constant, a trend and a
            // curvature cancel (e.g. a sag growing with current), white noise gives 20 σ².
            for w in pts.windows(4) {
                let monotone = (w[1].0 - w[0].0) * (w[2].0 - w[1].0) > 0.0
                    && (w[2].0 - w[1].0) * (w[3].0 - w[2].0) > 0.0;
                if monotone {
                    d2.push((w[3].1 - 3.0 * w[2].1 + 3.0 * w[1].1 - w[0].1).powi(2));
                }
            }
        }
        if d2.len() < 3 {
            continue;
        }
        d2.sort_by(f64::total_cmp);
        // Median of squared third differences → σ² (robust to an odd step):
        // median(χ²₁)·20σ² ≈ 0.455·20σ².
        let sigma = (d2[d2.len() / 2] / (20.0 * 0.455)).sqrt();
        let (slot, min) = match q {
            Quantity::PowerW | Quantity::CurrentA => (&mut floors.power, least.power),
            Quantity::VoltageV => (&mut floors.voltage, least.voltage),
            Quantity::SpeedRpm => (&mut floors.speed, least.speed),
            Quantity::TorqueNm => (&mut floors.torque, least.torque),
        };
        let measured = sigma.max(min.0);
        notes.push(format!(
            "{} noise floor {:.2} % (step-to-step scatter {:.2} %)",
            q.name(),
            100.0 * measured,
            100.0 * sigma
        ));
        *slot = (measured, min.1);
    }
    floors
}

fn rel_pct(pred: f64, meas: f64, max: f64) -> f64 {
    100.0 * (pred - meas) / meas.abs().max(0.1 * max).max(1e-12)
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn region(name: &'static str, v: &[f64]) -> Region {
    Region {
        region: name,
        mean_pct: mean(v),
        rms_pct: (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt(),
        steps: v.len(),
    }
}

fn locate(
    runs: &[(&StandSweep, bool)],
    p: &Params,
    qs: &[Quantity],
    scale: &Scale,
) -> Vec<QuantityWhere> {
    let tmax = scale.max_thrust_g.max(1e-9);
    qs.iter()
        .map(|&q| {
            let mut th: [Vec<f64>; 3] = Default::default();
            let mut time: [Vec<f64>; 2] = Default::default();
            let mut dir: [Vec<f64>; 2] = Default::default();
            let mut vr: Vec<(f64, f64)> = Vec::new();
            for (run, _) in runs {
                let pred = run.sweep.predict(p);
                for ((o, pr), m) in run.sweep.steps.iter().zip(&pred).zip(&run.meta) {
                    let Some(meas) = o.measured(q) else { continue };
                    let r = rel_pct(q.predicted(pr), meas, scale.max(q));
                    let k = ((o.thrust_g / tmax) * 3.0).floor().clamp(0.0, 2.0) as usize;
                    th[k].push(r);
                    time[usize::from(o.time_frac > 0.5)].push(r);
                    dir[usize::from(!m.up)].push(r);
                    if let Some(v) = o.voltage_v {
                        vr.push((v, r));
                    }
                }
            }
            let (slope, corr) = if vr.len() >= 3 {
                let mx = mean(&vr.iter().map(|x| x.0).collect::<Vec<_>>());
                let my = mean(&vr.iter().map(|x| x.1).collect::<Vec<_>>());
                let sxx: f64 = vr.iter().map(|x| (x.0 - mx).powi(2)).sum();
                let syy: f64 = vr.iter().map(|x| (x.1 - my).powi(2)).sum();
                let sxy: f64 = vr.iter().map(|x| (x.0 - mx) * (x.1 - my)).sum();
                if sxx > 1e-12 && q != Quantity::VoltageV {
                    (
                        Some(sxy / sxx),
                        (syy > 1e-12).then(|| sxy / (sxx * syy).sqrt()),
                    )
                } else if sxx > 1e-12 {
                    (Some(sxy / sxx), None)
                } else {
                    (None, None)
                }
            } else {
                (None, None)
            };
            let mut by_direction = vec![region("up", &dir[0])];
            if !dir[1].is_empty() {
                by_direction.push(region("down", &dir[1]));
            }
            QuantityWhere {
                quantity: q.name(),
                by_thrust: vec![
                    region("low", &th[0]),
                    region("middle", &th[1]),
                    region("top", &th[2]),
                ],
                by_time: vec![region("early", &time[0]), region("late", &time[1])],
                by_direction,
                voltage_slope_pct_per_v: slope,
                voltage_correlation: corr,
            }
        })
        .collect()
}

/// The training data in two halves of the same design: the even and the odd steps of every run
/// (halves made of whole runs would differ in design — an up-and-down run against an up-sweep —
/// and so in what they can tell about effects that build up in time).
fn halves(train: &[StandSweep]) -> Option<(Vec<StandSweep>, Vec<StandSweep>)> {
    let (a, b): (Vec<StandSweep>, Vec<StandSweep>) = (
        train.iter().map(|s| s.interleaved(false)).collect(),
        train.iter().map(|s| s.interleaved(true)).collect(),
    );
    let n = |v: &Vec<StandSweep>| v.iter().map(StandSweep::compared_steps).sum::<usize>();
    (n(&a) >= 5 && n(&b) >= 5).then_some((a, b))
}

/// Diagnoses the gap between the model and the stand: fitted on `train`, checked on `held`.
pub fn diagnose(
    train: &[StandSweep],
    held: &[StandSweep],
    opts: &Options,
) -> Result<Diagnosis, RigGapError> {
    if train.is_empty() || held.is_empty() {
        return Err(RigGapError::TooLittle(format!(
            "{} training and {} held-out runs: the diagnosis needs at least one of each",
            train.len(),
            held.len()
        )));
    }
    let n_train: usize = train.iter().map(StandSweep::compared_steps).sum();
    if n_train < 3 {
        return Err(RigGapError::TooLittle(format!(
            "{n_train} training steps above idle: the model needs at least 3"
        )));
    }
    let tr: Vec<&Sweep> = train.iter().map(|s| &s.sweep).collect();
    let he: Vec<&Sweep> = held.iter().map(|s| &s.sweep).collect();
    let all: Vec<&Sweep> = tr.iter().chain(&he).copied().collect();
    let mut notes = Vec::new();
    let qs = usable_quantities(&tr, &mut notes);
    let (mut start, priors) = fit::initial_guess(&tr);
    for &(p, v) in &opts.fixed {
        start.set(p, v);
    }
    if !opts.fixed.is_empty() {
        notes.push(format!(
            "held fixed: {}",
            opts.fixed
                .iter()
                .map(|(p, v)| format!("{} = {v:.4e}", p.name()))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let fixed = |p: Param| opts.fixed.iter().any(|f| f.0 == p);
    let speed_known = fixed(Param::KvRpmPerV) && fixed(Param::ThrustCoeffGPerKrpm2);
    if !qs.contains(&Quantity::SpeedRpm) && !speed_known {
        notes.push(
            "no rotor speed logged: Kv and the thrust coefficient rest on their priors; power, \
             current and voltage are still predicted"
                .to_owned(),
        );
    }
    if !qs.contains(&Quantity::TorqueNm) && !fixed(Param::TorqueCoeffNmPerKrpm2) {
        notes.push("no torque logged: the torque coefficient is set by power alone".to_owned());
    }
    if !qs.contains(&Quantity::VoltageV) {
        notes.push("no supply voltage logged: supply_sag can only show through current".to_owned());
    }
    let anchored: Vec<&str> = train
        .iter()
        .chain(held)
        .filter(|s| s.sweep.open_circuit_v.is_none() && s.sweep.anchor_first_voltage)
        .map(|s| s.sweep.name.as_str())
        .collect();
    if qs.contains(&Quantity::VoltageV) && !anchored.is_empty() {
        notes.push(format!(
            "no idle voltage before {}: each such run's open-circuit voltage is set by its first \
             spinning step, so the supply is judged by how its voltage falls from there",
            anchored.join(", ")
        ));
    }
    let mut ctx = Ctx {
        train: tr.clone(),
        held: he.clone(),
        qs: qs.clone(),
        scale: Scale::of(&all),
        opts,
        floors: opts.floors,
        priors,
        lm: LmOptions {
            huber_delta: opts.huber_delta,
            ..LmOptions::default()
        },
    };
    let first = ctx.fit(&tr, &start, &[], &[]);
    ctx.floors = scatter_floors(
        &all,
        &first.params,
        &qs,
        &opts.floors,
        &opts.min_floors,
        &ctx.scale,
        &mut notes,
    );
    let base_fit = ctx.fit(&tr, &first.params, &[], &[]);
    let baseline = ctx.report(&[], &base_fit);
    let within_noise = baseline.worst_quantity_chi2() <= opts.none_chi2_per_obs;
    let ln_n = (baseline.train_n.max(2) as f64).ln();

    let train_scale = Scale::of(&tr);
    let mut candidates = Vec::new();
    let mut selected: Vec<Effect> = Vec::new();
    // Selected effects taken in their short form.
    let mut short: Vec<Effect> = Vec::new();
    let mut current = baseline.clone();
    let mut chain: Vec<(Effect, ModelReport, ModelReport)> = Vec::new();
    for round in 0..opts.max_effects {
        if round > 0 && current.worst_quantity_chi2() <= opts.none_chi2_per_obs {
            break;
        }
        let mut best: Option<(f64, Effect, ModelReport, bool)> = None;
        for &e in &opts.candidates {
            if selected.contains(&e) {
                continue;
            }
            let mut set = selected.clone();
            set.push(e);
            // Its full form and, if it has one, its short form: the better training BIC wins.
            let mut forms = vec![false];
            if e.short_params().len() < e.params().len() {
                forms.push(true);
            }
            // (A form with a parameter pinned at the edge of its physical range is taken only
            // when no form is free of it: a polarisation branch at its bound standing in for a
            // discharge must not hide the plain resistance-and-discharge form.)
            let (rep, delta_bic, is_short) = forms
                .into_iter()
                .map(|sh| {
                    let mut short = short.clone();
                    if sh {
                        short.push(e);
                    }
                    let r = ctx.fit(&tr, &current.params, &set, &short);
                    let rep = ctx.report(&set, &r);
                    let k = if sh { e.short_params() } else { e.params() }.len() as f64;
                    let delta_bic = (current.train_cost - rep.train_cost) - k * ln_n;
                    (rep, delta_bic, sh)
                })
                .max_by(|a, b| {
                    let pinned = |r: &ModelReport, sh: bool| {
                        pinned_param(e, sh, &r.params, &train_scale).is_some()
                    };
                    pinned(&b.0, b.2)
                        .cmp(&pinned(&a.0, a.2))
                        .then(a.1.total_cmp(&b.1))
                })
                .expect("at least one form");
            let k = if is_short {
                e.short_params()
            } else {
                e.params()
            }
            .len() as f64;
            let gain = 1.0 - rep.heldout_chi2_per_obs / current.heldout_chi2_per_obs.max(1e-12);
            let worse_run = rep
                .heldout_chi2_by_run
                .iter()
                .zip(&current.heldout_chi2_by_run)
                .find(|(a, b)| a.1 > b.1.max(1.0) * 1.02 + 0.05)
                .map(|(a, _)| a.0.clone());
            // (A drift time constant at its long end is a steady linear drift, not an edge.)
            // (A polarisation time constant at either end is a plain resistance or a discharge.)
            let at_bound = pinned_param(e, is_short, &rep.params, &train_scale);
            let worse_quantity = rep
                .heldout_chi2_by_quantity
                .iter()
                .find(|(q, v)| {
                    current
                        .heldout_chi2_by_quantity
                        .get(*q)
                        // (Within noise, χ² ≤ 1, a change is not measurably worse.)
                        .is_some_and(|b| **v > b.max(1.0) * 1.02 + 0.05)
                })
                .map(|(q, _)| *q);
            // The winding temperature rise the heating extension implies on the training runs.
            let rise_k = tr
                .iter()
                .flat_map(|s| s.predict(&rep.params))
                .map(|p| p.winding_rise_k)
                .fold(0.0f64, f64::max);
            let rejected_because = if within_noise && round == 0 {
                Some("the base model is within noise".to_owned())
            } else if rise_k > MAX_WINDING_RISE_K {
                Some(format!(
                    "implies a winding temperature rise of {rise_k:.0} K (> {MAX_WINDING_RISE_K} K)"
                ))
            } else if let Some(p) = at_bound {
                Some(format!("{} at the edge of its physical range", p.name()))
            } else if delta_bic < opts.min_delta_bic {
                Some(format!(
                    "training ΔBIC {delta_bic:.1} < {}",
                    opts.min_delta_bic
                ))
            } else if gain < opts.min_relative_gain {
                Some(format!(
                    "held-out χ² cut by {:.0} % < {:.0} %",
                    100.0 * gain,
                    100.0 * opts.min_relative_gain
                ))
            } else if let Some(q) = worse_quantity {
                Some(format!("makes the held-out {q} worse"))
            } else {
                worse_run.map(|run| format!("makes held-out run {run} worse"))
            };
            let eligible = rejected_because.is_none();
            candidates.push(Candidate {
                effects: set.clone(),
                delta_bic,
                heldout_chi2_per_obs: rep.heldout_chi2_per_obs,
                heldout_chi2_by_quantity: rep.heldout_chi2_by_quantity.clone(),
                parameters: set
                    .iter()
                    .flat_map(|e| e.params())
                    .filter_map(|p| rep.parameters.get(p.name()).map(|v| (p.name(), *v)))
                    .collect(),
                eligible,
                rejected_because,
            });
            if eligible {
                let score = rep.heldout_chi2_per_obs + opts.penalty_per_param * k;
                if best.as_ref().is_none_or(|b| score < b.0) {
                    best = Some((score, e, rep, is_short));
                }
            }
        }
        let Some((_, e, rep, is_short)) = best else {
            break;
        };
        selected.push(e);
        if is_short {
            short.push(e);
        }
        chain.push((e, current.clone(), rep.clone()));
        current = rep;
    }

    // Stability: the selected effects fitted on the two halves of the training data.
    let mut stability: BTreeMap<Effect, f64> = BTreeMap::new();
    if !selected.is_empty()
        && let Some((a, b)) = halves(train)
    {
        let ra: Vec<&Sweep> = a.iter().map(|s| &s.sweep).collect();
        let rb: Vec<&Sweep> = b.iter().map(|s| &s.sweep).collect();
        let fa = ctx.fit(&ra, &current.params, &selected, &short);
        let fb = ctx.fit(&rb, &current.params, &selected, &short);
        for &e in &selected {
            let mut z: f64 = 0.0;
            // (A load cell's offset is each run's own tare error: it is not compared.)
            for &p in e.params().iter().filter(|p| **p != Param::LoadcellOffsetG) {
                let se = |f: &fit::FitResult| {
                    f.std_errors
                        .iter()
                        .find(|x| x.0 == p)
                        .map(|x| x.1)
                        .unwrap_or(f64::INFINITY)
                };
                let d = (fa.params.get(p) - fb.params.get(p)).abs();
                // A parameter pinned at a bound in either half has no standard error there (0):
                // it cannot be tested, not "infinitely" unstable.
                if se(&fa) <= 0.0 || se(&fb) <= 0.0 {
                    continue;
                }
                let s = (se(&fa).powi(2) + se(&fb).powi(2)).sqrt();
                if s.is_finite() {
                    z = z.max(d / s);
                }
            }
            stability.insert(e, z);
        }
    }
    let unstable = stability.values().any(|z| *z > opts.stability_z);
    // A quantity is left unexplained when it stays above the threshold and the selected effects
    // removed less than half of its held-out excess over noise.
    let left_unexplained: Vec<&'static str> = current
        .heldout_chi2_by_quantity
        .iter()
        .filter(|(q, after)| {
            let before = baseline
                .heldout_chi2_by_quantity
                .get(*q)
                .copied()
                .unwrap_or(0.0);
            **after > opts.unexplained_chi2_per_obs && (**after - 1.0) > 0.5 * (before - 1.0)
        })
        .map(|(q, _)| *q)
        .collect();
    let unexplained =
        !within_noise && (selected.is_empty() || !left_unexplained.is_empty() || unstable);
    if !selected.is_empty() && left_unexplained.is_empty() && !unstable {
        for (q, after) in &current.heldout_chi2_by_quantity {
            if *after > opts.unexplained_chi2_per_obs {
                notes.push(format!(
                    "{q}: the selected effects remove most of the gap, but a held-out residual of \
                     χ²/obs {after:.1} is left (the effect's form is close, not exact)"
                ));
            }
        }
    }
    if unstable {
        notes.push(format!(
            "the selected effect's parameters differ between the training halves by more than \
             {} σ: the model may be misspecified",
            opts.stability_z
        ));
    }
    let excess = (baseline.heldout_chi2_per_obs - 1.0).max(1e-12);
    let effects: Vec<EffectReport> = chain
        .iter()
        .map(|(e, before, after)| {
            let mut parameters = BTreeMap::new();
            for &p in e.params() {
                if let Some(v) = after.parameters.get(p.name()) {
                    parameters.insert(p.name(), *v);
                }
            }
            EffectReport {
                effect: e.name(),
                parameters,
                share_of_gap: ((before.heldout_chi2_per_obs - after.heldout_chi2_per_obs) / excess)
                    .clamp(0.0, 1.0),
                heldout_error_before_pct: before.heldout_error_pct.clone(),
                heldout_error_after_pct: after.heldout_error_pct.clone(),
                stability_z: stability.get(e).copied(),
            }
        })
        .collect();
    let verdict = if within_noise {
        vec!["none".to_owned()]
    } else if unexplained {
        vec!["unexplained".to_owned()]
    } else {
        selected.iter().map(|e| e.name().to_owned()).collect()
    };
    let runs: Vec<(&StandSweep, bool)> = train
        .iter()
        .map(|s| (s, false))
        .chain(held.iter().map(|s| (s, true)))
        .collect();
    let wh = Where {
        before: locate(&runs, &baseline.params, &qs, &ctx.scale),
        after: locate(&runs, &current.params, &qs, &ctx.scale),
    };
    let mut steps = Vec::new();
    for (run, h) in &runs {
        let pb: Vec<Prediction> = run.sweep.predict(&baseline.params);
        let pa: Vec<Prediction> = run.sweep.predict(&current.params);
        for &q in &qs {
            for ((o, b), a) in run.sweep.steps.iter().zip(&pb).zip(&pa) {
                if let Some(m) = o.measured(q) {
                    steps.push(StepResidual {
                        run: run.sweep.name.clone(),
                        heldout: *h,
                        quantity: q.name(),
                        thrust_g: o.thrust_g,
                        measured: m,
                        before_pct: rel_pct(q.predicted(b), m, ctx.scale.max(q)),
                        after_pct: rel_pct(q.predicted(a), m, ctx.scale.max(q)),
                    });
                }
            }
        }
    }
    Ok(Diagnosis {
        verdict,
        unexplained,
        within_noise,
        effects,
        r#where: wh,
        baseline,
        after: current,
        candidates,
        quantities: qs.iter().map(|q| q.name()).collect(),
        train: train.iter().map(|s| s.sweep.name.clone()).collect(),
        heldout: held.iter().map(|s| s.sweep.name.clone()).collect(),
        steps,
        notes,
    })
}

impl ModelReport {
    /// The largest held-out χ² per observation over the quantities.
    pub fn worst_quantity_chi2(&self) -> f64 {
        self.heldout_chi2_by_quantity
            .values()
            .copied()
            .fold(0.0, f64::max)
    }
}

impl Diagnosis {
    /// Held-out error of the power (or current) before and after, %, the headline numbers.
    pub fn headline_pct(&self) -> Option<(f64, f64)> {
        let key = ["power_w", "current_a"]
            .into_iter()
            .find(|k| self.baseline.heldout_error_pct.contains_key(k))?;
        Some((
            self.baseline.heldout_error_pct[key],
            self.after.heldout_error_pct[key],
        ))
    }
}

#[cfg(test)]
mod estimate_tests {
    use super::Estimate;

    #[test]
    fn an_estimate_is_identified_when_its_error_is_within_its_value() {
        let e = |value, std_error| Estimate { value, std_error };
        assert!(e(0.14, 0.02).identified());
        assert!(e(-0.5, 0.5).identified());
        assert!(e(1.0, 0.0).identified());
        assert!(!e(1882.7, 5255.7).identified());
        assert!(!e(0.05, f64::INFINITY).identified());
        assert!(!e(0.0, 1e-9).identified());
        let v = serde_json::to_value(e(1882.7, 5255.7)).unwrap();
        assert_eq!(v["identified"], false);
        assert_eq!(v["value"], 1882.7);
    }
}
