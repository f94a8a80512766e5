//! `hoverbench flights`: what is in a set of flight logs, one line per flight, and every file
//! skipped with its reason.

use std::path::PathBuf;

use anyhow::{Result, bail};
use flightlog::FlightSet;
use flightlog::summary::{FlightSummary, SetSummary};

use crate::output;

/// Inspect flight logs (folders or files: CSV with sidecar TOML, PX4 .ulg, ArduPilot .bin or
/// its text .log, a ground station's MAVLink .tlog, the Crazyflie dataset): format, span, rate, voltage and current, energy drawn, motor commands, phases and
/// metadata with their sources, warnings, and every skipped file with its reason.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Flight folders or log files.
    #[arg(required = true, value_name = "FOLDER_OR_FILES")]
    paths: Vec<PathBuf>,
    /// Print machine-readable JSON (`flights` and `skipped`).
    #[arg(long)]
    json: bool,
}

/// A number with a fixed count of decimals.
fn num(x: f64, decimals: usize) -> String {
    format!("{x:.decimals$}")
}

/// One flight's line, and its indented details.
fn print_flight(f: &FlightSummary) {
    let voltage = f.voltage_v.map_or_else(
        || "no valid voltage".to_owned(),
        |[lo, hi]| format!("{}–{} V", num(lo, 2), num(hi, 2)),
    );
    let current = f.current_a.map_or_else(
        || "no current".to_owned(),
        |[lo, hi]| format!("{}–{} A", num(lo, 2), num(hi, 2)),
    );
    let energy = f
        .energy_wh
        .map_or_else(|| "energy n/a".to_owned(), |e| format!("{} Wh", num(e, 3)));
    let mut phases: Vec<(&String, &f64)> = f.phases.iter().collect();
    phases.sort_by(|a, b| b.1.total_cmp(a.1).then(a.0.cmp(b.0)));
    let phases = if phases.is_empty() {
        "no phases".to_owned()
    } else {
        phases
            .iter()
            .map(|(p, x)| format!("{p} {:.0} %", 100.0 * **x))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!(
        "{}  {}  {} s  {} samples @ {} Hz  {}  {}  {}  phases: {} ({})",
        f.name,
        f.format,
        num(f.duration_s, 1),
        f.samples,
        num(f.rate_hz, 1),
        voltage,
        current,
        energy,
        phases,
        f.phase_source,
    );
    if let Some(v) = &f.vehicle {
        println!("    vehicle: {v}");
    }
    if let Some(b) = &f.battery {
        println!("    battery: {b}");
    }
    if let Some(m) = &f.motors {
        let range = m.range_us.map_or_else(String::new, |[lo, hi]| {
            format!(", {}–{} µs", num(lo, 0), num(hi, 0))
        });
        let source = m
            .source
            .as_ref()
            .map_or_else(String::new, |s| format!(" from {s}"));
        println!("    motors: {} outputs{range}{source}", m.outputs);
    }
    for e in &f.phase_evidence {
        println!(
            "    {} {:.0} %: {}",
            e.phase,
            100.0 * e.fraction,
            e.evidence
        );
    }
    if !f.metadata.is_empty() {
        let meta: Vec<String> = f
            .metadata
            .iter()
            .map(|(k, v)| format!("{k} = {} [{}]", v.value, v.source))
            .collect();
        println!("    metadata: {}", meta.join("; "));
    }
    for n in &f.phase_notes {
        println!("    note: {n}");
    }
    for w in &f.warnings {
        println!("    warning: {w}");
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let set = FlightSet::read_paths(&args.paths)?;
    let summary = SetSummary::of(&set);
    if args.json {
        return output::print_json(&summary);
    }
    for f in &summary.flights {
        print_flight(f);
    }
    if !summary.skipped.is_empty() {
        println!("skipped:");
        for s in &summary.skipped {
            println!("  {}: {}", s.file, s.reason);
        }
    }
    if summary.flights.is_empty() {
        bail!(
            "no flight could be read ({} file(s) skipped, reasons above)",
            summary.skipped.len()
        );
    }
    Ok(())
}
