//! From flight logs (the `flightlog` crate) to the diagnosis, with its two baselines: a rig
//! characterisation, or — for a robot nobody put on a bench — a hover power estimated from the
//! training flights.

use estimator::{EstimateError, PowerCurve};
use flightlog::{End, Flight, MetaSource, PhaseSource};
use serde::Serialize;

use crate::GapError;
use crate::battery::LearnedBattery;
use crate::diagnose::{BatterySet, DiagnoseOptions, Diagnosis, diagnose_with, learn_batteries};
use crate::flight::{FlightInfo, FlightRecord, Phase};
use crate::model::{EffectParams, Model};

/// Cut-off per cell when a log does not say, V (the paper's 3.0 V).
pub const DEFAULT_CUTOFF_CELL_V: f64 = 3.0;

/// Converts a read log into the diagnosis' form. Masses and powers a log does not give are
/// left as NaN (only a rig baseline needs them; [`require_masses`] checks).
pub fn record_from_log(f: &Flight) -> Result<FlightRecord, GapError> {
    if let Some(why) = f.not_hovering() {
        return Err(GapError::NotHovering {
            flight: f.name.clone(),
            why,
        });
    }
    let m = &f.meta;
    let missing = |what: &str| GapError::Metadata {
        flight: f.name.clone(),
        missing: what.to_owned(),
    };
    let cells = m.cells.ok_or_else(|| missing("cells"))?;
    let cells = u8::try_from(cells).map_err(|_| missing("cells (1 to 255)"))?;
    let battery_energy_wh = m.battery_energy().ok_or_else(|| {
        missing("battery_energy_wh (or battery_mass_kg and battery_energy_density_wh_per_kg)")
    })?;
    let n = f.samples.time_s.len();
    let phase = match (&f.samples.phase, &f.phase_source) {
        (Some(p), _) => p.clone(),
        (None, PhaseSource::None | PhaseSource::Logged | PhaseSource::Inferred { .. }) => {
            vec![Phase::Hover; n]
        }
    };
    let nan = f64::NAN;
    Ok(FlightRecord {
        name: f.name.clone(),
        time_s: f.samples.time_s.clone(),
        voltage_v: f.samples.voltage_v.clone(),
        current_a: f.samples.current_a.clone(),
        phase,
        altitude_m: f.samples.altitude_m.clone(),
        info: FlightInfo {
            structure_mass_kg: m.structure_mass_kg.unwrap_or(nan),
            battery_mass_kg: m.battery_mass_kg.unwrap_or(nan),
            battery_energy_wh,
            cells,
            payload_mass_kg: m.payload_mass_kg.unwrap_or(0.0),
            payload_power_w: m.payload_power_w.unwrap_or(0.0),
            avionics_power_w: m.avionics_power_w.unwrap_or(0.0),
            battery_id: m.battery_id.clone(),
            battery_cycles: m.battery_cycles,
            ambient_temperature_c: m.ambient_temperature_c,
            air_density_kg_m3: m.air_density_kg_m3,
            cutoff_voltage_v: m
                .cutoff_voltage_v
                .unwrap_or(f64::from(cells) * DEFAULT_CUTOFF_CELL_V),
            ended_at_cutoff: m.end == Some(End::Cutoff),
            ceiling_height_m: m.ceiling_height_m,
            measured_ocv: measured_curve(f)?,
        },
    })
}

/// The measured open-circuit curve a flight's metadata names (`battery_ocv_csv`), read.
fn measured_curve(f: &Flight) -> Result<Option<LearnedBattery>, GapError> {
    let Some(csv) = &f.meta.battery_ocv_csv else {
        return Ok(None);
    };
    let set_in = match f.metadata.get("battery_ocv_csv").map(|v| &v.source) {
        Some(MetaSource::Folder { path } | MetaSource::Sidecar { path }) => {
            path.display().to_string()
        }
        Some(other) => other.to_string(),
        None => "the flight's metadata".to_owned(),
    };
    let fail = |message: String| GapError::BatteryCurve {
        flight: f.name.clone(),
        csv: csv.clone(),
        set_in: set_in.clone(),
        message,
    };
    let text = std::fs::read_to_string(csv).map_err(|e| fail(format!("reading it: {e}")))?;
    LearnedBattery::from_ocv_csv(&text)
        .map(Some)
        .map_err(|e| fail(e.to_string()))
}

/// Checks that a flight gives the masses a rig baseline needs.
pub fn require_masses(f: &FlightRecord) -> Result<(), GapError> {
    for (what, v) in [
        ("structure_mass_kg", f.info.structure_mass_kg),
        ("battery_mass_kg", f.info.battery_mass_kg),
    ] {
        if !v.is_finite() {
            return Err(GapError::Metadata {
                flight: f.name.clone(),
                missing: format!("{what} (needed to read the rig curve at the take-off mass)"),
            });
        }
    }
    Ok(())
}

/// The baseline of a robot whose hover power was estimated from flights instead of measured on
/// a rig: momentum theory's `P = k·T^1.5` scaled to the flights' mean take-off mass, or the same
/// power for every flight when the masses are unknown. Evaluated with one "rotor" carrying the
/// whole take-off mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantPower {
    /// Hover power of all rotors at `reference_mass_kg`, W.
    pub hover_power_w: f64,
    /// Take-off mass the power refers to, kg (NaN: masses unknown, power taken as constant).
    pub reference_mass_kg: f64,
}

impl PowerCurve for ConstantPower {
    fn power_w(&self, thrust_g: f64) -> Result<f64, EstimateError> {
        let ratio = thrust_g / 1000.0 / self.reference_mass_kg;
        Ok(if ratio.is_finite() && ratio > 0.0 {
            self.hover_power_w * ratio.powf(1.5)
        } else {
            self.hover_power_w
        })
    }

    fn valid_range_g(&self) -> (f64, f64) {
        (0.0, f64::INFINITY)
    }
}

/// Least flying time, s, summed over the flights a hover power is estimated from, and least
/// flying time of a held-out flight for it to be scored. Spinning up, taking off and settling
/// into a hover take a few seconds (1–3 s of throttle transient on a multirotor), and flight
/// logs often record the battery at 1–10 Hz: under 10 s in the air, the mean power is the
/// transient's and the voltage barely leaves its resting level, so neither a hover power nor
/// an energy per phase can be read from it.
pub const MIN_FLYING_S: f64 = 10.0;

/// How far above the largest power the flights drew (logged voltage × current) an estimated
/// hover power may lie: room for the mass^1.5 scaling between flights of different take-off
/// masses, not for an estimate no flight supports.
pub const MAX_HOVER_OVER_DRAWN: f64 = 2.0;

/// Why a flight cannot be scored (too little flying time, no flying phase), or `None`.
pub fn unscorable(f: &FlightRecord) -> Option<String> {
    let flying = f.flying_s();
    (flying < MIN_FLYING_S).then(|| {
        if flying <= 0.0 {
            format!(
                "no flying phase in {:.1} s of log (on the ground throughout): nothing to score",
                f.duration_s()
            )
        } else {
            format!(
                "{flying:.1} s of flying in {:.1} s of log, under the {MIN_FLYING_S:.0} s an energy per phase needs",
                f.duration_s()
            )
        }
    })
}

/// Largest power any of the flights drew, W (logged voltage × current), or `None` when none
/// logs current.
fn max_drawn_w<'a>(flights: &[&'a FlightRecord]) -> Option<(f64, &'a str)> {
    flights
        .iter()
        .filter_map(|f| {
            let c = f.current_a.as_ref()?;
            let p = f
                .voltage_v
                .iter()
                .zip(c)
                .map(|(v, i)| v * i)
                .filter(|p| p.is_finite())
                .fold(f64::NEG_INFINITY, f64::max);
            p.is_finite().then_some((p, f.name.as_str()))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

/// Estimates the rotors' hover power from training flights: the mean measured hover power
/// (battery power less idle power) when current is logged; otherwise the power that makes the
/// baseline model follow the voltage trajectories best, with the batteries `batteries`.
///
/// Refuses ([`GapError::Implausible`]) flights with less than [`MIN_FLYING_S`] of flying in
/// all, and an estimate more than [`MAX_HOVER_OVER_DRAWN`] times the largest power the flights
/// drew or not above the avionics power ([`check_hover_power`]).
pub fn estimate_hover_power(
    train: &[&FlightRecord],
    batteries: &BatterySet,
    opts: &DiagnoseOptions,
) -> Result<ConstantPower, GapError> {
    let flying: f64 = train.iter().map(|f| f.flying_s()).sum();
    if flying < MIN_FLYING_S {
        return Err(GapError::Implausible(format!(
            "too little flying to estimate a hover power from: {flying:.1} s in the air in all ({}), under the {MIN_FLYING_S:.0} s needed to see past take-off transients — give longer flights or a rig characterisation (--params)",
            train
                .iter()
                .map(|f| format!(
                    "{}: {:.1} s of {:.1} s",
                    f.name,
                    f.flying_s(),
                    f.duration_s()
                ))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let curve = estimate_unchecked(train, batteries, opts);
    check_hover_power(&curve, train)?;
    if let Some((drawn, name)) = max_drawn_w(train)
        && curve.hover_power_w > MAX_HOVER_OVER_DRAWN * drawn
    {
        return Err(GapError::Implausible(format!(
            "the hover power estimated from the flights is {:.2} W, over {MAX_HOVER_OVER_DRAWN:.0} × the most any of them drew ({drawn:.2} W logged voltage × current, in {name}) — the flights do not support a hover-power estimate; give longer hovering flights or a rig characterisation (--params)",
            curve.hover_power_w
        )));
    }
    Ok(curve)
}

fn estimate_unchecked(
    train: &[&FlightRecord],
    batteries: &BatterySet,
    opts: &DiagnoseOptions,
) -> ConstantPower {
    let masses: Vec<f64> = train.iter().map(|f| f.info.total_mass_kg()).collect();
    let reference_mass_kg = if masses.iter().all(|m| m.is_finite() && *m > 0.0) {
        masses.iter().sum::<f64>() / masses.len() as f64
    } else {
        f64::NAN
    };
    let at_reference = |p: f64, m: f64| {
        let r = reference_mass_kg / m;
        if r.is_finite() { p * r.powf(1.5) } else { p }
    };
    let measured: Vec<f64> = train
        .iter()
        .filter_map(|f| {
            let c = f.current_a.as_ref()?;
            let p: Vec<f64> = f
                .phase
                .iter()
                .enumerate()
                .filter(|(_, p)| **p == Phase::Hover)
                .map(|(i, _)| f.voltage_v[i] * c[i] - f.info.idle_power_w())
                .collect();
            (!p.is_empty()).then(|| {
                at_reference(
                    p.iter().sum::<f64>() / p.len() as f64,
                    f.info.total_mass_kg(),
                )
            })
        })
        .collect();
    // Without current, the voltage's *slope* while flying says how fast the pack drains; its
    // level also carries the sag through the pack resistance, which is part of the gap, not of
    // the baseline. So each flight's mean residual is taken out before scoring a hover power.
    let chi2 = |w: f64| -> f64 {
        let curve = ConstantPower {
            hover_power_w: w,
            reference_mass_kg,
        };
        let model = Model {
            curve: &curve,
            rotor_count: 1,
        };
        train
            .iter()
            .map(|f| {
                let stride = (f.time_s.len() / opts.points_per_flight.max(1)).max(1);
                let pred = model.predict(
                    f,
                    batteries.for_flight(f),
                    &EffectParams::baseline(),
                    stride,
                );
                let r: Vec<f64> = pred
                    .index
                    .iter()
                    .zip(&pred.voltage_v)
                    .filter(|(i, _)| crate::flight::rotors_on(f.phase[**i]))
                    .map(|(i, v)| f.voltage_v[*i] - v)
                    .collect();
                // A model that empties the pack before the log ends misses samples: past its
                // cut-off the model's voltage is the cut-off, so each missed sample counts at
                // its own voltage less the cut-off (as the diagnosis's residuals do). Counted
                // at the last sample's voltage instead, a flight that ended at its cut-off would
                // score a model that empties the pack at once as a near-perfect fit.
                let first_missed = pred.index.last().map_or(0, |l| l + stride);
                let missed: Vec<f64> = (first_missed..f.time_s.len())
                    .step_by(stride)
                    .map(|i| f.voltage_v[i] - f.info.cutoff_voltage_v)
                    .collect();
                let all: Vec<f64> = r.iter().chain(&missed).copied().collect();
                if all.is_empty() {
                    return 0.0;
                }
                let m = all.iter().sum::<f64>() / all.len() as f64;
                all.iter().map(|x| (x - m).powi(2)).sum::<f64>() / all.len() as f64
                    + if missed.is_empty() { 0.0 } else { m * m }
            })
            .sum()
    };
    if !measured.is_empty() {
        return ConstantPower {
            hover_power_w: measured.iter().sum::<f64>() / measured.len() as f64,
            reference_mass_kg,
        };
    }
    let (a, b) = {
        // Scan decades for a bracket: per-cell energy and flight lengths vary a lot.
        let cand: Vec<f64> = (0..40).map(|k| 0.1 * 1.3f64.powi(k)).collect();
        let best = cand
            .iter()
            .copied()
            .min_by(|x, y| chi2(*x).total_cmp(&chi2(*y)))
            .unwrap_or(1.0);
        (best / 1.3, best * 1.3)
    };
    let (w, _) = crate::stats::golden_min(&chi2, a, b, 40);
    ConstantPower {
        hover_power_w: w,
        reference_mass_kg,
    }
}

/// Where the baseline's rotor power comes from.
#[derive(Debug, Clone, Copy)]
pub enum Baseline<'a, C> {
    /// A rig characterisation (curve and rotor count).
    Rig(&'a C, u8),
    /// Estimated from the training flights.
    FromTraining,
}

/// The held-out rule used when none is given: every third flight in name order (the 3rd, 6th,
/// 9th …), at least one, and at least two flights left to train on.
pub fn default_split(names: &[String]) -> Vec<bool> {
    let n = names.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| natural_cmp(&names[a], &names[b]));
    let mut held = vec![false; n];
    for (rank, &i) in order.iter().enumerate() {
        held[i] = rank % 3 == 2;
    }
    if n >= 3 && !held.iter().any(|h| *h) {
        held[order[n - 1]] = true;
    }
    held
}

/// How the flights were split into training and held-out ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SplitRule {
    /// Every third flight by name held out (no held-out flights given).
    EveryThirdByName,
    /// The held-out flights were given.
    Given,
}

impl SplitRule {
    /// In words.
    pub fn describe(self) -> &'static str {
        match self {
            SplitRule::EveryThirdByName => {
                "every third flight by name held out (no --holdout given)"
            }
            SplitRule::Given => "--holdout",
        }
    }
}

/// Splits flights into training and held-out ones: the given held-out flights, or, when none
/// are given, every third of `flights` by name ([`default_split`]).
pub fn split_flights(
    flights: Vec<FlightRecord>,
    given_heldout: Vec<FlightRecord>,
) -> (Vec<FlightRecord>, Vec<FlightRecord>, SplitRule) {
    if !given_heldout.is_empty() {
        return (flights, given_heldout, SplitRule::Given);
    }
    let names: Vec<String> = flights.iter().map(|f| f.name.clone()).collect();
    let mask = default_split(&names);
    let (mut train, mut held) = (Vec::new(), Vec::new());
    for (f, h) in flights.into_iter().zip(mask) {
        if h { held.push(f) } else { train.push(f) }
    }
    (train, held, SplitRule::EveryThirdByName)
}

/// Compares names with embedded numbers naturally ("2" before "10"): `flightlog`'s order,
/// the one natural order of the workspace.
pub use flightlog::natural_cmp;

/// One held-out flight's voltage, measured and predicted before and after (for plots).
#[derive(Debug, Clone, Serialize)]
pub struct HeldoutSeries {
    /// Flight name.
    pub name: String,
    /// Time, s.
    pub time_s: Vec<f64>,
    /// Measured voltage, V.
    pub measured_v: Vec<f64>,
    /// Baseline prediction, V (NaN past its cut-off).
    pub before_v: Vec<f64>,
    /// Prediction with the selected effects, V (NaN past its cut-off).
    pub after_v: Vec<f64>,
}

fn series<C: PowerCurve>(
    model: Model<'_, C>,
    batteries: &BatterySet,
    d: &Diagnosis,
    flights: &[&FlightRecord],
) -> Vec<HeldoutSeries> {
    let after = d.selected_params();
    flights
        .iter()
        .map(|f| {
            let stride = (f.time_s.len() / 400).max(1);
            let on_grid = |p: &EffectParams| {
                let pred = model.predict(f, batteries.for_flight(f), p, stride);
                let mut v = vec![f64::NAN; f.time_s.len().div_ceil(stride)];
                for (k, i) in pred.index.iter().enumerate() {
                    if let Some(slot) = v.get_mut(i / stride) {
                        *slot = pred.voltage_v[k];
                    }
                }
                v
            };
            let idx: Vec<usize> = (0..f.time_s.len()).step_by(stride).collect();
            HeldoutSeries {
                name: f.name.clone(),
                time_s: idx.iter().map(|&i| f.time_s[i]).collect(),
                measured_v: idx.iter().map(|&i| f.voltage_v[i]).collect(),
                before_v: on_grid(&EffectParams::baseline()),
                after_v: on_grid(&after),
            }
        })
        .collect()
}

/// The diagnosis of a flight set with the baseline it used.
#[derive(Debug, Clone, Serialize)]
pub struct GapReport {
    /// `rig curve` or `hover power estimated from the training flights`.
    pub baseline_source: String,
    /// The estimated hover power (all rotors), W, when estimated.
    pub estimated_hover_power_w: Option<f64>,
    /// The diagnosis.
    pub diagnosis: Diagnosis,
    /// Held-out flights' voltage, measured and predicted before and after.
    #[serde(skip)]
    pub heldout_series: Vec<HeldoutSeries>,
}

/// [`run`] with the baseline estimated from the training flights. Not generic, so it is
/// compiled, and optimised, in this crate rather than in the caller's (a generic function is
/// compiled where its type is named): the CLI's tests run the diagnosis in a debug build.
pub fn run_from_training(
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<GapReport, GapError> {
    run::<ConstantPower>(Baseline::FromTraining, train, heldout, opts)
}

/// [`run`] with a rig characterisation's curve as the baseline (compiled here, as
/// [`run_from_training`]).
pub fn run_with_rig(
    curve: &estimator::PolyCurve,
    rotor_count: u8,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<GapReport, GapError> {
    run(Baseline::Rig(curve, rotor_count), train, heldout, opts)
}

/// Runs the diagnosis with either baseline.
pub fn run<C: PowerCurve>(
    baseline: Baseline<'_, C>,
    train: &[&FlightRecord],
    heldout: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<GapReport, GapError> {
    if train.is_empty() {
        return Err(GapError::NoFlights("training"));
    }
    if heldout.is_empty() {
        return Err(GapError::NoFlights("held-out"));
    }
    match baseline {
        Baseline::Rig(curve, rotor_count) => {
            for f in train.iter().chain(heldout) {
                require_masses(f)?;
            }
            let model = Model { curve, rotor_count };
            let batteries = learn_batteries(model, train, opts);
            let d = diagnose_with(model, &batteries, train, heldout, opts)?;
            check_chi2(&d)?;
            Ok(GapReport {
                baseline_source: "rig curve through the paper's model (eqs. 1-9)".into(),
                estimated_hover_power_w: None,
                heldout_series: series(model, &batteries, &d, heldout),
                diagnosis: d,
            })
        }
        Baseline::FromTraining => {
            // The hover power first, with the prior battery (from logged current when there
            // is one; otherwise from the voltage's slope), then the battery with that power.
            // Without current the two are not learned jointly: a smaller power and a larger
            // resistance would explain the same voltage, and the joint fit drifts there.
            // The prior: a measured curve, else the chemistry's (given, or the one whose full
            // voltage matches the flights' resting level: a LiPo curve read on a LiFePO₄
            // pack's voltages would put every sample near empty).
            let prior = BatterySet::fixed(
                opts.measured_ocv
                    .or_else(|| train.iter().find_map(|f| f.info.measured_ocv))
                    .unwrap_or_else(|| {
                        crate::battery::prior_by_resting_level(train, opts.chemistry)
                    }),
            );
            let curve = estimate_hover_power(train, &prior, opts)?;
            let model = Model {
                curve: &curve,
                rotor_count: 1,
            };
            let batteries = learn_batteries(model, train, opts);
            let d = diagnose_with(model, &batteries, train, heldout, opts)?;
            check_chi2(&d)?;
            let heldout_series = series(model, &batteries, &d, heldout);
            Ok(GapReport {
                baseline_source: if curve.reference_mass_kg.is_finite() {
                    format!(
                        "hover power estimated from the training flights ({:.2} W at {:.3} kg, scaled as mass^1.5)",
                        curve.hover_power_w, curve.reference_mass_kg
                    )
                } else {
                    "hover power estimated from the training flights (the same for every flight: masses unknown)".into()
                },
                estimated_hover_power_w: Some(curve.hover_power_w),
                heldout_series,
                diagnosis: d,
            })
        }
    }
}

/// Largest baseline χ² per observation the diagnosis accepts: residuals a thousand times the
/// noise floors mean the inputs are wrong (units, a disconnected battery, a wrong cell count),
/// not that an effect is missing.
pub const MAX_PLAUSIBLE_CHI2_PER_OBS: f64 = 1e6;

/// Stops on an estimated hover power no flying robot has: at or below its avionics power, or
/// below 0.1 W.
pub fn check_hover_power(curve: &ConstantPower, flights: &[&FlightRecord]) -> Result<(), GapError> {
    let avionics = flights
        .iter()
        .map(|f| f.info.avionics_power_w)
        .fold(0.0, f64::max);
    if !(curve.hover_power_w.is_finite() && curve.hover_power_w > avionics.max(0.1)) {
        return Err(GapError::Implausible(format!(
            "the hover power estimated from the flights is {:.3} W, {} — check the voltage and current units, the cell count and that the battery was connected",
            curve.hover_power_w,
            if avionics > 0.0 {
                format!("not above the avionics power {avionics:.2} W")
            } else {
                "below 0.1 W".to_owned()
            }
        )));
    }
    Ok(())
}

/// Stops on a baseline so far from the flights that no effect can be the reason.
pub fn check_chi2(d: &Diagnosis) -> Result<(), GapError> {
    let c = d.baseline.training.chi2_per_obs;
    if !c.is_finite() || c > MAX_PLAUSIBLE_CHI2_PER_OBS {
        return Err(GapError::Implausible(format!(
            "the baseline misses the training flights by χ² {c:.3e} per observation (more than {MAX_PLAUSIBLE_CHI2_PER_OBS:.0e}: residuals over a thousand times the noise floors) — the inputs are wrong (units, cell count, metadata), not an effect missing"
        )));
    }
    Ok(())
}

/// Fewest flights the attribution needs: two to fit on and one held out to check on.
pub const MIN_FLIGHTS_FOR_ATTRIBUTION: usize = 3;

/// Where the baseline and too few flights for an attribution part: the localisation alone.
#[derive(Debug, Clone, Serialize)]
pub struct LocalisationReport {
    /// `rig curve` or `hover power estimated from these flights`.
    pub baseline_source: String,
    /// The estimated hover power (all rotors), W, when estimated.
    pub estimated_hover_power_w: Option<f64>,
    /// The batteries learned from these flights.
    pub batteries: Vec<crate::battery::BatteryFit>,
    /// The baseline's errors on these flights.
    pub errors: crate::diagnose::LevelErrors,
    /// Where the gap sits.
    pub r#where: crate::diagnose::Where,
    /// Flights read.
    pub flights: usize,
    /// More flights the attribution needs.
    pub more_flights_needed: usize,
}

/// Localises the gap on fewer flights than an attribution needs (one log is a use case): the
/// baseline (rig, or a hover power estimated from these flights) with the battery learned from
/// them, and where the flights part from it.
pub fn localise_only<C: PowerCurve>(
    baseline: Baseline<'_, C>,
    flights: &[&FlightRecord],
    opts: &DiagnoseOptions,
) -> Result<LocalisationReport, GapError> {
    if flights.is_empty() {
        return Err(GapError::NoFlights("readable"));
    }
    let more_flights_needed = MIN_FLIGHTS_FOR_ATTRIBUTION.saturating_sub(flights.len());
    fn finish<C: PowerCurve>(
        model: Model<'_, C>,
        flights: &[&FlightRecord],
        opts: &DiagnoseOptions,
        (source, hover, more_flights_needed): (String, Option<f64>, usize),
    ) -> LocalisationReport {
        let batteries = learn_batteries(model, flights, opts);
        let ev = crate::diagnose::Evaluator::new(model, &batteries, opts);
        let res = ev.residuals(flights, &EffectParams::baseline());
        LocalisationReport {
            baseline_source: source,
            estimated_hover_power_w: hover,
            batteries: batteries.fits.clone(),
            errors: crate::diagnose::LevelErrors::of(&res),
            r#where: crate::diagnose::localise(flights, &res),
            flights: flights.len(),
            more_flights_needed,
        }
    }
    Ok(match baseline {
        Baseline::Rig(curve, rotor_count) => {
            for f in flights {
                require_masses(f)?;
            }
            finish(
                Model { curve, rotor_count },
                flights,
                opts,
                (
                    "rig curve through the paper's model (eqs. 1-9)".into(),
                    None,
                    more_flights_needed,
                ),
            )
        }
        Baseline::FromTraining => {
            let prior = BatterySet::fixed(
                opts.measured_ocv
                    .or_else(|| flights.iter().find_map(|f| f.info.measured_ocv))
                    .unwrap_or_else(crate::battery::LearnedBattery::lipo),
            );
            let curve = estimate_hover_power(flights, &prior, opts)?;
            let model = Model {
                curve: &curve,
                rotor_count: 1,
            };
            finish(
                model,
                flights,
                opts,
                (
                    "hover power estimated from these flights".into(),
                    Some(curve.hover_power_w),
                    more_flights_needed,
                ),
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::battery::LearnedBattery;

    /// A 4S flight at `volts` drawing `amps`, `secs` long at 10 Hz, the first half on the
    /// ground and the rest in `flying`.
    fn flight(name: &str, secs: f64, volts: f64, amps: f64, flying: Phase) -> FlightRecord {
        let n = (secs * 10.0) as usize + 1;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 / 10.0).collect();
        let phase = (0..n)
            .map(|i| if i < n / 2 { Phase::Ground } else { flying })
            .collect();
        FlightRecord {
            name: name.into(),
            voltage_v: time_s.iter().map(|t| volts - 0.001 * t).collect(),
            current_a: Some(vec![amps; n]),
            time_s,
            phase,
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
                cutoff_voltage_v: 12.0,
                ended_at_cutoff: false,
                ceiling_height_m: None,
                measured_ocv: None,
            },
        }
    }

    fn estimate(fs: &[&FlightRecord]) -> Result<ConstantPower, GapError> {
        let prior = BatterySet::fixed(LearnedBattery::lipo());
        estimate_hover_power(fs, &prior, &DiagnoseOptions::default())
    }

    #[test]
    fn flying_time_counts_only_the_intervals_in_the_air() {
        let f = flight("a", 40.0, 16.0, 10.0, Phase::Hover);
        assert!((f.flying_s() - 20.0).abs() < 1e-9, "{}", f.flying_s());
        assert!(unscorable(&f).is_none());
        let short = flight("b", 8.0, 16.0, 10.0, Phase::Hover);
        assert!(unscorable(&short).unwrap().contains("4.0 s of flying"));
        let ground = flight("c", 30.0, 16.0, 10.0, Phase::Ground);
        assert!(unscorable(&ground).unwrap().contains("no flying phase"));
    }

    #[test]
    fn hover_power_needs_ten_seconds_of_flying() {
        let a = flight("a", 8.0, 16.0, 10.0, Phase::Hover);
        let b = flight("b", 8.0, 16.0, 10.0, Phase::Hover);
        let e = estimate(&[&a, &b]).unwrap_err().to_string();
        assert!(
            e.contains("8.0 s in the air") && e.contains("a: 4.0 s of 8.0 s"),
            "{e}"
        );
        // Long enough: the measured hover power (16 V × 10 A less 2 W of avionics).
        let long = flight("c", 40.0, 16.0, 10.0, Phase::Hover);
        let w = estimate(&[&long]).unwrap().hover_power_w;
        assert!((w - 158.0).abs() < 0.5, "{w}");
    }

    #[test]
    fn hover_power_below_the_avionics_power_is_refused() {
        // 16 V × 0.1 A = 1.6 W drawn, below the 2 W the avionics take.
        let f = flight("low", 40.0, 16.0, 0.1, Phase::Hover);
        let e = estimate(&[&f]).unwrap_err().to_string();
        assert!(e.contains("not above the avionics power 2.00 W"), "{e}");
    }

    #[test]
    fn hover_power_far_above_what_the_flights_drew_is_refused() {
        // Current is logged but no sample is in a hover (climbing only): the estimate falls
        // back on the voltage, whose slope here asks far more power than the 16 W drawn.
        let mut f = flight("climb", 40.0, 16.0, 1.0, Phase::Climb);
        let n = f.time_s.len();
        f.voltage_v = (0..n).map(|i| 16.8 - 2.0 * i as f64 / n as f64).collect();
        let e = estimate(&[&f]).unwrap_err().to_string();
        assert!(e.contains("the most any of them drew (16."), "{e}");
    }
}
