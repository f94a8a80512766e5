//! The characterisation seam: a nominal sweep and an optional limit sweep → `params.toml` and a
//! fit summary.
//!
//! `hoverbench fit`, the characterise session (`rig-host`) and the reports all turn sweeps into
//! parameters through [`fit_sweeps`] (and the reports take a thrust limit through
//! [`LimitSweep::thrust_limit`]), so the three agree on how power is obtained, what is
//! plausible, how repeated throttle set-points are treated and what a missing voltage means.
//! The module reads nothing: callers parse the logs with [`import::stand::StandLog`] (or a
//! generic [`import::XySeries`]) and hand them in.
//!
//! ```
//! use fit::sweeps::{LimitSweep, NominalSweep, SweepFitOptions, fit_sweeps};
//! use import::stand::{StandLog, StandOptions};
//!
//! let mut csv = String::from("thrust_g,voltage_v,current_a,power_w\n");
//! for i in 0..=20 {
//!     let t = 10.0 * f64::from(i);
//!     let p = 0.16 * t + 0.34 * (t / 100.0).powf(5.3);
//!     csv += &format!("{t},12.5,{},{p}\n", p / 12.5);
//! }
//! let nominal = StandLog::parse(csv.into_bytes(), "sweep.csv", &StandOptions::default())?;
//! let mut lim = String::from("throttle,thrust_g,voltage_v\n");
//! for (i, t) in [150.0, 220.0, 260.0, 271.0, 270.5, 271.2].iter().enumerate() {
//!     lim += &format!("{},{t},9.0\n", 1500 + 50 * i);
//! }
//! let limit = StandLog::parse(lim.into_bytes(), "limit.csv", &StandOptions::default())?;
//!
//! let nominal = NominalSweep::from_stand(&nominal, None)?;
//! let limit = LimitSweep::from_stand(&limit, None)?;
//! let done = fit_sweeps(&nominal, Some(&limit), &SweepFitOptions::new(4, "doc test"))?;
//! assert!(done.summary.r_squared > 0.9999);
//! let m_l = done.summary.thrust_limit_g.unwrap();
//! assert!(m_l > 260.0 && m_l <= 271.2, "{m_l}");
//! assert_eq!(done.params.thrust_limit.unwrap().supply_voltage_v, 9.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use estimator::file::{MotorSection, MotorSweepSection, ParamsFile, Provenance};
use import::stand::{PowerSource, StandLog, Step, ThrustOddity};

use crate::export::{CurveLabels, LimitRecord, params_file};
use crate::motor::{MotorMapFit, MotorMapOptions, MotorPoints, SweepResidual, fit_motor_map};
use crate::{FitError, PolyFit, ThrustLimit, ThrustLimitOptions, thrust_limit};

/// The rig's command range when no log states it, µs: the standard RC PWM range.
pub const DEFAULT_COMMAND_RANGE_US: (f64, f64) = (1000.0, 2000.0);

/// The rig's command range a hoverbench log's header states (`# rig: …, throttle 1000-2000
/// us`), µs.
pub fn command_range_us(comments: &[String]) -> Option<(f64, f64)> {
    comments.iter().find_map(|c| {
        let rest = &c[c.find("throttle ")? + "throttle ".len()..];
        let (range, unit) = rest.split_once(' ')?;
        if !unit.trim_start().starts_with("us") {
            return None;
        }
        let (lo, hi) = range.split_once('-')?;
        let (lo, hi) = (lo.parse::<f64>().ok()?, hi.parse::<f64>().ok()?);
        (lo.is_finite() && hi.is_finite() && lo < hi).then_some((lo, hi))
    })
}

/// A log's steps for the motor map: ESC command in µs, the voltage at each step (logged, else
/// the sweep's), power and thrust; or why the log cannot give them.
fn motor_points(
    log: &StandLog,
    power: Option<&[f64]>,
    supply_voltage_v: Option<f64>,
) -> Result<MotorPoints, String> {
    let name = &log.source_name;
    let column = log.columns.throttle.clone().ok_or_else(|| {
        format!("{name} logs no throttle command (the map is power against the ESC's command)")
    })?;
    let throttle = log
        .column(|s| s.throttle)
        .ok_or_else(|| format!("{name}: the throttle column {column:?} is empty on some steps"))?;
    // The map needs the command in µs: by the column's unit, else by its values.
    let unit = import::units::split_unit(&column).1.map(str::to_lowercase);
    let in_us = match unit.as_deref() {
        Some("us" | "µs" | "μs") => true,
        Some(_) => false,
        None => throttle.iter().all(|u| (500.0..=2500.0).contains(u)),
    };
    if !in_us {
        return Err(format!(
            "{name}: the throttle column {column:?} is not an ESC command in µs"
        ));
    }
    let power = match power {
        Some(p) => p.to_vec(),
        None => log.power_w(supply_voltage_v).map_err(|e| format!("{e}"))?.0,
    };
    let logged = log
        .column(|s| s.voltage_v)
        .filter(|v| v.iter().all(|v| *v > 0.0));
    let (voltage_v, supply) = match (logged, supply_voltage_v) {
        (Some(v), Some(s)) => (v, s),
        (Some(v), None) => {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v, mean)
        }
        (None, Some(s)) => (vec![s; throttle.len()], s),
        (None, None) => {
            return Err(format!("{name}: no supply voltage (logged or given)"));
        }
    };
    Ok(MotorPoints {
        throttle_us: throttle,
        voltage_v,
        power_w: power,
        thrust_g: log.thrust_g(),
        supply_voltage_v: supply,
        source_name: name.clone(),
        command_range_us: command_range_us(&log.comments),
    })
}

/// Largest thrust a stand log may report, g (10 t per rotor): beyond it the numbers are
/// corrupt, and a fit of them would give coefficients no other command can use.
pub const MAX_PLAUSIBLE_THRUST_G: f64 = 1e7;
/// Largest electrical power a stand log may report, W (100 MW).
pub const MAX_PLAUSIBLE_POWER_W: f64 = 1e8;
/// Largest supply voltage a stand log may report, V.
pub const MAX_PLAUSIBLE_VOLTAGE_V: f64 = 1e5;
/// Largest current a stand log may report, A.
pub const MAX_PLAUSIBLE_CURRENT_A: f64 = 1e6;

/// A value as people read it: `1e308`, not 309 digits.
fn short(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Why sweeps could not be turned into parameters.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SweepFitError {
    /// The log cannot give electrical power (no power, or no voltage and current).
    #[error(transparent)]
    Stand(#[from] import::ImportError),
    /// A value outside anything a thrust stand measures.
    #[error(
        "{source_name}, line {line}, column {column:?}: {} is not {expected}; the log looks corrupt",
        short(*value)
    )]
    Implausible {
        /// The file.
        source_name: String,
        /// 1-based line of the step (its first sample).
        line: u64,
        /// The column.
        column: String,
        /// The value.
        value: f64,
        /// What was expected.
        expected: String,
    },
    /// The voltage column reads zero (or less) on every step and power would be voltage ×
    /// current.
    #[error(
        "{source_name}: the voltage column {column:?} reads {mean_v} V on average, so voltage × current gives no power; give --volts V for the supply voltage, or log power"
    )]
    NoVoltage {
        /// The file.
        source_name: String,
        /// The voltage column.
        column: String,
        /// Its mean, V.
        mean_v: f64,
    },
    /// Power is zero on every step.
    #[error(
        "{source_name}: electrical power is zero on every step; check the current and voltage columns"
    )]
    ZeroPower {
        /// The file.
        source_name: String,
    },
    /// No step reads a positive thrust.
    #[error("{source_name}: no step reads a positive thrust (highest {max_g} g)")]
    NoThrust {
        /// The file.
        source_name: String,
        /// The highest thrust read, g.
        max_g: f64,
    },
    /// A given supply voltage is not a positive number of volts.
    #[error("supply voltage must be a positive number of volts, got {0}")]
    BadVoltage(f64),
    /// A limit sweep without throttle.
    #[error("{source_name}: a limit sweep needs a throttle column")]
    NoThrottle {
        /// The file.
        source_name: String,
    },
    /// A limit sweep without a voltage, and none given.
    #[error("{source_name} has no voltage column: give --limit-volts")]
    NoLimitVoltage {
        /// The file.
        source_name: String,
    },
    /// The least-squares fit or the thrust-limit extraction failed.
    #[error("{what}")]
    Fit {
        /// What was being done.
        what: String,
        /// Why it failed.
        #[source]
        source: FitError,
    },
}

/// The nominal sweep to fit: x, y, where they came from and what the reader did.
#[derive(Debug, Clone, PartialEq)]
pub struct NominalSweep {
    /// Abscissa (thrust, g, for a stand log).
    pub x: Vec<f64>,
    /// Ordinate (electrical power, W, for a stand log).
    pub y: Vec<f64>,
    /// Name of x in `params.toml` (`thrust_g`).
    pub x_name: String,
    /// Name of y in `params.toml` (`power_w`).
    pub y_name: String,
    /// How y was obtained, for people (`power_w = voltage × current`).
    pub y_label: String,
    /// What kind of log it was.
    pub kind: &'static str,
    /// What the reader and this module did that a user should know.
    pub notes: Vec<String>,
    /// Rows skipped as invalid (supply not regulating).
    pub skipped_invalid: usize,
    /// Supply voltage of the sweep, V, when known.
    pub supply_voltage_v: Option<f64>,
    /// The file, for provenance and messages.
    pub source_name: String,
    /// Its SHA-256, hex.
    pub sha256: String,
    /// Thrust readings a user should look at (a tare offset, a glitch), kept in the fit as
    /// logged (stand logs only).
    pub thrust_oddities: Vec<ThrustOddity>,
    /// The steps for the motor map (command, voltage, power), or why the log has none.
    pub motor_points: Result<MotorPoints, String>,
}

fn check_volts(v: Option<f64>) -> Result<Option<f64>, SweepFitError> {
    match v {
        Some(v) if !(v.is_finite() && v > 0.0) => Err(SweepFitError::BadVoltage(v)),
        v => Ok(v),
    }
}

/// Checks one per-step quantity against `[min, max]`.
fn check_range(
    log: &StandLog,
    column: Option<&String>,
    fallback: &str,
    get: impl Fn(&Step) -> Option<f64>,
    (min, max): (f64, f64),
    unit: &str,
) -> Result<(), SweepFitError> {
    for s in &log.steps {
        if let Some(v) = get(s) {
            if !(v >= min && v <= max) {
                return Err(SweepFitError::Implausible {
                    source_name: log.source_name.clone(),
                    line: s.line,
                    column: column.map_or(fallback, String::as_str).to_owned(),
                    value: v,
                    expected: format!("between {min:e} and {max:e} {unit}"),
                });
            }
        }
    }
    Ok(())
}

/// Refuses a log whose thrust, power, voltage or current is beyond any thrust stand.
fn check_plausible(log: &StandLog) -> Result<(), SweepFitError> {
    let c = &log.columns;
    let t = MAX_PLAUSIBLE_THRUST_G;
    check_range(
        log,
        c.thrust.as_ref(),
        "thrust_g",
        |s| Some(s.thrust_g),
        (-t, t),
        "g",
    )?;
    let p = MAX_PLAUSIBLE_POWER_W;
    check_range(
        log,
        c.power.as_ref(),
        "power_w",
        |s| s.power_w,
        (-p, p),
        "W",
    )?;
    let v = MAX_PLAUSIBLE_VOLTAGE_V;
    check_range(
        log,
        c.voltage.as_ref(),
        "voltage_v",
        |s| s.voltage_v,
        (-v, v),
        "V",
    )?;
    let a = MAX_PLAUSIBLE_CURRENT_A;
    check_range(
        log,
        c.current.as_ref(),
        "current_a",
        |s| s.current_a,
        (-a, a),
        "A",
    )?;
    Ok(())
}

/// Mean voltage of the log when it is a usable supply voltage (positive).
fn logged_voltage(log: &StandLog) -> Result<Option<f64>, f64> {
    match log.mean_voltage_v() {
        Some(v) if v > 0.0 => Ok(Some(v)),
        Some(v) => Err(v),
        None => Ok(None),
    }
}

impl NominalSweep {
    /// Power against thrust from a stand log: logged power, else voltage × current, else
    /// `assumed_voltage_v` × current. The values are checked for plausibility (line and column
    /// of the first absurd one), a voltage column of zeros counts as no voltage, and an
    /// all-zero power is refused.
    pub fn from_stand(
        log: &StandLog,
        assumed_voltage_v: Option<f64>,
    ) -> Result<Self, SweepFitError> {
        let assumed = check_volts(assumed_voltage_v)?;
        check_plausible(log)?;
        let mut notes = log.notes.clone();
        let logged = logged_voltage(log);
        let (power, source) = match (logged, log.power_logged) {
            (Err(mean_v), false) => {
                // voltage × current would be zero: the voltage column is not a measurement.
                let current = log.column(|s| s.current_a);
                match (current, assumed) {
                    (Some(i), Some(v)) => {
                        notes.push(format!(
                            "the voltage column reads {mean_v} V: power taken as {v} V (--volts) × current"
                        ));
                        (
                            i.iter().map(|i| i * v).collect(),
                            PowerSource::AssumedVoltage(v),
                        )
                    }
                    _ => {
                        return Err(SweepFitError::NoVoltage {
                            source_name: log.source_name.clone(),
                            column: log
                                .columns
                                .voltage
                                .clone()
                                .unwrap_or_else(|| "voltage_v".into()),
                            mean_v,
                        });
                    }
                }
            }
            _ => log.power_w(assumed)?,
        };
        if let PowerSource::AssumedVoltage(v) = source {
            if matches!(logged, Ok(None)) {
                notes.push(format!(
                    "no voltage logged: power taken as {v} V (--volts) × current"
                ));
            }
        }
        if power.iter().all(|p| *p == 0.0) {
            return Err(SweepFitError::ZeroPower {
                source_name: log.source_name.clone(),
            });
        }
        let supply_voltage_v = match (assumed, logged) {
            (Some(v), _) => Some(v),
            (None, Ok(v)) => v,
            (None, Err(mean_v)) => {
                notes.push(format!(
                    "the voltage column reads {mean_v} V on average: the supply voltage is not recorded"
                ));
                None
            }
        };
        let motor_points = motor_points(log, Some(&power), supply_voltage_v);
        Ok(Self {
            motor_points,
            x: log.thrust_g(),
            y: power,
            x_name: "thrust_g".into(),
            y_name: "power_w".into(),
            y_label: source.label(),
            kind: log.kind.describe(),
            notes,
            skipped_invalid: log.skipped_invalid,
            supply_voltage_v,
            source_name: log.source_name.clone(),
            sha256: import::sha256_hex(&log.bytes),
            thrust_oddities: log.thrust_oddities(),
        })
    }

    /// Any two columns of a table, taken as they are (no unit conversion, no step reduction).
    pub fn generic(
        xy: import::XySeries,
        supply_voltage_v: Option<f64>,
        source_name: &str,
        bytes: &[u8],
    ) -> Result<Self, SweepFitError> {
        Ok(Self {
            y_label: xy.y_name.clone(),
            x: xy.x,
            y: xy.y,
            x_name: xy.x_name,
            y_name: xy.y_name,
            kind: "generic table",
            notes: Vec::new(),
            skipped_invalid: xy.skipped_invalid,
            supply_voltage_v: check_volts(supply_voltage_v)?,
            source_name: source_name.to_owned(),
            sha256: import::sha256_hex(bytes),
            thrust_oddities: Vec::new(),
            motor_points: Err(format!(
                "{source_name} is a generic table, not a stand log with the ESC's command"
            )),
        })
    }

    fn is_thrust_curve(&self) -> bool {
        self.x_name == "thrust_g"
    }
}

/// A limit sweep (throttle steps at the minimum battery voltage), one reading per distinct
/// throttle set-point in ascending order.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitSweep {
    /// Distinct throttle set-points, ascending.
    pub throttle: Vec<f64>,
    /// Mean thrust at each, g.
    pub thrust_g: Vec<f64>,
    /// Standard deviation of each mean, g, when the log has spreads.
    pub thrust_std_g: Option<Vec<f64>>,
    /// Supply voltage, V, when logged or given.
    pub supply_voltage_v: Option<f64>,
    /// What was done that a user should know.
    pub notes: Vec<String>,
    /// The file.
    pub source_name: String,
    /// Its SHA-256, hex.
    pub sha256: String,
    /// The steps for the motor map (command, voltage, power; not averaged), or why the log has
    /// none.
    pub motor_points: Result<MotorPoints, String>,
}

impl LimitSweep {
    /// The limit sweep of a stand log. Steps that share a throttle set-point — a top held for
    /// several rows, repeated or up-and-down step tests — are averaged into one reading (the
    /// spread of the mean is the larger of the propagated spreads and the readings' scatter).
    /// `voltage_v` overrides the log's mean voltage.
    pub fn from_stand(log: &StandLog, voltage_v: Option<f64>) -> Result<Self, SweepFitError> {
        check_plausible(log)?;
        let throttle = log
            .column(|s| s.throttle)
            .ok_or_else(|| SweepFitError::NoThrottle {
                source_name: log.source_name.clone(),
            })?;
        let thrust = log.thrust_g();
        let std = log.column(|s| s.thrust_std_g);
        let mut order: Vec<usize> = (0..throttle.len()).collect();
        order.sort_by(|&a, &b| throttle[a].total_cmp(&throttle[b]));
        let (mut th, mut tg, mut ts) = (Vec::new(), Vec::new(), Vec::new());
        let mut merged = 0;
        let mut i = 0;
        while i < order.len() {
            let mut j = i;
            while j < order.len() && throttle[order[j]] == throttle[order[i]] {
                j += 1;
            }
            let group = &order[i..j];
            let n = group.len() as f64;
            let mean = group.iter().map(|&k| thrust[k]).sum::<f64>() / n;
            th.push(throttle[order[i]]);
            tg.push(mean);
            if let Some(s) = &std {
                let propagated = group.iter().map(|&k| s[k] * s[k]).sum::<f64>().sqrt() / n;
                let scatter = if group.len() > 1 {
                    let var = group
                        .iter()
                        .map(|&k| (thrust[k] - mean).powi(2))
                        .sum::<f64>()
                        / (n - 1.0);
                    (var / n).sqrt()
                } else {
                    0.0
                };
                ts.push(propagated.max(scatter));
            }
            merged += group.len() - 1;
            i = j;
        }
        let mut notes = Vec::new();
        if merged > 0 {
            notes.push(format!(
                "{}: {} readings averaged into {} throttle set-points (repeated set-points)",
                log.source_name,
                order.len(),
                th.len()
            ));
        }
        let supply_voltage_v = match check_volts(voltage_v)? {
            Some(v) => Some(v),
            None => logged_voltage(log).ok().flatten(),
        };
        Ok(Self {
            motor_points: motor_points(log, None, supply_voltage_v),
            throttle: th,
            thrust_g: tg,
            thrust_std_g: std.map(|_| ts),
            supply_voltage_v,
            notes,
            source_name: log.source_name.clone(),
            sha256: import::sha256_hex(&log.bytes),
        })
    }

    /// The thrust limit `m_L` per rotor ([`thrust_limit`] with the sweep's spreads).
    pub fn thrust_limit(&self) -> Result<ThrustLimit, SweepFitError> {
        let opts = ThrustLimitOptions {
            thrust_std_g: self.thrust_std_g.as_deref(),
            ..Default::default()
        };
        thrust_limit(&self.throttle, &self.thrust_g, &opts).map_err(|source| SweepFitError::Fit {
            what: format!("extracting the thrust limit from {}", self.source_name),
            source,
        })
    }
}

/// How [`fit_sweeps`] fits and what it records.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepFitOptions {
    /// Polynomial degree.
    pub degree: usize,
    /// Rotors sharing the take-off mass.
    pub rotors: u8,
    /// The tool and version, for the provenance record.
    pub tool: String,
    /// When (RFC 3339), for the provenance record.
    pub created: String,
    /// Degree of the motor map's power curve over drive voltage.
    pub motor_degree: usize,
}

impl SweepFitOptions {
    /// The paper's fifth-degree fit for `rotors` rotors, written by `tool` (the time is left
    /// empty: set `created`).
    pub fn new(rotors: u8, tool: &str) -> Self {
        Self {
            degree: crate::DEFAULT_DEGREE,
            rotors,
            tool: tool.to_owned(),
            created: String::new(),
            motor_degree: crate::motor::DEFAULT_MOTOR_DEGREE,
        }
    }
}

/// The fit of a characterisation, for summaries (`summary.json`, `hoverbench fit --json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitSummary {
    /// Steps fitted.
    pub n_points: usize,
    /// Rows skipped as invalid (supply not regulating).
    pub skipped_invalid: usize,
    /// Monomial coefficients of power (W) in thrust (g), ascending.
    pub coefficients: Vec<f64>,
    /// Thrust range of the fit, g.
    pub valid_range_g: (f64, f64),
    /// RMS residual, W.
    pub rmse_w: f64,
    /// R².
    pub r_squared: f64,
    /// Mean voltage of the nominal sweep, V.
    pub supply_voltage_v: Option<f64>,
    /// Thrust limit per rotor, g.
    pub thrust_limit_g: Option<f64>,
    /// Its uncertainty, g.
    pub thrust_limit_uncertainty_g: Option<f64>,
    /// Thrust limit of all rotors, kg.
    pub thrust_limit_total_kg: Option<f64>,
    /// Mean voltage of the limit sweep, V.
    pub limit_voltage_v: Option<f64>,
    /// Fit warnings.
    pub warnings: Vec<String>,
    /// The motor map (power from ESC command and supply voltage), when both sweeps gave one.
    pub motor_map: Option<MotorMapSummary>,
    /// Why there is no motor map, when there is none.
    pub motor_map_skipped: Option<String>,
}

/// The motor map of a characterisation, for summaries.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MotorMapSummary {
    /// Fitted command of zero duty, µs.
    pub zero_us: f64,
    /// Command of full duty, µs.
    pub full_us: f64,
    /// Degree of the power curve over drive voltage.
    pub degree: usize,
    /// Drive-voltage range covered, V.
    pub drive_range_v: (f64, f64),
    /// Relative RMS residual over all fitted steps.
    pub rmse_fraction: f64,
    /// Per sweep: file, supply voltage, steps, relative RMS residual.
    pub sweeps: Vec<SweepResidual>,
}

impl MotorMapSummary {
    /// One line for people: `motor map: power_w = P(duty × V), zero_us 1003.2, RMSE 0.31 % at
    /// 12.50 V, 0.25 % at 9.00 V`.
    pub fn line(&self) -> String {
        let per: Vec<String> = self
            .sweeps
            .iter()
            .map(|s| {
                format!(
                    "{:.2} % at {:.2} V ({} steps)",
                    100.0 * s.rmse_fraction,
                    s.supply_voltage_v,
                    s.n_points
                )
            })
            .collect();
        format!(
            "motor map: power_w = p(duty × V), degree {}, zero_us {:.1} (full {:.0} us), drive {:.2}..{:.2} V, RMSE {}",
            self.degree,
            self.zero_us,
            self.full_us,
            self.drive_range_v.0,
            self.drive_range_v.1,
            per.join(", ")
        )
    }
}

/// The motor map of the two sweeps, or why there is none (never an error: a log without the
/// ESC's command is a fine characterisation).
fn motor_map(
    nominal: &NominalSweep,
    limit: Option<&LimitSweep>,
    degree: usize,
    notes: &mut Vec<String>,
) -> Result<MotorMapFit, String> {
    let limit = limit.ok_or("it needs a limit sweep at a second supply voltage")?;
    let n = nominal.motor_points.as_ref().map_err(Clone::clone)?;
    let l = limit.motor_points.as_ref().map_err(Clone::clone)?;
    let (min_us, full_us) = match n.command_range_us.or(l.command_range_us) {
        Some(r) => r,
        None => {
            notes.push(format!(
                "motor map: the logs do not state the rig's command range: taken as {}-{} us (standard RC)",
                DEFAULT_COMMAND_RANGE_US.0, DEFAULT_COMMAND_RANGE_US.1
            ));
            DEFAULT_COMMAND_RANGE_US
        }
    };
    let opts = MotorMapOptions {
        degree,
        full_us,
        min_us,
        zero_us: None,
    };
    fit_motor_map(&[n.clone(), l.clone()], &opts).map_err(|e| format!("fitting it failed: {e}"))
}

/// Everything [`fit_sweeps`] produced.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepFit {
    /// The parameter file.
    pub params: ParamsFile,
    /// The polynomial.
    pub fit: PolyFit,
    /// The thrust limit, when a limit sweep was given.
    pub limit: Option<ThrustLimit>,
    /// The motor map, when both sweeps logged the ESC's command and the power.
    pub motor: Option<MotorMapFit>,
    /// The summary.
    pub summary: FitSummary,
    /// What was done that a user should know (the reader's notes and this module's).
    pub notes: Vec<String>,
}

/// Fits the nominal sweep, extracts the thrust limit of the limit sweep (when given) and
/// builds `params.toml` and the summary. A thrust curve whose lowest step reads slightly below
/// zero (a tare offset at idle) is valid from 0 g.
pub fn fit_sweeps(
    nominal: &NominalSweep,
    limit: Option<&LimitSweep>,
    opts: &SweepFitOptions,
) -> Result<SweepFit, SweepFitError> {
    let mut notes = nominal.notes.clone();
    if nominal.is_thrust_curve() {
        let max_g = nominal.x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if max_g.is_nan() || max_g <= 0.0 {
            return Err(SweepFitError::NoThrust {
                source_name: nominal.source_name.clone(),
                max_g,
            });
        }
    }
    let fitted = crate::fit_polynomial(&nominal.x, &nominal.y, opts.degree).map_err(|source| {
        SweepFitError::Fit {
            what: format!(
                "fitting {} against {} in {}",
                nominal.y_name, nominal.x_name, nominal.source_name
            ),
            source,
        }
    })?;
    let limit_record = match limit {
        None => None,
        Some(l) => {
            notes.extend(l.notes.iter().cloned());
            let extracted = l.thrust_limit()?;
            let v = l
                .supply_voltage_v
                .ok_or_else(|| SweepFitError::NoLimitVoltage {
                    source_name: l.source_name.clone(),
                })?;
            Some(LimitRecord {
                limit: extracted,
                supply_voltage_v: v,
            })
        }
    };
    let labels = CurveLabels {
        x: &nominal.x_name,
        y: &nominal.y_name,
        supply_voltage_v: nominal.supply_voltage_v,
    };
    let provenance = Provenance {
        input_file: nominal.source_name.clone(),
        input_sha256: nominal.sha256.clone(),
        limit_input_file: limit.map(|l| l.source_name.clone()),
        limit_input_sha256: limit.map(|l| l.sha256.clone()),
        created: opts.created.clone(),
        tool: opts.tool.clone(),
    };
    let mut params = params_file(
        &fitted,
        &labels,
        opts.rotors,
        limit_record.as_ref(),
        provenance,
    );
    // A tare offset, or a glitch, named by its line; the step is kept in the fit. The curve is
    // valid from 0 g whatever read below it.
    let below_zero = nominal.is_thrust_curve() && params.curve.valid_min < 0.0;
    let mut clamp_said = false;
    for o in &nominal.thrust_oddities {
        let mut note = format!("{}, {o}", nominal.source_name);
        if below_zero && !clamp_said && o.thrust_g() <= params.curve.valid_min {
            note.push_str("; the curve is valid from 0 g");
            clamp_said = true;
        }
        params.fit.warnings.push(note.clone());
        notes.push(note);
    }
    if below_zero {
        if !clamp_said {
            let note = format!(
                "the thrust reads down to {:.3} g: the curve is valid from 0 g",
                params.curve.valid_min
            );
            params.fit.warnings.push(note.clone());
            notes.push(note);
        }
        params.curve.valid_min = 0.0;
    }
    let (motor, motor_skipped) = match motor_map(nominal, limit, opts.motor_degree, &mut notes) {
        Ok(m) => (Some(m), None),
        Err(reason) => {
            notes.push(format!("no motor map: {reason}"));
            (None, Some(reason))
        }
    };
    let motor_summary = motor.as_ref().map(|m| MotorMapSummary {
        zero_us: m.map.zero_us(),
        full_us: m.map.full_us(),
        degree: m.map.degree(),
        drive_range_v: m.map.drive_range_v(),
        rmse_fraction: m.map.fit_rmse_fraction(),
        sweeps: m.per_sweep.clone(),
    });
    if let Some(m) = &motor {
        let source = m
            .per_sweep
            .iter()
            .map(|s| format!("{} ({:.2} V)", s.source_name, s.supply_voltage_v))
            .collect::<Vec<_>>()
            .join(" and ");
        params.motor = Some(MotorSection::from_map(
            &m.map,
            m.fit.monomial_coefficients(),
            &format!("fitted to {source}"),
            m.per_sweep
                .iter()
                .map(|s| MotorSweepSection {
                    file: s.source_name.clone(),
                    supply_voltage_v: s.supply_voltage_v,
                    n_points: s.n_points,
                    rmse_fraction: s.rmse_fraction,
                })
                .collect(),
        ));
    }
    let stats = fitted.stats();
    let l = limit_record.map(|r| r.limit);
    let summary = FitSummary {
        n_points: stats.n_points,
        skipped_invalid: nominal.skipped_invalid,
        coefficients: fitted.monomial_coefficients(),
        valid_range_g: (params.curve.valid_min, params.curve.valid_max),
        rmse_w: stats.rmse,
        r_squared: stats.r_squared,
        supply_voltage_v: nominal.supply_voltage_v,
        thrust_limit_g: l.map(|l| l.thrust_g),
        thrust_limit_uncertainty_g: l.map(|l| l.uncertainty_g),
        thrust_limit_total_kg: l.map(|l| l.thrust_g * f64::from(opts.rotors) / 1000.0),
        limit_voltage_v: limit_record.map(|r| r.supply_voltage_v),
        warnings: params.fit.warnings.clone(),
        motor_map: motor_summary,
        motor_map_skipped: motor_skipped,
    };
    Ok(SweepFit {
        params,
        fit: fitted,
        limit: l,
        motor,
        summary,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use import::stand::StandOptions;

    fn log(csv: &str, name: &str) -> StandLog {
        StandLog::parse(csv.as_bytes().to_vec(), name, &StandOptions::default()).unwrap()
    }

    /// A generic stand log (not hoverbench's own), thrust with a tare offset at idle.
    fn nominal_csv(offset_g: f64, volts: f64) -> String {
        let mut s = String::from("thrust_g,voltage_v,current_a\n");
        for i in 0..=20 {
            let t = 10.0 * f64::from(i) + offset_g;
            let p = 0.16 * t.max(0.0) + 0.34 * (t.max(0.0) / 100.0).powf(5.3) + 0.5;
            s += &format!("{t},{volts},{}\n", p / 12.5);
        }
        s
    }

    fn opts() -> SweepFitOptions {
        SweepFitOptions::new(4, "test")
    }

    #[test]
    fn a_tare_offset_at_idle_gives_a_curve_valid_from_zero() {
        let l = log(&nominal_csv(-1.07, 12.5), "tare.csv");
        let n = NominalSweep::from_stand(&l, None).unwrap();
        let done = fit_sweeps(&n, None, &opts()).unwrap();
        assert_eq!(done.params.curve.valid_min, 0.0);
        assert_eq!(done.summary.valid_range_g.0, 0.0);
        assert!(done.notes.iter().any(|n| n.contains("tare")));
        // The file is one other commands accept.
        done.params.to_params().unwrap();
        let back = ParamsFile::from_toml_str(&done.params.to_toml_string()).unwrap();
        back.to_params().unwrap();
    }

    #[test]
    fn a_voltage_column_of_zeros_is_no_voltage() {
        let l = log(&nominal_csv(0.0, 0.0), "zeros.csv");
        let err = NominalSweep::from_stand(&l, None).unwrap_err();
        assert!(matches!(err, SweepFitError::NoVoltage { .. }), "{err}");
        assert!(err.to_string().contains("--volts"), "{err}");
        // With an assumed voltage it fits, and records that voltage.
        let n = NominalSweep::from_stand(&l, Some(12.5)).unwrap();
        assert_eq!(n.supply_voltage_v, Some(12.5));
        let done = fit_sweeps(&n, None, &opts()).unwrap();
        assert_eq!(done.params.curve.supply_voltage_v, Some(12.5));
        assert!(done.fit.coeffs_scaled().iter().any(|c| *c != 0.0));
    }

    #[test]
    fn all_zero_power_is_refused() {
        let mut s = String::from("thrust_g,power_w\n");
        for i in 0..10 {
            s += &format!("{},0\n", 10 * i);
        }
        let err = NominalSweep::from_stand(&log(&s, "p0.csv"), None).unwrap_err();
        assert!(matches!(err, SweepFitError::ZeroPower { .. }), "{err}");
    }

    #[test]
    fn absurd_values_are_refused_with_line_and_column() {
        let mut s = String::from("thrust_g,power_w\n");
        for i in 0..10 {
            let p = if i == 6 {
                "1e300".to_owned()
            } else {
                format!("{}", i)
            };
            s += &format!("{},{p}\n", 10 * i);
        }
        let err = NominalSweep::from_stand(&log(&s, "absurd.csv"), None).unwrap_err();
        match &err {
            SweepFitError::Implausible {
                source_name,
                line,
                column,
                ..
            } => {
                assert_eq!(source_name, "absurd.csv");
                assert_eq!(*line, 8);
                assert_eq!(column, "power_w");
            }
            e => panic!("{e}"),
        }
        assert!(err.to_string().contains("line 8"), "{err}");
        // the value as people read it, not 301 digits
        assert!(err.to_string().contains(": 1e300 is not"), "{err}");
        assert_eq!(short(0.25), "0.25");
        assert_eq!(short(-2.5e-7), "-2.5e-7");
    }

    #[test]
    fn a_held_top_and_repeated_set_points_are_averaged() {
        // Up, the top held for three rows, then down again: an up-and-down step test.
        let mut s = String::from("throttle,thrust_g,thrust_std_g,voltage_v\n");
        let curve = |u: f64| 300.0 * (1.0 - (-(u - 1000.0) / 400.0).exp());
        let mut us: Vec<f64> = (0..=10).map(|i| 1000.0 + 100.0 * f64::from(i)).collect();
        us.extend([2000.0, 2000.0]);
        us.extend((0..10).rev().map(|i| 1000.0 + 100.0 * f64::from(i)));
        for (k, u) in us.iter().enumerate() {
            let wobble = if k % 2 == 0 { 0.3 } else { -0.3 };
            s += &format!("{u},{},0.5,9.0\n", curve(*u) + wobble);
        }
        let l = LimitSweep::from_stand(&log(&s, "updown.csv"), None).unwrap();
        assert_eq!(l.throttle.len(), 11);
        assert!(l.throttle.windows(2).all(|w| w[0] < w[1]));
        assert!(l.notes[0].contains("averaged"), "{:?}", l.notes);
        // Three readings at 2000 µs: the spread of their mean is below one reading's.
        let top = *l.thrust_std_g.as_ref().unwrap().last().unwrap();
        assert!(top < 0.5 && top > 0.0, "{top}");
        let m = l.thrust_limit().unwrap();
        assert!((m.thrust_g - curve(2000.0)).abs() < 30.0, "{m:?}");
        // And the whole seam accepts it.
        let n = NominalSweep::from_stand(&log(&nominal_csv(0.0, 12.5), "n.csv"), None).unwrap();
        let done = fit_sweeps(&n, Some(&l), &opts()).unwrap();
        assert_eq!(done.summary.limit_voltage_v, Some(9.0));
    }

    #[test]
    fn a_limit_sweep_without_voltage_needs_one() {
        let s = "throttle,thrust_g\n1000,10\n1100,20\n1200,25\n1300,26\n1400,26\n";
        let l = LimitSweep::from_stand(&log(s, "nov.csv"), None).unwrap();
        let n = NominalSweep::from_stand(&log(&nominal_csv(0.0, 12.5), "n.csv"), None).unwrap();
        let err = fit_sweeps(&n, Some(&l), &opts()).unwrap_err();
        assert!(matches!(err, SweepFitError::NoLimitVoltage { .. }), "{err}");
        let l = LimitSweep::from_stand(&log(s, "nov.csv"), Some(9.0)).unwrap();
        let done = fit_sweeps(&n, Some(&l), &opts()).unwrap();
        assert_eq!(done.params.thrust_limit.unwrap().supply_voltage_v, 9.0);
    }
}
