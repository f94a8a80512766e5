//! A pack's history: the usable capacity one flight measured, carried to the pack's next
//! flight.
//!
//! A faded pack empties sooner than its `[battery]` section says, and in flight the voltage
//! shows it only late: at half the flight a 15 % fade moves the open-circuit voltage by a few
//! hundredths of a volt per cell, as much as one pack's curve differs from another's (README,
//! "How long can it still fly?"). The end of a flight shows it plainly: a pack that reaches the
//! cut-off while the online estimator still expects charge in it holds less than the
//! estimator thought, and one that flies on after the estimator called it empty holds more.
//! With the current logged ([`capacity_reading`]):
//!
//! `C = C_end · Q / (Q + Q_left)`
//!
//! - `C_end`: the estimator's usable capacity at the end (the model's times its capacity
//!   scale, which the flight may already have moved);
//! - `Q`: the charge counted from the first sample to the last flying one;
//! - `Q_left`: the charge the estimator still expected at the cut-off, its remaining time
//!   there times the mean current of the last [`END_WINDOW_S`]; or, when it had called the
//!   pack empty ([`EMPTY_S`]) before the end, minus the charge counted since.
//!
//! A reading is refused, with the reason, when the current is not logged, when less than
//! [`MIN_SOC_SPAN`] of the capacity was counted, when the flight's lowest voltage over its last
//! [`LAST_VOLTAGE_WINDOW_S`] is above the cut-off (the robot landed with charge left: its
//! rotors ran out of thrust, or a pilot), when the pack's measured power at the end is more
//! than [`POWER_AGREEMENT`] off the estimator's (the end moved with the load), when the pack
//! flew on after the estimator had called it empty for more than [`MAX_FLOWN_ON`] of the
//! charge counted (the estimator misread the flight's voltage), or when the capacity is beyond
//! [`PLAUSIBLE_FACTOR`] of the model's. [`PackHistory`] keeps the last
//! reading of each pack (`battery_id`); `replay --pack-history` fuses it, as a factor on the
//! model's capacity with one-sigma [`READING_SIGMA`], into the pack's next flight. The same
//! reading is what a ground station would store after each flight and write into the
//! parameter blob before the next: nothing here runs in flight.
//!
//! Measured on `replay-eval`'s worlds it helps faded packs and harms packs with an extra
//! resistance on the held-out families, so it is off by default (README, "A pack's history").

use std::collections::BTreeMap;

use flightlog::Flight;
use serde::Serialize;

use crate::cutoff::{CUTOFF_TOLERANCE_CELL_V, FlightSpan};

/// The end of a flight whose mean current and power a reading uses, s.
pub const END_WINDOW_S: f64 = 5.0;
/// The lowest voltage over this last stretch of flying must be at the cut-off, s (an
/// autopilot lands on a voltage filtered over about a second).
pub const LAST_VOLTAGE_WINDOW_S: f64 = 2.0;
/// The least charge a reading's flight must have counted, as a fraction of the estimator's
/// capacity.
pub const MIN_SOC_SPAN: f64 = 0.4;
/// One-sigma of a reading, as a fraction of the capacity: the next flight's pack is not quite
/// this one (packs of one type differ by some per cent, and one pack from flight to flight by
/// its temperature) and the current sensor's scale error enters the count. The online
/// estimator fuses the reading with its own capacity (`FilterState::CapacityScale`).
pub const READING_SIGMA: f64 = 0.04;
/// A reading's capacity must lie between the model's divided and multiplied by this.
pub const PLAUSIBLE_FACTOR: f64 = 2.0;

/// The usable capacity one flight measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CapacityReading {
    /// The flight it comes from.
    pub flight: String,
    /// Charge counted from the first sample to the last flying one, Ah.
    pub counted_ah: f64,
    /// Charge the estimator still expected when the pack reached the cut-off, Ah (negative:
    /// the pack gave this much after the estimator had called it empty).
    pub expected_left_ah: f64,
    /// The pack's capacity: the estimator's at the end times
    /// `counted_ah / (counted_ah + expected_left_ah)`, Ah.
    pub capacity_ah: f64,
    /// The pack model's capacity the flight was flown with, Ah.
    pub model_capacity_ah: f64,
}

impl CapacityReading {
    /// The reading over the model's capacity.
    pub fn factor(&self) -> f64 {
        self.capacity_ah / self.model_capacity_ah
    }
}

/// What the online estimator said at the end of a flight, for a [`capacity_reading`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndOfFlight {
    /// Its usable capacity at the end (the model's times its capacity scale), Ah.
    pub usable_capacity_ah: f64,
    /// Its predicted remaining time at the last sample, s.
    pub remaining_s: f64,
    /// The first time its predicted remaining time fell to [`EMPTY_S`] or below and stayed
    /// there, s (log time); `None` when it did not before the end.
    pub empty_from_s: Option<f64>,
    /// The power it flew the last phase at, W.
    pub phase_power_w: f64,
}

/// A reading needs the measured power over the last [`END_WINDOW_S`] within this fraction of
/// the estimator's: beyond it the end came early or late because of the load, not the pack.
pub const POWER_AGREEMENT: f64 = 0.05;

/// A reading is refused when the pack gave more than this fraction of the charge counted after
/// the estimator had called it empty ([`EMPTY_S`]). Chosen on `replay-eval`'s tuning families
/// (seeds 0–71, with history, against history without the rule: median at 50 % 3.50 → 3.35 %,
/// flights worse than without history by more than 0.25 pp 39 → 34; 0.02 and 0.10 gave 3.45
/// and 3.40 %).
pub const MAX_FLOWN_ON: f64 = 0.05;

/// A predicted remaining time at or below this says "empty now", s.
pub const EMPTY_S: f64 = 1.0;

/// Charge counted between `from` and `to` (trapezoids over the logged current), Ah.
fn counted_ah(flight: &Flight, from: f64, to: f64) -> Option<f64> {
    let s = &flight.samples;
    let current = s.current_a.as_ref()?;
    let mut q = 0.0;
    for k in 1..s.len() {
        let (ta, tb) = (s.time_s[k - 1], s.time_s[k]);
        if ta < from {
            continue;
        }
        if tb > to {
            break;
        }
        let (ia, ib) = (current[k - 1], current[k]);
        if ia.is_finite() && ib.is_finite() && tb > ta {
            q += 0.5 * (ia + ib) * (tb - ta);
        }
    }
    Some(q / 3600.0)
}

/// The capacity `flight`, flown over `span` with a model of capacity `model_capacity_ah`,
/// measured, from what the online estimator said at its end (`end`); the reason when it gives
/// none.
pub fn capacity_reading(
    flight: &Flight,
    span: &FlightSpan,
    model_capacity_ah: f64,
    end: &EndOfFlight,
) -> Result<CapacityReading, String> {
    let s = &flight.samples;
    let Some(&t0) = s.time_s.first() else {
        return Err("no samples".to_owned());
    };
    let Some(counted) = counted_ah(flight, t0, span.end_s) else {
        return Err("no current logged".to_owned());
    };
    if !(end.usable_capacity_ah.is_finite() && end.usable_capacity_ah > 0.0) {
        return Err("the online estimator ended without a capacity".to_owned());
    }
    if counted < MIN_SOC_SPAN * end.usable_capacity_ah {
        return Err(format!(
            "counted {counted:.3} Ah, under {:.0} % of the {:.3} Ah the estimator flew: too shallow a discharge to read the capacity",
            100.0 * MIN_SOC_SPAN,
            end.usable_capacity_ah
        ));
    }
    // Only an end at the cut-off voltage says the pack was empty: a robot that landed because
    // its rotors ran out of thrust, or for any other reason, left charge in it.
    let Some(cutoff_v) = flight.meta.cutoff_voltage_v else {
        return Err("no cutoff_voltage_v in the metadata to tell an empty pack".to_owned());
    };
    let last: Vec<f64> = (0..s.len())
        .filter(|&k| {
            let t = s.time_s[k];
            s.phase.as_ref().is_none_or(|ph| ph[k].is_flying())
                && t >= span.end_s - LAST_VOLTAGE_WINDOW_S
                && t <= span.end_s
        })
        .map(|k| s.voltage_v[k])
        .collect();
    let final_v = last.iter().copied().fold(f64::NAN, f64::min);
    let tolerance = flight
        .meta
        .cells
        .map_or(0.02 * cutoff_v, |c| CUTOFF_TOLERANCE_CELL_V * f64::from(c));
    if final_v.is_nan() || final_v > cutoff_v + tolerance {
        return Err(format!(
            "its lowest voltage over the last {LAST_VOLTAGE_WINDOW_S:.0} s is {final_v:.2} V, above its {cutoff_v:.2} V cut-off (tolerance {tolerance:.2} V): it landed with charge left (thrust, or a pilot), so its end says nothing of the capacity"
        ));
    }
    // Over the last END_WINDOW_S: the mean power of the flying samples and the mean current.
    let (mut n, mut p, mut n_i, mut sum_i) = (0.0, 0.0, 0.0, 0.0);
    if let Some(c) = s.current_a.as_ref() {
        for k in 0..s.len() {
            let t = s.time_s[k];
            if t < span.end_s - END_WINDOW_S || t > span.end_s {
                continue;
            }
            if c[k].is_finite() {
                n_i += 1.0;
                sum_i += c[k];
            }
            let w = c[k] * s.voltage_v[k];
            if s.phase.as_ref().is_none_or(|ph| ph[k].is_flying()) && w.is_finite() {
                n += 1.0;
                p += w;
            }
        }
    }
    if n == 0.0 || end.phase_power_w.is_nan() || end.phase_power_w <= 0.0 {
        return Err("no measured or estimated power at the end".to_owned());
    }
    let measured_w = p / n;
    let off = measured_w / end.phase_power_w - 1.0;
    if off.abs() > POWER_AGREEMENT {
        return Err(format!(
            "the pack gave {measured_w:.1} W at the end against the estimator's {:.1} W ({:+.0} %, beyond {:.0} %): the end moved with the load, not the pack",
            end.phase_power_w,
            100.0 * off,
            100.0 * POWER_AGREEMENT
        ));
    }
    // The charge the estimator still expected when the pack reached the cut-off (positive),
    // or the charge the pack gave after the estimator had called it empty (negative).
    let expected_left_ah = match end.empty_from_s {
        Some(t) => -counted_ah(flight, t, span.end_s).unwrap_or(0.0),
        None => {
            let current = if n_i > 0.0 { sum_i / n_i } else { 0.0 };
            current.max(0.0) * end.remaining_s.max(0.0) / 3600.0
        }
    };
    // A pack that flew on long after the estimator had called it empty shows an estimator
    // that misread the flight's voltage (a sag it took for a low charge), not a pack larger
    // than its model: packs leave the factory at about their rating and only lose capacity.
    if -expected_left_ah > MAX_FLOWN_ON * counted {
        return Err(format!(
            "the pack gave {:.3} Ah after the estimator had called it empty, over {:.0} % of the {counted:.3} Ah counted: the estimator misread this flight's voltage, so its end says nothing of the capacity",
            -expected_left_ah,
            100.0 * MAX_FLOWN_ON
        ));
    }
    let factor = counted / (counted + expected_left_ah);
    let capacity_ah = end.usable_capacity_ah * factor;
    if !(capacity_ah.is_finite()
        && capacity_ah >= model_capacity_ah / PLAUSIBLE_FACTOR
        && capacity_ah <= model_capacity_ah * PLAUSIBLE_FACTOR)
    {
        return Err(format!(
            "measured {capacity_ah:.3} Ah against the model's {model_capacity_ah:.3} Ah, beyond a factor {PLAUSIBLE_FACTOR}: a current sensor or a curve is wrong"
        ));
    }
    Ok(CapacityReading {
        flight: flight.name.clone(),
        counted_ah: counted,
        expected_left_ah,
        capacity_ah,
        model_capacity_ah,
    })
}

/// The last capacity reading of each pack (`battery_id`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PackHistory {
    readings: BTreeMap<String, CapacityReading>,
    /// EXPERIMENT
    pub resistance: BTreeMap<String, f64>,
}

impl PackHistory {
    /// No readings.
    pub fn new() -> Self {
        Self::default()
    }

    /// The last reading of `pack`.
    pub fn get(&self, pack: &str) -> Option<&CapacityReading> {
        self.readings.get(pack)
    }

    /// Keeps `reading` as `pack`'s last.
    pub fn record(&mut self, pack: &str, reading: CapacityReading) {
        self.readings.insert(pack.to_owned(), reading);
    }

    /// Every pack's last reading, by pack.
    pub fn readings(&self) -> impl Iterator<Item = (&str, &CapacityReading)> {
        self.readings.iter().map(|(k, v)| (k.as_str(), v))
    }
}

/// Sorts `flights` into the order they were flown: by the pack's charge cycles
/// (`battery_cycles`) where the metadata gives them, then by name with runs of digits compared
/// as numbers (`2-hover` before `10-hover`). Flights of different packs keep that order among
/// themselves; only a pack's own order matters to its history.
pub fn sort_flown(flights: &mut [Flight]) {
    flights.sort_by(flown_cmp);
}

fn flown_cmp(fa: &Flight, fb: &Flight) -> std::cmp::Ordering {
    let cycles = match (fa.meta.battery_cycles, fb.meta.battery_cycles) {
        (Some(x), Some(y)) => x.cmp(&y),
        _ => std::cmp::Ordering::Equal,
    };
    cycles.then_with(|| natural_cmp(&fa.name, &fb.name))
}

/// Compares names with runs of ASCII digits as numbers.
fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for k in 1..=bytes.len() {
            if k == bytes.len() || bytes[k].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..k]));
                start = k;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let o = match (x, y) {
            ((true, p), (true, q)) => {
                let (p, q) = (p.trim_start_matches('0'), q.trim_start_matches('0'));
                p.len().cmp(&q.len()).then_with(|| p.cmp(q))
            }
            ((_, p), (_, q)) => p.cmp(q),
        };
        if o != std::cmp::Ordering::Equal {
            return o;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use flightlog::LogFormat;
    use std::path::Path;

    /// 5 s on the ground at 0.5 A, then 600 s of hover at 10 A with the voltage falling
    /// linearly from 12.0 V to `end_v` (3 cells, cut-off 9.0 V); `current` false: no current
    /// column.
    fn flight(end_v: f64, current: bool) -> (Flight, FlightSpan) {
        let mut csv = String::from(if current {
            "time_s,voltage_v,current_a,phase\n"
        } else {
            "time_s,voltage_v,phase\n"
        });
        for k in 0..=605 {
            let t = f64::from(k);
            let (v, i, ph) = if k < 5 {
                (12.4, 0.5, "ground")
            } else {
                (12.0 + (end_v - 12.0) * (t - 5.0) / 600.0, 10.0, "hover")
            };
            if current {
                csv += &format!("{t},{v:.4},{i},{ph}\n");
            } else {
                csv += &format!("{t},{v:.4},{ph}\n");
            }
        }
        let mut f = Flight::parse(csv.as_bytes(), Path::new("f.csv"), LogFormat::Csv).unwrap();
        f.meta.cells = Some(3);
        f.meta.cutoff_voltage_v = Some(9.0);
        f.meta.end = Some(flightlog::End::Cutoff);
        let span = crate::cutoff::detect(&f).unwrap();
        (f, span)
    }

    fn end(remaining_s: f64, empty_from_s: Option<f64>, phase_power_w: f64) -> EndOfFlight {
        EndOfFlight {
            usable_capacity_ah: 2.0,
            remaining_s,
            empty_from_s,
            phase_power_w,
        }
    }

    #[test]
    fn the_charge_left_at_the_cut_off_lowers_the_capacity() {
        let (f, span) = flight(8.95, true);
        // 0.5 A over the ground's 5 s (the trapezoid into the first hover sample adds 4.75 A·s),
        // 10 A over 600 s; the estimator expected 60 s more at the last 5 s's 10 A.
        let counted = (0.5 * 4.0 + 0.5 * (0.5 + 10.0) + 10.0 * 600.0) / 3600.0;
        let left = 10.0 * 60.0 / 3600.0;
        let r = capacity_reading(&f, &span, 2.2, &end(60.0, None, 90.0)).unwrap();
        assert!((r.counted_ah - counted).abs() < 1e-9, "{}", r.counted_ah);
        assert!((r.expected_left_ah - left).abs() < 1e-9);
        assert!((r.capacity_ah - 2.0 * counted / (counted + left)).abs() < 1e-9);
        assert!((r.factor() - r.capacity_ah / 2.2).abs() < 1e-12);
    }

    #[test]
    fn charge_given_after_the_estimator_called_it_empty_raises_the_capacity() {
        let (f, span) = flight(8.95, true);
        let r = capacity_reading(&f, &span, 2.0, &end(0.0, Some(585.0), 90.0)).unwrap();
        // 20 s at 10 A past the call (trapezoids from 585 s to 605 s): 3.3 % of the count.
        assert!((r.expected_left_ah + 10.0 * 20.0 / 3600.0).abs() < 1e-9);
        assert!(r.capacity_ah > 2.0);
    }

    #[test]
    fn a_reading_is_refused_with_its_reason() {
        let why = |f: (Flight, FlightSpan), e: EndOfFlight| {
            capacity_reading(&f.0, &f.1, 2.0, &e).unwrap_err()
        };
        // Landed at 9.6 V: charge left, whatever the estimator expected.
        let w = why(flight(9.6, true), end(60.0, None, 90.0));
        assert!(w.contains("landed with charge left"), "{w}");
        // The estimator flew 120 W where the pack gave about 90 W.
        let w = why(flight(8.95, true), end(60.0, None, 120.0));
        assert!(w.contains("moved with the load"), "{w}");
        // 60 s at 10 A past the estimator's "empty": 10 % of the count, beyond MAX_FLOWN_ON.
        let w = why(flight(8.95, true), end(0.0, Some(545.0), 90.0));
        assert!(w.contains("misread this flight's voltage"), "{w}");
        // No current: nothing to count.
        let w = why(flight(8.95, false), end(60.0, None, 90.0));
        assert!(w.contains("no current"), "{w}");
        // A capacity three times the model's.
        let w = capacity_reading(
            &flight(8.95, true).0,
            &flight(8.95, true).1,
            0.6,
            &end(0.0, None, 90.0),
        )
        .unwrap_err();
        assert!(w.contains("beyond a factor"), "{w}");
    }

    /// A flight that does not name its pack neither uses a history nor leaves one; one that
    /// does leaves its reading under its name.
    #[test]
    fn a_history_needs_the_packs_name() {
        let (mut f, _) = flight(8.95, true);
        f.meta.structure_mass_kg = Some(0.43);
        f.meta.battery_mass_kg = Some(0.17);
        f.meta.avionics_power_w = Some(2.4);
        let curve = paper::reproduce().unwrap().curve;
        let params = estimator::Params {
            rotor_count: 4,
            curve,
            thrust_limit: None,
            battery: None,
            vehicle: None,
        };
        let battery = estimator::online::BatteryModel::lipo(3, 2.0).unwrap();
        let online = crate::online::FileOnline::new(
            params,
            battery,
            estimator::online::OnlineConfig::default(),
        );
        let config = crate::ReplayConfig {
            params,
            online: Some(&online),
            chemistry: None,
        };
        let mut h = PackHistory::new();
        let r = crate::replay_flight_with_history(&f, &config, Some(&mut h)).unwrap();
        let why = r.capacity_reading.unwrap().unwrap_err();
        assert!(why.contains("no battery_id"), "{why}");
        assert_eq!(h.readings().count(), 0);
        f.meta.battery_id = Some("pack-1".to_owned());
        let r = crate::replay_flight_with_history(&f, &config, Some(&mut h)).unwrap();
        match r.capacity_reading.unwrap() {
            Ok(reading) => assert_eq!(h.get("pack-1"), Some(&reading)),
            Err(why) => {
                assert!(!why.contains("battery_id"), "{why}");
                assert_eq!(h.readings().count(), 0);
            }
        }
        assert!(r.capacity_carried.is_none());
    }

    #[test]
    fn names_sort_with_their_numbers_as_numbers() {
        let mut v = vec![
            "10-attach-B",
            "2-hover",
            "1-hover-A",
            "11-ceiling-A",
            "flight",
            "01-x",
        ];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            v,
            [
                "1-hover-A",
                "01-x",
                "2-hover",
                "10-attach-B",
                "11-ceiling-A",
                "flight"
            ]
        );
    }
}
