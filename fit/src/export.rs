//! A fit as the canonical parameter file, `params.toml` (see `estimator::file`).

use estimator::file::{
    CurveSection, FitSection, ParamsFile, Provenance, SCHEMA, SCHEMA_VERSION, ThrustLimitSection,
};

use crate::{PolyFit, ThrustLimit, ThrustLimitKind};

/// A thrust limit and the supply voltage of the sweep it came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitRecord {
    /// The extracted limit, per rotor.
    pub limit: ThrustLimit,
    /// Supply voltage of the limit sweep, V.
    pub supply_voltage_v: f64,
}

/// What the parameter file says about the fitted columns.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveLabels<'a> {
    /// Abscissa column (`thrust_g` for a characterisation).
    pub x: &'a str,
    /// Ordinate column (`power_w` for a characterisation).
    pub y: &'a str,
    /// Supply voltage of the sweep, when known, V.
    pub supply_voltage_v: Option<f64>,
}

/// Builds `params.toml` from a fit, an optional thrust limit and the provenance record.
pub fn params_file(
    fit: &PolyFit,
    labels: &CurveLabels<'_>,
    rotor_count: u8,
    limit: Option<&LimitRecord>,
    provenance: Provenance,
) -> ParamsFile {
    let stats = fit.stats();
    let (lo, hi) = fit.domain();
    let max = stats.max_residual;
    ParamsFile {
        schema: SCHEMA.to_owned(),
        schema_version: SCHEMA_VERSION,
        rotor_count,
        curve: CurveSection {
            x: labels.x.to_owned(),
            y: labels.y.to_owned(),
            degree: fit.degree(),
            center: fit.center(),
            scale: fit.scale(),
            coefficients_scaled: fit.coeffs_scaled().to_vec(),
            coefficients_monomial: fit.monomial_coefficients(),
            valid_min: lo,
            valid_max: hi,
            supply_voltage_v: labels.supply_voltage_v,
        },
        thrust_limit: limit.map(|l| ThrustLimitSection {
            per_rotor_g: l.limit.thrust_g,
            uncertainty_g: l.limit.uncertainty_g,
            total_kg: l.limit.thrust_g * f64::from(rotor_count) / 1000.0,
            supply_voltage_v: l.supply_voltage_v,
            method: match l.limit.kind {
                ThrustLimitKind::Plateau { .. } => "plateau".to_owned(),
                ThrustLimitKind::TopOfRange => "top_of_range".to_owned(),
            },
        }),
        fit: FitSection {
            n_points: stats.n_points,
            rmse: stats.rmse,
            r_squared: stats.r_squared,
            max_abs_residual: max.map(|m| m.abs_value),
            max_residual_at: max.map(|m| m.x),
            condition_number: stats.condition_number,
            coefficient_std_errors_scaled: stats.std_errors_scaled.clone().unwrap_or_default(),
            warnings: fit.warnings().iter().map(ToString::to_string).collect(),
        },
        provenance,
        battery: None,
        vehicle: None,
        motor: None,
    }
}
