//! Hover endurance estimation after *Energy Management for Indoor Hovering Robots*: equations
//! (1)–(9), battery optimisation and missions with ceiling attachment.
//!
//! The crate is `no_std` and never allocates, so the same code runs in flight firmware and on the
//! bench. The `std` feature adds reading and writing the canonical `params.toml`
//! ([`file::ParamsFile`]), the mission plan language ([`plan::parse_plan`]) and nothing else.
//!
//! Main types:
//! - [`PowerCurve`]: per-rotor thrust (g) → electrical power (W), the paper's Fig. 3;
//!   [`PolyCurve`] is the fitted polynomial `fit` produces.
//! - [`Model`]: curve + [`Platform`] (+ thrust limit `m_L`): [`Model::estimate`] (eqs. 1–6),
//!   [`Model::optimise_battery`] (Fig. 4), [`Model::rank_entry`] (Fig. 5),
//!   [`Model::evaluate_mission`] (eqs. 7–9, Table I).
//! - [`MotorMap`]: per-rotor electrical power from the ESC command and the supply voltage
//!   (not in the paper; fitted by `fit` from the rig's two sweeps), for flight controllers that
//!   log commands but no current.
//! - [`Params`]: what firmware needs from a characterisation, with an allocation-free binary
//!   form ([`Params::decode`]).
//!
//! The equations are also free functions named for what they compute
//! ([`flight_endurance_min`], [`post_ceiling_ratio`], …), each documented with its number.
//!
//! ```
//! use estimator::{Battery, FnCurve, Model, Payload, Platform};
//!
//! // A per-rotor curve (here the paper's reconstructed Fig. 3), valid from 0 to 260 g.
//! let curve = FnCurve::new(
//!     |t: f64| 0.157434234 * t + 0.341190317 * libm::pow(t / 100.0, 5.34865728),
//!     (0.0, 260.0),
//! );
//! let platform = Platform { structure_mass_kg: 0.431, avionics_power_w: 2.44, rotor_count: 4 };
//! let model = Model::new(curve, platform).with_thrust_limit_kg(0.600);
//!
//! // Battery-A: 0.144 kg at 164 Wh/kg, no payload.
//! let battery = Battery::from_density(0.144, 164.0)?;
//! let e = model.estimate(&battery, &Payload::default())?;
//! assert!((e.endurance_min - 13.83).abs() < 0.01);
//!
//! // Fig. 4: the realistic optimum is clamped by the payload limit at 0.169 kg.
//! let opt = model.optimise_battery(164.0, &Payload::default())?;
//! assert!((opt.ideal.battery_mass_kg - 0.353).abs() < 0.001);
//! assert!((opt.realistic.unwrap().battery_mass_kg - 0.169).abs() < 0.001);
//! # Ok::<(), estimator::EstimateError>(())
//! ```
//!
//! Invariants: no I/O and no allocation outside the `std` modules; a curve is never
//! extrapolated past its measured range; a mass over the payload limit is an error value except
//! in catalogue ranking, where the paper ranks such packs at zero (and [`RankedEndurance`] says
//! so).

#![cfg_attr(not(any(test, feature = "std")), no_std)]

mod curve;
mod error;
mod mission;
mod model;
pub mod motor;
pub mod online;
mod optimise;
pub mod params;

#[cfg(feature = "std")]
pub mod file;
#[cfg(feature = "std")]
pub mod plan;

pub use curve::{FnCurve, MAX_DEGREE, PolyCurve, PowerCurve};
pub use error::EstimateError;
pub use mission::{Depletion, MissionOptions, MissionSummary, Segment, SegmentOutcome};
pub use model::{
    Battery, Eq8Form, Estimate, MIN_PER_H, Model, Payload, Platform, battery_energy_wh,
    ceiling_endurance_min, flight_endurance_min, idle_power_w, payload_limit_kg,
    post_ceiling_ratio, reserve_ratio, reserved_endurance_min, total_mass_kg,
};
pub use motor::MotorMap;
pub use optimise::{BatteryOptimum, LIPO_NOMINAL_CELL_V, Optimum, RankedEndurance, pack_energy_wh};
pub use params::{Params, ThrustLimit};

impl Params {
    /// The estimator model these parameters describe, for a platform of the given structure mass
    /// and avionics power (the rotor count comes from the parameters).
    pub fn model(&self, structure_mass_kg: f64, avionics_power_w: f64) -> Model<PolyCurve> {
        let mut m = Model::new(
            self.curve,
            Platform {
                structure_mass_kg,
                avionics_power_w,
                rotor_count: self.rotor_count,
            },
        );
        m.thrust_limit_kg = self.thrust_limit_kg();
        m
    }
}

#[cfg(feature = "std")]
impl<C: PowerCurve> Model<C> {
    /// Evaluates a mission into a `Vec` of outcomes (one per evaluated segment).
    pub fn evaluate_mission_vec(
        &self,
        battery: &Battery,
        payload: &Payload,
        plan: &[Segment],
        options: &MissionOptions,
    ) -> Result<(MissionSummary, Vec<SegmentOutcome>), EstimateError> {
        let mut out = vec![SegmentOutcome::EMPTY; plan.len()];
        let s = self.evaluate_mission(battery, payload, plan, options, &mut out)?;
        out.truncate(s.segments_evaluated);
        Ok((s, out))
    }
}
