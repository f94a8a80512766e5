//! `hoverbench simulate-flights`: flight sets from the physical truth model, with the truth in a
//! separate file.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use gap::eval::{draw_truth, generate};
use gap::model::Effect;
use gap::truth::{OutOfLibrary, Robot, TruthEffect};

use crate::output;

/// Generate a training and a held-out flight set from the truth simulator (the paper's robot on
/// the `paper` rig preset, a LiPo with series resistance and an RC pair, control fluctuations,
/// sensor noise, the 9.0 V cut-off), with one effect switched on.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder: DIR/train, DIR/heldout (flights as CSV with sidecar TOML), and
    /// DIR/truth.json, which the diagnosis never reads.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The effect: none, an effect name (internal_resistance, capacity_fade, peukert,
    /// control_overhead, attached_power, air_density, ceiling_effect, climb_power) or an
    /// out-of-library one (motor_heating, high_voltage_cells), as NAME or NAME=MAGNITUDE.
    /// Default: drawn from the seed as in gap-eval.
    #[arg(long, value_name = "EFFECT")]
    effect: Option<String>,
    /// Seed of the missions, noise and (without --effect) the effect.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

fn parse_effect(s: &str) -> Result<TruthEffect> {
    let (name, mag) = match s.split_once('=') {
        Some((n, m)) => (
            n.trim(),
            Some(
                m.trim()
                    .parse::<f64>()
                    .with_context(|| format!("magnitude {m:?} is not a number"))?,
            ),
        ),
        None => (s.trim(), None),
    };
    if name == "none" {
        return Ok(TruthEffect::None);
    }
    if let Some(e) = Effect::ALL.into_iter().find(|e| e.name() == name) {
        let default = match e {
            Effect::InternalResistance => 0.05,
            Effect::CapacityFade => 0.1,
            Effect::Peukert => 0.03,
            Effect::ControlOverhead => 0.08,
            Effect::AttachedPower => 2.0,
            Effect::AirDensity => 0.5,
            Effect::CeilingEffect => 0.3,
            Effect::ClimbPower => 2.0,
        };
        let m = mag.unwrap_or(default);
        let (lo, hi) = e.bounds();
        if !(m.is_finite() && m >= lo.max(0.0) && m <= hi) {
            bail!(
                "{name} magnitude must be within {} to {hi}, got {m}",
                lo.max(0.0)
            );
        }
        return Ok(TruthEffect::Library(e, m));
    }
    match name {
        "motor_heating" => Ok(TruthEffect::OutOfLibrary(
            OutOfLibrary::MotorHeating,
            mag.unwrap_or(0.1),
        )),
        "high_voltage_cells" => Ok(TruthEffect::OutOfLibrary(
            OutOfLibrary::HighVoltageCells,
            mag.unwrap_or(0.08),
        )),
        _ => bail!(
            "unknown effect {name:?}: use none, {}, motor_heating or high_voltage_cells",
            Effect::ALL
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let effect = match &args.effect {
        Some(s) => parse_effect(s)?,
        None => draw_truth(args.seed),
    };
    let robot = Robot::paper();
    let set = generate(&robot, args.seed, effect);
    for (sub, flights) in [("train", &set.train), ("heldout", &set.heldout)] {
        let dir = args.output.join(sub);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for f in flights.iter() {
            output::write_atomic(
                &dir.join(format!("{}.csv", f.name)),
                gap::write::flight_csv(f).as_bytes(),
            )?;
            output::write_atomic(
                &dir.join(format!("{}.toml", f.name)),
                gap::write::sidecar_toml(f).as_bytes(),
            )?;
        }
    }
    let truth_path = args.output.join("truth.json");
    output::write_atomic(
        &truth_path,
        serde_json::to_string_pretty(&set.truth)?.as_bytes(),
    )?;
    println!(
        "wrote {} training and {} held-out flights to {} (truth in {}: keep it away from the diagnosis)",
        set.train.len(),
        set.heldout.len(),
        args.output.display(),
        truth_path.display()
    );
    Ok(())
}
