//! `hoverbench gap-eval`: the blind study of the gap diagnosis.

use anyhow::Result;
use gap::diagnose::DiagnoseOptions;
use gap::eval::{REPORT_SEEDS, TUNING_SEEDS, rig_curve, study};
use gap::truth::Robot;

use crate::output::{self, Table};

/// Run the blind study: per scenario draw an effect (or none, or one outside the library) and a
/// magnitude, simulate training and held-out flights, diagnose without the label, and score.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenarios to run.
    #[arg(long, default_value_t = 200)]
    scenarios: u64,
    /// First seed. The decision thresholds were tuned on seeds 1000–1199; report on others.
    #[arg(long, default_value_t = REPORT_SEEDS.start)]
    seed_start: u64,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Print machine-readable JSON (every scenario, the confusion matrix, the rates).
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let seeds = args.seed_start..args.seed_start + args.scenarios;
    let overlap = seeds.start < TUNING_SEEDS.end && TUNING_SEEDS.start < seeds.end;
    let robot = Robot::paper();
    let curve = rig_curve(&robot)?;
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
    let t0 = std::time::Instant::now();
    let rep = study(
        &robot,
        &curve,
        4,
        seeds.clone(),
        &DiagnoseOptions::default(),
        args.threads,
        &|n| {
            bar.set_position(n as u64);
        },
    );
    bar.finish_and_clear();
    if args.json {
        return output::print_json(&rep);
    }
    println!(
        "blind study: {} scenarios, seeds {}..{} ({:.1} s){}",
        args.scenarios,
        seeds.start,
        seeds.end,
        t0.elapsed().as_secs_f64(),
        if overlap {
            " — WARNING: overlaps the tuning seeds 1000..1200"
        } else {
            ""
        }
    );
    println!();
    let pct = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.1} %", v * 100.0));
    let mut t = Table::new(&["measure", "value", "target"]);
    t.row(vec![
        "correct verdicts, single effects with |impact| ≥ 2 %".into(),
        pct(rep.single_effect_accuracy_2pct),
        "≥ 95 %".into(),
    ]);
    t.row(vec![
        "false positives on `none`".into(),
        pct(rep.false_positive_rate_none),
        "≤ 5 %".into(),
    ]);
    t.row(vec![
        "`unexplained` on out-of-library effects".into(),
        pct(rep.unexplained_rate_out_of_library),
        "-".into(),
    ]);
    t.row(vec![
        "median held-out gap shrinkage when right".into(),
        pct(rep.median_shrinkage_when_right),
        "≥ 80 %".into(),
    ]);
    print!("{}", t.render());
    println!();
    let mut t = Table::new(&["|endurance impact|", "scenarios", "detected correctly"]);
    for (bin, n, f) in &rep.detection_by_impact {
        t.row(vec![
            bin.clone(),
            n.to_string(),
            format!("{:.0} %", f * 100.0),
        ]);
    }
    print!("{}", t.render());
    println!();
    println!("confusion (truth → verdict: count)");
    for (truth, verdict, n) in &rep.confusion {
        println!("  {truth:<20} → {verdict:<36} {n}");
    }
    Ok(())
}
