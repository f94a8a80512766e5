//! `hoverbench replay`: the in-flight estimator and its baselines run over logged flights sample
//! by sample, scored on the flights that end at the cut-off.

use std::path::PathBuf;

use anyhow::{Context, Result};
use estimator::file::ParamsFile;
use flightlog::FlightSet;
use flightlog::summary::error_chain;
use replay::methods::Px4Battery;
use replay::{FlightReplay, Replay, ReplayConfig, SkippedFlight};
use reports::replay::{ReplayErrorFigure, ReplayFlightFigure, ReplayMethodSeries};

/// Replay flights through the online estimator (with the battery section of the parameter file)
/// and three baselines — PX4's time_remaining_s, a rated-capacity coulomb counter and the static
/// model — exactly as firmware would, and score the predicted remaining time at 25, 50, 75 and
/// 90 % of every flight that ends at the cut-off (others are listed as skipped, with why).
///
/// When no flight is scored, the listing (and the JSON, and the -o folder) is still written,
/// then it exits with 2 and the most common reason.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The parameter file (params.toml: rig curve, and a `[battery]` section for the online
    /// estimator).
    #[arg(long, value_name = "FILE")]
    params: PathBuf,
    /// Flight logs or folders of flight logs (with their metadata sidecars).
    #[arg(required = true, value_name = "FLIGHTS")]
    flights: Vec<PathBuf>,
    /// Print machine-readable JSON instead of the table (with no flight scored: the skipped
    /// flights, each that flew with what the methods predicted at landing, and an empty
    /// summary, then exit 2).
    #[arg(long)]
    json: bool,
    /// Write plots (per flight and a summary, SVG and PNG), the table as CSV and the JSON into
    /// this folder (replaced as a whole, atomically); flights that landed before the cut-off
    /// get a plot of what each method predicted (`replay-unscored-*`) and
    /// `replay-unscored.csv`.
    #[arg(short = 'o', long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// End the online estimator's predictions also where the rotors run out of thrust (the
    /// parameters' `[thrust_limit]`, with 3 % of headroom for the controller), on flights that
    /// log their current; the one-sigma band is then sized for it (`end_soc_sigma` 0.04, 0.03
    /// with `--input-average`). Off by default: on simulated held-out flights it lowers the
    /// median error at half the flight but makes some flights worse
    /// (docs/evidence/online-estimator.md, "The thrust-limit end on flights with a current, and
    /// both opt-ins together").
    #[arg(long)]
    thrust_limit_end: bool,
    /// Average the samples over windows of this many seconds before the online estimator takes
    /// them: a noisy current sensor (a flight controller's Hall module at 10 Hz or faster)
    /// otherwise makes it learn too small a series resistance. Logs slower than the window are
    /// taken sample by sample. The one-sigma band is then sized for averaged samples
    /// (`end_soc_sigma` 0.05 instead of 0.06; 0.03 with `--thrust-limit-end`). Off (0) by default; 1 s lowered the median
    /// error at half the flight on all nine simulated held-out sets, with some flights worse
    /// (docs/evidence/online-estimator.md, "Averaging the samples").
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    input_average: f64,
    /// Read the current sensor's zero on the ground before take-off: the mean difference
    /// between the logged current and the idle power's (avionics and payload, from the vehicle)
    /// over the ground samples before the first flying one, taken off every later current, as
    /// a flight controller can before it arms. Needs phases (logged or inferred) and a logged
    /// current. Off by default: on the simulated held-out sets it lowered the median error at
    /// half the flight on most sets, with some flights worse (docs/evidence/online-estimator.md,
    /// "The current sensor's zero read before take-off").
    #[arg(long)]
    zero_current: bool,
    /// Carry each pack's usable capacity from one flight to its next (by `battery_id`): a
    /// flight that logged its current measures the capacity (the charge counted over the drop
    /// in state of charge, its end read on the curve at the pack's voltage there), and the
    /// pack's next flight starts from it. Flights are taken in the order they were flown:
    /// by `battery_cycles`, then by name with numbers compared as numbers.
    #[arg(long)]
    pack_history: bool,
    /// Give the online estimator the rotors' power read from each sample's motor commands
    /// (the ESC outputs a flight controller logs: PX4 `actuator_outputs`, ArduPilot `RCOU`,
    /// MAVLink `SERVO_OUTPUT_RAW`, CSV `motor1_us`…) through the parameters' `[motor]` map
    /// (written by `fit --limit` and the characterise session from the two sweeps), beside the
    /// current when one is logged. Off by default: on the simulated held-out sets it lowers the
    /// median error at half the flight, most on voltage-only logs, but makes some flights worse
    /// (docs/evidence/online-estimator.md, "The motor commands' power").
    #[arg(long)]
    motor_power: bool,
    /// On flights that log no current: let the online estimator learn a series resistance
    /// beyond the battery model's, with this one-sigma in ohms for the pack (a worn connector,
    /// thin wiring, a worn pack; 0.02 was chosen on simulated flights), instead of reading the
    /// extra sag as a lower charge or a curve offset. Off (0) by default: on the simulated
    /// held-out sets 0.02 lowers the voltage-only logs' median error at half the flight, but
    /// makes some flights worse, most where a heavier draw made the sag
    /// (docs/evidence/online-estimator.md, "An absolute prior on the series resistance for
    /// voltage-only logs").
    #[arg(long, value_name = "OHM", default_value_t = 0.0)]
    extra_resistance_sigma: f64,
    /// When the voltage falls far below the online estimator's prediction three samples in a
    /// row in flight (a take-off sag well beyond the battery model's: a worn connector, thin
    /// wiring, a cold pack), reopen the series resistance to this one-sigma in ohms for the
    /// pack and take the voltage again, instead of setting it aside and reading the sag as a
    /// curve offset later. 0 turns it off. The default, 0.1, was chosen on simulated flights
    /// (docs/evidence/online-estimator.md, "Session 24").
    #[arg(long, value_name = "OHM", default_value_t = estimator::online::OnlineConfig::default().resync_resistance_sigma_ohm)]
    resync_resistance_sigma: f64,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let file = ParamsFile::load(&args.params)?;
    let params = file
        .to_params()
        .with_context(|| format!("{} cannot drive the estimator", args.params.display()))?;
    let set = FlightSet::read_paths(&args.flights)?;
    let inputs = crate::output::ReplayInputs {
        pack_history: args.pack_history,
        voltage_only: false,
        motor_power: args.motor_power,
    };
    let unread: Vec<SkippedFlight> = set
        .skipped
        .iter()
        .map(|s| SkippedFlight {
            name: s.path.file_name().map_or_else(
                || s.path.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            ),
            reason: error_chain(&s.reason),
            capacity_reading: None,
            capacity_carried: None,
            trace: None,
        })
        .collect();
    if args.thrust_limit_end && file.thrust_limit.is_none() {
        anyhow::bail!(
            "--thrust-limit-end needs the rotors' thrust limit: {} has no [thrust_limit] section (fit a limit sweep at the minimum battery voltage: `hoverbench fit SWEEP --limit LIMIT_SWEEP`)",
            args.params.display()
        );
    }
    if args.motor_power && file.motor.is_none() {
        anyhow::bail!(
            "--motor-power needs the rig's motor map: {} has no [motor] section (fit the nominal and the limit sweep, both with the ESC command logged: `hoverbench fit SWEEP --limit LIMIT_SWEEP`)",
            args.params.display()
        );
    }
    if !(args.input_average.is_finite() && args.input_average >= 0.0) {
        anyhow::bail!(
            "--input-average takes a window in seconds, 0 or more; got {}",
            args.input_average
        );
    }
    crate::output::require_ohms("--extra-resistance-sigma", args.extra_resistance_sigma)?;
    crate::output::require_ohms("--resync-resistance-sigma", args.resync_resistance_sigma)?;
    let online = replay::online_from_file(
        &file,
        args.thrust_limit_end,
        args.input_average,
        args.zero_current,
        args.extra_resistance_sigma,
        args.resync_resistance_sigma,
    );
    // PX4 set up for the pack: the chemistry of the [battery] section (PX4's defaults without)
    let chemistry = file
        .battery
        .as_ref()
        .and_then(|b| estimator::online::Chemistry::from_name(&b.chemistry));
    let config = ReplayConfig {
        params,
        online: online.as_ref().ok().map(|o| o.as_ref()),
        chemistry,
        trace_unscored: true,
        motor_power: args.motor_power,
    };
    let px4 = config.px4_battery();
    let settings = estimator::online::OnlineConfig {
        zero_current: args.zero_current,
        extra_resistance_sigma_ohm: args.extra_resistance_sigma,
        resync_resistance_sigma_ohm: args.resync_resistance_sigma,
        ..estimator::online::OnlineConfig::default()
            .with_opt_ins(args.input_average, args.thrust_limit_end)
    };
    let about = About {
        px4: &px4,
        line: crate::output::online_settings_line(&settings, inputs),
        json: crate::output::online_settings_json(&settings, inputs),
    };
    let bar = indicatif::ProgressBar::new(set.flights.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} flights, {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    if args.json || set.flights.len() < 4 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut r = if args.pack_history {
        let mut flights = set.flights;
        replay::history::sort_flown(&mut flights);
        let mut history = replay::history::PackHistory::new();
        replay::replay_flights_with_history(&flights, unread, &config, Some(&mut history), |i| {
            bar.set_position(i as u64)
        })
    } else {
        replay::replay_flights(&set.flights, unread, &config, |i| {
            bar.set_position(i as u64)
        })
    };
    bar.finish_and_clear();
    if let Err(e) = &online {
        for f in &mut r.flights {
            f.unavailable.retain(|(m, _)| *m != replay::methods::ONLINE);
            f.unavailable.push((replay::methods::ONLINE, e.clone()));
        }
    }
    if let Some(dir) = &args.out {
        write_folder(&r, &about, dir)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&json(&r, &about)?)?);
    } else {
        print!("{}", text(&r, &about));
        if let Some(dir) = &args.out {
            println!("wrote {}", dir.display());
        }
    }
    if r.summary.scored_flights == 0 {
        return Err(nothing_scored(&r));
    }
    Ok(())
}

/// The error for a replay that scored no flight: how many were skipped and the most common
/// reason (the listing above names every one).
fn nothing_scored(r: &Replay) -> anyhow::Error {
    match r.most_common_skip() {
        Some((n, first)) => anyhow::anyhow!(
            "no flight was scored: all {} skipped; the most common reason ({n} of {}): {}: {}",
            r.skipped.len(),
            r.skipped.len(),
            first.name,
            first.reason
        ),
        None => anyhow::anyhow!("no flight was scored"),
    }
}

/// What the methods ran with: the PX4 baseline's cell voltages and the online estimator's
/// options, in words and as JSON.
struct About<'a> {
    px4: &'a Px4Battery,
    line: String,
    json: serde_json::Value,
}

/// The JSON document: the replay's, with `px4_battery` (the cell voltages the PX4 baseline ran
/// with) and `online` (the online estimator's options).
fn json(r: &Replay, about: &About<'_>) -> Result<serde_json::Value> {
    let mut v = r.to_json();
    if let Some(o) = v.as_object_mut() {
        o.insert("px4_battery".to_owned(), serde_json::to_value(about.px4)?);
        o.insert("online".to_owned(), about.json.clone());
    }
    Ok(v)
}

/// The text: the online estimator's options and the cell voltages the PX4 baseline ran with,
/// then the replay's table.
fn text(r: &Replay, about: &About<'_>) -> String {
    format!("{}\n{}\n{}", about.line, about.px4, r.to_text())
}

fn flight_figure(f: &FlightReplay) -> ReplayFlightFigure {
    ReplayFlightFigure {
        name: f.name.clone(),
        time_s: f.series_time_s.iter().map(|t| t - f.takeoff_s).collect(),
        true_remaining_s: f.series_time_s.iter().map(|t| f.end_s - t).collect(),
        methods: plotted(&f.series),
    }
}

/// The methods that predicted anything, as the figure's series.
fn plotted(series: &[replay::MethodSeries]) -> Vec<ReplayMethodSeries> {
    series
        .iter()
        .filter(|m| m.remaining_s.iter().any(|v| v.is_finite()))
        .map(|m| ReplayMethodSeries {
            name: m.name.to_owned(),
            remaining_s: m.remaining_s.clone(),
            sigma_s: m.sigma_s.clone(),
        })
        .collect()
}

/// A flight that landed before the cut-off, as a figure: each method's prediction, no truth.
fn trace_figure(name: &str, t: &replay::FlightTrace) -> ReplayFlightFigure {
    ReplayFlightFigure {
        name: name.to_owned(),
        time_s: t.series_time_s.iter().map(|x| x - t.takeoff_s).collect(),
        true_remaining_s: vec![f64::NAN; t.series_time_s.len()],
        methods: plotted(&t.series),
    }
}

fn write_folder(r: &Replay, about: &About<'_>, dir: &std::path::Path) -> Result<()> {
    // every file it writes is named replay*: an earlier run's folder is replaced whole, a
    // folder holding anything else is refused
    let staged = outfile::StagedDir::owning(dir, |n| n.starts_with("replay"))?;
    let flights: Vec<ReplayFlightFigure> = r.flights.iter().map(flight_figure).collect();
    let summary = ReplayErrorFigure {
        flights: r.summary.scored_flights,
        fractions: replay::FRACTIONS.to_vec(),
        methods: replay::METHODS
            .iter()
            .map(|m| {
                (
                    (*m).to_owned(),
                    r.summary
                        .checkpoints
                        .iter()
                        .map(|c| c.median_abs_error_pct[m].unwrap_or(f64::NAN))
                        .collect(),
                )
            })
            .collect(),
    };
    reports::replay::write_replay_figures(&flights, &summary, staged.path())?;
    let traces: Vec<ReplayFlightFigure> = r
        .skipped
        .iter()
        .filter_map(|k| match &k.trace {
            Some(Ok(t)) => Some(trace_figure(&k.name, t)),
            _ => None,
        })
        .collect();
    if !traces.is_empty() {
        reports::replay::write_unscored_figures(&traces, staged.path())?;
        outfile::write_atomic(
            &staged.path().join("replay-unscored.csv"),
            r.unscored_csv().as_bytes(),
        )?;
    }
    outfile::write_atomic(
        &staged.path().join("replay.json"),
        serde_json::to_string_pretty(&json(r, about)?)?.as_bytes(),
    )?;
    outfile::write_atomic(&staged.path().join("replay.csv"), r.to_csv().as_bytes())?;
    outfile::write_atomic(&staged.path().join("replay.txt"), text(r, about).as_bytes())?;
    staged.commit()?;
    Ok(())
}
