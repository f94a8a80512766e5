//! `hoverbench gap`: where the model and real flights part, which unmodelled effect causes it,
//! and how far the gap shrinks once it is added.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use estimator::file::ParamsFile;
use flightlog::FlightSet;
use flightlog::PhaseSource;
use flightlog::summary::error_chain;
use gap::diagnose::{DiagnoseOptions, LevelErrors};
use gap::flight::FlightRecord;
use gap::logs::{
    Baseline, ConstantPower, GapReport, MIN_FLIGHTS_FOR_ATTRIBUTION, localise_only,
    record_from_log, run_from_training, run_with_rig, split_flights,
};

use crate::output::{self, Table};

/// Diagnose the sim-to-real gap of a flight set (folders or log files: CSV with sidecar TOML,
/// PX4 .ulg, ArduPilot .bin or its text .log, a MAVLink .tlog, or the Crazyflie dataset's
/// folder).
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
    /// A measured open-circuit curve of one cell (`soc,ocv_v` CSV) that overrides the curve the
    /// diagnosis learns from the flights (the resistances are still learned), for every pack;
    /// per pack, the metadata key `battery_ocv_csv` does the same.
    #[arg(long, value_name = "CSV")]
    battery_ocv_csv: Option<PathBuf>,
    /// The packs' chemistry, when known (only its prior is used, held close; unknown, the
    /// priors whose full-charge voltage matches the flights' resting voltage are tried and the
    /// best-fitting kept).
    #[arg(long, value_enum, value_name = "CHEMISTRY")]
    chemistry: Option<super::battery::ChemistryArg>,
    /// Most effects combined in the verdict (1 to 8).
    #[arg(long, default_value_t = 2)]
    max_effects: usize,
    /// The rule that sets `unexplained`: `chi2` (χ² left against fixed noise floors, or an
    /// effect unstable between the early and late half of the flights) or `systematic` (a
    /// residual the flights share beyond their own scatter, or a flight's endurance missed by
    /// more than half; the default). Both are computed and printed; this picks the flag.
    #[arg(long, value_enum, default_value_t = RuleArg::Systematic)]
    unexplained_rule: RuleArg,
}

/// `--unexplained-rule`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RuleArg {
    /// χ² left against the fixed noise floors, or an unstable effect (the default until
    /// session 10; it fires on nearly every set whose flights scatter beyond those floors).
    Chi2,
    /// A residual shared by the flights beyond their own scatter, or a gross miss (the
    /// default).
    Systematic,
}

impl From<RuleArg> for gap::diagnose::UnexplainedRule {
    fn from(r: RuleArg) -> Self {
        match r {
            RuleArg::Chi2 => Self::Chi2,
            RuleArg::Systematic => Self::Systematic,
        }
    }
}

/// How a flight's phases were obtained.
#[derive(serde::Serialize)]
struct PhaseNote {
    flight: String,
    #[serde(skip)]
    kind: PhaseKind,
    how: String,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum PhaseKind {
    Logged,
    Inferred,
    Missing,
}

/// Reads the flights of `paths` (files or folders); `sources` gets every flight's log file,
/// read or skipped after reading.
fn read(
    paths: &[PathBuf],
    skipped: &mut Vec<(String, String)>,
    phases: &mut Vec<PhaseNote>,
    sources: &mut Vec<PathBuf>,
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
            skipped.push((s.path.display().to_string(), s.why()));
        }
        for f in &set.flights {
            sources.push(f.source.clone());
            let (kind, how) = match &f.phase_source {
                PhaseSource::Logged => (PhaseKind::Logged, "logged".to_owned()),
                PhaseSource::Inferred { method, notes } => {
                    let mut t = method.to_string();
                    for n in notes {
                        t.push_str("; ");
                        t.push_str(n);
                    }
                    (PhaseKind::Inferred, t)
                }
                PhaseSource::None => (
                    PhaseKind::Missing,
                    "none: no phase, current or altitude; every sample taken as hover".to_owned(),
                ),
            };
            phases.push(PhaseNote {
                flight: f.name.clone(),
                kind,
                how,
            });
            match record_from_log(f) {
                Ok(r) => out.push(r),
                // A curve the user gave that does not read is their mistake to fix, not a flight
                // to leave out.
                Err(e @ gap::GapError::BatteryCurve { .. }) => return Err(e.into()),
                Err(e) => skipped.push((f.source.display().to_string(), error_chain(&e))),
            }
        }
    }
    Ok(out)
}

#[derive(serde::Serialize)]
struct Json<'a> {
    verdict: Vec<&'static str>,
    unexplained: bool,
    unexplained_rule: gap::diagnose::UnexplainedRule,
    unexplained_reasons: &'a [String],
    cautions: &'a [String],
    unexplained_by_chi2: bool,
    unexplained_by_systematic: bool,
    systematic: &'a gap::systematic::SystematicCheck,
    stability: &'a [gap::diagnose::Stability],
    within_noise: bool,
    effects: Vec<serde_json::Value>,
    healthy_resistance: &'a Option<gap::diagnose::HealthyResistanceFound>,
    headline: &'a gap::diagnose::HeadlineGap,
    residual: &'a Option<gap::diagnose::Residual>,
    rejected: &'a [gap::diagnose::Rejected],
    look_alikes: &'a [gap::diagnose::LookAlike],
    batteries: &'a [gap::battery::BatteryFit],
    step_resistances: &'a [gap::steps::StepResistance],
    r#where: &'a gap::diagnose::Where,
    baseline: &'a gap::diagnose::TrainHeld,
    after: &'a gap::diagnose::TrainHeld,
    baseline_source: &'a str,
    estimated_hover_power_w: Option<f64>,
    split: &'a gap::diagnose::Split,
    split_rule: &'a str,
    skipped: Vec<serde_json::Value>,
    phase_sources: &'a [PhaseNote],
    candidates: &'a [gap::diagnose::Candidate],
}

fn levels(e: &LevelErrors) -> String {
    let mut parts = Vec::new();
    if let Some(v) = e.endurance_pct {
        parts.push(format!("endurance {v:.2} %"));
    }
    if let Some(v) = e.phase_energy_pct {
        parts.push(format!("energy per phase {v:.2} %"));
    }
    if let Some(v) = e.voltage_rmse_v {
        parts.push(format!("voltage RMSE {v:.3} V"));
    }
    parts.join(", ")
}

/// Why the gap is (or is not) `unexplained`, by the rule set, and what the other rule says.
fn print_why(d: &gap::diagnose::Diagnosis) {
    use gap::diagnose::UnexplainedRule;
    let (rule, other, other_says) = match d.unexplained_rule {
        UnexplainedRule::Chi2 => ("chi2", "systematic", d.unexplained_by_systematic),
        UnexplainedRule::Systematic => ("systematic", "chi2", d.unexplained_by_chi2),
    };
    for r in &d.unexplained_reasons {
        println!("unexplained ({rule} rule): {r}");
    }
    if d.within_noise {
        return;
    }
    // The systematic check's own findings, whichever rule is set.
    let c = &d.systematic;
    if c.reasons.is_empty() {
        let strongest = c
            .patterns
            .iter()
            .max_by(|a, b| a.t.abs().total_cmp(&b.t.abs()));
        println!(
            "systematic check: no residual shared by the flights beyond their own scatter{}",
            strongest.map_or(String::new(), |p| format!(
                " (strongest: {})",
                p.sentence().replace(" is systematically ", " ")
            ))
        );
    } else if d.unexplained_rule != UnexplainedRule::Systematic || !d.unexplained {
        for r in &c.reasons {
            println!("systematic check: {r}");
        }
    }
    for c in &d.cautions {
        println!("caution: {c}");
    }
    println!(
        "the {other} rule {} (--unexplained-rule {other})",
        if other_says {
            "would flag it unexplained"
        } else {
            "would not flag it"
        }
    );
}

fn print_where(w: &gap::diagnose::Where) {
    println!("where:");
    if !w.by_phase.is_empty() {
        let parts: Vec<String> = w
            .by_phase
            .iter()
            .map(|p| format!("{} {:.0} %", p.phase.name(), p.share * 100.0))
            .collect();
        println!("  energy gap by phase: {}", parts.join(", "));
    }
    let parts: Vec<String> = w
        .voltage_by_phase_v
        .iter()
        .map(|p| format!("{} {:+.3} V", p.phase.name(), p.residual_v))
        .collect();
    println!(
        "  voltage residual by phase (measured − predicted): {}",
        parts.join(", ")
    );
    let parts: Vec<String> = w
        .by_state_of_charge
        .iter()
        .map(|t| {
            format!(
                "{} {:+.3} V ({:.0} %)",
                t.part,
                t.residual_v,
                t.share * 100.0
            )
        })
        .collect();
    println!("  by state of charge: {}", parts.join(", "));
    let mut cov: Vec<&gap::diagnose::CovariateCorrelation> = w.by_covariate.iter().collect();
    cov.sort_by(|a, b| b.r2.total_cmp(&a.r2));
    let parts: Vec<String> = cov
        .iter()
        .take(3)
        .map(|c| format!("{} (r = {:+.2})", c.name, c.r))
        .collect();
    if !parts.is_empty() {
        println!(
            "  strongest covariates of the per-flight error: {}",
            parts.join(", ")
        );
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let mut skipped = Vec::new();
    let mut phase_notes = Vec::new();
    let (mut train_files, mut held_files) = (Vec::new(), Vec::new());
    let flights = read(
        &args.flights,
        &mut skipped,
        &mut phase_notes,
        &mut train_files,
    )?;
    let given = read(
        &args.holdout,
        &mut skipped,
        &mut phase_notes,
        &mut held_files,
    )?;
    // A held-out flight that is also trained on would be scored as if unseen.
    crate::overlap::refuse(&train_files, &held_files, "flight")?;
    // Why files were left out comes first, whatever happens next.
    if !args.json {
        for (path, why) in &skipped {
            eprintln!("skipped {path}: {why}");
        }
    }
    let mut opts = DiagnoseOptions {
        max_effects: args.max_effects,
        unexplained_rule: args.unexplained_rule.into(),
        ..DiagnoseOptions::default()
    };
    if let Some(p) = &args.battery_ocv_csv {
        let text =
            std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
        opts.measured_ocv = Some(
            gap::battery::LearnedBattery::from_ocv_csv(&text)
                .with_context(|| format!("--battery-ocv-csv {}", p.display()))?,
        );
    }
    opts.chemistry = args.chemistry.map(|c| c.0);
    let params = match &args.params {
        Some(p) => Some(
            ParamsFile::load(p)?
                .to_params()
                .with_context(|| format!("{} cannot drive the estimator", p.display()))?,
        ),
        None => None,
    };
    let total = flights.len() + given.len();
    if total == 0 {
        bail!("no readable flights (every file was skipped; reasons above)");
    }
    if total < MIN_FLIGHTS_FOR_ATTRIBUTION {
        // Too few flights to attribute: say where the gap sits, and what more is needed.
        let all: Vec<FlightRecord> = flights.into_iter().chain(given).collect();
        let refs: Vec<&FlightRecord> = all.iter().collect();
        let rep = match &params {
            Some(p) => localise_only(Baseline::Rig(&p.curve, p.rotor_count), &refs, &opts)?,
            None => localise_only::<ConstantPower>(Baseline::FromTraining, &refs, &opts)?,
        };
        if args.json {
            return output::print_json(&rep);
        }
        println!("baseline: {}", rep.baseline_source);
        if let Some(w) = rep.estimated_hover_power_w {
            println!("  estimated hover power: {w:.2} W");
        }
        println!("gap against the baseline: {}", levels(&rep.errors));
        print_where(&rep.r#where);
        println!();
        println!(
            "attribution needs at least {MIN_FLIGHTS_FOR_ATTRIBUTION} flights (2 to fit on, 1 held out to check on): {} read, {} more needed",
            rep.flights, rep.more_flights_needed
        );
        return Ok(());
    }
    let (train, held, rule) = split_flights(flights, given);
    let rule = rule.describe();
    // A held-out flight too short, or never off the ground, has no energy per phase to score:
    // left out, with its reason (first, like the skipped files).
    let (held, unscored): (Vec<FlightRecord>, Vec<FlightRecord>) = held
        .into_iter()
        .partition(|f| gap::logs::unscorable(f).is_none());
    for f in &unscored {
        let why = gap::logs::unscorable(f).unwrap_or_default();
        if !args.json {
            eprintln!("held out but not scored {}: {why}", f.name);
        }
        skipped.push((f.name.clone(), format!("held out but not scored: {why}")));
    }
    if held.is_empty() {
        bail!(
            "no held-out flight can be scored ({} held out, all too short or never flying; reasons above): give a longer flight with --holdout",
            unscored.len()
        );
    }
    if train.len() < 2 {
        bail!(
            "{} training flights: the diagnosis needs at least 2 (give fewer --holdout flights)",
            train.len()
        );
    }
    let tr: Vec<&FlightRecord> = train.iter().collect();
    let he: Vec<&FlightRecord> = held.iter().collect();
    let report: GapReport = match &params {
        Some(params) => run_with_rig(&params.curve, params.rotor_count, &tr, &he, &opts)?,
        None => run_from_training(&tr, &he, &opts)?,
    };
    let d = &report.diagnosis;
    let verdict_words = if d.verdict.is_empty() {
        "no effect (none selected)".to_owned()
    } else {
        d.verdict
            .iter()
            .map(|e| e.name())
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let mut written = Vec::new();
    if let Some(dir) = &args.output {
        let voltage = reports::gap::GapVoltageFigure {
            verdict: verdict_words.clone(),
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
        let phases = reports::gap::GapPhaseFigure {
            verdict: verdict_words.clone(),
            phases: d
                .heldout_voltage_by_phase()
                .into_iter()
                .map(|p| (p.phase.name().to_owned(), p.before_v, p.after_v))
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
                    "parameters": {e.parameter.name.clone(): e.parameter.value},
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
            unexplained_rule: d.unexplained_rule,
            unexplained_reasons: &d.unexplained_reasons,
            cautions: &d.cautions,
            unexplained_by_chi2: d.unexplained_by_chi2,
            unexplained_by_systematic: d.unexplained_by_systematic,
            systematic: &d.systematic,
            stability: &d.stability,
            within_noise: d.within_noise,
            effects,
            healthy_resistance: &d.healthy_resistance,
            headline: &d.headline,
            residual: &d.residual,
            rejected: &d.rejected,
            look_alikes: &d.look_alikes,
            batteries: &d.batteries,
            step_resistances: &d.step_resistances,
            r#where: &d.r#where,
            baseline: &d.baseline,
            after: &d.after,
            baseline_source: &report.baseline_source,
            estimated_hover_power_w: report.estimated_hover_power_w,
            split: &d.split,
            split_rule: rule,
            skipped: skipped
                .iter()
                .map(|(file, reason)| serde_json::json!({"file": file, "reason": reason}))
                .collect(),
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
        d.split.train.len(),
        d.split.heldout.len(),
        d.split.heldout.join(", ")
    );
    let inferred: Vec<&PhaseNote> = phase_notes
        .iter()
        .filter(|n| n.kind == PhaseKind::Inferred)
        .collect();
    let missing = phase_notes
        .iter()
        .filter(|n| n.kind == PhaseKind::Missing)
        .count();
    if let Some(first) = inferred.first() {
        println!(
            "phases inferred for {} of {} flights (first, {}: {})",
            inferred.len(),
            phase_notes.len(),
            first.flight,
            first.how
        );
    }
    if missing > 0 {
        println!(
            "{missing} flights have no phases, current or altitude: every sample is taken as hover"
        );
    }
    for b in &d.batteries {
        let lb = &b.battery;
        let knee = lb.knee().map_or("no knee".to_owned(), |(s, v)| {
            format!("knee at {:.0} % charge ({v:.2} V per cell)", s * 100.0)
        });
        println!(
            "battery {} learned from {} flights ({} prior, current {}): series {:.1} mΩ, RC {:.1} mΩ × {:.0} s per cell, {knee}; fit RMSE {:.3} V per cell — {}",
            b.battery_type,
            b.flights,
            b.prior.name(),
            match b.current {
                gap::battery::CurrentSource::Logged => "logged",
                gap::battery::CurrentSource::PowerModel => "from the power model",
            },
            lb.series_resistance_cell_ohm * 1000.0,
            lb.rc_resistance_cell_ohm * 1000.0,
            lb.rc_time_constant_s,
            b.rmse_cell_v,
            b.note
        );
        for w in &b.warnings {
            println!("  warning: {w}");
        }
        if let Some(st) = d
            .step_resistances
            .iter()
            .find(|s| s.battery_type == b.battery_type)
        {
            println!(
                "  its current's {} steps show a series resistance of {:.1} ± {:.1} mΩ per cell (wiring included){}",
                st.steps,
                st.cell_ohm() * 1000.0,
                st.sigma_ohm / f64::from(st.cells.max(1)) * 1000.0,
                if st.above_healthy() {
                    format!(
                        ", above the {:.1} mΩ a healthy {} pack of {:.2} Ah has at most",
                        st.healthy_top_cell_ohm * 1000.0,
                        b.prior.name(),
                        b.rated_capacity_ah
                    )
                } else {
                    String::new()
                }
            );
        }
        if let (Some(u), Some(lost)) = (b.usable_capacity_ah, b.capacity_lost_fraction()) {
            println!(
                "  usable capacity {u:.3} Ah (full to the cut-off) of {:.3} Ah rated: {}",
                b.rated_capacity_ah,
                if lost >= 0.0 {
                    format!("{:.1} % below the rating", lost * 100.0)
                } else {
                    format!("{:.1} % above the rating", -lost * 100.0)
                }
            );
        }
    }
    println!();
    println!("gap before, held-out: {}", levels(&d.baseline.heldout));
    print_where(&d.r#where);
    println!();
    let unit = d.headline.level.unit();
    if d.within_noise {
        println!("verdict: none — the gap is within noise");
    } else if d.verdict.is_empty() && d.unexplained {
        println!(
            "verdict: unexplained — a significant gap remains that no candidate effect explains"
        );
    } else if d.verdict.is_empty() {
        println!(
            "verdict: none — no library effect is selected, and no residual is shared by the flights beyond their own scatter"
        );
    } else {
        let mut t = Table::new(&["effect", "parameter", "share of gap closed"]);
        for e in &d.effects {
            t.row(vec![
                e.effect.name().into(),
                format!(
                    "{} = {:.4} ± {:.4}",
                    e.parameter.name, e.parameter.value, e.std_error
                ),
                format!("{:.0} %", e.share_of_gap * 100.0),
            ]);
        }
        println!("verdict: {verdict_words}");
        print!("{}", t.render());
        println!(
            "held-out {} gap: {:.3} {unit} before, {:.3} {unit} after",
            level_word(d.headline.level),
            d.headline.before,
            d.headline.after
        );
        if d.unexplained {
            println!(
                "…but a significant gap remains that these effects do not explain (unexplained)"
            );
        }
    }
    print_why(d);
    for r in &d.rejected {
        println!("dropped {}: {}", r.effect.name(), r.reason);
    }
    for l in &d.look_alikes {
        println!(
            "also fits these flights: {} — alone it lowers the training χ² by {:.0} (the best alone, {}: {:.0}) and the held-out {} error from {:.3} to {:.3} {unit}",
            l.effect.name(),
            l.training_chi2_drop,
            l.best_single.name(),
            l.best_single_chi2_drop,
            level_word(d.headline.level),
            l.heldout_before,
            l.heldout_alone
        );
    }
    if !d.look_alikes.is_empty() {
        println!(
            "  these flights cannot tell it from the verdict; flights that differ from them in power, payload or depth of discharge would"
        );
    }
    if let Some(h) = &d.healthy_resistance {
        let types: Vec<String> = h
            .types
            .iter()
            .map(|t| {
                format!(
                    "{} {:.1} mΩ per cell, a healthy {} pack of {:.2} Ah has up to {:.1} mΩ",
                    t.battery_type,
                    t.model_cell_ohm * 1000.0,
                    t.chemistry.name(),
                    t.rated_capacity_ah,
                    t.healthy_top_cell_ohm * 1000.0
                )
            })
            .collect();
        println!(
            "pack resistance: {:.1} mΩ of extra series resistance is kept in the model but not named: it is within what healthy packs have ({})",
            h.extra_ohm * 1000.0,
            types.join("; ")
        );
    }
    if let Some(r) = &d.residual {
        if d.unexplained || d.verdict.is_empty() {
            println!("residual: {}", r.description);
        }
    }
    println!();
    println!("gap after, held-out:  {}", levels(&d.after.heldout));
    for w in written {
        println!("wrote {}", w.display());
    }
    Ok(())
}

fn level_word(level: gap::diagnose::Level) -> &'static str {
    match level {
        gap::diagnose::Level::Endurance => "endurance",
        gap::diagnose::Level::PhaseEnergy => "phase-energy",
        gap::diagnose::Level::Voltage => "voltage",
    }
}
