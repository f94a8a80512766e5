//! The paper's reference platform and its end-to-end reproduction.
//!
//! *Energy Management for Indoor Hovering Robots* publishes its results (Fig. 4's optima, the
//! endurance of Batteries A and B, Table I) but not its rig data. [`reconstructed_power_w`] is a
//! per-rotor curve that, pushed through the paper's own pipeline (sample every 10 g, fit a
//! fifth-order polynomial, eqs. 1–9 with the published constants), lands on every published
//! number; see `shared/reference/paper-targets.md`. [`reproduce`] runs that pipeline with this
//! workspace's `fit` and `estimator` crates.
//!
//! Main items: the platform constants ([`STRUCTURE_MASS_KG`], [`AVIONICS_POWER_W`], …), the
//! batteries ([`BATTERY_A`], [`BATTERY_B`]), the published figures ([`PUBLISHED`]) and
//! [`Reproduction`].
//!
//! ```
//! let r = paper::reproduce()?;
//! assert!((r.optimum.ideal.battery_mass_kg - paper::PUBLISHED.ideal_battery_mass_kg).abs() < 0.001);
//! assert!((r.table_i_printed.total_min - paper::PUBLISHED.table_i_estimated_min).abs() < 0.05);
//! # Ok::<(), paper::PaperError>(())
//! ```
//!
//! The thrust limit `m_L` is an *input* here: the paper does not publish its 9.0 V sweep, and
//! 0.600 kg (150 g per rotor) is what its realistic optimum (0.169 kg) implies through eq. (5).
//! The simulated rig measures it instead (`hoverbench characterise`).

use estimator::{
    Battery, BatteryOptimum, Eq8Form, Estimate, MissionOptions, MissionSummary, Model, Payload,
    Platform, PolyCurve, Segment,
};
use fit::PolyFit;

/// `m_S`: structure mass from the captions of Fig. 4–6, kg (the text's 416 g excludes some parts).
pub const STRUCTURE_MASS_KG: f64 = 0.431;
/// `p_A`: avionics power, W.
pub const AVIONICS_POWER_W: f64 = 2.44;
/// Rotors: two contra-rotating pairs of 200 mm propellers.
pub const ROTOR_COUNT: u8 = 4;
/// Supply voltage of the Fig. 3 sweep, V.
pub const NOMINAL_VOLTAGE_V: f64 = 12.5;
/// Minimum battery voltage (3.0 V per cell, 3S): the automatic-landing threshold, V.
pub const MIN_BATTERY_VOLTAGE_V: f64 = 9.0;
/// Maximum battery voltage (4.2 V per cell, 3S), V.
pub const MAX_BATTERY_VOLTAGE_V: f64 = 12.6;
/// Thrust increment of the rig, g.
pub const THRUST_STEP_G: f64 = 10.0;
/// Maximum thrust per rotor at maximum battery voltage (~2.55 N), g.
pub const MAX_THRUST_PER_ROTOR_G: f64 = 260.0;
/// Energy density of Fig. 4's optimisation, Wh/kg.
pub const FIG4_ENERGY_DENSITY_WH_PER_KG: f64 = 164.0;
/// `m_L` implied by the paper's realistic optimum through eq. (5), kg (150 g per rotor at 9.0 V).
pub const IMPLIED_THRUST_LIMIT_KG: f64 = 0.600;
/// Degree of the paper's fit.
pub const FIT_DEGREE: usize = 5;

/// A battery of the paper.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PaperBattery {
    /// Its name in the paper.
    pub name: &'static str,
    /// Product.
    pub product: &'static str,
    /// `m_B`, kg.
    pub mass_kg: f64,
    /// `e_D`, Wh/kg (from the text; Fig. 6's caption swaps A's and B's).
    pub energy_density_wh_per_kg: f64,
}

/// Battery-A, TP-2100-3S1P: the optimal pack of Fig. 5.
pub const BATTERY_A: PaperBattery = PaperBattery {
    name: "Battery-A",
    product: "TP-2100-3S1P",
    mass_kg: 0.144,
    energy_density_wh_per_kg: 164.0,
};
/// Battery-B, TP-1320-3S1P: a middle-of-the-range pack.
pub const BATTERY_B: PaperBattery = PaperBattery {
    name: "Battery-B",
    product: "TP-1320-3S1P",
    mass_kg: 0.085,
    energy_density_wh_per_kg: 172.0,
};

/// The paper's published figures.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Published {
    /// Fig. 4 ideal optimum battery mass, kg.
    pub ideal_battery_mass_kg: f64,
    /// Fig. 4 ideal optimum endurance, min.
    pub ideal_endurance_min: f64,
    /// Fig. 4 realistic optimum battery mass, kg.
    pub realistic_battery_mass_kg: f64,
    /// Fig. 4 realistic optimum endurance, min.
    pub realistic_endurance_min: f64,
    /// Table I estimate, min.
    pub table_i_estimated_min: f64,
    /// Table I measured mean, min.
    pub table_i_measured_mean_min: f64,
    /// Table I measured standard deviation, min.
    pub table_i_measured_std_min: f64,
    /// Table I samples.
    pub table_i_samples: u32,
    /// Table I error, %.
    pub table_i_error_pct: f64,
}

/// What the paper publishes.
pub const PUBLISHED: Published = Published {
    ideal_battery_mass_kg: 0.353,
    ideal_endurance_min: 19.76,
    realistic_battery_mass_kg: 0.169,
    realistic_endurance_min: 15.28,
    table_i_estimated_min: 103.3,
    table_i_measured_mean_min: 102.3,
    table_i_measured_std_min: 0.2,
    table_i_samples: 2,
    table_i_error_pct: 0.97,
};

/// Table I's mission: three times (2 min hover, 30 min attached), then hover until empty.
pub const TABLE_I_PLAN: [Segment; 7] = [
    Segment::Hover { duration_min: 2.0 },
    Segment::Attached { duration_min: 30.0 },
    Segment::Hover { duration_min: 2.0 },
    Segment::Attached { duration_min: 30.0 },
    Segment::Hover { duration_min: 2.0 },
    Segment::Attached { duration_min: 30.0 },
    Segment::HoverUntilEmpty,
];

/// The plan of [`TABLE_I_PLAN`] in the plan language.
pub const TABLE_I_PLAN_TEXT: &str = "3x(hover 2m; attach 30m); hover until empty";

/// The reconstructed Fig. 3 curve: per-rotor electrical power at 12.5 V for `thrust_g` grams,
/// `P(T) = 0.157434234·T + 0.341190317·(T/100)^5.34865728` W, 0 ≤ T ≤ 260 g.
///
/// Not measured data: it was solved for so that the paper's pipeline reproduces its published
/// numbers (`shared/reference/paper-targets.md`).
pub fn reconstructed_power_w(thrust_g: f64) -> f64 {
    0.157_434_234 * thrust_g + 0.341_190_317 * (thrust_g / 100.0).powf(5.348_657_28)
}

/// The reconstructed curve sampled like the paper's rig: every `step_g` from 0 to 260 g.
pub fn reconstructed_sweep(step_g: f64) -> (Vec<f64>, Vec<f64>) {
    let n = (MAX_THRUST_PER_ROTOR_G / step_g).floor() as usize;
    let thrust_g: Vec<f64> = (0..=n).map(|i| i as f64 * step_g).collect();
    let power_w = thrust_g.iter().map(|&t| reconstructed_power_w(t)).collect();
    (thrust_g, power_w)
}

/// Why the reproduction failed (it should not: this is a regression guard).
#[derive(Debug, thiserror::Error)]
pub enum PaperError {
    /// The polynomial fit failed.
    #[error("fitting the reconstructed curve")]
    Fit(#[from] fit::FitError),
    /// The estimator refused an input.
    #[error("estimating")]
    Estimate(#[from] estimator::EstimateError),
}

/// The paper's pipeline run end to end.
#[derive(Debug, Clone)]
pub struct Reproduction {
    /// Thrust of the sampled sweep, g.
    pub sweep_thrust_g: Vec<f64>,
    /// Power of the sampled sweep, W.
    pub sweep_power_w: Vec<f64>,
    /// The fifth-order fit.
    pub fit: PolyFit,
    /// The fit as the estimator's curve.
    pub curve: PolyCurve,
    /// Fig. 4: ideal and realistic optima at 164 Wh/kg without payload.
    pub optimum: BatteryOptimum,
    /// Battery-A without payload.
    pub battery_a: Estimate,
    /// Battery-B without payload.
    pub battery_b: Estimate,
    /// Table I with the consistent eq. (8).
    pub table_i_consistent: MissionSummary,
    /// Table I with eq. (8) as printed (times in hours).
    pub table_i_printed: MissionSummary,
}

impl Reproduction {
    /// The estimator model the reproduction used.
    pub fn model(&self) -> Model<PolyCurve> {
        paper_model(self.curve)
    }
}

/// The paper's platform around a curve, with the implied thrust limit.
pub fn paper_model<C: estimator::PowerCurve>(curve: C) -> Model<C> {
    Model::new(
        curve,
        Platform {
            structure_mass_kg: STRUCTURE_MASS_KG,
            avionics_power_w: AVIONICS_POWER_W,
            rotor_count: ROTOR_COUNT,
        },
    )
    .with_thrust_limit_kg(IMPLIED_THRUST_LIMIT_KG)
}

/// Turns a fit of power (W) against thrust (g) into the estimator's curve.
pub fn curve_from_fit(
    fit: &PolyFit,
    supply_voltage_v: f64,
) -> Result<PolyCurve, estimator::EstimateError> {
    PolyCurve::new(
        fit.coeffs_scaled(),
        fit.center(),
        fit.scale(),
        fit.domain(),
        Some(supply_voltage_v),
    )
}

/// The reconstructed curve sampled every 10 g and fitted with a fifth-order polynomial, as the
/// paper's Fig. 3: the fit and the estimator's curve made from it.
pub fn fitted_curve() -> Result<(PolyFit, PolyCurve), PaperError> {
    let (thrust_g, power_w) = reconstructed_sweep(THRUST_STEP_G);
    let fit = fit::fit_polynomial(&thrust_g, &power_w, FIT_DEGREE)?;
    let curve = curve_from_fit(&fit, NOMINAL_VOLTAGE_V)?;
    Ok((fit, curve))
}

/// Runs the paper's pipeline on the reconstructed curve: sample every 10 g, fit a fifth-order
/// polynomial, optimise the battery (Fig. 4), estimate Batteries A and B, evaluate Table I with
/// both forms of eq. (8).
pub fn reproduce() -> Result<Reproduction, PaperError> {
    let (thrust_g, power_w) = reconstructed_sweep(THRUST_STEP_G);
    let (fit, curve) = fitted_curve()?;
    let model = paper_model(curve);
    let none = Payload::default();
    let optimum = model.optimise_battery(FIG4_ENERGY_DENSITY_WH_PER_KG, &none)?;
    let battery = |b: &PaperBattery| Battery::from_density(b.mass_kg, b.energy_density_wh_per_kg);
    let battery_a = model.estimate(&battery(&BATTERY_A)?, &none)?;
    let battery_b = model.estimate(&battery(&BATTERY_B)?, &none)?;
    let table_i = |eq8| {
        model
            .evaluate_mission_vec(
                &battery(&BATTERY_A)?,
                &none,
                &TABLE_I_PLAN,
                &MissionOptions {
                    eq8,
                    ..Default::default()
                },
            )
            .map(|(s, _)| s)
    };
    Ok(Reproduction {
        table_i_consistent: table_i(Eq8Form::Consistent)?,
        table_i_printed: table_i(Eq8Form::PrintedHours)?,
        sweep_thrust_g: thrust_g,
        sweep_power_w: power_w,
        fit,
        curve,
        optimum,
        battery_a,
        battery_b,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reconstruction column of `paper-targets.md`: masses ±0.001 kg, endurances ±0.01 min.
    #[test]
    fn reproduces_the_reconstruction_column() {
        let r = reproduce().unwrap();
        let ideal = r.optimum.ideal;
        let realistic = r.optimum.realistic.unwrap();
        let close = |got: f64, want: f64, tol: f64, what: &str| {
            assert!(
                (got - want).abs() <= tol,
                "{what}: got {got}, want {want} ± {tol}"
            );
        };
        close(ideal.battery_mass_kg, 0.3529, 0.001, "ideal m_B");
        close(ideal.endurance_min, 19.762, 0.01, "ideal t_E");
        close(realistic.battery_mass_kg, 0.1690, 0.001, "realistic m_B");
        close(realistic.endurance_min, 15.278, 0.01, "realistic t_E");
        close(r.battery_a.endurance_min, 13.826, 0.01, "Battery-A t_E");
        close(r.battery_b.endurance_min, 9.854, 0.01, "Battery-B t_E");
        close(r.table_i_printed.total_min, 103.33, 0.01, "Table I printed");
        close(
            r.table_i_consistent.total_min,
            101.68,
            0.01,
            "Table I consistent",
        );
        assert!(r.optimum.realistic_is_limited);
    }

    #[test]
    fn reconstructed_curve_rows() {
        for (t, p) in [
            (50.0, 7.880),
            (100.0, 16.085),
            (150.0, 26.599),
            (200.0, 45.390),
            (250.0, 85.219),
            (260.0, 97.498),
        ] {
            assert!((reconstructed_power_w(t) - p).abs() < 0.0005, "{t} g");
        }
        let (x, y) = reconstructed_sweep(10.0);
        assert_eq!(x.len(), 27);
        assert_eq!(y[0], 0.0);
    }
}
