//! `hoverbench sweep`: one thrust-targeted sweep of a rig on a bench supply, logged crash-safe
//! (one fsynced row per step, raw samples beside, `--resume`). Also the helpers that
//! `characterise` shares: connecting, Ctrl-C, progress and calibration prompts.

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rig_host::HostError;
use rig_host::bench_supply::{Dialect, SupplyControl, SupplyMonitor, open_supply};
use rig_host::log::{self, SweepLog};
use rig_host::rig_protocol::Rig;
use rig_host::settle::SettlePolicy;
use rig_host::sweep::{
    MassPlacer, SweepConfig, SweepEnd, SweepEvent, SweepKind, SweepObserver, SweepOutcome,
    calibrate, run_logged, sweep_header,
};

/// Drive a rig and a bench supply through a sweep: set the supply, tare, arm, then hit every
/// thrust target (±1 g) from zero to the rotor's maximum, or (--limit) step the throttle to
/// the top. One fsynced CSV row per step; raw samples to a second file.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The rig's serial port (or the pseudo-terminal of `hoverbench sim-rig`).
    #[arg(long, value_name = "PORT")]
    rig: String,
    /// The bench supply's serial port.
    #[arg(long, value_name = "PORT")]
    supply: String,
    /// The supply's command set.
    #[arg(long, default_value = "scpi", value_name = "scpi|korad")]
    dialect: Dialect,
    /// Supply voltage, V.
    #[arg(long, default_value_t = 12.5, value_name = "V")]
    volts: f64,
    /// Supply current limit, A (rows taken while the supply limits are marked invalid).
    #[arg(long, default_value_t = 10.0, value_name = "A")]
    current_limit: f64,
    /// Thrust step, g.
    #[arg(long, default_value_t = 10.0, value_name = "G")]
    step: f64,
    /// Last thrust target, g [default: up to the rotor's maximum].
    #[arg(long, value_name = "G")]
    max_target: Option<f64>,
    /// Thrust tolerance of a step, ± g.
    #[arg(long, default_value_t = 1.0, value_name = "G")]
    tolerance: f64,
    /// A limit sweep instead: throttle steps to the top (for the thrust limit at the minimum
    /// battery voltage).
    #[arg(long)]
    limit: bool,
    /// Throttle step of a limit sweep, µs.
    #[arg(long, default_value_t = 50, value_name = "US")]
    limit_step_us: u16,
    /// Write the step log here.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// Write the raw samples here (default: beside the log, `<name>-samples.csv`).
    #[arg(long, value_name = "FILE")]
    samples: Option<PathBuf>,
    /// Continue an interrupted sweep from its last complete step.
    #[arg(long)]
    resume: bool,
    /// The rig's clock rate, × real time (a simulated rig's --speed; 1 for hardware).
    #[arg(long, default_value_t = 1.0, value_name = "N")]
    speed: f64,
    /// Sample stream rate, Hz.
    #[arg(long, default_value_t = 200, value_name = "HZ")]
    rate: u16,
    /// Calibrate the load cell first with these known masses, g (you are asked to place each).
    #[arg(long, value_name = "G,G,…", value_delimiter = ',')]
    calibrate: Vec<f64>,
    /// Settle by a fixed dwell instead of adaptive detection: seconds and samples ("3,20").
    #[arg(long, value_name = "S,N")]
    fixed_dwell: Option<String>,
    /// Print the outcome as JSON.
    #[arg(long)]
    json: bool,
}

/// The Ctrl-C flag (the handler is installed once per process).
pub(crate) fn interrupt_flag() -> &'static AtomicBool {
    static STOP: AtomicBool = AtomicBool::new(false);
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        let _ = ctrlc::set_handler(|| STOP.store(true, Ordering::SeqCst));
    });
    &STOP
}

/// Renders sweep events: an indicatif line (step k of n, thrust, settle state) and one printed
/// line per completed step.
pub(crate) struct Progress {
    bar: ProgressBar,
    label: String,
    quiet: bool,
}

impl Progress {
    pub(crate) fn new(label: &str, quiet: bool) -> Self {
        let bar = ProgressBar::new_spinner();
        bar.set_style(
            ProgressStyle::with_template("{spinner} {prefix} {wide_msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.enable_steady_tick(Duration::from_millis(120));
        Self {
            bar,
            label: label.to_owned(),
            quiet,
        }
    }

    pub(crate) fn set_label(&mut self, label: &str) {
        self.label = label.to_owned();
    }

    pub(crate) fn line(&self, text: &str) {
        if !self.quiet {
            self.bar.suspend(|| println!("{text}"));
        }
    }

    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl SweepObserver for Progress {
    fn event(&mut self, event: SweepEvent<'_>) {
        match event {
            SweepEvent::Started {
                kind,
                resumed_steps,
                expected_steps,
            } => {
                self.bar.set_length(expected_steps.unwrap_or(0) as u64);
                self.bar.set_position(resumed_steps as u64);
                let resumed = if resumed_steps > 0 {
                    format!(", resuming after {resumed_steps} complete steps")
                } else {
                    String::new()
                };
                self.line(&format!("{}: {}{resumed}", self.label, kind.describe()));
            }
            SweepEvent::Progress {
                step,
                target_g,
                throttle_us,
                thrust_g,
                state,
            } => {
                let of = match self.bar.length() {
                    Some(n) if n > 0 => format!(" of {n}"),
                    _ => String::new(),
                };
                self.bar
                    .set_prefix(format!("{} step {}{of}", self.label, step + 1));
                self.bar.set_message(format!(
                    "{}throttle {throttle_us} us, thrust {}, {state}",
                    target_g.map_or(String::new(), |t| format!("target {t} g, ")),
                    thrust_g.map_or("not yet read".to_owned(), |t| format!("{t:.1} g"))
                ));
            }
            SweepEvent::Step(r) => {
                self.bar.set_position(r.step as u64 + 1);
                self.line(&format!(
                    "{} step {:>2}: {}throttle {:>4} us  thrust {:>7.2}{} g  {:>6.3} A  {:>6.3} V  {:>7.3} W  {} samples  settle {:.2} s  {}{}",
                    self.label,
                    r.step,
                    r.target_g.map_or(String::new(), |t| format!("target {t:>3} g  ")),
                    r.throttle_us,
                    r.thrust_g,
                    r.thrust_std_g.map_or(String::new(), |s| format!(" ± {s:.2}")),
                    r.current_a,
                    r.voltage_v,
                    r.power_w,
                    r.samples,
                    r.settle_s,
                    log::mode_tag(r.supply_mode),
                    if r.valid { "" } else { "  INVALID (supply not regulating)" }
                ));
            }
            SweepEvent::Note(n) => self.line(&format!("{}: {n}", self.label)),
        }
    }
}

/// Asks the operator to place each calibration mass.
pub(crate) struct PromptPlacer;

impl MassPlacer for PromptPlacer {
    fn place(&mut self, mass_g: f64) -> Result<(), HostError> {
        if mass_g == 0.0 {
            eprint!("Clear the load cell (nothing but the motor mount on it), then press Enter: ");
        } else {
            eprint!("Place {mass_g} g on the load cell, then press Enter: ");
        }
        let _ = std::io::stderr().flush();
        let mut line = String::new();
        std::io::stdin()
            .lock()
            .read_line(&mut line)
            .map_err(|e| HostError::io("stdin", e))?;
        Ok(())
    }
}

pub(crate) fn settle_policy(fixed: Option<&str>) -> Result<SettlePolicy> {
    let Some(f) = fixed else {
        return Ok(SettlePolicy::default());
    };
    let (s, n) = f
        .split_once(',')
        .with_context(|| format!("--fixed-dwell {f:?}: expected seconds,samples such as 3,20"))?;
    let dwell_s: f64 = s.trim().parse().context("--fixed-dwell seconds")?;
    let samples: usize = n.trim().parse().context("--fixed-dwell samples")?;
    if !(dwell_s.is_finite() && dwell_s >= 0.0 && samples > 0) {
        bail!("--fixed-dwell {f:?}: need seconds ≥ 0 and at least one sample");
    }
    Ok(SettlePolicy::FixedDwell { dwell_s, samples })
}

pub(crate) fn positive(name: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("{name} must be a positive number, got {v}")
    }
}

/// `<dir>/<stem>-samples.csv` beside `log`.
pub(crate) fn samples_path_for(log: &Path) -> PathBuf {
    let stem = log
        .file_stem()
        .map_or("sweep".into(), |s| s.to_string_lossy().into_owned());
    log.with_file_name(format!("{stem}-samples.csv"))
}

/// The message of a sweep that stopped on an error.
pub(crate) fn stopped(e: HostError, log: &Path) -> anyhow::Error {
    let state = rig_host::sweep::safe_state(&e);
    anyhow::Error::new(e).context(format!(
        "sweep stopped: {state}; the complete steps are in {} (continue with --resume)",
        log.display()
    ))
}

#[derive(serde::Serialize)]
struct OutcomeJson<'a> {
    log: String,
    samples: String,
    steps: usize,
    valid_steps: usize,
    resumed_steps: usize,
    end: String,
    rig_time_s: f64,
    attempts: usize,
    rows: Vec<RowJson<'a>>,
}

#[derive(serde::Serialize)]
struct RowJson<'a> {
    step: usize,
    target_g: Option<f64>,
    throttle_us: u16,
    thrust_g: f64,
    power_w: f64,
    supply_mode: &'a str,
    valid: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    positive("--volts", args.volts)?;
    positive("--current-limit", args.current_limit)?;
    positive("--step", args.step)?;
    positive("--tolerance", args.tolerance)?;
    positive("--speed", args.speed)?;
    let kind = if args.limit {
        SweepKind::Limit {
            step_us: args.limit_step_us.max(1),
        }
    } else {
        SweepKind::Nominal {
            step_g: args.step,
            max_target_g: args.max_target,
        }
    };
    let config = SweepConfig {
        kind,
        voltage_v: args.volts,
        current_limit_a: args.current_limit,
        tolerance_g: args.tolerance,
        stream_rate_hz: args.rate,
        settle: settle_policy(args.fixed_dwell.as_deref())?,
        ..SweepConfig::default()
    };
    let samples = args
        .samples
        .clone()
        .unwrap_or_else(|| samples_path_for(&args.output));
    if !args.resume && (args.output.exists() || samples.exists()) {
        bail!(
            "{} already exists: give --resume to continue that sweep, or another -o",
            if args.output.exists() {
                args.output.display()
            } else {
                samples.display()
            }
        );
    }
    // The logs' folders must be there before the rig moves: a sweep that cannot write its
    // first step would stop the rig half-way.
    for path in [&args.output, &samples] {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            if !parent.is_dir() {
                bail!(
                    "cannot write {}: the folder {} does not exist",
                    path.display(),
                    parent.display()
                );
            }
        }
    }
    let stop = interrupt_flag();
    let mut rig = rig_host::link::connect_rig(&args.rig, args.speed)
        .with_context(|| format!("connecting to the rig on {}", args.rig))?;
    let identity = rig.identify().context("identifying the rig")?;
    let mut supply = open_supply(&args.supply, args.dialect)
        .and_then(SupplyMonitor::start)
        .with_context(|| {
            format!(
                "connecting to the {} supply on {}",
                args.dialect, args.supply
            )
        })?;
    let clock = *rig.clock();
    let calibration = if args.calibrate.is_empty() {
        None
    } else {
        Some(
            calibrate(
                &mut rig,
                &clock,
                &args.calibrate,
                &mut PromptPlacer,
                config.tare_samples,
            )?
            .1,
        )
    };
    let status = rig.status().context("reading the rig's status")?;
    let header = sweep_header(
        &config,
        &identity,
        status.calibration_points,
        &calibration
            .unwrap_or_else(|| format!("kept by the rig ({} points)", status.calibration_points)),
        &supply.identity(),
    );
    let columns = config.kind.columns();
    let (log, resumed) = if args.resume && args.output.exists() {
        let (log, state) = SweepLog::resume(&args.output, &samples, &header, columns)?;
        if state.complete {
            println!(
                "{} is already complete ({} steps): nothing to do",
                args.output.display(),
                state.rows.len()
            );
            return Ok(());
        }
        (log, state.rows)
    } else {
        (
            SweepLog::create(&args.output, &samples, &header, columns)?,
            Vec::new(),
        )
    };
    let mut progress = Progress::new(if args.limit { "limit" } else { "sweep" }, args.json);
    let env = rig_host::sweep::SweepEnv {
        clock: &clock,
        identity: &identity,
        supply: &mut supply,
        observer: &mut progress,
        stop,
    };
    let result = run_logged(&mut rig, env, &config, &resumed, log);
    progress.finish();
    let outcome: SweepOutcome = result.map_err(|e| stopped(e, &args.output))?;
    report(&args, &samples, &outcome)
}

fn report(args: &Args, samples: &Path, o: &SweepOutcome) -> Result<()> {
    let valid = o.rows.iter().filter(|r| r.valid).count();
    if args.json {
        let rep = OutcomeJson {
            log: args.output.display().to_string(),
            samples: samples.display().to_string(),
            steps: o.rows.len(),
            valid_steps: valid,
            resumed_steps: o.resumed_steps,
            end: o.end.to_string(),
            rig_time_s: o.rig_time_s,
            attempts: o.attempts,
            rows: o
                .rows
                .iter()
                .map(|r| RowJson {
                    step: r.step,
                    target_g: r.target_g,
                    throttle_us: r.throttle_us,
                    thrust_g: r.thrust_g,
                    power_w: r.power_w,
                    supply_mode: log::mode_tag(r.supply_mode),
                    valid: r.valid,
                })
                .collect(),
        };
        return crate::output::print_json(&rep);
    }
    println!(
        "sweep {}: {} steps ({} valid{}), {:.1} s of rig time",
        o.end,
        o.rows.len(),
        valid,
        if o.resumed_steps > 0 {
            format!(", {} from the interrupted run", o.resumed_steps)
        } else {
            String::new()
        },
        o.rig_time_s
    );
    if let SweepEnd::SupplyLimited { .. } = o.end {
        println!(
            "note: the supply reached its current limit ({} A); the invalid row is skipped by `hoverbench fit`",
            args.current_limit
        );
    }
    println!("wrote {} and {}", args.output.display(), samples.display());
    Ok(())
}
