//! `hoverbench import`: another stand's log → a hoverbench sweep CSV, one row per settled step.

use std::path::PathBuf;

use anyhow::Result;
use import::stand::{StandLog, steps_to_csv};

use crate::output::{self, StandArgs, Table};

/// Read a thrust-stand log (Tyto RCbenchmark / Flight Stand export, or any table of thrust,
/// voltage, current, power, throttle) and write it as a hoverbench sweep CSV: canonical units,
/// one row per settled step.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The log.
    file: PathBuf,
    #[command(flatten)]
    stand: StandArgs,
    /// Write the sweep CSV here (otherwise only the summary is printed).
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct StepJson {
    throttle: Option<f64>,
    thrust_g: f64,
    thrust_std_g: Option<f64>,
    voltage_v: Option<f64>,
    current_a: Option<f64>,
    power_w: Option<f64>,
    samples: usize,
    transient_samples: usize,
    source_line: u64,
}

#[derive(serde::Serialize)]
struct Report {
    input: String,
    kind: &'static str,
    columns: Vec<(String, Option<String>)>,
    notes: Vec<String>,
    missing: Vec<&'static str>,
    steps: Vec<StepJson>,
    written: Option<String>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let log = StandLog::read(&args.file, &args.stand.options())?;
    let kind = log.kind.describe();
    let c = &log.columns;
    let columns: Vec<(String, Option<String>)> = [
        ("thrust", &c.thrust),
        ("voltage", &c.voltage),
        ("current", &c.current),
        ("power", &c.power),
        ("throttle", &c.throttle),
        ("speed", &c.speed),
        ("torque", &c.torque),
    ]
    .into_iter()
    .map(|(q, col)| (q.to_owned(), col.clone()))
    .collect();
    let mut missing = Vec::new();
    if log.column(|s| s.power_w).is_none() {
        missing.push("electrical power (no power column, and not both voltage and current): the thrust → power curve cannot be fitted; `fit --volts V` can assume a constant voltage if current is logged");
    }
    if log.column(|s| s.throttle).is_none() {
        missing.push(
            "throttle: no thrust-limit plateau and no thrust-curve exponent for flight controllers",
        );
    }
    let mut written = None;
    if let Some(path) = &args.output {
        let mut comments = vec![
            format!(
                "imported by hoverbench {} from {}",
                env!("CARGO_PKG_VERSION"),
                args.file.display()
            ),
            format!("source sha256 {}", import::sha256_hex(&log.bytes)),
            format!("recognised as: {kind}"),
        ];
        comments.extend(log.notes.iter().map(|n| format!("note: {n}")));
        comments.extend(log.comments.iter().map(|c| format!("source comment: {c}")));
        output::write_atomic_checked(
            path,
            steps_to_csv(&log.steps, &comments).as_bytes(),
            std::slice::from_ref(&args.file),
        )?;
        written = Some(path.display().to_string());
    }
    let rep = Report {
        input: args.file.display().to_string(),
        kind,
        columns,
        notes: log.notes.clone(),
        missing,
        steps: log
            .steps
            .iter()
            .map(|s| StepJson {
                throttle: s.throttle,
                thrust_g: s.thrust_g,
                thrust_std_g: s.thrust_std_g,
                voltage_v: s.voltage_v,
                current_a: s.current_a,
                power_w: s.power_w,
                samples: s.samples,
                transient_samples: s.transient_samples,
                source_line: s.line,
            })
            .collect(),
        written,
    };
    // What the reader assumed or noticed goes to stderr too, where a script's user sees it.
    for n in &rep.notes {
        eprintln!("warning: {n}");
    }
    if args.json {
        return output::print_json(&rep);
    }
    println!("{}: {} ({} steps)", rep.input, rep.kind, rep.steps.len());
    for (q, col) in &rep.columns {
        if let Some(col) = col {
            println!("  {q:<8} ← {col}");
        }
    }
    for n in &rep.notes {
        println!("note: {n}");
    }
    for m in &rep.missing {
        println!("cannot: {m}");
    }
    println!();
    let o = |v: Option<f64>, p: usize| v.map_or("-".to_owned(), |v| format!("{v:.p$}"));
    let mut t = Table::new(&[
        "throttle",
        "thrust_g",
        "±",
        "voltage_v",
        "current_a",
        "power_w",
        "samples",
    ]);
    for s in &rep.steps {
        t.row(vec![
            o(s.throttle, 1),
            format!("{:.2}", s.thrust_g),
            o(s.thrust_std_g, 2),
            o(s.voltage_v, 3),
            o(s.current_a, 3),
            o(s.power_w, 2),
            s.samples.to_string(),
        ]);
    }
    print!("{}", t.render());
    if let Some(w) = &rep.written {
        println!("wrote {w}");
    }
    Ok(())
}
