//! Oracle-battery experiments: how much of the diagnosis's error is the battery it has to learn?
//!
//! An experiment switch of the study, never a default and never a flag of `hoverbench`: with
//! [`BatteryOracle::Off`] (what [`crate::study`] and [`crate::run_scenario`] always use) nothing
//! here touches a scenario. Switched on, the truth's battery is handed to the diagnosis through
//! the same door a user with a measured pack takes, the flights' metadata:
//!
//! - [`BatteryOracle::Ocv`]: the chemistry's open-circuit curve at its nominal pack (no per-pack
//!   scatter), sampled at 401 points of state of charge, written as a `soc,ocv_v` CSV file and
//!   named by every training flight's sidecar (`battery_ocv_csv`), as a user who measured the
//!   pack type's curve would. The diagnosis then keeps the curve and learns only the
//!   resistances.
//! - [`BatteryOracle::OcvAll`]: that, plus every flight's (training and held-out) true capacity
//!   before any withheld fade, written as its rated energy (`battery_energy_wh` = capacity ×
//!   cells × the curve's mean voltage, so the diagnosis's capacity, energy over cells and the
//!   curve's mean, is the truth's): a user who measured each pack's curve and capacity.
//!
//! A measured series resistance or RC pair has no door: the diagnosis learns both even with a
//! measured curve (and its baseline holds the series resistance at the nominal 5 mΩ per cell at
//! most; a measured curve does not say the chemistry, so any extra resistance is named, without
//! the healthy band of `gap::model::healthy_cell_resistance_ohm`), so an `ocv+r` variant cannot
//! be run without changing the diagnosis.
//!
//! The reverse question, how far the learned curve is from the truth's, is
//! [`curve_errors`]: per battery type, the learned curve against the mean of the type's training
//! packs (the truth draws each flight's pack afresh) and against the nominal curve, over the
//! state of charge the training flights covered, by region (top, flat middle, knee), beside the
//! packs' own spread and the learned and true resistances.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use flight_sim::ocv::{OcvCurve, OcvScatter};
use flight_sim::{Chemistry, Family, GeneratedSet, PackTruth, pack_truths};
use serde::Serialize;

use crate::EvalError;

/// The environment variable the study's examples read the switch from (`off`, `ocv`,
/// `ocv+all`); the library itself never reads it.
pub const ENV_VAR: &str = "GAP_EVAL_BATTERY_ORACLE";

/// What of the truth's battery the diagnosis is given.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BatteryOracle {
    /// Nothing: the diagnosis learns the battery (the study's only mode outside experiments).
    #[default]
    Off,
    /// The pack type's nominal open-circuit curve as a measured curve of the training flights.
    Ocv,
    /// [`Self::Ocv`] and every flight's true capacity as its rated energy.
    OcvAll,
}

impl BatteryOracle {
    /// Every choice, `Off` first.
    pub const ALL: [BatteryOracle; 3] = [
        BatteryOracle::Off,
        BatteryOracle::Ocv,
        BatteryOracle::OcvAll,
    ];

    /// Name: `off`, `ocv`, `ocv+all`.
    pub fn name(self) -> &'static str {
        match self {
            BatteryOracle::Off => "off",
            BatteryOracle::Ocv => "ocv",
            BatteryOracle::OcvAll => "ocv+all",
        }
    }

    /// The choice of a name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == s.trim())
    }

    /// The choice [`ENV_VAR`] names (unset or empty: `Off`); an unknown name is an error.
    pub fn from_env() -> Result<Self, String> {
        match std::env::var(ENV_VAR) {
            Ok(v) if !v.trim().is_empty() => Self::parse(&v).ok_or_else(|| {
                format!("{ENV_VAR}={v:?}: use one of off, ocv, ocv+all (ocv+r has no door in the diagnosis)")
            }),
            _ => Ok(Self::Off),
        }
    }
}

/// The nominal open-circuit curve of a chemistry's cell as `soc,ocv_v` CSV text, 401 points.
pub fn nominal_ocv_csv(chem: Chemistry) -> String {
    let c = OcvCurve::new(chem, OcvScatter::NONE);
    let mut s = String::from("soc,ocv_v\n");
    for k in 0..=400 {
        let soc = f64::from(k) / 400.0;
        let _ = writeln!(s, "{soc:.4},{:.6}", c.at(soc));
    }
    s
}

/// A measured-curve file written for one scenario, removed when dropped.
#[derive(Debug)]
pub struct OracleFile {
    path: Option<PathBuf>,
}

impl Drop for OracleFile {
    fn drop(&mut self) {
        if let Some(p) = &self.path {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Replaces (or appends) `key = value` in a sidecar's text.
fn set_key(toml: &str, key: &str, value: &str) -> String {
    let mut out = String::with_capacity(toml.len() + 64);
    let mut done = false;
    for line in toml.lines() {
        let is_key = line.split_once('=').is_some_and(|(k, _)| k.trim() == key);
        if is_key && !done {
            let _ = writeln!(out, "{key} = {value}");
            done = true;
        } else if !is_key {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !done {
        let _ = writeln!(out, "{key} = {value}");
    }
    out
}

/// Hands the truth's battery to the diagnosis through the flights' sidecars, as `oracle` says;
/// the curve's CSV goes to `dir`. `Off` leaves the set untouched and writes nothing.
pub fn apply(
    oracle: BatteryOracle,
    family: &Family,
    seed: u64,
    set: &mut GeneratedSet,
    dir: &Path,
) -> Result<OracleFile, EvalError> {
    if oracle == BatteryOracle::Off {
        return Ok(OracleFile { path: None });
    }
    let chem = family.chemistry;
    let path = dir.join(format!(
        "gap-eval-oracle-{}-{seed}-{}.csv",
        std::process::id(),
        chem.name()
    ));
    std::fs::write(&path, nominal_ocv_csv(chem)).map_err(|e| EvalError::ReadBack {
        name: path.display().to_string(),
        message: format!("writing the oracle curve: {e}"),
    })?;
    let file = OracleFile {
        path: Some(path.clone()),
    };
    // A TOML basic string: the path with backslashes and quotes escaped.
    let quoted = format!(
        "\"{}\"",
        path.display()
            .to_string()
            .replace('\\', "\\\\")
            .replace('"', "\\\"")
    );
    for f in &mut set.train {
        f.toml = set_key(&f.toml, "battery_ocv_csv", &quoted);
    }
    if oracle == BatteryOracle::OcvAll {
        let mean_v = OcvCurve::new(chem, OcvScatter::NONE).mean_v();
        let (tp, hp) = pack_truths(family, seed);
        let energy = |p: &PackTruth| p.capacity_ah * f64::from(p.cells) * mean_v;
        for (f, p) in set.train.iter_mut().zip(&tp) {
            f.toml = set_key(&f.toml, "battery_energy_wh", &format!("{:.6}", energy(p)));
        }
        for (f, p) in set.heldout.iter_mut().zip(&hp) {
            f.toml = set_key(&f.toml, "battery_energy_wh", &format!("{:.6}", energy(p)));
        }
    }
    Ok(file)
}

/// How far one battery type's learned curve is from the truth's, V per cell, over the state of
/// charge the training flights covered (on the diagnosis's axis: charge counted over the rated
/// capacity; the truth counts over each pack's own).
///
/// The truth draws every flight's pack afresh (its curve's scatter, capacity and impedance from
/// the flight's seed), also for flights of the same `battery_id`, so a battery type has no one
/// curve: the target of a learner of one curve per type is the mean of the type's training
/// packs' curves, and their spread about it is a floor no such curve can go below.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveError {
    /// Scenario seed.
    pub seed: u64,
    /// World family.
    pub family: String,
    /// Battery type (as the diagnosis names it).
    pub battery_type: String,
    /// Training flights (packs) of the type.
    pub packs: usize,
    /// State of charge the training flights covered (as the diagnosis counts it).
    pub soc_covered: (f64, f64),
    /// RMS of learned − the type's packs' mean curve.
    pub rms_v: f64,
    /// Mean of learned − the packs' mean curve (a level offset).
    pub mean_v: f64,
    /// RMS of learned − the packs' mean over the covered part of the top (state of charge above
    /// 0.75), the flat middle (0.25–0.75) and the knee (below 0.25); `None` where the flights
    /// did not go.
    pub rms_top_v: Option<f64>,
    /// See [`Self::rms_top_v`].
    pub rms_flat_v: Option<f64>,
    /// See [`Self::rms_top_v`].
    pub rms_knee_v: Option<f64>,
    /// RMS of learned − the chemistry's nominal curve (what [`BatteryOracle::Ocv`] hands over).
    pub rms_vs_nominal_v: f64,
    /// RMS of the packs' curves about their mean (the floor of one curve per type).
    pub pack_spread_rms_v: f64,
    /// RMS of the packs' mean curve − the nominal curve.
    pub packs_mean_vs_nominal_rms_v: f64,
    /// RMS of the diagnosis's own fit residual, V per cell.
    pub fit_rmse_cell_v: f64,
    /// Learned series resistance, RC-pair resistance and the baseline's series resistance, Ω
    /// per cell.
    pub learned_r_cell_ohm: (f64, f64, f64),
    /// The type's packs' mean series resistance at 25 °C and the sum of their two RC pairs'
    /// resistances, Ω per cell.
    pub truth_r_cell_ohm: (f64, f64),
}

/// The learned curves of a scenario's battery types against the truth (see [`CurveError`]).
pub fn curve_errors(seed: u64, families: &[Family]) -> Result<Vec<CurveError>, EvalError> {
    let family = crate::family_of(seed, families);
    let effect = flight_sim::draw_effect(seed);
    let set = flight_sim::generate(&family, &effect, seed);
    let train = crate::read_back(&set.train)?;
    let curve = crate::rig_curve(&set.rig)?;
    let learned = crate::adapter::learned_batteries(&train, &curve, set.rig.rotor_count)?;
    let nominal = OcvCurve::new(family.chemistry, OcvScatter::NONE);
    let (tp, _) = pack_truths(&family, seed);
    let rms_of = |v: &[f64]| -> Option<f64> {
        (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
    };
    Ok(learned
        .into_iter()
        .map(|l| {
            let (lo, hi) = l.soc_covered;
            let n = 200;
            let grid: Vec<f64> = (0..=n)
                .map(|k| lo + (hi - lo) * f64::from(k) / f64::from(n))
                .collect();
            // The type's packs: flights whose sidecar names this type.
            let id_line = format!("battery_id = \"{}\"", l.battery_type);
            let mine: Vec<&PackTruth> = set
                .train
                .iter()
                .zip(&tp)
                .filter(|(f, _)| f.toml.lines().any(|x| x.trim() == id_line))
                .map(|(_, p)| p)
                .collect();
            let mean_at = |s: f64| -> f64 {
                if mine.is_empty() {
                    nominal.at(s)
                } else {
                    mine.iter().map(|p| p.ocv.at(s)).sum::<f64>() / mine.len() as f64
                }
            };
            let d: Vec<(f64, f64)> = grid
                .iter()
                .map(|s| (*s, l.ocv_cell_v(*s) - mean_at(*s)))
                .collect();
            let region = |f: &dyn Fn(f64) -> bool| -> Option<f64> {
                let v: Vec<f64> = d.iter().filter(|p| f(p.0)).map(|p| p.1).collect();
                rms_of(&v)
            };
            let vs_nominal: Vec<f64> = grid
                .iter()
                .map(|s| l.ocv_cell_v(*s) - nominal.at(*s))
                .collect();
            let spread: Vec<f64> = mine
                .iter()
                .flat_map(|p| grid.iter().map(|s| p.ocv.at(*s) - mean_at(*s)))
                .collect();
            let mean_vs_nominal: Vec<f64> =
                grid.iter().map(|s| mean_at(*s) - nominal.at(*s)).collect();
            CurveError {
                seed,
                family: family.name(),
                battery_type: l.battery_type,
                packs: mine.len(),
                soc_covered: l.soc_covered,
                rms_v: region(&|_| true).unwrap_or(f64::NAN),
                mean_v: d.iter().map(|p| p.1).sum::<f64>() / d.len() as f64,
                rms_top_v: region(&|s| s > 0.75),
                rms_flat_v: region(&|s| (0.25..=0.75).contains(&s)),
                rms_knee_v: region(&|s| s < 0.25),
                rms_vs_nominal_v: rms_of(&vs_nominal).unwrap_or(f64::NAN),
                pack_spread_rms_v: rms_of(&spread).unwrap_or(f64::NAN),
                packs_mean_vs_nominal_rms_v: rms_of(&mean_vs_nominal).unwrap_or(f64::NAN),
                fit_rmse_cell_v: l.rmse_cell_v,
                learned_r_cell_ohm: (
                    l.series_resistance_cell_ohm,
                    l.rc_resistance_cell_ohm,
                    l.baseline_series_resistance_cell_ohm,
                ),
                truth_r_cell_ohm: {
                    let n = mine.len().max(1) as f64;
                    let per_cell = |p: &PackTruth| 1.0 / f64::from(p.cells);
                    (
                        mine.iter()
                            .map(|p| p.series_resistance_ohm * per_cell(p))
                            .sum::<f64>()
                            / n,
                        mine.iter()
                            .map(|p| (p.rc[0].0 + p.rc[1].0) * per_cell(p))
                            .sum::<f64>()
                            / n,
                    )
                },
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for o in BatteryOracle::ALL {
            assert_eq!(BatteryOracle::parse(o.name()), Some(o));
        }
        assert_eq!(BatteryOracle::parse("ocv+r"), None);
        assert_eq!(BatteryOracle::default(), BatteryOracle::Off);
    }

    #[test]
    fn set_key_replaces_or_appends() {
        let t = "cells = 3\nbattery_energy_wh = 23.6\nbattery_id = \"A\"\n";
        assert_eq!(
            set_key(t, "battery_energy_wh", "20.0"),
            "cells = 3\nbattery_energy_wh = 20.0\nbattery_id = \"A\"\n"
        );
        assert_eq!(
            set_key(t, "battery_ocv_csv", "\"/x.csv\""),
            format!("{t}battery_ocv_csv = \"/x.csv\"\n")
        );
    }

    #[test]
    fn nominal_curve_reads_back_as_a_measured_curve() {
        for chem in Chemistry::ALL {
            let text = nominal_ocv_csv(chem);
            let b = gap::battery::LearnedBattery::from_ocv_csv(&text).unwrap();
            let c = OcvCurve::new(chem, OcvScatter::NONE);
            // The diagnosis's 21 knots reproduce the curve where it is smooth.
            for k in 2..=19 {
                let s = f64::from(k) / 20.0;
                assert!(
                    (b.ocv_cell_v(s) - c.at(s)).abs() < 0.01,
                    "{chem:?} at {s}: {} vs {}",
                    b.ocv_cell_v(s),
                    c.at(s)
                );
            }
        }
    }
}
