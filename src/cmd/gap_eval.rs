//! `hoverbench gap-eval`: the blind study of the gap diagnosis on worlds from the independent
//! truth simulator, reported per world family.

use anyhow::Result;
use gap_eval::{GroupSummary, StudyOptions, select_families, study};

use crate::output::{self, Table};

/// Run the blind study: per scenario a world family (battery chemistry × logging × robot) and
/// an effect (or none, or one outside the library) with its magnitude are drawn from the seed;
/// the truth simulator writes training and held-out flights as log files, the diagnosis reads
/// them without the label, and the verdict is scored per family. Held-out families are those
/// the diagnosis was not tuned on.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenarios to run.
    #[arg(long, default_value_t = 200, value_parser = crate::output::at_least_one)]
    scenarios: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    seed_start: u64,
    /// World families, comma-separated: `all`, `tuning`, `heldout`, or patterns
    /// chemistry/logging/robot with `*` (chemistries lipo, lihv, nmc, nca, lfp; logging lab-1hz,
    /// fc-10hz, vonly-5hz, bb-50hz; robots paper, varied), e.g. `lfp,*/vonly-5hz`.
    #[arg(long, default_value = "all", value_name = "FAMILIES")]
    families: String,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = crate::output::at_least_one_usize)]
    threads: usize,
    /// Print machine-readable JSON (every scenario, every family, the confusion matrix).
    #[arg(long)]
    json: bool,
    /// The rule that sets the diagnosis's `unexplained` flag (see `hoverbench gap --help`).
    #[arg(long, value_enum, default_value_t = super::gap::RuleArg::Systematic)]
    unexplained_rule: super::gap::RuleArg,
    /// Diagnose without the rig sweep: the baseline's hover power estimated from the training
    /// flights (their current, else their voltage's fall), as `hoverbench gap` does without
    /// `--params`.
    #[arg(long)]
    no_rig: bool,
}

fn pct(v: Option<f64>) -> String {
    v.map_or("-".to_owned(), |v| format!("{:.0} %", v * 100.0))
}

fn frac(p: (usize, usize)) -> String {
    if p.0 == 0 {
        "-".to_owned()
    } else {
        format!("{}/{}", p.1, p.0)
    }
}

fn row(g: &GroupSummary) -> Vec<String> {
    vec![
        g.name.clone(),
        g.split.to_owned(),
        g.scenarios.to_string(),
        format!("{} {}", frac(g.strict), pct(g.strict_rate())),
        frac(g.library),
        frac(g.none),
        frac(g.outside),
        format!("{} ({} > 0.25)", g.worse.0, g.worse.1),
        g.max_worse_pp
            .filter(|w| *w > 0.0)
            .map_or("-".to_owned(), |w| format!("{w:.2}")),
        pct(g.median_shrinkage),
    ]
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let end = crate::output::seed_end(args.seed_start, args.scenarios)?;
    let families = select_families(&args.families)?;
    let opts = StudyOptions {
        seeds: args.seed_start..end,
        families,
        threads: args.threads,
        unexplained_rule: args.unexplained_rule.into(),
        baseline: if args.no_rig {
            gap_eval::Baseline::FromFlights
        } else {
            gap_eval::Baseline::Rig
        },
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
    let t0 = std::time::Instant::now();
    let rep = study(&opts, &|n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    if args.json {
        return output::print_json(&rep);
    }
    println!(
        "blind study: {} scenarios, seeds {}..{}, {} families ({:.1} s){}",
        rep.scenarios.len(),
        rep.seeds.0,
        rep.seeds.1,
        opts.families.len(),
        t0.elapsed().as_secs_f64(),
        if args.no_rig {
            "; without the rig: the hover power estimated from the training flights"
        } else {
            ""
        }
    );
    println!(
        "tuning families: {}",
        if rep.tuning_families.is_empty() {
            "(none run)".to_owned()
        } else {
            rep.tuning_families.join(", ")
        }
    );
    println!(
        "held out: every other family ({} run)",
        rep.heldout_families.len()
    );
    println!(
        "strict: a library effect with |impact| >= 2 % is right when it has the largest share; \
         none when the verdict is empty and not unexplained; outside the library when unexplained"
    );
    println!(
        "targets on held-out families: strict >= 90 %, none >= 95 %, outside >= 80 %, 0 runs worse by > 0.25 pp, median shrinkage >= 80 %"
    );
    println!();
    let mut t = Table::new(&[
        "group",
        "split",
        "runs",
        "strict",
        "library ≥2 %",
        "none",
        "outside",
        "worse",
        "max worse pp",
        "median shrinkage",
    ]);
    for g in &rep.groups {
        t.row(row(g));
    }
    print!("{}", t.render());
    println!();
    println!(
        "`unexplained` by rule (ran with --unexplained-rule {}): none right, outside flagged",
        match opts.unexplained_rule {
            gap_eval::UnexplainedRule::Chi2 => "chi2",
            gap_eval::UnexplainedRule::Systematic => "systematic",
        }
    );
    let mut t = Table::new(&[
        "group",
        "chi2: none",
        "chi2: outside",
        "systematic: none",
        "systematic: outside",
    ]);
    for g in rep.groups.iter().filter(|g| g.name.starts_with("all ")) {
        let r = g.by_rule;
        t.row(vec![
            g.name.clone(),
            frac(r.chi2.0),
            frac(r.chi2.1),
            frac(r.systematic.0),
            frac(r.systematic.1),
        ]);
    }
    print!("{}", t.render());
    let misses: Vec<&gap_eval::GroupSummary> = rep
        .groups
        .iter()
        .filter(|g| g.name.starts_with("all ") && !g.library_misses.is_empty())
        .collect();
    if !misses.is_empty() {
        println!();
        println!(
            "library effects (impact >= 2 %) missed, by the step of the search that lost them \
             (in brackets: runs where the true effect alone would have lowered the held-out \
             endurance error)"
        );
        for g in misses {
            let parts: Vec<String> = g
                .library_misses
                .iter()
                .map(|(c, n, helps)| format!("{} {n} ({helps})", c.name()))
                .collect();
            println!("  {}: {}", g.name, parts.join(", "));
        }
    }
    for g in rep.groups.iter().filter(|g| g.name.starts_with("all ")) {
        let (n, k) = g.library_named_or_look_alike;
        let (m, j) = g.none_with_look_alikes;
        if n + m > 0 {
            println!(
                "{}: library effects (impact >= 2 %) named, or listed as fitting the flights as well (`also fits`): {k}/{n}; `none` worlds with an empty verdict that list such effects: {j}/{m}",
                g.name
            );
        }
    }
    if !rep.failed.is_empty() {
        println!();
        println!("scenarios that did not run:");
        for (seed, why) in &rep.failed {
            println!("  seed {seed}: {why}");
        }
    }
    println!();
    println!("confusion (truth → verdict: count)");
    for (truth, verdict, n) in &rep.confusion {
        println!("  {truth:<20} → {verdict:<48} {n}");
    }
    Ok(())
}
