//! `hoverbench estimate`: eqs. (1)–(6) for one battery and payload.

use anyhow::Result;
use estimator::Battery;

use crate::output::{self, ModelArgs, Table};

/// Estimate hover endurance for one battery and payload.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// m_B: battery mass (kg; or e.g. 144g).
    #[arg(long, value_name = "MASS", value_parser = output::positive_mass_kg, allow_negative_numbers = true)]
    battery_mass: f64,
    /// e_D: battery energy density (Wh/kg); c_B = e_D · m_B (eq. 3).
    #[arg(long, value_name = "WH_PER_KG", value_parser = output::energy_density, allow_negative_numbers = true, required_unless_present = "battery_energy", conflicts_with = "battery_energy")]
    energy_density: Option<f64>,
    /// c_B: battery energy (Wh), instead of --energy-density.
    #[arg(long, value_name = "WH", value_parser = output::energy_wh, allow_negative_numbers = true)]
    battery_energy: Option<f64>,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Report<'a> {
    source: &'a output::ModelSource,
    total_mass_kg: f64,
    idle_power_w: f64,
    battery_energy_wh: f64,
    thrust_per_rotor_g: f64,
    motor_power_w: f64,
    endurance_min: f64,
    ceiling_endurance_min: f64,
    payload_limit_kg: Option<f64>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let (model, payload, source) = args.model.build()?;
    let battery = match (args.energy_density, args.battery_energy) {
        (_, Some(wh)) => Battery::new(args.battery_mass, wh)?,
        (Some(d), None) => Battery::from_density(args.battery_mass, d)?,
        (None, None) => anyhow::bail!("give --energy-density or --battery-energy"),
    };
    let e = model.estimate(&battery, &payload)?;
    if args.json {
        return output::print_json(&Report {
            source: &source,
            total_mass_kg: e.total_mass_kg,
            idle_power_w: e.idle_power_w,
            battery_energy_wh: e.battery_energy_wh,
            thrust_per_rotor_g: e.thrust_per_rotor_g,
            motor_power_w: e.motor_power_w,
            endurance_min: e.endurance_min,
            ceiling_endurance_min: e.ceiling_endurance_min,
            payload_limit_kg: e.payload_limit_kg,
        });
    }
    println!("curve: {}", source.curve);
    println!("thrust limit: {}", source.thrust_limit);
    println!();
    let mut t = Table::new(&["quantity", "value", "equation"]);
    let mut row = |q: &str, v: String, eq: &str| t.row(vec![q.into(), v, eq.into()]);
    row(
        "take-off mass m_T",
        format!("{:.3} kg", e.total_mass_kg),
        "(1)",
    );
    row("idle power p_I", format!("{:.2} W", e.idle_power_w), "(2)");
    row(
        "battery energy c_B",
        format!("{:.2} Wh", e.battery_energy_wh),
        "(3)",
    );
    row(
        "thrust per rotor",
        format!("{:.1} g", e.thrust_per_rotor_g),
        "m_T / rotors",
    );
    row(
        "motor power p_M",
        format!("{:.2} W", e.motor_power_w),
        "Fig. 3 × rotors",
    );
    row(
        "flight endurance t_E",
        format!("{:.2} min", e.endurance_min),
        "(4)",
    );
    if let Some(m_x) = e.payload_limit_kg {
        row("payload limit m_X", format!("{m_x:.3} kg"), "(5)");
    }
    row(
        "ceiling endurance t_C",
        format!("{:.1} min", e.ceiling_endurance_min),
        "(6)",
    );
    print!("{}", t.render());
    Ok(())
}
