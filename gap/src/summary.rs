//! The gap on mission summaries: estimated against measured endurance, when only the totals
//! are known (the paper's Table I). The candidate explanation here is the form of eq. (8): the
//! printed form subtracts a time from a ratio, the consistent form does not.

use estimator::{Battery, Eq8Form, MissionOptions, Model, Payload, PowerCurve, Segment};
use serde::Serialize;

use crate::GapError;

/// One mission summary: what flew and how long it lasted.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionSummaryRow {
    /// Name.
    pub name: String,
    /// The plan flown.
    pub plan: Vec<Segment>,
    /// The plan as written.
    pub plan_text: String,
    /// Battery.
    pub battery: Battery,
    /// Payload.
    pub payload: Payload,
    /// Measured mean endurance, min.
    pub measured_mean_min: f64,
    /// Its standard deviation, min.
    pub measured_std_min: f64,
    /// Flights averaged.
    pub samples: u32,
}

/// The gap of one summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SummaryGap {
    /// Name.
    pub name: String,
    /// The plan.
    pub plan: String,
    /// Estimate with eq. (8) as printed, min.
    pub printed_min: f64,
    /// Estimate with the consistent eq. (8), min.
    pub consistent_min: f64,
    /// Measured mean, min.
    pub measured_mean_min: f64,
    /// Standard error of the measured mean, min (std / √samples).
    pub measured_standard_error_min: f64,
    /// Printed estimate minus measurement, min.
    pub gap_printed_min: f64,
    /// Consistent estimate minus measurement, min.
    pub gap_consistent_min: f64,
    /// How much of the printed estimate's gap the eq. (8) form accounts for, min (printed minus
    /// consistent).
    pub eq8_accounts_for_min: f64,
    /// That, as a fraction of the printed estimate's gap.
    pub eq8_share_of_gap: f64,
    /// The consistent estimate's gap in standard errors of the measurement.
    pub remaining_gap_in_standard_errors: f64,
}

/// Compares each summary's estimates (both forms of eq. 8) with its measurement.
pub fn explain<C: PowerCurve>(
    model: &Model<C>,
    rows: &[MissionSummaryRow],
) -> Result<Vec<SummaryGap>, GapError> {
    rows.iter()
        .map(|r| {
            let total = |eq8| -> Result<f64, GapError> {
                let (s, _) = model.evaluate_mission_vec(
                    &r.battery,
                    &r.payload,
                    &r.plan,
                    &MissionOptions {
                        eq8,
                        ..Default::default()
                    },
                )?;
                Ok(s.total_min)
            };
            let printed = total(Eq8Form::PrintedHours)?;
            let consistent = total(Eq8Form::Consistent)?;
            let m = r.measured_mean_min;
            let se = r.measured_std_min / f64::from(r.samples.max(1)).sqrt();
            let gp = printed - m;
            Ok(SummaryGap {
                name: r.name.clone(),
                plan: r.plan_text.clone(),
                printed_min: printed,
                consistent_min: consistent,
                measured_mean_min: m,
                measured_standard_error_min: se,
                gap_printed_min: gp,
                gap_consistent_min: consistent - m,
                eq8_accounts_for_min: printed - consistent,
                eq8_share_of_gap: if gp != 0.0 {
                    (printed - consistent) / gp
                } else {
                    0.0
                },
                remaining_gap_in_standard_errors: if se > 0.0 {
                    (consistent - m) / se
                } else {
                    f64::INFINITY
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::{FnCurve, Platform};

    #[test]
    fn table_i_through_the_reconstructed_curve() {
        let model = Model::new(
            FnCurve::new(
                |t: f64| 0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728),
                (0.0, 260.0),
            ),
            Platform {
                structure_mass_kg: 0.431,
                avionics_power_w: 2.44,
                rotor_count: 4,
            },
        );
        let row = MissionSummaryRow {
            name: "Table I".into(),
            plan: estimator::plan::parse_plan("3x(hover 2m; attach 30m); hover until empty")
                .unwrap(),
            plan_text: "3x(hover 2m; attach 30m); hover until empty".into(),
            battery: Battery::from_density(0.144, 164.0).unwrap(),
            payload: Payload::default(),
            measured_mean_min: 102.3,
            measured_std_min: 0.2,
            samples: 2,
        };
        let g = &explain(&model, &[row]).unwrap()[0];
        assert!((g.printed_min - 103.33).abs() < 0.01);
        assert!((g.consistent_min - 101.68).abs() < 0.01);
        // The printed form's error is larger than the whole gap: it overshoots it.
        assert!(g.eq8_share_of_gap > 1.0);
        assert!(g.gap_consistent_min < 0.0 && g.gap_printed_min > 0.0);
    }
}
