//! The paper's figures from its reproduction ([`paper::reproduce`]).

use std::path::Path;

use estimator::{Battery, MissionOptions, Payload};
use paper::{BATTERY_A, BATTERY_B, PUBLISHED, PaperBattery, Reproduction};

use crate::{
    Comparison, LimitMarker, MeasuredStep, MissionInput, NamedBattery, PayloadStudy, ReportError,
    ReportFiles, ReportInput, Sweep, write_report,
};

/// Payload powers of the paper's Fig. 6 (section IV-A: without and with an active 5 W payload), W.
pub const FIG6_PAYLOAD_POWERS_W: [f64; 2] = [0.0, 5.0];

fn named(b: &PaperBattery) -> Result<NamedBattery, ReportError> {
    Ok(NamedBattery {
        name: format!("{} ({})", b.name, b.product),
        battery: Battery::from_density(b.mass_kg, b.energy_density_wh_per_kg)
            .map_err(ReportError::estimate(b.name))?,
    })
}

impl ReportInput {
    /// The report of the paper's reproduction: Fig. 3 from the reconstructed sweep and its fit,
    /// Fig. 4 with both optima, Fig. 5 ranking Batteries A and B, Fig. 6 for A and B at 0 and
    /// 5 W, the timeline of Table I's plan with Battery-A, and the reproduced numbers beside the
    /// published ones.
    pub fn from_reproduction(r: &Reproduction) -> Result<Self, ReportError> {
        let model = r.model();
        let a = named(&BATTERY_A)?;
        let b = named(&BATTERY_B)?;
        let per_rotor_g = paper::IMPLIED_THRUST_LIMIT_KG * 1000.0 / f64::from(paper::ROTOR_COUNT);
        let realistic = r.optimum.realistic.unwrap_or(r.optimum.ideal);
        let published = "paper";
        let cmp = |what: &str, value: f64, reference: f64, unit: &str, source: &str| Comparison {
            what: what.to_owned(),
            value,
            reference,
            unit: unit.to_owned(),
            reference_source: source.to_owned(),
        };
        Ok(Self {
            title: "Energy Management for Indoor Hovering Robots, reproduced".to_owned(),
            model: crate::ReportModel::Platform(model),
            payload: Payload::default(),
            sweep: Some(Sweep {
                source: format!(
                    "the reconstructed curve sampled every {} g",
                    paper::THRUST_STEP_G
                ),
                label: "reconstructed curve, sampled".to_owned(),
                steps: r
                    .sweep_thrust_g
                    .iter()
                    .zip(&r.sweep_power_w)
                    .map(|(&thrust_g, &power_w)| MeasuredStep {
                        thrust_g,
                        power_w,
                        power_std_w: None,
                    })
                    .collect(),
            }),
            thrust_limit: Some(LimitMarker {
                per_rotor_g,
                uncertainty_g: 0.0,
                supply_voltage_v: Some(paper::MIN_BATTERY_VOLTAGE_V),
                note: Some("implied by the realistic optimum".to_owned()),
            }),
            energy_density_wh_per_kg: Some(paper::FIG4_ENERGY_DENSITY_WH_PER_KG),
            catalogue: vec![a.clone(), b.clone()],
            payload_study: Some(PayloadStudy {
                batteries: vec![a.clone(), b],
                payload_powers_w: FIG6_PAYLOAD_POWERS_W.to_vec(),
            }),
            flights: Vec::new(),
            mission: Some(MissionInput {
                plan: paper::TABLE_I_PLAN_TEXT.to_owned(),
                segments: paper::TABLE_I_PLAN.to_vec(),
                battery: a,
                options: MissionOptions::default(),
            }),
            comparisons: vec![
                cmp(
                    "Fig. 4 ideal optimum m_B",
                    r.optimum.ideal.battery_mass_kg,
                    PUBLISHED.ideal_battery_mass_kg,
                    "kg",
                    published,
                ),
                cmp(
                    "Fig. 4 ideal optimum t_E",
                    r.optimum.ideal.endurance_min,
                    PUBLISHED.ideal_endurance_min,
                    "min",
                    published,
                ),
                cmp(
                    "Fig. 4 realistic optimum m_B",
                    realistic.battery_mass_kg,
                    PUBLISHED.realistic_battery_mass_kg,
                    "kg",
                    published,
                ),
                cmp(
                    "Fig. 4 realistic optimum t_E",
                    realistic.endurance_min,
                    PUBLISHED.realistic_endurance_min,
                    "min",
                    published,
                ),
                cmp(
                    "Table I, eq. (8) as printed",
                    r.table_i_printed.total_min,
                    PUBLISHED.table_i_estimated_min,
                    "min",
                    "paper's estimate",
                ),
                cmp(
                    "Table I, consistent eq. (8)",
                    r.table_i_consistent.total_min,
                    PUBLISHED.table_i_measured_mean_min,
                    "min",
                    "measured mean (2 flights, std 0.2 min)",
                ),
            ],
            provenance: vec![
                (
                    "thrust curve".to_owned(),
                    "the paper's Fig. 3 as reconstructed in shared/reference/paper-targets.md, \
                     sampled and fitted with a degree-5 polynomial (not measured data)"
                        .to_owned(),
                ),
                (
                    "platform".to_owned(),
                    "constants from the paper's captions and text (paper crate)".to_owned(),
                ),
                (
                    "thrust limit".to_owned(),
                    "0.600 kg, implied by the paper's realistic optimum through eq. (5); its 9.0 V sweep is unpublished"
                        .to_owned(),
                ),
            ],
        })
    }
}

/// Writes the paper's figures (Fig. 3–7 as SVG and PNG) and its HTML report into `out_dir`.
pub fn paper_figures(r: &Reproduction, out_dir: &Path) -> Result<ReportFiles, ReportError> {
    write_report(&ReportInput::from_reproduction(r)?, out_dir)
}
