//! `hoverbench replay-eval`: the evidence study of the online estimator on simulated flight
//! sets with conditions it is not told about, per group of world families.

use anyhow::Result;
use replay_eval::{StudyOptions, select_families, study, table, to_json};

/// Run the online estimator's study: per scenario a world family (battery chemistry × logging ×
/// robot) and a condition of the held-out flights (capacity fade, extra resistance, cold pack,
/// undeclared payload, control overhead, draining payload, or none) are drawn from the seed;
/// the pack is learned by the gap diagnosis from nominal training flights, and the held-out
/// flights, flown to the cut-off, are replayed beside the baselines. Tuning families and
/// held-out families are reported apart.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenarios to run.
    #[arg(long, default_value_t = 40, value_parser = crate::output::at_least_one)]
    scenarios: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// World families, comma-separated: `all`, `tuning`, `heldout`, or patterns
    /// chemistry/logging/robot with `*`, e.g. `lfp,*/vonly-5hz`.
    #[arg(long, default_value = "all", value_name = "FAMILIES")]
    families: String,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = crate::output::at_least_one_usize)]
    threads: usize,
    /// Print machine-readable JSON (every scenario's flights and checkpoints, every group's
    /// summary and targets).
    #[arg(long)]
    json: bool,
    /// Carry each pack's usable capacity, measured over one held-out flight (charge counted
    /// over the drop in state of charge, the end read on the curve at the pack's voltage), to
    /// its next flight, as `replay --pack-history` does
    #[arg(long)]
    pack_history: bool,
    /// Replay the held-out flights without their current column (an ablation: what the
    /// estimator and the baselines do with voltage-only logs of the same flights)
    #[arg(long)]
    voltage_only: bool,
    /// Give the online estimator the rotors' power read from the held-out flights' motor
    /// commands through the motor map fitted on each world's rig sweeps, as `replay
    /// --motor-power` does (families whose logs carry the commands: fc-10hz, vonly-5hz,
    /// bb-50hz)
    #[arg(long)]
    motor_power: bool,
    /// The online estimator averages the samples over windows of this many seconds, with the
    /// band sized for it, as `replay --input-average` does (0: off, the default)
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    input_average: f64,
    /// The online estimator ends its predictions also where the rotors run out of thrust, as
    /// `replay --thrust-limit-end` does (the study measures each world's limit sweep)
    #[arg(long)]
    thrust_limit_end: bool,
    /// The online estimator reads the current sensor's zero on the ground before take-off, as
    /// `replay --zero-current` does
    #[arg(long)]
    zero_current: bool,
    /// The online estimator learns a series resistance beyond the battery model's on flights
    /// without a current, with this one-sigma in ohms for the pack, as `replay
    /// --extra-resistance-sigma` does (0: off, the default)
    #[arg(long, value_name = "OHM", default_value_t = 0.0)]
    extra_resistance_sigma: f64,
    /// The online estimator reopens the series resistance to this one-sigma in ohms for the
    /// pack when the voltage falls far below its prediction three samples in a row in flight
    /// (a worn connector, a cold pack), as `replay --resync-resistance-sigma` does (0: off)
    #[arg(long, value_name = "OHM", default_value_t = estimator::online::OnlineConfig::default().resync_resistance_sigma_ohm)]
    resync_resistance_sigma: f64,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    if !(args.input_average.is_finite() && args.input_average >= 0.0) {
        anyhow::bail!(
            "--input-average takes a window in seconds, 0 or more; got {}",
            args.input_average
        );
    }
    crate::output::require_ohms("--extra-resistance-sigma", args.extra_resistance_sigma)?;
    crate::output::require_ohms("--resync-resistance-sigma", args.resync_resistance_sigma)?;
    let end = crate::output::seed_end(args.seed, args.scenarios)?;
    let families = select_families(&args.families)?;
    let opts = StudyOptions {
        seeds: args.seed..end,
        families,
        threads: args.threads,
        config: estimator::online::OnlineConfig {
            zero_current: args.zero_current,
            extra_resistance_sigma_ohm: args.extra_resistance_sigma,
            resync_resistance_sigma_ohm: args.resync_resistance_sigma,
            ..estimator::online::OnlineConfig::default()
                .with_opt_ins(args.input_average, args.thrust_limit_end)
        },
        pack_history: args.pack_history,
        voltage_only: args.voltage_only,
        motor_power: args.motor_power,
    };
    let bar = indicatif::ProgressBar::new(args.scenarios);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} scenarios, {elapsed} ({eta} left)",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let s = study(&opts, &|| bar.inc(1));
    bar.finish_and_clear();
    let c = &opts.config;
    let inputs = crate::output::ReplayInputs {
        pack_history: opts.pack_history,
        voltage_only: opts.voltage_only,
        motor_power: opts.motor_power,
    };
    if args.json {
        let mut v = to_json(&s);
        if let Some(o) = v.as_object_mut() {
            // What the online estimator ran with, beside the numbers it gave.
            o.insert(
                "online".to_owned(),
                crate::output::online_settings_json(c, inputs),
            );
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("{}", crate::output::online_settings_line(c, inputs));
        print!("{}", table(&s));
    }
    Ok(())
}
