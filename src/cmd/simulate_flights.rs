//! `hoverbench simulate-flights`: flight sets from the independent truth simulator, written as
//! flight-log files, with the truth in a separate file.

use std::path::PathBuf;

use anyhow::{Context, Result};
use flight_sim::{draw_effect, generate, parse_effect, parse_family};

use crate::output;

/// Generate a training and a held-out flight set from the truth simulator (`flight-sim`: its
/// own battery chemistries, propulsion and sensors), with one effect switched on, as flight-log
/// CSV files with TOML sidecars that `hoverbench gap` reads.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder: DIR/train and DIR/heldout (flights as CSV with sidecar TOML),
    /// DIR/rig-sweep.csv (the robot's rotor on a rig at 12.5 V: thrust_g,power_w), and
    /// DIR/truth.json, which the diagnosis never reads.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// World family chemistry/logging/robot: chemistry lipo, lihv, nmc, nca or lfp; logging
    /// lab-1hz, fc-10hz, vonly-5hz or bb-50hz; robot paper or varied.
    #[arg(long, default_value = "lipo/lab-1hz/paper", value_name = "FAMILY")]
    family: String,
    /// The effect as NAME or NAME=MAGNITUDE: none, internal_resistance (Ω), capacity_fade
    /// (fraction), peukert (exponent), control_overhead (airframe download, fraction of weight),
    /// attached_power (holding current, A), air_density (density deficit, fraction),
    /// ceiling_effect (1/K1), climb_power (1/efficiency), or outside the diagnosis's library
    /// motor_heating (K) and draining_payload (kg). Default: drawn from the seed as in gap-eval.
    #[arg(long, value_name = "EFFECT")]
    effect: Option<String>,
    /// Seed of the packs, missions, sensors, noise and (without --effect) the effect.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let family = parse_family(&args.family)?;
    let effect = match &args.effect {
        Some(s) => parse_effect(s)?,
        None => draw_effect(args.seed),
    };
    let set = generate(&family, &effect, args.seed);
    // Built aside and renamed into place whole: a killed run leaves no half-written set, and a
    // folder holding anything but an earlier set is never replaced.
    let staged = outfile::StagedDir::owning(&args.output, |n| {
        matches!(n, "train" | "heldout" | "rig-sweep.csv" | "truth.json")
    })?;
    for (sub, flights) in [("train", &set.train), ("heldout", &set.heldout)] {
        let dir = staged.path().join(sub);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for f in flights.iter() {
            output::write_atomic(&dir.join(format!("{}.csv", f.name)), f.csv.as_bytes())?;
            output::write_atomic(&dir.join(format!("{}.toml", f.name)), f.toml.as_bytes())?;
        }
    }
    output::write_atomic(
        &staged.path().join("rig-sweep.csv"),
        set.rig.csv().as_bytes(),
    )?;
    output::write_atomic(
        &staged.path().join("truth.json"),
        serde_json::to_string_pretty(&set.truth)?.as_bytes(),
    )?;
    staged.commit()?;
    let truth_path = args.output.join("truth.json");
    println!(
        "wrote {} training and {} held-out flights of {} to {} (truth in {}: keep it away from the diagnosis)",
        set.train.len(),
        set.heldout.len(),
        family.name(),
        args.output.display(),
        truth_path.display()
    );
    Ok(())
}
