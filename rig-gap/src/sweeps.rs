//! Stand logs → runs of settled steps the model can be compared with.

use import::stand::StandLog;
use motor_model::{Observation, Point, Prediction, Sweep};

use crate::RigGapError;

/// Where a step sits in its run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepMeta {
    /// Whether the command rose into this step (the first step counts as up).
    pub up: bool,
    /// The throttle command, if logged.
    pub throttle: Option<f64>,
    /// Source line of the step.
    pub line: u64,
}

/// One run of a stand log: steps in the order they were taken.
#[derive(Debug, Clone, PartialEq)]
pub struct StandSweep {
    /// The steps as the model sees them.
    pub sweep: Sweep,
    /// Per-step metadata, parallel to `sweep.steps`.
    pub meta: Vec<StepMeta>,
}

impl StandSweep {
    /// Its name.
    pub fn name(&self) -> &str {
        &self.sweep.name
    }

    /// A run built from model predictions (for examples and tests): every quantity logged.
    pub fn from_predictions(name: &str, points: &[Point], pred: &[Prediction]) -> Self {
        let steps = points
            .iter()
            .zip(pred)
            .map(|(pt, p)| Observation {
                thrust_g: pt.thrust_g,
                time_frac: pt.time_frac,
                time_s: pt.time_s,
                power_w: Some(p.power_w),
                current_a: Some(p.current_a),
                voltage_v: Some(p.voltage_v),
                speed_rpm: Some(p.rpm),
                torque_nm: Some(p.torque_nm),
            })
            .collect();
        Self {
            sweep: Sweep {
                name: name.to_owned(),
                steps,
                open_circuit_v: None,
                tare_time_s: 0.0,
            },
            meta: (0..points.len())
                .map(|i| StepMeta {
                    up: i == 0 || points[i].thrust_g >= points[i - 1].thrust_g,
                    throttle: None,
                    line: i as u64,
                })
                .collect(),
        }
    }

    /// The steps with even (`odd = false`) or odd indices, as a run of their own.
    pub fn interleaved(&self, odd: bool) -> Self {
        let keep = |i: &usize| (i % 2 == 1) == odd;
        let idx: Vec<usize> = (0..self.meta.len()).filter(keep).collect();
        Self {
            sweep: Sweep {
                name: format!(
                    "{} ({} steps)",
                    self.sweep.name,
                    if odd { "odd" } else { "even" }
                ),
                steps: idx.iter().map(|&i| self.sweep.steps[i]).collect(),
                open_circuit_v: self.sweep.open_circuit_v,
                tare_time_s: self.sweep.tare_time_s,
            },
            meta: idx.iter().map(|&i| self.meta[i]).collect(),
        }
    }
}

/// Share of a run's largest thrust below which a step counts as idle (motor stopped or barely
/// turning) and is left out: the model describes a spinning propeller.
pub const IDLE_SHARE: f64 = 0.05;

/// Splits a stand log into runs (a new run starts where the command falls back by more than
/// half its range, e.g. a second sweep in the same file) and turns each run's settled steps into
/// a [`StandSweep`]. Idle steps are dropped; a speed column of zeros counts as not logged; a
/// torque column of the other sign (rotation direction) is flipped.
pub fn runs_of_log(log: &StandLog) -> Result<Vec<StandSweep>, RigGapError> {
    let steps = &log.steps;
    if steps.is_empty() {
        return Err(RigGapError::Unusable {
            source_name: log.source_name.clone(),
            message: "no steps".into(),
        });
    }
    let thr: Option<Vec<f64>> = steps.iter().map(|s| s.throttle).collect();
    let mut bounds = vec![0];
    if let Some(t) = &thr {
        let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let range = hi - lo;
        for i in 1..t.len() {
            if range > 0.0 && t[i] < t[i - 1] - 0.5 * range {
                bounds.push(i);
            }
        }
    }
    bounds.push(steps.len());
    let torque_sign = {
        let mut q: Vec<f64> = steps.iter().filter_map(|s| s.torque_nm).collect();
        q.sort_by(f64::total_cmp);
        if q.is_empty() || q[q.len() / 2] >= 0.0 {
            1.0
        } else {
            -1.0
        }
    };
    let times = step_times(log);
    let t_log0 = times.as_ref().and_then(|t| t.get(&steps[0].line)).copied();
    let n_runs = bounds.len() - 1;
    let base_name = std::path::Path::new(&log.source_name)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| log.source_name.clone());
    let mut out = Vec::new();
    for k in 0..n_runs {
        let run = &steps[bounds[k]..bounds[k + 1]];
        let t_max = run.iter().map(|s| s.thrust_g).fold(0.0f64, f64::max);
        let run_max_current = run
            .iter()
            .filter_map(|s| s.current_a)
            .fold(0.0f64, f64::max);
        // Idle: little thrust, or the run's lowest command with the rotor not turning (a load
        // cell's drifted zero can read well above 5 % there).
        let lowest_cmd = run
            .iter()
            .filter_map(|s| s.throttle)
            .fold(f64::INFINITY, f64::min);
        let idle = |s: &import::stand::Step| {
            s.thrust_g <= IDLE_SHARE * t_max
                || (s.throttle.is_some_and(|t| t <= lowest_cmd)
                    && s.speed_rpm.is_none_or(|r| r <= 0.0)
                    && s.current_a.is_none_or(|i| i.abs() < 0.02 * run_max_current))
        };
        let kept: Vec<(usize, &import::stand::Step)> =
            run.iter().enumerate().filter(|(_, s)| !idle(s)).collect();
        if kept.len() < 3 {
            continue;
        }
        // The supply's open-circuit voltage: measured at the idle steps before the first
        // spinning step (a battery's state of charge differs from run to run).
        let first = kept[0].0;
        let idle_v: Vec<f64> = run[..first].iter().filter_map(|s| s.voltage_v).collect();
        let open_circuit_v =
            (!idle_v.is_empty()).then(|| idle_v.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        // The load cell's tare: its reading at the lowest command before the run spins up
        // (when that command is the run's lowest, i.e. the motor is stopped).
        let lowest = run
            .iter()
            .filter_map(|s| s.throttle)
            .fold(f64::INFINITY, f64::min);
        let tare_step = run[..first]
            .iter()
            .enumerate()
            .find(|(_, s)| s.throttle.is_some_and(|t| t <= lowest));
        let tare_g = tare_step
            .map(|(_, s)| s.thrust_g)
            // A reading within 1 % of the run's largest thrust is the cell's noise, not a tare
            // shift worth taking off every step.
            .filter(|t| t.abs() > 0.01 * t_max)
            .unwrap_or(0.0);
        let n = kept.len();
        // The clock: the log's time column at each step's first line (from the log's first
        // row) when it has one, else the step's index in the log (the thermal, discharge and
        // drift extensions then count in steps).
        let clock = |i_in_run: usize| -> f64 {
            let s = &run[i_in_run];
            match (times.as_ref().and_then(|t| t.get(&s.line)), t_log0) {
                (Some(t), Some(t0)) => t - t0,
                _ => (bounds[k] + i_in_run) as f64,
            }
        };
        // The load cell was zeroed at the tare step, else (no tare taken) at the run's start.
        let tare_time_s = clock(tare_step.map(|(i, _)| i).unwrap_or(0));
        let mut obs = Vec::with_capacity(n);
        let mut meta = Vec::with_capacity(n);
        for (j, (i, s)) in kept.iter().enumerate() {
            let power = s
                .power_w
                .or_else(|| s.voltage_v.zip(s.current_a).map(|(v, i)| v * i));
            obs.push(Observation {
                thrust_g: s.thrust_g - tare_g,
                time_frac: if n > 1 {
                    j as f64 / (n - 1) as f64
                } else {
                    0.0
                },
                time_s: clock(*i),
                power_w: power,
                current_a: s.current_a,
                voltage_v: s.voltage_v.filter(|v| *v > 0.0),
                speed_rpm: s.speed_rpm.filter(|r| *r > 0.0),
                torque_nm: s.torque_nm.map(|q| q * torque_sign).filter(|q| *q > 0.0),
            });
            let up = match (i.checked_sub(1).map(|p| run[p].throttle), s.throttle) {
                (Some(Some(prev)), Some(now)) => now >= prev,
                _ => true,
            };
            meta.push(StepMeta {
                up,
                throttle: s.throttle,
                line: s.line,
            });
        }
        if obs
            .iter()
            .all(|o| o.power_w.is_none() && o.current_a.is_none())
        {
            return Err(RigGapError::Unusable {
                source_name: log.source_name.clone(),
                message: "no power, voltage × current or current column: the model has nothing \
                          to be compared with but thrust"
                    .into(),
            });
        }
        out.push(StandSweep {
            sweep: Sweep {
                name: if n_runs > 1 {
                    format!("{base_name} run {}", k + 1)
                } else {
                    base_name.clone()
                },
                steps: obs,
                open_circuit_v,
                tare_time_s,
            },
            meta,
        });
    }
    if out.is_empty() {
        return Err(RigGapError::Unusable {
            source_name: log.source_name.clone(),
            message: "fewer than 3 steps above idle in every run".into(),
        });
    }
    Ok(out)
}

/// Time of every source line of a log that has a time column, s; `None` when it has none or a
/// time cell does not read as a number.
fn step_times(log: &StandLog) -> Option<std::collections::HashMap<u64, f64>> {
    let column = log.columns.time.as_ref()?;
    let table = import::Table::parse(&log.bytes, &log.source_name).ok()?;
    if !table.has(column) {
        return None;
    }
    let factor = match import::units::split_unit(column).1 {
        None => 1.0,
        Some(u) => import::units::factor(import::units::Quantity::Time, u)?,
    };
    let mut out = std::collections::HashMap::with_capacity(table.len());
    for r in 0..table.len() {
        let t = table.cell_number(r, column).ok()? * factor;
        if !t.is_finite() {
            return None;
        }
        out.insert(table.line(r), t);
    }
    Some(out)
}

/// The default split when no held-out runs are given: with two or more runs every second run
/// (the 2nd, 4th, …) is held out; a single run is split into its even steps (training) and odd
/// steps (held out). Returns (training, held out, the rule in words).
pub fn split_default(runs: Vec<StandSweep>) -> (Vec<StandSweep>, Vec<StandSweep>, String) {
    if runs.len() >= 2 {
        let mut train = Vec::new();
        let mut held = Vec::new();
        for (i, r) in runs.into_iter().enumerate() {
            if i % 2 == 1 {
                held.push(r)
            } else {
                train.push(r)
            }
        }
        (
            train,
            held,
            "every second run held out (no --holdout given)".into(),
        )
    } else {
        let r = &runs[0];
        (
            vec![r.interleaved(false)],
            vec![r.interleaved(true)],
            "one run: even steps train, odd steps held out (no --holdout given)".into(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use import::stand::StandOptions;

    #[test]
    fn runs_carry_the_log_clock_and_their_tare() {
        // Two sweeps: the idle row of the second reads a drifted zero well above 5 % of the top
        // thrust, yet the rotor is stopped at the lowest command, so it is the tare.
        let csv = "time_s,throttle,thrust_g,voltage_v,current_a,power_w,rpm\n\
                   0,0,2,12.0,0,0,0\n\
                   4,0.3,102,11.9,2,23.8,6000\n\
                   8,0.6,302,11.8,6,70.8,9000\n\
                   12,1.0,502,11.7,10,117,11000\n\
                   80,0,40,12.0,0,0,0\n\
                   84,0.3,140,11.9,2,23.8,6000\n\
                   88,0.6,340,11.8,6,70.8,9000\n\
                   92,1.0,540,11.7,10,117,11000\n";
        let log = StandLog::parse(csv.as_bytes().to_vec(), "two.csv", &StandOptions::default())
            .expect("log");
        let runs = runs_of_log(&log).expect("runs");
        assert_eq!(runs.len(), 2);
        let r2 = &runs[1].sweep;
        assert_eq!(r2.steps.len(), 3);
        assert_eq!(r2.tare_time_s, 80.0);
        let t: Vec<f64> = r2.steps.iter().map(|o| o.time_s).collect();
        assert_eq!(t, [84.0, 88.0, 92.0]);
        // The 40 g tare is taken off every step of the second run.
        assert!((r2.steps[0].thrust_g - 100.0).abs() < 1e-9);
        assert_eq!(r2.open_circuit_v, Some(12.0));
        assert_eq!(runs[0].sweep.steps[0].time_s, 4.0);
    }

    #[test]
    fn without_a_time_column_the_clock_is_the_step_order() {
        let csv = "throttle,thrust_g,power_w\n0,0,0\n0.3,100,20\n0.6,300,70\n1.0,500,117\n";
        let log = StandLog::parse(csv.as_bytes().to_vec(), "n.csv", &StandOptions::default())
            .expect("log");
        let runs = runs_of_log(&log).expect("runs");
        let t: Vec<f64> = runs[0].sweep.steps.iter().map(|o| o.time_s).collect();
        assert_eq!(t, [1.0, 2.0, 3.0]);
    }
}
