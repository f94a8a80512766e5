//! `hoverbench sim-rig`: the simulated rig (firmware core on simulated peripherals) behind a
//! pseudo-terminal. Prints the port path, then serves until interrupted (Ctrl-C).

use anyhow::{Context, ensure};
use std::io::Write;

/// Arguments of `hoverbench sim-rig`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Bench preset: `paper` (calibrated to the paper), `paper-physical` or `ctu-2312-9450`.
    #[arg(long, default_value = "paper")]
    pub preset: String,
    /// Simulated time per real time (e.g. 10 runs the rig clock ten times faster).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Supply voltage at start, V (defaults to the preset's).
    #[arg(long, value_name = "V")]
    pub supply_v: Option<f64>,
    /// Print the port and the rig's settings as one JSON line (then serve as without it).
    #[arg(long)]
    pub json: bool,
}

/// Starts the simulated rig and serves it until interrupted.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut preset = sim::presets::by_name(&args.preset).with_context(|| {
        format!(
            "unknown preset `{}` (known: {})",
            args.preset,
            sim::presets::NAMES.join(", ")
        )
    })?;
    ensure!(
        args.speed.is_finite() && args.speed > 0.0,
        "--speed must be a positive number"
    );
    if let Some(v) = args.supply_v {
        ensure!(
            v.is_finite() && v > 0.0,
            "--supply-v must be a positive number"
        );
        preset.supply.voltage_v = v;
    }
    let rig = sim::pty::PtyRig::spawn(
        preset.clone(),
        sim::pty::PtyRigOptions {
            speed: args.speed,
            seed: args.seed,
            record_samples: false,
        },
    )
    .context("starting the simulated rig on a pseudo-terminal")?;
    let mut out = std::io::stdout().lock();
    if args.json {
        let line = serde_json::json!({
            "port": rig.path().display().to_string(),
            "preset": preset.name,
            "supply_v": preset.supply.voltage_v,
            "speed": args.speed,
            "seed": args.seed,
        });
        writeln!(out, "{line}")?;
    } else {
        writeln!(out, "{}", rig.path().display())?;
    }
    out.flush()?;
    drop(out);
    eprintln!(
        "sim-rig: preset `{}` ({}), supply {:.2} V, {}x real time; Ctrl-C to stop",
        preset.name, preset.description, preset.supply.voltage_v, args.speed
    );
    rig.join().context("simulated rig stopped")
}
