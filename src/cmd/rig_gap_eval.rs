//! `hoverbench rig-gap-eval`: the stand gap diagnosis' blind study on the stand truth simulator.

use anyhow::Result;
use flightlog::summary::error_chain;
use import::stand::{StandLog, StandOptions};
use indicatif::{ProgressBar, ProgressStyle};
use rig_gap::diagnose::{Options, diagnose};
use rig_gap::runs_of_log;
use stand_sim::Scenario;
use stand_sim::eval::{Outcome, Scored, score, summarise};

use crate::output::{self, Table};

/// Run the stand gap diagnosis blind on simulated stands (a truth simulator written apart from
/// it), and score its verdicts. Thresholds were tuned on seeds 0–99, 1000–1099 and 2000–2099;
/// report on others (the README reports 7000–7199).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of scenarios.
    #[arg(long, default_value_t = 100, value_parser = crate::output::at_least_one)]
    scenarios: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print machine-readable JSON (summary and every scenario).
    #[arg(long)]
    json: bool,
}

fn outcome(s: &Scenario) -> Result<Outcome, String> {
    let read = |csv: &str, name: &str| -> Result<_, String> {
        let log = StandLog::parse(csv.as_bytes().to_vec(), name, &StandOptions::default())
            .map_err(|e| error_chain(&e))?;
        runs_of_log(&log).map_err(|e| error_chain(&e))
    };
    let train = read(&s.train_csv, "train.csv")?;
    let held = read(&s.heldout_csv, "heldout.csv")?;
    let d = diagnose(&train, &held, &Options::default()).map_err(|e| error_chain(&e))?;
    let (before_pct, after_pct) = d.headline_pct().unwrap_or((f64::NAN, f64::NAN));
    Ok(Outcome {
        verdict: d.verdict.clone(),
        before_pct,
        after_pct,
        chi2_before: d.baseline.heldout_chi2_per_obs,
        chi2_after: d.after.heldout_chi2_per_obs,
    })
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let end = crate::output::seed_end(args.seed, args.scenarios)?;
    let bar = ProgressBar::new(args.scenarios);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} scenarios, {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut runs: Vec<Scored> = Vec::new();
    for seed in args.seed..end {
        let s = Scenario::draw(seed);
        let o = outcome(&s);
        runs.push(score(s, o));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let summary = summarise((args.seed, end - 1), &runs);
    if args.json {
        return output::print_json(&serde_json::json!({ "summary": summary, "runs": runs }));
    }
    let pct = |(a, b): (usize, usize)| {
        if b == 0 {
            "-".to_owned()
        } else {
            format!("{a}/{b} = {:.0} %", 100.0 * a as f64 / b as f64)
        }
    };
    println!(
        "seeds {}–{} (tuned on 0–99, 1000–1099 and 2000–2099)",
        summary.seeds.0, summary.seeds.1
    );
    println!(
        "single effects moving power or current ≥ 2 %: {} right (target ≥ 90 %)",
        pct(summary.effects_right)
    );
    println!("none: {} right (target ≥ 95 %)", pct(summary.none_right));
    println!(
        "outside the library: {} said unexplained or none",
        pct(summary.outside_right)
    );
    println!(
        "median held-out shrinkage: {} (target ≥ 80 %)",
        summary
            .median_shrinkage
            .map(|v| format!("{:.0} %", 100.0 * v))
            .unwrap_or_else(|| "-".into())
    );
    println!("runs made worse: {} (target 0)", summary.worse);
    let mut t = Table::new(&["truth", "right", "total"]);
    for (n, a, b) in &summary.by_truth {
        t.row(vec![(*n).to_owned(), a.to_string(), b.to_string()]);
    }
    print!("{}", t.render());
    for (seed, e) in &summary.errors {
        println!("seed {seed}: {e}");
    }
    Ok(())
}
