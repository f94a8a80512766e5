//! The online estimator (`estimator::online`) as a replayed method.
//!
//! Per flight it gets what firmware would have before take-off:
//! - the rig curve and the pack model of the parameter file (`[battery]`);
//! - the vehicle (masses and powers, eqs. 1–2) from the flight's metadata, else the file's
//!   `[vehicle]` section;
//! - the autopilot's cut-off voltage from the metadata (`cutoff_voltage_v` / cells), else the
//!   battery section's;
//! - the mission plan ([`crate::methods::mission_plan`]): the time on the ground before
//!   take-off, then the legs of the flight, the last one "hover until empty".
//!
//! A section whose open-circuit curve is degenerate (spans under
//! [`MIN_CURVE_SPAN_CELL_V`] from empty to full: a collapsed fit) is flown with the built-in
//! LiPo table instead.
//!
//! The `[battery]` section describes a pack type. When a flight's metadata gives a rated energy
//! that differs from the section's (another pack of the same cells and chemistry), the model's
//! capacity is scaled by the ratio of the rated energies and its resistances by the inverse (a
//! bigger pack of the same cells has proportionally lower resistance). Nothing measured in the
//! flight is used before it is sampled.

use estimator::file::ParamsFile;
use estimator::online::{
    BatteryModel, FilterState, FlightPhase, LIPO_OCV_CELL_V, MAX_PLAN_SEGMENTS, OCV_KNOTS,
    OnlineConfig, OnlineEstimator, Sample as OnlineSample, Vehicle,
};
use estimator::{MissionOptions, Params, Segment};
use flightlog::Phase;

use crate::methods::{FlightSetup, PlanLeg, Prediction, Predictor, Sample};
use crate::{OnlineBuilder, OnlinePredictor};

/// The online estimator built from a parameter file.
#[derive(Debug, Clone)]
pub struct FileOnline {
    params: Params,
    battery: BatteryModel,
    config: OnlineConfig,
}

impl FileOnline {
    /// From a parameter file with a `[battery]` section; the reason when it cannot run.
    pub fn from_file(file: &ParamsFile) -> Result<Self, String> {
        let params = file
            .to_params()
            .map_err(|e| flightlog::summary::error_chain(&e))?;
        let battery = params.battery.ok_or_else(|| {
            "the parameter file has no [battery] section (store one with `hoverbench battery learn`)"
                .to_owned()
        })?;
        let mut config = OnlineConfig::default();
        // A learned section says how far its curve may be off (fit RMSE, prior's pull).
        if let Some(b) = &file.battery {
            config.cutoff_curve_sigma_cell_v =
                b.curve_shape_sigma_cell_v(config.cutoff_curve_sigma_cell_v);
        }
        Ok(Self::new(params, battery, config))
    }

    /// The same with the thrust-limit end switched on or off
    /// ([`OnlineConfig::thrust_limit_end`]: it acts only with the parameters' `[thrust_limit]`
    /// and a logged current) and samples averaged over windows of `input_average_s` before the
    /// filter takes them (0: none), with the band that goes with them
    /// ([`OnlineConfig::with_opt_ins`]).
    pub fn with_opt_ins(mut self, input_average_s: f64, thrust_limit_end: bool) -> Self {
        self.config = self.config.with_opt_ins(input_average_s, thrust_limit_end);
        self
    }

    /// The same with the current sensor's zero read on the ground before take-off, or not
    /// ([`OnlineConfig::zero_current`]).
    #[must_use]
    pub fn with_zero_current(mut self, on: bool) -> Self {
        self.config.zero_current = on;
        self
    }

    /// The same with an absolute prior on a series resistance beyond the battery model's on
    /// flights that log no current, Ω at pack level (0: none;
    /// [`OnlineConfig::extra_resistance_sigma_ohm`]).
    #[must_use]
    pub fn with_extra_resistance_sigma_ohm(mut self, ohm: f64) -> Self {
        self.config.extra_resistance_sigma_ohm = ohm;
        self
    }

    /// The same with the series resistance reopened to this one-sigma, Ω at pack level, at a
    /// run of voltages far below the prediction in flight (0: never;
    /// [`OnlineConfig::resync_resistance_sigma_ohm`]).
    #[must_use]
    pub fn with_resync_resistance_sigma_ohm(mut self, ohm: f64) -> Self {
        self.config.resync_resistance_sigma_ohm = ohm;
        self
    }

    /// From parameters, a pack model and the filter's configuration.
    pub fn new(params: Params, battery: BatteryModel, config: OnlineConfig) -> Self {
        Self {
            params,
            battery,
            config,
        }
    }

    /// The pack model.
    pub fn battery(&self) -> &BatteryModel {
        &self.battery
    }
}

/// Least span of a usable open-circuit curve from empty to full, V per cell: every lithium
/// chemistry spans more (LiFePO₄ about 0.6 V, LiPo about 0.9 V).
pub const MIN_CURVE_SPAN_CELL_V: f64 = 0.3;

/// True when the pack model's open-circuit curve spans less than [`MIN_CURVE_SPAN_CELL_V`] (a
/// collapsed fit); [`FileOnline`] then flies the built-in LiPo table instead.
pub fn curve_is_degenerate(b: &BatteryModel) -> bool {
    b.ocv_cell_v[OCV_KNOTS - 1] - b.ocv_cell_v[0] < MIN_CURVE_SPAN_CELL_V
}

/// Phase of `flightlog` as the estimator's.
pub fn phase_of(p: Phase) -> FlightPhase {
    match p {
        Phase::Ground => FlightPhase::Ground,
        Phase::Hover => FlightPhase::Hover,
        Phase::Climb => FlightPhase::Climb,
        Phase::Descend => FlightPhase::Descend,
        Phase::Attached => FlightPhase::Attached,
        Phase::Transition => FlightPhase::Hover,
    }
}

impl FileOnline {
    /// The pack model and filter configuration for one flight: the vehicle from the metadata
    /// (else the file's), the pack scaled to the flight's rated energy, a degenerate curve
    /// replaced by the built-in LiPo table, the flight's cut-off. What [`OnlineBuilder::build`]
    /// starts the filter from; public so that a study can change a piece before it does.
    pub fn flight_model(
        &self,
        setup: &FlightSetup,
    ) -> Result<(BatteryModel, OnlineConfig), String> {
        let vehicle = match (
            setup.structure_mass_kg,
            setup.battery_mass_kg,
            setup.avionics_power_w,
        ) {
            (Some(s), Some(b), Some(a)) => Some(Vehicle {
                structure_mass_kg: s,
                battery_mass_kg: b,
                payload_mass_kg: setup.payload_mass_kg,
                avionics_power_w: a,
                payload_power_w: setup.payload_power_w,
            }),
            _ => self.params.vehicle,
        };
        let Some(vehicle) = vehicle else {
            return Err(
                "no vehicle: the metadata lacks structure_mass_kg, battery_mass_kg or avionics_power_w and the file has no [vehicle]"
                    .to_owned(),
            );
        };
        let mut battery = self.battery;
        if let Some(c) = setup.cells {
            if c != u32::from(battery.cells) {
                return Err(format!(
                    "the flight's pack has {c} cells, the [battery] section {}",
                    battery.cells
                ));
            }
        }
        if let Some(e) = setup.battery_energy_wh {
            let k = e / battery.energy_wh();
            if k.is_finite() && k > 0.0 && (k - 1.0).abs() > 0.01 {
                battery.rated_capacity_ah *= k;
                battery.series_resistance_cell_ohm /= k;
                battery.rc_resistance_cell_ohm /= k;
            }
        }
        if curve_is_degenerate(&battery) {
            // A learned curve that spans less than any lithium cell does from full to empty
            // (a collapsed fit) says nothing about the state of charge: fly the built-in LiPo
            // table instead, and let the filter's curve offset take up the difference.
            battery.ocv_cell_v = LIPO_OCV_CELL_V;
        }
        let mut config = self.config;
        config.vehicle = Some(vehicle);
        if let Some(v) = setup.cutoff_voltage_v {
            config.cutoff_cell_v = Some(v / f64::from(battery.cells));
        }
        Ok((battery, config))
    }

    /// The rig curve and masses the filter is started with.
    pub fn params(&self) -> &Params {
        &self.params
    }
}

/// The mission plan's legs as the estimator's segments; empty (fly without a plan: hover to
/// the cut-off from wherever the robot is) when there are more legs than the firmware's plan
/// buffer holds.
pub fn plan_segments(plan: &[PlanLeg]) -> Vec<Segment> {
    let mut segments: Vec<Segment> = plan.iter().map(PlanLeg::segment).collect();
    if segments.len() + 1 > MAX_PLAN_SEGMENTS {
        segments.clear();
    }
    segments
}

impl OnlineBuilder for FileOnline {
    fn build(
        &self,
        setup: &FlightSetup,
        plan: &[PlanLeg],
        takeoff_s: f64,
    ) -> Result<Box<dyn OnlinePredictor>, String> {
        let (battery, config) = self.flight_model(setup)?;
        let est = OnlineEstimator::new(&self.params, &battery, &config)
            .map_err(|e| format!("online estimator: {e}"))?;
        let readings = setup
            .capacity_reading
            .map(|(factor, sigma)| (FilterState::CapacityScale, factor, sigma))
            .into_iter()
            .collect();
        Ok(Box::new(
            Online::new(est, plan_segments(plan), takeoff_s).with_readings(readings),
        ))
    }
}

/// The online estimator flying one flight sample by sample, with its mission plan set at the
/// first sample.
pub struct Online {
    est: OnlineEstimator,
    segments: Vec<Segment>,
    takeoff_s: f64,
    plan_set: bool,
    last: Option<estimator::online::Estimate>,
    /// Outside readings of a state still to fuse, after the first valid sample
    /// ([`OnlineEstimator::observe_state`]).
    readings: Vec<(FilterState, f64, f64)>,
    /// The time and state of charge of the first valid estimate.
    start: Option<(f64, f64)>,
    /// The curve offset [`crate::history::SETTLED_AFTER_S`] after the first valid estimate, V
    /// (pack); until then the last one.
    settled_offset_v: f64,
    /// [`Self::settled_offset_v`] is final.
    settled: bool,
    /// The charge the estimator's current (logged, or its model's) drew since the first valid
    /// estimate, A·s, and the last (time, current).
    charge_as: f64,
    last_current: Option<(f64, f64)>,
}

impl Online {
    /// A filter, the plan's segments ([`plan_segments`]) and the take-off time.
    pub fn new(est: OnlineEstimator, segments: Vec<Segment>, takeoff_s: f64) -> Self {
        Self {
            est,
            segments,
            takeoff_s,
            plan_set: false,
            last: None,
            readings: Vec::new(),
            start: None,
            settled_offset_v: f64::NAN,
            settled: false,
            charge_as: 0.0,
            last_current: None,
        }
    }

    /// Outside readings `(state, value, sigma)` fused once, right after the first valid
    /// sample (a study's oracle; in the field, e.g. a charger's capacity measurement).
    #[must_use]
    pub fn with_readings(mut self, readings: Vec<(FilterState, f64, f64)>) -> Self {
        self.readings = readings;
        self
    }
}

impl Predictor for Online {
    fn update(&mut self, s: &Sample) -> Option<Prediction> {
        if !self.plan_set {
            self.plan_set = true;
            if !self.segments.is_empty() {
                let mut plan = Vec::with_capacity(self.segments.len() + 1);
                let ground = (self.takeoff_s - s.time_s).max(0.0);
                if ground > 0.0 {
                    plan.push(Segment::Attached {
                        duration_min: ground / 60.0,
                    });
                }
                plan.extend_from_slice(&self.segments);
                // The plan runs from the next sample; this one is on the ground anyway.
                let _ = self.est.set_plan(&plan, &MissionOptions::default());
            }
        }
        let e = self.est.update(&OnlineSample {
            time_s: s.time_s,
            voltage_v: s.voltage_v,
            current_a: s.current_a,
            phase: s.phase.map(phase_of),
            motor_power_w: s.motor_power_w,
        });
        if !e.is_valid() {
            return None;
        }
        for (state, value, sigma) in self.readings.drain(..) {
            // A value outside what the filter holds is clamped by it; an invalid one (not
            // finite) leaves the state alone.
            let _ = self.est.observe_state(state, value, sigma);
        }
        self.last = Some(e);
        if let Some((t, i)) = self.last_current {
            if s.time_s > t && e.current_a.is_finite() {
                self.charge_as += 0.5 * (i + e.current_a) * (s.time_s - t);
            }
        }
        if e.current_a.is_finite() {
            self.last_current = Some((s.time_s, e.current_a));
        }
        let (t0, _) = *self.start.get_or_insert((s.time_s, e.soc));
        if !self.settled {
            self.settled_offset_v = self.est.curve_offset_v().0;
            self.settled = s.time_s >= t0 + crate::history::SETTLED_AFTER_S;
        }
        Some(match (e.remaining_plan_s, e.remaining_plan_sigma_s) {
            (Some(r), sigma) => Prediction {
                remaining_s: r,
                sigma_s: sigma,
            },
            (None, _) => Prediction {
                remaining_s: e.remaining_phase_s,
                sigma_s: Some(e.remaining_phase_sigma_s),
            },
        })
    }
}

impl OnlinePredictor for Online {
    fn pack(&self) -> Option<BatteryModel> {
        Some(*self.est.battery())
    }

    fn final_state(&self) -> Vec<(&'static str, f64)> {
        self.last.map_or_else(Vec::new, |e| {
            vec![
                ("soc", e.soc),
                ("usable_capacity_ah", e.usable_capacity_ah),
                ("series_resistance_ohm", e.series_resistance_ohm),
                ("extra_power_w", e.extra_power_w),
                ("phase_power_w", e.phase_power_w),
                ("samples_rejected", f64::from(e.samples_rejected)),
                ("curve_offset_v", self.est.curve_offset_v().0),
                ("curve_offset_sigma_v", self.est.curve_offset_v().1),
                ("start_soc", self.start.map_or(f64::NAN, |x| x.1)),
                ("settled_curve_offset_v", self.settled_offset_v),
                ("estimator_charge_ah", self.charge_as / 3600.0),
            ]
            .into_iter()
            .chain(self.est.current_offset_a().map(|o| ("current_offset_a", o)))
            .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_collapsed_curve_is_degenerate_and_a_lipo_one_is_not() {
        let lipo = BatteryModel::lipo(3, 2.0).unwrap();
        assert!(!curve_is_degenerate(&lipo));
        let mut flat = lipo;
        for (k, v) in flat.ocv_cell_v.iter_mut().enumerate() {
            *v = 4.244 + 1e-4 * k as f64;
        }
        assert!(
            flat.validate().is_ok(),
            "strictly rising, so it passes validation"
        );
        assert!(curve_is_degenerate(&flat));
    }
}
