//! Flight logs in: battery voltage, current, altitude and flight phases of real flights, with
//! what is known about each flight, for comparing measured endurance with the paper's model.
//!
//! A flight set is a folder. Each flight is one log:
//!
//! - `NAME.csv` with a header: `time_s` and `voltage_v` required; `current_a`, `phase`
//!   (`ground`, `hover`, `climb`, `descend`, `attached`, `transition`), `altitude_m`, `throttle`
//!   and the motor commands `motor1_us`, `motor2_us`, … optional; any rate of at least 1 Hz
//!   ([`csvlog`]);
//! - the Crazyflie dataset's CSV (`x_estimate,y_estimate,z_estimate,battery_voltage` at 100 Hz),
//!   alone or as the dataset's folder with `Real_path/` and `Planned_trajectories/`, with
//!   documented platform defaults ([`crazyflie`]);
//! - a PX4 ULog `.ulg` ([`ulog`]) or an ArduPilot DataFlash `.bin` ([`dataflash`]), or the
//!   same DataFlash as text (`.log`: Mission Planner's "convert .bin to .log", older
//!   firmware's text logs; [`dataflash::DataFlash::parse_text`]);
//! - a ground station's MAVLink telemetry log `.tlog` ([`tlog`]), when the autopilot's own
//!   log is not at hand.
//!
//! A binary log's batteries (every ULog `battery_status` instance; DataFlash `BAT`, `BAT2`,
//! ArduCopter 3.x `CURR` and `BCL`) go through one check ([`battery`]): a battery that is not
//! connected, or whose voltage is implausible for its cell count, is skipped with that reason
//! ([`SkipReason`], [`FlightLogError::NoUsableBattery`]). The motor commands (ESC outputs,
//! PWM µs: ULog `actuator_outputs`, DataFlash `RCOU`, MAVLink `SERVO_OUTPUT_RAW`) are read for
//! the vehicle's motors only, as many as its parameters or type say, and only when they are PWM
//! pulses ([`motors`], [`Samples::motor_us`]); the Crazyflie dataset has none. What the log says
//! about itself —
//! firmware, vehicle type, metadata from its own parameters — is its [`LogInfo`].
//!
//! Metadata ([`FlightMeta`]) is layered, each value with its source ([`Flight::metadata`],
//! [`MetaSource`]): platform defaults, then the log's own parameters, then the folder's
//! `flights.toml`, then the sidecar `NAME.toml` ([`meta`]). A log without phases gets them
//! inferred from its current, altitude and land detector for the vehicle it is: `attached`
//! only for a robot whose metadata says `perches = true`, `transition` only for a VTOL; each
//! phase with its evidence ([`PhaseSource::Inferred`], [`phase`]). One bad flight never stops
//! the others: it is listed in [`FlightSet::skipped`] with the reason. [`summary`] computes what
//! `hoverbench flights` prints.
//!
//! Main types: [`FlightSet`] (a folder read), [`Flight`] (one log: [`Samples`], [`FlightMeta`],
//! [`PhaseSource`], [`LogInfo`]), [`Phase`], [`FlightSummary`], [`FlightLogError`] (every error
//! names the file and the line or byte offset and the field). The library never prints and
//! never panics on any input.
//!
//! ```
//! use std::path::Path;
//! use flightlog::{Flight, LogFormat, Phase, PhaseSource};
//!
//! let csv = "time_s,voltage_v,current_a,altitude_m\n\
//!            0.0,12.6,0.4,0.0\n0.5,12.6,0.4,0.0\n1.0,12.5,9.0,0.5\n1.5,12.4,9.1,1.0\n\
//!            2.0,12.4,9.0,1.0\n2.5,12.4,9.0,1.0\n3.0,12.3,9.0,1.0\n";
//! let flight = Flight::parse(csv.as_bytes(), Path::new("hover.csv"), LogFormat::Csv)?;
//! assert_eq!(flight.name, "hover");
//! assert_eq!(flight.samples.len(), 7);
//! assert!((flight.samples.duration_s() - 3.0).abs() < 1e-12);
//! let phases = flight.samples.phase.as_ref().unwrap();
//! assert_eq!(phases[0], Phase::Ground);
//! assert!(matches!(flight.phase_source, PhaseSource::Inferred { .. }));
//! let flying_s = flight.samples.time_in_s(Phase::is_flying).unwrap();
//! assert!((flying_s - 2.0).abs() < 1e-12); // from 1.0 s to the last sample at 3.0 s
//! # Ok::<(), flightlog::FlightLogError>(())
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub mod battery;
pub mod crazyflie;
pub mod csvlog;
pub mod dataflash;
mod error;
pub mod loginfo;
pub mod meta;
pub mod motors;
pub mod phase;
mod resample;
mod set;
pub mod summary;
pub mod tlog;
pub mod ulog;

pub use battery::{BatteryInfo, SkipReason, SkippedBattery};
pub use error::FlightLogError;
pub use loginfo::{LogInfo, Vehicle, VehicleKind};
pub use meta::{End, FlightMeta, MetaLayer, MetaSource, MetaValue};
pub use phase::{
    Capabilities, InferenceMethod, InferenceSignals, Phase, PhaseEvidence, PhaseFractions,
    PhaseSource,
};
pub use set::{FlightSet, Skipped, natural_cmp};
pub use summary::{FlightSummary, SetSummary};

/// Lowest plausible peak electrical power of a flying vehicle per battery cell, W: a check of
/// the current sensor ([`Flight::plausibility_warnings`]). A 1S Crazyflie peaks near 10 W;
/// multirotors on 3S–6S draw 100 W or more.
pub const MIN_FLYING_POWER_PER_CELL_W: f64 = 8.0;

/// Longest gap allowed between two samples, s: a longer one is a hole in the log.
pub const MAX_GAP_S: f64 = 5.0;

/// The samples of one flight, all on one time base (every present column has `time_s.len()`
/// values).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    /// Time, s, strictly increasing: as logged for CSV, from the first battery sample for ULog
    /// and DataFlash, `row / 100 Hz` for the Crazyflie dataset.
    pub time_s: Vec<f64>,
    /// Battery voltage, V.
    pub voltage_v: Vec<f64>,
    /// Battery current, A.
    pub current_a: Option<Vec<f64>>,
    /// Phase of each sample, logged or inferred (see [`Flight::phase_source`]).
    pub phase: Option<Vec<Phase>>,
    /// Altitude (above the log's origin or ground), m.
    pub altitude_m: Option<Vec<f64>>,
    /// Throttle as logged (0–1 for DataFlash `CTUN.ThO`).
    pub throttle: Option<Vec<f64>>,
    /// A land detector's verdict (PX4 `vehicle_land_detected.landed`), when logged.
    pub landed: Option<Vec<bool>>,
    /// A VTOL's own state: in transition or in fixed-wing flight (PX4
    /// `vtol_vehicle_status`), when logged.
    pub vtol_transition: Option<Vec<bool>>,
    /// The motor commands, PWM µs as the flight controller commanded each ESC: one inner
    /// `Vec` per motor (motor 1 first, in the order of the flight controller's outputs), each
    /// with one value per sample. From the CSV's `motor1_us`, `motor2_us`, … as written; from
    /// a binary log ([`motors`]: PX4 `actuator_outputs`, ArduPilot `RCOU`, MAVLink
    /// `SERVO_OUTPUT_RAW`) only the vehicle's motors (their count from the log's own
    /// parameters or vehicle type) and only when every command read lies in
    /// [`motors::PWM_RANGE_US`], put on the battery's times by the crate's one rule for other
    /// topics (as `altitude_m` and `throttle`): linear interpolation between the two commands
    /// around a battery sample (not an average over its interval), the first or last command
    /// held before the first or after the last. Never NaN. `None` when the log has no motor
    /// outputs or they cannot be read as PWM for the motors (the flight's warnings say why).
    pub motor_us: Option<Vec<Vec<f64>>>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Time from the first to the last sample, s.
    pub fn duration_s(&self) -> f64 {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Electrical power `voltage_v × current_a`, W, when current is logged.
    pub fn power_w(&self) -> Option<Vec<f64>> {
        let current = self.current_a.as_ref()?;
        Some(
            self.voltage_v
                .iter()
                .zip(current)
                .map(|(v, i)| v * i)
                .collect(),
        )
    }

    /// Time spent in phases matching `which`, s: each sample counts for the interval to the
    /// next one. `None` without phases.
    pub fn time_in_s(&self, which: impl Fn(Phase) -> bool) -> Option<f64> {
        let phases = self.phase.as_ref()?;
        Some(
            self.time_s
                .windows(2)
                .zip(phases)
                .filter(|&(_, &p)| which(p))
                .map(|(w, _)| w[1] - w[0])
                .sum(),
        )
    }

    /// Whether every present column has one value per time.
    pub fn is_consistent(&self) -> bool {
        let n = self.time_s.len();
        self.voltage_v.len() == n
            && self.current_a.as_ref().is_none_or(|c| c.len() == n)
            && self.phase.as_ref().is_none_or(|c| c.len() == n)
            && self.altitude_m.as_ref().is_none_or(|c| c.len() == n)
            && self.throttle.as_ref().is_none_or(|c| c.len() == n)
            && self.landed.as_ref().is_none_or(|c| c.len() == n)
            && self.vtol_transition.as_ref().is_none_or(|c| c.len() == n)
            && self
                .motor_us
                .as_ref()
                .is_none_or(|m| m.iter().all(|c| c.len() == n))
    }
}

/// The format a log was read as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    /// A CSV with a `time_s`, `voltage_v`, … header.
    Csv,
    /// The Crazyflie dataset's CSV (`x_estimate,y_estimate,z_estimate,battery_voltage`).
    Crazyflie,
    /// PX4 ULog.
    Ulog,
    /// ArduPilot DataFlash.
    DataFlash,
    /// ArduPilot DataFlash as text (`.log`: Mission Planner's conversion of a `.bin`, or older
    /// firmware's text logs).
    DataFlashText,
    /// A ground station's MAVLink telemetry log (`.tlog`).
    Tlog,
}

impl LogFormat {
    /// The format of a log from its extension, and for CSV its header.
    pub fn detect(path: &Path, bytes: &[u8]) -> Result<Self, FlightLogError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("ulg") => Ok(Self::Ulog),
            Some("bin") => Ok(Self::DataFlash),
            Some("tlog") => Ok(Self::Tlog),
            Some("log" | "txt") if dataflash::is_text_log(bytes) => Ok(Self::DataFlashText),
            Some("log") => Err(FlightLogError::UnknownFormat {
                path: path.to_owned(),
                message:
                    "a .log that is not an ArduPilot text log (its first line is not `FMT, 128, …`)"
                        .to_owned(),
            }),
            Some("csv") if crazyflie::has_header(bytes) => Ok(Self::Crazyflie),
            Some("csv") => Ok(Self::Csv),
            _ if bytes.starts_with(&ulog::MAGIC) => Ok(Self::Ulog),
            _ if bytes.starts_with(&dataflash::MAGIC) => Ok(Self::DataFlash),
            _ if dataflash::is_text_log(bytes) => Ok(Self::DataFlashText),
            _ if tlog::looks_like_tlog(bytes) => Ok(Self::Tlog),
            _ => Err(FlightLogError::UnknownFormat {
                path: path.to_owned(),
                message: "not a .csv, .ulg, .bin, text .log or .tlog flight log".to_owned(),
            }),
        }
    }
}

/// A time for a message, to the millisecond (a time derived from positions in the log has
/// more digits than it means).
fn round_3(t: f64) -> f64 {
    (t * 1000.0).round() / 1000.0
}

/// One flight: its samples, what is known about it, and where its phases come from.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight {
    /// The log's file name without extension.
    pub name: String,
    /// The log file.
    pub source: PathBuf,
    /// The format it was read as.
    pub format: LogFormat,
    /// The samples.
    pub samples: Samples,
    /// Metadata: platform defaults, then the log's own parameters, then the folder's
    /// `flights.toml`, then the sidecar.
    pub meta: FlightMeta,
    /// Every key of [`Flight::meta`] with its value and where it came from.
    pub metadata: BTreeMap<String, MetaValue>,
    /// What the log says about itself: firmware, vehicle, the battery read.
    pub log: LogInfo,
    /// Whether the phases were logged, inferred (and how), or are absent.
    pub phase_source: PhaseSource,
    /// Planned waypoints (x, y, z), m, when the log comes with a plan (Crazyflie).
    pub planned_waypoints_m: Option<Vec<[f64; 3]>>,
    /// Things a reader should know that did not stop the flight being read (ignored columns,
    /// a truncated final record, dropped samples).
    pub warnings: Vec<String>,
}

impl Flight {
    /// Reads a log file, its format from the extension (and the CSV header). The metadata is
    /// the format's platform defaults only; [`FlightSet`] adds sidecars and folder defaults.
    pub fn read(path: &Path) -> Result<Self, FlightLogError> {
        let bytes = std::fs::read(path).map_err(|error| FlightLogError::Io {
            path: path.to_owned(),
            error,
        })?;
        let format = LogFormat::detect(path, &bytes)?;
        Self::parse(&bytes, path, format)
    }

    /// Parses a log held in memory; `source` names it (and gives the flight its name).
    pub fn parse(bytes: &[u8], source: &Path, format: LogFormat) -> Result<Self, FlightLogError> {
        let decoded = match format {
            LogFormat::Csv => csvlog::parse(bytes, source)?,
            LogFormat::Crazyflie => crazyflie::parse(bytes, source)?,
            LogFormat::Ulog => ulog::parse(bytes, source)?,
            LogFormat::DataFlash => dataflash::parse(bytes, source)?,
            LogFormat::DataFlashText => dataflash::parse_text(bytes, source)?,
            LogFormat::Tlog => tlog::parse(bytes, source)?,
        };
        let below = match format {
            LogFormat::Crazyflie => vec![crazyflie::platform_layer()],
            _ => Vec::new(),
        };
        let Decoded {
            mut samples,
            landed,
            warnings,
            info,
        } = decoded;
        samples.landed = landed;
        let mut flight = Self {
            name: flight_name(source),
            source: source.to_owned(),
            format,
            samples,
            meta: FlightMeta::default(),
            metadata: BTreeMap::new(),
            log: info,
            phase_source: PhaseSource::None,
            planned_waypoints_m: None,
            warnings,
        };
        flight.set_metadata(&below, &[]);
        Ok(flight)
    }

    /// The log's own metadata as a layer ([`MetaSource::Log`], each key with its parameter).
    pub fn log_layer(&self) -> MetaLayer {
        MetaLayer {
            meta: self.log.meta.clone(),
            source: MetaSource::Log {
                origin: "log".to_owned(),
            },
            origins: self.log.meta_origins.clone(),
        }
    }

    /// Sets the metadata from layers below the log's own (platform defaults) and above it
    /// (folder `flights.toml`, then sidecar), lowest first, and infers the phases again for
    /// the vehicle they describe (unless the log has phases).
    pub fn set_metadata(&mut self, below_log: &[MetaLayer], above_log: &[MetaLayer]) {
        let mut layers = below_log.to_vec();
        layers.push(self.log_layer());
        layers.extend_from_slice(above_log);
        let (meta, values) = FlightMeta::resolve(&layers);
        self.meta = meta;
        self.metadata = values;
        self.infer_phases();
    }

    /// Checks of what was read that do not stop a flight being read, in words: a current
    /// sensor that reads too little for the vehicle to fly (peak power below
    /// [`MIN_FLYING_POWER_PER_CELL_W`] per cell while airborne for at least 5 s).
    pub fn plausibility_warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let s = &self.samples;
        if let (Some(power), Some(phases), Some(cells)) = (s.power_w(), &s.phase, self.meta.cells) {
            let airborne_s = s.time_in_s(Phase::is_flying).unwrap_or(0.0);
            let peak = power
                .iter()
                .zip(phases)
                .filter(|(_, p)| p.is_flying())
                .map(|(w, _)| *w)
                .fold(f64::NEG_INFINITY, f64::max);
            let floor = MIN_FLYING_POWER_PER_CELL_W * f64::from(cells);
            if airborne_s >= 5.0 && peak < floor {
                out.push(format!(
                    "current implausibly low: {peak:.1} W at most while flying for \
                     {airborne_s:.0} s, below {floor:.0} W ({MIN_FLYING_POWER_PER_CELL_W} W per \
                     cell × {cells}); check the current sensor's calibration (PX4 BAT*_A_PER_V, \
                     ArduPilot BATT_AMP_PERVLT) before using this flight's power"
                ));
            }
        }
        out
    }

    /// Checks the battery voltage against the cell count of the metadata (which a sidecar or
    /// the folder may have set after the log was read): a median voltage outside
    /// [`battery::MIN_CELL_V`]–[`battery::MAX_CELL_V`] per cell is
    /// [`FlightLogError::NoUsableBattery`] with [`SkipReason::ImplausibleVoltage`].
    /// [`FlightSet`] skips such a flight.
    pub fn check_battery(&self) -> Result<(), FlightLogError> {
        let Some(cells) = self.meta.cells else {
            return Ok(());
        };
        let mut sorted = self.samples.voltage_v.clone();
        sorted.sort_by(f64::total_cmp);
        let Some(&median_v) = sorted.get(sorted.len() / 2) else {
            return Ok(());
        };
        let c = f64::from(cells);
        let range_v = [battery::MIN_CELL_V * c, battery::MAX_CELL_V * c];
        if (range_v[0]..=range_v[1]).contains(&median_v) {
            return Ok(());
        }
        let battery = self
            .log
            .battery
            .as_ref()
            .map_or_else(|| "voltage_v".to_owned(), |b| b.battery.clone());
        let source = self
            .metadata
            .get("cells")
            .map_or_else(String::new, |v| format!(" (cells from {})", v.source));
        Err(FlightLogError::NoUsableBattery {
            path: self.source.clone(),
            batteries: vec![SkippedBattery {
                battery: format!("{battery}{source}"),
                reason: SkipReason::ImplausibleVoltage {
                    median_v,
                    cells: Some(cells),
                    range_v,
                },
            }],
        })
    }

    /// What the vehicle can do, from its metadata: perch (`perches = true`) and fly as a VTOL
    /// (`vehicle = "vtol"`), each with its source.
    pub fn capabilities(&self) -> Capabilities {
        let why = |key: &str| {
            self.metadata.get(key).map_or_else(String::new, |v| {
                format!("{key} = {} from {}", v.value, v.source)
            })
        };
        Capabilities {
            perches: (self.meta.perches == Some(true)).then(|| why("perches")),
            vtol: (self.meta.vehicle == Some(VehicleKind::Vtol)).then(|| why("vehicle")),
        }
    }

    /// Why the flight is not one of a hovering vehicle, when its metadata's `vehicle` says it
    /// is a fixed-wing aircraft or a ground or water vehicle (an ArduPlane, ArduRover or ArduSub
    /// log, a MAVLink `MAV_TYPE` of a plane, boat or submarine): its flight phases are not
    /// inferred, and the paper's endurance model (eqs. 1–9: rotor power at hover) does not
    /// describe it. `None` for a hovering vehicle or one the metadata does not name.
    pub fn not_hovering(&self) -> Option<String> {
        let kind = self.meta.vehicle?;
        if kind.hovers() != Some(false) {
            return None;
        }
        let source = self
            .metadata
            .get("vehicle")
            .map_or_else(String::new, |v| format!(" according to the {}", v.source));
        Some(format!(
            "the vehicle is {}{source}: it does not hover, and hoverbench's endurance models are for hovering vehicles (multirotors, helicopters, VTOLs)",
            kind.words()
        ))
    }

    /// Infers the phases from the samples and [`Flight::capabilities`], unless they were
    /// logged (a phase column). A vehicle that does not hover ([`Flight::not_hovering`]) gets
    /// none, and a warning says why.
    pub fn infer_phases(&mut self) {
        let logged = match &self.phase_source {
            PhaseSource::Logged => true,
            PhaseSource::None => self.samples.phase.is_some(),
            PhaseSource::Inferred { .. } => false,
        };
        if logged {
            self.phase_source = PhaseSource::Logged;
            return;
        }
        if let Some(why) = self.not_hovering() {
            self.samples.phase = None;
            self.phase_source = PhaseSource::None;
            let warning = format!("phases not inferred: {why}");
            if !self.warnings.contains(&warning) {
                self.warnings.push(warning);
            }
            return;
        }
        let caps = self.capabilities();
        match phase::infer_vtol(
            phase::Signals {
                time_s: &self.samples.time_s,
                current_a: self.samples.current_a.as_deref(),
                altitude_m: self.samples.altitude_m.as_deref(),
                landed: self.samples.landed.as_deref(),
            },
            &caps,
            self.samples.vtol_transition.as_deref(),
        ) {
            Some((phases, source)) => {
                self.samples.phase = Some(phases);
                self.phase_source = source;
            }
            None => {
                self.samples.phase = None;
                self.phase_source = PhaseSource::None;
            }
        }
    }
}

/// One message of a binary log, reduced to the numeric fields asked for; `None` for a field
/// the message's format lacks.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Position of the message in the file: its byte offset, or its 1-based line in a text
    /// log.
    pub offset: u64,
    /// The fields' values, in the order asked for.
    pub values: Vec<Option<f64>>,
}

impl Row {
    /// The rows that have a value for each of `fields` (indices into [`Row::values`]). The
    /// readers fill a required field in every row, so this drops nothing for them; it lets
    /// their values be read without a stand-in for "missing".
    pub(crate) fn having<'a>(rows: &'a [Row], fields: &[usize]) -> Vec<&'a Row> {
        rows.iter()
            .filter(|r| {
                fields
                    .iter()
                    .all(|&k| r.values.get(k).is_some_and(Option::is_some))
            })
            .collect()
    }
}

/// What a format decoder hands over: samples, an optional land detector, warnings.
#[derive(Debug, Default)]
pub(crate) struct Decoded {
    pub(crate) samples: Samples,
    pub(crate) landed: Option<Vec<bool>>,
    pub(crate) warnings: Vec<String>,
    pub(crate) info: LogInfo,
}

impl Decoded {
    /// A log without phases or a land detector (DataFlash, telemetry logs): the battery's
    /// samples kept, altitude, throttle and motor commands on their times, what was read past, what the log
    /// says about itself.
    pub(crate) fn battery_log(
        chosen: battery::Chosen,
        altitude_m: Option<Vec<f64>>,
        throttle: Option<Vec<f64>>,
        motor_us: Option<Vec<Vec<f64>>>,
        warnings: Vec<String>,
        info: LogInfo,
    ) -> Self {
        Self {
            samples: Samples {
                time_s: chosen.time_s,
                voltage_v: chosen.voltage_v,
                current_a: chosen.current_a,
                altitude_m,
                throttle,
                motor_us,
                ..Samples::default()
            },
            landed: None,
            warnings,
            info,
        }
    }
}

/// A log's name: its file name without extension.
pub(crate) fn flight_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// Checks that time is strictly increasing, sampled at 1 Hz or faster (median interval) and
/// without holes longer than [`MAX_GAP_S`]. `locate(i)` says where sample `i` is (`line 12`,
/// `byte 4096`); `field` names the time field.
pub(crate) fn check_time(
    path: &Path,
    time_s: &[f64],
    field: &str,
    locate: impl Fn(usize) -> String,
) -> Result<(), FlightLogError> {
    let fail = |i: usize, message: String| FlightLogError::Time {
        path: path.to_owned(),
        location: locate(i),
        field: field.to_owned(),
        message,
    };
    if time_s.len() < 2 {
        return Err(FlightLogError::TooShort {
            path: path.to_owned(),
            samples: time_s.len(),
        });
    }
    let mut intervals = Vec::with_capacity(time_s.len() - 1);
    for i in 1..time_s.len() {
        let dt = time_s[i] - time_s[i - 1];
        if dt.is_nan() || dt <= 0.0 {
            return Err(fail(
                i,
                format!(
                    "time goes from {} s to {} s: it must increase",
                    time_s[i - 1],
                    time_s[i]
                ),
            ));
        }
        if dt > MAX_GAP_S {
            return Err(fail(
                i,
                format!(
                    "{} s without a sample (from {} s): longer than {MAX_GAP_S} s",
                    round_3(dt),
                    round_3(time_s[i - 1])
                ),
            ));
        }
        intervals.push(dt);
    }
    let mid = intervals.len() / 2;
    let (_, median, _) = intervals.select_nth_unstable_by(mid, f64::total_cmp);
    if *median > 1.0 {
        return Err(fail(
            0,
            format!(
                "median sample interval {} s: the rate must be at least 1 Hz",
                *median
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_having_fields_keep_only_complete_ones() {
        let row = |offset, values: Vec<Option<f64>>| Row { offset, values };
        let rows = [
            row(0, vec![Some(1.0), Some(2.0), None]),
            row(1, vec![Some(1.0), None, Some(3.0)]),
            row(2, vec![Some(1.0)]),
        ];
        let offsets =
            |k: &[usize]| -> Vec<u64> { Row::having(&rows, k).iter().map(|r| r.offset).collect() };
        assert_eq!(offsets(&[0, 1]), [0]);
        assert_eq!(offsets(&[0]), [0, 1, 2]);
        assert_eq!(offsets(&[2]), [1]);
    }

    #[test]
    fn time_checks() {
        let p = Path::new("x.csv");
        let at = |i: usize| format!("row {i}");
        assert!(check_time(p, &[0.0, 0.5, 1.0], "time_s", at).is_ok());
        let e = check_time(p, &[0.0, 0.5, 0.5], "time_s", at).unwrap_err();
        assert!(e.to_string().contains("row 2"), "{e}");
        let e = check_time(p, &[0.0, 2.0, 4.0], "time_s", at).unwrap_err();
        assert!(e.to_string().contains("1 Hz"), "{e}");
        let e = check_time(p, &[0.0, 0.1, 9.0, 9.1], "time_s", at).unwrap_err();
        assert!(e.to_string().contains("without a sample"), "{e}");
        assert!(matches!(
            check_time(p, &[0.0], "time_s", at),
            Err(FlightLogError::TooShort { samples: 1, .. })
        ));
    }
}
