//! `hoverbench rig-gap`: where a motor–propeller physics model and a thrust stand's
//! measurements part, which unmodelled effect causes it, how far the held-out error shrinks.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use import::stand::StandLog;
use rig_gap::diagnose::{Diagnosis, Options, QuantityWhere, diagnose};
use rig_gap::{StandSweep, runs_of_log, split_default};

use crate::output::{self, StandArgs, Table};

/// Diagnose the gap between the physical motor–propeller–supply model and stand logs (any log
/// `import` reads: hoverbench sweeps, RCbenchmark / Flight Stand exports, generic CSV).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Stand logs to train on (a log holding several sweeps is split into runs).
    #[arg(required = true, value_name = "SWEEP")]
    sweeps: Vec<PathBuf>,
    /// Stand logs to check on (held out from the fit). Default: every second run of the
    /// training logs, or the odd steps of a single run.
    #[arg(long, value_name = "SWEEP", num_args = 1..)]
    holdout: Vec<PathBuf>,
    /// Hold the base parameters a physical preset knows (motor, propeller, ESC) fixed instead
    /// of fitting them: `paper` (the paper's rotor) or `ctu-2312-9450`. Their derivation is in
    /// `rig_gap::presets`.
    #[arg(long, value_name = "NAME")]
    preset: Option<String>,
    #[command(flatten)]
    stand: StandArgs,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
    /// Write the diagnosis (rig-gap.json), the per-step residuals (rig-gap-residuals.csv) and
    /// the residual figure before and after (rig-gap.svg, rig-gap.png) here.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
}

/// The runs of the logs, and a note per thrust reading worth a look (a tare offset, a glitch:
/// `StandLog::thrust_oddities`, as `fit` says them; the steps are kept as logged).
fn read(paths: &[PathBuf], stand: &StandArgs) -> Result<(Vec<StandSweep>, Vec<String>)> {
    let opts = stand.options();
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for p in paths {
        let log = StandLog::read(p, &opts)?;
        notes.extend(
            log.thrust_oddities()
                .iter()
                .map(|o| format!("{}, {o}", log.source_name)),
        );
        out.extend(runs_of_log(&log).with_context(|| format!("reading {}", p.display()))?);
    }
    Ok((out, notes))
}

#[derive(serde::Serialize)]
struct Json<'a> {
    verdict: &'a [String],
    unexplained: bool,
    within_noise: bool,
    effects: &'a [rig_gap::diagnose::EffectReport],
    r#where: &'a rig_gap::diagnose::Where,
    baseline: &'a rig_gap::diagnose::ModelReport,
    after: &'a rig_gap::diagnose::ModelReport,
    candidates: &'a [rig_gap::diagnose::Candidate],
    quantities: &'a [&'static str],
    train: &'a [String],
    heldout: &'a [String],
    split_rule: &'a str,
    notes: &'a [String],
}

fn json<'a>(d: &'a Diagnosis, rule: &'a str) -> Json<'a> {
    Json {
        verdict: &d.verdict,
        unexplained: d.unexplained,
        within_noise: d.within_noise,
        effects: &d.effects,
        r#where: &d.r#where,
        baseline: &d.baseline,
        after: &d.after,
        candidates: &d.candidates,
        quantities: &d.quantities,
        train: &d.train,
        heldout: &d.heldout,
        split_rule: rule,
        notes: &d.notes,
    }
}

fn where_table(w: &[QuantityWhere]) -> String {
    let mut t = Table::new(&[
        "quantity", "low %", "middle %", "top %", "early %", "late %", "up %", "down %", "vs V %/V",
    ]);
    let m = |v: &[rig_gap::diagnose::Region], i: usize| {
        v.get(i)
            .filter(|r| r.steps > 0)
            .map(|r| format!("{:+.2}", r.mean_pct))
            .unwrap_or_else(|| "-".into())
    };
    for q in w {
        t.row(vec![
            q.quantity.to_owned(),
            m(&q.by_thrust, 0),
            m(&q.by_thrust, 1),
            m(&q.by_thrust, 2),
            m(&q.by_time, 0),
            m(&q.by_time, 1),
            m(&q.by_direction, 0),
            m(&q.by_direction, 1),
            q.voltage_slope_pct_per_v
                .map(|v| format!("{v:+.2}"))
                .unwrap_or_else(|| "-".into()),
        ]);
    }
    t.render()
}

/// A standard error, marked when it exceeds the value (`Estimate::identified`).
fn std_error_cell(v: &rig_gap::diagnose::Estimate, decimals: usize) -> String {
    if v.identified() {
        format!("{:.decimals$}", v.std_error)
    } else if v.std_error.is_finite() {
        format!("{:.decimals$} (not identified)", v.std_error)
    } else {
        "- (not identified)".to_owned()
    }
}

fn text(d: &Diagnosis, rule: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "verdict: {}", d.verdict.join(" + "));
    let _ = writeln!(s, "train: {}", d.train.join(", "));
    let _ = writeln!(s, "held out: {} ({rule})", d.heldout.join(", "));
    let _ = writeln!(s, "quantities: {}", d.quantities.join(", "));
    let _ = writeln!(s);
    let mut t = Table::new(&["quantity", "held-out error before %", "after %"]);
    for (q, b) in &d.baseline.heldout_error_pct {
        let a = d
            .after
            .heldout_error_pct
            .get(q)
            .copied()
            .unwrap_or(f64::NAN);
        t.row(vec![(*q).to_owned(), format!("{b:.2}"), format!("{a:.2}")]);
    }
    s.push_str(&t.render());
    let _ = writeln!(
        s,
        "held-out chi2/obs: {:.2} before, {:.2} after",
        d.baseline.heldout_chi2_per_obs, d.after.heldout_chi2_per_obs
    );
    if !d.effects.is_empty() {
        let _ = writeln!(s);
        let mut t = Table::new(&["effect", "parameter", "value", "std error", "share of gap"]);
        for e in &d.effects {
            for (i, (p, v)) in e.parameters.iter().enumerate() {
                t.row(vec![
                    if i == 0 {
                        e.effect.to_owned()
                    } else {
                        String::new()
                    },
                    (*p).to_owned(),
                    format!("{:.4}", v.value),
                    std_error_cell(v, 4),
                    if i == 0 {
                        format!("{:.0} %", 100.0 * e.share_of_gap)
                    } else {
                        String::new()
                    },
                ]);
            }
        }
        s.push_str(&t.render());
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "where the base model parts (mean residual, predicted − measured):"
    );
    s.push_str(&where_table(&d.r#where.before));
    if !d.effects.is_empty() {
        let _ = writeln!(s, "after:");
        s.push_str(&where_table(&d.r#where.after));
    }
    let _ = writeln!(s);
    let mut t = Table::new(&["base parameter", "value", "std error"]);
    for (p, v) in &d.baseline.parameters {
        t.row(vec![
            (*p).to_owned(),
            format!("{:.5}", v.value),
            std_error_cell(v, 5),
        ]);
    }
    s.push_str(&t.render());
    let flat: Vec<&str> = d
        .baseline
        .parameters
        .iter()
        .chain(d.effects.iter().flat_map(|e| e.parameters.iter()))
        .filter(|(_, v)| !v.identified())
        .map(|(p, _)| *p)
        .collect();
    if !flat.is_empty() {
        let _ = writeln!(
            s,
            "not identified by this data: {} (standard error above the value: the fit is nearly flat in each, and the other parameters can take up what it would explain; not a measurement)",
            flat.join(", ")
        );
    }
    for n in &d.notes {
        let _ = writeln!(s, "note: {n}");
    }
    s
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let (train, mut log_notes) = read(&args.sweeps, &args.stand)?;
    let (held, held_notes) = read(&args.holdout, &args.stand)?;
    log_notes.extend(held_notes);
    // A held-out log that is also trained on would be scored as if unseen.
    crate::overlap::refuse(&args.sweeps, &args.holdout, "stand log")?;
    let (train, held, rule) = if held.is_empty() {
        split_default(train)
    } else {
        (train, held, "--holdout".to_owned())
    };
    let mut opts = Options::default();
    if let Some(name) = &args.preset {
        let preset = rig_gap::presets::by_name(name).with_context(|| {
            format!(
                "unknown preset '{name}' (known: {})",
                rig_gap::presets::NAMES.join(", ")
            )
        })?;
        opts.fixed = preset.fixed;
    }
    let mut d = diagnose(&train, &held, &opts)?;
    // the logs' own notes first, then the diagnosis's
    log_notes.append(&mut d.notes);
    d.notes = log_notes;
    if let Some(target) = &args.output {
        // built aside and renamed into place whole (outfile::StagedDir)
        let staged = outfile::StagedDir::owning(target, |n| n.starts_with("rig-gap"))?;
        let dir = staged.path();
        output::write_atomic(
            &dir.join("rig-gap.json"),
            serde_json::to_string_pretty(&json(&d, &rule))?.as_bytes(),
        )?;
        let mut csv = String::from(
            "run,heldout,quantity,thrust_g,measured,residual_before_pct,residual_after_pct\n",
        );
        for r in &d.steps {
            let _ = writeln!(
                csv,
                "\"{}\",{},{},{},{},{},{}",
                r.run.replace('"', "'"),
                r.heldout,
                r.quantity,
                r.thrust_g,
                r.measured,
                r.before_pct,
                r.after_pct
            );
        }
        output::write_atomic(&dir.join("rig-gap-residuals.csv"), csv.as_bytes())?;
        let fig = reports::rig_gap::RigGapFigure {
            verdict: if d.effects.is_empty() {
                "no effect added".to_owned()
            } else {
                let names: Vec<&str> = d.effects.iter().map(|e| e.effect).collect();
                let mut v = names.join(" + ");
                if d.unexplained {
                    v.push_str(" (a significant residual left unexplained)");
                }
                v
            },
            points: d
                .steps
                .iter()
                .map(|r| reports::rig_gap::ResidualPoint {
                    quantity: r.quantity.to_owned(),
                    heldout: r.heldout,
                    thrust_g: r.thrust_g,
                    before_pct: r.before_pct,
                    after_pct: r.after_pct,
                })
                .collect(),
        };
        reports::rig_gap::draw(&fig, &dir.join("rig-gap.svg"), &dir.join("rig-gap.png"))?;
        staged.commit()?;
    }
    if args.json {
        output::print_json(&json(&d, &rule))
    } else {
        print!("{}", text(&d, &rule));
        if let Some(dir) = &args.output {
            println!(
                "wrote {}/rig-gap.{{json,svg,png}} and rig-gap-residuals.csv",
                dir.display()
            );
        }
        Ok(())
    }
}
