//! Evidence for the in-flight estimator: flight sets from the truth simulator (`flight-sim`)
//! with conditions the estimator is not told about, the pack learned by the gap diagnosis from
//! nominal flights of the same pack type, every held-out flight replayed by `replay` beside the
//! baselines, and the scores rolled up per group of world families.
//!
//! One scenario (a seed and a world family: chemistry × logging × robot, see
//! [`flight_sim::Family`]):
//! 1. the robot's rig sweep is fitted (fifth order, as `hoverbench fit` does) into the rig curve;
//! 2. the scenario's eight training flights are flown **nominal** (no condition) and the pack of
//!    each of the two pack types is learned from its own training flights
//!    (`gap::params_link::learn_section`) into a `[battery]` section;
//! 3. the four held-out flights are flown to the cut-off **with the condition** drawn from the
//!    seed ([`Condition`]): capacity fade, extra series resistance (a bad connector), a cold pack
//!    (ambient −10…+5 °C: flight-sim's Arrhenius resistance with self-heating), a payload the
//!    metadata does not declare, control overhead (airframe download: power above the model),
//!    a payload that drains in flight (a sprayer), or nothing;
//! 4. each held-out flight is replayed with its pack's learned section, and scored.
//!
//! The truth (condition, magnitude) never reaches the estimator: it reads the flight's files
//! (CSV and metadata sidecar, through `flightlog`) and the parameter sections only. The
//! sidecar gets the rated capacity a pack's label gives (`capacity_mah`: rated energy over the
//! cells and the chemistry's label voltage) so the baselines can be set up as a user would.
//!
//! Tuning and held-out families: the online estimator may be tuned on flight-sim's tuning
//! families (`lipo|nmc` × `lab-1hz|fc-10hz` × `paper`, as in gap-eval) only; every other family
//! (LiHV, NCA, LiFePO₄, voltage-only 5 Hz and 50 Hz logging, every varied robot) is held out.
//! [`Study::groups`] reports both.
//!
//! Sensor ablation: [`study_with`] and [`prepare_scenario_with`] fly the same worlds with
//! calibrated sensors ([`flight_sim::SensorErrors`]: no per-flight scale or offset error on the
//! voltage, the current or both), so a study tells how much of the error the sensors cause.
//!
//! Main types: [`StudyOptions`] (seeds, families, the estimator's configuration and the
//! opt-ins), [`Study`] (every scenario's [`ScenarioOutcome`] and the [`Group`] roll-ups), and
//! [`table`] / [`to_json`] (what `hoverbench replay-eval` prints). A study of four held-out
//! scenarios with both opt-ins (`hoverbench replay-eval --scenarios 4 --seed 9100 --families
//! heldout --input-average 1 --thrust-limit-end` from the CLI):
//!
//! ```no_run
//! use estimator::online::OnlineConfig;
//! use replay_eval::{StudyOptions, select_families, study, table};
//!
//! let opts = StudyOptions {
//!     seeds: 9100..9104,
//!     families: select_families("heldout")?,
//!     threads: 2,
//!     config: OnlineConfig::default().with_opt_ins(1.0, true),
//!     pack_history: false,
//!     voltage_only: false,
//!     motor_power: false,
//! };
//! let result = study(&opts, &|| {});
//! print!("{}", table(&result));
//! # Ok::<(), replay_eval::EvalError>(())
//! ```

pub mod oracle;

use std::ops::Range;
use std::path::Path;

use estimator::file::BatterySection;
use estimator::online::OnlineConfig;
use estimator::{Params, PolyCurve};
use flight_sim::{
    Chemistry, EffectKind, Family, FlightPlan, FlightTruth, Logging, Robot, RobotVariant,
    SensorErrors, SimFlight, Withheld, plans, simulate_with, simulate_with_truth,
};
use flightlog::{Flight, FlightMeta, LogFormat};
pub use oracle::{Oracle, OracleOnline};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use replay::online::FileOnline;
use replay::{FlightReplay, Replay, ReplayConfig, SkippedFlight};
use serde::Serialize;

/// Errors of a scenario.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// The rig sweep could not be fitted.
    #[error("rig curve: {0}")]
    Rig(String),
    /// A simulated flight could not be read back.
    #[error("reading back {name}: {message}")]
    ReadBack {
        /// Flight.
        name: String,
        /// Why.
        message: String,
    },
    /// The battery could not be learned.
    #[error("learning the battery {pack}: {message}")]
    Battery {
        /// Pack type.
        pack: String,
        /// Why.
        message: String,
    },
    /// An unknown family or group filter.
    #[error("no world family matches {0:?}")]
    NoFamily(String),
}

/// A condition of the held-out flights the estimator is not told about.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Condition {
    /// Nothing.
    Nominal,
    /// Capacity lost, fraction.
    CapacityFade {
        /// Fraction lost.
        fraction: f64,
    },
    /// Extra series resistance (connector, wiring), Ω.
    ExtraResistance {
        /// Ω.
        ohm: f64,
    },
    /// A cold pack: ambient temperature, °C.
    Cold {
        /// °C.
        ambient_c: f64,
    },
    /// A payload the metadata does not declare, kg.
    UndeclaredPayload {
        /// kg.
        kg: f64,
    },
    /// Control overhead (airframe download), fraction of the weight.
    ControlOverhead {
        /// Fraction.
        fraction: f64,
    },
    /// A payload that drains in flight over 5 min (declared at take-off), kg.
    DrainingPayload {
        /// kg.
        kg: f64,
    },
}

impl Condition {
    /// Names of the condition kinds, in draw order.
    pub const NAMES: [&'static str; 7] = [
        "nominal",
        "capacity_fade",
        "extra_resistance",
        "cold",
        "undeclared_payload",
        "control_overhead",
        "draining_payload",
    ];

    /// Name of the kind.
    pub fn name(&self) -> &'static str {
        match self {
            Condition::Nominal => Self::NAMES[0],
            Condition::CapacityFade { .. } => Self::NAMES[1],
            Condition::ExtraResistance { .. } => Self::NAMES[2],
            Condition::Cold { .. } => Self::NAMES[3],
            Condition::UndeclaredPayload { .. } => Self::NAMES[4],
            Condition::ControlOverhead { .. } => Self::NAMES[5],
            Condition::DrainingPayload { .. } => Self::NAMES[6],
        }
    }

    /// Drawn from a seed: each kind equally often, magnitudes uniform over their ranges.
    pub fn draw(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7265_706c_6179);
        let k = rng.random_range(0..Self::NAMES.len());
        let u: f64 = rng.random();
        let lerp = |a: f64, b: f64| a + (b - a) * u;
        match k {
            0 => Condition::Nominal,
            1 => Condition::CapacityFade {
                fraction: lerp(0.05, 0.25),
            },
            2 => Condition::ExtraResistance {
                ohm: lerp(0.02, 0.10),
            },
            3 => Condition::Cold {
                ambient_c: lerp(-10.0, 5.0),
            },
            4 => Condition::UndeclaredPayload {
                kg: lerp(0.03, 0.08),
            },
            5 => Condition::ControlOverhead {
                fraction: lerp(0.03, 0.10),
            },
            _ => Condition::DrainingPayload {
                kg: lerp(0.03, 0.08),
            },
        }
    }

    fn effect(&self) -> Withheld {
        let (kind, magnitude) = match *self {
            Condition::CapacityFade { fraction } => (EffectKind::CapacityFade, fraction),
            Condition::ExtraResistance { ohm } => (EffectKind::InternalResistance, ohm),
            Condition::ControlOverhead { fraction } => (EffectKind::ControlOverhead, fraction),
            Condition::DrainingPayload { kg } => (EffectKind::DrainingPayload, kg),
            _ => return Withheld::NONE,
        };
        Withheld { kind, magnitude }
    }
}

/// Label voltage of a chemistry's cell, V: what a pack's label multiplies into its Wh.
pub fn label_cell_v(c: Chemistry) -> f64 {
    match c {
        Chemistry::LiPo => 3.7,
        Chemistry::LiHv => 3.85,
        Chemistry::Nmc | Chemistry::Nca => 3.6,
        Chemistry::LiFePo4 => 3.2,
    }
}

/// The chemistry printed on a pack's label, as the gap diagnosis names its priors: what a user
/// passes to `hoverbench battery learn --chemistry`. `None` for LiFePO₄, as when the diagnosis had
/// no prior for it: it now has one (`gap::battery::Chemistry::Lifepo4`), which its pick by the
/// flights' voltage level chooses for these packs; passing it explicitly would change the
/// study's reported numbers, so it is not.
pub fn label_chemistry(c: Chemistry) -> Option<gap::battery::Chemistry> {
    match c {
        Chemistry::LiPo => Some(gap::battery::Chemistry::Lipo),
        Chemistry::LiHv => Some(gap::battery::Chemistry::Lihv),
        Chemistry::Nmc => Some(gap::battery::Chemistry::LiIonNmc),
        Chemistry::Nca => Some(gap::battery::Chemistry::LiIonNca),
        Chemistry::LiFePo4 => None,
    }
}

/// Whether the online estimator may be tuned on this family (see the crate docs).
pub fn is_tuning_family(f: &Family) -> bool {
    matches!(f.chemistry, Chemistry::LiPo | Chemistry::Nmc)
        && matches!(f.logging, Logging::Lab1Hz | Logging::Fc10Hz)
        && f.robot == RobotVariant::Paper
}

/// Families selected by a comma-separated filter: `all`, `tuning`, `heldout` (by
/// [`is_tuning_family`]), or patterns `chemistry/logging/robot` with `*`.
pub fn select_families(filter: &str) -> Result<Vec<Family>, EvalError> {
    Family::select(filter, is_tuning_family).map_err(|e| EvalError::NoFamily(e.0))
}

/// The families and seeds of an example's command line `FAMILIES FIRST COUNT` (`args[1..]`;
/// defaults `tuning`, 0, 12).
pub fn families_and_seeds(args: &[String]) -> Result<(Vec<Family>, Range<u64>), EvalError> {
    let families = select_families(args.get(1).map_or("tuning", String::as_str))?;
    let first: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let count: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(12);
    Ok((families, first..first + count))
}

/// The motor map a characterisation session fits from the robot's two rig sweeps with their ESC
/// commands (`fit::motor`, as `hoverbench fit` does from `sweep.csv` and `limit.csv`).
pub fn motor_map(sweeps: &flight_sim::RigSweeps) -> Result<estimator::MotorMap, EvalError> {
    let points = |steps: &[flight_sim::RigStep], name: &str| fit::motor::MotorPoints {
        throttle_us: steps.iter().map(|s| s.throttle_us).collect(),
        voltage_v: steps.iter().map(|s| s.voltage_v).collect(),
        power_w: steps.iter().map(|s| s.power_w).collect(),
        thrust_g: steps.iter().map(|s| s.thrust_g).collect(),
        supply_voltage_v: steps.first().map_or(f64::NAN, |s| s.voltage_v),
        source_name: name.to_owned(),
        command_range_us: Some((1000.0, 2000.0)),
    };
    let fitted = fit::motor::fit_motor_map(
        &[
            points(&sweeps.nominal, "sweep"),
            points(&sweeps.limit, "limit"),
        ],
        &fit::motor::MotorMapOptions::new(1000.0, 2000.0),
    )
    .map_err(|e| EvalError::Rig(format!("motor map: {e}")))?;
    Ok(fitted.map)
}

/// The rig curve a user fits from the sweep (fifth order).
pub fn rig_curve(thrust_g: &[f64], power_w: &[f64], volts: f64) -> Result<PolyCurve, EvalError> {
    let f = fit::fit_polynomial(thrust_g, power_w, 5).map_err(|e| EvalError::Rig(e.to_string()))?;
    PolyCurve::new(
        f.coeffs_scaled(),
        f.center(),
        f.scale(),
        f.domain(),
        Some(volts),
    )
    .map_err(|e| EvalError::Rig(e.to_string()))
}

fn read_back(f: &SimFlight, label_v: f64) -> Result<Flight, EvalError> {
    let err = |e: flightlog::FlightLogError| EvalError::ReadBack {
        name: f.name.clone(),
        message: flightlog::summary::error_chain(&e),
    };
    let mut flight = Flight::parse(
        f.csv.as_bytes(),
        Path::new(&format!("{}.csv", f.name)),
        LogFormat::Csv,
    )
    .map_err(err)?;
    let mut meta =
        FlightMeta::parse(&f.toml, Path::new(&format!("{}.toml", f.name))).map_err(err)?;
    if let (Some(e), Some(c)) = (meta.battery_energy_wh, meta.cells) {
        meta.capacity_mah = Some(e / (f64::from(c) * label_v) * 1000.0);
    }
    flight.meta = meta.merged_over(&flight.meta);
    Ok(flight)
}

/// The rig's thrust-limit sweep of one rotor at `volts` (the paper's procedure: at the minimum
/// battery voltage, the autopilot's landing threshold, thrust stepped by `step_g` until the
/// rotor cannot hold a step, in the rig hall's air): the limit lies between the last step held and the next, so it is
/// reported as the middle of that step with the step's uniform standard deviation
/// (`step / √12`).
pub fn limit_sweep(robot: &Robot, volts: f64, step_g: f64) -> estimator::ThrustLimit {
    let max = robot
        .propulsion
        .max_thrust_g(volts, flight_sim::robot::RIG_AIR_DENSITY_KG_M3);
    let mut held = 0.0;
    while held + step_g <= max {
        held += step_g;
    }
    estimator::ThrustLimit {
        per_rotor_g: held + 0.5 * step_g,
        uncertainty_g: step_g / 12f64.sqrt(),
        supply_voltage_v: volts,
    }
}

/// What was learned for one pack type.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LearnedPack {
    /// Pack type (`battery_id`).
    pub pack: String,
    /// Rated capacity in the section, Ah.
    pub rated_capacity_ah: f64,
    /// Series resistance, Ω per cell.
    pub series_resistance_cell_ohm: f64,
    /// Prior chosen.
    pub chemistry: String,
}

/// One scenario's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioOutcome {
    /// Seed.
    pub seed: u64,
    /// World family.
    pub family: Family,
    /// A tuning family.
    pub tuning: bool,
    /// The condition of the held-out flights.
    pub condition: Condition,
    /// Packs learned.
    pub packs: Vec<LearnedPack>,
    /// Replayed held-out flights.
    pub flights: Vec<FlightReplay>,
    /// Held-out flights not scored.
    pub skipped: Vec<SkippedFlight>,
    /// For the harness's diagnostics only (`flight_lines`), never handed to an estimator: each
    /// held-out flight's name with its pack's true capacity, Ah, and mean airborne series
    /// resistance, Ω (flight-sim's record).
    pub truth_pack: Vec<(String, f64, f64)>,
}

/// A scenario's worlds flown and its packs learned, before any estimator runs: what
/// [`run_scenario`] replays (kept apart so that traces and configuration sweeps need not fly
/// the flights again).
#[derive(Debug, Clone)]
pub struct PreparedScenario {
    /// Seed.
    pub seed: u64,
    /// World family.
    pub family: Family,
    /// The condition of the held-out flights.
    pub condition: Condition,
    /// Rig curve and rotor count (no `[battery]`: each flight gets its pack's section), as the
    /// baselines get them: without the thrust limit (the static model would otherwise refuse
    /// every flight over eq. 5's payload limit, a change to the baseline's inputs).
    pub params: Params,
    /// The rig's thrust limit at the minimum battery voltage ([`limit_sweep`] at the flights'
    /// cut-off voltage), given to the online estimator only
    /// ([`estimator::online::OnlineConfig::thrust_limit_end`]).
    pub thrust_limit: Option<estimator::ThrustLimit>,
    /// Packs learned.
    pub packs: Vec<LearnedPack>,
    /// Held-out flights with the learned pack model of their pack type.
    pub flights: Vec<(Flight, estimator::online::BatteryModel)>,
    /// Held-out flights that cannot be replayed (no training flight of their pack).
    pub skipped: Vec<SkippedFlight>,
    /// The online band's curve-shape uncertainty for each flight in [`Self::flights`], V per
    /// cell, from its pack's learned section (`BatterySection::curve_shape_sigma_cell_v`:
    /// the fit's RMSE and the prior's pull), or `None` to keep the configured value.
    pub curve_sigma_cell_v: Vec<Option<f64>>,
    /// The truth of each flight in [`Self::flights`] (flight-sim's record beside the flight):
    /// for the oracle ablation only ([`replay_scenario_with_oracle`]); the plain replay never
    /// reads it.
    pub truths: Vec<FlightTruth>,
}

impl PreparedScenario {
    /// The same scenario with the held-out flights' current column removed (the truth, the
    /// packs and the metadata kept): what the estimator and the baselines do with a
    /// voltage-only log of the same flights.
    #[must_use]
    pub fn without_current(mut self) -> Self {
        for (f, _) in &mut self.flights {
            f.samples.current_a = None;
        }
        self
    }

    /// The same scenario with the held-out flights' motor commands removed: the online
    /// estimator then runs without the rotors' power read from them (as without
    /// [`StudyOptions::motor_power`]).
    #[must_use]
    pub fn without_motors(mut self) -> Self {
        for (f, _) in &mut self.flights {
            f.samples.motor_us = None;
        }
        self
    }
}

/// Flies a scenario's training and held-out flights and learns its packs (steps 1–3 of the
/// crate docs).
pub fn prepare_scenario(family: &Family, seed: u64) -> Result<PreparedScenario, EvalError> {
    prepare_scenario_with(family, seed, SensorErrors::Drawn)
}

/// [`prepare_scenario`] with a choice of the sensors' constant errors for every flight of the
/// scenario, training and held-out (an ablation: how much of the estimator's error the
/// per-flight sensor scale and offset errors cause). [`SensorErrors::Drawn`] is
/// [`prepare_scenario`].
pub fn prepare_scenario_with(
    family: &Family,
    seed: u64,
    sensors: SensorErrors,
) -> Result<PreparedScenario, EvalError> {
    let robot = Robot::of(family.robot, seed);
    let (train_plans, held_plans) = plans(family, seed);
    let (thrust, power) = robot.rig_sweep(10.0, seed);
    let curve = rig_curve(&thrust, &power, flight_sim::robot::RIG_VOLTAGE_V)?;
    let label_v = label_cell_v(family.chemistry);
    let fly = |p: &FlightPlan, effect: &Withheld, salt: u64| {
        let s = seed.wrapping_mul(1_000_003).wrapping_add(salt);
        simulate_with(family, &robot, p, effect, s, sensors)
    };
    // Nominal training flights.
    let mut train = Vec::new();
    for (k, p) in train_plans.iter().enumerate() {
        train.push(read_back(&fly(p, &Withheld::NONE, k as u64), label_v)?);
    }
    let records: Vec<gap::flight::FlightRecord> = train
        .iter()
        .filter_map(|f| gap::logs::record_from_log(f).ok())
        .collect();
    let params = Params {
        rotor_count: robot.rotor_count,
        curve,
        thrust_limit: None,
        battery: None,
        vehicle: None,
        motor: Some(motor_map(&robot.rig_sweeps(10.0, seed))?),
    };
    let model = gap::model::Model {
        curve: &params.curve,
        rotor_count: params.rotor_count,
    };
    let mut sections: Vec<(String, BatterySection)> = Vec::new();
    let mut packs = Vec::new();
    let mut ids: Vec<String> = records.iter().map(gap::battery::battery_type).collect();
    ids.sort();
    ids.dedup();
    for id in &ids {
        let l = gap::params_link::learn_section(
            model,
            &records,
            Some(id),
            label_chemistry(family.chemistry),
        )
        .map_err(|e| EvalError::Battery {
            pack: id.clone(),
            message: flightlog::summary::error_chain(&e),
        })?;
        packs.push(LearnedPack {
            pack: id.clone(),
            rated_capacity_ah: l.section.rated_capacity_ah.unwrap_or(f64::NAN),
            series_resistance_cell_ohm: l.section.series_resistance_cell_ohm,
            chemistry: l.section.chemistry.clone(),
        });
        sections.push((id.clone(), l.section));
    }
    // Held-out flights with the condition.
    let condition = Condition::draw(seed);
    let effect = condition.effect();
    let mut flights = Vec::new();
    let mut curve_sigma = Vec::new();
    let mut truths = Vec::new();
    let mut skipped = Vec::new();
    for (k, p) in held_plans.iter().enumerate() {
        let mut plan = p.clone();
        let mut declared_payload = None;
        match condition {
            Condition::Cold { ambient_c } => plan.ambient_c = ambient_c,
            Condition::UndeclaredPayload { kg } => {
                declared_payload = Some(plan.payload_mass_kg);
                plan.payload_mass_kg += kg;
            }
            _ => {}
        }
        let (mut sim, truth) = simulate_with_truth(
            family,
            &robot,
            &plan,
            &effect,
            seed.wrapping_mul(1_000_003).wrapping_add(100 + k as u64),
            sensors,
        );
        if let Some(d) = declared_payload {
            sim.toml = sim
                .toml
                .lines()
                .map(|l| {
                    if l.starts_with("payload_mass_kg") {
                        format!("payload_mass_kg = {d}")
                    } else {
                        l.to_owned()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n")
                + "\n";
        }
        let flight = read_back(&sim, label_v)?;
        let id = flight.meta.battery_id.clone().unwrap_or_default();
        let Some((_, section)) = sections.iter().find(|(i, _)| *i == id) else {
            skipped.push(SkippedFlight {
                name: flight.name.clone(),
                reason: format!("no training flight of pack {id}"),
                capacity_reading: None,
                capacity_carried: None,
                trace: None,
            });
            continue;
        };
        let battery = section.to_model().map_err(|(_, m)| EvalError::Battery {
            pack: id.clone(),
            message: m,
        })?;
        curve_sigma.push(
            (section.fit_rmse_cell_v.is_some() || section.curve_prior_sigma_cell_v.is_some())
                .then(|| section.curve_shape_sigma_cell_v(0.0)),
        );
        flights.push((flight, battery));
        truths.push(truth);
    }
    let thrust_limit = train
        .iter()
        .find_map(|f| f.meta.cutoff_voltage_v)
        .map(|v| limit_sweep(&robot, v, 10.0));
    Ok(PreparedScenario {
        seed,
        family: *family,
        condition,
        params,
        thrust_limit,
        packs,
        flights,
        skipped,
        curve_sigma_cell_v: curve_sigma,
        truths,
    })
}

impl PreparedScenario {
    /// The parameters the online estimator gets: [`Self::params`] with the thrust limit.
    pub fn online_params(&self) -> Params {
        Params {
            thrust_limit: self.thrust_limit,
            ..self.params
        }
    }
}

/// Replays a prepared scenario's held-out flights with the online estimator configured by
/// `config` (step 4 of the crate docs).
pub fn replay_scenario(prepared: &PreparedScenario, config: &OnlineConfig) -> ScenarioOutcome {
    replay_scenario_with_history(prepared, config, false)
}

/// [`replay_scenario`] with the packs' history on or off (`replay --pack-history`,
/// [`replay::history`]): the held-out flights are replayed in the order they were flown, and
/// each pack's second flight flies the capacity its first measured.
pub fn replay_scenario_with_history(
    prepared: &PreparedScenario,
    config: &OnlineConfig,
    pack_history: bool,
) -> ScenarioOutcome {
    replay_scenario_by(prepared, config, pack_history, &|_, battery, config| {
        Box::new(FileOnline::new(prepared.online_params(), battery, config))
    })
}

/// [`replay_scenario`] with the pieces of each flight's truth that `oracle` hands the
/// estimator ([`oracle`]); its `sensors` switch is the preparation's
/// ([`prepare_scenario_with`] with [`Oracle::sensor_errors`]), not this function's. With
/// [`Oracle::NONE`] the outcome is [`replay_scenario`]'s.
pub fn replay_scenario_with_oracle(
    prepared: &PreparedScenario,
    config: &OnlineConfig,
    oracle: Oracle,
) -> ScenarioOutcome {
    replay_scenario_by(prepared, config, false, &|k, battery, config| {
        Box::new(OracleOnline {
            params: prepared.online_params(),
            battery,
            config,
            truth: prepared.truths[k].clone(),
            oracle,
        })
    })
}

/// The replay of [`replay_scenario`] with the estimator of held-out flight `k` built by
/// `online(k, its learned pack, config)`.
fn replay_scenario_by(
    prepared: &PreparedScenario,
    config: &OnlineConfig,
    pack_history: bool,
    online: &dyn Fn(
        usize,
        estimator::online::BatteryModel,
        OnlineConfig,
    ) -> Box<dyn replay::OnlineBuilder>,
) -> ScenarioOutcome {
    let mut flights = Vec::new();
    let mut skipped = prepared.skipped.clone();
    let mut history = replay::history::PackHistory::new();
    for (k, (flight, battery)) in prepared.flights.iter().enumerate() {
        let mut config = *config;
        if let Some(Some(s)) = prepared.curve_sigma_cell_v.get(k) {
            config.cutoff_curve_sigma_cell_v = config.cutoff_curve_sigma_cell_v.max(*s);
        }
        let online = online(k, *battery, config);
        // PX4 set up for the chemistry of the pack's learned section
        let rc = ReplayConfig {
            params: prepared.params,
            online: Some(online.as_ref()),
            chemistry: Some(battery.chemistry),
            trace_unscored: false,
            // the commands are there only when the study asks for them
            // ([`StudyOptions::motor_power`])
            motor_power: true,
        };
        let h = pack_history.then_some(&mut history);
        match replay::replay_flight_with_history(flight, &rc, h) {
            Ok(r) => flights.push(r),
            Err(k) => skipped.push(*k),
        }
    }
    ScenarioOutcome {
        seed: prepared.seed,
        family: prepared.family,
        tuning: is_tuning_family(&prepared.family),
        condition: prepared.condition,
        packs: prepared.packs.clone(),
        flights,
        skipped,
        truth_pack: prepared
            .flights
            .iter()
            .zip(&prepared.truths)
            .map(|((f, _), t)| (f.name.clone(), t.capacity_ah, t.mean_airborne_series_ohm))
            .collect(),
    }
}

/// A scenario prepared as `opts` asks: with `sensors`, without its current column when
/// [`StudyOptions::voltage_only`], without its motor commands unless
/// [`StudyOptions::motor_power`].
fn prepare_for(
    opts: &StudyOptions,
    family: &Family,
    seed: u64,
    sensors: SensorErrors,
) -> Result<PreparedScenario, EvalError> {
    prepare_scenario_with(family, seed, sensors).map(|p| {
        let p = if opts.voltage_only {
            p.without_current()
        } else {
            p
        };
        if opts.motor_power {
            p
        } else {
            p.without_motors()
        }
    })
}

/// The oracle budget on a study's seeds: every scenario is prepared once per sensor choice the
/// `oracles` need and replayed with each (without its current column with
/// [`StudyOptions::voltage_only`]; the pack history is not carried); one [`Study`] per oracle,
/// in the order given.
pub fn study_oracles(
    opts: &StudyOptions,
    oracles: &[Oracle],
    progress: &(dyn Fn() + Sync),
) -> Vec<Study> {
    type Row = (u64, Family, Result<ScenarioOutcome, String>);
    let seeds: Vec<u64> = opts.seeds.clone().collect();
    let threads = opts.threads.max(1);
    let mut results: Vec<Vec<Row>> = vec![Vec::new(); oracles.len()];
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let seeds = &seeds;
                scope.spawn(move || {
                    let mut out: Vec<Vec<Row>> = vec![Vec::new(); oracles.len()];
                    for &s in seeds.iter().skip(t).step_by(threads) {
                        let fam = family_of(s, &opts.families);
                        for sensors in [SensorErrors::Drawn, SensorErrors::Ideal] {
                            let mine: Vec<usize> = (0..oracles.len())
                                .filter(|&k| oracles[k].sensor_errors() == sensors)
                                .collect();
                            if mine.is_empty() {
                                continue;
                            }
                            let prepared = prepare_for(opts, &fam, s, sensors);
                            for k in mine {
                                let r = match &prepared {
                                    Ok(p) => {
                                        Ok(replay_scenario_with_oracle(p, &opts.config, oracles[k]))
                                    }
                                    Err(e) => Err(e.to_string()),
                                };
                                out[k].push((s, fam, r));
                            }
                        }
                        progress();
                    }
                    out
                })
            })
            .collect();
        for h in handles {
            if let Ok(v) = h.join() {
                for (k, rows) in v.into_iter().enumerate() {
                    results[k].extend(rows);
                }
            }
        }
    });
    results.into_iter().map(study_of).collect()
}

/// Runs one scenario (see the crate docs): [`prepare_scenario`] then [`replay_scenario`].
pub fn run_scenario(
    family: &Family,
    seed: u64,
    config: &OnlineConfig,
) -> Result<ScenarioOutcome, EvalError> {
    Ok(replay_scenario(&prepare_scenario(family, seed)?, config))
}

/// How a study runs.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Seeds (scenario `s` flies family `families[s mod len]`).
    pub seeds: Range<u64>,
    /// World families.
    pub families: Vec<Family>,
    /// Worker threads.
    pub threads: usize,
    /// The online estimator's configuration.
    pub config: OnlineConfig,
    /// Carry each pack's measured capacity to its next flight ([`replay_scenario_with_history`]).
    pub pack_history: bool,
    /// Replay the held-out flights without their current column ([`PreparedScenario::without_current`]):
    /// a family that logs its current flown as a voltage-only log, an ablation for telling what
    /// the current is worth (and for studying voltage-only logs on the tuning families).
    pub voltage_only: bool,
    /// Give the online estimator the rotors' power read from the held-out flights' motor
    /// commands (families whose logs carry them) through the motor map fitted on the world's
    /// rig sweeps, as `replay --motor-power` does; without it the commands are removed
    /// ([`PreparedScenario::without_motors`]).
    pub motor_power: bool,
}

/// A group of scenarios and its replay summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// Name (`held out`, `tuning`, `condition cold`, `chemistry lfp`, …).
    pub name: String,
    /// `tuning`, `held out` or `mixed`.
    pub split: &'static str,
    /// Scenarios in it.
    pub scenarios: usize,
    /// The replay of its flights.
    pub replay: Replay,
}

/// The targets of issue 14 on a group.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Targets {
    /// Median absolute error of the online estimator at 50 %, % of duration.
    pub online_median_50_pct: Option<f64>,
    /// The better baseline's (lower median at 50 %), with its name.
    pub best_baseline_median_50_pct: Option<f64>,
    /// Which baseline that is.
    pub best_baseline: Option<&'static str>,
    /// One-sigma coverage.
    pub coverage: Option<f64>,
    /// ≤ 3 % at 50 %.
    pub within_3_pct: bool,
    /// ≤ half the better baseline's.
    pub half_best_baseline: bool,
    /// Coverage in 60–75 %.
    pub coverage_in_band: bool,
}

impl Targets {
    /// The targets evaluated on a replay summary.
    pub fn of(summary: &replay::Summary) -> Self {
        let half = summary
            .checkpoints
            .iter()
            .find(|c| (c.fraction - 0.5).abs() < 1e-9);
        let online = half.and_then(|c| c.median_abs_error_pct[replay::methods::ONLINE]);
        let best = half.and_then(|c| {
            replay::METHODS[1..]
                .iter()
                .filter_map(|m| c.median_abs_error_pct[m].map(|v| (*m, v)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        });
        let coverage = summary.coverage.one_sigma;
        Self {
            online_median_50_pct: online,
            best_baseline_median_50_pct: best.map(|b| b.1),
            best_baseline: best.map(|b| b.0),
            coverage,
            within_3_pct: online.is_some_and(|v| v <= 3.0),
            half_best_baseline: match (online, best) {
                (Some(o), Some((_, b))) => o <= 0.5 * b,
                _ => false,
            },
            coverage_in_band: coverage.is_some_and(|c| (0.6..=0.75).contains(&c)),
        }
    }

    /// All three met.
    pub fn all_met(&self) -> bool {
        self.within_3_pct && self.half_best_baseline && self.coverage_in_band
    }
}

/// A study's results.
#[derive(Debug, Clone)]
pub struct Study {
    /// Every scenario (in seed order), or its error.
    pub scenarios: Vec<(u64, Family, Result<ScenarioOutcome, String>)>,
    /// Roll-ups: held out, tuning, per condition, chemistry, logging, robot.
    pub groups: Vec<Group>,
}

/// The world family of a seed.
pub fn family_of(seed: u64, families: &[Family]) -> Family {
    families[(seed % families.len() as u64) as usize]
}

/// Runs a study on `threads` workers, calling `progress` after each scenario.
pub fn study(opts: &StudyOptions, progress: &(dyn Fn() + Sync)) -> Study {
    study_with(opts, SensorErrors::Drawn, progress)
}

/// [`study`] on worlds whose sensors carry the constant errors `sensors` says
/// ([`prepare_scenario_with`]); [`SensorErrors::Drawn`] is [`study`].
pub fn study_with(
    opts: &StudyOptions,
    sensors: SensorErrors,
    progress: &(dyn Fn() + Sync),
) -> Study {
    let seeds: Vec<u64> = opts.seeds.clone().collect();
    let threads = opts.threads.max(1);
    let mut results: Vec<(u64, Family, Result<ScenarioOutcome, String>)> = Vec::new();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let seeds = &seeds;
                scope.spawn(move || {
                    let mut out = Vec::new();
                    for &s in seeds.iter().skip(t).step_by(threads) {
                        let fam = family_of(s, &opts.families);
                        let r = prepare_for(opts, &fam, s, sensors)
                            .map(|p| {
                                replay_scenario_with_history(&p, &opts.config, opts.pack_history)
                            })
                            .map_err(|e| e.to_string());
                        out.push((s, fam, r));
                        progress();
                    }
                    out
                })
            })
            .collect();
        for h in handles {
            if let Ok(v) = h.join() {
                results.extend(v);
            }
        }
    });
    study_of(results)
}

/// A study from scenario results (sorted by seed here) and their roll-ups.
pub fn study_of(mut results: Vec<(u64, Family, Result<ScenarioOutcome, String>)>) -> Study {
    results.sort_by_key(|r| r.0);
    let groups = roll_up(&results);
    Study {
        scenarios: results,
        groups,
    }
}

fn roll_up(results: &[(u64, Family, Result<ScenarioOutcome, String>)]) -> Vec<Group> {
    let ok: Vec<&ScenarioOutcome> = results.iter().filter_map(|r| r.2.as_ref().ok()).collect();
    let mut groups = Vec::new();
    let mut add = |name: String, pick: &dyn Fn(&ScenarioOutcome) -> bool| {
        let mine: Vec<&&ScenarioOutcome> = ok.iter().filter(|s| pick(s)).collect();
        if mine.is_empty() {
            return;
        }
        let split = if mine.iter().all(|s| !s.tuning) {
            "held out"
        } else if mine.iter().all(|s| s.tuning) {
            "tuning"
        } else {
            "mixed"
        };
        let flights = mine
            .iter()
            .flat_map(|s| s.flights.iter().cloned())
            .collect();
        let skipped = mine
            .iter()
            .flat_map(|s| s.skipped.iter().cloned())
            .collect();
        groups.push(Group {
            name,
            split,
            scenarios: mine.len(),
            replay: Replay::new(flights, skipped),
        });
    };
    add("all held-out families".into(), &|s| !s.tuning);
    add("all tuning families".into(), &|s| s.tuning);
    for c in Condition::NAMES {
        add(format!("held out, {c}"), &|s| {
            !s.tuning && s.condition.name() == c
        });
    }
    for c in Condition::NAMES {
        add(format!("tuning, {c}"), &|s| {
            s.tuning && s.condition.name() == c
        });
    }
    for c in Chemistry::ALL {
        add(format!("chemistry {}", c.name()), &|s| {
            s.family.chemistry == c
        });
    }
    for l in Logging::ALL {
        add(format!("logging {}", l.name()), &|s| s.family.logging == l);
    }
    for r in [RobotVariant::Paper, RobotVariant::Varied] {
        add(format!("robot {}", r.name()), &|s| s.family.robot == r);
    }
    groups
}

/// The study's table: per group, median absolute error per method at 50 % (and 25/75/90 % for
/// the online estimator), coverage, and whether the targets are met.
pub fn table(study: &Study) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let failed = study.scenarios.iter().filter(|r| r.2.is_err()).count();
    let _ = writeln!(
        s,
        "median |error| of the remaining time at 50 % of the flight, % of its duration (flights); online also at 25/75/90 %; coverage of the online one-sigma band"
    );
    let _ = writeln!(
        s,
        "{:<30} {:<8} {:>5} {:>7} {:>14} {:>14} {:>14} {:>14} {:>20} {:>9}  targets",
        "group",
        "split",
        "runs",
        "flights",
        "online",
        "px4",
        "coulomb",
        "static",
        "online 25/75/90",
        "coverage"
    );
    for g in &study.groups {
        let sm = &g.replay.summary;
        let at = |f: f64, m: &str| {
            sm.checkpoints
                .iter()
                .find(|c| (c.fraction - f).abs() < 1e-9)
                .and_then(|c| c.median_abs_error_pct[m].map(|v| (v, c.flights[m])))
        };
        let cell = |m: &str| at(0.5, m).map_or("-".to_owned(), |(v, n)| format!("{v:.2} ({n})"));
        let others = [0.25, 0.75, 0.9]
            .iter()
            .map(|f| at(*f, "online").map_or("-".to_owned(), |(v, _)| format!("{v:.1}")))
            .collect::<Vec<_>>()
            .join("/");
        let t = Targets::of(sm);
        let _ = writeln!(
            s,
            "{:<30} {:<8} {:>5} {:>7} {:>14} {:>14} {:>14} {:>14} {:>20} {:>9}  {}{}{}",
            g.name,
            g.split,
            g.scenarios,
            sm.scored_flights,
            cell("online"),
            cell("px4"),
            cell("coulomb"),
            cell("static_model"),
            others,
            sm.coverage
                .one_sigma
                .map_or("-".to_owned(), |c| format!("{:.0} %", c * 100.0)),
            if t.within_3_pct {
                "≤3 % yes"
            } else {
                "≤3 % NO"
            },
            if t.half_best_baseline {
                ", ≤½ base yes"
            } else {
                ", ≤½ base NO"
            },
            if t.coverage_in_band {
                ", cov yes"
            } else {
                ", cov NO"
            },
        );
    }
    if failed > 0 {
        let _ = writeln!(s, "\n{failed} scenario(s) failed:");
        for (seed, fam, r) in &study.scenarios {
            if let Err(e) = r {
                let _ = writeln!(s, "  seed {seed} {}: {e}", fam.name());
            }
        }
    }
    s
}

/// One line per replayed flight (what `sweep` prints with `SWEEP_FLIGHTS=1`): seed, family,
/// condition, flight, the online error at 50 % and its one-sigma band (% of the flight), the
/// static model's error, and the filter's state of charge and curve offset at the cut-off.
pub fn flight_lines(study: &Study) -> String {
    flight_lines_with(study, false)
}

/// [`flight_lines`]; with `truth`, also each flight's pack as flight-sim flew it (true capacity
/// and mean airborne series resistance, [`ScenarioOutcome::truth_pack`]) beside the filter's
/// at the end, and the truth beside each pack-history reading: for the analysis only.
pub fn flight_lines_with(study: &Study, truth: bool) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for (seed, fam, r) in &study.scenarios {
        let Ok(o) = r else { continue };
        for f in &o.flights {
            let c = &f.checkpoints[1];
            let d = f.end_s - f.takeoff_s;
            let state = |n: &str| {
                f.final_state
                    .iter()
                    .find(|x| x.0 == n)
                    .map_or(f64::NAN, |x| x.1)
            };
            let _ = writeln!(
                s,
                "{seed:4} {:24} {:18} {:16} err50 {:+6.1} % sigma {:5.1} % static {:+6.1} % | at the cut-off: soc {:.3} offset {:+.3} V",
                fam.name(),
                o.condition.name(),
                f.name,
                c.predicted_remaining_s
                    .map_or(f64::NAN, |p| (p - c.true_remaining_s) / d * 100.0),
                c.sigma_s.map_or(f64::NAN, |s| s / d * 100.0),
                c.baselines[2].map_or(f64::NAN, |p| (p - c.true_remaining_s) / d * 100.0),
                state("soc"),
                state("curve_offset_v"),
            );
            if truth {
                let t = o.truth_pack.iter().find(|t| t.0 == f.name);
                let _ = writeln!(
                    s,
                    "     truth: R {:.4} ohm (estimator {:.4}), capacity {:.3} Ah (estimator {:.3})",
                    t.map_or(f64::NAN, |t| t.2),
                    state("series_resistance_ohm"),
                    t.map_or(f64::NAN, |t| t.1),
                    state("usable_capacity_ah"),
                );
            }
            if let Some(r) = &f.capacity_reading {
                let carried = f
                    .capacity_carried
                    .as_ref()
                    .map_or_else(|| "-".to_owned(), |c| format!("{:.3}", c.1));
                let true_ah = o
                    .truth_pack
                    .iter()
                    .find(|t| t.0 == f.name)
                    .map(|t| t.1)
                    .filter(|_| truth);
                let reading = match r {
                    Ok(r) => format!(
                        "{:.3} (estimator's {:.3}, soc {:.3} -> {:.3}{})",
                        r.factor(),
                        state("usable_capacity_ah") / r.model_capacity_ah,
                        r.start_soc,
                        r.end_soc,
                        true_ah.map_or(String::new(), |t| format!(
                            ", truth {:.3}",
                            t / r.model_capacity_ah
                        ))
                    ),
                    Err(e) => format!("none: {}", e.chars().take(60).collect::<String>()),
                };
                let _ = writeln!(s, "     pack history: carried {carried}, reading {reading}");
            }
        }
    }
    s
}

/// The study as JSON: per scenario (seed, family, tuning, condition, packs, flights' checkpoint
/// errors, skipped), per group (summary and targets).
pub fn to_json(study: &Study) -> serde_json::Value {
    let scenarios: Vec<serde_json::Value> = study
        .scenarios
        .iter()
        .map(|(seed, fam, r)| match r {
            Ok(o) => serde_json::json!({
                "seed": seed,
                "family": fam.name(),
                "tuning": o.tuning,
                "condition": o.condition,
                "packs": o.packs,
                "replay": Replay::new(o.flights.clone(), o.skipped.clone()).to_json(),
            }),
            Err(e) => serde_json::json!({"seed": seed, "family": fam.name(), "error": e}),
        })
        .collect();
    let groups: Vec<serde_json::Value> = study
        .groups
        .iter()
        .map(|g| {
            serde_json::json!({
                "name": g.name,
                "split": g.split,
                "scenarios": g.scenarios,
                "summary": g.replay.summary,
                "targets": Targets::of(&g.replay.summary),
            })
        })
        .collect();
    serde_json::json!({"scenarios": scenarios, "groups": groups})
}

/// The online estimator's defaults with overrides `key=value,key=value` (the field names of
/// [`OnlineConfig`]'s numbers; `thrust_limit_end` and `zero_current` are 0 for off, 1 for on): what the
/// `sweep` and `trace` examples read from `SWEEP_CFG`.
pub fn config_from_spec(spec: &str) -> Result<OnlineConfig, String> {
    let mut c = OnlineConfig::default();
    for kv in spec.split(',').filter(|s| !s.trim().is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| format!("{kv:?} is not key=value"))?;
        let (k, v) = (k.trim(), v.trim());
        let v: f64 = v
            .parse()
            .map_err(|_| format!("{k}: {v:?} is not a number"))?;
        if k == "thrust_limit_end" {
            c.thrust_limit_end = v != 0.0;
            continue;
        }
        if k == "zero_current" {
            c.zero_current = v != 0.0;
            continue;
        }
        let slot = match k {
            "voltage_sigma_v" => &mut c.voltage_sigma_v,
            "current_sigma_a" => &mut c.current_sigma_a,
            "power_sigma_fraction" => &mut c.power_sigma_fraction,
            "motor_power_sigma_fraction" => &mut c.motor_power_sigma_fraction,
            "initial_soc_sigma" => &mut c.initial_soc_sigma,
            "resistance_scale_sigma" => &mut c.resistance_scale_sigma,
            "extra_resistance_sigma_ohm" => &mut c.extra_resistance_sigma_ohm,
            "resync_resistance_sigma_ohm" => &mut c.resync_resistance_sigma_ohm,
            "capacity_scale_sigma" => &mut c.capacity_scale_sigma,
            "extra_power_sigma_fraction" => &mut c.extra_power_sigma_fraction,
            "resistance_drift_per_sqrt_s" => &mut c.resistance_drift_per_sqrt_s,
            "capacity_drift_per_sqrt_s" => &mut c.capacity_drift_per_sqrt_s,
            "extra_power_drift_fraction_per_sqrt_s" => &mut c.extra_power_drift_fraction_per_sqrt_s,
            "voltage_bias_sigma_cell_v" => &mut c.voltage_bias_sigma_cell_v,
            "voltage_bias_drift_cell_v_per_sqrt_s" => &mut c.voltage_bias_drift_cell_v_per_sqrt_s,
            "prediction_model_sigma_fraction" => &mut c.prediction_model_sigma_fraction,
            "end_soc_sigma" => &mut c.end_soc_sigma,
            "end_soc_sigma_motor_cut" => &mut c.end_soc_sigma_motor_cut,
            "charged_start_soc_sigma" => &mut c.charged_start_soc_sigma,
            "current_scale_sigma" => &mut c.current_scale_sigma,
            "current_offset_sigma_a" => &mut c.current_offset_sigma_a,
            "cutoff_curve_sigma_cell_v" => &mut c.cutoff_curve_sigma_cell_v,
            "voltage_scale_sigma" => &mut c.voltage_scale_sigma,
            "capacity_fade_sigma" => &mut c.capacity_fade_sigma,
            "extra_power_thrust_share" => &mut c.extra_power_thrust_share,
            "extra_power_thrust_share_sigma" => &mut c.extra_power_thrust_share_sigma,
            "thrust_headroom_fraction" => &mut c.thrust_headroom_fraction,
            "input_average_s" => &mut c.input_average_s,
            other => return Err(format!("unknown key {other:?}")),
        };
        *slot = v;
    }
    Ok(c)
}
