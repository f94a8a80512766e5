//! `characterise`: the paper's section III-C in one session folder — a nominal sweep, a
//! limit sweep at the minimum battery voltage, the fit and `params.toml`, and a summary.
//!
//! The folder's files (stable names, see [`files`]):
//!
//! | file | what |
//! | --- | --- |
//! | `sweep.csv` | nominal sweep, one row per 10 g step (what `hoverbench fit` reads) |
//! | `sweep-samples.csv` | its raw samples |
//! | `limit.csv` | limit sweep at the minimum voltage, one row per throttle step |
//! | `limit-samples.csv` | its raw samples |
//! | `params.toml` | the fitted curve and thrust limit (`estimator::file`) |
//! | `summary.txt`, `summary.json` | what was done and found |
//! | `report/` | figures, written by `hoverbench report` |

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use estimator::file::ParamsFile;
use fit::sweeps::{LimitSweep, NominalSweep, SweepFitOptions};
use import::stand::{StandLog, StandOptions};
use rig_protocol::{Clock, Rig};

use crate::bench_supply::SupplyControl;
use crate::error::HostError;
use crate::log::{self, StepRecord, SweepLog};
use crate::sweep::{
    LinkError, MassPlacer, SweepConfig, SweepEnv, SweepEvent, SweepKind, SweepObserver,
    SweepOutcome, calibrate, run_logged, sweep_header,
};

/// File names in a session folder.
pub mod files {
    /// Nominal sweep.
    pub const SWEEP: &str = "sweep.csv";
    /// Its samples.
    pub const SWEEP_SAMPLES: &str = "sweep-samples.csv";
    /// Limit sweep.
    pub const LIMIT: &str = "limit.csv";
    /// Its samples.
    pub const LIMIT_SAMPLES: &str = "limit-samples.csv";
    /// Parameters.
    pub const PARAMS: &str = "params.toml";
    /// Human summary.
    pub const SUMMARY_TXT: &str = "summary.txt";
    /// Machine summary.
    pub const SUMMARY_JSON: &str = "summary.json";
    /// Figures (written by the reports crate).
    pub const REPORT_DIR: &str = "report";
}

/// How a characterisation runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// The session folder.
    pub dir: PathBuf,
    /// The nominal sweep (the paper: 10 g steps at 12.5 V).
    pub nominal: SweepConfig,
    /// The limit sweep (the paper: 9.0 V, the minimum battery voltage).
    pub limit: SweepConfig,
    /// Rotors sharing the take-off mass.
    pub rotors: u8,
    /// Degree of the power curve.
    pub degree: usize,
    /// Continue an interrupted session in `dir`.
    pub resume: bool,
    /// Known masses to calibrate the load cell with (empty: keep the rig's calibration).
    pub calibration_masses_g: Vec<f64>,
    /// What the bench is (for the summary).
    pub bench: String,
}

impl SessionConfig {
    /// The paper's session in `dir`: 10 g steps at 12.5 V, throttle steps at 9.0 V, a
    /// fifth-order fit, four rotors.
    pub fn paper(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: dir.into(),
            nominal: SweepConfig::default(),
            limit: SweepConfig {
                kind: SweepKind::Limit { step_us: 50 },
                voltage_v: 9.0,
                ..SweepConfig::default()
            },
            rotors: 4,
            degree: fit::DEFAULT_DEGREE,
            resume: false,
            calibration_masses_g: Vec::new(),
            bench: "rig".into(),
        }
    }
}

impl SessionConfig {
    /// Checks every setting before anything moves: a bad degree, stream rate or step fails
    /// here, not after both sweeps have run.
    pub fn validate(&self) -> Result<(), HostError> {
        if self.degree > fit::MAX_DEGREE {
            return Err(HostError::Invalid(format!(
                "degree {} is above the highest supported, {}",
                self.degree,
                fit::MAX_DEGREE
            )));
        }
        if self.rotors == 0 {
            return Err(HostError::Invalid("rotor count 0".into()));
        }
        for (what, c) in [("nominal", &self.nominal), ("limit", &self.limit)] {
            c.validate()
                .map_err(|e| HostError::Invalid(format!("{what} sweep: {e}")))?;
        }
        if !matches!(self.nominal.kind, SweepKind::Nominal { .. }) {
            return Err(HostError::Invalid(
                "the nominal sweep must be thrust-targeted".into(),
            ));
        }
        if !matches!(self.limit.kind, SweepKind::Limit { .. }) {
            return Err(HostError::Invalid(
                "the limit sweep must step the throttle".into(),
            ));
        }
        Ok(())
    }
}

/// An advisory lock on a session folder (`DIR/.lock`, `flock`): two `characterise` runs on
/// one folder would interleave their rows. Released when dropped (or when the process dies).
#[derive(Debug)]
pub struct SessionLock {
    _file: std::fs::File,
}

/// The lock file in a session folder.
pub const LOCK_FILE: &str = ".lock";

impl SessionLock {
    /// Takes the lock, or says that another run holds it.
    pub fn acquire(dir: &Path) -> Result<Self, HostError> {
        std::fs::create_dir_all(dir).map_err(|e| HostError::io(dir, e))?;
        let path = dir.join(LOCK_FILE);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|e| HostError::io(&path, e))?;
        #[cfg(unix)]
        {
            use rustix::fs::{FlockOperation, flock};
            match flock(&file, FlockOperation::NonBlockingLockExclusive) {
                Ok(()) => {}
                Err(rustix::io::Errno::WOULDBLOCK) => {
                    return Err(HostError::Locked {
                        dir: dir.to_owned(),
                    });
                }
                Err(e) => return Err(HostError::io(&path, e.into())),
            }
        }
        Ok(Self { _file: file })
    }
}

/// The fit of a session (the summary of [`fit::sweeps::fit_sweeps`]).
pub use fit::sweeps::FitSummary;

/// Summary of one sweep.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SweepSummary {
    /// Steps in the log.
    pub steps: usize,
    /// Of those, valid.
    pub valid_steps: usize,
    /// Steps taken from an interrupted run.
    pub resumed_steps: usize,
    /// How it ended.
    pub end: String,
    /// Rig time of the whole session, s: this run's plus what the session's earlier
    /// `summary.json` recorded (a run interrupted before its summary is not counted).
    pub rig_time_s: f64,
    /// Highest thrust logged, g.
    pub max_thrust_g: f64,
}

impl SweepSummary {
    /// The summary of a sweep whose samples are logged in `samples`: `outcome` is this run's
    /// (`None`: the sweep was complete before), `earlier_s` the rig time an earlier summary
    /// recorded for it. The rig time of earlier, interrupted runs is read from the sample log.
    fn of(
        rows: &[StepRecord],
        outcome: Option<&SweepOutcome>,
        earlier_s: f64,
        samples: &Path,
    ) -> Self {
        let rig_time_s = match outcome {
            Some(o) if o.resumed_steps > 0 => {
                log::logged_rig_time_s(samples, o.resumed_steps) + o.rig_time_s
            }
            Some(o) => o.rig_time_s,
            None if earlier_s > 0.0 => earlier_s,
            None => log::logged_rig_time_s(samples, usize::MAX),
        };
        Self {
            steps: rows.len(),
            valid_steps: rows.iter().filter(|r| r.valid).count(),
            resumed_steps: outcome.map_or(rows.len(), |o| o.resumed_steps),
            end: outcome.map_or("complete (earlier run)".into(), |o| o.end.to_string()),
            rig_time_s,
            max_thrust_g: rows.iter().map(|r| r.thrust_g).fold(0.0, f64::max),
        }
    }
}

/// What a characterisation produced.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SessionSummary {
    /// The bench.
    pub bench: String,
    /// The session folder.
    pub dir: String,
    /// Load-cell calibration.
    pub calibration: String,
    /// The nominal sweep.
    pub nominal: SweepSummary,
    /// The limit sweep.
    pub limit: SweepSummary,
    /// The fit.
    pub fit: FitSummary,
    /// Files written.
    pub files: Vec<String>,
}

/// Writes `bytes` to `path` atomically (`outfile::write_atomic`: temporary file in the same
/// folder, fsync, rename; the temporary file is removed on error).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), HostError> {
    outfile::write_atomic(path, bytes).map_err(HostError::from)
}

/// Fits a nominal sweep and a limit sweep through [`fit::sweeps::fit_sweeps`], as
/// `hoverbench fit SWEEP --limit LIMIT` does.
pub fn fit_sweeps(
    sweep: &Path,
    limit: &Path,
    rotors: u8,
    degree: usize,
) -> Result<(ParamsFile, FitSummary), HostError> {
    let read = |p: &Path| {
        StandLog::read(p, &StandOptions::default()).map_err(|source| HostError::Import {
            path: p.to_owned(),
            source: Box::new(source),
        })
    };
    let nominal = NominalSweep::from_stand(&read(sweep)?, None)?;
    let limit = LimitSweep::from_stand(&read(limit)?, None)?;
    let opts = SweepFitOptions {
        degree,
        rotors,
        tool: format!("hoverbench rig-host {}", env!("CARGO_PKG_VERSION")),
        created: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        motor_degree: fit::motor::DEFAULT_MOTOR_DEGREE,
    };
    let done = fit::sweeps::fit_sweeps(&nominal, Some(&limit), &opts)?;
    Ok((done.params, done.summary))
}

/// Runs one sweep of a session into `csv` (resuming or skipping it as the folder says).
fn session_sweep<R: Rig>(
    rig: &mut R,
    env: SweepEnv<'_>,
    config: &SweepConfig,
    header: &log::LogHeader,
    csv: &Path,
    samples: &Path,
    resume: bool,
) -> Result<(Vec<StepRecord>, Option<SweepOutcome>), HostError>
where
    R::Error: LinkError,
{
    let columns = config.kind.columns();
    let (log, resumed) = if csv.exists() && resume {
        let (log, state) = SweepLog::resume(csv, samples, header, columns)?;
        if state.complete {
            drop(log);
            return Ok((state.rows, None));
        }
        (log, state.rows)
    } else {
        (SweepLog::create(csv, samples, header, columns)?, Vec::new())
    };
    let o = run_logged(rig, env, config, &resumed, log)?;
    Ok((o.rows.clone(), Some(o)))
}

/// What an earlier run of the session recorded in its `summary.json`.
#[derive(Debug, Default)]
struct Earlier {
    nominal_s: f64,
    limit_s: f64,
    calibration: String,
    bench: String,
}

impl Earlier {
    fn read(dir: &Path) -> Self {
        let Ok(text) = std::fs::read_to_string(dir.join(files::SUMMARY_JSON)) else {
            return Self::default();
        };
        let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else {
            return Self::default();
        };
        let time = |k: &str| v[k]["rig_time_s"].as_f64().unwrap_or(0.0);
        Self {
            nominal_s: time("nominal"),
            limit_s: time("limit"),
            calibration: v["calibration"].as_str().unwrap_or_default().to_owned(),
            bench: v["bench"].as_str().unwrap_or_default().to_owned(),
        }
    }
}

/// Checks that `dir` can take a new session (it holds none), unless resuming, and creates it:
/// a folder that cannot be made (a file in its place, a missing or read-only parent) is refused
/// here, before the rig is started or moved.
pub fn check_session_dir(dir: &Path, resume: bool) -> Result<(), HostError> {
    let unusable = |source| HostError::SessionDir {
        dir: dir.to_owned(),
        source,
    };
    if dir.exists() && !dir.is_dir() {
        return Err(unusable(std::io::Error::new(
            std::io::ErrorKind::NotADirectory,
            "a file is in its place: give a folder",
        )));
    }
    let taken = [files::SWEEP, files::LIMIT, files::PARAMS]
        .iter()
        .any(|f| dir.join(f).exists());
    if taken && !resume {
        return Err(HostError::Invalid(format!(
            "{} already holds a session: give --resume to continue it, or another folder",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(unusable)
}

/// Whether the session in `dir` has both sweeps complete (`# end: complete`): nothing is left
/// to measure, and `--resume` only regenerates its outputs ([`regenerate`]).
pub fn is_finished(dir: &Path) -> bool {
    log::is_complete(&dir.join(files::SWEEP)) && log::is_complete(&dir.join(files::LIMIT))
}

/// Regenerates a finished session's `params.toml` and summaries from its logs, without a rig:
/// nothing moves and nothing is calibrated. The rig time and calibration are those the session
/// recorded.
pub fn regenerate(config: &SessionConfig) -> Result<SessionSummary, HostError> {
    let dir = &config.dir;
    if !is_finished(dir) {
        return Err(HostError::Invalid(format!(
            "{} is not a finished session (both sweeps ending with `# end: complete`)",
            dir.display()
        )));
    }
    let _lock = SessionLock::acquire(dir)?;
    let p = |name: &str| dir.join(name);
    let earlier = Earlier::read(dir);
    let nominal_rows = log::read_steps(&p(files::SWEEP))?.rows;
    let limit_rows = log::read_steps(&p(files::LIMIT))?.rows;
    let (params, fit) = fit_sweeps(
        &p(files::SWEEP),
        &p(files::LIMIT),
        config.rotors,
        config.degree,
    )?;
    write_atomic(&p(files::PARAMS), params.to_toml_string().as_bytes())?;
    let calibration = if earlier.calibration.is_empty() {
        std::fs::read_to_string(p(files::SWEEP))
            .ok()
            .and_then(|t| {
                log::LogHeader::parse(&t)
                    .get("calibration")
                    .map(str::to_owned)
            })
            .unwrap_or_default()
    } else {
        earlier.calibration.clone()
    };
    let summary = SessionSummary {
        bench: if earlier.bench.is_empty() {
            config.bench.clone()
        } else {
            earlier.bench.clone()
        },
        dir: dir.display().to_string(),
        calibration,
        nominal: SweepSummary::of(
            &nominal_rows,
            None,
            earlier.nominal_s,
            &p(files::SWEEP_SAMPLES),
        ),
        limit: SweepSummary::of(&limit_rows, None, earlier.limit_s, &p(files::LIMIT_SAMPLES)),
        fit,
        files: [
            files::SWEEP,
            files::SWEEP_SAMPLES,
            files::LIMIT,
            files::LIMIT_SAMPLES,
            files::PARAMS,
            files::SUMMARY_TXT,
            files::SUMMARY_JSON,
        ]
        .map(str::to_owned)
        .to_vec(),
    };
    write_summaries(dir, &summary, &nominal_rows, &limit_rows)?;
    Ok(summary)
}

/// Runs a characterisation on a connected rig and supply; see the [module docs](self).
pub fn characterise<R: Rig>(
    rig: &mut R,
    clock: &dyn Clock,
    supply: &mut dyn SupplyControl,
    config: &SessionConfig,
    placer: Option<&mut dyn MassPlacer>,
    observer: &mut dyn SweepObserver,
    stop: &AtomicBool,
) -> Result<SessionSummary, HostError>
where
    R::Error: LinkError,
{
    config.validate()?;
    let dir = &config.dir;
    check_session_dir(dir, config.resume)?;
    let _lock = SessionLock::acquire(dir)?;
    let p = |name: &str| dir.join(name);
    // A finished session resumed: nothing moves, nothing is calibrated again.
    let earlier = Earlier::read(dir);
    let finished =
        config.resume && log::is_complete(&p(files::SWEEP)) && log::is_complete(&p(files::LIMIT));
    let err = |during: &'static str| {
        move |e: R::Error| HostError::Rig {
            during,
            source: Box::new(e),
        }
    };
    let identity = rig.identify().map_err(err("identify"))?;
    let first_run = !p(files::SWEEP).exists();
    let uncalibrated = rig.status().map_err(err("status"))?.calibration_points == 0;
    let calibration = match placer {
        Some(placer)
            if !finished
                && (first_run || uncalibrated)
                && !config.calibration_masses_g.is_empty() =>
        {
            observer.event(SweepEvent::Note("calibrating the load cell"));
            calibrate(
                rig,
                clock,
                &config.calibration_masses_g,
                placer,
                config.nominal.tare_samples,
            )?
            .1
        }
        _ => String::new(),
    };
    let status = rig.status().map_err(err("status"))?;
    let calibration = if calibration.is_empty() && finished && !earlier.calibration.is_empty() {
        earlier.calibration.clone()
    } else if calibration.is_empty() {
        format!(
            "kept by the rig ({})",
            count(usize::from(status.calibration_points), "point")
        )
    } else {
        calibration
    };
    // A finished session keeps the calibration its logs were taken with.
    let calibration_points = if finished {
        std::fs::read_to_string(p(files::SWEEP))
            .ok()
            .and_then(|t| {
                log::LogHeader::parse(&t)
                    .get("calibration_points")?
                    .parse()
                    .ok()
            })
            .unwrap_or(status.calibration_points)
    } else {
        status.calibration_points
    };
    let supply_id = supply.identity();
    let mut done = Vec::new();
    let mut run = |cfg: &SweepConfig,
                   csv: &str,
                   samples: &str,
                   what: &str,
                   rig: &mut R,
                   supply: &mut dyn SupplyControl,
                   observer: &mut dyn SweepObserver|
     -> Result<(Vec<StepRecord>, Option<SweepOutcome>), HostError> {
        observer.event(SweepEvent::Note(&format!(
            "{what} sweep at {} V → {}",
            cfg.voltage_v,
            p(csv).display()
        )));
        let header = sweep_header(cfg, &identity, calibration_points, &calibration, &supply_id);
        let env = SweepEnv {
            clock,
            identity: &identity,
            supply,
            observer,
            stop,
        };
        let r = session_sweep(rig, env, cfg, &header, &p(csv), &p(samples), config.resume)?;
        done.push(csv.to_owned());
        done.push(samples.to_owned());
        Ok(r)
    };
    let (nominal_rows, nominal) = run(
        &config.nominal,
        files::SWEEP,
        files::SWEEP_SAMPLES,
        "nominal",
        rig,
        supply,
        observer,
    )?;
    let (limit_rows, limit) = run(
        &config.limit,
        files::LIMIT,
        files::LIMIT_SAMPLES,
        "limit",
        rig,
        supply,
        observer,
    )?;
    observer.event(SweepEvent::Note("fitting"));
    let (params, fit) = fit_sweeps(
        &p(files::SWEEP),
        &p(files::LIMIT),
        config.rotors,
        config.degree,
    )?;
    write_atomic(&p(files::PARAMS), params.to_toml_string().as_bytes())?;
    done.push(files::PARAMS.to_owned());
    done.push(files::SUMMARY_TXT.to_owned());
    done.push(files::SUMMARY_JSON.to_owned());
    let summary = SessionSummary {
        bench: config.bench.clone(),
        dir: dir.display().to_string(),
        calibration,
        nominal: SweepSummary::of(
            &nominal_rows,
            nominal.as_ref(),
            earlier.nominal_s,
            &p(files::SWEEP_SAMPLES),
        ),
        limit: SweepSummary::of(
            &limit_rows,
            limit.as_ref(),
            earlier.limit_s,
            &p(files::LIMIT_SAMPLES),
        ),
        fit,
        files: done,
    };
    write_summaries(dir, &summary, &nominal_rows, &limit_rows)?;
    Ok(summary)
}

/// Writes `summary.json` and `summary.txt` into the session folder.
fn write_summaries(
    dir: &Path,
    summary: &SessionSummary,
    nominal_rows: &[StepRecord],
    limit_rows: &[StepRecord],
) -> Result<(), HostError> {
    let json = serde_json::to_string_pretty(summary).map_err(|source| HostError::Json {
        what: "the session summary",
        source,
    })?;
    write_atomic(
        &dir.join(files::SUMMARY_JSON),
        format!("{json}\n").as_bytes(),
    )?;
    write_atomic(
        &dir.join(files::SUMMARY_TXT),
        summary_text(summary, nominal_rows, limit_rows).as_bytes(),
    )?;
    Ok(())
}

/// `n` and a noun, in the singular for one (`1 step`, `3 steps`).
fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The human summary of a session: the steps of both sweeps, the fit and the thrust limit.
pub fn summary_text(s: &SessionSummary, nominal: &[StepRecord], limit: &[StepRecord]) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(t, "hoverbench characterise — {}", s.bench);
    let _ = writeln!(t, "session folder: {}", s.dir);
    let _ = writeln!(t, "load cell: {}", s.calibration);
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "nominal sweep: {} ({} valid), {}; {:.1} s of rig time",
        count(s.nominal.steps, "step"),
        s.nominal.valid_steps,
        s.nominal.end,
        s.nominal.rig_time_s
    );
    let _ = writeln!(
        t,
        "{:>8} {:>9} {:>10} {:>9} {:>9} {:>9} {:>8} {:>5}",
        "target_g",
        "thrust_g",
        "throttle_us",
        "current_a",
        "voltage_v",
        "power_w",
        "settle_s",
        "mode"
    );
    for r in nominal {
        let _ = writeln!(
            t,
            "{:>8} {:>9.2} {:>10} {:>9.3} {:>9.3} {:>9.3} {:>8.2} {:>5}{}",
            r.target_g.map_or("-".into(), |x| format!("{x}")),
            r.thrust_g,
            r.throttle_us,
            r.current_a,
            r.voltage_v,
            r.power_w,
            r.settle_s,
            log::mode_tag(r.supply_mode),
            if r.valid { "" } else { "  invalid" }
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "limit sweep: {} ({} valid), {}; highest thrust {:.2} g",
        count(s.limit.steps, "step"),
        s.limit.valid_steps,
        s.limit.end,
        s.limit.max_thrust_g
    );
    for r in limit.iter().rev().take(4).rev() {
        // a step logged without a spread (an empty cell) has none to show
        let spread = r
            .thrust_std_g
            .map_or(String::new(), |s| format!(" ± {s:.2}"));
        let _ = writeln!(
            t,
            "  {} us: {:.2}{spread} g at {:.3} V",
            r.throttle_us, r.thrust_g, r.voltage_v
        );
    }
    let f = &s.fit;
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "fit: power_w = p(thrust_g), degree {}, {} ({} skipped), {:.1}..{:.1} g, RMSE {:.4} W, R² {:.6}",
        f.coefficients.len().saturating_sub(1),
        count(f.n_points, "point"),
        count(f.skipped_invalid, "invalid row"),
        f.valid_range_g.0,
        f.valid_range_g.1,
        f.rmse_w,
        f.r_squared
    );
    if let (Some(l), Some(u), Some(kg)) = (
        f.thrust_limit_g,
        f.thrust_limit_uncertainty_g,
        f.thrust_limit_total_kg,
    ) {
        let at = f
            .limit_voltage_v
            .map_or(String::new(), |v| format!(" at {v:.2} V"));
        let _ = writeln!(
            t,
            "thrust limit: {l:.1} ± {u:.1} g per rotor{at} → m_L = {kg:.3} kg"
        );
    }
    match (&f.motor_map, &f.motor_map_skipped) {
        (Some(m), _) => {
            let _ = writeln!(t, "{}", m.line());
        }
        (None, Some(why)) => {
            let _ = writeln!(t, "no motor map: {why}");
        }
        (None, None) => {}
    }
    for w in &f.warnings {
        let _ = writeln!(t, "warning: {w}");
    }
    let _ = writeln!(t);
    let _ = writeln!(t, "files: {}", s.files.join(", "));
    if matches!(s.nominal.end.as_str(), e if e.starts_with("supply")) {
        let _ = writeln!(
            t,
            "note: the nominal sweep stopped at the supply's current limit"
        );
    }
    t
}

#[cfg(test)]
mod lock_tests {
    use super::*;

    #[test]
    fn a_session_folder_has_one_holder_at_a_time() {
        let d = tempfile::tempdir().unwrap();
        let first = SessionLock::acquire(d.path()).unwrap();
        let err = SessionLock::acquire(d.path()).unwrap_err();
        assert!(matches!(err, HostError::Locked { .. }), "{err}");
        drop(first);
        SessionLock::acquire(d.path()).unwrap();
    }

    #[test]
    fn settings_are_checked_before_anything_moves() {
        let mut c = SessionConfig::paper("unused");
        c.validate().unwrap();
        c.degree = 40;
        assert!(c.validate().is_err());
        let mut c = SessionConfig::paper("unused");
        c.limit.kind = SweepKind::Limit { step_us: 0 };
        assert!(c.validate().is_err());
        let mut c = SessionConfig::paper("unused");
        c.nominal.stream_rate_hz = 0;
        assert!(c.validate().is_err());
    }
}
