//! `hoverbench export`: parameters for flight stacks (PX4, ArduPilot) and firmware (C header).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use autopilot::{
    ArduPilotParams, BatterySpec, Command, ExportInput, Px4Params, SpinRange, ardupilot_actuator,
    fit_thrust_expo,
};
use estimator::file::ParamsFile;
use import::stand::StandLog;

use crate::output::{self, StandArgs};

/// Write parameters that real flight stacks and firmware load.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    target: Target,
}

#[derive(Debug, clap::Subcommand)]
enum Target {
    /// PX4 (QGroundControl .params): THR_MDL_FAC, MPC_THR_HOVER, BAT1_*.
    Px4(Px4Args),
    /// ArduPilot (.param): MOT_THST_EXPO, MOT_SPIN_MIN/MAX, MOT_THST_HOVER, BATT_*, MOT_BAT_VOLT_*.
    Ardupilot(ArduArgs),
    /// A C header with the estimator's parameters (curve constants, evaluator, binary blob).
    CHeader(HeaderArgs),
}

#[derive(Debug, clap::Args)]
struct FlightArgs {
    /// A sweep of thrust against the ESC command (hoverbench's, or another stand's log).
    #[arg(long, value_name = "FILE")]
    sweep: PathBuf,
    #[command(flatten)]
    stand: StandArgs,
    /// PWM of zero command, µs (when the command is logged in µs).
    #[arg(long, value_name = "US", default_value_t = 1000.0)]
    pwm_min: f64,
    /// PWM of full command, µs.
    #[arg(long, value_name = "US", default_value_t = 2000.0)]
    pwm_max: f64,
    /// Take-off mass for the hover throttle (kg; or e.g. 575g).
    #[arg(long, value_name = "MASS", value_parser = output::positive_mass_kg, allow_negative_numbers = true)]
    takeoff_mass: Option<f64>,
    /// Rotors sharing the take-off mass.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..))]
    rotors: u8,
    /// Battery cells in series (with --capacity: battery parameters).
    #[arg(long, value_name = "N", requires = "capacity", value_parser = clap::value_parser!(u8).range(1..=24))]
    cells: Option<u8>,
    /// Battery capacity, mAh.
    #[arg(long, value_name = "MAH", requires = "cells")]
    capacity: Option<f64>,
    /// Landing voltage per cell, V (with --cells and --capacity; default the paper's 3.0 V).
    #[arg(long, value_name = "V")]
    empty_cell_v: Option<f64>,
    /// Full voltage per cell, V (with --cells and --capacity; default 4.2 V).
    #[arg(long, value_name = "V")]
    full_cell_v: Option<f64>,
    /// Pack internal resistance, Ω, when estimated (with --cells and --capacity).
    #[arg(long, value_name = "OHM")]
    internal_resistance: Option<f64>,
    /// Write the file here (otherwise print it).
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
struct Px4Args {
    #[command(flatten)]
    flight: FlightArgs,
    /// The cells' chemistry (lipo, lihv, li_ion_nmc, li_ion_nca, lifepo4): BAT1_V_EMPTY and
    /// BAT1_V_CHARGED as PX4 wants them for it (under load; lipo and li-ion: PX4's defaults
    /// 3.6 / 4.05 V, lifepo4: 3.0 / 3.35 V) instead of --empty-cell-v / --full-cell-v. With
    /// --cells and --capacity.
    #[arg(long, value_name = "NAME", value_parser = parse_chemistry, conflicts_with_all = ["empty_cell_v", "full_cell_v"])]
    chemistry: Option<autopilot::Chemistry>,
}

fn parse_chemistry(s: &str) -> Result<autopilot::Chemistry, String> {
    autopilot::Chemistry::from_name(s)
        .filter(|c| autopilot::px4_cell_voltages(*c).is_some())
        .ok_or_else(|| {
            format!(
                "{s:?} is not one of lipo, lihv, li_ion_nmc, li_ion_nca, lifepo4 (for other cells give --empty-cell-v and --full-cell-v)"
            )
        })
}

#[derive(Debug, clap::Args)]
struct ArduArgs {
    #[command(flatten)]
    flight: FlightArgs,
    /// MOT_SPIN_MIN: PWM fraction where the motors spin reliably.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.15)]
    spin_min: f64,
    /// MOT_SPIN_MAX: PWM fraction where thrust saturates.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.95)]
    spin_max: f64,
    /// More sweeps at other supply voltages (e.g. the 9.0 V limit sweep): the exponent is then
    /// fitted through ArduPilot's battery-voltage scaling (MOT_BAT_VOLT_MAX = cells × full
    /// cell voltage; needs --cells and a voltage column in every sweep).
    #[arg(long = "also-sweep", value_name = "FILE")]
    also: Vec<PathBuf>,
}

#[derive(Debug, clap::Args)]
struct HeaderArgs {
    /// The parameter file.
    params: PathBuf,
    /// Write the header here (otherwise print it).
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

/// Prints `text`, or writes it to `output`, which may not be one of `inputs` (an `-o` naming the
/// sweep or the parameter file would have replaced it).
fn emit(text: &str, output: Option<&PathBuf>, inputs: &[PathBuf]) -> Result<()> {
    match output {
        Some(path) => {
            output::write_atomic_checked(path, text.as_bytes(), inputs)?;
            eprintln!("wrote {}", path.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}

/// A sweep's commands (as fractions of full scale), thrusts and mean voltage.
struct Sweep {
    command: Vec<f64>,
    thrust_g: Vec<f64>,
    voltage_v: Option<f64>,
}

fn input(
    a: &FlightArgs,
    chemistry: Option<autopilot::Chemistry>,
    expo: autopilot::ExpoFit,
) -> Result<ExportInput> {
    Ok(ExportInput {
        expo,
        sweep_name: a.sweep.display().to_string(),
        takeoff_mass_kg: a.takeoff_mass,
        rotors: a.rotors,
        battery: battery(a, chemistry)?,
    })
}

/// Reads one sweep and normalises its throttle once, with the same checks for every sweep
/// (the main one and each `--also-sweep`).
fn sweep(path: &Path, a: &FlightArgs) -> Result<Sweep> {
    let log = StandLog::read(path, &a.stand.options())?;
    let throttle = log.column(|s| s.throttle).with_context(|| {
        format!(
            "{}: the sweep has no throttle column, so the thrust curve against the command cannot be fitted (name it with --throttle)",
            path.display()
        )
    })?;
    let command = match Command::guess(&throttle) {
        Command::Microseconds { .. } => {
            if a.pwm_max.is_nan() || a.pwm_min.is_nan() || a.pwm_max <= a.pwm_min {
                bail!(
                    "--pwm-max ({}) must be above --pwm-min ({})",
                    a.pwm_max,
                    a.pwm_min
                );
            }
            Command::Microseconds {
                min_us: a.pwm_min,
                max_us: a.pwm_max,
            }
        }
        other => other,
    };
    Ok(Sweep {
        command: throttle.iter().map(|&t| command.normalise(t)).collect(),
        thrust_g: log.thrust_g(),
        voltage_v: log.mean_voltage_v(),
    })
}

/// Landing voltage per cell without --empty-cell-v, V: the paper's cut-off.
const DEFAULT_EMPTY_CELL_V: f64 = 3.0;
/// Full voltage per cell without --full-cell-v, V.
const DEFAULT_FULL_CELL_V: f64 = 4.2;

/// The battery of `--cells`/`--capacity`; `chemistry` (PX4's `--chemistry`, which clap keeps
/// apart from `--empty-cell-v`/`--full-cell-v`) sets both voltages.
fn battery(a: &FlightArgs, chemistry: Option<autopilot::Chemistry>) -> Result<Option<BatterySpec>> {
    let (Some(cells), Some(capacity_mah)) = (a.cells, a.capacity) else {
        // clap makes --cells and --capacity come together; the flags below act only on the
        // battery parameters they write, so alone they would be ignored.
        let given = [
            ("--chemistry", chemistry.is_some()),
            ("--empty-cell-v", a.empty_cell_v.is_some()),
            ("--full-cell-v", a.full_cell_v.is_some()),
            ("--internal-resistance", a.internal_resistance.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|g| g.1) {
            bail!(
                "{flag} sets a battery parameter, which is written only for a battery: give --cells and --capacity too"
            );
        }
        return Ok(None);
    };
    if !(capacity_mah.is_finite() && capacity_mah > 0.0) {
        bail!("--capacity must be a positive number of mAh, got {capacity_mah}");
    }
    let px4 = chemistry.and_then(autopilot::px4_cell_voltages);
    let empty_cell_v = a
        .empty_cell_v
        .or(px4.map(|v| v.empty_cell_v))
        .unwrap_or(DEFAULT_EMPTY_CELL_V);
    let full_cell_v = a
        .full_cell_v
        .or(px4.map(|v| v.charged_cell_v))
        .unwrap_or(DEFAULT_FULL_CELL_V);
    if !(empty_cell_v.is_finite() && empty_cell_v > 0.0) {
        bail!("--empty-cell-v must be a positive voltage per cell, got {empty_cell_v}");
    }
    if !(full_cell_v.is_finite() && full_cell_v > 0.0) {
        bail!("--full-cell-v must be a positive voltage per cell, got {full_cell_v}");
    }
    if empty_cell_v >= full_cell_v {
        bail!(
            "the empty voltage per cell ({empty_cell_v} V{}) is at or above the full one ({full_cell_v} V{}): the landing voltage must be below the full-charge one",
            if a.empty_cell_v.is_some() {
                ", --empty-cell-v"
            } else {
                ", the default"
            },
            if a.full_cell_v.is_some() {
                ", --full-cell-v"
            } else {
                ", the default"
            },
        );
    }
    if let Some(r) = a
        .internal_resistance
        .filter(|r| !(r.is_finite() && *r >= 0.0))
    {
        bail!("--internal-resistance must be a resistance of 0 Ω or more, got {r}");
    }
    Ok(Some(BatterySpec {
        cells,
        capacity_mah,
        empty_cell_v,
        full_cell_v,
        internal_resistance_ohm: a.internal_resistance,
        voltages_of: px4.and(chemistry),
    }))
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    match args.target {
        Target::Px4(Px4Args {
            flight: a,
            chemistry,
        }) => {
            let s = sweep(&a.sweep, &a)?;
            let expo = fit_thrust_expo(&s.command, &s.thrust_g)
                .with_context(|| format!("fitting THR_MDL_FAC to {}", a.sweep.display()))?;
            emit(
                &Px4Params::new(&input(&a, chemistry, expo)?)?.render(),
                a.output.as_ref(),
                std::slice::from_ref(&a.sweep),
            )
        }
        Target::Ardupilot(ar) => {
            let a = &ar.flight;
            let spin = SpinRange {
                spin_min: ar.spin_min,
                spin_max: ar.spin_max,
            };
            spin.validate()?;
            let main = sweep(&a.sweep, a)?;
            let actuator = |s: &Sweep| -> Vec<f64> {
                s.command
                    .iter()
                    .map(|&p| ardupilot_actuator(p, spin.spin_min, spin.spin_max))
                    .collect()
            };
            let expo = if ar.also.is_empty() {
                fit_thrust_expo(&actuator(&main), &main.thrust_g)
                    .with_context(|| format!("fitting MOT_THST_EXPO to {}", a.sweep.display()))?
            } else {
                let b = battery(a, None)?.with_context(|| {
                    "--also-sweep fits through ArduPilot's voltage scaling: give --cells and --capacity".to_owned()
                })?;
                let v_max = f64::from(b.cells) * b.full_cell_v;
                let mut sweeps = Vec::new();
                let also = ar
                    .also
                    .iter()
                    .map(|p| sweep(p, a).map(|s| (p, s)))
                    .collect::<Result<Vec<_>>>()?;
                for (path, s) in std::iter::once((&a.sweep, main)).chain(also) {
                    let volts = s.voltage_v.with_context(|| {
                        format!(
                            "{}: no voltage column, needed to fit across voltages",
                            path.display()
                        )
                    })?;
                    sweeps.push(autopilot::VoltageSweep {
                        voltage_v: volts,
                        actuator: actuator(&s),
                        thrust_g: s.thrust_g,
                    });
                }
                autopilot::fit_expo_with_voltage_scaling(&sweeps, v_max)
                    .context("fitting MOT_THST_EXPO across the sweeps' voltages")?
            };
            let mut input = input(a, None, expo)?;
            if !ar.also.is_empty() {
                let names: Vec<String> = std::iter::once(&a.sweep)
                    .chain(&ar.also)
                    .map(|p| p.display().to_string())
                    .collect();
                input.sweep_name = format!(
                    "{} through ArduPilot's battery-voltage scaling",
                    names.join(" + ")
                );
            }
            let inputs: Vec<PathBuf> = std::iter::once(&a.sweep).chain(&ar.also).cloned().collect();
            emit(
                &ArduPilotParams::new(&input, spin)?.render(),
                a.output.as_ref(),
                &inputs,
            )
        }
        Target::CHeader(h) => {
            let file = ParamsFile::load(&h.params)?;
            let params = file
                .to_params()
                .with_context(|| format!("{} cannot drive the estimator", h.params.display()))?;
            let mut buf = [0u8; estimator::params::MAX_BLOB_LEN];
            let n = params.encode(&mut buf)?;
            emit(
                &autopilot::c_header(&params, &buf[..n], "HOVERBENCH_PARAMS_H"),
                h.output.as_ref(),
                std::slice::from_ref(&h.params),
            )
        }
    }
}
