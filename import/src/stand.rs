//! Thrust-stand logs of any origin → settled steps in canonical units.
//!
//! A [`ColumnMap`] says which column holds thrust, voltage, current, power, throttle, speed,
//! torque and time; [`ColumnMap::detect`] knows hoverbench's own sweeps, Tyto Robotics'
//! RCbenchmark / Flight Stand exports (`Thrust (gf)`, `ESC signal (µs)`, …) and unit-suffixed
//! names (`thrust_n`, `Current [mA]`). Units follow the column names (gf, kgf, N, lbf, mA, …) and
//! are converted to g, V, A, W, N·m, s, rpm.
//!
//! A row with an empty cell in a column the curve needs (thrust, voltage, current, power,
//! throttle) is left out, as is a speed or torque column empty in some of the rows kept: a
//! stand that logs its sensors at different rates (Tyto's fast-sampled tests) leaves them; each
//! is said in a note.
//!
//! [`Measurements::reduce_steps`] turns a step test into one row per settled step: samples are
//! grouped by their throttle command, and each group's leading transient (samples far from the
//! group's settled tail, judged against the tail's own noise) is dropped before averaging — no
//! fixed settle time is assumed. Logs that already hold one row per step, and ramps whose command
//! changes every sample, pass through one row each.

use crate::units::{Quantity, factor, split_unit};
use crate::{ImportError, Table};

/// Which column holds which quantity (column names as in the header).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ColumnMap {
    /// Thrust (required).
    pub thrust: Option<String>,
    /// Supply voltage.
    pub voltage: Option<String>,
    /// Current.
    pub current: Option<String>,
    /// Electrical power.
    pub power: Option<String>,
    /// Throttle command (ESC µs, %, or fraction).
    pub throttle: Option<String>,
    /// Rotor speed.
    pub speed: Option<String>,
    /// Torque.
    pub torque: Option<String>,
    /// Time.
    pub time: Option<String>,
}

/// Where a log's electrical power comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PowerSource {
    /// A logged power column.
    Logged,
    /// Logged voltage × logged current.
    VoltageTimesCurrent,
    /// An assumed constant supply voltage × logged current (the log has no voltage).
    AssumedVoltage(f64),
}

impl PowerSource {
    /// How the power was obtained, for a column label.
    pub fn label(&self) -> String {
        match self {
            Self::Logged => "power_w".into(),
            Self::VoltageTimesCurrent => "power_w = voltage × current".into(),
            Self::AssumedVoltage(v) => format!("power_w = {v} V (assumed) × current"),
        }
    }
}

/// Which kind of log the columns were recognised as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// hoverbench's own sweep (`thrust_g`, `power_w`, …).
    Hoverbench,
    /// Tyto Robotics RCbenchmark / Flight Stand export.
    Tyto,
    /// Anything else, mapped by name patterns or by the user.
    Generic,
}

fn find(table: &Table, names: &[&str]) -> Option<String> {
    // Exact names first, then "base name (unit)" / "base_unit" patterns, case-insensitively.
    for n in names {
        if let Some(h) = table.header().iter().find(|h| h.as_str() == *n) {
            return Some(h.clone());
        }
    }
    for n in names {
        if let Some(h) = table
            .header()
            .iter()
            .find(|h| split_unit(h).0.eq_ignore_ascii_case(n))
        {
            return Some(h.clone());
        }
    }
    None
}

impl LogKind {
    /// The kind in words.
    pub fn describe(self) -> &'static str {
        match self {
            LogKind::Hoverbench => "hoverbench sweep",
            LogKind::Tyto => "Tyto RCbenchmark / Flight Stand export",
            LogKind::Generic => "generic stand log",
        }
    }
}

impl ColumnMap {
    /// Recognises the columns of a table.
    pub fn detect(table: &Table) -> (Self, LogKind) {
        let has = |c: &str| table.has(c);
        let kind = if has("thrust_g") {
            LogKind::Hoverbench
        } else if has("ESC signal (µs)") || (has("Time (s)") && find(table, &["Thrust"]).is_some())
        {
            LogKind::Tyto
        } else {
            LogKind::Generic
        };
        let map = Self {
            // A stand built on a scale logs its reading as a weight (`weight[g]`).
            thrust: find(table, &["thrust_g", "thrust", "force", "weight"]),
            // Single letters (`v[V]`, `i[A]`, `p[W]`) as a power monitor's columns are named.
            voltage: find(table, &["voltage_v", "voltage", "volts", "volt", "v", "u"]),
            current: find(table, &["current_a", "current", "amps", "amp", "i"]),
            power: find(
                table,
                &[
                    "power_w",
                    "Electrical Power",
                    "electrical_power",
                    "power",
                    "p",
                ],
            ),
            throttle: find(
                table,
                &["throttle", "ESC signal", "esc", "esc_signal", "pwm"],
            ),
            speed: find(
                table,
                &[
                    "rpm",
                    "Motor Electrical Speed",
                    "Motor Optical Speed",
                    "speed",
                    "motor_speed",
                ],
            ),
            torque: find(table, &["torque_nm", "Torque", "torque"]),
            time: find(table, &["time_s", "Time", "time"]),
        };
        (map, kind)
    }

    /// Overrides the detected columns with the ones given (`None` leaves a column as detected).
    pub fn overridden_by(mut self, other: &Self) -> Self {
        macro_rules! take {
            ($($f:ident),*) => {$(if other.$f.is_some() { self.$f = other.$f.clone(); })*};
        }
        take!(
            thrust, voltage, current, power, throttle, speed, torque, time
        );
        self
    }
}

/// Samples in canonical units, one entry per kept row.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measurements {
    /// Thrust, g.
    pub thrust_g: Vec<f64>,
    /// Voltage, V.
    pub voltage_v: Option<Vec<f64>>,
    /// Current, A.
    pub current_a: Option<Vec<f64>>,
    /// Electrical power, W (logged, or voltage × current).
    pub power_w: Option<Vec<f64>>,
    /// Whether `power_w` was logged (true) or computed as voltage × current (false).
    pub power_logged: bool,
    /// Throttle command, in its own unit.
    pub throttle: Option<Vec<f64>>,
    /// Speed, rpm.
    pub speed_rpm: Option<Vec<f64>>,
    /// Torque, N·m.
    pub torque_nm: Option<Vec<f64>>,
    /// Source line of each sample.
    pub lines: Vec<u64>,
    /// Table row of each sample.
    pub rows: Vec<usize>,
    /// What the reader did that a user should know (negated thrust, …).
    pub notes: Vec<String>,
    /// Rows skipped because their `valid` column was false.
    pub skipped_invalid: usize,
}

/// One settled step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Throttle command of the step, when logged.
    pub throttle: Option<f64>,
    /// Mean settled thrust, g.
    pub thrust_g: f64,
    /// Its standard deviation (None for single-sample steps).
    pub thrust_std_g: Option<f64>,
    /// Mean voltage, V.
    pub voltage_v: Option<f64>,
    /// Mean current, A.
    pub current_a: Option<f64>,
    /// Mean electrical power, W.
    pub power_w: Option<f64>,
    /// Its standard deviation.
    pub power_std_w: Option<f64>,
    /// Mean speed, rpm.
    pub speed_rpm: Option<f64>,
    /// Mean torque, N·m.
    pub torque_nm: Option<f64>,
    /// Samples averaged.
    pub samples: usize,
    /// Samples dropped as the step's transient.
    pub transient_samples: usize,
    /// First source line of the step.
    pub line: u64,
}

/// Rows that pass a `COLUMN=VALUE` filter (text equality after trimming).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RowFilter {
    /// Column name.
    pub column: String,
    /// Required value.
    pub value: String,
}

impl std::str::FromStr for RowFilter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (c, v) = s
            .split_once('=')
            .ok_or_else(|| format!("{s:?}: expected COLUMN=VALUE"))?;
        Ok(Self {
            column: c.trim().to_owned(),
            value: v.trim().to_owned(),
        })
    }
}

impl Table {
    /// Values of the distinct combinations of `columns`, for telling a user how to filter.
    pub fn distinct(&self, columns: &[&str]) -> Vec<String> {
        let mut seen: Vec<String> = Vec::new();
        for r in 0..self.len() {
            let key = columns
                .iter()
                .map(|c| format!("{c}={}", self.cell_text(r, c)))
                .collect::<Vec<_>>()
                .join(", ");
            if !seen.contains(&key) {
                seen.push(key);
            }
        }
        seen
    }

    /// Warnings for text columns (not mapped, not filtered on) that take several values over
    /// `rows`: a table of several motors or propellers fitted as one curve is a mixture.
    fn label_columns(&self, map: &ColumnMap, filters: &[RowFilter], rows: &[usize]) -> Vec<String> {
        let mapped = [
            &map.thrust,
            &map.voltage,
            &map.current,
            &map.power,
            &map.throttle,
            &map.speed,
            &map.torque,
            &map.time,
        ];
        let mut out = Vec::new();
        for name in self.header() {
            if name.is_empty()
                || name == "valid"
                || mapped.iter().any(|m| m.as_deref() == Some(name.as_str()))
                || filters.iter().any(|f| &f.column == name)
            {
                continue;
            }
            let mut values: Vec<&str> = Vec::new();
            let mut label = true;
            for &r in rows {
                let t = self.cell_text(r, name);
                if t.is_empty() || t.parse::<f64>().is_ok() {
                    label = false;
                    break;
                }
                if !values.contains(&t) {
                    values.push(t);
                    if values.len() > 50 {
                        label = false;
                        break;
                    }
                }
            }
            if label && values.len() > 1 {
                let shown: Vec<String> = values.iter().take(6).map(|v| format!("{v:?}")).collect();
                out.push(format!(
                    "column {name:?} takes {} different values ({}{}): they are fitted as one curve; select one with --where \"{name}={}\"",
                    values.len(),
                    shown.join(", "),
                    if values.len() > 6 { ", …" } else { "" },
                    values[0]
                ));
            }
        }
        out
    }

    fn converted(
        &self,
        column: &str,
        quantity: Quantity,
        rows: &[usize],
    ) -> Result<Vec<f64>, ImportError> {
        let unit = split_unit(column).1;
        let f = match unit {
            None => 1.0,
            Some(u) => factor(quantity, u).ok_or_else(|| ImportError::BadUnit {
                source_name: self.source_name.clone(),
                column: column.to_owned(),
                unit: u.to_owned(),
                quantity: format!("{quantity:?}").to_lowercase(),
            })?,
        };
        rows.iter()
            .map(|&r| self.cell_number(r, column).map(|v| v * f))
            .collect()
    }

    /// Whether the header is a flight log's rather than a stand's: a column only flight logs
    /// have (a flight controller's battery counters, altitude) and none with thrust, torque or
    /// rotor speed in its name.
    fn looks_like_a_flight_log(&self) -> bool {
        let names: Vec<String> = self.header.iter().map(|c| c.to_lowercase()).collect();
        let flight = [
            "discharged_mah",
            "remaining",
            "altitude",
            "altitude_m",
            "vbatlatest",
            "timeus",
            "currtot",
        ];
        let stand = ["thrust", "torque", "rpm", "esc"];
        names
            .iter()
            .any(|n| flight.iter().any(|f| n.starts_with(f)))
            && !names.iter().any(|n| stand.iter().any(|s| n.contains(s)))
    }

    /// Reads the mapped columns over the rows that pass every filter (and whose `valid` column,
    /// if any, is true), converted to canonical units.
    pub fn measurements(
        &self,
        map: &ColumnMap,
        filters: &[RowFilter],
    ) -> Result<Measurements, ImportError> {
        let thrust_col = map
            .thrust
            .as_deref()
            .ok_or_else(|| ImportError::MissingColumn {
                source_name: self.source_name.clone(),
                column: if self.looks_like_a_flight_log() {
                    "for thrust (name it with --thrust; with a battery's columns and none of a stand's, it looks like a flight log, which `hoverbench flights`, `gap` and `replay` read)".into()
                } else {
                    "for thrust (name it with --thrust)".into()
                },
                available: self.available(),
            })?;
        for f in filters {
            self.index(&f.column)?;
        }
        let valid = self.valid_rows()?;
        let mut rows: Vec<usize> = (0..self.len())
            .filter(|&r| valid[r])
            .filter(|&r| {
                filters
                    .iter()
                    .all(|f| self.cell_text(r, &f.column) == f.value)
            })
            .collect();
        let mut notes = Vec::new();
        // A stand that logs its sensors at different rates leaves cells empty in the rows of
        // the others (Tyto's fast-sampled tests): a row with an empty cell in a column the curve
        // needs is left out, and said so.
        let core: Vec<&str> = [
            Some(thrust_col),
            map.voltage.as_deref(),
            map.current.as_deref(),
            map.power.as_deref(),
            map.throttle.as_deref(),
        ]
        .into_iter()
        .flatten()
        .filter(|c| self.has(c) && rows.iter().any(|&r| !self.cell_text(r, c).is_empty()))
        .collect();
        let before = rows.len();
        rows.retain(|&r| core.iter().all(|c| !self.cell_text(r, c).is_empty()));
        if rows.len() < before && !rows.is_empty() {
            notes.push(format!(
                "{} of {before} row(s) left out for an empty cell in {} (sensors logged at different rates)",
                before - rows.len(),
                core.iter()
                    .map(|c| format!("{c:?}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let skipped_invalid = valid.iter().filter(|v| !**v).count();
        if rows.is_empty() {
            return Err(ImportError::Empty {
                source_name: self.source_name.clone(),
                message: if filters.is_empty() {
                    "no valid rows".into()
                } else {
                    let cols: Vec<&str> = filters.iter().map(|f| f.column.as_str()).collect();
                    format!(
                        "no row matches the filter; the file has: {}",
                        self.distinct(&cols).join("; ")
                    )
                },
            });
        }
        // A column that is empty in every row was not logged (`hoverbench import` writes one for
        // each quantity a log lacks): it is absent, not an error.
        // A column logged in only some of the rows kept (a sensor slower than the rest, not one
        // the curve needs) is left out too, and said so.
        let mut sparse = Vec::new();
        for c in [&map.speed, &map.torque].into_iter().flatten() {
            let empty = rows
                .iter()
                .filter(|&&r| self.cell_text(r, c).is_empty())
                .count();
            if empty > 0 && empty < rows.len() {
                notes.push(format!(
                    "column {c:?} is empty in {empty} of the {} row(s) kept (a sensor logged at another rate): not read",
                    rows.len()
                ));
                sparse.push(c.clone());
            }
        }
        let opt = |c: &Option<String>, q| -> Result<Option<Vec<f64>>, ImportError> {
            c.as_deref()
                .filter(|c| rows.iter().any(|&r| !self.cell_text(r, c).is_empty()))
                .filter(|c| !sparse.iter().any(|s| s == c))
                .map(|c| self.converted(c, q, &rows))
                .transpose()
        };
        if split_unit(thrust_col).1.is_none() {
            notes.push(format!(
                "column {thrust_col:?} names no unit: read as grams (g). If it holds newtons or kilograms, put the unit in the header, e.g. \"{thrust_col} (N)\""
            ));
        }
        // Milliamps, millivolts and milliwatts are common in logs: a bare name is read in the
        // base unit, and said so (a current in mA read as A would make the power 1000× off).
        for (col, unit, example) in [
            (&map.voltage, "volts (V)", "(mV)"),
            (&map.current, "amperes (A)", "(mA)"),
            (&map.power, "watts (W)", "(mW)"),
        ] {
            if let Some(c) = col.as_deref() {
                let logged = rows.iter().any(|&r| !self.cell_text(r, c).is_empty());
                if logged && split_unit(c).1.is_none() {
                    notes.push(format!(
                        "column {c:?} names no unit: read as {unit}. If it holds another, put the unit in the header, e.g. \"{c} {example}\""
                    ));
                }
            }
        }
        notes.extend(self.label_columns(map, filters, &rows));
        let mut thrust_g = self.converted(thrust_col, Quantity::Thrust, &rows)?;
        let voltage_v = opt(&map.voltage, Quantity::Voltage)?;
        let current_a = opt(&map.current, Quantity::Current)?;
        let logged_power = opt(&map.power, Quantity::Power)?;
        let power_logged = logged_power.is_some();
        let power_w = logged_power.or_else(|| match (&voltage_v, &current_a) {
            (Some(v), Some(i)) => Some(v.iter().zip(i).map(|(v, i)| v * i).collect()),
            _ => None,
        });
        let mut sorted = thrust_g.clone();
        sorted.sort_by(f64::total_cmp);
        if sorted[sorted.len() / 2] < 0.0 {
            for t in &mut thrust_g {
                *t = -*t;
            }
            notes.push(format!(
                "thrust was negative in most rows (a load cell mounted the other way round); {thrust_col} was negated"
            ));
        }
        Ok(Measurements {
            thrust_g,
            voltage_v,
            current_a,
            power_w,
            power_logged,
            throttle: opt(&map.throttle, Quantity::Throttle)?,
            speed_rpm: opt(&map.speed, Quantity::Speed)?,
            torque_nm: opt(&map.torque, Quantity::Torque)?,
            lines: rows.iter().map(|&r| self.line(r)).collect(),
            rows,
            notes,
            skipped_invalid,
        })
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn std_dev(v: &[f64]) -> Option<f64> {
    (v.len() > 1).then(|| {
        let m = mean(v);
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    })
}

/// Index of the first settled sample of a group: samples before it are the transient.
///
/// The settled level and noise come from the group's last half; leading samples more than four
/// noise standard deviations (and more than 0.5 % of the level, so that a noiseless log does not
/// call every wiggle a transient) from that level are dropped.
fn settled_from(thrust: &[f64]) -> usize {
    let n = thrust.len();
    if n < 4 {
        return 0;
    }
    let tail = &thrust[n / 2..];
    let level = mean(tail);
    let noise = std_dev(tail).unwrap_or(0.0);
    let band = (4.0 * noise).max(0.005 * level.abs());
    thrust[..n / 2]
        .iter()
        .position(|t| (t - level).abs() <= band)
        .unwrap_or(n / 2)
}

impl Measurements {
    /// One row per settled step (see the module documentation).
    pub fn reduce_steps(&self) -> Vec<Step> {
        let n = self.thrust_g.len();
        let mut groups: Vec<(usize, usize)> = Vec::new();
        let mut start = 0;
        for i in 1..=n {
            let boundary = i == n
                || match &self.throttle {
                    Some(t) => t[i] != t[i - 1],
                    None => true,
                };
            if boundary {
                groups.push((start, i));
                start = i;
            }
        }
        groups
            .into_iter()
            .map(|(a, b)| {
                let k = a + settled_from(&self.thrust_g[a..b]);
                let sl = |v: &Option<Vec<f64>>| v.as_ref().map(|v| mean(&v[k..b]));
                Step {
                    throttle: self.throttle.as_ref().map(|t| t[a]),
                    thrust_g: mean(&self.thrust_g[k..b]),
                    thrust_std_g: std_dev(&self.thrust_g[k..b]),
                    voltage_v: sl(&self.voltage_v),
                    current_a: sl(&self.current_a),
                    power_w: sl(&self.power_w),
                    power_std_w: self.power_w.as_ref().and_then(|p| std_dev(&p[k..b])),
                    speed_rpm: sl(&self.speed_rpm),
                    torque_nm: sl(&self.torque_nm),
                    samples: b - k,
                    transient_samples: k - a,
                    line: self.lines[a],
                }
            })
            .collect()
    }
}

/// How to read a stand log.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct StandOptions {
    /// Columns to use instead of the detected ones.
    pub columns: ColumnMap,
    /// Names for a file without a header row (or to rename a header's columns).
    pub names: Option<Vec<String>>,
    /// Keep only the rows that match every filter.
    pub filters: Vec<RowFilter>,
}

/// A stand log read and reduced to steps.
#[derive(Debug, Clone, PartialEq)]
pub struct StandLog {
    /// What the columns were recognised as.
    pub kind: LogKind,
    /// The columns used.
    pub columns: ColumnMap,
    /// One row per settled step.
    pub steps: Vec<Step>,
    /// Whether power was logged or computed from voltage × current.
    pub power_logged: bool,
    /// What the reader did that a user should know.
    pub notes: Vec<String>,
    /// Rows skipped because their `valid` column was false (e.g. the supply was limiting).
    pub skipped_invalid: usize,
    /// The file's `#` comment lines.
    pub comments: Vec<String>,
    /// The file's bytes (for provenance hashes).
    pub bytes: Vec<u8>,
    /// The file's name, for messages.
    pub source_name: String,
}

impl StandLog {
    /// Reads a stand log of any supported kind from a file.
    pub fn read(path: &std::path::Path, options: &StandOptions) -> Result<Self, ImportError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|error| ImportError::Io {
            source_name: name.clone(),
            error,
        })?;
        Self::parse(bytes, &name, options)
    }

    /// Reads a stand log of any supported kind from bytes.
    pub fn parse(bytes: Vec<u8>, name: &str, options: &StandOptions) -> Result<Self, ImportError> {
        let table = Table::parse_with(&bytes, name, options.names.as_deref())?;
        let (detected, kind) = ColumnMap::detect(&table);
        let columns = detected.overridden_by(&options.columns);
        let m = table.measurements(&columns, &options.filters)?;
        let mut notes = m.notes.clone();
        let steps = if kind == LogKind::Hoverbench {
            // hoverbench sweeps already hold one row per settled step, with their spreads.
            // An empty spread cell (a single-sample step) is no spread, not an error.
            let spread = |c: &str, i: usize| -> Result<Option<f64>, ImportError> {
                let r = m.rows[i];
                if table.cell_text(r, c).is_empty() {
                    return Ok(None);
                }
                let v = table.cell_number(r, c)?;
                if v < 0.0 {
                    return Err(table.bad_value(r, c, "a standard deviation ≥ 0"));
                }
                Ok(Some(v))
            };
            // sample counts: whole numbers (≥ `min`), `min` when the column is absent or empty
            let count = |c: &str, i: usize, min: usize| -> Result<usize, ImportError> {
                let r = m.rows[i];
                if table.cell_text(r, c).is_empty() {
                    return Ok(min);
                }
                let v = table.cell_number(r, c)?;
                if v.fract() != 0.0 || v < min as f64 || v > 1e15 {
                    return Err(table.bad_value(r, c, &format!("a whole number ≥ {min}")));
                }
                Ok(v as usize)
            };
            (0..m.thrust_g.len())
                .map(|i| {
                    let at = |v: &Option<Vec<f64>>| v.as_ref().map(|v| v[i]);
                    Ok(Step {
                        throttle: at(&m.throttle),
                        thrust_g: m.thrust_g[i],
                        thrust_std_g: spread("thrust_std_g", i)?,
                        voltage_v: at(&m.voltage_v),
                        current_a: at(&m.current_a),
                        power_w: at(&m.power_w),
                        power_std_w: spread("power_std_w", i)?,
                        speed_rpm: at(&m.speed_rpm),
                        torque_nm: at(&m.torque_nm),
                        samples: count("samples", i, 1)?,
                        transient_samples: count("transient_samples", i, 0)?,
                        line: m.lines[i],
                    })
                })
                .collect::<Result<Vec<_>, ImportError>>()?
        } else {
            let steps = m.reduce_steps();
            if steps.len() < m.thrust_g.len() {
                notes.push(format!(
                    "{} samples reduced to {} settled steps ({} transient samples dropped)",
                    m.thrust_g.len(),
                    steps.len(),
                    steps.iter().map(|s| s.transient_samples).sum::<usize>()
                ));
            }
            steps
        };
        Ok(Self {
            kind,
            columns,
            steps,
            power_logged: m.power_logged,
            notes,
            skipped_invalid: m.skipped_invalid,
            comments: table.comments.clone(),
            bytes,
            source_name: name.to_owned(),
        })
    }

    /// Thrust of every step, g.
    pub fn thrust_g(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.thrust_g).collect()
    }

    /// A per-step quantity, if every step has it.
    pub fn column(&self, f: impl Fn(&Step) -> Option<f64>) -> Option<Vec<f64>> {
        self.steps.iter().map(f).collect()
    }

    /// Electrical power of every step: logged, else voltage × current, else — with
    /// `assumed_voltage_v` — that voltage × current. A log with none of these is an error that
    /// says what would make it work.
    pub fn power_w(
        &self,
        assumed_voltage_v: Option<f64>,
    ) -> Result<(Vec<f64>, PowerSource), ImportError> {
        if let Some(p) = self.column(|s| s.power_w) {
            let src = if self.power_logged {
                PowerSource::Logged
            } else {
                PowerSource::VoltageTimesCurrent
            };
            return Ok((p, src));
        }
        match (self.column(|s| s.current_a), assumed_voltage_v) {
            (Some(i), Some(v)) => Ok((
                i.iter().map(|i| i * v).collect(),
                PowerSource::AssumedVoltage(v),
            )),
            (current, _) => Err(ImportError::NoPower {
                source_name: self.source_name.clone(),
                has_current: current.is_some(),
            }),
        }
    }

    /// Mean supply voltage over the steps, if logged.
    pub fn mean_voltage_v(&self) -> Option<f64> {
        self.column(|s| s.voltage_v)
            .map(|v| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// Thrust readings worth a look before fitting, in file order: an idle step below 0 g (a
    /// tare offset), a step past idle that reads below 0 g and below idle (which no tare
    /// offset explains), and a step on a throttle ramp far off both its neighbours. Nothing is
    /// changed or dropped; see [`ThrustOddity`].
    pub fn thrust_oddities(&self) -> Vec<ThrustOddity> {
        let steps = &self.steps;
        let n = steps.len();
        if n == 0 {
            return Vec::new();
        }
        let top_g = steps.iter().map(|s| s.thrust_g).fold(0.0, f64::max);
        // Readings closer than this are noise, not a second cause.
        let margin_g = (ODDITY_MARGIN_FRACTION * top_g).max(ODDITY_MIN_MARGIN_G);
        let throttle = self.column(|s| s.throttle);
        // The idle steps: the lowest throttle; without a throttle column, the lower of the
        // first and last steps (a sweep starts, and an up-and-down one also ends, at idle).
        let idle: Vec<usize> = match &throttle {
            Some(t) => {
                let low = t.iter().copied().fold(f64::INFINITY, f64::min);
                (0..n).filter(|&i| t[i] <= low).collect()
            }
            None => {
                let low = steps[0].thrust_g.min(steps[n - 1].thrust_g);
                [0, n - 1]
                    .into_iter()
                    .filter(|&i| steps[i].thrust_g <= low)
                    .collect()
            }
        };
        let idle_g = idle
            .iter()
            .map(|&i| steps[i].thrust_g)
            .fold(f64::INFINITY, f64::min);
        let mut out = Vec::new();
        let tare = idle
            .iter()
            .copied()
            .filter(|&i| steps[i].thrust_g < 0.0)
            .min_by(|&a, &b| steps[a].thrust_g.total_cmp(&steps[b].thrust_g));
        if let Some(i) = tare {
            out.push(ThrustOddity::TareOffset {
                line: steps[i].line,
                thrust_g: steps[i].thrust_g,
            });
        }
        // A negative step past idle is a glitch when it also dips below its neighbours (in file
        // order): a run of readings near 0 g below the motor's start-up is the cell's noise.
        let dips = |i: usize| {
            let lower = [i.checked_sub(1), Some(i + 1).filter(|&j| j < n)]
                .into_iter()
                .flatten()
                .map(|j| steps[j].thrust_g)
                .fold(f64::INFINITY, f64::min);
            steps[i].thrust_g < lower - margin_g
        };
        // The steps the ramp check compares with each other: all but the negative ones past
        // idle (named first), then, one at a time, the step farthest off its neighbours.
        let mut kept: Vec<usize> = Vec::with_capacity(n);
        for (i, s) in steps.iter().enumerate() {
            if !idle.contains(&i) && s.thrust_g < 0.0 && s.thrust_g < idle_g - margin_g && dips(i) {
                out.push(ThrustOddity::NegativePastIdle {
                    line: s.line,
                    thrust_g: s.thrust_g,
                    idle_g,
                });
            } else {
                kept.push(i);
            }
        }
        if let Some(t) = &throttle {
            // On a ramp (throttle strictly rising or falling through the step) thrust follows
            // the throttle: a step beyond both neighbours by more than the spike margin is off
            // it. The worst is named and left out of its neighbours' checks, then the next.
            let spike_margin_g = (ODDITY_SPIKE_FRACTION * top_g).max(ODDITY_MIN_MARGIN_G);
            loop {
                let worst = (1..kept.len().saturating_sub(1))
                    .filter_map(|j| {
                        let (a, i, b) = (kept[j - 1], kept[j], kept[j + 1]);
                        let ramp = (t[a] < t[i] && t[i] < t[b]) || (t[a] > t[i] && t[i] > t[b]);
                        let (ga, gi, gb) =
                            (steps[a].thrust_g, steps[i].thrust_g, steps[b].thrust_g);
                        let beyond = (ga.min(gb) - gi).max(gi - ga.max(gb)) - spike_margin_g;
                        (ramp && beyond > 0.0).then_some((j, beyond))
                    })
                    .max_by(|x, y| x.1.total_cmp(&y.1));
                let Some((j, _)) = worst else { break };
                let (a, i, b) = (kept[j - 1], kept[j], kept[j + 1]);
                out.push(ThrustOddity::OffTheRamp {
                    line: steps[i].line,
                    thrust_g: steps[i].thrust_g,
                    before_g: steps[a].thrust_g,
                    after_g: steps[b].thrust_g,
                });
                kept.remove(j);
            }
        }
        out.sort_by_key(ThrustOddity::line);
        out
    }
}

/// Readings within this fraction of the sweep's top thrust of the idle reading are noise.
const ODDITY_MARGIN_FRACTION: f64 = 0.02;
/// A step this fraction of the top thrust beyond both ramp neighbours is off the ramp.
const ODDITY_SPIKE_FRACTION: f64 = 0.1;
/// The least margin, g (a load cell's noise at idle).
const ODDITY_MIN_MARGIN_G: f64 = 1.0;

/// A thrust reading a user should look at ([`StandLog::thrust_oddities`]); its text names the
/// line and the likely cause. The step is kept as logged.
#[derive(Debug, Clone, PartialEq)]
pub enum ThrustOddity {
    /// The idle step (the lowest throttle) reads below 0 g: a tare offset at idle.
    TareOffset {
        /// 1-based line of the step.
        line: u64,
        /// Its thrust, g.
        thrust_g: f64,
    },
    /// A step past idle reads below 0 g and below the idle step: a tare offset would shift
    /// idle too, so it looks like a glitch or an outlier.
    NegativePastIdle {
        /// 1-based line of the step.
        line: u64,
        /// Its thrust, g.
        thrust_g: f64,
        /// The idle step's thrust, g.
        idle_g: f64,
    },
    /// A step on a throttle ramp reads far below or above both neighbours.
    OffTheRamp {
        /// 1-based line of the step.
        line: u64,
        /// Its thrust, g.
        thrust_g: f64,
        /// The step before's thrust, g.
        before_g: f64,
        /// The step after's thrust, g.
        after_g: f64,
    },
}

impl ThrustOddity {
    /// The step's line.
    pub fn line(&self) -> u64 {
        match self {
            Self::TareOffset { line, .. }
            | Self::NegativePastIdle { line, .. }
            | Self::OffTheRamp { line, .. } => *line,
        }
    }

    /// The step's thrust, g.
    pub fn thrust_g(&self) -> f64 {
        match self {
            Self::TareOffset { thrust_g, .. }
            | Self::NegativePastIdle { thrust_g, .. }
            | Self::OffTheRamp { thrust_g, .. } => *thrust_g,
        }
    }
}

impl std::fmt::Display for ThrustOddity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::TareOffset { line, thrust_g } => write!(
                f,
                "line {line}: the idle step reads {thrust_g:.3} g (a tare offset at idle?)"
            ),
            Self::NegativePastIdle {
                line,
                thrust_g,
                idle_g,
            } => write!(
                f,
                "line {line}: a step past idle reads {thrust_g:.3} g, below the idle step's {idle_g:.3} g, which a tare offset cannot explain: a glitch or an outlier? (kept as logged: check or remove the row)"
            ),
            Self::OffTheRamp {
                line,
                thrust_g,
                before_g,
                after_g,
            } => write!(
                f,
                "line {line}: a step on the throttle ramp reads {thrust_g:.3} g between steps of {before_g:.3} g and {after_g:.3} g: a glitch or an outlier? (kept as logged: check or remove the row)"
            ),
        }
    }
}

/// Writes steps as a hoverbench sweep CSV (the format `hoverbench fit` reads by default), with a
/// comment block of `comments` lines first.
pub fn steps_to_csv(steps: &[Step], comments: &[String]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for c in comments {
        let _ = writeln!(s, "# {c}");
    }
    s.push_str(
        "throttle,thrust_g,thrust_std_g,voltage_v,current_a,power_w,power_std_w,rpm,torque_nm,samples,transient_samples,source_line,valid\n",
    );
    let o = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
    for st in steps {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},true",
            o(st.throttle),
            st.thrust_g,
            o(st.thrust_std_g),
            o(st.voltage_v),
            o(st.current_a),
            o(st.power_w),
            o(st.power_std_w),
            o(st.speed_rpm),
            o(st.torque_nm),
            st.samples,
            st.transient_samples,
            st.line
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn stand_logs_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = StandLog::parse(bytes, "fuzz", &StandOptions::default());
        }

        #[test]
        fn stand_like_text_never_panics(
            text in "(Time \\(s\\),ESC signal \\(µs\\),Thrust \\((gf|N|kgf)\\),Voltage \\(V\\),Current \\(A\\),\n)?([-0-9.,e ]{0,30}\n){0,8}",
            names in proptest::option::of(Just(vec!["a_s".to_string(), "thrust_n".into(), "current_a".into()])),
        ) {
            let opts = StandOptions { names, ..Default::default() };
            if let Ok(log) = StandLog::parse(text.into_bytes(), "fuzz", &opts) {
                prop_assert!(!log.steps.is_empty());
                for s in &log.steps {
                    prop_assert!(s.thrust_g.is_finite());
                }
            }
        }
    }

    #[test]
    fn step_test_reduces_to_settled_means() {
        // Two steps: each starts with a 3-sample transient, then settles with small noise.
        let mut csv = String::from(
            "\u{feff}Time (s),ESC signal (µs),Thrust (N),Voltage (V),Current (A),App message,\n",
        );
        let mut t = 0.0;
        for (esc, level) in [(1200, 1.0), (1300, 2.0)] {
            for i in 0..12 {
                let thrust = if i < 3 {
                    level * (0.3 + 0.2 * f64::from(i))
                } else {
                    level + 0.001 * f64::from(i % 2)
                };
                csv.push_str(&format!("{t},{esc},{thrust},12.0,{},,\n", level * 3.0));
                t += 0.1;
            }
        }
        let table = Table::parse(csv.as_bytes(), "tyto.csv").unwrap();
        let (map, kind) = ColumnMap::detect(&table);
        assert_eq!(kind, LogKind::Tyto);
        let m = table.measurements(&map, &[]).unwrap();
        let steps = m.reduce_steps();
        assert_eq!(steps.len(), 2);
        assert_eq!(steps[0].transient_samples, 3);
        assert_eq!(steps[0].samples, 9);
        assert!(
            (steps[1].thrust_g - 2.0005 * 1000.0 / crate::units::STANDARD_GRAVITY).abs() < 0.05
        );
        assert!((steps[1].power_w.unwrap() - 72.0).abs() < 1e-9);
        assert_eq!(steps[1].throttle, Some(1300.0));
    }

    fn sweep_with(thrust: &[(f64, f64)]) -> StandLog {
        let mut csv = String::from("# a sweep\nthrottle,thrust_g,power_w\n");
        for (t, g) in thrust {
            csv.push_str(&format!("{t},{g},{}\n", 1.0 + g.abs()));
        }
        StandLog::parse(csv.into_bytes(), "s.csv", &StandOptions::default()).unwrap()
    }

    #[test]
    fn a_negative_idle_step_is_a_tare_offset_and_a_negative_step_past_idle_a_glitch() {
        let ramp = |f: &dyn Fn(usize, f64) -> f64| -> Vec<(f64, f64)> {
            (0..10)
                .map(|i| (0.1 * i as f64, f(i, 30.0 * i as f64)))
                .collect()
        };
        // a clean ramp: nothing
        assert!(sweep_with(&ramp(&|_, g| g)).thrust_oddities().is_empty());
        // every step 3 g low: the idle step (line 3, after a comment and the header) is a tare
        // offset, the rest follow it
        let o = sweep_with(&ramp(&|_, g| g - 3.0)).thrust_oddities();
        assert_eq!(
            o,
            [ThrustOddity::TareOffset {
                line: 3,
                thrust_g: -3.0
            }]
        );
        assert!(o[0].to_string().contains("tare offset at idle"), "{}", o[0]);
        // the third step reads -20 g with idle at 0: a glitch, named by its line
        let o = sweep_with(&ramp(&|i, g| if i == 2 { -20.0 } else { g })).thrust_oddities();
        assert_eq!(
            o,
            [ThrustOddity::NegativePastIdle {
                line: 5,
                thrust_g: -20.0,
                idle_g: 0.0
            }]
        );
        assert!(
            !o[0].to_string().contains("tare offset at idle"),
            "{}",
            o[0]
        );
        assert!(o[0].to_string().contains("line 5"), "{}", o[0]);
        // a positive drop mid-ramp; noise within 10 % of the top is not one
        let o = sweep_with(&ramp(&|i, g| if i == 6 { 20.0 } else { g })).thrust_oddities();
        assert_eq!(o.len(), 1);
        assert!(
            matches!(o[0], ThrustOddity::OffTheRamp { line: 9, .. }),
            "{o:?}"
        );
        let noisy = sweep_with(&ramp(&|i, g| g + if i % 2 == 0 { 9.0 } else { -9.0 }));
        assert!(
            noisy.thrust_oddities().is_empty(),
            "{:?}",
            noisy.thrust_oddities()
        );
        // readings near 0 g below the motor's start-up, some negative: noise, not a glitch
        let start_up = ramp(&|i, g| match i {
            1 => -2.0,
            2 => -2.5,
            3 => -1.8,
            _ => g,
        });
        assert!(sweep_with(&start_up).thrust_oddities().is_empty());
        // an idle step read twice (up and down): the lower of them is the one named
        let mut up_down = ramp(&|_, g| g - 2.0);
        up_down.push((0.0, -4.0));
        let o = sweep_with(&up_down).thrust_oddities();
        assert_eq!(o.len(), 1);
        assert_eq!((o[0].line(), o[0].thrust_g()), (13, -4.0));
    }

    #[test]
    fn rows_of_sensors_logged_at_other_rates_are_left_out_and_said() {
        let t = Table::parse(
            b"Time (s),ESC signal (\xC2\xB5s),Torque (N\xC2\xB7m),Thrust (gf),Voltage (V),Current (A)\n\
              0.0,1100,0.01,50,12,1\n0.1,1100,,,12,1\n0.2,1100,,51,12,1\n0.3,1100,0.01,,12,1\n",
            "tyto.csv",
        )
        .unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert_eq!(m.thrust_g, [50.0, 51.0]);
        assert!(m.torque_nm.is_none());
        assert!(
            m.notes[0].starts_with("2 of 4 row(s) left out for an empty cell"),
            "{:?}",
            m.notes
        );
        assert!(
            m.notes[1].contains("\"Torque (N·m)\" is empty in 1 of the 2 row(s) kept"),
            "{:?}",
            m.notes
        );
        // A cell that holds text, not nothing, is still an error.
        let t = Table::parse(b"thrust_g,voltage_v,current_a\n10,12,x\n", "bad").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        assert!(t.measurements(&map, &[]).is_err());
    }

    #[test]
    fn a_flight_log_without_thrust_is_named_as_one() {
        let t = Table::parse(
            b"timestamp,voltage_v,current_a,discharged_mah\n1,16,3,0\n2,16,3,1\n",
            "battery_status_0.csv",
        )
        .unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let e = t.measurements(&map, &[]).unwrap_err().to_string();
        assert!(e.contains("it looks like a flight log"), "{e}");
        // A stand's table without a thrust column is not one.
        let t = Table::parse(b"time_s,voltage_v,current_a,rpm\n1,16,3,0\n", "s.csv").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let e = t.measurements(&map, &[]).unwrap_err().to_string();
        assert!(!e.contains("flight log"), "{e}");
    }

    #[test]
    fn negative_thrust_is_negated_and_said() {
        let t = Table::parse(b"thrust_g,voltage_v,current_a\n-10,12,1\n-20,12,2\n", "neg").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert_eq!(m.thrust_g, [10.0, 20.0]);
        assert!(m.notes[0].contains("negated"));
        assert_eq!(m.power_w.unwrap(), [12.0, 24.0]);
        assert!(!m.power_logged);
    }

    #[test]
    fn filters_select_rows_and_say_what_exists() {
        let t = Table::parse(b"motor,thrust_g,power_w\nA,1,2\nB,3,4\n", "f").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let f: RowFilter = "motor=B".parse().unwrap();
        let m = t.measurements(&map, &[f]).unwrap();
        assert_eq!(m.thrust_g, [3.0]);
        let e = t
            .measurements(&map, &["motor=C".parse().unwrap()])
            .unwrap_err();
        assert!(e.to_string().contains("motor=A; motor=B"), "{e}");
    }

    #[test]
    fn a_thrust_column_without_a_unit_is_said_to_be_read_as_grams() {
        let t = Table::parse(b"thrust,power_w\n1,2\n3,4\n", "t").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert!(
            m.notes
                .iter()
                .any(|n| n.contains("\"thrust\" names no unit: read as grams (g)")),
            "{:?}",
            m.notes
        );
        let t = Table::parse(b"thrust_g,power_w\n1,2\n", "t").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        assert!(t.measurements(&map, &[]).unwrap().notes.is_empty());
    }

    #[test]
    fn a_current_or_power_column_without_a_unit_is_said_to_be_read_in_the_base_unit() {
        let t = Table::parse(b"thrust_g,voltage_v,current\n1,12,2\n3,12,4\n", "t").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert_eq!(m.notes.len(), 1, "{:?}", m.notes);
        assert!(
            m.notes[0].contains("\"current\" names no unit: read as amperes (A)")
                && m.notes[0].contains("\"current (mA)\""),
            "{:?}",
            m.notes
        );
        let t = Table::parse(b"thrust_g,power\n1,2\n3,4\n", "t").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert!(
            m.notes
                .iter()
                .any(|n| n.contains("\"power\" names no unit: read as watts (W)")),
            "{:?}",
            m.notes
        );
    }

    #[test]
    fn a_text_column_of_several_values_points_to_where() {
        let t = Table::parse(
            b"propeller,thrust_g,power_w,note\nA,1,2,x\nB,3,4,x\nA,5,6,x\n",
            "p",
        )
        .unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert_eq!(m.notes.len(), 1, "{:?}", m.notes);
        assert!(
            m.notes[0].contains("\"propeller\" takes 2 different values (\"A\", \"B\")")
                && m.notes[0].contains("--where \"propeller=A\""),
            "{}",
            m.notes[0]
        );
        // filtered on: no warning
        let m = t
            .measurements(&map, &["propeller=B".parse().unwrap()])
            .unwrap();
        assert!(m.notes.is_empty(), "{:?}", m.notes);
    }

    #[test]
    fn sample_counts_are_whole_and_spreads_not_negative() {
        for (cell, col) in [
            ("-3", "samples"),
            ("2.5", "samples"),
            ("-0.1", "thrust_std_g"),
        ] {
            let (s, t) = if col == "samples" {
                (cell, "0.1")
            } else {
                ("4", cell)
            };
            let csv = format!("thrust_g,thrust_std_g,power_w,samples\n1,0.1,2,4\n2,{t},3,{s}\n");
            let e = StandLog::parse(csv.into_bytes(), "s.csv", &StandOptions::default())
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with(&format!(
                    "s.csv, line 3, column \"{col}\": \"{cell}\" is not"
                )),
                "{e}"
            );
        }
        let log = StandLog::parse(
            b"thrust_g,thrust_std_g,power_w,samples\n1,,2,\n2,0.1,3,7\n".to_vec(),
            "s.csv",
            &StandOptions::default(),
        )
        .unwrap();
        assert_eq!(log.steps[0].samples, 1);
        assert_eq!(log.steps[1].samples, 7);
        assert_eq!(log.steps[0].thrust_std_g, None);
    }

    #[test]
    fn columns_empty_in_every_row_are_absent() {
        let t = Table::parse(b"thrust_g,power_w,rpm,throttle\n1,2,,0.2\n3,4,,0.5\n", "e").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert!(m.speed_rpm.is_none());
        assert_eq!(m.throttle.unwrap(), [0.2, 0.5]);
        // Partly empty: the row is left out, and said so (a stand logging its sensors at
        // different rates); a column empty in every row that passes is an error.
        let t = Table::parse(b"thrust_g,power_w,throttle\n1,2,\n3,4,0.5\n", "e").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let m = t.measurements(&map, &[]).unwrap();
        assert_eq!(
            (m.thrust_g.as_slice(), m.notes[0].as_str()),
            (
                [3.0].as_slice(),
                "1 of 2 row(s) left out for an empty cell in \"thrust_g\", \"power_w\", \"throttle\" (sensors logged at different rates)"
            )
        );
        let t = Table::parse(b"thrust_g,power_w\n1,\n,4\n", "e").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        assert!(t.measurements(&map, &[]).is_err());
    }

    #[test]
    fn unknown_unit_is_named() {
        let t = Table::parse(b"Thrust (furlongs),x\n1,2\n", "u").unwrap();
        let (map, _) = ColumnMap::detect(&t);
        let e = t.measurements(&map, &[]).unwrap_err().to_string();
        assert!(e.contains("\"furlongs\""), "{e}");
    }
}
