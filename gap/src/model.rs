//! The prediction model: the paper's power model (rig curve + eqs. 1–9) driving a battery, plus
//! the library of candidate effects, each a bounded physical extension with one parameter.

use estimator::PowerCurve;
use serde::Serialize;

use crate::battery::{Chemistry, LearnedBattery};
use crate::flight::{FlightRecord, Phase};
use crate::lipo::current_for_power;

/// Standard gravity, m/s².
pub const G: f64 = 9.806_65;
/// Air density the rig curve is taken to be measured at (ISA sea level), kg/m³.
pub const RIG_AIR_DENSITY_KG_M3: f64 = 1.225;
/// Nominal pack resistance per cell of the baseline battery, Ω (PX4's default estimate,
/// `BAT1_R_INTERNAL` auto: 5 mΩ per cell), so that the baseline has a voltage readout at all;
/// also the healthy-pack reference when the chemistry or the size is not known
/// ([`healthy_cell_resistance_ohm`]).
pub const NOMINAL_CELL_RESISTANCE_OHM: f64 = 0.005;
/// Range over which hovering close under the ceiling saves power, in rotor radii... expressed
/// directly in metres for a 200 mm propeller (one radius = 0.1 m): the saving decays as
/// `exp(−gap / CEILING_DECAY_M)`.
pub const CEILING_DECAY_M: f64 = 0.15;

/// A candidate effect: a named, bounded extension of the model with one parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Extra pack resistance, Ω: voltage sag `I·R`, `I²R` loss, earlier cut-off.
    InternalResistance,
    /// Usable energy below nominal: fraction lost.
    CapacityFade,
    /// Rate-dependent capacity: Peukert exponent minus one.
    Peukert,
    /// In-flight rotor power above static rig power at equal thrust: fraction.
    ControlOverhead,
    /// Power while perched differs from avionics + payload: extra watts.
    AttachedPower,
    /// Rotor power ∝ ρ^−a: the exponent `a` (momentum theory: 0.5).
    AirDensity,
    /// Less rotor power hovering close under the ceiling: fraction saved at zero gap.
    CeilingEffect,
    /// Power to climb: `m·g·v_z / η`; the parameter is `1/η` (0 = free climbs).
    ClimbPower,
}

impl Effect {
    /// The whole library.
    pub const ALL: [Effect; 8] = [
        Effect::InternalResistance,
        Effect::CapacityFade,
        Effect::Peukert,
        Effect::ControlOverhead,
        Effect::AttachedPower,
        Effect::AirDensity,
        Effect::CeilingEffect,
        Effect::ClimbPower,
    ];

    /// Name as in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Effect::InternalResistance => "internal_resistance",
            Effect::CapacityFade => "capacity_fade",
            Effect::Peukert => "peukert",
            Effect::ControlOverhead => "control_overhead",
            Effect::AttachedPower => "attached_power",
            Effect::AirDensity => "air_density",
            Effect::CeilingEffect => "ceiling_effect",
            Effect::ClimbPower => "climb_power",
        }
    }

    /// The parameter's name with its unit.
    pub fn parameter_name(self) -> &'static str {
        match self {
            Effect::InternalResistance => "extra_resistance_ohm",
            Effect::CapacityFade => "fade_fraction",
            Effect::Peukert => "peukert_exponent_minus_1",
            Effect::ControlOverhead => "overhead_fraction",
            Effect::AttachedPower => "extra_attached_power_w",
            Effect::AirDensity => "density_exponent",
            Effect::CeilingEffect => "saving_fraction_at_contact",
            Effect::ClimbPower => "inverse_climb_efficiency",
        }
    }

    /// Physically plausible bounds of the parameter; the value that switches the effect off
    /// lies inside.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            // Extra resistance only adds to the nominal: a pack below nominal is no effect.
            Effect::InternalResistance => (0.0, 0.5),
            Effect::CapacityFade => (-0.1, 0.5),
            Effect::Peukert => (0.0, 0.3),
            Effect::ControlOverhead => (-0.2, 0.6),
            Effect::AttachedPower => (-5.0, 30.0),
            Effect::AirDensity => (0.0, 1.5),
            Effect::CeilingEffect => (0.0, 0.6),
            Effect::ClimbPower => (0.0, 5.0),
        }
    }

    /// The parameter value of the baseline (effect off).
    pub fn neutral(self) -> f64 {
        0.0
    }

    /// Whether a set of flights can reveal the effect at all (the data it needs exist).
    pub fn observable(self, flights: &[&FlightRecord]) -> bool {
        let any = |f: &dyn Fn(&FlightRecord) -> bool| flights.iter().any(|fl| f(fl));
        match self {
            Effect::InternalResistance
            | Effect::CapacityFade
            | Effect::ControlOverhead
            | Effect::Peukert => !flights.is_empty(),
            Effect::AttachedPower => any(&|f| f.phase.contains(&Phase::Attached)),
            Effect::AirDensity => {
                // Needs densities that differ from the rig's: otherwise it is control_overhead.
                flights.iter().any(|f| {
                    f.info
                        .air_density_kg_m3
                        .is_some_and(|r| (r - RIG_AIR_DENSITY_KG_M3).abs() > 0.02)
                })
            }
            Effect::CeilingEffect => {
                any(&|f| f.altitude_m.is_some() && ceiling_height_m(f).is_some())
            }
            Effect::ClimbPower => {
                any(&|f| f.altitude_m.is_some() && f.phase.contains(&Phase::Climb))
            }
        }
    }
}

/// The ceiling height of a flight: from its metadata, else the altitude while attached.
pub fn ceiling_height_m(f: &FlightRecord) -> Option<f64> {
    if let Some(h) = f.info.ceiling_height_m {
        return Some(h);
    }
    let z = f.altitude_m.as_ref()?;
    f.phase
        .iter()
        .zip(z)
        .filter(|(p, _)| **p == Phase::Attached)
        .map(|(_, z)| *z)
        .fold(None, |m: Option<f64>, z| Some(m.map_or(z, |m| m.max(z))))
}

/// Parameter values of the effects switched on (absent = neutral).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct EffectParams {
    /// `(effect, value)` pairs.
    pub values: Vec<(Effect, f64)>,
}

impl EffectParams {
    /// The baseline: every effect off.
    pub fn baseline() -> Self {
        Self::default()
    }

    /// The value of `e` (neutral when off).
    pub fn get(&self, e: Effect) -> f64 {
        self.values
            .iter()
            .find(|(x, _)| *x == e)
            .map_or(e.neutral(), |(_, v)| *v)
    }

    /// Sets `e` to `v`.
    pub fn set(&mut self, e: Effect, v: f64) {
        match self.values.iter_mut().find(|(x, _)| *x == e) {
            Some(slot) => slot.1 = v,
            None => self.values.push((e, v)),
        }
    }
}

/// What the model predicts for one flight, on the flight's own (possibly thinned) time base.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// Sample indices of the flight the prediction is evaluated at.
    pub index: Vec<usize>,
    /// Predicted battery voltage at those samples, V (NaN after the predicted cut-off).
    pub voltage_v: Vec<f64>,
    /// Predicted battery current, A.
    pub current_a: Vec<f64>,
    /// Predicted battery power, W.
    pub power_w: Vec<f64>,
    /// Predicted state of charge (0..1).
    pub soc: Vec<f64>,
    /// Predicted endurance: time of the cut-off, s from the start of the log (the last logged
    /// phase is continued past the end of the log to find it).
    pub endurance_s: f64,
}

/// The model: a rig curve for rotor power, the rotor count, and effect parameters.
#[derive(Debug)]
pub struct Model<'a, C> {
    /// Per-rotor thrust → electrical power (the rig characterisation).
    pub curve: &'a C,
    /// Rotors sharing the take-off mass.
    pub rotor_count: u8,
}

impl<C> Clone for Model<'_, C> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<C> Copy for Model<'_, C> {}

impl<C: PowerCurve> Model<'_, C> {
    /// Rotor power hovering the flight's take-off mass at the rig (eq. 4's `p_M`), W. Thrusts
    /// beyond the curve's range are clamped to its end (the rig could not measure more).
    pub fn hover_rotor_power_w(&self, f: &FlightRecord) -> f64 {
        let n = f64::from(self.rotor_count.max(1));
        let (lo, hi) = self.curve.valid_range_g();
        let per_rotor = (f.info.total_mass_kg() * 1000.0 / n).clamp(lo, hi);
        self.curve.power_w(per_rotor).unwrap_or(f64::NAN) * n
    }

    /// Battery power the model draws at every sample of `f` with effects `p`, W (the current
    /// of a flight without a current log is this over the measured voltage).
    pub fn power_series_w(&self, f: &FlightRecord, p: &EffectParams) -> Vec<f64> {
        let rotor_w = self.hover_rotor_power_w(f);
        let vz = if p.get(Effect::ClimbPower) != 0.0 {
            f.vertical_speed_m_s(2.0)
        } else {
            None
        };
        let ceiling = if p.get(Effect::CeilingEffect) != 0.0 {
            ceiling_height_m(f)
        } else {
            None
        };
        let terms = PowerTerms::new(f, p, rotor_w, vz.as_deref(), ceiling);
        (0..f.time_s.len()).map(|i| terms.at(f, i)).collect()
    }

    /// Runs the battery through the flight's phases and predicts voltage, current, state of
    /// charge and the time of the cut-off. `stride` thins the samples evaluated (1 = all).
    ///
    /// `battery` is the baseline's battery: the learned one with the series resistance of
    /// [`baseline_cell_resistance_ohm`] (see [`crate::diagnose::BatterySet`]).
    pub fn predict(
        &self,
        f: &FlightRecord,
        battery: &LearnedBattery,
        p: &EffectParams,
        stride: usize,
    ) -> Prediction {
        let consts = FlightConsts::new(self, f, p.get(Effect::ClimbPower) != 0.0);
        self.predict_with(f, battery, battery.mean_ocv_cell_v(), &consts, p, stride)
    }

    /// [`Self::predict`] with what does not change with `p` computed once: `mean_ocv_cell_v`
    /// is `battery.mean_ocv_cell_v()`, `consts` the flight's [`FlightConsts`] under this model.
    pub(crate) fn predict_with(
        &self,
        f: &FlightRecord,
        battery: &LearnedBattery,
        mean_ocv_cell_v: f64,
        consts: &FlightConsts,
        p: &EffectParams,
        stride: usize,
    ) -> Prediction {
        let cells = f64::from(f.info.cells.max(1));
        let fade = p.get(Effect::CapacityFade);
        // The pack's nominal behaviour with temperature is part of the baseline.
        let (r_temp, c_temp) = crate::lipo::temperature_factors(f.info.ambient_temperature_c);
        let capacity_ah =
            f.info.battery_energy_wh / (cells * mean_ocv_cell_v) * c_temp * (1.0 - fade);
        let r1 = cells * battery.rc_resistance_cell_ohm * r_temp;
        let tau = battery.rc_time_constant_s;
        let r = cells * battery.series_resistance_cell_ohm.max(0.0) * r_temp
            + p.get(Effect::InternalResistance);
        let r = r.max(0.0);
        let peukert = p.get(Effect::Peukert);
        let one_c_a = capacity_ah.max(1e-9);
        let rotor_w = consts.rotor_w;
        let vz = if p.get(Effect::ClimbPower) != 0.0 {
            consts.vz.as_deref()
        } else {
            None
        };
        let ceiling = if p.get(Effect::CeilingEffect) != 0.0 {
            consts.ceiling_m
        } else {
            None
        };
        let stride = stride.max(1);
        let n = f.time_s.len();
        let terms = PowerTerms::new(f, p, rotor_w, vz, ceiling);
        let airborne_a = match f.voltage_v.first() {
            Some(v) if !f.time_s.is_empty() => terms.at(f, 0) / v.max(1e-3),
            _ => 0.0,
        };
        let mut soc = consts.initial_soc(f, battery, r, airborne_a);
        let mut v1 = 0.0;
        let mut out = Prediction {
            index: Vec::with_capacity(n / stride + 2),
            voltage_v: Vec::with_capacity(n / stride + 2),
            current_a: Vec::with_capacity(n / stride + 2),
            power_w: Vec::with_capacity(n / stride + 2),
            soc: Vec::with_capacity(n / stride + 2),
            endurance_s: f64::NAN,
        };
        let cutoff = f.info.cutoff_voltage_v;
        // Electrical state at a power draw and state of charge.
        let state = |w: f64, soc: f64, v1: f64| -> Option<(f64, f64)> {
            let e = cells * battery.ocv_cell_v(soc) - v1;
            let i = current_for_power(e, r, w)?;
            Some((i, e - i * r))
        };
        // The decay over the last step length (steps mostly repeat their length).
        let mut decay: Option<(f64, f64)> = None;
        let mut relax = |v1: f64, i: f64, dt: f64| {
            if r1 > 0.0 && tau > 0.0 {
                let a = match decay {
                    Some((d, a)) if d.to_bits() == dt.to_bits() => a,
                    _ => {
                        let a = (-dt / tau).exp();
                        decay = Some((dt, a));
                        a
                    }
                };
                a * v1 + (1.0 - a) * i * r1
            } else {
                0.0
            }
        };
        // Charge drawn per second at current i (Peukert: effective current I·(I/1C)^(k−1)).
        let drain = |i: f64| {
            let eff = if peukert > 0.0 && i > 0.0 {
                i * (i / one_c_a).powf(peukert)
            } else {
                i
            };
            eff / 3600.0 / capacity_ah
        };
        let mut k = 0;
        while k < n {
            let next = (k + stride).min(n);
            let w = terms.at(f, k);
            let st = state(w, soc, v1);
            let (i, v) = match st {
                Some(s) if s.1 >= cutoff && soc > 0.0 => s,
                _ => {
                    out.endurance_s = f.time_s[k] - f.time_s[0];
                    break;
                }
            };
            out.index.push(k);
            out.voltage_v.push(v);
            out.current_a.push(i);
            out.power_w.push(w);
            out.soc.push(soc);
            let dt = if next < n {
                f.time_s[next] - f.time_s[k]
            } else {
                0.0
            };
            // Midpoint step: the charge over [k, next) at the power of sample k.
            let mid = soc - 0.5 * drain(i) * dt;
            let i_mid = state(w, mid, v1).map_or(i, |s| s.0);
            soc -= drain(i_mid) * dt;
            v1 = relax(v1, i_mid, dt);
            k = next;
        }
        if out.endurance_s.is_nan() {
            // The log ended first: continue its last phase until the cut-off.
            let last = n.saturating_sub(1);
            let w = terms.at(f, last);
            let mut t = f.time_s[last] - f.time_s[0];
            let dt = 1.0;
            let limit = t + 48.0 * 3600.0;
            loop {
                match state(w, soc, v1) {
                    Some((i, v)) if v >= cutoff && soc > 0.0 && t < limit => {
                        soc -= drain(i) * dt;
                        v1 = relax(v1, i, dt);
                        t += dt;
                    }
                    _ => break,
                }
            }
            out.endurance_s = t;
        }
        out
    }
}

/// The healthy-pack reference: the highest series resistance per cell a healthy pack of
/// `chemistry` and `rated_capacity_ah` has ([`Chemistry::healthy_resistance`],
/// [`crate::battery::HealthyResistance::upper_cell_ohm`]), Ω. A measured curve
/// ([`Chemistry::Measured`]) does not say the chemistry, and a fit without a rated capacity
/// does not say the size: both get the nominal ([`NOMINAL_CELL_RESISTANCE_OHM`]). The
/// diagnosis names `internal_resistance` only above it
/// ([`crate::diagnose::healthy_resistance`]).
pub fn healthy_cell_resistance_ohm(chemistry: Chemistry, rated_capacity_ah: f64) -> f64 {
    chemistry
        .healthy_resistance()
        .and_then(|h| h.upper_cell_ohm(rated_capacity_ah))
        .unwrap_or(NOMINAL_CELL_RESISTANCE_OHM)
}

/// The series resistance per cell the baseline uses. With logged current: the learned one up
/// to the nominal ([`NOMINAL_CELL_RESISTANCE_OHM`]), and resistance above it is left to the
/// effect search (`internal_resistance`, its parameter the extra over the baseline's), which
/// fits it to the flights' endurance and energy rather than to their voltage. Whether that
/// extra is an effect or the resistance a healthy pack of the chemistry and size has is decided
/// after the search ([`crate::diagnose::healthy_resistance`]): holding the baseline at the
/// healthy reference instead (the learned resistance up to it) made 16 of 40 tuning-family
/// predictions worse by more than 0.25 pp (issue 9, session 11), as the search can then no
/// longer go below the learned resistance. Without current (the current is the power model's),
/// the resistance and the curve's level cannot be told apart, so the learned resistance is
/// taken whole: `internal_resistance` then needs logged current.
pub fn baseline_cell_resistance_ohm(battery: &LearnedBattery, current_logged: bool) -> f64 {
    if current_logged {
        battery
            .series_resistance_cell_ohm
            .clamp(0.0, NOMINAL_CELL_RESISTANCE_OHM)
    } else {
        battery.series_resistance_cell_ohm.max(0.0)
    }
}

impl FlightRecord {
    /// State of charge when the log starts, on `battery`'s curve, from the voltage of the first
    /// samples before the rotors start, corrected for the sag of the avionics' current through
    /// the pack resistance `resistance_ohm`. A log that starts airborne is read from its first
    /// samples with the sag of their current (logged, else `airborne_current_a`).
    pub fn initial_soc(
        &self,
        battery: &LearnedBattery,
        resistance_ohm: f64,
        airborne_current_a: f64,
    ) -> f64 {
        StartVoltage::of(self).initial_soc(self, resistance_ohm, airborne_current_a, |ocv| {
            battery.soc_for_ocv(ocv)
        })
    }
}

/// The voltage a log starts at, as [`FlightRecord::initial_soc`] reads it: the mean of the
/// samples before the rotors start, else the mean voltage (and logged current) of the first
/// samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum StartVoltage {
    /// Resting before the rotors start: mean voltage, V.
    Rest(f64),
    /// Airborne from the first sample: mean voltage, V, and mean logged current, A.
    Airborne(f64, Option<f64>),
    /// No samples.
    Empty,
}

impl StartVoltage {
    fn of(f: &FlightRecord) -> Self {
        let rest = f.resting_voltages_v();
        if rest.is_empty() {
            let head = f.voltage_v.len().min(5);
            if head == 0 {
                return StartVoltage::Empty;
            }
            let v = f.voltage_v[..head].iter().sum::<f64>() / head as f64;
            let i = f
                .current_a
                .as_ref()
                .map(|c| c[..head].iter().sum::<f64>() / head as f64);
            return StartVoltage::Airborne(v, i);
        }
        StartVoltage::Rest(rest.iter().sum::<f64>() / rest.len() as f64)
    }

    /// The state of charge at the start; `soc_for_ocv` inverts the battery's curve (an
    /// open-circuit voltage per cell).
    fn initial_soc(
        self,
        f: &FlightRecord,
        resistance_ohm: f64,
        airborne_current_a: f64,
        soc_for_ocv: impl FnOnce(f64) -> f64,
    ) -> f64 {
        let cells = f64::from(f.info.cells.max(1));
        match self {
            StartVoltage::Empty => 1.0,
            StartVoltage::Airborne(v, i) => {
                let i = i.unwrap_or(airborne_current_a);
                soc_for_ocv((v + i * resistance_ohm) / cells)
            }
            StartVoltage::Rest(v) => {
                let i = f.info.idle_power_w() / v.max(1e-3);
                soc_for_ocv((v + i * resistance_ohm) / cells)
            }
        }
    }
}

/// The parts of the battery power at a sample that do not change from sample to sample.
struct PowerTerms<'f> {
    /// On the ground: avionics and payload, W.
    ground_w: f64,
    /// Perched: idle power plus the effect `attached_power`, W.
    attached_w: f64,
    /// Rotor power before the ceiling: the rig's with overhead and air density, W.
    rotor_w: f64,
    /// Idle power, W.
    idle_w: f64,
    /// Ceiling height, altitudes and the saving at contact.
    ceiling: Option<(f64, &'f [f64], f64)>,
    /// Vertical speeds, weight (N) and the inverse climb efficiency.
    climb: Option<(&'f [f64], f64, f64)>,
}

impl<'f> PowerTerms<'f> {
    fn new(
        f: &'f FlightRecord,
        p: &EffectParams,
        rotor_w: f64,
        vz: Option<&'f [f64]>,
        ceiling: Option<f64>,
    ) -> Self {
        let idle = f.info.idle_power_w();
        let mut rotor = rotor_w * (1.0 + p.get(Effect::ControlOverhead));
        if let Some(rho) = f.info.air_density_kg_m3 {
            rotor *= (RIG_AIR_DENSITY_KG_M3 / rho).powf(p.get(Effect::AirDensity));
        }
        Self {
            ground_w: f.info.avionics_power_w + f.info.payload_power_w,
            attached_w: idle + p.get(Effect::AttachedPower),
            rotor_w: rotor,
            idle_w: idle,
            ceiling: match (ceiling, f.altitude_m.as_deref()) {
                (Some(h), Some(z)) => Some((h, z, p.get(Effect::CeilingEffect))),
                _ => None,
            },
            climb: vz.map(|vz| (vz, f.info.total_mass_kg() * G, p.get(Effect::ClimbPower))),
        }
    }

    /// Battery power the model draws at sample `i` of `f`, W.
    fn at(&self, f: &FlightRecord, i: usize) -> f64 {
        match f.phase[i] {
            Phase::Ground => self.ground_w,
            Phase::Attached => self.attached_w,
            _ => {
                let mut rotor = self.rotor_w;
                if let Some((h, z, saving)) = self.ceiling {
                    let gap = (h - z[i]).max(0.0);
                    rotor *= 1.0 - saving * (-gap / CEILING_DECAY_M).exp();
                }
                let mut w = rotor + self.idle_w;
                if let Some((vz, weight_n, inverse_efficiency)) = self.climb {
                    let climb = vz[i].max(0.0);
                    w += weight_n * climb * inverse_efficiency;
                }
                w
            }
        }
    }
}

/// What a prediction of a flight needs that does not change with the effect parameters (the
/// rotor power at the rig, the vertical speed, the ceiling, the start voltage), computed once
/// per flight and model.
#[derive(Debug)]
pub(crate) struct FlightConsts {
    rotor_w: f64,
    vz: Option<Vec<f64>>,
    ceiling_m: Option<f64>,
    start: StartVoltage,
    /// The last open-circuit voltage per cell inverted to a state of charge at the start, and
    /// the result: most evaluations start the flight from the same voltage. (The battery of a
    /// flight is the same at every prediction made with these constants.)
    start_soc: std::sync::Mutex<Option<(u64, f64)>>,
}

impl FlightConsts {
    /// The constants of `f` under `model`; the vertical speed only when `with_vz`.
    pub(crate) fn new<C: PowerCurve>(
        model: &Model<'_, C>,
        f: &FlightRecord,
        with_vz: bool,
    ) -> Self {
        Self {
            rotor_w: model.hover_rotor_power_w(f),
            vz: if with_vz {
                f.vertical_speed_m_s(2.0)
            } else {
                None
            },
            ceiling_m: ceiling_height_m(f),
            start: StartVoltage::of(f),
            start_soc: std::sync::Mutex::new(None),
        }
    }

    /// [`FlightRecord::initial_soc`] of `f` (whose constants these are) on `battery`.
    fn initial_soc(
        &self,
        f: &FlightRecord,
        battery: &LearnedBattery,
        resistance_ohm: f64,
        airborne_current_a: f64,
    ) -> f64 {
        self.start
            .initial_soc(f, resistance_ohm, airborne_current_a, |ocv| {
                let mut memo = self
                    .start_soc
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                match *memo {
                    Some((x, soc)) if x == ocv.to_bits() => soc,
                    _ => {
                        let soc = battery.soc_for_ocv(ocv);
                        *memo = Some((ocv.to_bits(), soc));
                        soc
                    }
                }
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The healthy reference scales as one over the rated capacity, lies above the typical
    /// cell, and holds the published healthy cells its doc comment cites (a new 5 Ah hobby
    /// LiPo at 3 mΩ, an A123 26650 at 10 mΩ DC for 2.5 Ah, an LG M50 at about 25 mΩ DC for
    /// 5 Ah) within its band.
    #[test]
    fn the_healthy_reference_follows_chemistry_and_capacity() {
        for c in Chemistry::PRIORS {
            let h = c.healthy_resistance().unwrap();
            let r2 = healthy_cell_resistance_ohm(c, 2.0);
            let r4 = healthy_cell_resistance_ohm(c, 4.0);
            assert!((r2 / r4 - 2.0).abs() < 1e-12, "{c:?}: {r2} {r4}");
            assert!(r2 > h.typical_cell_ohm(2.0).unwrap(), "{c:?}");
        }
        let healthy = [
            (Chemistry::Lipo, 5.0, 0.003),
            (Chemistry::Lihv, 2.2, 0.007),
            (Chemistry::Lifepo4, 2.5, 0.010),
            (Chemistry::LiIonNmc, 5.0, 0.025),
            (Chemistry::LiIonNca, 3.4, 0.040),
        ];
        for (c, capacity_ah, cell_ohm) in healthy {
            let h = c.healthy_resistance().unwrap();
            let low = h.typical_cell_ohm(capacity_ah).unwrap() / h.spread_factor;
            let top = healthy_cell_resistance_ohm(c, capacity_ah);
            assert!(
                (low..=top).contains(&cell_ohm),
                "{c:?} {capacity_ah} Ah: {cell_ohm} outside {low}..{top}"
            );
        }
        // A 5 Ah cylindrical Li-ion pack is allowed far more than PX4's 5 mΩ, a 5 Ah LiPo not.
        assert!(healthy_cell_resistance_ohm(Chemistry::LiIonNmc, 5.0) > 0.02);
        assert!(healthy_cell_resistance_ohm(Chemistry::Lipo, 5.0) < NOMINAL_CELL_RESISTANCE_OHM);
        // Unknown chemistry or size: the nominal.
        for cap in [f64::NAN, 0.0, -1.0, f64::INFINITY] {
            assert_eq!(
                healthy_cell_resistance_ohm(Chemistry::Lipo, cap),
                NOMINAL_CELL_RESISTANCE_OHM
            );
        }
        assert_eq!(
            healthy_cell_resistance_ohm(Chemistry::Measured, 5.0),
            NOMINAL_CELL_RESISTANCE_OHM
        );
    }
}
