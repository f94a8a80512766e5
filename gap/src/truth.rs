//! The truth simulator: flights of a physical robot whose effects are switched on with known
//! magnitudes, for testing the diagnosis blind.
//!
//! It is deliberately richer than the diagnosis model, so that a diagnosis cannot succeed by
//! inverting its own equations: rotor power comes from the `sim` crate's motor–propeller physics
//! (not from the fitted rig curve), the LiPo has a series resistance *and* an RC pair, each pack's
//! open-circuit curve and capacity scatter a little, resistance and capacity follow the ambient
//! temperature, control activity makes the power fluctuate,
//! and voltage, current and altitude are logged with sensor noise at 1 Hz. The flight ends at the
//! 9.0 V landing cut-off (3.0 V per cell) or when the rotors can no longer hold the robot up.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use sim::physics::{Propulsion, Supply};

use crate::flight::{FlightInfo, FlightRecord, Phase};
use crate::lipo::{current_for_power, mean_ocv_cell_v, ocv_cell_v};
use crate::model::{CEILING_DECAY_M, Effect, G, RIG_AIR_DENSITY_KG_M3};

/// An effect the truth can have that the diagnosis library does not contain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OutOfLibrary {
    /// Motor and ESC heat up: rotor power grows linearly with time airborne (fraction per
    /// 10 minutes).
    MotorHeating,
    /// A pack of a different chemistry (high-voltage LiPo): the open-circuit curve sits higher
    /// by the magnitude, V per cell, and the pack holds correspondingly more energy.
    HighVoltageCells,
}

impl OutOfLibrary {
    /// Name as in reports.
    pub fn name(self) -> &'static str {
        match self {
            OutOfLibrary::MotorHeating => "motor_heating",
            OutOfLibrary::HighVoltageCells => "high_voltage_cells",
        }
    }
}

/// What the truth contains besides the model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "effect")]
pub enum TruthEffect {
    /// Nothing beyond the model (and the simulator's own realism).
    None,
    /// A library effect with its magnitude (in the effect's parameter unit).
    Library(Effect, f64),
    /// An effect outside the library with its magnitude.
    OutOfLibrary(OutOfLibrary, f64),
}

/// A mission segment of the truth simulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Leg {
    /// On the ground, motors off, s.
    Ground(f64),
    /// Climb to an altitude at a speed (m, m/s).
    Climb(f64, f64),
    /// Descend to an altitude at a speed (m, m/s).
    Descend(f64, f64),
    /// Hover for a time at the current altitude, s.
    Hover(f64),
    /// Attached to the ceiling, motors off, s.
    Attached(f64),
    /// Hover until the cut-off.
    HoverToCutoff,
}

/// One flight to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightPlan {
    /// Name.
    pub name: String,
    /// The legs.
    pub legs: Vec<Leg>,
    /// What the robot carries (the metadata a pilot would write down).
    pub info: FlightInfo,
}

/// The truth of a generated set: kept apart from the flights; the diagnosis never reads it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// The effect switched on.
    pub effect: TruthEffect,
    /// Endurance of each flight with and without the effect, s (`name`, with, without).
    pub endurance_s: Vec<(String, f64, f64)>,
}

impl Truth {
    /// Mean relative change of endurance the effect causes, % (negative = shorter flights).
    pub fn endurance_impact_pct(&self) -> f64 {
        let n = self.endurance_s.len().max(1) as f64;
        self.endurance_s
            .iter()
            .map(|(_, with, without)| (with - without) / without * 100.0)
            .sum::<f64>()
            / n
    }
}

/// The simulated robot: rig preset physics and rotor count.
#[derive(Debug, Clone)]
pub struct Robot {
    propulsion: Propulsion,
    /// Rotors.
    pub rotor_count: u8,
    /// Nominal pack resistance per cell, Ω.
    pub cell_resistance_ohm: f64,
    /// RC-pair resistance per cell, Ω.
    pub rc_resistance_ohm: f64,
    /// RC-pair time constant, s.
    pub rc_tau_s: f64,
    /// Control fluctuation of rotor power (1 σ fraction) and its correlation time, s.
    pub control_noise: (f64, f64),
    /// Sensor noise (1 σ): voltage V, current A, altitude m.
    pub sensor_noise: (f64, f64, f64),
    /// Highest thrust of one rotor at 0, 0.1, 0.2, … V, g.
    max_thrust_table_g: Vec<f64>,
}

/// Voltage step of the maximum-thrust table, V.
const TABLE_STEP_V: f64 = 0.1;

impl Robot {
    /// The paper's platform on the `sim` crate's `paper` preset.
    pub fn paper() -> Self {
        let p = sim::presets::paper();
        let propulsion = Propulsion::new(p.motor, p.prop, p.esc);
        let max_thrust_table_g = (0..=170)
            .map(|k| {
                let supply = Supply {
                    voltage_v: f64::from(k) * TABLE_STEP_V,
                    resistance_ohm: 0.0,
                };
                propulsion.steady_state(p.esc.max_us, supply).thrust_g
            })
            .collect();
        Self {
            propulsion,
            max_thrust_table_g,
            rotor_count: 4,
            // Series and RC-pair resistance add up to the nominal DC resistance the model assumes;
            // the RC pair's 20 s relaxation after every load step is what the model leaves out.
            cell_resistance_ohm: 0.6 * crate::model::NOMINAL_CELL_RESISTANCE_OHM,
            rc_resistance_ohm: 0.4 * crate::model::NOMINAL_CELL_RESISTANCE_OHM,
            rc_tau_s: 20.0,
            control_noise: (0.03, 2.0),
            sensor_noise: (0.01, 0.05, 0.01),
        }
    }

    /// Electrical power one rotor draws giving `thrust_g` at `volts`, and whether it can.
    fn rotor_power_w(&self, thrust_g: f64, volts: f64) -> Option<f64> {
        let supply = Supply {
            voltage_v: volts,
            resistance_ohm: 0.0,
        };
        let esc = self.propulsion.esc;
        let full = self.propulsion.steady_state(esc.max_us, supply);
        if full.thrust_g < thrust_g {
            return None;
        }
        let (mut lo, mut hi) = (esc.min_us, esc.max_us);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if self.propulsion.steady_state(mid, supply).thrust_g < thrust_g {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(self.propulsion.steady_state(hi, supply).power_w())
    }

    /// A rig sweep of one rotor at `volts`: thrust every `step_g` from `step_g` up to the
    /// highest thrust, and the electrical power at each, W (what `hoverbench characterise`
    /// measures, without the sensor noise).
    pub fn rig_sweep(&self, volts: f64, step_g: f64) -> (Vec<f64>, Vec<f64>) {
        let max = self.max_thrust_g(volts);
        let mut thrust = Vec::new();
        let mut power = Vec::new();
        let mut t = step_g;
        while t <= max {
            if let Some(p) = self.rotor_power_w(t, volts) {
                thrust.push(t);
                power.push(p);
            }
            t += step_g;
        }
        (thrust, power)
    }

    /// Highest thrust one rotor gives at `volts` (interpolated in a table), g.
    fn max_thrust_g(&self, volts: f64) -> f64 {
        let x = (volts / TABLE_STEP_V).max(0.0);
        let last = self.max_thrust_table_g.len() - 1;
        let i = (x.floor() as usize).min(last - 1);
        let f = (x - i as f64).min(1.0);
        self.max_thrust_table_g[i] * (1.0 - f) + self.max_thrust_table_g[i + 1] * f
    }
}

/// Per-pack scatter: real packs differ a little from the table and their rating.
#[derive(Debug, Clone, Copy)]
struct PackScatter {
    ocv_offset_v: f64,
    capacity_factor: f64,
    resistance_factor: f64,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    // Box–Muller.
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Simulates one flight. Returns the logged flight and the true endurance, s.
pub fn simulate(
    robot: &Robot,
    plan: &FlightPlan,
    effect: TruthEffect,
    seed: u64,
) -> (FlightRecord, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let info = &plan.info;
    let cells = f64::from(info.cells.max(1));
    let scatter = PackScatter {
        ocv_offset_v: 0.003 * normal(&mut rng),
        capacity_factor: 1.0 + 0.004 * normal(&mut rng),
        resistance_factor: 1.0 + 0.1 * normal(&mut rng),
    };
    let lib = |e: Effect| match effect {
        TruthEffect::Library(x, m) if x == e => m,
        _ => 0.0,
    };
    let ool = |e: OutOfLibrary| match effect {
        TruthEffect::OutOfLibrary(x, m) if x == e => m,
        _ => 0.0,
    };
    let hv = ool(OutOfLibrary::HighVoltageCells);
    let ocv = |soc: f64| ocv_cell_v(soc) + scatter.ocv_offset_v + hv;
    let mean_ocv = mean_ocv_cell_v() + scatter.ocv_offset_v;
    // The rated energy is what the pack holds; a high-voltage pack holds more at equal charge.
    // Resistance and usable capacity follow the ambient temperature.
    let (r_temp, c_temp) = crate::lipo::temperature_factors(info.ambient_temperature_c);
    let capacity_ah = info.battery_energy_wh / (cells * mean_ocv)
        * scatter.capacity_factor
        * c_temp
        * (1.0 - lib(Effect::CapacityFade));
    let r0 = cells * robot.cell_resistance_ohm * scatter.resistance_factor * r_temp
        + lib(Effect::InternalResistance);
    let r1 = cells * robot.rc_resistance_ohm * r_temp;
    let peukert = lib(Effect::Peukert);
    let n = f64::from(robot.rotor_count);
    let m_t = info.total_mass_kg();
    let hover_thrust_g = m_t * 1000.0 / n;
    let rho_factor = info.air_density_kg_m3.map_or(1.0, |rho| {
        (RIG_AIR_DENSITY_KG_M3 / rho).powf(lib(Effect::AirDensity))
    });
    let nominal_v = 12.5_f64.min(cells * 4.2);
    let base_rotor_w = robot
        .rotor_power_w(hover_thrust_g, nominal_v)
        .unwrap_or(f64::NAN)
        * n;
    let ceiling = info.ceiling_height_m;

    let dt = 1.0;
    let mut t = 0.0;
    let mut z = 0.0_f64;
    let mut soc = 1.0_f64;
    let mut v_rc = 0.0_f64;
    let mut airborne_s = 0.0;
    let mut ctrl = 0.0_f64;
    let (ctrl_sigma, ctrl_tau) = robot.control_noise;
    let a = (-dt / ctrl_tau).exp();
    let (sv, si, sz) = robot.sensor_noise;
    let mut rec = FlightRecord {
        name: plan.name.clone(),
        time_s: Vec::new(),
        voltage_v: Vec::new(),
        current_a: Some(Vec::new()),
        phase: Vec::new(),
        altitude_m: Some(Vec::new()),
        info: info.clone(),
    };
    let mut last_v = cells * ocv(soc);
    let mut ended = false;
    for leg in &plan.legs {
        let mut leg_t = 0.0;
        loop {
            // What this second of the leg is.
            let (phase, vz, done) = match *leg {
                Leg::Ground(d) => (Phase::Ground, 0.0, leg_t >= d),
                Leg::Attached(d) => (Phase::Attached, 0.0, leg_t >= d),
                Leg::Hover(d) => (Phase::Hover, 0.0, leg_t >= d),
                Leg::HoverToCutoff => (Phase::Hover, 0.0, false),
                Leg::Climb(to, v) => (Phase::Climb, v, z >= to - 1e-9),
                Leg::Descend(to, v) => (Phase::Descend, -v, z <= to + 1e-9),
            };
            if done {
                break;
            }
            // Power demand.
            let airborne = crate::flight::rotors_on(phase);
            ctrl = a * ctrl + (1.0 - a * a).sqrt() * ctrl_sigma * normal(&mut rng);
            let w = if airborne {
                let mut rotor = base_rotor_w * (1.0 + lib(Effect::ControlOverhead)) * rho_factor;
                rotor *= 1.0 + ctrl;
                rotor *= 1.0 + ool(OutOfLibrary::MotorHeating) * airborne_s / 600.0;
                if let Some(h) = ceiling {
                    let gap = (h - z).max(0.0);
                    rotor *= 1.0 - lib(Effect::CeilingEffect) * (-gap / CEILING_DECAY_M).exp();
                }
                rotor + info.idle_power_w() + m_t * G * vz.max(0.0) * lib(Effect::ClimbPower)
            } else if phase == Phase::Attached {
                info.idle_power_w() + lib(Effect::AttachedPower)
            } else {
                info.idle_power_w()
            };
            // Battery.
            let e = cells * ocv(soc) - v_rc;
            let Some(i) = current_for_power(e, r0, w) else {
                ended = true;
                break;
            };
            let v = e - i * r0;
            let can_hold = !airborne || robot.max_thrust_g(v) >= hover_thrust_g;
            if v < info.cutoff_voltage_v || soc <= 0.0 || !can_hold {
                ended = true;
                break;
            }
            last_v = v;
            rec.time_s.push(t);
            rec.voltage_v.push(v + sv * normal(&mut rng));
            if let Some(c) = rec.current_a.as_mut() {
                c.push(i + si * normal(&mut rng));
            }
            rec.phase.push(phase);
            if let Some(alt) = rec.altitude_m.as_mut() {
                alt.push(z + sz * normal(&mut rng));
            }
            let eff = if peukert > 0.0 {
                i * (i / capacity_ah).powf(peukert)
            } else {
                i
            };
            soc -= eff * dt / 3600.0 / capacity_ah;
            v_rc += (i * r1 - v_rc) * (1.0 - (-dt / robot.rc_tau_s).exp());
            z = (z + vz * dt).max(0.0);
            if let (Leg::Climb(to, _), true) = (*leg, vz > 0.0) {
                z = z.min(to);
            }
            if let Leg::Descend(to, _) = *leg {
                z = z.max(to);
            }
            if airborne {
                airborne_s += dt;
            }
            t += dt;
            leg_t += dt;
        }
        if ended {
            break;
        }
    }
    let _ = last_v;
    rec.info.ended_at_cutoff = ended;
    (rec, t)
}

/// Simulates a flight with and without the effect (same noise), for the truth record.
pub fn simulate_with_truth(
    robot: &Robot,
    plan: &FlightPlan,
    effect: TruthEffect,
    seed: u64,
) -> (FlightRecord, (f64, f64)) {
    let (rec, with) = simulate(robot, plan, effect, seed);
    let (_, without) = simulate(robot, plan, TruthEffect::None, seed);
    (rec, (with, without))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(battery_mass_kg: f64, energy_density: f64) -> FlightInfo {
        FlightInfo {
            structure_mass_kg: 0.431,
            battery_mass_kg,
            battery_energy_wh: battery_mass_kg * energy_density,
            cells: 3,
            payload_mass_kg: 0.0,
            payload_power_w: 0.0,
            avionics_power_w: 2.44,
            battery_id: None,
            battery_cycles: None,
            ambient_temperature_c: None,
            air_density_kg_m3: None,
            cutoff_voltage_v: 9.0,
            ended_at_cutoff: false,
            ceiling_height_m: Some(2.5),
        }
    }

    #[test]
    fn hover_to_cutoff_lasts_about_the_paper_endurance() {
        let plan = FlightPlan {
            name: "a".into(),
            legs: vec![Leg::Ground(5.0), Leg::Climb(1.0, 0.5), Leg::HoverToCutoff],
            info: info(0.144, 164.0),
        };
        let (rec, t) = simulate(&Robot::paper(), &plan, TruthEffect::None, 1);
        assert!(rec.info.ended_at_cutoff);
        // The paper's t_E for Battery-A is 13.83 min; the truth battery loses a little to its
        // resistance and cuts off at 9.0 V under load.
        let min = t / 60.0;
        assert!((13.0..14.2).contains(&min), "{min} min");
        assert_eq!(rec.time_s.len(), rec.voltage_v.len());
    }

    #[test]
    fn effects_change_endurance_in_the_right_direction() {
        let plan = FlightPlan {
            name: "a".into(),
            legs: vec![Leg::Ground(5.0), Leg::Climb(1.0, 0.5), Leg::HoverToCutoff],
            info: info(0.144, 164.0),
        };
        let r = Robot::paper();
        let base = simulate(&r, &plan, TruthEffect::None, 3).1;
        for (e, m) in [
            (Effect::InternalResistance, 0.05),
            (Effect::CapacityFade, 0.1),
            (Effect::Peukert, 0.08),
            (Effect::ControlOverhead, 0.1),
        ] {
            let t = simulate(&r, &plan, TruthEffect::Library(e, m), 3).1;
            assert!(t < base * 0.99, "{e:?}: {t} vs {base}");
        }
        let t = simulate(
            &r,
            &plan,
            TruthEffect::OutOfLibrary(OutOfLibrary::HighVoltageCells, 0.1),
            3,
        )
        .1;
        assert!(t > base, "HV cells hold more energy");
    }
}
