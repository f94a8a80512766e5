//! A pack's history: the usable capacity one flight measured, carried to the pack's next
//! flight.
//!
//! A faded pack empties sooner than its `[battery]` section says, and in flight the voltage
//! shows it only late: at half the flight a 15 % fade moves the open-circuit voltage by a few
//! hundredths of a volt per cell, as much as one pack's curve differs from another's
//! (docs/evidence/online-estimator.md, "Why the remaining misses resist the filter"). The
//! online estimator lets its curve offset absorb such a slow fall (it cannot tell a fade from
//! the curve's shape in flight), and so its own capacity hardly moves. A whole flight, looked
//! at after landing, tells them apart: over a deep discharge a fade makes the offset grow with
//! the charge drawn, by the curve's slope times the charge the model did not expect to be
//! gone. [`capacity_reading`] reads that back:
//!
//! `C = Q / (soc_start − soc_end)`, with
//! `soc_end = curve⁻¹(curve(soc_filter_end) + (offset_end − offset_settled) / cells)`
//!
//! - `Q`: the charge counted from the first sample to the last flying one (without a logged
//!   current, the charge the estimator's own current drew: its power model's, with the extra
//!   power the voltage taught it);
//! - `soc_start`: the estimator's state of charge at the first sample;
//! - `soc_filter_end`, `offset_end`: its state of charge and curve offset at the last sample;
//! - `offset_settled`: its curve offset [`SETTLED_AFTER_S`] after the first sample, the
//!   pack's (and the voltage sensor's) own level against the curve, which the end's offset is
//!   measured from;
//! - `curve`: the battery model's open-circuit voltage per cell.
//!
//! So the end of the flight is read on the model's curve at the voltage the pack really had
//! there. The flight need not end at the cut-off: a robot that landed because its rotors ran
//! out of thrust gives a reading as well, and so does a flight `replay` does not score (it
//! landed before the cut-off): the estimator flies it only to read the pack. A reading is refused, with the reason, when there is
//! no charge to count, when less than [`MIN_SOC_SPAN`] of the capacity was counted, when
//! the reading is more than [`MAX_ABOVE_MODEL`] above the model's capacity (packs come at about
//! their rating and only lose capacity with age; a larger reading is a flight that ran past
//! the model's empty, where the curve no longer tells the charge) or below the model's divided
//! by [`PLAUSIBLE_FACTOR`]. [`PackHistory`] keeps the last reading of each pack
//! (`battery_id`); `replay --pack-history` fuses it, as a factor on the model's capacity with
//! one-sigma [`READING_SIGMA`], into the pack's next flight when it lies at least
//! [`MIN_SHORTFALL`] below the model's capacity (a faded pack); a pack that reads closer to its
//! model flies with the model's capacity. The same reading is what a ground
//! station would store after each flight and write into the parameter blob before the next:
//! nothing here runs in flight.
//!
//! Measured on `replay-eval`'s worlds it helps faded packs most and moves some packs with an
//! extra resistance or a cold start the wrong way, so it is off by default
//! (docs/evidence/online-estimator.md, "A pack's history").

use std::collections::BTreeMap;

use estimator::online::BatteryModel;
use flightlog::Flight;
use serde::Serialize;

/// The curve offset the end is measured from is the estimator's this long after the first
/// sample, s: by then it has read the pack's level against the curve (a voltage sensor's
/// offset and scale, the pack's own curve) from its first minute of flying.
pub const SETTLED_AFTER_S: f64 = 60.0;
/// The least charge a reading's flight must have counted, as a fraction of the estimator's
/// capacity.
pub const MIN_SOC_SPAN: f64 = 0.4;
/// One-sigma of a reading, as a fraction of the capacity: the next flight's pack is not quite
/// this one (packs of one type differ by some per cent, and one pack from flight to flight by
/// its temperature) and the current sensor's scale error enters the count. The online
/// estimator fuses the reading with its own capacity (`FilterState::CapacityScale`). Chosen on
/// `replay-eval`'s tuning families (seeds 0–71) over 0.03, 0.05 and 0.06.
pub const READING_SIGMA: f64 = 0.04;
/// A reading may lie at most this fraction above the model's capacity. Chosen on
/// `replay-eval`'s tuning families (seeds 0–71; 1.10 and no bound let readings of 1.1–1.25
/// through, from flights that ran past the model's empty at a low current).
pub const MAX_ABOVE_MODEL: f64 = 0.05;
/// A reading must lie above the model's capacity divided by this.
pub const PLAUSIBLE_FACTOR: f64 = 2.0;
/// A reading is carried to the pack's next flight only when it lies at least this fraction
/// below the model's capacity ([`CapacityReading::carries`]); a pack that reads closer to its
/// model flies its next flight with the model's capacity. Readings of healthy packs scatter by
/// some per cent (1–3.5 % median error on 1 Hz lab logs, 3–6 % on 10 Hz flight-controller
/// logs, whose current sensors' scale and offset errors enter the count), and a pack whose
/// other errors (an extra resistance, a cold start, a payload) the filter had balanced against
/// the model's capacity then flies worse with a right one; a fade of this size is beyond both.
/// Chosen on `replay-eval`'s tuning families (seeds 0–71) over 0, 0.03, 0.05, 0.08, 0.10,
/// 0.12, 0.15 and 0.20 (docs/evidence/online-estimator.md, "Session 23").
pub const MIN_SHORTFALL: f64 = 0.15;

/// The usable capacity one flight measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CapacityReading {
    /// The flight it comes from.
    pub flight: String,
    /// Charge counted from the first sample to the last flying one, Ah.
    pub counted_ah: f64,
    /// The flight logged no current: [`Self::counted_ah`] is the charge the estimator's own
    /// current drew (its power model's, with the extra power the voltage taught it).
    pub charge_from_model: bool,
    /// The estimator's state of charge at the first sample.
    pub start_soc: f64,
    /// The state of charge at the end, read on the model's curve at the pack's voltage there
    /// (the estimator's end state moved by its curve offset since [`SETTLED_AFTER_S`]).
    pub end_soc: f64,
    /// The pack's capacity, `counted_ah / (start_soc − end_soc)`, Ah.
    pub capacity_ah: f64,
    /// The pack model's capacity the flight was flown with, Ah.
    pub model_capacity_ah: f64,
}

impl CapacityReading {
    /// The reading over the model's capacity.
    pub fn factor(&self) -> f64 {
        self.capacity_ah / self.model_capacity_ah
    }

    /// Whether the pack's next flight flies with this reading: it lies at least
    /// [`MIN_SHORTFALL`] below the model's capacity.
    pub fn carries(&self) -> bool {
        self.factor() <= 1.0 - MIN_SHORTFALL
    }
}

/// What the online estimator said over a flight, for a [`capacity_reading`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightEstimates {
    /// Its state of charge at the first sample.
    pub start_soc: f64,
    /// Its curve offset [`SETTLED_AFTER_S`] after the first sample (at the last sample of a
    /// shorter flight), V (pack).
    pub settled_offset_v: f64,
    /// Its state of charge at the last sample.
    pub end_soc: f64,
    /// Its curve offset at the last sample, V (pack).
    pub end_offset_v: f64,
    /// Its usable capacity at the end, Ah.
    pub usable_capacity_ah: f64,
    /// The charge its current drew from the first sample to the last (the logged current, or
    /// without one its model's), Ah.
    pub estimator_charge_ah: f64,
}

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

/// The capacity `flight`, flown until `end_s` (its last flying sample, log time) with the
/// battery model `pack`, measured, from what the online estimator said over it (`est`); the
/// reason when it gives none.
pub fn capacity_reading(
    flight: &Flight,
    end_s: f64,
    pack: &BatteryModel,
    est: &FlightEstimates,
) -> Result<CapacityReading, String> {
    let s = &flight.samples;
    let Some(&t0) = s.time_s.first() else {
        return Err("no samples".to_owned());
    };
    // Without a logged current, the charge the estimator's own current drew: its power model's,
    // with the extra power the voltage taught it.
    let (counted, charge_from_model) = match counted_ah(flight, t0, end_s) {
        Some(q) => (q, false),
        None if est.estimator_charge_ah.is_finite() && est.estimator_charge_ah > 0.0 => {
            (est.estimator_charge_ah, true)
        }
        None => {
            return Err(
                "no current logged, and no charge from the estimator's model to count instead"
                    .to_owned(),
            );
        }
    };
    let numbers = [
        est.start_soc,
        est.settled_offset_v,
        est.end_soc,
        est.end_offset_v,
        est.usable_capacity_ah,
    ];
    if numbers.iter().any(|x| !x.is_finite()) || est.usable_capacity_ah <= 0.0 {
        return Err("the online estimator ended without a state to read".to_owned());
    }
    if counted < MIN_SOC_SPAN * est.usable_capacity_ah {
        return Err(format!(
            "counted {counted:.3} Ah, under {:.0} % of the {:.3} Ah the estimator flew: too shallow a discharge to read the capacity",
            100.0 * MIN_SOC_SPAN,
            est.usable_capacity_ah
        ));
    }
    let cells = f64::from(pack.cells);
    let end_ocv_cell_v =
        pack.ocv_cell_at(est.end_soc) + (est.end_offset_v - est.settled_offset_v) / cells;
    let end_soc = pack.soc_for_ocv_cell(end_ocv_cell_v);
    let span_soc = est.start_soc - end_soc;
    let model_capacity_ah = pack.rated_capacity_ah;
    let capacity_ah = counted / span_soc;
    if !(span_soc > 0.0 && capacity_ah.is_finite()) {
        return Err(format!(
            "the end reads at {end_soc:.3} of the charge on the model's curve, not below the start's {:.3}",
            est.start_soc
        ));
    }
    if capacity_ah > model_capacity_ah * (1.0 + MAX_ABOVE_MODEL) {
        return Err(format!(
            "measured {capacity_ah:.3} Ah, more than {:.0} % above the model's {model_capacity_ah:.3} Ah: the flight ran past the model's empty ({end_ocv_cell_v:.3} V per cell at the end), where the curve no longer tells the charge",
            100.0 * MAX_ABOVE_MODEL
        ));
    }
    if capacity_ah < model_capacity_ah / PLAUSIBLE_FACTOR {
        return Err(format!(
            "measured {capacity_ah:.3} Ah against the model's {model_capacity_ah:.3} Ah, below a factor {PLAUSIBLE_FACTOR}: a current sensor or a curve is wrong"
        ));
    }
    Ok(CapacityReading {
        flight: flight.name.clone(),
        counted_ah: counted,
        charge_from_model,
        start_soc: est.start_soc,
        end_soc,
        capacity_ah,
        model_capacity_ah,
    })
}

/// The last capacity reading of each pack (`battery_id`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PackHistory {
    readings: BTreeMap<String, CapacityReading>,
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
    fn flight(end_v: f64, current: bool) -> (Flight, crate::cutoff::FlightSpan) {
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

    /// The estimator's view of a flight that ended at `filter_end_soc` while the pack's voltage
    /// there was that of `true_end_soc` on the 3-cell LiPo curve, its level `settled_v` above
    /// the curve throughout.
    fn est(filter_end_soc: f64, true_end_soc: f64, settled_v: f64) -> FlightEstimates {
        let pack = BatteryModel::lipo(3, 2.0).unwrap();
        let gap_cell_v = pack.ocv_cell_at(true_end_soc) - pack.ocv_cell_at(filter_end_soc);
        FlightEstimates {
            start_soc: 1.0,
            settled_offset_v: settled_v,
            end_soc: filter_end_soc,
            end_offset_v: settled_v + 3.0 * gap_cell_v,
            usable_capacity_ah: 2.0,
            estimator_charge_ah: 1.5,
        }
    }

    /// 0.5 A over the ground's 5 s (the trapezoid into the first hover sample adds 4.75 A·s),
    /// 10 A over 600 s.
    const COUNTED_AH: f64 = (0.5 * 4.0 + 0.5 * (0.5 + 10.0) + 10.0 * 600.0) / 3600.0;

    #[test]
    fn an_offset_grown_over_the_flight_reads_as_a_smaller_capacity() {
        let (f, span) = flight(9.6, true);
        let pack = BatteryModel::lipo(3, 2.0).unwrap();
        // The filter ended at 20 % of the charge, its offset down to the curve's voltage at 5 %:
        // the pack gave its count over 95 % of its charge, not 80 %. It need not have reached
        // the cut-off (9.6 V here).
        let r = capacity_reading(&f, span.end_s, &pack, &est(0.2, 0.05, 0.0)).unwrap();
        assert!((r.counted_ah - COUNTED_AH).abs() < 1e-9, "{}", r.counted_ah);
        assert!((r.end_soc - 0.05).abs() < 1e-6, "{}", r.end_soc);
        assert!((r.capacity_ah - COUNTED_AH / 0.95).abs() < 1e-6, "{r:?}");
        assert!((r.factor() - r.capacity_ah / 2.0).abs() < 1e-12);
        // A pack whose level sits 0.1 V above the curve from the start reads the same.
        let same = capacity_reading(&f, span.end_s, &pack, &est(0.2, 0.05, 0.1)).unwrap();
        assert!((same.capacity_ah - r.capacity_ah).abs() < 1e-9);
        // No offset grown: the filter's own end.
        let own = capacity_reading(&f, span.end_s, &pack, &est(0.15, 0.15, 0.0)).unwrap();
        assert!(
            (own.capacity_ah - COUNTED_AH / 0.85).abs() < 1e-6,
            "{own:?}"
        );
    }

    /// A reading is carried to the pack's next flight only when it lies at least
    /// [`MIN_SHORTFALL`] below the model's capacity.
    #[test]
    fn only_a_reading_well_below_the_model_is_carried() {
        let (f, span) = flight(9.6, true);
        let read = |ah: f64| {
            capacity_reading(
                &f,
                span.end_s,
                &BatteryModel::lipo(3, ah).unwrap(),
                &est(0.2, 0.05, 0.0),
            )
            .unwrap()
        };
        // 1.757 Ah read: 88 % of a 2 Ah model, 70 % of a 2.5 Ah one.
        let near = read(2.0);
        assert!((near.factor() - 0.878).abs() < 1e-3, "{near:?}");
        assert!(!near.carries());
        let faded = read(2.5);
        assert!((faded.factor() - 0.703).abs() < 1e-3, "{faded:?}");
        assert!(faded.carries());
        let edge = CapacityReading {
            capacity_ah: 2.0 * (1.0 - MIN_SHORTFALL),
            ..near
        };
        assert!(edge.carries());
    }

    /// Without a logged current the charge is the estimator's own (its power model's current).
    #[test]
    fn a_voltage_only_flight_reads_with_the_estimators_charge() {
        let (f, span) = flight(9.6, false);
        let pack = BatteryModel::lipo(3, 2.0).unwrap();
        let r = capacity_reading(&f, span.end_s, &pack, &est(0.2, 0.05, 0.0)).unwrap();
        assert!(r.charge_from_model);
        assert!((r.counted_ah - 1.5).abs() < 1e-12);
        assert!((r.capacity_ah - 1.5 / 0.95).abs() < 1e-6, "{r:?}");
        let (g, gspan) = flight(9.6, true);
        assert!(
            !capacity_reading(&g, gspan.end_s, &pack, &est(0.2, 0.05, 0.0))
                .unwrap()
                .charge_from_model
        );
    }

    #[test]
    fn a_reading_is_refused_with_its_reason() {
        let (f, span) = flight(8.95, true);
        let why = |pack: BatteryModel, e: FlightEstimates| {
            capacity_reading(&f, span.end_s, &pack, &e).unwrap_err()
        };
        let lipo = |ah: f64| BatteryModel::lipo(3, ah).unwrap();
        // No current, and no charge from the estimator either: nothing to count.
        let (g, gspan) = flight(8.95, false);
        let mut uncounted = est(0.2, 0.05, 0.0);
        uncounted.estimator_charge_ah = f64::NAN;
        let w = capacity_reading(&g, gspan.end_s, &lipo(2.0), &uncounted).unwrap_err();
        assert!(w.contains("no current"), "{w}");
        // 1.67 Ah counted of a 5 Ah pack.
        let mut shallow = est(0.2, 0.05, 0.0);
        shallow.usable_capacity_ah = 5.0;
        let w = why(lipo(2.0), shallow);
        assert!(w.contains("too shallow"), "{w}");
        // 1.76 Ah read on a 1.5 Ah model: 17 % above it.
        let w = why(lipo(1.5), est(0.2, 0.05, 0.0));
        assert!(w.contains("past the model's empty"), "{w}");
        // 1.76 Ah read on a 4 Ah model.
        let w = why(lipo(4.0), est(0.2, 0.05, 0.0));
        assert!(w.contains("below a factor"), "{w}");
        // A state the estimator did not give.
        let mut lost = est(0.2, 0.05, 0.0);
        lost.start_soc = f64::NAN;
        let w = why(lipo(2.0), lost);
        assert!(w.contains("without a state"), "{w}");
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
        let params = estimator::Params::new(4, curve);
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
            trace_unscored: false,
            motor_power: false,
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
