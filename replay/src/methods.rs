//! The estimators replayed: the trait they share, what a flight's metadata tells them, and the
//! baselines (PX4's `time_remaining_s`, a rated-capacity coulomb counter, the static model).

use estimator::online::Chemistry;
use estimator::{Battery, MissionOptions, Params, Payload, Segment};
use flightlog::{Flight, Phase};
use serde::Serialize;

use crate::cutoff::FlightSpan;

/// One logged sample as firmware receives it: nothing of the future.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s (log time).
    pub time_s: f64,
    /// Battery voltage, V.
    pub voltage_v: f64,
    /// Battery current, A, when a current sensor is logged.
    pub current_a: Option<f64>,
    /// Flight phase, when logged or inferred.
    pub phase: Option<Phase>,
    /// The rotors' electrical power from the logged motor commands through the parameters'
    /// motor map, W, when both are there.
    pub motor_power_w: Option<f64>,
}

/// What an estimator says after a sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted time until the flight ends at the cut-off, s.
    pub remaining_s: f64,
    /// One-sigma band of that prediction, s, when the method gives one.
    pub sigma_s: Option<f64>,
}

/// An estimator fed one sample at a time, in time order.
pub trait Predictor {
    /// Takes the next sample; returns the current prediction, or `None` while the method has
    /// none (e.g. no current logged for a current-based method).
    fn update(&mut self, sample: &Sample) -> Option<Prediction>;
}

/// The methods compared, by name.
pub const ONLINE: &str = "online";
/// PX4's `time_remaining_s`.
pub const PX4: &str = "px4";
/// Rated-capacity coulomb counter.
pub const COULOMB: &str = "coulomb";
/// The paper's static model minus elapsed time.
pub const STATIC: &str = "static_model";
/// Every method, in report order.
pub const METHODS: [&str; 4] = [ONLINE, PX4, COULOMB, STATIC];

/// Nominal cell voltage used to turn a rated energy into a rated capacity when the metadata has
/// no `capacity_mah`, V (a LiPo's label voltage).
pub const NOMINAL_CELL_V: f64 = 3.7;

/// What the flight's metadata says about the vehicle and its pack, as a user would set up an
/// autopilot before flying (nothing measured in the flight).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightSetup {
    /// Cells in series.
    pub cells: Option<u32>,
    /// Rated capacity, Ah: `capacity_mah`, else rated energy / (cells × 3.7 V).
    pub rated_capacity_ah: Option<f64>,
    /// Rated energy, Wh: `battery_energy_wh`, else density × mass.
    pub battery_energy_wh: Option<f64>,
    /// Structure mass, kg.
    pub structure_mass_kg: Option<f64>,
    /// Battery mass, kg.
    pub battery_mass_kg: Option<f64>,
    /// Payload mass, kg (0 when not given).
    pub payload_mass_kg: f64,
    /// Payload power, W (0 when not given).
    pub payload_power_w: f64,
    /// Avionics power, W.
    pub avionics_power_w: Option<f64>,
    /// Cut-off voltage, V.
    pub cutoff_voltage_v: Option<f64>,
    /// The pack's usable capacity over its model's, as its last flight measured it, and the
    /// reading's one-sigma ([`crate::history`]; `replay --pack-history`): the online estimator
    /// fuses it with its capacity at the first sample. `None` (no history, or not asked for):
    /// the model's capacity alone.
    pub capacity_reading: Option<(f64, f64)>,
}

impl FlightSetup {
    /// From a flight's merged metadata.
    pub fn of(flight: &Flight) -> Self {
        let m = &flight.meta;
        let energy = m.battery_energy_wh.or(
            match (m.battery_energy_density_wh_per_kg, m.battery_mass_kg) {
                (Some(d), Some(mass)) => Some(d * mass),
                _ => None,
            },
        );
        let rated = m
            .capacity_mah
            .map(|c| c / 1000.0)
            .or(match (energy, m.cells) {
                (Some(e), Some(c)) if c > 0 => Some(e / (f64::from(c) * NOMINAL_CELL_V)),
                _ => None,
            });
        Self {
            cells: m.cells,
            rated_capacity_ah: rated,
            battery_energy_wh: energy,
            structure_mass_kg: m.structure_mass_kg,
            battery_mass_kg: m.battery_mass_kg,
            payload_mass_kg: m.payload_mass_kg.unwrap_or(0.0),
            payload_power_w: m.payload_power_w.unwrap_or(0.0),
            avionics_power_w: m.avionics_power_w,
            cutoff_voltage_v: m.cutoff_voltage_v,
            capacity_reading: None,
        }
    }

    /// The keys the static model and the online estimator need that are missing.
    pub fn missing_for_model(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.structure_mass_kg.is_none() {
            v.push("structure_mass_kg");
        }
        if self.battery_mass_kg.is_none() {
            v.push("battery_mass_kg");
        }
        if self.battery_energy_wh.is_none() {
            v.push("battery_energy_wh");
        }
        if self.avionics_power_w.is_none() {
            v.push("avionics_power_w");
        }
        if self.cells.is_none() {
            v.push("cells");
        }
        v
    }
}

/// One leg of the mission a flight flew, as its plan would have said before take-off: the
/// phase schedule of the log from take-off, each run of equal phases one leg. Climb, descend
/// and transition count as hover; ground between flights and attached count as attached
/// (motors off). The last leg is "hover until the cut-off", open-ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlanLeg {
    /// Motors off (attached to a ceiling, or on the ground between flights).
    pub attached: bool,
    /// Start, s (log time).
    pub start_s: f64,
    /// Duration, s; `None` for the last, open-ended leg.
    pub duration_s: Option<f64>,
}

impl PlanLeg {
    /// The leg as the estimator's mission segment (eqs. 7–9).
    pub fn segment(&self) -> Segment {
        match (self.attached, self.duration_s) {
            (true, Some(d)) => Segment::Attached {
                duration_min: d / 60.0,
            },
            (false, Some(d)) => Segment::Hover {
                duration_min: d / 60.0,
            },
            (_, None) => Segment::HoverUntilEmpty,
        }
    }
}

/// The mission plan of a flight (see [`PlanLeg`]); a flight without phases is one open leg.
pub fn mission_plan(flight: &Flight, span: &FlightSpan) -> Vec<PlanLeg> {
    mission_plan_between(flight, span.takeoff_s, span.end_s)
}

/// [`mission_plan`] of the part of a flight from `takeoff_s` to `end_s` (log time).
pub fn mission_plan_between(flight: &Flight, takeoff_s: f64, end_s: f64) -> Vec<PlanLeg> {
    let s = &flight.samples;
    let Some(ph) = &s.phase else {
        return vec![PlanLeg {
            attached: false,
            start_s: takeoff_s,
            duration_s: None,
        }];
    };
    let mut legs: Vec<PlanLeg> = Vec::new();
    for (&t, p) in s.time_s.iter().zip(ph) {
        if t < takeoff_s || t > end_s {
            continue;
        }
        let attached = !p.is_flying();
        match legs.last_mut() {
            Some(l) if l.attached == attached => {}
            _ => legs.push(PlanLeg {
                attached,
                start_s: t,
                duration_s: None,
            }),
        }
    }
    for i in 0..legs.len() {
        let end = legs.get(i + 1).map_or(end_s, |n| n.start_s);
        legs[i].duration_s = Some(end - legs[i].start_s);
    }
    if let Some(l) = legs.last_mut() {
        l.duration_s = None;
    }
    legs
}

/// A first-order low-pass `state += α (x − state)`, `α = dt / (τ + dt)` (PX4's `AlphaFilter`).
#[derive(Debug, Clone, Copy)]
struct Alpha {
    tau_s: f64,
    state: f64,
}

impl Alpha {
    fn update(&mut self, x: f64, dt: f64) {
        let a = if self.tau_s + dt > f64::EPSILON {
            dt / (self.tau_s + dt)
        } else {
            1.0
        };
        self.state += a * (x - self.state);
    }
}

/// PX4's battery parameters the reimplementation reads, with PX4's defaults where the metadata
/// says nothing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Px4Params {
    /// `BAT1_N_CELLS`.
    pub n_cells: u32,
    /// `BAT1_CAPACITY`, mAh.
    pub capacity_mah: f64,
    /// `BAT1_V_EMPTY`, V per cell (PX4 default 3.6).
    pub v_empty: f64,
    /// `BAT1_V_CHARGED`, V per cell (PX4 default 4.05).
    pub v_charged: f64,
    /// `BAT1_R_INTERNAL`, Ω per cell; `None` (PX4's default −1) estimates it online.
    pub r_internal: Option<f64>,
    /// `BAT_AVRG_CURRENT`, A (PX4 default 15): the current-average filter's start value.
    pub avrg_current_a: f64,
}

impl Px4Params {
    /// PX4's defaults with the flight's cells and rated capacity.
    pub fn defaults(cells: u32, capacity_mah: f64) -> Self {
        Self::configured(cells, capacity_mah, &Px4Battery::of(None))
    }

    /// PX4's defaults with the flight's cells and rated capacity, and the cell voltages a PX4
    /// configured for the pack has ([`Px4Battery::of`]).
    pub fn configured(cells: u32, capacity_mah: f64, battery: &Px4Battery) -> Self {
        Self {
            n_cells: cells,
            capacity_mah,
            v_empty: battery.v_empty_cell_v,
            v_charged: battery.v_charged_cell_v,
            r_internal: None,
            avrg_current_a: 15.0,
        }
    }
}

/// The cell voltages the PX4 baseline runs with: those a PX4 configured for the pack's
/// chemistry has (`autopilot::px4_cell_voltages`, the values `hoverbench export px4
/// --chemistry` writes), else PX4's defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Px4Battery {
    /// `BAT1_V_EMPTY`, V per cell.
    pub v_empty_cell_v: f64,
    /// `BAT1_V_CHARGED`, V per cell.
    pub v_charged_cell_v: f64,
    /// The chemistry they are for; `None`: PX4's defaults, the chemistry unknown.
    pub chemistry: Option<&'static str>,
}

impl Px4Battery {
    /// For a pack of `chemistry` (`None`, `measured` or `other`: PX4's defaults).
    pub fn of(chemistry: Option<Chemistry>) -> Self {
        match chemistry.and_then(|c| autopilot::px4_cell_voltages(c).map(|v| (c, v))) {
            Some((c, v)) => Self {
                v_empty_cell_v: v.empty_cell_v,
                v_charged_cell_v: v.charged_cell_v,
                chemistry: Some(c.name()),
            },
            None => Self {
                v_empty_cell_v: autopilot::PX4_DEFAULT_CELL_VOLTAGES.empty_cell_v,
                v_charged_cell_v: autopilot::PX4_DEFAULT_CELL_VOLTAGES.charged_cell_v,
                chemistry: None,
            },
        }
    }
}

impl std::fmt::Display for Px4Battery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "px4 baseline: BAT1_V_EMPTY {:.2} V, BAT1_V_CHARGED {:.2} V per cell",
            self.v_empty_cell_v, self.v_charged_cell_v
        )?;
        match self.chemistry {
            Some(c) => write!(
                f,
                " (PX4 set up for {c} cells, as `hoverbench export px4 --chemistry {c}` writes)"
            ),
            None => write!(f, " (PX4's defaults: the pack's chemistry is not known)"),
        }
    }
}

// Constants of PX4's online internal-resistance estimator (recursive least squares on
// `V = OCV − R·I`): forgetting factor, start values and start covariances per cell. Checked
// against PX4-Autopilot `src/lib/battery/battery.h` (`LAMBDA = 0.95f`, `R_DEFAULT = 0.005f`,
// `OCV_DEFAULT = 4.2f`, `R_COVARIANCE = 0.1f`, `OCV_COVARIANCE = 1.5f`).
const RLS_LAMBDA: f64 = 0.95;
const R_DEFAULT: f64 = 0.005;
const OCV_DEFAULT: f64 = 4.2;
const R_COVARIANCE: f64 = 0.1;
const OCV_COVARIANCE: f64 = 1.5;

/// PX4's `time_remaining_s`, reimplemented from the logic of `Battery` in PX4-Autopilot's
/// `src/lib/battery/battery.cpp` (our own code, not a copy; checked line by line against the
/// version with `computeRemainingTime` and the RLS resistance estimator, v1.14–v1.15, and its
/// `battery.h`; `BAT_AVRG_CURRENT` = 15 A from `src/lib/battery/battery_params_common.c`;
/// `BAT1_V_EMPTY` 3.6 V and `BAT1_V_CHARGED` 4.05 V as PX4's parameter reference lists them
/// for v1.14 — the `src/lib/battery/module.yaml` read (an older one) says 3.5 V empty, so
/// that default is the one value here not confirmed in the source itself):
///
/// - charge used by integrating the current (`sumDischarged`);
/// - a voltage-based state of charge: the cell voltage corrected for the load drop with an
///   internal resistance (`BAT_R_INTERNAL`, or estimated by recursive least squares on
///   `V = OCV − R·I` when it is −1), low-passed (1 s), mapped linearly between `V_EMPTY` and
///   `V_CHARGED` (`calculateStateOfChargeVoltageBased`);
/// - once the battery has been connected 2 s and a capacity is set, the state of charge is
///   fused: `soc ← (1 − w)·soc + w·soc_v` with `w = 0.03·(1 − soc_v)`, minus the charge of this
///   step over the capacity, capped by the coulomb-counted `1 − used/capacity`
///   (`estimateStateOfCharge`); before that it is the voltage-based one;
/// - `time_remaining_s = soc · capacity / I_avg`, where `I_avg` is the current low-passed with a
///   50 s time constant while armed, started at `BAT_AVRG_CURRENT` (`computeRemainingTime`).
///
/// Armed here means the flight's phase is not `ground` (every sample when no phase is known).
/// Without a logged current the method gives no prediction (PX4 would divide by
/// `BAT_AVRG_CURRENT`, a guess). The filters run on the actual sample interval (PX4's
/// `AlphaFilter`s are set up for the driver's nominal interval; the same time constants).
/// In PX4 the load-compensated cell voltage and the RLS update happen only while the current
/// is above `FLT_EPSILON`, the state of charge is the voltage-based one until the battery has
/// been connected 2 s, and a capacity ≤ 0 gives no remaining time — all as here.
#[derive(Debug, Clone)]
pub struct Px4TimeRemaining {
    p: Px4Params,
    first_t: Option<f64>,
    last_t: Option<f64>,
    discharged_mah: f64,
    soc: f64,
    rls: [f64; 2],
    cov: [[f64; 2]; 2],
    cov_norm: f64,
    r_est: f64,
    cell_v: Alpha,
    i_avg: Alpha,
}

impl Px4TimeRemaining {
    /// A battery with these parameters, just connected.
    pub fn new(p: Px4Params) -> Self {
        let n = f64::from(p.n_cells.max(1));
        let cov = [[OCV_COVARIANCE * n, 0.0], [0.0, R_COVARIANCE * n]];
        Self {
            p,
            first_t: None,
            last_t: None,
            discharged_mah: 0.0,
            soc: 1.0,
            rls: [OCV_DEFAULT * n, R_DEFAULT * n],
            cov,
            cov_norm: norm(&cov),
            r_est: R_DEFAULT,
            cell_v: Alpha {
                tau_s: 1.0,
                state: 0.0,
            },
            i_avg: Alpha {
                tau_s: 50.0,
                state: 0.0,
            },
        }
    }

    fn reset_rls(&mut self, v: f64, i: f64) {
        let n = f64::from(self.p.n_cells.max(1));
        self.rls = [v, R_DEFAULT * n];
        self.cov = [[OCV_COVARIANCE * n, 0.0], [0.0, R_COVARIANCE * n]];
        self.cov_norm = norm(&self.cov);
        self.r_est = R_DEFAULT;
        let r = self.p.r_internal.unwrap_or(self.r_est);
        self.cell_v.state = v / n + r * i;
    }

    fn update_rls(&mut self, v: f64, i: f64) {
        let n = f64::from(self.p.n_cells.max(1));
        let x = [1.0, -i];
        let pred = x[0] * self.rls[0] + x[1] * self.rls[1];
        let err = v - pred;
        let px = [
            self.cov[0][0] * x[0] + self.cov[0][1] * x[1],
            self.cov[1][0] * x[0] + self.cov[1][1] * x[1],
        ];
        let denom = RLS_LAMBDA + x[0] * px[0] + x[1] * px[1];
        let gain = [px[0] / denom, px[1] / denom];
        let est = [self.rls[0] + gain[0] * err, self.rls[1] + gain[1] * err];
        // xᵀP (row), then P − g·(xᵀP), over λ.
        let xp = [
            x[0] * self.cov[0][0] + x[1] * self.cov[1][0],
            x[0] * self.cov[0][1] + x[1] * self.cov[1][1],
        ];
        let mut cov = [[0.0; 2]; 2];
        for (r, row) in cov.iter_mut().enumerate() {
            for (c, cell) in row.iter_mut().enumerate() {
                *cell = (self.cov[r][c] - gain[r] * xp[c]) / RLS_LAMBDA;
            }
        }
        let cn = norm(&cov);
        if cn < self.cov_norm {
            self.rls = est;
            self.cov = cov;
            self.cov_norm = cn;
            self.r_est = (self.rls[1] / n).max(0.0);
        } else {
            self.rls[0] = v + self.rls[1] * i;
        }
    }
}

fn norm(c: &[[f64; 2]; 2]) -> f64 {
    (c[0][0] * c[0][0] + 2.0 * c[1][0] * c[1][0] + c[1][1] * c[1][1]).sqrt()
}

impl Predictor for Px4TimeRemaining {
    fn update(&mut self, s: &Sample) -> Option<Prediction> {
        let i = s.current_a?;
        let n = f64::from(self.p.n_cells.max(1));
        let first = *self.first_t.get_or_insert(s.time_s);
        let dt_discharge = self.last_t.map_or(0.0, |l| (s.time_s - l).max(0.0));
        let dt = dt_discharge.min(2.0);
        self.last_t = Some(s.time_s);
        let initialised = s.time_s > first + 2.0;
        if !initialised {
            self.reset_rls(s.voltage_v, i);
        }
        // sumDischarged
        let loop_mah = i * 1e3 * dt_discharge / 3600.0;
        self.discharged_mah += loop_mah;
        // calculateStateOfChargeVoltageBased
        let mut cell = s.voltage_v / n;
        if i > f64::EPSILON {
            self.update_rls(s.voltage_v, i);
            cell += self.p.r_internal.unwrap_or(self.r_est) * i;
        }
        self.cell_v.update(cell, dt);
        let soc_v = ((self.cell_v.state - self.p.v_empty) / (self.p.v_charged - self.p.v_empty))
            .clamp(0.0, 1.0);
        // estimateStateOfCharge
        let cap = self.p.capacity_mah;
        if cap > 0.0 && initialised {
            let w = 0.03 * (1.0 - soc_v);
            self.soc = (1.0 - w) * self.soc + w * soc_v;
            self.soc = (self.soc - loop_mah / cap).max(0.0);
            let coulomb = (1.0 - self.discharged_mah / cap).max(0.0);
            self.soc = self.soc.min(coulomb);
        } else {
            self.soc = soc_v;
        }
        // computeRemainingTime
        if !self.i_avg.state.is_finite() || self.i_avg.state < f64::EPSILON {
            self.i_avg.state = self.p.avrg_current_a;
        }
        let armed = s.phase.is_none_or(|p| p != Phase::Ground);
        if armed {
            self.i_avg.update(i.max(0.0), dt);
        }
        if cap <= 0.0 {
            return None;
        }
        let i_ma = (self.i_avg.state * 1e3).max(f64::EPSILON);
        Some(Prediction {
            remaining_s: self.soc * cap / i_ma * 3600.0,
            sigma_s: None,
        })
    }
}

/// Time constant of the coulomb counter's current filter, s.
pub const COULOMB_FILTER_S: f64 = 30.0;

/// A rated-capacity coulomb counter: `remaining = (rated − used charge) / filtered current`,
/// the current low-passed with a [`COULOMB_FILTER_S`] time constant while the motors run
/// (phase not `ground`/`attached`, every sample when no phase is known), started at the first
/// such sample's current. No prediction without a logged current.
#[derive(Debug, Clone)]
pub struct CoulombCounter {
    rated_ah: f64,
    used_ah: f64,
    last_t: Option<f64>,
    i_f: Option<f64>,
}

impl CoulombCounter {
    /// A full pack of `rated_ah`.
    pub fn new(rated_ah: f64) -> Self {
        Self {
            rated_ah,
            used_ah: 0.0,
            last_t: None,
            i_f: None,
        }
    }
}

impl Predictor for CoulombCounter {
    fn update(&mut self, s: &Sample) -> Option<Prediction> {
        let i = s.current_a?;
        let dt = self.last_t.map_or(0.0, |l| (s.time_s - l).max(0.0));
        self.last_t = Some(s.time_s);
        self.used_ah += i * dt / 3600.0;
        if s.phase.is_none_or(|p| p.is_flying()) {
            let i = i.max(0.0);
            self.i_f = Some(match self.i_f {
                None => i,
                Some(f) => f + dt / (COULOMB_FILTER_S + dt) * (i - f),
            });
        }
        let i_f = self.i_f?;
        Some(Prediction {
            remaining_s: ((self.rated_ah - self.used_ah).max(0.0) / i_f.max(1e-6)) * 3600.0,
            sigma_s: None,
        })
    }
}

/// The paper's static model: before take-off, the mission's end from eqs. (1)–(9) with the
/// rated battery energy and the masses and powers of the metadata (the plan of
/// [`mission_plan`], its last leg "hover until empty"); in flight, that end minus the time
/// elapsed. It never looks at a sample's voltage or current.
#[derive(Debug, Clone, Copy)]
pub struct StaticModel {
    predicted_end_s: f64,
}

impl StaticModel {
    /// The prediction for a flight; the reason when the model cannot be evaluated.
    pub fn new(
        params: &Params,
        setup: &FlightSetup,
        plan: &[PlanLeg],
        takeoff_s: f64,
    ) -> Result<Self, String> {
        let missing = setup.missing_for_model();
        if !missing.is_empty() {
            return Err(format!("metadata lacks {}", missing.join(", ")));
        }
        let (Some(ms), Some(mb), Some(e), Some(pa)) = (
            setup.structure_mass_kg,
            setup.battery_mass_kg,
            setup.battery_energy_wh,
            setup.avionics_power_w,
        ) else {
            return Err("metadata incomplete".to_owned());
        };
        let model = params.model(ms, pa);
        let battery = Battery::new(mb, e).map_err(|e| e.to_string())?;
        let payload = Payload {
            mass_kg: setup.payload_mass_kg,
            power_w: setup.payload_power_w,
        };
        let segments: Vec<Segment> = plan.iter().map(PlanLeg::segment).collect();
        let (summary, _) = model
            .evaluate_mission_vec(&battery, &payload, &segments, &MissionOptions::default())
            .map_err(|e| e.to_string())?;
        Ok(Self {
            predicted_end_s: takeoff_s + summary.total_min * 60.0,
        })
    }

    /// Predicted end of the flight, s (log time).
    pub fn predicted_end_s(&self) -> f64 {
        self.predicted_end_s
    }
}

impl Predictor for StaticModel {
    fn update(&mut self, s: &Sample) -> Option<Prediction> {
        Some(Prediction {
            remaining_s: (self.predicted_end_s - s.time_s).max(0.0),
            sigma_s: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, v: f64, i: f64) -> Sample {
        Sample {
            time_s: t,
            voltage_v: v,
            current_a: Some(i),
            phase: Some(Phase::Hover),
            motor_power_w: None,
        }
    }

    #[test]
    fn coulomb_counter_divides_what_is_left_by_the_current() {
        let mut c = CoulombCounter::new(2.0);
        let mut last = None;
        for k in 0..=3600 {
            last = c.update(&sample(f64::from(k), 11.5, 1.0));
        }
        // 1 Ah used of 2 Ah at 1 A: one hour left.
        let p = last.unwrap();
        assert!((p.remaining_s - 3600.0).abs() < 1.0, "{p:?}");
    }

    #[test]
    fn px4_converges_to_coulomb_counting_at_constant_current() {
        // A full pack at 4.05 V/cell under load: the voltage-based charge is near 1, the
        // counted one falls; after the average filter settles, remaining ≈ soc·C/I.
        let mut p = Px4TimeRemaining::new(Px4Params::defaults(3, 2000.0));
        let mut last = None;
        for k in 0..=600 {
            last = p.update(&sample(f64::from(k), 12.3, 8.0));
        }
        let r = last.unwrap().remaining_s;
        let used = 8.0 * 600.0 / 3600.0 * 1000.0;
        let expected = (2000.0 - used) / 8000.0 * 3600.0;
        assert!(
            r <= expected + 1.0 && r > 0.5 * expected,
            "{r} vs {expected}"
        );
    }

    #[test]
    fn current_methods_give_nothing_without_current() {
        let s = Sample {
            time_s: 0.0,
            voltage_v: 12.0,
            current_a: None,
            phase: None,
            motor_power_w: None,
        };
        assert!(CoulombCounter::new(1.0).update(&s).is_none());
        assert!(
            Px4TimeRemaining::new(Px4Params::defaults(3, 1000.0))
                .update(&s)
                .is_none()
        );
    }
}
