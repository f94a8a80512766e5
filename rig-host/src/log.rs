//! Crash-safe sweep logs: one CSV row per completed step (flushed and fsynced before the
//! next step starts), the raw sample stream in a second file, a `#` comment block that
//! identifies the sweep, and `--resume` from the last complete step.
//!
//! The step log is what `hoverbench fit` reads (`import::stand` recognises `thrust_g` and
//! skips rows whose `valid` is `false`). Its comment block has one `key: value` per line; the
//! keys in [`VALIDATED_KEYS`] must match for a resume to be accepted (same sweep, rig,
//! calibration, supply settings and columns). A sweep ends with a `# end: <reason>` line;
//! `# end: complete` marks a finished sweep.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rig_protocol::Sample;
use supply::RegulationMode;

use crate::error::HostError;

/// Comment keys that must be equal for `--resume` to continue a log.
pub const VALIDATED_KEYS: [&str; 6] = [
    "sweep",
    "rig",
    "calibration_points",
    "supply_voltage_v",
    "current_limit_a",
    "columns",
];

/// Columns of a nominal (thrust-targeted) sweep log.
pub const NOMINAL_COLUMNS: &str = "step,target_g,throttle_us,thrust_g,thrust_std_g,current_a,current_std_a,voltage_v,voltage_std_v,power_w,power_std_w,samples,settle_s,time_s,supply_mode,valid";
/// Columns of a limit (throttle-stepped) sweep log.
pub const LIMIT_COLUMNS: &str = "step,throttle_us,thrust_g,thrust_std_g,current_a,current_std_a,voltage_v,voltage_std_v,power_w,power_std_w,samples,settle_s,time_s,supply_mode,valid";
/// Columns of a raw sample log.
pub const SAMPLE_COLUMNS: &str =
    "step,attempt,in_window,time_us,throttle_us,thrust_g,current_a,voltage_v,power_w";

/// The text of a regulation mode in the logs: `CV`, `CC`, `UR`, `OFF`.
pub fn mode_tag(m: RegulationMode) -> &'static str {
    match m {
        RegulationMode::ConstantVoltage => "CV",
        RegulationMode::ConstantCurrent => "CC",
        RegulationMode::Unregulated => "UR",
        RegulationMode::Off => "OFF",
    }
}

fn parse_mode(s: &str) -> Option<RegulationMode> {
    Some(match s {
        "CV" => RegulationMode::ConstantVoltage,
        "CC" => RegulationMode::ConstantCurrent,
        "UR" => RegulationMode::Unregulated,
        "OFF" => RegulationMode::Off,
        _ => return None,
    })
}

/// One completed step: the means and spreads of its steady window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepRecord {
    /// Step number, from 0.
    pub step: usize,
    /// Thrust target, g (nominal sweeps).
    pub target_g: Option<f64>,
    /// Throttle, µs.
    pub throttle_us: u16,
    /// Mean thrust, g.
    pub thrust_g: f64,
    /// Its standard deviation, g; `None` when the log has none (an empty cell).
    pub thrust_std_g: Option<f64>,
    /// Mean current, A.
    pub current_a: f64,
    /// Its standard deviation, A; `None` when the log has none (an empty cell).
    pub current_std_a: Option<f64>,
    /// Mean voltage, V.
    pub voltage_v: f64,
    /// Its standard deviation, V; `None` when the log has none (an empty cell).
    pub voltage_std_v: Option<f64>,
    /// Mean electrical power, W.
    pub power_w: f64,
    /// Its standard deviation, W; `None` when the log has none (an empty cell).
    pub power_std_w: Option<f64>,
    /// Samples averaged.
    pub samples: usize,
    /// Rig time from the step's first command to steady, s.
    pub settle_s: f64,
    /// Rig time at the end of the step, s.
    pub time_s: f64,
    /// Supply regulation mode during the step (the worst seen).
    pub supply_mode: RegulationMode,
    /// False when the supply was not regulating its voltage (the fit skips the row).
    pub valid: bool,
}

impl StepRecord {
    fn csv(&self) -> String {
        let mut s = format!("{}", self.step);
        if let Some(t) = self.target_g {
            s.push_str(&format!(",{t}"));
        }
        // a missing spread is an empty cell, as the importer reads one
        let spread =
            |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
        s.push_str(&format!(
            ",{},{:.4},{},{:.5},{},{:.4},{},{:.5},{},{},{:.3},{:.3},{},{}",
            self.throttle_us,
            self.thrust_g,
            spread(self.thrust_std_g, 4),
            self.current_a,
            spread(self.current_std_a, 5),
            self.voltage_v,
            spread(self.voltage_std_v, 4),
            self.power_w,
            spread(self.power_std_w, 5),
            self.samples,
            self.settle_s,
            self.time_s,
            mode_tag(self.supply_mode),
            self.valid
        ));
        s
    }

    fn parse(header: &[&str], line: &str) -> Option<Self> {
        let record = csv_record(line)?;
        let cells: Vec<&str> = record.iter().collect();
        if cells.len() != header.len() {
            return None;
        }
        let get = |name: &str| header.iter().position(|h| *h == name).map(|i| cells[i]);
        let num = |name: &str| get(name).and_then(|c| c.parse::<f64>().ok());
        // a spread as the importer reads one (`import::Table::uncertainty_column`): an empty
        // cell is no spread (`Some(None)`), a value must be a finite number ≥ 0 (else the row
        // is refused: `None`)
        let spread = |name: &str| match get(name)? {
            "" => Some(None),
            c => c
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .map(Some),
        };
        Some(Self {
            step: get("step")?.parse().ok()?,
            target_g: num("target_g"),
            throttle_us: get("throttle_us")?.parse().ok()?,
            thrust_g: num("thrust_g")?,
            thrust_std_g: spread("thrust_std_g")?,
            current_a: num("current_a")?,
            current_std_a: spread("current_std_a")?,
            voltage_v: num("voltage_v")?,
            voltage_std_v: spread("voltage_std_v")?,
            power_w: num("power_w")?,
            power_std_w: spread("power_std_w")?,
            samples: get("samples")?.parse().ok()?,
            settle_s: num("settle_s")?,
            time_s: num("time_s")?,
            supply_mode: parse_mode(get("supply_mode")?)?,
            valid: get("valid")?.parse().ok()?,
        })
    }
}

/// One CSV line as a record (the `csv` crate's quoting rules, cells trimmed).
fn csv_record(line: &str) -> Option<csv::StringRecord> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .from_reader(line.as_bytes())
        .records()
        .next()?
        .ok()
}

/// One raw sample in the sample log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoggedSample {
    /// Step number.
    pub step: usize,
    /// Throttle attempt within the step, from 0.
    pub attempt: usize,
    /// Whether the sample is in the step's measurement window.
    pub in_window: bool,
    /// The sample as the rig sent it.
    pub sample: Sample,
}

impl LoggedSample {
    fn csv(&self) -> String {
        let s = self.sample;
        format!(
            "{},{},{},{},{},{},{},{},{}",
            self.step,
            self.attempt,
            u8::from(self.in_window),
            s.time_us,
            s.throttle_us,
            s.thrust_g,
            s.current_a,
            s.voltage_v,
            f64::from(s.current_a) * f64::from(s.voltage_v)
        )
    }
}

/// The identifying comment block of a log, `key: value` lines in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogHeader {
    /// The lines.
    pub lines: Vec<(String, String)>,
}

impl LogHeader {
    /// Adds a line.
    pub fn push(&mut self, key: &str, value: impl Into<String>) {
        self.lines.push((key.to_owned(), value.into()));
    }

    /// The value of `key`.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.lines
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    fn render(&self) -> String {
        let mut s = String::new();
        for (k, v) in &self.lines {
            s.push_str(&format!("# {k}: {v}\n"));
        }
        s
    }

    /// Reads the `# key: value` header lines of a log's text.
    pub fn parse(text: &str) -> Self {
        let mut h = Self::default();
        for l in text.lines() {
            let Some(c) = l.strip_prefix('#') else {
                break;
            };
            if let Some((k, v)) = c.trim().split_once(':') {
                h.push(k.trim(), v.trim());
            }
        }
        h
    }
}

/// What an interrupted log holds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResumeState {
    /// The complete steps, in order.
    pub rows: Vec<StepRecord>,
    /// Whether the sweep had already finished (`# end: complete`).
    pub complete: bool,
}

/// An open sweep log (steps and samples); see the [module docs](self).
#[derive(Debug)]
pub struct SweepLog {
    path: PathBuf,
    file: File,
    samples_path: PathBuf,
    samples: BufWriter<File>,
    columns: &'static str,
}

fn sync(path: &Path, f: &mut File) -> Result<(), HostError> {
    f.flush().map_err(|e| HostError::io(path, e))?;
    f.sync_data().map_err(|e| HostError::io(path, e))
}

impl SweepLog {
    /// Creates a new log (refusing to overwrite one) and writes its comment block and header.
    pub fn create(
        path: &Path,
        samples_path: &Path,
        header: &LogHeader,
        columns: &'static str,
    ) -> Result<Self, HostError> {
        let open = |p: &Path| {
            OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(p)
                .map_err(|e| HostError::io(p, e))
        };
        let mut file = open(path)?;
        let mut h = header.clone();
        h.push("columns", columns);
        file.write_all(format!("{}{columns}\n", h.render()).as_bytes())
            .map_err(|e| HostError::io(path, e))?;
        sync(path, &mut file)?;
        let mut sf = open(samples_path)?;
        sf.write_all(format!("{}{SAMPLE_COLUMNS}\n", header.render()).as_bytes())
            .map_err(|e| HostError::io(samples_path, e))?;
        sync(samples_path, &mut sf)?;
        Ok(Self {
            path: path.to_owned(),
            file,
            samples_path: samples_path.to_owned(),
            samples: BufWriter::new(sf),
            columns,
        })
    }

    /// Reopens an interrupted log: checks that it belongs to the sweep described by `header`,
    /// drops a trailing partial line, and returns the complete steps.
    pub fn resume(
        path: &Path,
        samples_path: &Path,
        header: &LogHeader,
        columns: &'static str,
    ) -> Result<(Self, ResumeState), HostError> {
        let refuse = |reason: String| HostError::Resume {
            path: path.to_owned(),
            reason,
        };
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(|e| HostError::io(path, e))?;
        let mut text = String::new();
        file.read_to_string(&mut text)
            .map_err(|e| HostError::io(path, e))?;
        let old = LogHeader::parse(&text);
        let mut want = header.clone();
        want.push("columns", columns);
        for key in VALIDATED_KEYS {
            if old.get(key) != want.get(key) {
                return Err(refuse(format!(
                    "its {key:?} is {:?}, this sweep's is {:?}",
                    old.get(key).unwrap_or("(missing)"),
                    want.get(key).unwrap_or("(missing)")
                )));
            }
        }
        // Keep whole lines only: a step row is complete once its newline is on disk.
        let keep = text.rfind('\n').map_or(0, |i| i + 1);
        let state = parse_steps(&text[..keep], Some(columns), refuse)?;
        file.set_len(keep as u64)
            .map_err(|e| HostError::io(path, e))?;
        file.seek(SeekFrom::End(0))
            .map_err(|e| HostError::io(path, e))?;
        let mut sf = OpenOptions::new()
            .append(true)
            .create(true)
            .open(samples_path)
            .map_err(|e| HostError::io(samples_path, e))?;
        if sf.metadata().map(|m| m.len()).unwrap_or(0) == 0 {
            sf.write_all(format!("{}{SAMPLE_COLUMNS}\n", header.render()).as_bytes())
                .map_err(|e| HostError::io(samples_path, e))?;
        } else {
            // A partial last sample line from the interrupted run stays; start on a new line.
            sf.write_all(b"\n# resumed\n")
                .map_err(|e| HostError::io(samples_path, e))?;
        }
        let mut log = Self {
            path: path.to_owned(),
            file,
            samples_path: samples_path.to_owned(),
            samples: BufWriter::new(sf),
            columns,
        };
        if !state.complete {
            log.comment(&format!(
                "resumed: after {} complete steps, {}",
                state.rows.len(),
                humantime::format_rfc3339_seconds(std::time::SystemTime::now())
            ))?;
        }
        Ok((log, state))
    }

    /// The step log's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The columns of the step log.
    pub fn columns(&self) -> &'static str {
        self.columns
    }

    /// Writes one completed step: its samples first, then its row; both are flushed and
    /// fsynced before this returns.
    pub fn append_step(
        &mut self,
        row: &StepRecord,
        samples: &[LoggedSample],
    ) -> Result<(), HostError> {
        let sp = self.samples_path.clone();
        for s in samples {
            writeln!(self.samples, "{}", s.csv()).map_err(|e| HostError::io(&sp, e))?;
        }
        self.samples.flush().map_err(|e| HostError::io(&sp, e))?;
        self.samples
            .get_ref()
            .sync_data()
            .map_err(|e| HostError::io(&sp, e))?;
        let p = self.path.clone();
        writeln!(self.file, "{}", row.csv()).map_err(|e| HostError::io(&p, e))?;
        sync(&p, &mut self.file)
    }

    /// Writes a `# text` line to the step log (flushed and fsynced).
    pub fn comment(&mut self, text: &str) -> Result<(), HostError> {
        let p = self.path.clone();
        writeln!(self.file, "# {text}").map_err(|e| HostError::io(&p, e))?;
        sync(&p, &mut self.file)
    }

    /// Closes the log with `# end: <reason>` in both files.
    pub fn finish(mut self, reason: &str) -> Result<(), HostError> {
        let sp = self.samples_path.clone();
        writeln!(self.samples, "# end: {reason}").map_err(|e| HostError::io(&sp, e))?;
        self.samples.flush().map_err(|e| HostError::io(&sp, e))?;
        let _ = self.samples.get_ref().sync_data();
        self.comment(&format!("end: {reason}"))
    }
}

/// Whether the log at `path` ends with `# end: complete`.
pub fn is_complete(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| {
        t.lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .is_some_and(|l| l.trim() == "# end: complete")
    })
}

/// Reads a log without opening it for writing: its complete steps and whether it ended with
/// `# end: complete` (a partial last line is ignored). For a finished session that is only
/// regenerated.
pub fn read_steps(path: &Path) -> Result<ResumeState, HostError> {
    let refuse = |reason: String| HostError::Resume {
        path: path.to_owned(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| HostError::io(path, e))?;
    let keep = text.rfind('\n').map_or(0, |i| i + 1);
    parse_steps(&text[..keep], None, refuse)
}

/// The step rows of a log's whole lines (the `#` header lines skipped) and whether it ends
/// with `# end: complete`. With `columns`, the log must be the sweep's own: its column header
/// is `columns` and its steps are numbered 0, 1, 2, … without a gap.
fn parse_steps(
    body: &str,
    columns: Option<&str>,
    refuse: impl Fn(String) -> HostError,
) -> Result<ResumeState, HostError> {
    let mut lines = body.lines().skip_while(|l| l.starts_with('#'));
    let head = lines
        .next()
        .ok_or_else(|| refuse("no column header".into()))?;
    if let Some(columns) = columns
        && head != columns
    {
        return Err(refuse(format!("columns {head:?}, expected {columns:?}")));
    }
    let head_record = csv_record(head).ok_or_else(|| refuse(format!("column header {head:?}")))?;
    let names: Vec<&str> = head_record.iter().collect();
    let mut state = ResumeState::default();
    for (i, l) in lines.enumerate() {
        if let Some(c) = l.strip_prefix('#') {
            state.complete = c.trim() == "end: complete";
            continue;
        }
        if l.trim().is_empty() {
            continue;
        }
        let row = StepRecord::parse(&names, l)
            .ok_or_else(|| refuse(format!("row {} is not a step: {l:?}", i + 1)))?;
        if columns.is_some() && row.step != state.rows.len() {
            return Err(refuse(format!(
                "step {} follows {} steps",
                row.step,
                state.rows.len()
            )));
        }
        state.complete = false;
        state.rows.push(row);
    }
    Ok(state)
}

/// Rig time, s, that the sample log at `path` records for the steps before `before_step`: the
/// span of the sample clock over each run (a resumed run starts a new span: `# resumed`, or
/// the rig's clock starting again), summed. 0 when the log cannot be read.
pub fn logged_rig_time_s(path: &Path, before_step: usize) -> f64 {
    let Ok(text) = std::fs::read_to_string(path) else {
        return 0.0;
    };
    let mut lines = text.lines().skip_while(|l| l.starts_with('#'));
    let Some(head) = lines.next() else {
        return 0.0;
    };
    let names: Vec<&str> = head.split(',').map(str::trim).collect();
    let (Some(step_col), Some(time_col)) = (
        names.iter().position(|n| *n == "step"),
        names.iter().position(|n| *n == "time_us"),
    ) else {
        return 0.0;
    };
    let mut total_us = 0u64;
    let mut span: Option<(u64, u64)> = None;
    let mut close = |span: &mut Option<(u64, u64)>| {
        if let Some((a, b)) = span.take() {
            total_us += b.saturating_sub(a);
        }
    };
    for l in lines {
        if l.starts_with('#') {
            close(&mut span);
            continue;
        }
        let cells: Vec<&str> = l.split(',').collect();
        let (Some(step), Some(t)) = (
            cells
                .get(step_col)
                .and_then(|c| c.trim().parse::<usize>().ok()),
            cells
                .get(time_col)
                .and_then(|c| c.trim().parse::<u64>().ok()),
        ) else {
            continue;
        };
        if step >= before_step {
            continue;
        }
        span = match span {
            Some((a, b)) if t >= b => Some((a, t)),
            Some(_) => {
                close(&mut span);
                Some((t, t))
            }
            None => Some((t, t)),
        };
    }
    close(&mut span);
    total_us as f64 * 1e-6
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(step: usize) -> StepRecord {
        StepRecord {
            step,
            target_g: Some(10.0 * (step + 1) as f64),
            throttle_us: 1100 + step as u16,
            thrust_g: 10.0 * (step + 1) as f64,
            thrust_std_g: Some(0.1),
            current_a: 1.0,
            current_std_a: Some(0.01),
            voltage_v: 12.5,
            voltage_std_v: Some(0.01),
            power_w: 12.5,
            power_std_w: Some(0.1),
            samples: 40,
            settle_s: 0.5,
            time_s: 1.0,
            supply_mode: RegulationMode::ConstantVoltage,
            valid: true,
        }
    }

    fn header(v: &str) -> LogHeader {
        let mut h = LogHeader::default();
        h.push("sweep", "nominal");
        h.push("rig", "serial 1");
        h.push("calibration_points", "3");
        h.push("supply_voltage_v", v);
        h.push("current_limit_a", "10");
        h
    }

    #[test]
    fn resume_keeps_complete_rows_drops_a_partial_one_and_checks_the_header() {
        let dir = tempfile::tempdir().unwrap();
        let (p, s) = (dir.path().join("s.csv"), dir.path().join("s-samples.csv"));
        let mut log = SweepLog::create(&p, &s, &header("12.5"), NOMINAL_COLUMNS).unwrap();
        assert!(SweepLog::create(&p, &s, &header("12.5"), NOMINAL_COLUMNS).is_err());
        for i in 0..3 {
            log.append_step(&row(i), &[]).unwrap();
        }
        drop(log);
        // A crash in the middle of the fourth row.
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        f.write_all(b"3,40,1103,40.0").unwrap();
        drop(f);
        let err = SweepLog::resume(&p, &s, &header("9"), NOMINAL_COLUMNS).unwrap_err();
        assert!(err.to_string().contains("supply_voltage_v"), "{err}");
        let (mut log, state) = SweepLog::resume(&p, &s, &header("12.5"), NOMINAL_COLUMNS).unwrap();
        assert_eq!(state.rows, vec![row(0), row(1), row(2)]);
        assert!(!state.complete);
        log.append_step(&row(3), &[]).unwrap();
        log.finish("complete").unwrap();
        assert!(is_complete(&p));
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(!text.contains("40.0\n3,"), "the partial row is gone");
        let (_, state) = SweepLog::resume(&p, &s, &header("12.5"), NOMINAL_COLUMNS).unwrap();
        assert!(state.complete && state.rows.len() == 4);
    }

    #[test]
    fn a_sweep_log_reads_as_a_hoverbench_sweep() {
        let dir = tempfile::tempdir().unwrap();
        let (p, s) = (dir.path().join("s.csv"), dir.path().join("s-samples.csv"));
        let mut log = SweepLog::create(&p, &s, &header("12.5"), NOMINAL_COLUMNS).unwrap();
        for i in 0..3 {
            log.append_step(&row(i), &[]).unwrap();
        }
        let mut bad = row(3);
        bad.valid = false;
        bad.supply_mode = RegulationMode::ConstantCurrent;
        log.append_step(&bad, &[]).unwrap();
        log.finish("complete").unwrap();
        let read = import::stand::StandLog::read(&p, &Default::default()).unwrap();
        assert_eq!(read.kind, import::stand::LogKind::Hoverbench);
        assert_eq!(read.steps.len(), 3);
        assert_eq!(read.skipped_invalid, 1);
        assert!(read.column(|s| s.throttle).is_some());
        assert_eq!(read.column(|s| s.power_w).unwrap(), vec![12.5; 3]);
    }
}
