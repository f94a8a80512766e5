//! `hoverbench report`: the figures of a characterisation (Fig. 3–7 as SVG and PNG) and a
//! self-contained HTML report.

use std::path::{Path, PathBuf};

use anyhow::Result;
use estimator::{Eq8Form, Payload};

use crate::output;

/// Which form of eq. (8) the mission timeline uses.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Eq8 {
    /// r_Ep = r_E - t_A/t_C: the energy balance (default).
    Consistent,
    /// r_Ep = r_E - t_E·t_A/t_C with times in hours, as printed in the paper.
    Printed,
}

/// Draw the figures of a characterisation (Fig. 3-7, SVG and PNG) and write a self-contained
/// HTML report.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A session folder (params.toml, optional sweep.csv and limit.csv) or a params.toml file.
    #[arg(value_name = "SESSION_OR_PARAMS")]
    input: PathBuf,
    /// Write the figures and report.html into this folder (created if needed).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The nominal sweep CSV for Fig. 3's measured steps (columns thrust_g, power_w or
    /// voltage_v × current_a, optional power_std_w) [default: the session's sweep.csv, else the
    /// params file's provenance.input_file].
    #[arg(long, value_name = "CSV")]
    sweep: Option<PathBuf>,
    /// Battery catalogue CSV for Fig. 5 (name, cells, capacity_mah, mass_g, optional energy_wh
    /// or energy_density_wh_per_kg).
    #[arg(long, value_name = "CSV")]
    catalogue: Option<PathBuf>,
    /// A mission plan for the timeline, e.g. "3x(hover 2m; attach 30m); hover until empty".
    #[arg(long, value_name = "PLAN")]
    plan: Option<String>,
    /// Measured flights CSV for Fig. 6 (battery, payload_mass_kg, payload_power_w,
    /// endurance_mean_min, optional endurance_std_min and samples).
    #[arg(long, value_name = "CSV")]
    flights: Option<PathBuf>,
    /// m_S: structure mass without battery (kg; or e.g. 431g) [default: the session's
    /// platform.toml]. Without a platform only Fig. 3 is drawn.
    #[arg(long, value_name = "MASS", value_parser = output::mass_kg, allow_negative_numbers = true, requires = "avionics_power")]
    structure_mass: Option<f64>,
    /// p_A: avionics power (W) [default: the session's platform.toml].
    #[arg(long, value_name = "POWER", value_parser = output::power_w, allow_negative_numbers = true, requires = "structure_mass")]
    avionics_power: Option<f64>,
    /// m_P: payload mass for Fig. 4, Fig. 5 and the mission (kg).
    #[arg(long, value_name = "MASS", value_parser = output::mass_kg, allow_negative_numbers = true, default_value = "0")]
    payload_mass: f64,
    /// p_P: payload power for Fig. 4, Fig. 5 and the mission (W).
    #[arg(long, value_name = "POWER", value_parser = output::power_w, allow_negative_numbers = true, default_value = "0")]
    payload_power: f64,
    /// Override the thrust limit m_L, total over all rotors (kg).
    #[arg(long, value_name = "MASS", value_parser = output::positive_mass_kg, allow_negative_numbers = true)]
    thrust_limit: Option<f64>,
    /// e_D of Fig. 4's batteries (Wh/kg) [default: the paper's 164 Wh/kg].
    #[arg(long, value_name = "WH_PER_KG", value_parser = output::energy_density, allow_negative_numbers = true)]
    energy_density: Option<f64>,
    /// m_B of a battery to fly the mission and draw in Fig. 6 (kg) [default: the best pack of
    /// --catalogue].
    #[arg(long, value_name = "MASS", value_parser = output::positive_mass_kg, allow_negative_numbers = true, requires = "battery_energy_density")]
    battery_mass: Option<f64>,
    /// e_D of the --battery-mass battery (Wh/kg).
    #[arg(long, value_name = "WH_PER_KG", value_parser = output::energy_density, allow_negative_numbers = true, requires = "battery_mass")]
    battery_energy_density: Option<f64>,
    /// Payload powers of Fig. 6's lines (W), comma-separated.
    #[arg(long, value_name = "W,W", value_parser = output::power_w, value_delimiter = ',', default_value = "0,5")]
    payload_powers: Vec<f64>,
    /// Form of eq. (8) for the mission.
    #[arg(long, value_enum, default_value = "consistent")]
    eq8: Eq8,
    /// Print the written files as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let written = write(&args)?;
    if args.json {
        return output::print_json(&serde_json::json!({ "written": written }));
    }
    for w in &written {
        println!("wrote {w}");
    }
    Ok(())
}

/// Draws a characterisation session's figures into `SESSION/report`, as
/// `hoverbench report SESSION -o SESSION/report` would; with a battery (mass kg, Wh/kg) also
/// Fig. 6 and the timeline of `plan`.
pub fn session_figures(
    session: &Path,
    structure_mass_kg: f64,
    avionics_power_w: f64,
    battery: Option<(f64, f64)>,
    plan: Option<String>,
) -> Result<Vec<String>> {
    write(&Args {
        input: session.to_path_buf(),
        output: session.join("report"),
        sweep: None,
        catalogue: None,
        plan,
        flights: None,
        structure_mass: Some(structure_mass_kg),
        avionics_power: Some(avionics_power_w),
        payload_mass: 0.0,
        payload_power: 0.0,
        thrust_limit: None,
        energy_density: None,
        battery_mass: battery.map(|b| b.0),
        battery_energy_density: battery.map(|b| b.1),
        payload_powers: vec![0.0, 5.0],
        eq8: Eq8::Consistent,
        json: false,
    })
}

fn write(args: &Args) -> Result<Vec<String>> {
    let written_by = format!(
        "written {} by hoverbench {}",
        humantime::format_rfc3339_seconds(std::time::SystemTime::now()),
        env!("CARGO_PKG_VERSION")
    );
    // The platform: the flags, else the session's platform.toml, else Fig. 3 alone.
    let stored = if args.input.is_dir() {
        reports::session::SessionPlatform::load(&args.input)?
    } else {
        None
    };
    let (Some(structure_mass_kg), Some(avionics_power_w)) = (
        args.structure_mass.or(stored.map(|p| p.structure_mass_kg)),
        args.avionics_power.or(stored.map(|p| p.avionics_power_w)),
    ) else {
        // A params file alone: Fig. 3 and the HTML; everything else needs the platform.
        let needs_platform = [
            (args.catalogue.is_some(), "--catalogue"),
            (args.plan.is_some(), "--plan"),
            (args.flights.is_some(), "--flights"),
            (args.battery_mass.is_some(), "--battery-mass"),
            (args.energy_density.is_some(), "--energy-density"),
        ];
        if let Some((_, flag)) = needs_platform.iter().find(|(given, _)| *given) {
            anyhow::bail!(
                "{flag} needs the platform: give --structure-mass and --avionics-power (without them only Fig. 3 is drawn)"
            );
        }
        let files = reports::write_curve_report(
            &args.input,
            args.sweep.as_deref(),
            &args.output,
            &written_by,
        )?;
        return Ok(files
            .paths()
            .iter()
            .map(|p| p.display().to_string())
            .collect());
    };
    if args.plan.is_some() && args.battery_mass.is_none() && args.catalogue.is_none() {
        anyhow::bail!(
            "--plan needs a battery: give --battery-mass and --battery-energy-density, or a --catalogue with a pack within the payload limit"
        );
    }
    let files = reports::session::write_session_report(&reports::session::SessionReport {
        input: args.input.clone(),
        output: args.output.clone(),
        sweep: args.sweep.clone(),
        catalogue: args.catalogue.clone(),
        plan: args.plan.clone(),
        flights: args.flights.clone(),
        structure_mass_kg: Some(structure_mass_kg),
        avionics_power_w: Some(avionics_power_w),
        payload: Payload {
            mass_kg: args.payload_mass,
            power_w: args.payload_power,
        },
        thrust_limit_kg: args.thrust_limit,
        energy_density_wh_per_kg: args.energy_density,
        // 144g is 0.144 kg, not 0.14400000000000002 in the battery's name
        battery: args
            .battery_mass
            .map(round_decimal)
            .zip(args.battery_energy_density.map(round_decimal)),
        payload_powers_w: args.payload_powers.clone(),
        eq8: match args.eq8 {
            Eq8::Consistent => Eq8Form::Consistent,
            Eq8::Printed => Eq8Form::PrintedHours,
        },
        written_by,
    })?;
    Ok(files
        .paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect())
}

/// `v` with the binary noise of a unit conversion removed (12 significant digits).
fn round_decimal(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(11 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}
