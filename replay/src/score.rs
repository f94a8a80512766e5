//! Scoring: checkpoints per flight, medians per method and checkpoint, coverage of the
//! one-sigma band, and the text table.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use crate::cutoff::CutoffEvidence;
use crate::methods::{METHODS, ONLINE};

/// Fractions of the flight at which predictions are scored.
pub const FRACTIONS: [f64; 4] = [0.25, 0.5, 0.75, 0.9];

/// One method's prediction at a checkpoint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Checkpoint {
    /// Fraction of the flight (from take-off to the cut-off).
    pub fraction: f64,
    /// Time of the last sample at or before the checkpoint, s (log time): the prediction
    /// scored is the one made at that sample.
    pub time_s: f64,
    /// True remaining time from that sample to the end, s.
    pub true_remaining_s: f64,
    /// The online estimator's predicted remaining time, s.
    pub predicted_remaining_s: Option<f64>,
    /// Its one-sigma band, s.
    pub sigma_s: Option<f64>,
    /// The baselines' predictions, s (`None`: the method has no prediction for this flight).
    #[serde(skip)]
    pub baselines: [Option<f64>; 3],
}

impl Checkpoint {
    /// The prediction of method `m` (index into [`METHODS`]).
    pub fn of(&self, m: usize) -> Option<f64> {
        if m == 0 {
            self.predicted_remaining_s
        } else {
            self.baselines[m - 1]
        }
    }

    /// Error of method `m`, % of the flight's duration (positive: predicts too long).
    pub fn error_pct(&self, m: usize, duration_s: f64) -> Option<f64> {
        self.of(m)
            .map(|p| (p - self.true_remaining_s) / duration_s * 100.0)
    }
}

impl Serialize for BaselinesView<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = BTreeMap::new();
        for (k, v) in METHODS[1..].iter().zip(self.0) {
            m.insert(*k, *v);
        }
        m.serialize(s)
    }
}

/// The baselines of a checkpoint as a `{name: s}` map.
struct BaselinesView<'a>(&'a [Option<f64>; 3]);

/// A prediction series of one method over the flight, for plots.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MethodSeries {
    /// Method name.
    pub name: &'static str,
    /// Predicted remaining time at each plotted sample, s (NaN: no prediction).
    pub remaining_s: Vec<f64>,
    /// One-sigma band, s (NaN where none).
    pub sigma_s: Vec<f64>,
}

/// What was replayed for one flight: checkpoints, and decimated series for plots.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightReplay {
    /// Flight name.
    pub name: String,
    /// Take-off, s (log time).
    pub takeoff_s: f64,
    /// End at the cut-off, s (log time).
    pub end_s: f64,
    /// How the cut-off was recognised.
    pub evidence: CutoffEvidence,
    /// Scored checkpoints, one per entry of [`FRACTIONS`].
    pub checkpoints: Vec<Checkpoint>,
    /// Methods that gave no prediction on this flight, with the reason.
    pub unavailable: Vec<(&'static str, String)>,
    /// Plotted sample times, s (log time, from take-off on).
    pub series_time_s: Vec<f64>,
    /// One series per method, in [`METHODS`] order.
    pub series: Vec<MethodSeries>,
    /// Estimator states at the end (online method), for the report: (name, value).
    pub final_state: Vec<(&'static str, f64)>,
    /// With the packs' history (`replay --pack-history`): the capacity this flight measured,
    /// or why it gave none ([`crate::history::capacity_reading`]); `None` without history.
    pub capacity_reading: Option<Result<crate::history::CapacityReading, String>>,
    /// With the packs' history: the flight whose reading this one flew with, and its factor
    /// on the model's capacity; `None` when there was none.
    pub capacity_carried: Option<(String, f64)>,
    /// What measured the power the online estimator fused in flight.
    pub power_source: PowerSource,
}

/// What measured the power a flight drew, for the online estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct PowerSource {
    /// The logged current times the voltage.
    pub current: bool,
    /// The motors' ESC commands, and whether they measured it.
    pub commands: Commands,
}

/// Whether a flight's motor commands measured its power ([`PowerSource::commands`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Commands {
    /// Through the parameters' motor map.
    Used,
    /// The log has none.
    NotLogged,
    /// Logged, but not asked for (`--motor-power` off).
    NotAsked,
    /// Logged and asked for, but the parameters have no `[motor]` map.
    NoMap,
    /// Logged and asked for, but no flying sample drives the motors within the map's range.
    OutOfRange,
}

impl PowerSource {
    /// The line the text report gives a flight, `None` for one whose current alone measured
    /// its power with no motor commands logged.
    pub fn text(self) -> Option<&'static str> {
        let line = match (self.current, self.commands) {
            (true, Commands::NotLogged) => return None,
            (true, Commands::Used) => {
                "power: the current's, and the rotors' read from the motor commands through the [motor] map"
            }
            (true, Commands::NotAsked) => {
                "power: the current's (the motor commands are logged; --motor-power reads them too)"
            }
            (true, Commands::NoMap) => {
                "power: the current's (the motor commands are logged, but the parameters have no [motor] map: fit a session with a limit sweep)"
            }
            (true, Commands::OutOfRange) => {
                "power: the current's (no flying sample drives the motors within the [motor] map's range)"
            }
            (false, Commands::Used) => {
                "power: no current logged; the rotors' power read from the motor commands through the [motor] map"
            }
            (false, Commands::NotLogged) => {
                "power: no current and no motor commands logged; the model's power, taught by the voltage's fall"
            }
            (false, Commands::NotAsked) => {
                "power: no current logged; the model's power, taught by the voltage's fall (the motor commands are logged: --motor-power reads them)"
            }
            (false, Commands::NoMap) => {
                "power: no current logged; the motor commands are, but the parameters have no [motor] map (fit a session with a limit sweep) - the model's power, taught by the voltage's fall"
            }
            (false, Commands::OutOfRange) => {
                "power: no current logged; no flying sample drives the motors within the [motor] map's range - the model's power, taught by the voltage's fall"
            }
        };
        Some(line)
    }
}

impl FlightReplay {
    /// Flight duration, s.
    pub fn duration_s(&self) -> f64 {
        self.end_s - self.takeoff_s
    }
}

/// A flight left out, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedFlight {
    /// Flight name (or file).
    pub name: String,
    /// Why.
    pub reason: String,
    /// With the packs' history: the capacity the flight measured although it was not scored
    /// (it did not end at the cut-off), or why it gives none (`replay --pack-history`;
    /// [`crate::history`]). `None` without history, or when the flight could not be read.
    #[serde(skip)]
    pub capacity_reading: Option<Result<crate::history::CapacityReading, String>>,
    /// The reading it flew with (the flight that measured it and its factor on the model's
    /// capacity), as [`FlightReplay::capacity_carried`].
    #[serde(skip)]
    pub capacity_carried: Option<(String, f64)>,
    /// What the methods said over it when it flew but landed before the cut-off (no truth to
    /// score against), or why they could not fly it, when the replay asked for traces
    /// ([`crate::ReplayConfig::trace_unscored`]).
    #[serde(skip)]
    pub trace: Option<Result<FlightTrace, String>>,
}

/// What the methods said over a flight that landed before the cut-off, sample by sample as
/// for a scored flight, with no truth to score against: the remaining time each predicted
/// (to the cut-off, had the robot flown on) until it landed.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightTrace {
    /// Take-off, s (log time).
    pub takeoff_s: f64,
    /// The last flying sample, s (log time).
    pub landed_s: f64,
    /// Plotted sample times, s (log time, from take-off on).
    pub series_time_s: Vec<f64>,
    /// One series per method, in [`METHODS`] order.
    pub series: Vec<MethodSeries>,
    /// Per method, in [`METHODS`] order: its last prediction at or before landing (remaining
    /// time, s, and its one-sigma band when it has one).
    pub at_landing: Vec<Option<(f64, Option<f64>)>>,
    /// Methods that gave no prediction on this flight, with the reason.
    pub unavailable: Vec<(&'static str, String)>,
    /// Estimator states at landing (online method): (name, value).
    pub final_state: Vec<(&'static str, f64)>,
}

impl FlightTrace {
    /// Time flown, s.
    pub fn flown_s(&self) -> f64 {
        self.landed_s - self.takeoff_s
    }
}

/// Per checkpoint: median absolute error per method and how many flights each had.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CheckpointSummary {
    /// Fraction of the flight.
    pub fraction: f64,
    /// Median absolute error, % of the flight duration, per method (`None`: no flight).
    pub median_abs_error_pct: BTreeMap<&'static str, Option<f64>>,
    /// Flights scored per method.
    pub flights: BTreeMap<&'static str, usize>,
}

/// Coverage of the online estimator's one-sigma band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coverage {
    /// Checkpoints with a prediction and a sigma.
    pub checkpoints: usize,
    /// Of those, how many had the truth within ±1 σ.
    pub within_one_sigma: usize,
    /// The share, 0–1 (`None` without checkpoints).
    pub one_sigma: Option<f64>,
}

/// Medians and coverage over the scored flights.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Flights scored.
    pub scored_flights: usize,
    /// Flights skipped.
    pub skipped_flights: usize,
    /// Per checkpoint.
    pub checkpoints: Vec<CheckpointSummary>,
    /// One-sigma coverage of the online estimator.
    pub coverage: Coverage,
}

/// Median of a slice (`None` when empty): the diagnosis's one implementation.
pub use gap::stats::median;

/// Summarises scored flights.
pub fn summarise(flights: &[FlightReplay], skipped: usize) -> Summary {
    let checkpoints = FRACTIONS
        .iter()
        .enumerate()
        .map(|(c, &fraction)| {
            let mut med = BTreeMap::new();
            let mut count = BTreeMap::new();
            for (m, name) in METHODS.iter().enumerate() {
                let errs: Vec<f64> = flights
                    .iter()
                    .filter_map(|f| {
                        f.checkpoints
                            .get(c)
                            .and_then(|k| k.error_pct(m, f.duration_s()))
                            .map(f64::abs)
                    })
                    .collect();
                med.insert(*name, median(&errs));
                count.insert(*name, errs.len());
            }
            CheckpointSummary {
                fraction,
                median_abs_error_pct: med,
                flights: count,
            }
        })
        .collect();
    let (mut n, mut within) = (0, 0);
    for k in flights.iter().flat_map(|f| &f.checkpoints) {
        if let (Some(p), Some(s)) = (k.predicted_remaining_s, k.sigma_s) {
            n += 1;
            if (p - k.true_remaining_s).abs() <= s {
                within += 1;
            }
        }
    }
    Summary {
        scored_flights: flights.len(),
        skipped_flights: skipped,
        checkpoints,
        coverage: Coverage {
            checkpoints: n,
            within_one_sigma: within,
            one_sigma: (n > 0).then(|| within as f64 / n as f64),
        },
    }
}

/// A whole replay: scored flights, skipped ones, summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// Scored flights, in the order given.
    pub flights: Vec<FlightReplay>,
    /// Flights left out, with reasons.
    pub skipped: Vec<SkippedFlight>,
    /// The summary.
    pub summary: Summary,
}

#[derive(Serialize)]
struct CheckpointJson<'a> {
    fraction: f64,
    time_s: f64,
    true_remaining_s: f64,
    predicted_remaining_s: Option<f64>,
    sigma_s: Option<f64>,
    error_pct: BTreeMap<&'static str, Option<f64>>,
    baselines: BaselinesView<'a>,
}

#[derive(Serialize)]
struct FlightJson<'a> {
    name: &'a str,
    takeoff_s: f64,
    end_s: f64,
    duration_s: f64,
    cutoff: &'a CutoffEvidence,
    checkpoints: Vec<CheckpointJson<'a>>,
    unavailable: BTreeMap<&'static str, &'a str>,
    final_state: BTreeMap<&'static str, f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pack_history: Option<HistoryJson<'a>>,
    power_source: PowerSource,
}

/// A skipped flight, with the capacity it measured (`--pack-history` only) and what the
/// methods said over it (with traces).
#[derive(Serialize)]
struct SkippedJson<'a> {
    name: &'a str,
    reason: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pack_history: Option<HistoryJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    trace: Option<TraceJson<'a>>,
    /// Why the methods could not fly it (with traces).
    #[serde(skip_serializing_if = "Option::is_none")]
    not_traced: Option<&'a str>,
}

/// What the methods said over a flight that landed before the cut-off.
#[derive(Serialize)]
struct TraceJson<'a> {
    takeoff_s: f64,
    landed_s: f64,
    flown_s: f64,
    /// Each method's last prediction before landing: remaining time to the cut-off, s.
    remaining_at_landing_s: BTreeMap<&'static str, Option<f64>>,
    /// The online estimator's one-sigma band then, s.
    online_sigma_at_landing_s: Option<f64>,
    unavailable: BTreeMap<&'static str, &'a str>,
    final_state: BTreeMap<&'static str, f64>,
}

impl<'a> TraceJson<'a> {
    fn of(t: &'a FlightTrace) -> Self {
        Self {
            takeoff_s: t.takeoff_s,
            landed_s: t.landed_s,
            flown_s: t.flown_s(),
            remaining_at_landing_s: METHODS
                .iter()
                .zip(&t.at_landing)
                .map(|(m, p)| (*m, p.map(|p| p.0)))
                .collect(),
            online_sigma_at_landing_s: t.at_landing.first().copied().flatten().and_then(|p| p.1),
            unavailable: reasons_view(&t.unavailable),
            final_state: t.final_state.iter().copied().collect(),
        }
    }
}

/// A flight's part in the packs' history (`--pack-history` only).
#[derive(Serialize)]
struct HistoryJson<'a> {
    /// The reading it flew with: the flight it came from and its factor on the model's
    /// capacity.
    carried_from: Option<&'a str>,
    carried_factor: Option<f64>,
    /// What it measured, or why nothing.
    reading: Option<&'a crate::history::CapacityReading>,
    reading_factor: Option<f64>,
    /// Whether the pack's next flight flies with the reading (`history::MIN_SHORTFALL`).
    reading_carries: Option<bool>,
    no_reading: Option<&'a str>,
}

impl<'a> HistoryJson<'a> {
    /// A flight's history part: the reading it flew with (`carried`) and what it measured.
    fn of(
        carried: Option<&'a (String, f64)>,
        reading: &'a Result<crate::history::CapacityReading, String>,
    ) -> Self {
        let ok = reading.as_ref().ok();
        Self {
            carried_from: carried.map(|c| c.0.as_str()),
            carried_factor: carried.map(|c| c.1),
            reading: ok,
            reading_factor: ok.map(crate::history::CapacityReading::factor),
            reading_carries: ok.map(crate::history::CapacityReading::carries),
            no_reading: reading.as_ref().err().map(String::as_str),
        }
    }
}

#[derive(Serialize)]
struct ReplayJson<'a> {
    methods: [&'static str; 4],
    flights: Vec<FlightJson<'a>>,
    skipped: Vec<SkippedJson<'a>>,
    summary: &'a Summary,
}

impl Replay {
    /// Builds the summary from flights and skipped ones.
    pub fn new(flights: Vec<FlightReplay>, skipped: Vec<SkippedFlight>) -> Self {
        let summary = summarise(&flights, skipped.len());
        Self {
            flights,
            skipped,
            summary,
        }
    }

    /// The most common reason among the skipped flights, as (how many share it, the first
    /// such flight): reasons that differ only in their numbers ("flies only 2.0 s" and "flies
    /// only 4.5 s") count as one. `None` when nothing was skipped.
    pub fn most_common_skip(&self) -> Option<(usize, &SkippedFlight)> {
        let mut groups: Vec<(String, usize, &SkippedFlight)> = Vec::new();
        for k in &self.skipped {
            let key = without_numbers(&k.reason);
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.1 += 1,
                None => groups.push((key, 1, k)),
            }
        }
        // the first of the largest groups, in the order the flights were given (`max_by_key`
        // keeps the last maximum, hence the reversal)
        groups
            .into_iter()
            .rev()
            .max_by_key(|g| g.1)
            .map(|(_, n, k)| (n, k))
    }

    /// The `--json` document: `methods`, `flights` (each with `name` and `checkpoints`
    /// [{`fraction`, `true_remaining_s`, `predicted_remaining_s`, `sigma_s`, `baselines`
    /// {name: s}}]), `skipped` [{`name`, `reason`}] and `summary`.
    pub fn to_json(&self) -> serde_json::Value {
        let flights = self
            .flights
            .iter()
            .map(|f| FlightJson {
                name: &f.name,
                takeoff_s: f.takeoff_s,
                end_s: f.end_s,
                duration_s: f.duration_s(),
                cutoff: &f.evidence,
                checkpoints: f
                    .checkpoints
                    .iter()
                    .map(|k| CheckpointJson {
                        fraction: k.fraction,
                        time_s: k.time_s,
                        true_remaining_s: k.true_remaining_s,
                        predicted_remaining_s: k.predicted_remaining_s,
                        sigma_s: k.sigma_s,
                        error_pct: METHODS
                            .iter()
                            .enumerate()
                            .map(|(m, n)| (*n, k.error_pct(m, f.duration_s())))
                            .collect(),
                        baselines: BaselinesView(&k.baselines),
                    })
                    .collect(),
                unavailable: reasons_view(&f.unavailable),
                final_state: f.final_state.iter().copied().collect(),
                pack_history: f
                    .capacity_reading
                    .as_ref()
                    .map(|r| HistoryJson::of(f.capacity_carried.as_ref(), r)),
                power_source: f.power_source,
            })
            .collect();
        serde_json::to_value(ReplayJson {
            methods: METHODS,
            flights,
            skipped: self
                .skipped
                .iter()
                .map(|k| SkippedJson {
                    name: &k.name,
                    reason: &k.reason,
                    pack_history: k
                        .capacity_reading
                        .as_ref()
                        .map(|r| HistoryJson::of(k.capacity_carried.as_ref(), r)),
                    trace: k
                        .trace
                        .as_ref()
                        .and_then(|t| t.as_ref().ok())
                        .map(TraceJson::of),
                    not_traced: k
                        .trace
                        .as_ref()
                        .and_then(|t| t.as_ref().err())
                        .map(String::as_str),
                })
                .collect(),
            summary: &self.summary,
        })
        .unwrap_or(serde_json::Value::Null)
    }

    /// The checkpoint table as CSV: one row per flight and checkpoint, predictions and errors
    /// per method.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("flight,fraction,time_s,duration_s,true_remaining_s");
        for m in METHODS {
            let _ = write!(s, ",{m}_remaining_s,{m}_error_pct");
        }
        s.push_str(",online_sigma_s\n");
        for f in &self.flights {
            for k in &f.checkpoints {
                let _ = write!(
                    s,
                    "{},{},{:.2},{:.2},{:.2}",
                    csv_field(&f.name),
                    k.fraction,
                    k.time_s,
                    f.duration_s(),
                    k.true_remaining_s
                );
                for m in 0..METHODS.len() {
                    let _ = write!(
                        s,
                        ",{},{}",
                        opt(k.of(m), 2),
                        opt(k.error_pct(m, f.duration_s()), 3)
                    );
                }
                let _ = writeln!(s, ",{}", opt(k.sigma_s, 2));
            }
        }
        s
    }

    /// The flights that landed before the cut-off and were traced ([`SkippedFlight::trace`]),
    /// as CSV: per plotted sample, each method's predicted remaining time to the cut-off and
    /// the online estimator's one-sigma band.
    pub fn unscored_csv(&self) -> String {
        let mut s = String::from("flight,time_since_takeoff_s");
        for m in METHODS {
            let _ = write!(s, ",{m}_remaining_s");
        }
        s.push_str(",online_sigma_s\n");
        let cell = |v: f64| opt(v.is_finite().then_some(v), 2);
        for k in &self.skipped {
            let Some(Ok(t)) = &k.trace else { continue };
            let name = csv_field(&k.name);
            for (i, time) in t.series_time_s.iter().enumerate() {
                let _ = write!(s, "{name},{:.2}", time - t.takeoff_s);
                for m in &t.series {
                    let _ = write!(s, ",{}", cell(m.remaining_s[i]));
                }
                let sigma = t.series.first().map_or(f64::NAN, |m| m.sigma_s[i]);
                let _ = writeln!(s, ",{}", cell(sigma));
            }
        }
        s
    }

    /// The text report: per flight, per checkpoint, the truth and each method's prediction and
    /// error; the skipped flights; the summary.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "remaining time to the cut-off, predicted sample by sample; error = (predicted - true) / flight duration"
        );
        for f in &self.flights {
            let _ = writeln!(
                s,
                "\n{}  flight {:.0} s (take-off {:.1} s, cut-off {:.1} s; {})",
                f.name,
                f.duration_s(),
                f.takeoff_s,
                f.end_s,
                match f.evidence {
                    CutoffEvidence::Metadata => "end = cutoff".to_owned(),
                    CutoffEvidence::Voltage { final_v, cutoff_v } =>
                        format!("ends at {final_v:.2} V, cut-off {cutoff_v:.2} V"),
                }
            );
            let _ = writeln!(
                s,
                "  {:>5}  {:>8}  {:>18}  {:>16}  {:>16}  {:>16}",
                "at",
                "true s",
                "online s ± σ (err)",
                "px4 s (err)",
                "coulomb s (err)",
                "static s (err)"
            );
            for k in &f.checkpoints {
                let d = f.duration_s();
                let cell = |m: usize| match (k.of(m), k.error_pct(m, d)) {
                    (Some(p), Some(e)) => format!("{p:.0} ({e:+.1} %)"),
                    _ => "-".to_owned(),
                };
                let online = match (k.predicted_remaining_s, k.sigma_s, k.error_pct(0, d)) {
                    (Some(p), Some(sg), Some(e)) => format!("{p:.0} ± {sg:.0} ({e:+.1} %)"),
                    (Some(_), None, _) => cell(0),
                    _ => "-".to_owned(),
                };
                let _ = writeln!(
                    s,
                    "  {:>4.0}%  {:>8.0}  {:>18}  {:>16}  {:>16}  {:>16}",
                    k.fraction * 100.0,
                    k.true_remaining_s,
                    online,
                    cell(1),
                    cell(2),
                    cell(3)
                );
            }
            for (m, r) in &f.unavailable {
                let _ = writeln!(s, "  {m}: {r}");
            }
            if let Some(line) = f.power_source.text() {
                let _ = writeln!(s, "  {line}");
            }
            if let Some((from, factor)) = &f.capacity_carried {
                s += &carried_line(from, *factor);
            }
            if let Some(r) = &f.capacity_reading {
                s += &reading_line(r);
            }
        }
        if !self.skipped.is_empty() {
            let _ = writeln!(s, "\nskipped ({}):", self.skipped.len());
            for k in &self.skipped {
                let _ = writeln!(s, "  {}: {}", k.name, k.reason);
                match &k.trace {
                    Some(Ok(t)) => s += &trace_line(t),
                    Some(Err(why)) => {
                        let _ = writeln!(s, "    not flown by the methods: {why}");
                    }
                    None => {}
                }
                if let Some((from, factor)) = &k.capacity_carried {
                    s += &carried_line(from, *factor);
                }
                if let Some(r) = &k.capacity_reading {
                    s += &reading_line(r);
                }
            }
        }
        let _ = writeln!(
            s,
            "\nsummary over {} flight(s) at the cut-off: median |error|, % of flight duration (flights)",
            self.summary.scored_flights
        );
        let _ = write!(s, "  {:>5}", "at");
        for m in METHODS {
            let _ = write!(s, "  {m:>16}");
        }
        s.push('\n');
        for c in &self.summary.checkpoints {
            let _ = write!(s, "  {:>4.0}%", c.fraction * 100.0);
            for m in METHODS {
                let cell = match c.median_abs_error_pct.get(m).copied().flatten() {
                    Some(v) => format!("{v:.2} % ({})", c.flights[m]),
                    None => "-".to_owned(),
                };
                let _ = write!(s, "  {cell:>16}");
            }
            s.push('\n');
        }
        let cov = self.summary.coverage;
        match cov.one_sigma {
            Some(c) => {
                let _ = writeln!(
                    s,
                    "  {ONLINE} one-sigma band covers the truth at {}/{} checkpoints ({:.0} %)",
                    cov.within_one_sigma,
                    cov.checkpoints,
                    c * 100.0
                );
            }
            None => {
                let _ = writeln!(s, "  {ONLINE} one-sigma band: no checkpoint scored");
            }
        }
        s
    }
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(String::new, |x| format!("{x:.decimals$}"))
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// `reason` with every number (digits, with their sign and decimal point) replaced by `#`.
fn without_numbers(reason: &str) -> String {
    let mut out = String::with_capacity(reason.len());
    let mut in_number = false;
    for c in reason.chars() {
        let numeric = c.is_ascii_digit() || (in_number && c == '.');
        if numeric {
            if !in_number {
                if out.ends_with(['-', '+', '\u{2212}']) {
                    out.pop();
                }
                out.push('#');
            }
        } else {
            out.push(c);
        }
        in_number = numeric;
    }
    out
}

/// What the methods said at landing on a flight that landed before the cut-off.
fn trace_line(t: &FlightTrace) -> String {
    let cells: Vec<String> = METHODS
        .iter()
        .zip(&t.at_landing)
        .filter_map(|(m, p)| {
            p.map(|(r, sigma)| match sigma {
                Some(sg) => format!("{m} {:.1} ± {:.1} min", r / 60.0, sg / 60.0),
                None => format!("{m} {:.1} min", r / 60.0),
            })
        })
        .collect();
    if cells.is_empty() {
        return format!(
            "    flew {:.0} s; no method gave a prediction\n",
            t.flown_s()
        );
    }
    format!(
        "    flew {:.0} s; left to the cut-off at landing, as predicted: {}\n",
        t.flown_s(),
        cells.join(", ")
    )
}

/// The text line of the reading a flight flew with (`--pack-history`).
fn carried_line(from: &str, factor: f64) -> String {
    format!(
        "  pack history: flew with the capacity {from} measured ({:.0} % of the model's)\n",
        100.0 * factor
    )
}

/// The text line of a flight's capacity reading, or of why it gives none (`--pack-history`).
fn reading_line(r: &Result<crate::history::CapacityReading, String>) -> String {
    match r {
        Ok(r) => format!(
            "  pack history: measured {:.3} Ah ({:.0} % of the model's {:.3} Ah; {:.3} Ah {} from {:.0} % of the charge to {:.0} %, the end read on the curve at the pack's voltage); {}\n",
            r.capacity_ah,
            100.0 * r.factor(),
            r.model_capacity_ah,
            r.counted_ah,
            if r.charge_from_model {
                "drawn by the estimator's power model (no current logged)"
            } else {
                "counted"
            },
            100.0 * r.start_soc,
            100.0 * r.end_soc,
            if r.carries() {
                "the pack's next flight flies with it".to_owned()
            } else {
                format!(
                    "within {:.0} % of the model's, so the pack's next flight flies with the model's capacity",
                    100.0 * crate::history::MIN_SHORTFALL
                )
            }
        ),
        Err(why) => format!("  pack history: no capacity reading: {why}\n"),
    }
}

/// The methods that gave no prediction, with the reason, as the JSON's `unavailable` map.
fn reasons_view<'a>(unavailable: &'a [(&'static str, String)]) -> BTreeMap<&'static str, &'a str> {
    unavailable.iter().map(|(m, r)| (*m, r.as_str())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skipped(reasons: &[&str]) -> Replay {
        let skipped = reasons
            .iter()
            .enumerate()
            .map(|(i, r)| SkippedFlight {
                name: format!("f{i}"),
                reason: (*r).to_owned(),
                capacity_reading: None,
                capacity_carried: None,
                trace: None,
            })
            .collect();
        Replay::new(Vec::new(), skipped)
    }

    #[test]
    fn the_most_common_skip_reason_counts_reasons_that_differ_only_in_numbers_as_one() {
        let r = skipped(&[
            "landed before the cut-off",
            "flies only 2.0 s (under 10 s)",
            "final voltage 11.42 V is above its 9.00 V cut-off",
            "flies only 4.5 s (under 10 s)",
            "final voltage -1 V is above its 9.00 V cut-off",
            "flies only 0.0 s (under 10 s)",
        ]);
        let (n, first) = r.most_common_skip().unwrap();
        assert_eq!((n, first.name.as_str()), (3, "f1"));
        assert_eq!(
            without_numbers("final voltage -1.25 V is above its 9.00 V cut-off"),
            "final voltage # V is above its # V cut-off"
        );
    }

    #[test]
    fn ties_go_to_the_reason_seen_first_and_nothing_skipped_gives_none() {
        let r = skipped(&["b 1", "a", "b 2", "a"]);
        assert_eq!(r.most_common_skip().unwrap().1.name, "f0");
        assert!(skipped(&[]).most_common_skip().is_none());
    }
}
