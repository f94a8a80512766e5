//! The truth simulator of the gap study: flights of a hovering robot from this crate's own
//! battery, propulsion and sensor physics, rendered as the files a pilot would bring — a
//! flight-log CSV (`time_s,voltage_v[,current_a],phase,altitude_m[,motor1_us,…]`) and its TOML
//! metadata sidecar — so that whatever reads them (the `gap` diagnosis, through `flightlog`) sees only
//! what it would see in the field.
//!
//! It depends on neither the diagnosis nor the rig simulator and shares no table, constant or
//! equation with them:
//! - batteries ([`ocv`]): open-circuit curves per chemistry (LiPo, LiHV, Li-ion NMC and NCA from
//!   measured electrode potentials, LiFePO4 from a Nernst-type formula), per-pack scatter, series
//!   resistance with Arrhenius self-heating, two RC pairs, hysteresis;
//! - propulsion ([`robot`]): momentum theory with a figure of merit and a stall term, calibrated
//!   to the paper's rig curve, thrust limit against voltage and air density (a motor's resistive
//!   drop at full throttle), lead losses; a robot lands when it has lacked thrust for about two
//!   seconds (a low-passed demand), not on one control spike; the physics steps at 0.1 s
//!   whatever the log rate; the motors' ESC commands from the drive each rotor's speed needs
//!   (back-EMF plus a winding drop, the flight's own propellers, trims and winding
//!   temperature), and the rig's two sweeps with their commands ([`Robot::rig_sweeps`]);
//! - logging ([`Logging`]): 1–50 Hz, offset and scale errors of the voltage and current
//!   sensors, noise, quantisation, dropped samples and bursts, clock jitter, current optional,
//!   the motor commands logged by flight controllers (not by a lab logger)
//!   ([`simulate_with`] and [`SensorErrors`] fly a flight with calibrated sensors instead, for an
//!   ablation; [`simulate`] is unchanged);
//! - effects a scenario withholds ([`EffectKind`]): each of the diagnosis's library effects in
//!   this crate's own physical form (a ceiling effect after Sanchez-Cuevas et al., climb power
//!   from momentum theory, airframe download, …), and two outside it.
//!
//! Worlds come in families ([`Family`]: chemistry × logging × robot).
//!
//! ```
//! use flight_sim::{EffectKind, Family, Withheld, generate};
//!
//! let family = Family::parse("nmc/fc-10hz/paper").unwrap();
//! let effect = Withheld { kind: EffectKind::CapacityFade, magnitude: 0.1 };
//! let set = generate(&family, &effect, 7);
//! assert_eq!((set.train.len(), set.heldout.len()), (8, 4));
//! assert!(set.train[0].csv.starts_with("time_s,voltage_v,current_a,phase,altitude_m,motor1_us,"));
//! assert!(set.train[0].toml.contains("cells = 3"));
//! // A faded pack flies shorter.
//! assert!(set.truth.endurance_impact_pct() < -5.0);
//! ```

pub mod mission;
pub mod ocv;
pub mod robot;
mod simulate;
mod world;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

pub use mission::{FlightPlan, HALL_CEILING_M, Leg, plans};
pub use robot::{Propulsion, RigStep, RigSweeps, Robot};
pub use simulate::{
    FlightEnd, FlightTruth, PackTruth, SensorErrors, SimFlight, pack_truth, simulate,
    simulate_with, simulate_with_truth,
};
pub use world::{Chemistry, EffectKind, Family, Logging, NoFamily, RobotVariant, Withheld};

/// A pack as its label says.
#[derive(Debug, Clone, PartialEq)]
pub struct PackSpec {
    /// `Battery-A` …
    pub id: String,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Rated energy, Wh.
    pub energy_wh: f64,
}

/// The `k`-th (0 or 1) pack of a chemistry's world.
pub fn pack_spec(chem: Chemistry, k: usize) -> PackSpec {
    let (id, m, e) = chem.packs()[k.min(1)];
    PackSpec {
        id: format!("{}-{id}", chem.name()),
        mass_kg: m,
        energy_wh: m * e,
    }
}

/// A standard normal draw (Box–Muller).
pub(crate) fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The truth of a generated set: what was switched on and what it did. Never part of the
/// flight files.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// The world family.
    pub family: String,
    /// The seed.
    pub seed: u64,
    /// The effect and its magnitude.
    pub effect: Withheld,
    /// Unit of the magnitude.
    pub unit: &'static str,
    /// Endurance of each flight with and without the effect, s: (name, with, without).
    pub endurance_s: Vec<(String, f64, f64)>,
}

impl Truth {
    /// Mean relative change of endurance the effect causes, % (negative: shorter flights).
    pub fn endurance_impact_pct(&self) -> f64 {
        let n = self.endurance_s.len().max(1) as f64;
        self.endurance_s
            .iter()
            .map(|(_, with, without)| (with - without) / without * 100.0)
            .sum::<f64>()
            / n
    }
}

/// A rig characterisation of the robot: one rotor swept in 10 g steps at 12.5 V.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RigSweep {
    /// Supply voltage, V.
    pub voltage_v: f64,
    /// Thrust, g.
    pub thrust_g: Vec<f64>,
    /// Electrical power, W.
    pub power_w: Vec<f64>,
    /// Rotors on the robot.
    pub rotor_count: u8,
}

impl RigSweep {
    /// As a CSV `thrust_g,power_w`.
    pub fn csv(&self) -> String {
        let mut s = String::from("thrust_g,power_w\n");
        for (t, p) in self.thrust_g.iter().zip(&self.power_w) {
            s.push_str(&format!("{t},{p:.4}\n"));
        }
        s
    }
}

/// The flights of a scenario as files, the robot's rig sweep, and the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedSet {
    /// Training flights.
    pub train: Vec<SimFlight>,
    /// Held-out flights.
    pub heldout: Vec<SimFlight>,
    /// The robot on the rig.
    pub rig: RigSweep,
    /// The hall's ceiling above the take-off point, m (site knowledge a pilot has).
    pub ceiling_height_m: f64,
    /// The truth (keep it away from the diagnosis).
    pub truth: Truth,
}

/// Simulates a scenario: the family's robot, its training and held-out flights with the
/// effect, each flight also without it (same seed) for the truth's endurance impact.
pub fn generate(family: &Family, effect: &Withheld, seed: u64) -> GeneratedSet {
    let robot = Robot::of(family.robot, seed);
    let (tp, hp) = plans(family, seed);
    let mut endurance_s = Vec::new();
    let mut run = |ps: &[FlightPlan], salt: u64| -> Vec<SimFlight> {
        ps.iter()
            .enumerate()
            .map(|(k, p)| {
                let s = flight_seed(seed, salt, k);
                let with = simulate(family, &robot, p, effect, s);
                let without = match effect.kind {
                    EffectKind::None => with.endurance_s,
                    // The counterfactual of a draining payload is the same take-off payload
                    // that stays on board.
                    EffectKind::DrainingPayload => {
                        let mut kept = p.clone();
                        kept.payload_mass_kg += effect.magnitude;
                        simulate::run(
                            family,
                            &robot,
                            &kept,
                            &Withheld::NONE,
                            s,
                            false,
                            SensorErrors::Drawn,
                        )
                        .0
                        .endurance_s
                    }
                    _ => {
                        simulate::run(
                            family,
                            &robot,
                            p,
                            &Withheld::NONE,
                            s,
                            false,
                            SensorErrors::Drawn,
                        )
                        .0
                        .endurance_s
                    }
                };
                endurance_s.push((p.name.clone(), with.endurance_s, without));
                with
            })
            .collect()
    };
    let train = run(&tp, TRAIN_SALT);
    let heldout = run(&hp, HELDOUT_SALT);
    let (thrust_g, power_w) = robot.rig_sweep(10.0, seed);
    GeneratedSet {
        train,
        heldout,
        rig: RigSweep {
            voltage_v: robot::RIG_VOLTAGE_V,
            thrust_g,
            power_w,
            rotor_count: robot.rotor_count,
        },
        ceiling_height_m: HALL_CEILING_M,
        truth: Truth {
            family: family.name(),
            seed,
            effect: *effect,
            unit: effect.kind.unit(),
            endurance_s,
        },
    }
}

/// Every flight of `family`'s training and held-out plans for `seeds`, with no withheld effect
/// and calibrated sensors ([`SensorErrors::Ideal`]), beside its truth: how the simulator's own
/// flights end, for its examples and tests (flight `k` of seed `s` flies seed `1000·s + k`).
pub fn clean_flights(
    family: &Family,
    seeds: std::ops::Range<u64>,
) -> Vec<(SimFlight, FlightTruth)> {
    let mut out = Vec::new();
    for seed in seeds {
        let robot = Robot::of(family.robot, seed);
        let (tp, hp) = plans(family, seed);
        for (k, p) in tp.iter().chain(&hp).enumerate() {
            out.push(simulate_with_truth(
                family,
                &robot,
                p,
                &Withheld::NONE,
                seed * 1000 + k as u64,
                SensorErrors::Ideal,
            ));
        }
    }
    out
}

/// Salts of the training and held-out flights' seeds.
const TRAIN_SALT: u64 = 0;
const HELDOUT_SALT: u64 = 100;

/// The seed of the `k`-th flight of a set (`salt`: training or held out) of scenario `seed`.
fn flight_seed(seed: u64, salt: u64, k: usize) -> u64 {
    seed.wrapping_mul(1_000_003).wrapping_add(salt + k as u64)
}

/// The packs [`generate`] flies for a scenario, training flights then held-out ones, in the
/// order of the set's flights, as the truth knows them ([`PackTruth`]: the curve, the capacity
/// without any withheld fade, the impedance). For oracle experiments of a study only; never
/// part of the files.
pub fn pack_truths(family: &Family, seed: u64) -> (Vec<PackTruth>, Vec<PackTruth>) {
    let (tp, hp) = plans(family, seed);
    let of = |ps: &[FlightPlan], salt: u64| -> Vec<PackTruth> {
        ps.iter()
            .enumerate()
            .map(|(k, p)| pack_truth(family, p, flight_seed(seed, salt, k)))
            .collect()
    };
    (of(&tp, TRAIN_SALT), of(&hp, HELDOUT_SALT))
}

/// Draws a scenario's effect from its seed: `none`, each library-named effect and each outside
/// effect about equally often, magnitudes log-uniform over [`EffectKind::range`].
pub fn draw_effect(seed: u64) -> Withheld {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6566_6665_6374);
    let kind = EffectKind::ALL[rng.random_range(0..EffectKind::ALL.len())];
    if kind == EffectKind::None {
        return Withheld::NONE;
    }
    let (lo, hi) = kind.range();
    let x: f64 = rng.random();
    Withheld {
        kind,
        magnitude: (lo.ln() + x * (hi.ln() - lo.ln())).exp(),
    }
}

/// Errors of this crate's parsers.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum SimError {
    /// An unknown family name.
    #[error("unknown world family {0:?}: use chemistry/logging/robot, e.g. lipo/fc-10hz/paper")]
    Family(String),
    /// An unknown effect name.
    #[error("unknown effect {0:?}: use one of {1}")]
    Effect(String, String),
    /// A magnitude that is not a non-negative number.
    #[error("effect magnitude {0:?} is not a non-negative number")]
    Magnitude(String),
}

/// Parses `NAME` or `NAME=MAGNITUDE` (the typical magnitude when none is given).
pub fn parse_effect(s: &str) -> Result<Withheld, SimError> {
    let (name, mag) = match s.split_once('=') {
        Some((n, m)) => (n.trim(), Some(m.trim())),
        None => (s.trim(), None),
    };
    let kind = EffectKind::parse(name).ok_or_else(|| {
        SimError::Effect(
            name.to_owned(),
            EffectKind::ALL
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", "),
        )
    })?;
    let magnitude = match mag {
        Some(m) => m
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| SimError::Magnitude(m.to_owned()))?,
        None => kind.typical(),
    };
    Ok(Withheld { kind, magnitude })
}

/// Parses a family name.
pub fn parse_family(s: &str) -> Result<Family, SimError> {
    Family::parse(s).ok_or_else(|| SimError::Family(s.to_owned()))
}
