//! Which flights end at the cut-off, and where a flight starts and ends.
//!
//! Only a flight that ran until the battery's cut-off has a true remaining endurance at every
//! instant (the time to its end); a flight landed early says nothing about when the pack would
//! have been empty. A flight is taken as ending at the cut-off when:
//!
//! 1. its metadata says `end = "cutoff"` ([`CutoffEvidence::Metadata`]), or
//! 2. its metadata says nothing about the end, a `cutoff_voltage_v` is known, and the logged
//!    voltage over the last [`END_WINDOW_S`] of flying (median of the samples there) lies within
//!    [`CUTOFF_TOLERANCE_CELL_V`] per cell (or 2 % of the cut-off without a cell count) of that cut-off
//!    ([`CutoffEvidence::Voltage`]): the autopilot landed on its low-voltage threshold.
//!
//! Every other flight is skipped with its reason: metadata `end = "landed"`; no cut-off voltage
//! known; the last voltage too far above the cut-off (with both numbers); no flying samples.
//!
//! The flight spans from its take-off (the first sample in a flying phase: hover, climb,
//! descend, transition) to its end (the last sample in a flying phase); without phases, from
//! the first to the last sample.

use flightlog::{End, Flight, Phase};
use serde::Serialize;

/// Window at the end of the flight whose voltage is compared with the cut-off, s.
pub const END_WINDOW_S: f64 = 5.0;
/// How far above the cut-off (per cell) the final loaded voltage may lie, V: sensor offset and
/// scale errors and the autopilot's voltage filter.
pub const CUTOFF_TOLERANCE_CELL_V: f64 = 0.05;

/// Why a flight is taken as ending at the cut-off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CutoffEvidence {
    /// Its metadata says `end = "cutoff"`.
    Metadata,
    /// Its last flying voltage reached the cut-off voltage.
    Voltage {
        /// Median voltage over the last [`END_WINDOW_S`] of flying, V.
        final_v: f64,
        /// The cut-off voltage, V.
        cutoff_v: f64,
    },
}

/// The flying span of a flight that ended at the cut-off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlightSpan {
    /// Time of take-off, s (log time).
    pub takeoff_s: f64,
    /// Time of the end (landing at the cut-off), s (log time).
    pub end_s: f64,
    /// How the cut-off was recognised.
    pub evidence: CutoffEvidence,
}

impl FlightSpan {
    /// Flight duration, s.
    pub fn duration_s(&self) -> f64 {
        self.end_s - self.takeoff_s
    }
}

/// Shortest flight scored (or traced), s: shorter, the take-off's transient is all there is.
pub const MIN_FLIGHT_S: f64 = 10.0;

/// First and last flying sample times (first and last sample without phases); `None` when no
/// sample flies.
pub fn flying_span(flight: &Flight) -> Option<(f64, f64)> {
    let t = &flight.samples.time_s;
    match &flight.samples.phase {
        Some(ph) => {
            let first = ph.iter().position(|p| p.is_flying())?;
            let last = ph.iter().rposition(|p| p.is_flying())?;
            Some((t[first], t[last]))
        }
        None => Some((*t.first()?, *t.last()?)),
    }
}

/// Whether a flight ended at the cut-off, with its span; the reason when it did not.
pub fn detect(flight: &Flight) -> Result<FlightSpan, String> {
    let Some((takeoff_s, end_s)) = flying_span(flight) else {
        return Err("no sample in a flying phase".to_owned());
    };
    if end_s - takeoff_s < MIN_FLIGHT_S {
        return Err(format!(
            "flies only {:.1} s (under {MIN_FLIGHT_S:.0} s)",
            (end_s - takeoff_s).max(0.0)
        ));
    }
    match flight.meta.end {
        Some(End::Cutoff) => {
            return Ok(FlightSpan {
                takeoff_s,
                end_s,
                evidence: CutoffEvidence::Metadata,
            });
        }
        Some(End::Landed) => {
            return Err("landed before the cut-off (metadata end = \"landed\")".to_owned());
        }
        None => {}
    }
    let Some(cutoff_v) = flight.meta.cutoff_voltage_v else {
        return Err(
            "no end = \"cutoff\" in its metadata and no cutoff_voltage_v to check the end against"
                .to_owned(),
        );
    };
    let s = &flight.samples;
    let flying = |k: usize| s.phase.as_ref().is_none_or(|p| p[k].is_flying());
    let last: Vec<f64> = (0..s.len())
        .filter(|&k| flying(k) && s.time_s[k] >= end_s - END_WINDOW_S && s.time_s[k] <= end_s)
        .map(|k| s.voltage_v[k])
        .collect();
    let final_v = gap::stats::median(&last)
        .ok_or_else(|| "no voltage at the end of the flight".to_owned())?;
    let tolerance = match flight.meta.cells {
        Some(c) => CUTOFF_TOLERANCE_CELL_V * f64::from(c),
        None => 0.02 * cutoff_v,
    };
    if final_v <= cutoff_v + tolerance {
        Ok(FlightSpan {
            takeoff_s,
            end_s,
            evidence: CutoffEvidence::Voltage { final_v, cutoff_v },
        })
    } else {
        Err(format!(
            "ends at {final_v:.2} V, {:.2} V above its {cutoff_v:.2} V cut-off (tolerance {tolerance:.2} V): landed or stopped before the cut-off",
            final_v - cutoff_v
        ))
    }
}

/// The phase of sample `k`, when logged or inferred.
pub fn phase_at(flight: &Flight, k: usize) -> Option<Phase> {
    flight.samples.phase.as_ref().map(|p| p[k])
}
