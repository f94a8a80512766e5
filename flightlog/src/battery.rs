//! One path from a binary log's battery messages to a flight's voltage and current, shared by
//! the ULog and DataFlash readers.
//!
//! A format reader turns each battery it finds (ULog `battery_status` instance, DataFlash `BAT`
//! instance, `BAT2`, ArduCopter 3.x `CURR`, per-cell `BCL`) into a track; one function then applies the
//! same checks to every track, in order, and keeps the first that passes:
//!
//! 1. samples the battery reports as not connected (ULog `connected = 0`) are dropped; a
//!    track with no connected sample is skipped ([`SkipReason::NotConnected`]);
//! 2. samples with a voltage at or below 0 V or not finite ("not measured") are dropped; a
//!    track with fewer than 2 left is skipped ([`SkipReason::NoVoltage`]);
//! 3. the median voltage must be plausible: between [`MIN_CELL_V`] and [`MAX_CELL_V`] per cell
//!    when the cell count is known, at least [`MIN_CELL_V`] otherwise
//!    ([`SkipReason::ImplausibleVoltage`]);
//! 4. current: a sample below [`MIN_CURRENT_A`] or not finite is "unknown" (PX4 logs −1); a
//!    track whose current is all unknown has no current; unknown samples between known ones
//!    are interpolated (and counted in a warning).
//!
//! When no track passes, the flight is refused with [`FlightLogError::NoUsableBattery`],
//! naming every track and why it was skipped.

use std::path::Path;

use serde::Serialize;

use crate::FlightLogError;

/// Lowest plausible voltage of one cell under load, V (Li-ion at its deepest discharge).
pub const MIN_CELL_V: f64 = 2.5;
/// Highest plausible voltage of one cell, V (LiHV charged to 4.35 V, with margin).
pub const MAX_CELL_V: f64 = 4.5;
/// Highest per-cell voltage used to estimate a cell count from the highest voltage, V (LiHV).
pub const ESTIMATE_CELL_V: f64 = 4.35;
/// A current below this is "unknown", A (PX4 logs −1; small negative offsets are kept).
pub const MIN_CURRENT_A: f64 = -0.5;

/// Why a battery of a log was not used.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SkipReason {
    /// The log says the battery is not connected in every sample.
    NotConnected {
        /// Samples in the log.
        samples: usize,
    },
    /// Fewer than 2 samples with a voltage above 0 V.
    NoVoltage {
        /// Samples in the log.
        samples: usize,
    },
    /// The median voltage is not that of a battery of its cell count.
    ImplausibleVoltage {
        /// Median voltage, V.
        median_v: f64,
        /// Cell count used, when known.
        cells: Option<u32>,
        /// Plausible range, V.
        range_v: [f64; 2],
    },
}

impl std::fmt::Display for SkipReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotConnected { samples } => {
                write!(f, "not connected (connected = 0 in all {samples} samples)")
            }
            Self::NoVoltage { samples } => write!(
                f,
                "no voltage (fewer than 2 of {samples} samples above 0 V)"
            ),
            Self::ImplausibleVoltage {
                median_v,
                cells: Some(cells),
                range_v,
            } => write!(
                f,
                "median voltage {median_v:.3} V is implausible for {cells} cells \
                 ({:.1}–{:.1} V)",
                range_v[0], range_v[1]
            ),
            Self::ImplausibleVoltage {
                median_v, range_v, ..
            } => write!(
                f,
                "median voltage {median_v:.3} V is below any battery (at least {:.1} V)",
                range_v[0]
            ),
        }
    }
}

/// A battery that was not used, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedBattery {
    /// Which battery (`battery_status instance 1`, `BAT instance 0`, `CURR`).
    pub battery: String,
    /// Why.
    pub reason: SkipReason,
}

impl std::fmt::Display for SkippedBattery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.battery, self.reason)
    }
}

/// Where a number came from inside a log (a parameter, a message field, an estimate).
pub type LogOrigin = String;

/// The battery kept, as read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BatteryInfo {
    /// Which battery (`battery_status instance 0`, `BAT instance 0`, `CURR`).
    pub battery: String,
    /// Cell count, when the log gives it, and where from.
    pub cells: Option<(u32, LogOrigin)>,
    /// Lowest and highest state of charge the log reports (0–1), when it does.
    pub remaining: Option<[f64; 2]>,
    /// Highest warning level the log reports (PX4 `battery_status.warning`: 0 none, 1 low,
    /// 2 critical, 3 emergency, 4 failed), when it does.
    pub max_warning: Option<u8>,
    /// Other batteries in the log, not used, with why (a usable one is listed as
    /// "usable, not used").
    pub others: Vec<String>,
}

/// One battery of a log, as decoded by a format reader (all columns of one length).
#[derive(Debug, Clone, Default)]
pub(crate) struct Track {
    /// Which battery, for messages.
    pub(crate) name: String,
    /// Byte offset of each message.
    pub(crate) offsets: Vec<u64>,
    /// Time of each message, s, on the log's clock.
    pub(crate) time_s: Vec<f64>,
    /// Voltage, V.
    pub(crate) voltage_v: Vec<f64>,
    /// Current, A (`None`: the message has no current field).
    pub(crate) current_a: Vec<Option<f64>>,
    /// Connected flag, when the format has one.
    pub(crate) connected: Option<Vec<bool>>,
    /// State of charge, 0–1 (negative: unknown), when the format has one.
    pub(crate) remaining: Option<Vec<f64>>,
    /// Warning level, when the format has one.
    pub(crate) warning: Option<Vec<u8>>,
    /// Cell count and where it came from.
    pub(crate) cells: Option<(u32, LogOrigin)>,
}

/// The battery samples kept.
#[derive(Debug, Clone)]
pub(crate) struct Chosen {
    /// Time from the first kept sample, s.
    pub(crate) time_s: Vec<f64>,
    /// Log clock time of the first kept sample, s.
    pub(crate) t0_s: f64,
    pub(crate) offsets: Vec<u64>,
    pub(crate) voltage_v: Vec<f64>,
    pub(crate) current_a: Option<Vec<f64>>,
    pub(crate) info: BatteryInfo,
    pub(crate) warnings: Vec<String>,
}

/// Checks a track (see the module docs): the samples kept, or why it is skipped.
fn check(track: &Track) -> Result<Chosen, SkipReason> {
    let n = track.time_s.len();
    let connected = |i: usize| track.connected.as_ref().is_none_or(|c| c[i]);
    if track.connected.is_some() && !(0..n).any(connected) {
        return Err(SkipReason::NotConnected { samples: n });
    }
    let keep: Vec<usize> = (0..n)
        .filter(|&i| connected(i) && track.voltage_v[i].is_finite() && track.voltage_v[i] > 0.0)
        .collect();
    if keep.len() < 2 {
        return Err(SkipReason::NoVoltage { samples: n });
    }
    let mut sorted: Vec<f64> = keep.iter().map(|&i| track.voltage_v[i]).collect();
    sorted.sort_by(f64::total_cmp);
    let median_v = sorted[sorted.len() / 2];
    let cells = track.cells.as_ref().map(|c| c.0);
    let range_v = match cells {
        Some(c) => [MIN_CELL_V * f64::from(c), MAX_CELL_V * f64::from(c)],
        None => [MIN_CELL_V, f64::INFINITY],
    };
    if !(range_v[0]..=range_v[1]).contains(&median_v) {
        return Err(SkipReason::ImplausibleVoltage {
            median_v,
            cells,
            range_v,
        });
    }
    let mut warnings = Vec::new();
    let dropped_disconnected = (0..n).filter(|&i| !connected(i)).count();
    if dropped_disconnected > 0 {
        warnings.push(format!(
            "{dropped_disconnected} {} sample(s) marked not connected dropped",
            track.name
        ));
    }
    let dropped_voltage = n - keep.len() - dropped_disconnected;
    if dropped_voltage > 0 {
        warnings.push(format!(
            "{dropped_voltage} {} sample(s) without a voltage (≤ 0 or not finite) dropped",
            track.name
        ));
    }
    let t0_s = track.time_s[keep[0]];
    let time_s: Vec<f64> = keep.iter().map(|&i| track.time_s[i] - t0_s).collect();
    let known = |c: Option<f64>| c.filter(|c| c.is_finite() && *c >= MIN_CURRENT_A);
    let current: Vec<Option<f64>> = keep.iter().map(|&i| known(track.current_a[i])).collect();
    let (t_known, c_known): (Vec<f64>, Vec<f64>) = time_s
        .iter()
        .zip(&current)
        .filter_map(|(&t, c)| c.map(|c| (t, c)))
        .unzip();
    let current_a = if c_known.is_empty() {
        None
    } else {
        let unknown = current.len() - c_known.len();
        if unknown > 0 {
            warnings.push(format!(
                "{unknown} {} current sample(s) unknown (below {MIN_CURRENT_A} A or not \
                 finite): interpolated from their neighbours",
                track.name
            ));
            crate::resample::linear(&t_known, &c_known, &time_s)
        } else {
            Some(c_known)
        }
    };
    let remaining = track.remaining.as_ref().and_then(|r| {
        let v: Vec<f64> = keep
            .iter()
            .map(|&i| r[i])
            .filter(|x| x.is_finite() && (0.0..=1.0).contains(x))
            .collect();
        let lo = v.iter().copied().reduce(f64::min)?;
        let hi = v.iter().copied().reduce(f64::max)?;
        Some([lo, hi])
    });
    let max_warning = track
        .warning
        .as_ref()
        .and_then(|w| keep.iter().map(|&i| w[i]).max());
    Ok(Chosen {
        time_s,
        t0_s,
        offsets: keep.iter().map(|&i| track.offsets[i]).collect(),
        voltage_v: keep.iter().map(|&i| track.voltage_v[i]).collect(),
        current_a,
        info: BatteryInfo {
            battery: track.name.clone(),
            cells: track.cells.clone(),
            remaining,
            max_warning,
            others: Vec::new(),
        },
        warnings,
    })
}

/// Keeps the first track that passes the checks; `looked_for` names what the reader searched
/// (for the error when there is no track at all).
pub(crate) fn choose(
    path: &Path,
    tracks: &[Track],
    looked_for: &str,
    available: &str,
) -> Result<Chosen, FlightLogError> {
    if tracks.is_empty() {
        return Err(FlightLogError::MissingData {
            path: path.to_owned(),
            field: looked_for.to_owned(),
            message: format!("the log has none (it has: {available})"),
        });
    }
    let mut skipped = Vec::new();
    let mut chosen: Option<Chosen> = None;
    for track in tracks {
        match check(track) {
            Ok(c) if chosen.is_none() => chosen = Some(c),
            Ok(_) => {
                if let Some(c) = chosen.as_mut() {
                    c.info
                        .others
                        .push(format!("{}: usable, not used", track.name));
                }
            }
            Err(reason) => skipped.push(SkippedBattery {
                battery: track.name.clone(),
                reason,
            }),
        }
    }
    match chosen {
        Some(mut c) => {
            if !skipped.is_empty() {
                c.warnings.push(format!(
                    "used {}; skipped {}",
                    c.info.battery,
                    skipped
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join("; ")
                ));
            }
            let mut others: Vec<String> = skipped.iter().map(ToString::to_string).collect();
            others.append(&mut c.info.others);
            c.info.others = others;
            Ok(c)
        }
        None => Err(FlightLogError::NoUsableBattery {
            path: path.to_owned(),
            batteries: skipped,
        }),
    }
}

/// A cell count estimated from the highest voltage: `⌈max / 4.35 V⌉`.
pub(crate) fn estimate_cells(voltage_v: &[f64]) -> Option<(u32, LogOrigin)> {
    let max = voltage_v
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .reduce(f64::max)?;
    let cells = (max / ESTIMATE_CELL_V).ceil();
    (1.0..=30.0).contains(&cells).then(|| {
        (
            cells as u32,
            format!(
                "estimated from the highest voltage {max:.2} V ÷ {ESTIMATE_CELL_V} V per cell, \
                 rounded up"
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(v: &[f64], c: &[f64], connected: Option<Vec<bool>>, cells: Option<u32>) -> Track {
        Track {
            name: "t".to_owned(),
            offsets: (0..v.len() as u64).collect(),
            time_s: (0..v.len()).map(|i| i as f64 * 0.1 + 5.0).collect(),
            voltage_v: v.to_vec(),
            current_a: c.iter().map(|&x| Some(x)).collect(),
            connected,
            remaining: None,
            warning: None,
            cells: cells.map(|c| (c, "x".to_owned())),
        }
    }

    #[test]
    fn skips_with_reasons() {
        let p = Path::new("l.ulg");
        let off = track(&[0.1, 0.1, 0.1], &[0.0; 3], Some(vec![false; 3]), Some(4));
        let low = track(&[0.1, 0.13, 0.12], &[0.0; 3], None, None);
        let wrong = track(&[12.0, 12.1, 12.2], &[1.0; 3], None, Some(6));
        let e = choose(p, &[off, low, wrong], "battery_status", "").unwrap_err();
        let text = e.to_string();
        assert!(text.contains("not connected"), "{text}");
        assert!(text.contains("below any battery"), "{text}");
        assert!(text.contains("implausible for 6 cells"), "{text}");
    }

    #[test]
    fn unknown_current_is_interpolated_or_absent() {
        let p = Path::new("l.ulg");
        let t = track(&[12.0; 4], &[1.0, -1.0, 3.0, 3.0], None, Some(3));
        let c = choose(p, &[t], "x", "").unwrap();
        let i = c.current_a.unwrap();
        for (got, want) in i.iter().zip([1.0, 2.0, 3.0, 3.0]) {
            assert!((got - want).abs() < 1e-9, "{i:?}");
        }
        assert!((c.time_s[1] - 0.1).abs() < 1e-12 && c.t0_s == 5.0);
        let t = track(&[12.0; 4], &[-1.0; 4], None, Some(3));
        assert!(choose(p, &[t], "x", "").unwrap().current_a.is_none());
        let e = choose(p, &[], "BAT or CURR", "GPS").unwrap_err();
        assert!(e.to_string().contains("BAT or CURR"), "{e}");
    }

    #[test]
    fn cell_estimate() {
        assert_eq!(estimate_cells(&[16.45, 15.0]).unwrap().0, 4);
        assert_eq!(estimate_cells(&[12.4]).unwrap().0, 3);
        assert_eq!(estimate_cells(&[4.2]).unwrap().0, 1);
        assert!(estimate_cells(&[]).is_none());
    }
}
