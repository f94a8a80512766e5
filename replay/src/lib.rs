//! Replay: runs in-flight endurance estimators over logged flights exactly as firmware would —
//! sample by sample, in time order, each prediction made from past samples only — and scores
//! their predicted remaining time on flights that end at the cut-off.
//!
//! For every flight ([`flightlog::Flight`]) that ends at the cut-off ([`cutoff`] says how that
//! is recognised; the others are skipped with their reason), the methods ([`methods::METHODS`])
//! are fed the same samples:
//!
//! - `online`: the in-flight estimator `estimator::online` ([`online`]), with its one-sigma band;
//! - `px4`: PX4's `time_remaining_s` logic ([`methods::Px4TimeRemaining`]);
//! - `coulomb`: a rated-capacity coulomb counter ([`methods::CoulombCounter`]);
//! - `static_model`: the paper's endurance (eqs. 1–9) from the parameter file and the flight's
//!   metadata, minus the time elapsed ([`methods::StaticModel`]).
//!
//! At 25, 50, 75 and 90 % of the flight (take-off to cut-off) the prediction made at the last
//! sample before that instant is compared with the true remaining time (flight end − t), the
//! error expressed as a percentage of the flight's duration ([`score`]). [`Replay::summary`]
//! gives the median absolute error per method and checkpoint and how often the online
//! estimator's one-sigma band covers the truth.
//!
//! Main types: [`Sample`], [`Predictor`] (any estimator), [`ReplayConfig`], [`replay_flight`],
//! [`replay_flights`], [`Replay`] (with [`Replay::to_text`], [`Replay::to_json`],
//! [`Replay::to_csv`]); [`history`] carries the capacity a flight measured to its pack's next
//! flight ([`replay_flights_with_history`], `replay --pack-history`).
//!
//! ```
//! use std::path::Path;
//! use flightlog::{Flight, LogFormat};
//! use replay::{ReplayConfig, replay_flight};
//!
//! // A 3S pack hovering at 10 A until the autopilot lands at 10.5 V.
//! let mut csv = String::from("time_s,voltage_v,current_a,phase\n");
//! for k in 0..=600 {
//!     let v = 12.4 - 1.9 * f64::from(k) / 600.0;
//!     csv += &format!("{k},{v:.3},10.0,hover\n");
//! }
//! let mut flight = Flight::parse(csv.as_bytes(), Path::new("hover.csv"), LogFormat::Csv)?;
//! flight.meta.end = Some(flightlog::End::Cutoff);
//! flight.meta.cells = Some(3);
//! flight.meta.capacity_mah = Some(2000.0);
//!
//! let curve = paper::reproduce().unwrap().curve;
//! let params = estimator::Params { rotor_count: 4, curve, thrust_limit: None, battery: None, vehicle: None, motor: None };
//! let config = ReplayConfig::baselines_only(params);
//! let r = replay_flight(&flight, &config).unwrap();
//! assert_eq!(r.checkpoints.len(), 4);
//! // At half the flight, 300 s are left; the coulomb counter (2 Ah at 10 A = 720 s in all)
//! // says 720 - 300 = 420 s.
//! let half = &r.checkpoints[1];
//! assert_eq!(half.true_remaining_s, 300.0);
//! assert!((half.baselines[1].unwrap() - 420.0).abs() < 1.0);
//! # Ok::<(), flightlog::FlightLogError>(())
//! ```
//!
//! Invariants: a method never sees a sample after the one it predicts at; the library never
//! prints; it depends on no simulator (the evidence lives in `replay-eval`).

pub mod cutoff;
pub mod history;
pub mod methods;
pub mod online;
pub mod score;

use estimator::Params;
use flightlog::Flight;

pub use cutoff::{CutoffEvidence, FlightSpan};
pub use methods::{FlightSetup, METHODS, PlanLeg, Prediction, Predictor, Sample};
pub use score::{
    Checkpoint, CheckpointSummary, Commands, Coverage, FRACTIONS, FlightReplay, FlightTrace,
    MethodSeries, PowerSource, Replay, SkippedFlight, Summary,
};

/// Most points a plotted series keeps.
pub const MAX_SERIES_POINTS: usize = 1500;

/// Builds the online estimator for one flight (given the flight's metadata-derived setup and
/// its mission plan), or says why it cannot run on it. Also returns the names and final values
/// of its internal states, read after the flight, through [`OnlinePredictor::final_state`].
pub trait OnlineBuilder: Sync {
    /// The estimator for this flight.
    fn build(
        &self,
        setup: &FlightSetup,
        plan: &[PlanLeg],
        takeoff_s: f64,
    ) -> Result<Box<dyn OnlinePredictor>, String>;
}

/// An online estimator: a [`Predictor`] whose internal state can be read at the end.
pub trait OnlinePredictor: Predictor {
    /// Named internal states (state of charge, capacity, resistance, …) as they stand.
    fn final_state(&self) -> Vec<(&'static str, f64)>;

    /// The pack model it flies, when it has one ([`history`] reads a capacity against it).
    fn pack(&self) -> Option<estimator::online::BatteryModel> {
        None
    }
}

/// What a replay needs: the parameter file's estimator parameters and, when the online
/// estimator is to run, how to build it.
pub struct ReplayConfig<'a> {
    /// Parameters of the rig characterisation (curve, rotors, thrust limit).
    pub params: Params,
    /// The online estimator, when it runs.
    pub online: Option<&'a dyn OnlineBuilder>,
    /// The pack's chemistry, for the PX4 baseline's cell voltages
    /// ([`methods::Px4Battery::of`]; `None`: PX4's defaults).
    pub chemistry: Option<estimator::online::Chemistry>,
    /// Fly the methods also over flights that landed before the cut-off, for what they said
    /// ([`SkippedFlight::trace`]); they are still not scored.
    pub trace_unscored: bool,
    /// Give the online estimator the rotors' power read from each sample's motor commands
    /// through the parameters' `[motor]` map ([`Sample::motor_power_w`]), beside the current
    /// when there is one (`hoverbench replay --motor-power`; off by default).
    pub motor_power: bool,
}

impl ReplayConfig<'_> {
    /// The motor map the samples' power is read through: the parameters' `[motor]` when
    /// [`Self::motor_power`] asks for it.
    fn motor_map(&self) -> Option<&estimator::MotorMap> {
        self.params.motor.as_ref().filter(|_| self.motor_power)
    }

    /// Only the baselines (no online estimator), PX4 with its defaults.
    pub fn baselines_only(params: Params) -> Self {
        Self {
            params,
            online: None,
            chemistry: None,
            trace_unscored: false,
            motor_power: false,
        }
    }

    /// The cell voltages the PX4 baseline runs with.
    pub fn px4_battery(&self) -> methods::Px4Battery {
        methods::Px4Battery::of(self.chemistry)
    }
}

/// The online estimator of a parameter file (its `[battery]` section), with the thrust-limit
/// end on or off and samples averaged over `input_average_s` (0: none), and the band that goes
/// with them ([`online::FileOnline::with_opt_ins`]), the current sensor's zero read or not, and
/// the absolute resistance prior of voltage-only flights (`extra_resistance_sigma_ohm`, 0:
/// none) and the resistance's reopening at a run of low voltages
/// (`resync_resistance_sigma_ohm`, 0: never), or why it cannot run.
pub fn online_from_file(
    file: &estimator::file::ParamsFile,
    thrust_limit_end: bool,
    input_average_s: f64,
    zero_current: bool,
    extra_resistance_sigma_ohm: f64,
    resync_resistance_sigma_ohm: f64,
) -> Result<Box<dyn OnlineBuilder>, String> {
    online::FileOnline::from_file(file).map(|o| {
        Box::new(
            o.with_opt_ins(input_average_s, thrust_limit_end)
                .with_zero_current(zero_current)
                .with_extra_resistance_sigma_ohm(extra_resistance_sigma_ohm)
                .with_resync_resistance_sigma_ohm(resync_resistance_sigma_ohm),
        ) as Box<dyn OnlineBuilder>
    })
}

/// Replays one flight; `Err` with the reason when it is not scored.
pub fn replay_flight(flight: &Flight, config: &ReplayConfig<'_>) -> Result<FlightReplay, String> {
    replay_flight_with_history(flight, config, None).map_err(|k| k.reason)
}

/// A flight's pack (`battery_id`), and the reading its pack's history carries to it (the
/// flight that measured it and its factor on the model's capacity): the pack's last reading,
/// when that one [`carries`](history::CapacityReading::carries).
fn pack_of(
    flight: &Flight,
    history: Option<&history::PackHistory>,
) -> (Option<String>, Option<(String, f64)>) {
    // A history belongs to one pack: a flight that does not name its pack neither uses one
    // nor leaves one.
    let pack_id = flight
        .meta
        .battery_id
        .clone()
        .filter(|id| !id.trim().is_empty());
    let carried = history
        .zip(pack_id.as_deref())
        .and_then(|(h, id)| h.get(id))
        .filter(|r| r.carries())
        .map(|r| (r.flight.clone(), r.factor()));
    (pack_id, carried)
}

/// The capacity `flight` measured, flown until `end_s` by the online estimator `online` (which
/// ended in `final_state`), recorded in `h` under `pack_id`; why there is none otherwise.
fn take_reading(
    flight: &Flight,
    end_s: f64,
    online: Option<&dyn OnlinePredictor>,
    final_state: &[(&'static str, f64)],
    pack_id: Option<&str>,
    h: &mut history::PackHistory,
) -> Result<history::CapacityReading, String> {
    let Some(o) = online else {
        return Err("no online estimator ran".to_owned());
    };
    let Some(id) = pack_id else {
        return Err(
            "no battery_id in the metadata: a capacity is carried only to flights of the same pack"
                .to_owned(),
        );
    };
    let Some(pack) = o.pack() else {
        return Err("the online estimator has no pack model".to_owned());
    };
    let state = |name: &str| {
        final_state
            .iter()
            .find(|(k, _)| *k == name)
            .map_or(f64::NAN, |(_, v)| *v)
    };
    let est = history::FlightEstimates {
        start_soc: state("start_soc"),
        settled_offset_v: state("settled_curve_offset_v"),
        end_soc: state("soc"),
        end_offset_v: state("curve_offset_v"),
        usable_capacity_ah: state("usable_capacity_ah"),
        estimator_charge_ah: state("estimator_charge_ah"),
    };
    let r = history::capacity_reading(flight, end_s, &pack, &est)?;
    h.record(id, r.clone());
    Ok(r)
}

/// The capacity reading of a flight that is not scored (it did not end at the cut-off): the
/// online estimator flies it to its last flying sample, without a plan, only to read the
/// pack at the end ([`history::capacity_reading`] needs no cut-off).
fn reading_of_unscored(
    flight: &Flight,
    config: &ReplayConfig<'_>,
    pack_id: Option<&str>,
    carried: Option<f64>,
    h: &mut history::PackHistory,
) -> Result<history::CapacityReading, String> {
    let Some(builder) = config.online else {
        return Err("no online estimator ran".to_owned());
    };
    let Some((takeoff_s, end_s)) = cutoff::flying_span(flight) else {
        return Err("no sample in a flying phase".to_owned());
    };
    let mut setup = FlightSetup::of(flight);
    setup.capacity_reading = carried.map(|factor| (factor, history::READING_SIGMA));
    let mut online = builder.build(&setup, &[], takeoff_s)?;
    let s = &flight.samples;
    for k in 0..s.len() {
        if s.time_s[k] > end_s {
            break;
        }
        let _ = online.update(&sample_at(flight, k, config.motor_map()));
    }
    let final_state = online.final_state();
    take_reading(
        flight,
        end_s,
        Some(online.as_ref()),
        &final_state,
        pack_id,
        h,
    )
}

/// Sample `k` of `flight`, as the predictors take it; with the parameters' motor map and the
/// log's motor commands, the rotors' power read through the map at the sample's voltage (none
/// when a command drives its motor outside the map's measured range, as at idle).
fn sample_at(flight: &Flight, k: usize, motor: Option<&estimator::MotorMap>) -> Sample {
    let s = &flight.samples;
    Sample {
        time_s: s.time_s[k],
        voltage_v: s.voltage_v[k],
        current_a: s.current_a.as_ref().map(|c| c[k]),
        phase: s.phase.as_ref().map(|p| p[k]),
        motor_power_w: motor_power_w(flight, k, motor),
    }
}

/// The rotors' electrical power at sample `k` from the log's motor commands through `map`, W.
fn motor_power_w(flight: &Flight, k: usize, map: Option<&estimator::MotorMap>) -> Option<f64> {
    let (map, cols) = (map?, flight.samples.motor_us.as_ref()?);
    let mut us = [0.0; MAX_MOTORS];
    if cols.is_empty() || cols.len() > MAX_MOTORS {
        return None;
    }
    for (u, c) in us.iter_mut().zip(cols) {
        *u = *c.get(k)?;
    }
    map.total_power_w(&us[..cols.len()], flight.samples.voltage_v[k])
        .ok()
}

/// The most motors whose commands a sample's power is read from (`flightlog` reads up to 16).
const MAX_MOTORS: usize = 16;

/// [`replay_flight`] with the packs' history: the online estimator flies the capacity the
/// pack's last flight measured ([`history`]), and this flight's reading, or why it gives
/// none, is recorded in `history` and in [`FlightReplay::capacity_reading`]. `None`: no
/// history, as [`replay_flight`]. A flight that is not scored still measures its pack's
/// capacity, which its [`SkippedFlight::capacity_reading`] gives.
pub fn replay_flight_with_history(
    flight: &Flight,
    config: &ReplayConfig<'_>,
    history: Option<&mut history::PackHistory>,
) -> Result<FlightReplay, Box<SkippedFlight>> {
    let (pack_id, carried) = pack_of(flight, history.as_deref());
    let skip = |reason: String, history: Option<&mut history::PackHistory>| {
        Box::new(SkippedFlight {
            name: flight.name.clone(),
            reason,
            capacity_reading: history.map(|h| {
                let factor = carried.as_ref().map(|c| c.1);
                reading_of_unscored(flight, config, pack_id.as_deref(), factor, h)
            }),
            capacity_carried: carried.clone(),
            trace: None,
        })
    };
    if let Some(why) = flight.not_hovering() {
        return Err(skip(why, history));
    }
    let span = match cutoff::detect(flight) {
        Ok(span) => span,
        Err(why) => {
            let mut k = skip(why, history);
            // A flight too short to score is not traced either (its reason says so already).
            let span = cutoff::flying_span(flight).filter(|(a, b)| b - a >= cutoff::MIN_FLIGHT_S);
            if let Some(span) = span.filter(|_| config.trace_unscored) {
                k.trace = Some(trace_unscored(
                    flight,
                    config,
                    carried.as_ref().map(|c| c.1),
                    span,
                ));
            }
            return Err(k);
        }
    };
    let plan = methods::mission_plan(flight, &span);
    let Methods {
        mut online,
        mut baselines,
        unavailable,
    } = match Methods::for_flight(
        flight,
        config,
        carried.as_ref().map(|c| c.1),
        &plan,
        span.takeoff_s,
    ) {
        Ok(m) => m,
        Err(why) => return Err(skip(why, history)),
    };
    let s = &flight.samples;
    let n = s.len();
    // Checkpoint instants and the sample index each is scored at.
    let targets: Vec<f64> = FRACTIONS
        .iter()
        .map(|f| span.takeoff_s + f * span.duration_s())
        .collect();
    let mut checkpoints: Vec<Option<Checkpoint>> = vec![None; targets.len()];
    let mut recorder = SeriesRecorder::new(flight, span.takeoff_s);
    for k in 0..n {
        let t = s.time_s[k];
        if t > span.end_s {
            break;
        }
        let preds = step(
            &mut online,
            &mut baselines,
            &sample_at(flight, k, config.motor_map()),
        );
        recorder.record(k, t, &preds);
        // The last sample at or before each checkpoint instant.
        let next_t = s.time_s.get(k + 1).copied().unwrap_or(f64::INFINITY);
        for (c, &target) in targets.iter().enumerate() {
            if t <= target && next_t > target {
                checkpoints[c] = Some(Checkpoint {
                    fraction: FRACTIONS[c],
                    time_s: t,
                    true_remaining_s: span.end_s - t,
                    predicted_remaining_s: preds[0].map(|p| p.remaining_s),
                    sigma_s: preds[0].and_then(|p| p.sigma_s),
                    baselines: [
                        preds[1].map(|p| p.remaining_s),
                        preds[2].map(|p| p.remaining_s),
                        preds[3].map(|p| p.remaining_s),
                    ],
                });
            }
        }
    }
    let checkpoints: Vec<Checkpoint> = checkpoints.into_iter().flatten().collect();
    if checkpoints.len() != FRACTIONS.len() {
        return Err(skip(
            "a checkpoint falls in a hole of the log".to_owned(),
            history,
        ));
    }
    let final_state = online.as_ref().map(|o| o.final_state()).unwrap_or_default();
    let capacity_reading = history.map(|h| {
        take_reading(
            flight,
            span.end_s,
            online.as_deref(),
            &final_state,
            pack_id.as_deref(),
            h,
        )
    });
    Ok(FlightReplay {
        capacity_reading,
        capacity_carried: carried,
        name: flight.name.clone(),
        takeoff_s: span.takeoff_s,
        end_s: span.end_s,
        evidence: span.evidence,
        checkpoints,
        unavailable,
        series_time_s: recorder.time_s,
        series: recorder.series,
        final_state,
        power_source: power_source(flight, config),
    })
}

/// What measures the power of `flight` for the online estimator: its current, its motor
/// commands through the `[motor]` map when `config` asks for them and any flying sample reads
/// through it, both, or neither (the model's power).
fn power_source(flight: &Flight, config: &ReplayConfig<'_>) -> PowerSource {
    let s = &flight.samples;
    let flying = |k: usize| s.phase.as_ref().is_none_or(|p| p[k].is_flying());
    let commands = if s.motor_us.is_none() {
        Commands::NotLogged
    } else if !config.motor_power {
        Commands::NotAsked
    } else if config.params.motor.is_none() {
        Commands::NoMap
    } else if (0..s.len())
        .any(|k| flying(k) && motor_power_w(flight, k, config.motor_map()).is_some())
    {
        Commands::Used
    } else {
        Commands::OutOfRange
    };
    PowerSource {
        current: s.current_a.is_some(),
        commands,
    }
}

/// The methods flown over one flight: the online estimator and the three baselines, and why
/// each that cannot run does not.
struct Methods {
    online: Option<Box<dyn OnlinePredictor>>,
    baselines: [Option<Box<dyn Predictor>>; 3],
    unavailable: Vec<(&'static str, String)>,
}

impl Methods {
    /// The methods for `flight` flown with `plan` from `takeoff_s`, the online estimator with
    /// the capacity factor its pack's history carried (`carried`); why none can run otherwise.
    fn for_flight(
        flight: &Flight,
        config: &ReplayConfig<'_>,
        carried: Option<f64>,
        plan: &[PlanLeg],
        takeoff_s: f64,
    ) -> Result<Self, String> {
        let mut setup = FlightSetup::of(flight);
        setup.capacity_reading = carried.map(|factor| (factor, history::READING_SIGMA));
        let mut unavailable: Vec<(&'static str, String)> = Vec::new();
        let online: Option<Box<dyn OnlinePredictor>> = match config.online {
            None => {
                unavailable.push((methods::ONLINE, "not run (no online estimator)".to_owned()));
                None
            }
            Some(b) => match b.build(&setup, plan, takeoff_s) {
                Ok(p) => Some(p),
                Err(e) => {
                    unavailable.push((methods::ONLINE, e));
                    None
                }
            },
        };
        let has_current = flight.samples.current_a.is_some();
        let mut baselines: [Option<Box<dyn Predictor>>; 3] = [None, None, None];
        match (setup.cells, setup.rated_capacity_ah) {
            _ if !has_current => {
                unavailable.push((methods::PX4, "no current logged".to_owned()));
                unavailable.push((methods::COULOMB, "no current logged".to_owned()));
            }
            (Some(c), Some(ah)) => {
                baselines[0] = Some(Box::new(methods::Px4TimeRemaining::new(
                    methods::Px4Params::configured(c, ah * 1000.0, &config.px4_battery()),
                )));
                baselines[1] = Some(Box::new(methods::CoulombCounter::new(ah)));
            }
            _ => {
                let why = "metadata lacks cells or a rated capacity".to_owned();
                unavailable.push((methods::PX4, why.clone()));
                unavailable.push((methods::COULOMB, why));
            }
        }
        match methods::StaticModel::new(&config.params, &setup, plan, takeoff_s) {
            Ok(m) => baselines[2] = Some(Box::new(m)),
            Err(e) => unavailable.push((methods::STATIC, e)),
        }
        if online.is_none() && baselines.iter().all(Option::is_none) {
            let why: Vec<String> = unavailable
                .iter()
                .map(|(m, r)| format!("{m}: {r}"))
                .collect();
            return Err(format!("no method can run on it ({})", why.join("; ")));
        }
        Ok(Self {
            online,
            baselines,
            unavailable,
        })
    }
}

/// One sample through every method that runs: their predictions in [`METHODS`] order.
fn step(
    online: &mut Option<Box<dyn OnlinePredictor>>,
    baselines: &mut [Option<Box<dyn Predictor>>; 3],
    sample: &Sample,
) -> [Option<Prediction>; 4] {
    let mut preds: [Option<Prediction>; 4] = [None; 4];
    if let Some(o) = online.as_mut() {
        preds[0] = o.update(sample).filter(|p| p.remaining_s.is_finite());
    }
    for (i, b) in baselines.iter_mut().enumerate() {
        if let Some(b) = b {
            preds[i + 1] = b.update(sample).filter(|p| p.remaining_s.is_finite());
        }
    }
    preds
}

/// What the methods said over a flight that landed before the cut-off: flown as a scored
/// flight is, with its phase schedule as the plan (the last leg "hover until empty") up to its
/// last flying sample; `(takeoff_s, landed_s)`: its flying span ([`cutoff::flying_span`]).
fn trace_unscored(
    flight: &Flight,
    config: &ReplayConfig<'_>,
    carried: Option<f64>,
    (takeoff_s, landed_s): (f64, f64),
) -> Result<FlightTrace, String> {
    let plan = methods::mission_plan_between(flight, takeoff_s, landed_s);
    let Methods {
        mut online,
        mut baselines,
        unavailable,
    } = Methods::for_flight(flight, config, carried, &plan, takeoff_s)?;
    let s = &flight.samples;
    let mut recorder = SeriesRecorder::new(flight, takeoff_s);
    let mut at_landing: [Option<Prediction>; 4] = [None; 4];
    for k in 0..s.len() {
        let t = s.time_s[k];
        if t > landed_s {
            break;
        }
        let preds = step(
            &mut online,
            &mut baselines,
            &sample_at(flight, k, config.motor_map()),
        );
        recorder.record(k, t, &preds);
        for (last, p) in at_landing.iter_mut().zip(preds) {
            if p.is_some() {
                *last = p;
            }
        }
    }
    Ok(FlightTrace {
        takeoff_s,
        landed_s,
        series_time_s: recorder.time_s,
        series: recorder.series,
        at_landing: at_landing
            .iter()
            .map(|p| p.map(|p| (p.remaining_s, p.sigma_s)))
            .collect(),
        unavailable,
        final_state: online.as_ref().map(|o| o.final_state()).unwrap_or_default(),
    })
}

/// Every method's predictions over a flight from take-off on, kept at most
/// [`MAX_SERIES_POINTS`] times, for plots.
struct SeriesRecorder {
    flying_from: usize,
    stride: usize,
    time_s: Vec<f64>,
    series: Vec<MethodSeries>,
}

impl SeriesRecorder {
    fn new(flight: &Flight, takeoff_s: f64) -> Self {
        let t = &flight.samples.time_s;
        let flying_from = t.partition_point(|&x| x < takeoff_s);
        Self {
            flying_from,
            stride: ((t.len() - flying_from) / MAX_SERIES_POINTS).max(1),
            time_s: Vec::new(),
            series: METHODS
                .iter()
                .map(|m| MethodSeries {
                    name: m,
                    ..MethodSeries::default()
                })
                .collect(),
        }
    }

    /// The predictions after sample `k` (time `t`), kept when it is a plotted one.
    fn record(&mut self, k: usize, t: f64, preds: &[Option<Prediction>; 4]) {
        if k < self.flying_from || (k - self.flying_from) % self.stride != 0 {
            return;
        }
        self.time_s.push(t);
        for (m, p) in self.series.iter_mut().zip(preds) {
            m.remaining_s.push(p.map_or(f64::NAN, |p| p.remaining_s));
            m.sigma_s
                .push(p.and_then(|p| p.sigma_s).unwrap_or(f64::NAN));
        }
    }
}

/// Replays flights in order, calling `progress` after each; flights not scored are listed with
/// their reason (and `unread` — files that could not be read at all — are added as skipped).
pub fn replay_flights(
    flights: &[Flight],
    unread: Vec<SkippedFlight>,
    config: &ReplayConfig<'_>,
    progress: impl FnMut(usize),
) -> Replay {
    replay_flights_with_history(flights, unread, config, None, progress)
}

/// [`replay_flights`] with the packs' history ([`replay_flight_with_history`]): flights are
/// replayed in the order given, so a pack's flights should come in the order they were
/// flown.
pub fn replay_flights_with_history(
    flights: &[Flight],
    unread: Vec<SkippedFlight>,
    config: &ReplayConfig<'_>,
    mut history: Option<&mut history::PackHistory>,
    mut progress: impl FnMut(usize),
) -> Replay {
    let mut scored = Vec::new();
    let mut skipped = unread;
    for (i, f) in flights.iter().enumerate() {
        match replay_flight_with_history(f, config, history.as_deref_mut()) {
            Ok(r) => scored.push(r),
            Err(k) => skipped.push(*k),
        }
        progress(i + 1);
    }
    Replay::new(scored, skipped)
}
