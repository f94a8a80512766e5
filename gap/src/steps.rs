//! The series resistance the current's steps show: at take-off, landing, perching and every
//! other jump of the logged current, the voltage moves at once by the current's jump times the
//! pack's series resistance (and the wiring's), before the charge drawn, the open-circuit curve
//! or a slower polarisation can move it. A capacity fade, a Peukert loss or any extra power
//! move the voltage only through the charge they draw, never at a step; an extra series
//! resistance moves it at every step.
//!
//! [`step_resistances`] reads it per battery type from the training flights with a logged
//! current: a least-squares slope through the origin of the voltage's jumps on the current's,
//! less the share the learned RC pair took up while the current jumped (half-way through the
//! interval on average), with its standard error from the steps' own scatter, beside the top
//! of a healthy pack of the type's chemistry and size. The diagnosis reports it
//! ([`crate::diagnose::Diagnosis::step_resistances`]); it does not enter the verdict or any
//! prediction. Flights without a current (Crazyflie) have no steps to read.
//!
//! Used as the baseline's resistance (the pack's own, less what lies above the healthy band)
//! it made the baseline's held-out endurance better but did not generalise to the verdicts:
//! on the blind study's held-out families the strict verdicts went 181 → 178 of 375 (issue 9,
//! session 25; `docs/evidence/gap.md`).
//!
//! ```
//! use gap::flight::{FlightInfo, FlightRecord, Phase};
//! use gap::steps::steps_of;
//!
//! // A 3S pack of 30 mΩ: a take-off from 0.5 A to 10.5 A drops the voltage by 0.3 V.
//! let f = FlightRecord {
//!     name: "hop".into(),
//!     time_s: vec![0.0, 1.0, 2.0, 3.0],
//!     voltage_v: vec![12.585, 12.585, 12.285, 12.284],
//!     current_a: Some(vec![0.5, 0.5, 10.5, 10.5]),
//!     phase: vec![Phase::Ground, Phase::Ground, Phase::Hover, Phase::Hover],
//!     altitude_m: None,
//!     info: FlightInfo {
//!         structure_mass_kg: 1.0,
//!         battery_mass_kg: 0.2,
//!         battery_energy_wh: 30.0,
//!         cells: 3,
//!         payload_mass_kg: 0.0,
//!         payload_power_w: 0.0,
//!         avionics_power_w: 5.0,
//!         battery_id: None,
//!         battery_cycles: None,
//!         ambient_temperature_c: None,
//!         air_density_kg_m3: None,
//!         cutoff_voltage_v: 10.5,
//!         ended_at_cutoff: false,
//!         ceiling_height_m: None,
//!         measured_ocv: None,
//!     },
//! };
//! let steps = steps_of(&f, 0.0, 1.0);
//! assert_eq!(steps.len(), 1);
//! let (di, dv) = steps[0];
//! assert!((di - 10.0).abs() < 1e-12 && (dv + 0.3).abs() < 1e-12);
//! ```

use serde::Serialize;

use crate::battery::{CurrentSource, battery_type};
use crate::diagnose::BatterySet;
use crate::flight::{FlightRecord, rotors_on};

/// Longest interval between the two samples of a step, s: longer, and the polarisation and
/// the charge drawn move the voltage as well.
pub const MAX_STEP_INTERVAL_S: f64 = 1.5;

/// Smallest jump of the current that counts as a step, as a fraction of the flight's median
/// current with the rotors on (and at least [`MIN_STEP_A`]).
pub const MIN_STEP_FRACTION: f64 = 0.3;

/// Smallest jump of the current that counts as a step, A.
pub const MIN_STEP_A: f64 = 0.5;

/// Fewest steps a battery type needs for its resistance to be read.
pub const MIN_STEPS: usize = 3;

/// The series resistance one battery type's steps show.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepResistance {
    /// Battery type ([`battery_type`]).
    pub battery_type: String,
    /// Cells in series.
    pub cells: u8,
    /// Steps read.
    pub steps: usize,
    /// Series resistance of the pack, Ω (the voltage's jump over the current's, less the
    /// learned RC pair's share).
    pub pack_ohm: f64,
    /// Its standard error from the steps' scatter, Ω.
    pub sigma_ohm: f64,
    /// The series resistance per cell the battery fit learned from the voltage, Ω.
    pub learned_cell_ohm: f64,
    /// The highest series resistance per cell a healthy pack of the type's chemistry and size
    /// has ([`crate::model::healthy_cell_resistance_ohm`]), Ω.
    pub healthy_top_cell_ohm: f64,
}

impl StepResistance {
    /// The steps' resistance per cell, Ω (the wiring's shared among the cells).
    pub fn cell_ohm(&self) -> f64 {
        self.pack_ohm / f64::from(self.cells.max(1))
    }

    /// Whether the steps show more than a healthy pack of the type has, by more than two
    /// standard errors.
    pub fn above_healthy(&self) -> bool {
        self.pack_ohm - 2.0 * self.sigma_ohm
            > f64::from(self.cells.max(1)) * self.healthy_top_cell_ohm
    }
}

/// The current's steps of one flight: (the current's jump, A; the voltage's jump, V), each
/// less the share of a polarisation `rc_pack_ohm` with time constant `tau_s` over half the
/// step's interval (the current jumps half-way through it on average). Empty without a
/// logged current.
pub fn steps_of(f: &FlightRecord, rc_pack_ohm: f64, tau_s: f64) -> Vec<(f64, f64)> {
    let Some(cur) = f.current_a.as_ref() else {
        return Vec::new();
    };
    let mut on: Vec<f64> = cur
        .iter()
        .zip(&f.phase)
        .filter(|(i, p)| rotors_on(**p) && i.is_finite())
        .map(|(i, _)| i.abs())
        .collect();
    if on.is_empty() {
        return Vec::new();
    }
    on.sort_by(f64::total_cmp);
    let typical = on[on.len() / 2];
    let min_step = (MIN_STEP_FRACTION * typical).max(MIN_STEP_A);
    let mut out = Vec::new();
    for k in 1..f.time_s.len().min(cur.len()).min(f.voltage_v.len()) {
        let dt = f.time_s[k] - f.time_s[k - 1];
        let di = cur[k] - cur[k - 1];
        let dv = f.voltage_v[k] - f.voltage_v[k - 1];
        if !(dt > 0.0 && dt <= MAX_STEP_INTERVAL_S && di.is_finite() && dv.is_finite()) {
            continue;
        }
        if di.abs() < min_step {
            continue;
        }
        // The current jumps somewhere within the interval, on average half-way: the RC pair
        // has followed it for half the interval.
        let rc_share = if tau_s > 0.0 {
            rc_pack_ohm * (1.0 - (-0.5 * dt / tau_s).exp())
        } else {
            rc_pack_ohm
        };
        out.push((di, dv + di * rc_share));
    }
    out
}

/// The series resistance each training battery type's steps show, for every type whose
/// current is logged and that has at least [`MIN_STEPS`] steps.
pub fn step_resistances(batteries: &BatterySet, train: &[&FlightRecord]) -> Vec<StepResistance> {
    let mut out = Vec::new();
    for fit in &batteries.fits {
        if fit.current != CurrentSource::Logged {
            continue;
        }
        let mine: Vec<&&FlightRecord> = train
            .iter()
            .filter(|f| battery_type(f) == fit.battery_type)
            .collect();
        let Some(first) = mine.first() else {
            continue;
        };
        let cells = first.info.cells.max(1);
        let n = f64::from(cells);
        let steps: Vec<(f64, f64)> = mine
            .iter()
            .flat_map(|f| {
                steps_of(
                    f,
                    n * fit.battery.rc_resistance_cell_ohm,
                    fit.battery.rc_time_constant_s,
                )
            })
            .collect();
        if steps.len() < MIN_STEPS {
            continue;
        }
        let sxx: f64 = steps.iter().map(|(di, _)| di * di).sum();
        let sxy: f64 = steps.iter().map(|(di, dv)| -dv * di).sum();
        let r = sxy / sxx;
        let ss: f64 = steps.iter().map(|(di, dv)| (-dv - r * di).powi(2)).sum();
        let sigma = (ss / (steps.len() - 1) as f64 / sxx).sqrt();
        out.push(StepResistance {
            battery_type: fit.battery_type.clone(),
            cells,
            steps: steps.len(),
            pack_ohm: r,
            sigma_ohm: sigma,
            learned_cell_ohm: fit.battery.series_resistance_cell_ohm,
            healthy_top_cell_ohm: crate::model::healthy_cell_resistance_ohm(
                fit.prior,
                fit.rated_capacity_ah,
            ),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::{FlightInfo, Phase};

    /// A 3S flight at `dt_s` with the current stepping between the ground, hover and a perch
    /// half-way between two samples: its voltage `ocv − I·r_ohm − v_rc` (one RC pair
    /// `r1_ohm`, `tau_s`), the open-circuit voltage falling by `fall_v_per_ah` with the charge
    /// drawn.
    fn stepped_flight(
        dt_s: f64,
        r_ohm: f64,
        r1_ohm: f64,
        tau_s: f64,
        fall_v_per_ah: f64,
    ) -> FlightRecord {
        let legs = [
            (10.0, 0.5, Phase::Ground),
            (100.0, 10.0, Phase::Hover),
            (20.0, 1.0, Phase::Attached),
            (60.0, 12.0, Phase::Hover),
            (10.0, 0.5, Phase::Ground),
        ];
        let (mut t, mut q_ah, mut v_rc) = (0.0, 0.0, 0.0);
        let mut f = FlightRecord {
            name: "steps".into(),
            time_s: Vec::new(),
            voltage_v: Vec::new(),
            current_a: Some(Vec::new()),
            phase: Vec::new(),
            altitude_m: None,
            info: FlightInfo {
                structure_mass_kg: 1.0,
                battery_mass_kg: 0.2,
                battery_energy_wh: 30.0,
                cells: 3,
                payload_mass_kg: 0.0,
                payload_power_w: 0.0,
                avionics_power_w: 5.0,
                battery_id: None,
                battery_cycles: None,
                ambient_temperature_c: None,
                air_density_kg_m3: None,
                cutoff_voltage_v: 10.5,
                ended_at_cutoff: false,
                ceiling_height_m: None,
                measured_ocv: None,
            },
        };
        for (dur, i, phase) in legs {
            let end = t + dur;
            while t < end - 1e-9 {
                // The half interval since the current took this value.
                v_rc = i * r1_ohm + (v_rc - i * r1_ohm) * (-0.5 * dt_s / tau_s).exp();
                f.time_s.push(t);
                f.voltage_v
                    .push(12.6 - fall_v_per_ah * q_ah - i * r_ohm - v_rc);
                if let Some(c) = f.current_a.as_mut() {
                    c.push(i);
                }
                f.phase.push(phase);
                q_ah += i * dt_s / 3600.0;
                v_rc = i * r1_ohm + (v_rc - i * r1_ohm) * (-0.5 * dt_s / tau_s).exp();
                t += dt_s;
            }
        }
        f
    }

    fn resistance(steps: &[(f64, f64)]) -> f64 {
        let sxx: f64 = steps.iter().map(|(di, _)| di * di).sum();
        steps.iter().map(|(di, dv)| -dv * di).sum::<f64>() / sxx
    }

    #[test]
    fn the_steps_read_the_series_resistance_less_the_rc_pairs_share() {
        for dt in [0.02, 0.1, 1.0] {
            let f = stepped_flight(dt, 0.045, 0.02, 20.0, 0.3);
            let steps = steps_of(&f, 0.02, 20.0);
            // Take-off, perch, take-off again, landing.
            assert_eq!(steps.len(), 4, "dt {dt}");
            let r = resistance(&steps);
            // The charge drawn over one interval moves the voltage a little (0.3 V/Ah).
            assert!((r - 0.045).abs() < 2e-4, "dt {dt}: {r}");
            // Without the RC pair's share the 1 Hz steps read high.
            if dt == 1.0 {
                let raw = resistance(&steps_of(&f, 0.0, 20.0));
                assert!(raw > 0.0453, "{raw}");
            }
        }
    }

    #[test]
    fn a_charge_that_falls_faster_leaves_the_steps_alone() {
        // A fade (or a Peukert loss) makes the voltage fall faster with the charge drawn; the
        // steps read the same resistance.
        let slow = resistance(&steps_of(
            &stepped_flight(0.1, 0.03, 0.01, 10.0, 0.3),
            0.01,
            10.0,
        ));
        let fast = resistance(&steps_of(
            &stepped_flight(0.1, 0.03, 0.01, 10.0, 0.6),
            0.01,
            10.0,
        ));
        assert!(
            (slow - 0.03).abs() < 1e-4 && (fast - 0.03).abs() < 1e-4,
            "{slow} {fast}"
        );
    }

    #[test]
    fn no_current_no_steps_and_small_jumps_are_not_steps() {
        let mut f = stepped_flight(1.0, 0.03, 0.0, 10.0, 0.3);
        f.current_a = None;
        assert!(steps_of(&f, 0.0, 10.0).is_empty());
        // The hover current wanders by 10 % of itself: under the step threshold (30 %).
        let mut f = stepped_flight(1.0, 0.03, 0.0, 10.0, 0.3);
        if let Some(c) = f.current_a.as_mut() {
            for (k, i) in c.iter_mut().enumerate() {
                if f.phase[k] == Phase::Hover && k % 2 == 0 {
                    *i *= 1.1;
                }
            }
        }
        assert_eq!(steps_of(&f, 0.0, 10.0).len(), 4);
    }

    #[test]
    fn a_type_reads_above_a_healthy_pack_only_beyond_two_sigma() {
        let s = StepResistance {
            battery_type: "3S".into(),
            cells: 3,
            steps: 8,
            pack_ohm: 0.05,
            sigma_ohm: 0.002,
            learned_cell_ohm: 0.015,
            healthy_top_cell_ohm: 0.015,
        };
        assert!((s.cell_ohm() - 0.05 / 3.0).abs() < 1e-15);
        assert!(s.above_healthy());
        let close = StepResistance {
            pack_ohm: 0.048,
            ..s.clone()
        };
        assert!(!close.above_healthy());
    }
}
