//! `hoverbench gap`: where the model and real flights part, which unmodelled effect causes it,
//! and how far the gap shrinks once it is added.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use estimator::file::ParamsFile;
use flightlog::FlightSet;
use gap::diagnose::{DiagnoseOptions, LevelErrors};
use gap::flight::FlightRecord;
use gap::logs::{
    Baseline, ConstantPower, GapReport, default_split, record_from_log, run as run_gap,
};

use crate::output::{self, Table};

/// Diagnose the sim-to-real gap of a flight set (folders or log files: CSV with sidecar TOML,
/// PX4 .ulg, ArduPilot .bin, or the Crazyflie dataset's folder).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Flight folders or files to train on.
    #[arg(required = true, value_name = "FLIGHTS")]
    flights: Vec<PathBuf>,
    /// Flights to check on (held out from the fit). Default: every third flight by name.
    #[arg(long, value_name = "FLIGHTS", num_args = 1..)]
    holdout: Vec<PathBuf>,
    /// Rig characterisation for the baseline; without it the hover power is estimated from the
    /// training flights.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
    /// Write plots here: held-out voltage over time and the residual by phase, before and after.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
}

/// How a flight's phases were obtained: (flight, "logged" / "inferred: …" / "none").
type PhaseNote = (String, String);

fn read(
    paths: &[PathBuf],
    skipped: &mut Vec<(String, String)>,
    phases: &mut Vec<PhaseNote>,
) -> Result<Vec<FlightRecord>> {
    let mut out = Vec::new();
    for p in paths {
        let set = if p.is_dir() {
            FlightSet::read(p)?
        } else {
            let dir = p
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            FlightSet::read_files(dir, std::slice::from_ref(p))?
        };
        for s in &set.skipped {
            skipped.push((s.path.display().to_string(), s.reason.to_string()));
        }
        for f in &set.flights {
            phases.push((
                f.name.clone(),
                match &f.phase_source {
                    flightlog::PhaseSource::Logged => "logged".to_owned(),
                    flightlog::PhaseSource::Inferred { method, notes } => {
                        let mut t = format!("inferred: {method}");
                        for n in notes {
                            t.push_str("; ");
                            t.push_str(n);
                        }
                        t
                    }
                    flightlog::PhaseSource::None => {
                        "none: no phase, current or altitude; every sample taken as hover"
                            .to_owned()
                    }
                },
            ));
            match record_from_log(f) {
                Ok(r) => out.push(r),
                Err(e) => skipped.push((f.source.display().to_string(), e.to_string())),
            }
        }
    }
    Ok(out)
}

#[derive(serde::Serialize)]
struct Json<'a> {
    verdict: Vec<&'static str>,
    unexplained: bool,
    within_noise: bool,
    effects: Vec<serde_json::Value>,
    r#where: &'a gap::diagnose::Where,
    baseline: serde_json::Value,
    after: serde_json::Value,
    baseline_source: &'a str,
    estimated_hover_power_w: Option<f64>,
    split: serde_json::Value,
    split_rule: &'a str,
    skipped: &'a [(String, String)],
    phase_sources: &'a [PhaseNote],
    candidates: &'a [gap::diagnose::Candidate],
}

fn levels(e: &LevelErrors) -> String {
    let mut parts = Vec::new();
    if let Some(v) = e.endurance_pct {
        parts.push(format!("endurance {v:.2} %"));
    }
    if let Some(v) = e.phase_power_pct {
        parts.push(format!("phase power {v:.2} %"));
    }
    if let Some(v) = e.voltage_rmse_v {
        parts.push(format!("voltage RMSE {v:.3} V"));
    }
    parts.join(", ")
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let mut skipped = Vec::new();
    let mut phase_notes = Vec::new();
    let mut train = read(&args.flights, &mut skipped, &mut phase_notes)?;
    let mut held = read(&args.holdout, &mut skipped, &mut phase_notes)?;
    let rule = if args.holdout.is_empty() {
        let names: Vec<String> = train.iter().map(|f| f.name.clone()).collect();
        let mask = default_split(&names);
        let all = std::mem::take(&mut train);
        for (f, h) in all.into_iter().zip(mask) {
            if h { held.push(f) } else { train.push(f) }
        }
        "every third flight by name held out (no --holdout given)"
    } else {
        "--holdout"
    };
    if train.len() < 2 {
        bail!(
            "{} training flights: the diagnosis needs at least 2 (and held-out flights to check on)",
            train.len()
        );
    }
    let tr: Vec<&FlightRecord> = train.iter().collect();
    let he: Vec<&FlightRecord> = held.iter().collect();
    let opts = DiagnoseOptions::default();
    let report: GapReport = match &args.params {
        Some(p) => {
            let file = ParamsFile::load(p)?;
            let params = file
                .to_params()
                .with_context(|| format!("{} cannot drive the estimator", p.display()))?;
            run_gap(
                Baseline::Rig(&params.curve, params.rotor_count),
                &tr,
                &he,
                &opts,
            )?
        }
        None => run_gap::<ConstantPower>(Baseline::FromTraining, &tr, &he, &opts)?,
    };
    let d = &report.diagnosis;
    let mut written = Vec::new();
    if let Some(dir) = &args.output {
        let verdict = if d.verdict.is_empty() {
            "no effect (none selected)".to_owned()
        } else {
            d.verdict
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(" + ")
        };
        let voltage = reports::gap::GapVoltageFigure {
            verdict: verdict.clone(),
            flights: report
                .heldout_series
                .iter()
                .map(|s| reports::gap::GapSeries {
                    name: s.name.clone(),
                    time_s: s.time_s.clone(),
                    measured_v: s.measured_v.clone(),
                    before_v: s.before_v.clone(),
                    after_v: s.after_v.clone(),
                })
                .collect(),
        };
        let phase_mean = |res: &[gap::diagnose::FlightResiduals], p: gap::flight::Phase| {
            let v: Vec<f64> = res
                .iter()
                .flat_map(|r| {
                    r.voltage_by_phase_v
                        .iter()
                        .filter(|(q, _)| *q == p)
                        .map(|(_, v)| *v)
                })
                .collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let phases = reports::gap::GapPhaseFigure {
            verdict,
            phases: gap::flight::Phase::ALL
                .into_iter()
                .filter_map(|p| {
                    Some((
                        p.name().to_owned(),
                        phase_mean(&d.heldout_baseline, p)?,
                        phase_mean(&d.heldout_after, p)?,
                    ))
                })
                .collect(),
        };
        written = reports::gap::write_gap_figures(&voltage, &phases, dir)?;
    }
    if args.json {
        let effects = d
            .effects
            .iter()
            .map(|e| {
                serde_json::json!({
                    "effect": e.effect.name(),
                    "parameters": e.parameters.iter().map(|(k, v)| (k.clone(), *v)).collect::<std::collections::BTreeMap<_, _>>(),
                    "std_error": e.std_error,
                    "share_of_gap": e.share_of_gap,
                    "heldout_error_before_pct": e.heldout_error_before_pct,
                    "heldout_error_after_pct": e.heldout_error_after_pct,
                })
            })
            .collect();
        return output::print_json(&Json {
            verdict: d.verdict.iter().map(|e| e.name()).collect(),
            unexplained: d.unexplained,
            within_noise: d.within_noise,
            effects,
            r#where: &d.r#where,
            baseline: serde_json::json!({"training": d.baseline.0, "heldout": d.baseline.1}),
            after: serde_json::json!({"training": d.after.0, "heldout": d.after.1}),
            baseline_source: &report.baseline_source,
            estimated_hover_power_w: report.estimated_hover_power_w,
            split: serde_json::json!({"train": d.split.0, "heldout": d.split.1}),
            split_rule: rule,
            skipped: &skipped,
            phase_sources: &phase_notes,
            candidates: &d.candidates,
        });
    }
    println!("baseline: {}", report.baseline_source);
    if let Some(w) = report.estimated_hover_power_w {
        println!("  estimated hover power: {w:.2} W");
    }
    println!(
        "split ({rule}): {} training, {} held-out: {}",
        d.split.0.len(),
        d.split.1.len(),
        d.split.1.join(", ")
    );
    for (path, why) in &skipped {
        println!("skipped {path}: {why}");
    }
    let inferred: Vec<&PhaseNote> = phase_notes
        .iter()
        .filter(|(_, n)| n.starts_with("inferred"))
        .collect();
    let missing = phase_notes
        .iter()
        .filter(|(_, n)| n.starts_with("none"))
        .count();
    if let Some((name, how)) = inferred.first() {
        println!(
            "phases inferred for {} of {} flights (first, {name}: {})",
            inferred.len(),
            phase_notes.len(),
            how.trim_start_matches("inferred: ")
        );
    }
    if missing > 0 {
        println!(
            "{missing} flights have no phases, current or altitude: every sample is taken as hover"
        );
    }
    println!();
    println!("gap before, held-out: {}", levels(&d.baseline.1));
    println!("where:");
    if !d.r#where.by_phase.is_empty() {
        let parts: Vec<String> = d
            .r#where
            .by_phase
            .iter()
            .map(|(p, s)| format!("{} {:.0} %", p.name(), s * 100.0))
            .collect();
        println!("  energy gap by phase: {}", parts.join(", "));
    }
    let parts: Vec<String> = d
        .r#where
        .voltage_by_phase_v
        .iter()
        .map(|(p, v)| format!("{} {:+.3} V", p.name(), v))
        .collect();
    println!(
        "  voltage residual by phase (measured − predicted): {}",
        parts.join(", ")
    );
    let parts: Vec<String> = d
        .r#where
        .by_state_of_charge
        .iter()
        .map(|(n, v, s)| format!("{n} {v:+.3} V ({:.0} %)", s * 100.0))
        .collect();
    println!("  by state of charge: {}", parts.join(", "));
    let mut cov: Vec<&(String, f64, f64)> = d.r#where.by_covariate.iter().collect();
    cov.sort_by(|a, b| b.2.total_cmp(&a.2));
    let parts: Vec<String> = cov
        .iter()
        .take(3)
        .map(|(n, r, _)| format!("{n} (r = {r:+.2})"))
        .collect();
    if !parts.is_empty() {
        println!(
            "  strongest covariates of the per-flight error: {}",
            parts.join(", ")
        );
    }
    println!();
    if d.within_noise {
        println!("verdict: none — the gap is within noise");
    } else if d.verdict.is_empty() {
        println!(
            "verdict: unexplained — a significant gap remains that no candidate effect explains"
        );
    } else {
        let mut t = Table::new(&["effect", "parameter", "share of gap closed"]);
        for e in &d.effects {
            let (k, v) = &e.parameters[0];
            t.row(vec![
                e.effect.name().into(),
                format!("{k} = {v:.4} ± {:.4}", e.std_error),
                format!("{:.0} %", e.share_of_gap * 100.0),
            ]);
        }
        println!(
            "verdict: {}",
            d.verdict
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(" + ")
        );
        print!("{}", t.render());
        if d.unexplained {
            println!(
                "…but a significant gap remains that these effects do not explain (unexplained)"
            );
        }
    }
    println!();
    println!("gap after, held-out:  {}", levels(&d.after.1));
    for w in written {
        println!("wrote {}", w.display());
    }
    Ok(())
}
