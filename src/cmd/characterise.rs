//! `hoverbench characterise`: the main job — nominal sweep, limit sweep, fit, `params.toml`
//! and a summary in one session folder; with no ports, on the simulated `paper` rig and
//! supply.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use rig_host::bench_supply::{Dialect, SupplyControl, SupplyMonitor, open_supply};
use rig_host::rig_protocol::Rig;
use rig_host::session::{self, SessionConfig, files};
use rig_host::simbench::{SimBench, SimBenchOptions};
use rig_host::sweep::{MassPlacer, SweepKind};

use super::sweep::{Progress, PromptPlacer, interrupt_flag, positive, settle_policy};

/// Characterise a motor–propeller: a thrust-targeted sweep at the nominal voltage, a limit
/// sweep at the minimum battery voltage, the fit and params.toml, and a summary, in one
/// session folder. Without --rig/--supply it runs the simulated `paper` rig and a simulated
/// bench supply on pseudo-terminals, faster than real time.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The rig's serial port (with --supply; neither: simulate).
    #[arg(long, value_name = "PORT", requires = "supply")]
    rig: Option<String>,
    /// The bench supply's serial port.
    #[arg(long, value_name = "PORT", requires = "rig")]
    supply: Option<String>,
    /// The supply's command set.
    #[arg(long, default_value = "scpi", value_name = "scpi|korad")]
    dialect: Dialect,
    /// The session folder.
    #[arg(short, long, default_value = "session", value_name = "DIR")]
    output: PathBuf,
    /// Nominal supply voltage, V.
    #[arg(long, default_value_t = 12.5, value_name = "V")]
    volts: f64,
    /// Minimum battery voltage (the limit sweep's supply voltage), V.
    #[arg(long, default_value_t = 9.0, value_name = "V")]
    limit_volts: f64,
    /// Supply current limit, A.
    #[arg(long, default_value_t = 10.0, value_name = "A")]
    current_limit: f64,
    /// Thrust step of the nominal sweep, g.
    #[arg(long, default_value_t = 10.0, value_name = "G")]
    step: f64,
    /// Throttle step of the limit sweep, µs.
    #[arg(long, default_value_t = 50, value_name = "US")]
    limit_step_us: u16,
    /// Rotors sharing the take-off mass.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..))]
    rotors: u8,
    /// Degree of the power curve.
    #[arg(long, default_value_t = fit::DEFAULT_DEGREE)]
    degree: usize,
    /// Continue an interrupted session in the folder.
    #[arg(long)]
    resume: bool,
    /// The rig's clock rate, × real time (10: ten times faster) [default: 1 with ports, 10
    /// simulated].
    #[arg(long, value_name = "N")]
    speed: Option<f64>,
    /// Sample stream rate, Hz.
    #[arg(long, default_value_t = 200, value_name = "HZ")]
    rate: u16,
    /// Calibrate the load cell with these known masses, g [simulated: 100,200,500 placed
    /// automatically; with ports you are asked to place each].
    #[arg(long, value_name = "G,G,…", value_delimiter = ',')]
    calibrate: Vec<f64>,
    /// Simulation: the bench preset (`paper`, calibrated to the paper; `paper-physical`;
    /// `ctu-2312-9450`).
    #[arg(long, default_value = "paper")]
    preset: String,
    /// Simulation: seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Settle by a fixed dwell instead of adaptive detection: seconds and samples ("3,20").
    #[arg(long, value_name = "S,N")]
    fixed_dwell: Option<String>,
    /// m_S for the session's figures (kg) [simulated `paper` rig: the paper's 0.431 kg; with
    /// ports and without it, only the rig's own figures are drawn].
    #[arg(long, value_name = "MASS", value_parser = crate::output::mass_kg)]
    structure_mass: Option<f64>,
    /// p_A for the session's figures (W) [simulated `paper` rig: the paper's 2.44 W].
    #[arg(long, value_name = "POWER", value_parser = crate::output::power_w)]
    avionics_power: Option<f64>,
    /// Do not draw the figures (SESSION/report).
    #[arg(long)]
    no_figures: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    positive("--volts", args.volts)?;
    positive("--limit-volts", args.limit_volts)?;
    positive("--current-limit", args.current_limit)?;
    positive("--step", args.step)?;
    let settle = settle_policy(args.fixed_dwell.as_deref())?;
    let mut config = SessionConfig::paper(&args.output);
    config.nominal.voltage_v = args.volts;
    config.nominal.current_limit_a = args.current_limit;
    config.nominal.stream_rate_hz = args.rate;
    config.nominal.settle = settle;
    config.nominal.kind = SweepKind::Nominal {
        step_g: args.step,
        max_target_g: None,
    };
    config.limit.voltage_v = args.limit_volts;
    config.limit.current_limit_a = args.current_limit;
    config.limit.stream_rate_hz = args.rate;
    config.limit.settle = settle;
    config.limit.kind = SweepKind::Limit {
        step_us: args.limit_step_us,
    };
    config.rotors = args.rotors;
    config.degree = args.degree;
    config.resume = args.resume;
    config.calibration_masses_g = args.calibrate.clone();

    // Every setting is checked before the (simulated) rig is started or moved.
    config.validate()?;
    session::check_session_dir(&args.output, args.resume)?;
    // A finished session resumed: nothing to measure, no rig, no calibration (with hardware it
    // would ask for the masses again); its outputs are regenerated from its logs.
    if args.resume && session::is_finished(&args.output) {
        eprintln!(
            "{} is complete (both sweeps finished): nothing to measure; regenerating {}, the \
             summary and the figures from its logs",
            args.output.display(),
            files::PARAMS
        );
        let summary = session::regenerate(&config)?;
        return finish(&args, &summary, true);
    }
    let stop = interrupt_flag();
    let mut progress = Progress::new("characterise", args.json);
    let bench;
    let (rig_path, supply_path, speed, mut placer): (
        String,
        String,
        f64,
        Box<dyn MassPlacer + '_>,
    );
    match (&args.rig, &args.supply) {
        (Some(r), Some(s)) => {
            let rate = positive("--speed", args.speed.unwrap_or(1.0))?;
            config.bench = format!("rig on {r}, {} supply on {s}", args.dialect);
            (rig_path, supply_path, speed) = (r.clone(), s.clone(), rate);
            placer = Box::new(PromptPlacer);
        }
        (None, None) => {
            let preset = sim::presets::by_name(&args.preset).with_context(|| {
                format!(
                    "unknown preset `{}` (known: {})",
                    args.preset,
                    sim::presets::NAMES.join(", ")
                )
            })?;
            let rate = positive("--speed", args.speed.unwrap_or(10.0))?;
            bench = SimBench::spawn(
                preset,
                SimBenchOptions {
                    speed: rate,
                    seed: args.seed,
                    dialect: args.dialect,
                    record_samples: false,
                },
            )
            .context("starting the simulated rig and supply")?;
            // The first line says what this is.
            println!(
                "simulated bench: no --rig/--supply given, so this runs the simulated `{}` rig \
                 (real firmware core) and a simulated {} bench supply on pseudo-terminals (rig \
                 {}, supply {}), coupled, at {rate}× real time",
                bench.preset_name(),
                args.dialect,
                bench.rig_path(),
                bench.supply_path()
            );
            config.bench = format!(
                "simulated `{}` rig and {} supply at {rate}x real time (seed {})",
                bench.preset_name(),
                args.dialect,
                args.seed
            );
            if config.calibration_masses_g.is_empty() {
                config.calibration_masses_g = vec![100.0, 200.0, 500.0];
            }
            (rig_path, supply_path, speed) =
                (bench.rig_path(), bench.supply_path().to_owned(), rate);
            placer = Box::new(bench.mass_placer());
        }
        _ => bail!("give both --rig and --supply, or neither to simulate"),
    }
    let mut rig = rig_host::link::connect_rig(&rig_path, speed)
        .with_context(|| format!("connecting to the rig on {rig_path}"))?;
    let mut supply = open_supply(&supply_path, args.dialect)
        .and_then(SupplyMonitor::start)
        .with_context(|| format!("connecting to the {} supply on {supply_path}", args.dialect))?;
    let identity = rig.identify().context("identifying the rig")?;
    progress.line(&format!(
        "rig serial 0x{:08x} (firmware {}.{}.{}), supply {}",
        identity.serial_number,
        identity.firmware_version[0],
        identity.firmware_version[1],
        identity.firmware_version[2],
        supply.identity()
    ));
    let clock = *rig.clock();
    let placer_ref: Option<&mut dyn MassPlacer> = if config.calibration_masses_g.is_empty() {
        None
    } else {
        Some(placer.as_mut())
    };
    progress.set_label("characterise");
    let result = session::characterise(
        &mut rig,
        &clock,
        &mut supply,
        &config,
        placer_ref,
        &mut progress,
        stop,
    );
    progress.finish();
    let summary = result.map_err(|e| {
        let state = rig_host::sweep::safe_state(&e);
        // Say where the completed steps are only when a step log was started.
        let kept = if args.output.join(files::SWEEP).exists() {
            format!(
                "the complete steps are in {} (continue with --resume)",
                args.output.display()
            )
        } else {
            "no step was logged: run it again (with or without --resume)".to_owned()
        };
        anyhow::Error::new(e).context(format!("characterisation stopped: {state}; {kept}"))
    })?;
    finish(&args, &summary, false)
}

/// Stores the platform, draws the figures and prints the summary of a session that has run
/// (or, `finished_before`, was only regenerated).
fn finish(args: &Args, summary: &session::SessionSummary, finished_before: bool) -> Result<()> {
    // The figures: the given platform, else the one the session stored, else the paper's for
    // the simulated paper rigs (its Battery A and Table I mission only with `paper`: the
    // physical `paper-physical` rotor cannot lift that pack at 9.0 V).
    let simulated_paper = args.rig.is_none()
        && matches!(args.preset.as_str(), "paper" | "paper-physical")
        && !finished_before;
    let stored = reports::session::SessionPlatform::load(&args.output)?;
    let platform = match (args.structure_mass, args.avionics_power) {
        (Some(m), Some(p)) => Some((m, p, None)),
        _ if stored.is_some() => stored.map(|p| {
            (
                p.structure_mass_kg,
                p.avionics_power_w,
                p.battery_mass_kg.zip(p.battery_energy_density_wh_per_kg),
            )
        }),
        _ if simulated_paper => Some((
            paper::STRUCTURE_MASS_KG,
            paper::AVIONICS_POWER_W,
            (args.preset == "paper").then_some((
                paper::BATTERY_A.mass_kg,
                paper::BATTERY_A.energy_density_wh_per_kg,
            )),
        )),
        _ => None,
    };
    // The session keeps its platform, so that `hoverbench report SESSION` needs no flags.
    if let Some((m, p, battery)) = platform {
        let stored = reports::session::SessionPlatform {
            structure_mass_kg: m,
            avionics_power_w: p,
            battery_mass_kg: battery.map(|b| b.0),
            battery_energy_density_wh_per_kg: battery.map(|b| b.1),
        };
        crate::output::write_atomic(
            &args.output.join(reports::session::SessionPlatform::FILE),
            stored.to_toml_string().as_bytes(),
        )?;
    }
    let figures = match platform {
        Some((m, p, battery)) if !args.no_figures => super::report::session_figures(
            &args.output,
            m,
            p,
            battery,
            battery.map(|_| paper::TABLE_I_PLAN_TEXT.to_owned()),
        )
        .context("drawing the session's figures")?,
        _ => Vec::new(),
    };
    if args.json {
        return crate::output::print_json(summary);
    }
    let text = std::fs::read_to_string(args.output.join(files::SUMMARY_TXT))
        .with_context(|| format!("reading back {}", files::SUMMARY_TXT))?;
    print!("{text}");
    if !figures.is_empty() {
        println!(
            "figures: {} files in {} (open report.html)",
            figures.len(),
            args.output.join("report").display()
        );
    }
    println!(
        "next: hoverbench optimise --params {} --structure-mass … --avionics-power … --energy-density …",
        args.output.join(files::PARAMS).display()
    );
    Ok(())
}
