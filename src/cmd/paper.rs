//! `hoverbench paper`: the paper reproduced end to end from its reconstructed Fig. 3 curve.

use anyhow::Result;
use paper::{BATTERY_A, BATTERY_B, PUBLISHED, Reproduction};

use crate::output::{self, Table};

/// Reproduce the paper end to end: Fig. 3 sampled every 10 g and fitted (degree 5), Fig. 4's
/// optima, Batteries A and B, and Table I with both forms of eq. (8).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
    /// Also draw the paper's figures (Fig. 3-7, SVG and PNG) and report.html into this folder.
    #[arg(long, value_name = "DIR")]
    figures: Option<std::path::PathBuf>,
}

#[derive(serde::Serialize)]
struct Optimum {
    battery_mass_kg: f64,
    endurance_min: f64,
}

#[derive(serde::Serialize)]
struct BatteryResult {
    name: &'static str,
    product: &'static str,
    battery_mass_kg: f64,
    energy_density_wh_per_kg: f64,
    endurance_min: f64,
    payload_limit_kg: Option<f64>,
}

#[derive(serde::Serialize)]
struct TableI {
    plan: &'static str,
    printed_eq8_min: f64,
    consistent_eq8_min: f64,
    published_estimate_min: f64,
    measured_mean_min: f64,
    measured_std_min: f64,
    measured_samples: u32,
    printed_error_pct: f64,
    consistent_error_pct: f64,
}

#[derive(serde::Serialize)]
struct FitSummary {
    points: usize,
    thrust_step_g: f64,
    supply_voltage_v: f64,
    degree: usize,
    coefficients: Vec<f64>,
    rmse_w: f64,
    r_squared: f64,
}

#[derive(serde::Serialize)]
struct Report {
    fit: FitSummary,
    thrust_limit_kg: f64,
    ideal: Optimum,
    realistic: Optimum,
    batteries: Vec<BatteryResult>,
    table_i: TableI,
    published: paper::Published,
}

fn report(r: &Reproduction) -> Report {
    let realistic = r.optimum.realistic.unwrap_or(r.optimum.ideal);
    let measured = PUBLISHED.table_i_measured_mean_min;
    let err = |v: f64| (v - measured) / measured * 100.0;
    let battery = |b: &paper::PaperBattery, e: &estimator::Estimate| BatteryResult {
        name: b.name,
        product: b.product,
        battery_mass_kg: b.mass_kg,
        energy_density_wh_per_kg: b.energy_density_wh_per_kg,
        endurance_min: e.endurance_min,
        payload_limit_kg: e.payload_limit_kg,
    };
    Report {
        fit: FitSummary {
            points: r.sweep_thrust_g.len(),
            thrust_step_g: paper::THRUST_STEP_G,
            supply_voltage_v: paper::NOMINAL_VOLTAGE_V,
            degree: r.fit.degree(),
            coefficients: r.fit.monomial_coefficients(),
            rmse_w: r.fit.stats().rmse,
            r_squared: r.fit.stats().r_squared,
        },
        thrust_limit_kg: paper::IMPLIED_THRUST_LIMIT_KG,
        ideal: Optimum {
            battery_mass_kg: r.optimum.ideal.battery_mass_kg,
            endurance_min: r.optimum.ideal.endurance_min,
        },
        realistic: Optimum {
            battery_mass_kg: realistic.battery_mass_kg,
            endurance_min: realistic.endurance_min,
        },
        batteries: vec![
            battery(&BATTERY_A, &r.battery_a),
            battery(&BATTERY_B, &r.battery_b),
        ],
        table_i: TableI {
            plan: paper::TABLE_I_PLAN_TEXT,
            printed_eq8_min: r.table_i_printed.total_min,
            consistent_eq8_min: r.table_i_consistent.total_min,
            published_estimate_min: PUBLISHED.table_i_estimated_min,
            measured_mean_min: measured,
            measured_std_min: PUBLISHED.table_i_measured_std_min,
            measured_samples: PUBLISHED.table_i_samples,
            printed_error_pct: err(r.table_i_printed.total_min),
            consistent_error_pct: err(r.table_i_consistent.total_min),
        },
        published: PUBLISHED,
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let r = paper::reproduce()?;
    let rep = report(&r);
    let written = match &args.figures {
        Some(dir) => reports::paper_figures(&r, dir)?
            .paths()
            .into_iter()
            .map(std::path::Path::to_path_buf)
            .collect(),
        None => Vec::new(),
    };
    if args.json {
        return output::print_json(&rep);
    }
    println!(
        "Reproducing \"Energy Management for Indoor Hovering Robots\" from its reconstructed Fig. 3 curve"
    );
    println!(
        "Fig. 3: {} points every {} g at {} V, fitted with a degree-{} polynomial (RMSE {:.4} W, R² {:.6})",
        rep.fit.points,
        rep.fit.thrust_step_g,
        rep.fit.supply_voltage_v,
        rep.fit.degree,
        rep.fit.rmse_w,
        rep.fit.r_squared
    );
    println!(
        "Platform: m_S = {} kg, p_A = {} W, {} rotors; m_L = {:.3} kg (implied by the paper's realistic optimum)",
        paper::STRUCTURE_MASS_KG,
        paper::AVIONICS_POWER_W,
        paper::ROTOR_COUNT,
        rep.thrust_limit_kg
    );
    println!();
    let mut t = Table::new(&["result", "reproduced", "paper"]);
    let kg = |v: f64| format!("{v:.4} kg");
    let min = |v: f64| format!("{v:.2} min");
    t.row(vec![
        "Fig. 4 ideal optimum m_B".into(),
        kg(rep.ideal.battery_mass_kg),
        format!("{} kg", PUBLISHED.ideal_battery_mass_kg),
    ]);
    t.row(vec![
        "Fig. 4 ideal optimum t_E".into(),
        min(rep.ideal.endurance_min),
        format!("{} min", PUBLISHED.ideal_endurance_min),
    ]);
    t.row(vec![
        "Fig. 4 realistic optimum m_B".into(),
        kg(rep.realistic.battery_mass_kg),
        format!("{} kg", PUBLISHED.realistic_battery_mass_kg),
    ]);
    t.row(vec![
        "Fig. 4 realistic optimum t_E".into(),
        min(rep.realistic.endurance_min),
        format!("{} min", PUBLISHED.realistic_endurance_min),
    ]);
    for b in &rep.batteries {
        t.row(vec![
            format!(
                "{} ({}, {} kg, {} Wh/kg) t_E",
                b.name, b.product, b.battery_mass_kg, b.energy_density_wh_per_kg
            ),
            min(b.endurance_min),
            "not published".into(),
        ]);
    }
    print!("{}", t.render());
    println!();
    let ti = &rep.table_i;
    println!("Table I, Battery-A: {}", ti.plan);
    let mut t = Table::new(&["eq. (8) form", "estimate", "vs measured", "paper"]);
    t.row(vec![
        "printed: r_Ep = r_E - t_E·t_A/t_C (hours)".into(),
        min(ti.printed_eq8_min),
        format!("{:+.2} %", ti.printed_error_pct),
        format!("{} min", ti.published_estimate_min),
    ]);
    t.row(vec![
        "consistent: r_Ep = r_E - t_A/t_C".into(),
        min(ti.consistent_eq8_min),
        format!("{:+.2} %", ti.consistent_error_pct),
        "-".into(),
    ]);
    t.row(vec![
        "measured (mean ± std)".into(),
        format!("{} ± {} min", ti.measured_mean_min, ti.measured_std_min),
        format!("n = {}", ti.measured_samples),
        format!("{} min", ti.measured_mean_min),
    ]);
    print!("{}", t.render());
    println!();
    println!(
        "Errors are (estimate - measured) / measured; the paper's 0.97 % divides by the estimate instead."
    );
    println!(
        "The printed eq. (8) subtracts a time from a ratio; its value depends on the time unit."
    );
    println!(
        "hoverbench uses the consistent form by default (--eq8 printed reproduces the paper)."
    );
    for path in written {
        println!("wrote {}", path.display());
    }
    Ok(())
}
