//! `hoverbench report`: the figures of a characterisation (Fig. 3–7 as SVG and PNG) and a
//! self-contained HTML report.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use estimator::file::ParamsFile;
use estimator::{Battery, Eq8Form, MissionOptions, Payload};
use import::Table;
use reports::{
    LimitMarker, MeasuredFlight, MissionInput, NamedBattery, PayloadStudy, ReportInput, Sweep,
};

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
    /// m_S: structure mass without battery (kg; or e.g. 431g).
    #[arg(long, value_name = "MASS", value_parser = output::mass_kg, allow_negative_numbers = true)]
    structure_mass: f64,
    /// p_A: avionics power (W).
    #[arg(long, value_name = "POWER", value_parser = output::power_w, allow_negative_numbers = true)]
    avionics_power: f64,
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

/// The parameter file of a session folder, or the given file.
fn params_path(input: &Path) -> PathBuf {
    if input.is_dir() {
        input.join("params.toml")
    } else {
        input.to_owned()
    }
}

/// The sweeps that go with the parameters: the nominal sweep (`--sweep`, else the session's
/// `sweep.csv`, else the file the parameters were fitted from, as recorded or beside the params
/// file) and the session's limit sweep.
struct Inputs {
    sweep: Option<PathBuf>,
    limit: Option<PathBuf>,
}

fn locate(args: &Args, params: &Path, file: &ParamsFile) -> Inputs {
    let session = args.input.is_dir().then_some(args.input.as_path());
    let in_session = |name: &str| session.map(|d| d.join(name)).filter(|p| p.is_file());
    let from_provenance = || {
        let recorded = Path::new(&file.provenance.input_file);
        let beside = params.parent().map(|d| d.join(recorded));
        [Some(recorded.to_owned()), beside]
            .into_iter()
            .flatten()
            .find(|p| p.is_file())
    };
    let sweep = args
        .sweep
        .clone()
        .or_else(|| in_session("sweep.csv"))
        .or_else(from_provenance);
    Inputs {
        limit: in_session("limit.csv"),
        sweep,
    }
}

fn read(path: &Path, what: &str) -> Result<(Table, String)> {
    let (table, bytes) = Table::read(path).with_context(|| format!("reading the {what}"))?;
    Ok((table, import::sha256_hex(&bytes)))
}

fn limit_from_sweep(path: &Path) -> Result<LimitMarker> {
    let (t, _) = read(path, "limit sweep")?;
    let std = if t.has("thrust_std_g") {
        Some(t.column("thrust_std_g")?)
    } else {
        None
    };
    let opts = fit::ThrustLimitOptions {
        thrust_std_g: std.as_deref(),
        ..Default::default()
    };
    let l = fit::thrust_limit(&t.column("throttle")?, &t.column("thrust_g")?, &opts)
        .with_context(|| format!("extracting the thrust limit from {}", path.display()))?;
    let v = t
        .column("voltage_v")
        .ok()
        .map(|v| v.iter().sum::<f64>() / v.len() as f64);
    Ok(LimitMarker {
        per_rotor_g: l.thrust_g,
        uncertainty_g: l.uncertainty_g,
        supply_voltage_v: v,
        note: Some(format!("from {}", path.display())),
    })
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
        structure_mass: structure_mass_kg,
        avionics_power: avionics_power_w,
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
    let params_path = params_path(&args.input);
    let file = ParamsFile::load(&params_path)?;
    let params = file
        .to_params()
        .with_context(|| format!("{} cannot drive the estimator", params_path.display()))?;
    let inputs = locate(args, &params_path, &file);
    let mut model = params.model(args.structure_mass, args.avionics_power);
    let rotors = f64::from(model.platform.rotor_count);
    let mut provenance = vec![(
        "parameters".to_owned(),
        format!(
            "{} (written {} by {}; fitted from {}, SHA-256 {})",
            params_path.display(),
            file.provenance.created,
            file.provenance.tool,
            file.provenance.input_file,
            file.provenance.input_sha256
        ),
    )];

    let mut thrust_limit = params.thrust_limit.map(LimitMarker::from);
    if let Some(l) = args.thrust_limit {
        model.thrust_limit_kg = Some(l);
        thrust_limit = Some(LimitMarker {
            per_rotor_g: l * 1000.0 / rotors,
            uncertainty_g: 0.0,
            supply_voltage_v: None,
            note: Some("given with --thrust-limit".to_owned()),
        });
    } else if let (None, Some(path)) = (&thrust_limit, &inputs.limit) {
        let marker = limit_from_sweep(path)?;
        model.thrust_limit_kg = Some(marker.per_rotor_g * rotors / 1000.0);
        thrust_limit = Some(marker);
    }
    model.validate()?;
    let payload = Payload {
        mass_kg: args.payload_mass,
        power_w: args.payload_power,
    };

    let sweep = match &inputs.sweep {
        Some(path) => {
            let (t, sha) = read(path, "sweep")?;
            provenance.push((
                "sweep".into(),
                format!("{} (SHA-256 {sha})", path.display()),
            ));
            Some(Sweep::from_table(&t, &path.display().to_string())?)
        }
        None => {
            provenance.push((
                "sweep".into(),
                "not found: Fig. 3 shows the fitted curve alone".into(),
            ));
            None
        }
    };
    if let Some(path) = &inputs.limit {
        let (_, sha) = read(path, "limit sweep")?;
        provenance.push((
            "limit sweep".into(),
            format!("{} (SHA-256 {sha})", path.display()),
        ));
    }

    let mut catalogue = Vec::new();
    if let Some(path) = &args.catalogue {
        let (t, sha) = read(path, "battery catalogue")?;
        provenance.push((
            "catalogue".into(),
            format!("{} (SHA-256 {sha})", path.display()),
        ));
        for pack in t.catalogue()? {
            catalogue.push(NamedBattery::from_pack(&pack)?);
        }
    }
    let flights = match &args.flights {
        Some(path) => {
            let (t, sha) = read(path, "measured flights")?;
            provenance.push((
                "flights".into(),
                format!("{} (SHA-256 {sha})", path.display()),
            ));
            MeasuredFlight::from_table(&t)?
        }
        None => Vec::new(),
    };

    let given = match (args.battery_mass, args.battery_energy_density) {
        (Some(m), Some(d)) => Some(NamedBattery {
            name: format!("battery {m} kg, {d} Wh/kg"),
            battery: Battery::from_density(m, d)?,
        }),
        _ => None,
    };
    // Feasible catalogue packs, best first.
    let ranked: Vec<NamedBattery> = if catalogue.is_empty() {
        Vec::new()
    } else {
        reports::CatalogueFigure::rank(&model, &payload, &catalogue)?
            .ranking
            .into_iter()
            .filter(|r| !r.over_payload_limit)
            .map(|r| r.battery)
            .collect()
    };
    // Fig. 6: the given battery and the packs flown, else the two best packs.
    let mut study: Vec<NamedBattery> = given.iter().cloned().collect();
    let flown: Vec<NamedBattery> = catalogue
        .iter()
        .filter(|b| flights.iter().any(|f| f.matches(&b.name)))
        .cloned()
        .collect();
    if !flown.is_empty() {
        study.extend(flown);
    } else if study.is_empty() {
        study.extend(ranked.iter().take(2).cloned());
    }

    let mission = match &args.plan {
        None => None,
        Some(text) => {
            let segments = estimator::plan::parse_plan(text).context("--plan")?;
            let Some(battery) = given.clone().or_else(|| ranked.first().cloned()) else {
                bail!(
                    "--plan needs a battery: give --battery-mass and --battery-energy-density, or a --catalogue with a pack within the payload limit"
                );
            };
            Some(MissionInput {
                plan: text.clone(),
                segments,
                battery,
                options: MissionOptions {
                    eq8: match args.eq8 {
                        Eq8::Consistent => Eq8Form::Consistent,
                        Eq8::Printed => Eq8Form::PrintedHours,
                    },
                    ..Default::default()
                },
            })
        }
    };
    provenance.push((
        "report".into(),
        format!(
            "written {} by hoverbench {}",
            jiff::Timestamp::now(),
            env!("CARGO_PKG_VERSION")
        ),
    ));

    let input = ReportInput {
        title: format!("hoverbench report: {}", args.input.display()),
        model,
        payload,
        sweep,
        thrust_limit,
        energy_density_wh_per_kg: Some(
            args.energy_density
                .unwrap_or(paper::FIG4_ENERGY_DENSITY_WH_PER_KG),
        ),
        catalogue,
        payload_study: Some(PayloadStudy {
            batteries: study,
            payload_powers_w: args.payload_powers.clone(),
        }),
        flights,
        mission,
        comparisons: Vec::new(),
        provenance,
    };
    let files = reports::write_report(&input, &args.output)?;
    Ok(files
        .paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect())
}
