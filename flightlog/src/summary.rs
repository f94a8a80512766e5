//! What `hoverbench flights` shows about a set of logs: per flight its format, span, rate,
//! voltage and current ranges, energy drawn, motor commands, phases with their source, metadata with its
//! source and warnings; per skipped file its reason. Computed here; the CLI only formats.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::{Flight, FlightSet, LogFormat, PhaseEvidence, PhaseSource};

/// One flight, summarised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightSummary {
    /// The flight's name (file name without extension).
    pub name: String,
    /// The log file.
    pub file: String,
    /// `csv`, `crazyflie`, `ulog` or `dataflash`.
    pub format: &'static str,
    /// From the first to the last sample, s.
    pub duration_s: f64,
    /// Samples kept.
    pub samples: usize,
    /// Mean sample rate, Hz.
    pub rate_hz: f64,
    /// Lowest and highest battery voltage, V (`None`: no finite reading).
    pub voltage_v: Option<[f64; 2]>,
    /// Lowest and highest current, A, when logged.
    pub current_a: Option<[f64; 2]>,
    /// Energy drawn, Wh (∫ V·I dt, trapezoidal), when current is logged.
    pub energy_wh: Option<f64>,
    /// Fraction of the samples in each phase present.
    pub phases: BTreeMap<String, f64>,
    /// Where the phases come from: `logged`, `inferred from …`, or `none`.
    pub phase_source: String,
    /// For inferred phases, what put samples in each.
    pub phase_evidence: Vec<PhaseEvidence>,
    /// Notes of the phase inference.
    pub phase_notes: Vec<String>,
    /// Every metadata value with its source.
    pub metadata: BTreeMap<String, MetaEntry>,
    /// Firmware, as the log names it.
    pub firmware: Option<String>,
    /// The vehicle, as the log describes it.
    pub vehicle: Option<String>,
    /// The battery read (and the others, skipped or not used).
    pub battery: Option<String>,
    /// The motor commands, when the flight has them ([`crate::Samples::motor_us`]).
    pub motors: Option<MotorsSummary>,
    /// What did not stop the flight being read.
    pub warnings: Vec<String>,
}

/// A flight's motor commands, summarised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MotorsSummary {
    /// How many motors (outputs) there are.
    pub outputs: usize,
    /// Lowest and highest command over every motor, µs (`None`: no sample).
    pub range_us: Option<[f64; 2]>,
    /// Where they were read (`RCOU.C1–C4 (FRAME_CLASS 1 (quad); …)`); `None` for a CSV's
    /// `motorN_us` columns.
    pub source: Option<String>,
}

/// One metadata value and its source, in words.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetaEntry {
    /// The value.
    pub value: toml::Value,
    /// Its source: `log (BAT1_N_CELLS)`, `sidecar (a.toml)`, `folder (flights.toml)`,
    /// `default (…)`.
    pub source: String,
}

/// A file that was not read, and why.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct SkippedSummary {
    /// The file.
    pub file: String,
    /// Why, with every cause.
    pub reason: String,
}

/// A set of logs, summarised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetSummary {
    /// The flights read.
    pub flights: Vec<FlightSummary>,
    /// The files skipped, with their reasons.
    pub skipped: Vec<SkippedSummary>,
}

/// Lowest and highest of finite values.
fn range(values: &[f64]) -> Option<[f64; 2]> {
    let mut it = values.iter().copied().filter(|v| v.is_finite());
    let first = it.next()?;
    Some(it.fold([first, first], |[lo, hi], v| [lo.min(v), hi.max(v)]))
}

/// Rounds to `digits` decimals (for stable output).
fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

/// The name of a format.
pub fn format_name(format: LogFormat) -> &'static str {
    match format {
        LogFormat::Csv => "csv",
        LogFormat::Crazyflie => "crazyflie",
        LogFormat::Ulog => "ulog",
        LogFormat::DataFlash => "dataflash",
        LogFormat::DataFlashText => "dataflash-text",
        LogFormat::Tlog => "tlog",
    }
}

/// An error with its causes, `: `-joined (for a one-line reason: a skipped file, a warning).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let c_text = c.to_string();
        if !text.contains(&c_text) {
            text.push_str(": ");
            text.push_str(&c_text);
        }
        cause = c.source();
    }
    text
}

impl FlightSummary {
    /// Summarises a flight.
    pub fn of(flight: &Flight) -> Self {
        let s = &flight.samples;
        let duration_s = s.duration_s();
        let voltage_v = range(&s.voltage_v);
        let current_a = s.current_a.as_deref().and_then(range);
        let energy_wh = s.power_w().map(|p| {
            let joules: f64 = s
                .time_s
                .windows(2)
                .zip(p.windows(2))
                .map(|(t, p)| 0.5 * (p[0] + p[1]) * (t[1] - t[0]))
                .sum();
            round(joules / 3600.0, 4)
        });
        let mut phases = BTreeMap::new();
        if let Some(p) = &s.phase {
            let f = crate::PhaseFractions::of(p);
            for phase in crate::Phase::ALL {
                if f.get(phase) > 0.0 {
                    phases.insert(phase.name().to_owned(), round(f.get(phase), 4));
                }
            }
        }
        let (phase_source, phase_evidence, phase_notes) = match &flight.phase_source {
            PhaseSource::Logged => ("logged".to_owned(), Vec::new(), Vec::new()),
            PhaseSource::Inferred { method, notes } => {
                let signals = match method.signals {
                    crate::InferenceSignals::CurrentAndAltitude => "current and altitude",
                    crate::InferenceSignals::Current => "current",
                    crate::InferenceSignals::Altitude => "altitude",
                    crate::InferenceSignals::LandDetector => "land detector and altitude",
                };
                let evidence = method
                    .evidence
                    .iter()
                    .map(|e| PhaseEvidence {
                        fraction: round(e.fraction, 4),
                        ..e.clone()
                    })
                    .collect();
                (format!("inferred from {signals}"), evidence, notes.clone())
            }
            PhaseSource::None => ("none".to_owned(), Vec::new(), Vec::new()),
        };
        let metadata = flight
            .metadata
            .iter()
            .map(|(k, v)| {
                let value = match &v.value {
                    toml::Value::Float(x) => toml::Value::Float(round(*x, 4)),
                    other => other.clone(),
                };
                (
                    k.clone(),
                    MetaEntry {
                        value,
                        source: v.source.to_string(),
                    },
                )
            })
            .collect();
        let battery = flight.log.battery.as_ref().map(|b| {
            let mut text = b.battery.clone();
            if let Some([lo, hi]) = b.remaining {
                text.push_str(&format!(
                    ", remaining {:.0}–{:.0} %",
                    100.0 * lo,
                    100.0 * hi
                ));
            }
            if let Some(w) = b.max_warning {
                text.push_str(&format!(", highest warning {w}"));
            }
            if !b.others.is_empty() {
                text.push_str(&format!(" (others: {})", b.others.join("; ")));
            }
            text
        });
        Self {
            name: flight.name.clone(),
            file: flight.source.display().to_string(),
            format: format_name(flight.format),
            duration_s: round(duration_s, 3),
            samples: s.len(),
            rate_hz: if duration_s > 0.0 {
                round((s.len() - 1) as f64 / duration_s, 3)
            } else {
                0.0
            },
            voltage_v: voltage_v.map(|v| v.map(|v| round(v, 4))),
            current_a: current_a.map(|c| c.map(|v| round(v, 4))),
            energy_wh,
            phases,
            phase_source,
            phase_evidence,
            phase_notes,
            metadata,
            firmware: flight.log.firmware.clone(),
            vehicle: flight.log.vehicle.as_ref().map(|v| v.description.clone()),
            battery,
            motors: s.motor_us.as_ref().map(|m| MotorsSummary {
                outputs: m.len(),
                range_us: crate::motors::range_us(m).map(|r| r.map(|v| round(v, 1))),
                source: flight.log.motors.clone(),
            }),
            warnings: flight
                .warnings
                .iter()
                .cloned()
                .chain(flight.plausibility_warnings())
                .collect(),
        }
    }
}

impl SetSummary {
    /// Summarises a flight set.
    pub fn of(set: &FlightSet) -> Self {
        Self {
            flights: set.flights.iter().map(FlightSummary::of).collect(),
            skipped: set
                .skipped
                .iter()
                .map(|s| SkippedSummary {
                    file: s.path.display().to_string(),
                    reason: s.why(),
                })
                .collect(),
        }
    }
}
