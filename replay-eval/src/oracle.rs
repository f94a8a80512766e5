//! The oracle ablation: where the online estimator's error comes from. Each switch hands the
//! estimator one piece of the truth of the flight it replays (flight-sim's
//! [`FlightTruth`], recorded beside the flight, never in its files), so the drop of the error
//! with the switch on is what not knowing that piece costs; all switches on leave only the
//! filter's own structure (one RC pair where the pack has two, no hysteresis, no temperature,
//! a constant power where the pack's varies, the prediction's integration), and all but one
//! (leave-one-out) tell what a term costs once the others are known, the better budget when
//! terms interact.
//!
//! | switch | what the estimator is handed |
//! |---|---|
//! | `curve` | the pack's open-circuit curve, sampled at the section's 21 knots (made strictly rising by 0.1 mV where the truth is flat) |
//! | `capacity` | the capacity scale `truth capacity / the model's capacity` (after the replay's scaling to the flight's rated energy), σ 10⁻⁴, no random walk |
//! | `resistance` | the resistance scale: the pack's mean series resistance in the air (cells at their temperature, plus a worn connector's) over the model's, σ 10⁻⁴, no random walk; the RC pair stays the model's |
//! | `power` | the extra power: the pack's mean electrical power in the air minus the model's hover power, σ 0.1 % of the hover power, no random walk |
//! | `start` | the state of charge at the first sample, σ 10⁻⁴ |
//! | `sensors` | calibrated sensors on every flight of the scenario, training and held out ([`SensorErrors::Ideal`]) |
//!
//! The pieces are fused as measurements ([`estimator::online::OnlineEstimator::observe_state`])
//! right after the first sample. The estimator is built as [`replay::online::FileOnline`]
//! builds it (vehicle from the metadata, capacity and resistances scaled to the flight's rated
//! energy, a collapsed curve replaced by the LiPo table, the cut-off from the metadata), so
//! with every switch off it replays each flight exactly as the study does (tested). Nothing
//! here reaches `gap`, `estimator`'s defaults or the CLI.

use estimator::Params;
use estimator::online::{BatteryModel, FilterState, OCV_KNOTS, OnlineConfig, OnlineEstimator};
use flight_sim::{FlightTruth, SensorErrors};
use replay::methods::{FlightSetup, PlanLeg};
use replay::online::{FileOnline, Online, plan_segments};
use replay::{OnlineBuilder, OnlinePredictor};

/// Which pieces of the truth the estimator is handed (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct Oracle {
    /// The pack's open-circuit curve.
    pub curve: bool,
    /// The pack's capacity.
    pub capacity: bool,
    /// The pack's series resistance in the air.
    pub resistance: bool,
    /// The power above the model.
    pub power: bool,
    /// The state of charge at the first sample.
    pub start: bool,
    /// Calibrated sensors.
    pub sensors: bool,
}

impl Oracle {
    /// Nothing handed: the study as it is.
    pub const NONE: Oracle = Oracle {
        curve: false,
        capacity: false,
        resistance: false,
        power: false,
        start: false,
        sensors: false,
    };
    /// Everything handed: what remains is the filter's structure.
    pub const ALL: Oracle = Oracle {
        curve: true,
        capacity: true,
        resistance: true,
        power: true,
        start: true,
        sensors: true,
    };
    /// The switches' names.
    pub const TERMS: [&'static str; 6] = [
        "curve",
        "capacity",
        "resistance",
        "power",
        "start",
        "sensors",
    ];

    fn slot(&mut self, term: &str) -> Option<&mut bool> {
        Some(match term {
            "curve" => &mut self.curve,
            "capacity" => &mut self.capacity,
            "resistance" => &mut self.resistance,
            "power" => &mut self.power,
            "start" => &mut self.start,
            "sensors" => &mut self.sensors,
            _ => return None,
        })
    }

    /// Only `term` on.
    pub fn only(term: &str) -> Result<Oracle, String> {
        let mut o = Oracle::NONE;
        *o.slot(term).ok_or_else(|| unknown(term))? = true;
        Ok(o)
    }

    /// Every switch but `term` on.
    pub fn all_but(term: &str) -> Result<Oracle, String> {
        let mut o = Oracle::ALL;
        *o.slot(term).ok_or_else(|| unknown(term))? = false;
        Ok(o)
    }

    /// Parses `none`, `all`, `all-but-TERM` or a comma-separated list of terms.
    pub fn parse(spec: &str) -> Result<Oracle, String> {
        let spec = spec.trim();
        match spec {
            "" | "none" => return Ok(Oracle::NONE),
            "all" => return Ok(Oracle::ALL),
            _ => {}
        }
        if let Some(t) = spec.strip_prefix("all-but-") {
            return Oracle::all_but(t.trim());
        }
        let mut o = Oracle::NONE;
        for t in spec.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            *o.slot(t).ok_or_else(|| unknown(t))? = true;
        }
        Ok(o)
    }

    /// The switches on, as [`Oracle::parse`] reads them back (`none`, `all`, `all-but-…`,
    /// `curve,power`).
    pub fn name(&self) -> String {
        let mut on = Vec::new();
        let mut off = Vec::new();
        for t in Oracle::TERMS {
            let mut c = *self;
            if c.slot(t).is_some_and(|b| *b) {
                on.push(t);
            } else {
                off.push(t);
            }
        }
        match (on.len(), off.len()) {
            (0, _) => "none".to_owned(),
            (_, 0) => "all".to_owned(),
            (_, 1) => format!("all-but-{}", off[0]),
            _ => on.join(","),
        }
    }

    /// The sensors the scenario's flights are flown with.
    pub fn sensor_errors(&self) -> SensorErrors {
        if self.sensors {
            SensorErrors::Ideal
        } else {
            SensorErrors::Drawn
        }
    }

    /// Whether a switch other than `sensors` is on (the estimator needs the truth).
    pub fn hands_truth(&self) -> bool {
        self.curve || self.capacity || self.resistance || self.power || self.start
    }

    /// The leave-one-out budget's sets: nothing, each term alone, all, and all but each term.
    pub fn budget_set() -> Vec<Oracle> {
        let mut v = vec![Oracle::NONE];
        v.extend(Oracle::TERMS.iter().filter_map(|t| Oracle::only(t).ok()));
        v.push(Oracle::ALL);
        v.extend(Oracle::TERMS.iter().filter_map(|t| Oracle::all_but(t).ok()));
        v
    }
}

fn unknown(t: &str) -> String {
    format!(
        "unknown oracle term {t:?}: use none, all, all-but-TERM or a list of {}",
        Oracle::TERMS.join(", ")
    )
}

/// The pack's open-circuit curve at the section's knots, strictly rising.
pub fn truth_knots(truth: &FlightTruth) -> [f64; OCV_KNOTS] {
    let mut k = [0.0; OCV_KNOTS];
    for (i, v) in k.iter_mut().enumerate() {
        *v = truth.ocv.at(i as f64 / (OCV_KNOTS - 1) as f64);
    }
    for i in 1..OCV_KNOTS {
        if k[i] <= k[i - 1] {
            k[i] = k[i - 1] + 1e-4;
        }
    }
    k
}

/// The online estimator of one flight, with the pieces of its truth the oracle hands it.
#[derive(Debug, Clone)]
pub struct OracleOnline {
    /// Rig curve, rotors, thrust limit.
    pub params: Params,
    /// The learned pack model.
    pub battery: BatteryModel,
    /// The filter's configuration.
    pub config: OnlineConfig,
    /// The flight's truth.
    pub truth: FlightTruth,
    /// What is handed.
    pub oracle: Oracle,
}

impl OnlineBuilder for OracleOnline {
    fn build(
        &self,
        setup: &FlightSetup,
        plan: &[PlanLeg],
        takeoff_s: f64,
    ) -> Result<Box<dyn OnlinePredictor>, String> {
        // As `replay::online::FileOnline` builds it, then the oracle's pieces.
        let (mut battery, mut config) =
            FileOnline::new(self.params, self.battery, self.config).flight_model(setup)?;
        // The oracle's pieces.
        let o = self.oracle;
        let t = &self.truth;
        if o.curve {
            battery.ocv_cell_v = truth_knots(t);
        }
        if o.capacity {
            config.capacity_drift_per_sqrt_s = 0.0;
        }
        if o.resistance {
            config.resistance_drift_per_sqrt_s = 0.0;
        }
        if o.power {
            config.extra_power_drift_fraction_per_sqrt_s = 0.0;
        }
        let est = OnlineEstimator::new(&self.params, &battery, &config)
            .map_err(|e| format!("online estimator: {e}"))?;
        let mut pins = Vec::new();
        if o.capacity {
            pins.push((
                FilterState::CapacityScale,
                t.capacity_ah / battery.rated_capacity_ah,
                1e-4,
            ));
        }
        if o.resistance {
            let model_ohm = f64::from(battery.cells) * battery.series_resistance_cell_ohm;
            if model_ohm > 0.0 {
                pins.push((
                    FilterState::ResistanceScale,
                    t.mean_airborne_series_ohm / model_ohm,
                    1e-4,
                ));
            }
        }
        if o.power {
            let hover = est.model_hover_power_w();
            pins.push((
                FilterState::ExtraPowerW,
                t.mean_airborne_power_w - hover,
                1e-3 * hover,
            ));
        }
        if o.start {
            pins.push((FilterState::Soc, t.start_soc, 1e-4));
        }
        Ok(Box::new(
            Online::new(est, plan_segments(plan), takeoff_s).with_readings(pins),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_read_back() {
        for o in Oracle::budget_set() {
            assert_eq!(Oracle::parse(&o.name()).unwrap(), o, "{}", o.name());
        }
        assert_eq!(Oracle::budget_set().len(), 14);
        assert_eq!(Oracle::parse("power, start").unwrap().name(), "power,start");
        assert!(Oracle::parse("weather").is_err());
        assert!(Oracle::parse("all-but-weather").is_err());
        assert_eq!(Oracle::NONE.sensor_errors(), SensorErrors::Drawn);
        assert!(!Oracle::only("sensors").unwrap().hands_truth());
    }
}
