//! One flight: pack, propulsion and sensors stepped through a mission, logged as the field logs.

use std::fmt::Write as _;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::mission::{FlightPlan, HALL_CEILING_M, Leg, LoggedPhase};
use crate::ocv::{OcvCurve, OcvScatter};
use crate::robot::{GRAVITY_M_S2, Propulsion, RIG_AIR_DENSITY_KG_M3, Robot};
use crate::world::{Chemistry, EffectKind, Family, Withheld};
use crate::{PackSpec, normal};

/// Arrhenius temperature of the cells' resistance, K.
const RESISTANCE_ACTIVATION_K: f64 = 2800.0;
/// Specific heat of a pack, J/(kg·K).
const PACK_HEAT_J_KG_K: f64 = 1000.0;
/// Temperature coefficient of copper, 1/K.
const COPPER_PER_K: f64 = 0.003_93;
/// Share of a rotor's power lost in the windings (at the rig's temperature).
const COPPER_SHARE: f64 = 0.2;
/// Distance from the rotor plane to the top of the frame, m.
const ROTOR_BELOW_TOP_M: f64 = 0.03;
/// `K₂` of the ceiling-effect formula, in rotor radii.
const CEILING_K2_RADII: f64 = 0.6;
/// Integration step of the flight's physics, s (whatever the log rate).
const STEP_S: f64 = 0.1;
/// Time constant over which the autopilot must lack thrust before the robot can no longer hold
/// its altitude, s: a control spike that saturates the rotors for a moment costs a few
/// centimetres that the next moment wins back; a deficit that lasts this long is a sink rate.
const THRUST_LIMIT_TAU_S: f64 = 2.0;

/// A simulated flight: its log as files and its truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SimFlight {
    /// Name (file stem).
    pub name: String,
    /// `NAME.csv` in the flight-log format (`time_s,voltage_v[,current_a],phase,altitude_m`,
    /// then `motor1_us,…` when the logging profile logs the motors' ESC commands).
    pub csv: String,
    /// `NAME.toml`, the metadata sidecar.
    pub toml: String,
    /// True endurance: time from the start of the log to the landing, s.
    pub endurance_s: f64,
    /// Whether the flight ended at the autopilot's cut-off — its voltage reading or the rotors'
    /// thrust limit — or with exhausted cells (else the mission ended first;
    /// [`FlightTruth::end`] says which).
    pub ended_at_cutoff: bool,
    /// Logged samples.
    pub samples: usize,
}

impl SimFlight {
    /// The last logged voltage, V (`None` for a log without samples).
    pub fn last_voltage_v(&self) -> Option<f64> {
        self.csv
            .lines()
            .skip(1)
            .last()
            .and_then(|l| l.split(',').nth(1))
            .and_then(|v| v.parse().ok())
    }
}

/// How a flight ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FlightEnd {
    /// The mission ended first: the robot landed with charge to spare.
    Landed,
    /// The autopilot's filtered voltage reading fell below its cut-off.
    Cutoff,
    /// The rotors could no longer carry the robot at the pack's voltage.
    ThrustLimit,
    /// The pack's electrodes ran out of charge ([`OcvCurve::exhausted_soc`]), or it could no
    /// longer deliver the power asked of it.
    Exhausted,
}

/// What one flight really was, beside its log: the pack it flew (curve, capacity, impedance,
/// start), what the pack saw in the air (temperature, resistance, power) and where it ended.
/// For a study harness's oracle ablation only ([`simulate_with_truth`]); never written into the
/// flight's files, so nothing that reads them can see it.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightTruth {
    /// The pack's open-circuit curve of one cell (on its own state-of-charge axis: 0 rated
    /// empty, 1 full, over [`Self::capacity_ah`]; below 0 down to
    /// [`OcvCurve::exhausted_soc`]).
    pub ocv: OcvCurve,
    /// Cells in series.
    pub cells: u8,
    /// Charge from full to empty of the pack flown (its fade included), Ah.
    pub capacity_ah: f64,
    /// State of charge at the first sample.
    pub start_soc: f64,
    /// State of charge when the flight ended (at the cut-off: the charge the pack still held;
    /// below 0 when it was discharged past its rated empty).
    pub end_soc: f64,
    /// How the flight ended.
    pub end: FlightEnd,
    /// Series resistance of one cell at 25 °C, Ω.
    pub r0_cell_ohm_25c: f64,
    /// The cell's two RC pairs at 25 °C: (Ω, s).
    pub rc_cell_25c: [(f64, f64); 2],
    /// Resistance outside the cells (a worn connector), Ω.
    pub extra_resistance_ohm: f64,
    /// Hysteresis half-width of a cell, V.
    pub hysteresis_cell_v: f64,
    /// Mean cell temperature while airborne, °C.
    pub mean_airborne_cell_c: f64,
    /// Mean series resistance of the pack while airborne (cells at their temperature, plus
    /// [`Self::extra_resistance_ohm`]), Ω.
    pub mean_airborne_series_ohm: f64,
    /// Mean electrical power the pack delivered while airborne (rotors, leads, avionics and
    /// payload), W.
    pub mean_airborne_power_w: f64,
    /// Mean electrical power the pack delivered in level hover (the logged `hover` phase), W.
    pub mean_hover_power_w: f64,
}

/// The pack of one flight: its cells' curve, capacity and impedance.
struct Pack {
    ocv: OcvCurve,
    cells: f64,
    capacity_ah: f64,
    r0_ohm: f64,
    rc: [(f64, f64); 2],
    hysteresis_v: f64,
    heat_capacity_j_k: f64,
}

impl Pack {
    fn new(family: &Family, spec: &PackSpec, rng: &mut ChaCha8Rng, fade: f64) -> Self {
        let chem = family.chemistry;
        let ocv = draw_ocv(chem, rng);
        let cells = f64::from(chem.cells());
        // The rated energy is the maker's; the pack holds within a few percent of it.
        let built_ah =
            spec.energy_wh / (cells * ocv.mean_v()) * (1.0 + 0.025 * normal(rng)).clamp(0.9, 1.1);
        // The impedance scales with the cells' size (their capacity as built); a withheld
        // capacity fade takes charge away, not conductance (a worn pack's resistance is the
        // internal-resistance effect's).
        let imp = chem.impedance();
        let spread = (1.0 + 0.12 * normal(rng)).clamp(0.6, 1.5);
        let capacity_ah = built_ah * (1.0 - fade);
        Self {
            r0_ohm: imp.r0_ohm_ah / built_ah * spread,
            rc: [
                (imp.rc[0].0 / built_ah * spread, imp.rc[0].1),
                (imp.rc[1].0 / built_ah * spread, imp.rc[1].1),
            ],
            hysteresis_v: imp.hysteresis_v,
            heat_capacity_j_k: spec.mass_kg * PACK_HEAT_J_KG_K,
            ocv,
            cells,
            capacity_ah,
        }
    }
}

/// One pack's open-circuit curve: its chemistry's curve with a drawn [`OcvScatter`]. A draw the
/// electrodes cannot reach (1 of 10⁵ NCA draws, none of 10⁵ of each other chemistry:
/// `cargo run --release -p flight-sim --example pack_scatter 100000`) is drawn again, so every
/// pack reads its own full and empty voltages.
pub(crate) fn draw_ocv(chem: Chemistry, rng: &mut ChaCha8Rng) -> OcvCurve {
    loop {
        if let Ok(c) = OcvCurve::try_new(chem, OcvScatter::draw(rng)) {
            return c;
        }
    }
}

/// What the pack of one flight truly is: its cells' open-circuit curve, its capacity before any
/// withheld fade, and its impedance at 25 °C. Never part of the flight files; for oracle
/// experiments of a study (how much of a diagnosis's error is the battery it had to learn).
#[derive(Debug, Clone, PartialEq)]
pub struct PackTruth {
    /// The pack's own open-circuit curve per cell (its chemistry's curve with its scatter).
    pub ocv: OcvCurve,
    /// Cells in series.
    pub cells: u8,
    /// Capacity, Ah, without a withheld capacity fade.
    pub capacity_ah: f64,
    /// Series resistance of the pack at 25 °C, Ω.
    pub series_resistance_ohm: f64,
    /// The pack's two RC pairs: (resistance Ω, time constant s).
    pub rc: [(f64, f64); 2],
}

/// The pack that [`simulate`] flies for `plan` with `seed` (the same draws), as the truth knows
/// it.
pub fn pack_truth(family: &Family, plan: &FlightPlan, seed: u64) -> PackTruth {
    let mut pack_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7061_636b);
    let spec = crate::pack_spec(family.chemistry, plan.pack);
    let p = Pack::new(family, &spec, &mut pack_rng, 0.0);
    PackTruth {
        cells: family.chemistry.cells(),
        capacity_ah: p.capacity_ah,
        series_resistance_ohm: p.r0_ohm * p.cells,
        rc: [
            (p.rc[0].0 * p.cells, p.rc[0].1),
            (p.rc[1].0 * p.cells, p.rc[1].1),
        ],
        ocv: p.ocv,
    }
}

/// The motors of one flight as their ESC commands tell them: how each rotor's share of the
/// thrust and its propeller differ from the rig's, and how warm the windings run. Drawn from
/// the flight's own stream, so nothing else of the flight moves with them.
struct Motors {
    rng: ChaCha8Rng,
    /// Each rotor's share of the total thrust over the mean (the centre of mass is never
    /// exactly central): mean 1.
    trim: Vec<f64>,
    /// Each propeller's thrust at equal speed over the rig's propeller (same model, another
    /// piece).
    prop_factor: Vec<f64>,
    /// The windings' resistance in flight over the rig's (they run warmer in the air than
    /// through a sweep).
    drop_factor: f64,
    /// Each rotor's drive this step: duty (0 with the motors stopped).
    duty: Vec<f64>,
}

impl Motors {
    fn draw(rotors: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6d6f_7472);
        let mut trim: Vec<f64> = (0..rotors)
            .map(|_| 1.0 + 0.03 * normal(&mut rng).clamp(-2.5, 2.5))
            .collect();
        let mean = trim.iter().sum::<f64>() / rotors.max(1) as f64;
        for t in &mut trim {
            *t /= mean;
        }
        let prop_factor = (0..rotors)
            .map(|_| 1.0 + 0.02 * normal(&mut rng).clamp(-2.5, 2.5))
            .collect();
        let drop_factor = 1.0 + 0.12 * rng.random::<f64>();
        Self {
            rng,
            trim,
            prop_factor,
            drop_factor,
            duty: vec![0.0; rotors],
        }
    }

    /// Each rotor's duty to carry its share of a mean `speed_thrust_g` per rotor (the thrust a
    /// static rotor at the same speed would give) from an ESC supply of `esc_v`.
    fn set_drives(
        &mut self,
        prop: &Propulsion,
        speed_thrust_g: f64,
        rho: f64,
        drop: f64,
        esc_v: f64,
    ) {
        for (k, d) in self.duty.iter_mut().enumerate() {
            let t = speed_thrust_g * self.trim[k] / self.prop_factor[k];
            *d = (prop.drive_for_thrust_v(t, rho, drop) / esc_v.max(1.0)).min(1.0);
        }
    }

    fn stop(&mut self) {
        self.duty.fill(0.0);
    }

    /// Appends each motor's command, µs, as a flight controller logs it: the attitude loop's
    /// rotor-to-rotor corrections on top (2 % of the drive, white at the log's rate); a stopped
    /// motor at the bottom of the output range, 1000 µs.
    fn log(&mut self, prop: &Propulsion, csv: &mut String) {
        for k in 0..self.duty.len() {
            let d = self.duty[k];
            let us = if d > 0.0 {
                let d = (d * (1.0 + 0.02 * normal(&mut self.rng))).clamp(0.0, 1.0);
                prop.command_us(d).round()
            } else {
                1000.0
            };
            let _ = write!(csv, ",{us:.0}");
        }
    }
}

/// The sensors of one flight: constant errors drawn once.
struct Sensors {
    v_scale: f64,
    v_offset: f64,
    i_scale: f64,
    i_offset: f64,
}

/// Which of a flight's constant sensor errors (the scale and offset of its voltage and current
/// sensors, drawn once per flight from the logging profile) the log carries. Noise,
/// quantisation, dropped samples and jitter are kept either way. The errors are drawn in every
/// case, so the pack, the noise and everything else of a seed stay the same: an ablation
/// compares like with like.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorErrors {
    /// As the logging profile draws them (the default: what every study flies).
    #[default]
    Drawn,
    /// A calibrated voltage sensor (scale 1, offset 0); the current sensor's errors drawn.
    IdealVoltage,
    /// A calibrated current sensor (scale 1, offset 0); the voltage sensor's errors drawn.
    IdealCurrent,
    /// Both sensors calibrated.
    Ideal,
}

impl SensorErrors {
    /// Every choice, default first.
    pub const ALL: [SensorErrors; 4] = [
        SensorErrors::Drawn,
        SensorErrors::IdealVoltage,
        SensorErrors::IdealCurrent,
        SensorErrors::Ideal,
    ];

    /// Short name (`drawn`, `ideal-voltage`, `ideal-current`, `ideal`).
    pub fn name(self) -> &'static str {
        match self {
            SensorErrors::Drawn => "drawn",
            SensorErrors::IdealVoltage => "ideal-voltage",
            SensorErrors::IdealCurrent => "ideal-current",
            SensorErrors::Ideal => "ideal",
        }
    }

    /// The choice of a short name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.name() == s.trim())
    }

    fn voltage(self) -> bool {
        matches!(self, SensorErrors::Drawn | SensorErrors::IdealCurrent)
    }

    fn current(self) -> bool {
        matches!(self, SensorErrors::Drawn | SensorErrors::IdealVoltage)
    }
}

/// Simulates one flight of `plan` in `family` with `effect`. Same seed, same pack, sensors and
/// noise whatever the effect, so runs with and without it compare.
pub fn simulate(
    family: &Family,
    robot: &Robot,
    plan: &FlightPlan,
    effect: &Withheld,
    seed: u64,
) -> SimFlight {
    run(family, robot, plan, effect, seed, true, SensorErrors::Drawn).0
}

/// [`simulate`] with a choice of the sensors' constant errors ([`SensorErrors::Drawn`]: the
/// same flight as [`simulate`], byte for byte).
pub fn simulate_with(
    family: &Family,
    robot: &Robot,
    plan: &FlightPlan,
    effect: &Withheld,
    seed: u64,
    sensors: SensorErrors,
) -> SimFlight {
    run(family, robot, plan, effect, seed, true, sensors).0
}

/// [`simulate_with`] and the flight's truth beside it (the same flight, byte for byte): what a
/// study's oracle ablation hands the estimator one piece at a time.
pub fn simulate_with_truth(
    family: &Family,
    robot: &Robot,
    plan: &FlightPlan,
    effect: &Withheld,
    seed: u64,
    sensors: SensorErrors,
) -> (SimFlight, FlightTruth) {
    run(family, robot, plan, effect, seed, true, sensors)
}

/// Simulates a flight; `log: false` skips the log (only the endurance is wanted).
pub(crate) fn run(
    family: &Family,
    robot: &Robot,
    plan: &FlightPlan,
    effect: &Withheld,
    seed: u64,
    log: bool,
    errors: SensorErrors,
) -> (SimFlight, FlightTruth) {
    let mut pack_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7061_636b);
    let mut noise_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6e6f_6973);
    let mut ctrl_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6374_726c);
    let chem = family.chemistry;
    let spec = crate::pack_spec(chem, plan.pack);
    let pack = Pack::new(
        family,
        &spec,
        &mut pack_rng,
        effect.of(EffectKind::CapacityFade),
    );
    let sensor = family.logging.sensors();
    let mut s = Sensors {
        v_scale: 1.0 + sensor.v_scale_sd * normal(&mut pack_rng),
        v_offset: sensor.v_offset_sd * normal(&mut pack_rng),
        i_scale: 1.0 + sensor.i_scale_sd * normal(&mut pack_rng),
        i_offset: sensor.i_offset_sd * normal(&mut pack_rng),
    };
    if !errors.voltage() {
        (s.v_scale, s.v_offset) = (1.0, 0.0);
    }
    if !errors.current() {
        (s.i_scale, s.i_offset) = (1.0, 0.0);
    }
    let start_soc = 1.0 - 0.012 * pack_rng.random::<f64>();
    let ambient_k = plan.ambient_c + 273.15;
    let logged_ambient_c = plan.ambient_c + 0.5 * normal(&mut pack_rng);
    // The hall's air: near the rig's, unless the site is thinner.
    let rho = RIG_AIR_DENSITY_KG_M3
        * (1.0 - 0.008 * normal(&mut pack_rng).clamp(-2.0, 2.0))
        * (1.0 - effect.of(EffectKind::AirDensity) * plan.density_draw);
    let logged_rho = rho * (1.0 + 0.003 * normal(&mut pack_rng));

    let prop = &robot.propulsion;
    let n_rot = f64::from(robot.rotor_count);
    let water0 = effect.of(EffectKind::DrainingPayload);
    let extra_r = effect.of(EffectKind::InternalResistance);
    let peukert = effect.of(EffectKind::Peukert);
    let download = effect.of(EffectKind::ControlOverhead);
    let hold_a = effect.of(EffectKind::AttachedPower);
    let inv_k1 = effect.of(EffectKind::CeilingEffect);
    let climb_gain = effect.of(EffectKind::ClimbPower);
    let heating_k = effect.of(EffectKind::MotorHeating);
    let cutoff_v = f64::from(chem.cells()) * chem.cutoff_cell_v();
    let idle_w = robot.avionics_power_w + plan.payload_power_w;

    // Integration step: the same for every log rate, so a flight's physics does not depend
    // on how often it is logged; each log tick samples the state of the step it falls in (with
    // its own noise).
    let log_dt = 1.0 / sensor.rate_hz;
    let dt = STEP_S;
    let mut tick = 0u64;
    let mut last_kept_s = 0.0_f64;

    let mut csv = String::with_capacity(64 * 4096);
    csv.push_str("time_s,voltage_v");
    if sensor.current {
        csv.push_str(",current_a");
    }
    csv.push_str(",phase,altitude_m");
    let rotors = usize::from(robot.rotor_count);
    if sensor.motors {
        for k in 1..=rotors {
            let _ = write!(csv, ",motor{k}_us");
        }
    }
    csv.push('\n');
    let mut samples = 0usize;
    let mut motors = Motors::draw(rotors, seed);

    let (mut t, mut z, mut soc) = (0.0_f64, 0.0_f64, start_soc);
    let mut v_rc = [0.0_f64; 2];
    let mut hyst = pack.hysteresis_v; // after charging: on the charge branch
    let mut cell_k = ambient_k;
    let mut motor_dk = 0.0_f64;
    let mut water = water0;
    let mut airborne_s = 0.0_f64;
    let mut ctrl = 0.0_f64;
    let (ctrl_sigma, ctrl_tau) = robot.control_noise;
    let a_ctrl = (-dt / ctrl_tau).exp();
    // What relaxes by a fixed share per step (the step is fixed).
    let rc_gain = pack.rc.map(|(_, tau)| 1.0 - (-dt / tau).exp());
    let motor_gain = 1.0 - (-dt / 150.0).exp();
    let mut v_filtered = f64::NAN;
    // The thrust asked of the rotors over what they can give, low-passed over
    // THRUST_LIMIT_TAU_S (0 on the ground).
    let mut demand_filtered = 0.0_f64;
    let mut last_v = pack.cells * pack.ocv.at(soc);
    let mut drop_left = 0usize;
    let mut ended = false;
    let mut end = FlightEnd::Landed;
    // Sums for the truth: airborne time-weighted cell temperature, series resistance, power;
    // hover power.
    let (mut air_k, mut air_r, mut air_w) = (0.0_f64, 0.0_f64, 0.0_f64);
    let (mut hover_s, mut hover_w) = (0.0_f64, 0.0_f64);

    'legs: for leg in &plan.legs {
        let mut leg_t = 0.0;
        loop {
            let (phase, vz, done) = match *leg {
                Leg::Ground(d) => (LoggedPhase::Ground, 0.0, leg_t >= d - 1e-9),
                Leg::Attached(d) => (LoggedPhase::Attached, 0.0, leg_t >= d - 1e-9),
                Leg::Hover(d) => (LoggedPhase::Hover, 0.0, leg_t >= d - 1e-9),
                Leg::HoverToCutoff => (LoggedPhase::Hover, 0.0, false),
                Leg::Climb(to, v) => (LoggedPhase::Climb, v, z >= to - 1e-9),
                Leg::Descend(to, v) => (LoggedPhase::Descend, -v, z <= to + 1e-9),
            };
            if done {
                break;
            }
            let flying = !matches!(phase, LoggedPhase::Ground | LoggedPhase::Attached);
            ctrl =
                a_ctrl * ctrl + (1.0 - a_ctrl * a_ctrl).sqrt() * ctrl_sigma * normal(&mut ctrl_rng);
            let mass = robot.structure_mass_kg + spec.mass_kg + plan.payload_mass_kg + water;
            let mut rotor_w = 0.0;
            let mut demand = 0.0;
            if flying {
                let mut thrust_g = mass * 1000.0 / n_rot * (1.0 + download) * (1.0 + ctrl).max(0.2);
                // Saturated rotors give what they can (at the pack's last voltage), no more.
                let max_g = prop.max_thrust_g(last_v, rho);
                demand = thrust_g / max_g.max(1e-9);
                thrust_g = thrust_g.min(max_g);
                // Ceiling: more thrust at equal rotor speed means less speed, hence less power,
                // at equal thrust: P ∝ (T/f)^1.5.
                let mut aero_thrust_g = thrust_g;
                if inv_k1 > 0.0 {
                    let d = (HALL_CEILING_M - ROTOR_BELOW_TOP_M - z).max(0.0);
                    let x = prop.radius_m / (d + CEILING_K2_RADII * prop.radius_m);
                    let f = 1.0 / (1.0 - (inv_k1 * x * x).min(0.8));
                    aero_thrust_g = thrust_g / f;
                }
                // Ground effect (Cheeseman–Bennett), always: only near the floor.
                if z > 0.05 {
                    let g = (prop.radius_m / (4.0 * z)).powi(2);
                    aero_thrust_g *= 1.0 - g.min(0.5);
                }
                let mut per_rotor = prop.rotor_power_w(aero_thrust_g, rho);
                if heating_k > 0.0 {
                    per_rotor *= 1.0 + COPPER_SHARE * COPPER_PER_K * motor_dk;
                }
                rotor_w = per_rotor * n_rot;
                if climb_gain > 0.0 && vz > 0.0 {
                    // Momentum theory in climb: T·(v_c/2 + √((v_c/2)² + v_h²)) − T·v_h.
                    let vh = prop.induced_velocity_m_s(thrust_g, rho);
                    let tn = thrust_g / 1000.0 * GRAVITY_M_S2 * n_rot;
                    let half = vz / 2.0;
                    rotor_w += climb_gain * tn * (half + (half * half + vh * vh).sqrt() - vh);
                }
                if sensor.motors {
                    // The rotors turn as fast as a static rotor drawing the same power would
                    // (P ∝ T^1.5 at equal speed-law), a warm winding drops more.
                    let speed_thrust_g =
                        aero_thrust_g * (rotor_w / n_rot / per_rotor).powf(2.0 / 3.0);
                    let drop = motors.drop_factor * (1.0 + COPPER_PER_K * motor_dk);
                    let esc_v =
                        last_v - rotor_w / n_rot / last_v.max(1.0) * prop.lead_resistance_ohm;
                    motors.set_drives(prop, speed_thrust_g, rho, drop, esc_v);
                }
            } else {
                motors.stop();
            }
            // Lead losses at the pack's voltage.
            let lead_w = if flying {
                let i_rotor = rotor_w / n_rot / last_v.max(1.0);
                i_rotor * i_rotor * prop.lead_resistance_ohm * n_rot
            } else {
                0.0
            };
            let mut load_w = rotor_w + lead_w + idle_w;
            if phase == LoggedPhase::Attached {
                load_w += hold_a * last_v;
            }
            // Pack: E − I·R = V, V·I = P.
            // Arrhenius factor of the cells' resistances at their temperature.
            let arrhenius = (RESISTANCE_ACTIVATION_K * (1.0 / cell_k - 1.0 / 298.15)).exp();
            let r_cell = pack.r0_ohm * arrhenius;
            let r = pack.cells * r_cell + extra_r;
            let e = pack.cells * (pack.ocv.at(soc) + hyst - v_rc[0] - v_rc[1]);
            let disc = e * e - 4.0 * r * load_w;
            // Past the rated empty (state of charge 0) the cells go on along their curve; only
            // exhausted electrodes end a flight that the autopilot has not landed.
            if disc < 0.0 || soc <= pack.ocv.exhausted_soc() {
                ended = true;
                end = FlightEnd::Exhausted;
                break 'legs;
            }
            let i = (e - disc.sqrt()) / (2.0 * r);
            let v = e - i * r;
            // The autopilot lands on its own (filtered) voltage reading, and when the rotors
            // can no longer carry the robot.
            let v_meas = v * s.v_scale + s.v_offset;
            v_filtered = if v_filtered.is_nan() {
                v_meas
            } else {
                v_filtered + (v_meas - v_filtered) * (dt / 1.0).min(1.0)
            };
            demand_filtered = if flying {
                demand_filtered + (demand - demand_filtered) * (dt / THRUST_LIMIT_TAU_S).min(1.0)
            } else {
                0.0
            };
            if v_filtered < cutoff_v || demand_filtered > 1.0 {
                ended = true;
                end = if v_filtered < cutoff_v {
                    FlightEnd::Cutoff
                } else {
                    FlightEnd::ThrustLimit
                };
                break 'legs;
            }
            last_v = v;
            // Log.
            while log && (tick as f64) * log_dt < t + dt - 1e-9 {
                let tick_s = tick as f64 * log_dt;
                tick += 1;
                let mut keep = true;
                if drop_left > 0 {
                    drop_left -= 1;
                    keep = false;
                } else if noise_rng.random::<f64>() < sensor.burst_p {
                    drop_left = (noise_rng.random_range(1.0..3.0) * sensor.rate_hz) as usize;
                    keep = false;
                } else if noise_rng.random::<f64>() < sensor.drop_p {
                    keep = false;
                }
                // A logger that stalls this long restarts: no hole reaches 4 s.
                if !keep && tick_s - last_kept_s >= 4.0 - log_dt {
                    keep = true;
                    drop_left = 0;
                }
                if keep || samples == 0 {
                    last_kept_s = tick_s;
                    let jitter = (sensor.jitter_frac * normal(&mut noise_rng)).clamp(-0.3, 0.3);
                    let ts = tick_s + jitter * log_dt;
                    let q = sensor.v_quantum;
                    let vq = ((v_meas + sensor.v_noise * normal(&mut noise_rng)) / q).round() * q;
                    let _ = write!(csv, "{ts:.3},{vq:.3}");
                    if sensor.current {
                        let im =
                            i * s.i_scale + s.i_offset + sensor.i_noise * normal(&mut noise_rng);
                        let _ = write!(csv, ",{:.2}", (im * 100.0).round() / 100.0);
                    }
                    let zm = z + sensor.alt_noise * normal(&mut noise_rng);
                    let _ = write!(csv, ",{},{zm:.2}", phase.name());
                    if sensor.motors {
                        motors.log(prop, &mut csv);
                    }
                    csv.push('\n');
                    samples += 1;
                }
            }
            // Advance the state.
            let i_1c = pack.capacity_ah;
            let drawn = if peukert > 0.0 && i > 0.0 {
                i * (i / i_1c).powf(peukert)
            } else {
                i
            };
            soc -= drawn * dt / 3600.0 / pack.capacity_ah;
            for (k, (r1, _)) in pack.rc.iter().enumerate() {
                v_rc[k] += (i * (r1 * arrhenius) - v_rc[k]) * rc_gain[k];
            }
            // Hysteresis relaxes towards the discharge branch with the charge moved.
            let gamma = 40.0;
            let dq = i.abs() * dt / 3600.0 / pack.capacity_ah;
            hyst += (-pack.hysteresis_v * i.signum() - hyst) * (1.0 - (-gamma * dq).exp());
            // Self-heating: I²R in, convection out (prop wash cools in flight).
            let heat_w = i * i * pack.cells * r_cell + i * pack.cells * (v_rc[0] + v_rc[1]);
            let ha = (if flying { 0.9 } else { 0.35 }) * (spec.mass_kg / 0.144).powf(2.0 / 3.0);
            cell_k += (heat_w - ha * (cell_k - ambient_k)) * dt / pack.heat_capacity_j_k;
            if heating_k > 0.0 {
                let target = if flying { heating_k } else { 0.0 };
                motor_dk += (target - motor_dk) * motor_gain;
            }
            if flying && water > 0.0 {
                water = (water - water0 / 300.0 * dt).max(0.0);
            }
            z = (z + vz * dt).max(0.0);
            match *leg {
                Leg::Climb(to, _) => z = z.min(to),
                Leg::Descend(to, _) => z = z.max(to),
                _ => {}
            }
            if flying {
                airborne_s += dt;
                air_k += cell_k * dt;
                air_r += r * dt;
                air_w += load_w * dt;
            }
            if phase == LoggedPhase::Hover {
                hover_s += dt;
                hover_w += load_w * dt;
            }
            t += dt;
            leg_t += dt;
        }
    }
    let logged_payload = plan.payload_mass_kg + water0;
    let mut toml = String::new();
    let _ = writeln!(
        toml,
        "structure_mass_kg = {}",
        robot.logged_structure_mass_kg
    );
    let _ = writeln!(toml, "battery_mass_kg = {}", spec.mass_kg);
    let _ = writeln!(toml, "battery_energy_wh = {}", spec.energy_wh);
    let _ = writeln!(toml, "cells = {}", chem.cells());
    let _ = writeln!(toml, "payload_mass_kg = {logged_payload}");
    let _ = writeln!(toml, "payload_power_w = {}", plan.payload_power_w);
    let _ = writeln!(toml, "avionics_power_w = {}", robot.logged_avionics_power_w);
    let _ = writeln!(toml, "battery_id = \"{}\"", spec.id);
    let _ = writeln!(toml, "battery_cycles = {}", plan.cycles);
    let _ = writeln!(toml, "ambient_temperature_c = {logged_ambient_c:.1}");
    let _ = writeln!(toml, "air_density_kg_m3 = {logged_rho:.4}");
    let _ = writeln!(toml, "cutoff_voltage_v = {cutoff_v}");
    // Site knowledge a pilot writes down: the hall's ceiling above the take-off point.
    let _ = writeln!(toml, "ceiling_height_m = {HALL_CEILING_M:?}");
    let _ = writeln!(
        toml,
        "end = \"{}\"",
        if ended { "cutoff" } else { "landed" }
    );
    let air = airborne_s.max(1e-9);
    let truth = FlightTruth {
        cells: chem.cells(),
        capacity_ah: pack.capacity_ah,
        start_soc,
        end_soc: soc,
        end,
        r0_cell_ohm_25c: pack.r0_ohm,
        rc_cell_25c: pack.rc,
        extra_resistance_ohm: extra_r,
        hysteresis_cell_v: pack.hysteresis_v,
        mean_airborne_cell_c: air_k / air - 273.15,
        mean_airborne_series_ohm: air_r / air,
        mean_airborne_power_w: air_w / air,
        mean_hover_power_w: hover_w / hover_s.max(1e-9),
        ocv: pack.ocv,
    };
    (
        SimFlight {
            name: plan.name.clone(),
            csv,
            toml,
            endurance_s: t,
            ended_at_cutoff: ended,
            samples,
        },
        truth,
    )
}
