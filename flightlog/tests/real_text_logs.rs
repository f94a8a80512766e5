//! Real logs in text form, kept in `tests/data/` with their licences (`SOURCE.md` in each
//! folder): ArduPilot's LogAnalyzer examples (ArduCopter 3.0.1 and 3.1 on APM 2, text
//! DataFlash with a banner, `CURR` without a time field) and a PX4 `ulog2csv` export of
//! `battery_status`. Each reader's timing is checked against what the log itself counted: the
//! charge integrated from the samples against the firmware's own counter (`CURR.CurrTot`,
//! `discharged_mah`), which no code here computes.

mod common;

use common::charge_mah;

use flightlog::dataflash::DataFlash;
use flightlog::{Flight, FlightLogError, LogFormat};

#[test]
fn an_apm2_text_log_without_battery_times_is_timed_by_its_gps() {
    let path = common::data("ardupilot-text/mechanical_fail.log");
    let f = Flight::read(&path).unwrap();
    assert_eq!(f.format, LogFormat::DataFlashText);
    assert_eq!(
        f.log.firmware.as_deref(),
        Some("ArduCopter V3.1 (5c6503e2)")
    );
    assert_eq!(f.log.battery.as_ref().unwrap().battery, "CURR");
    // 110 CURR lines, one before the GPS's first time; Volt and Curr in cV and cA.
    assert_eq!(f.samples.len(), 109);
    assert!((f.samples.duration_s() - 108.1).abs() < 0.1);
    let v = &f.samples.voltage_v;
    let (lo, hi) = v
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    assert_eq!((lo, hi), (13.83, 16.95));
    assert_eq!(f.meta.capacity_mah, Some(4200.0));
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("interpolated by position in the log between the GPS.TimeMS")),
        "{:?}",
        f.warnings
    );
    // The firmware's own charge counter over the same samples: the times taken from the
    // GPS agree with it within 3 %.
    let bytes = std::fs::read(&path).unwrap();
    let log = DataFlash::parse_text(&bytes, &path).unwrap();
    let rows = log.rows("CURR", None, &[("CurrTot", true)], &path).unwrap();
    // The CURR lines the flight kept: those within the GPS's times.
    let clock = log.clock(&path).unwrap();
    assert_eq!(clock.label, "GPS.TimeMS");
    let counted: Vec<f64> = rows
        .iter()
        .filter(|r| clock.at(r.offset).is_some())
        .filter_map(|r| r.values[0])
        .collect();
    assert_eq!(counted.len(), f.samples.len());
    let firmware_mah = counted.last().unwrap() - counted.first().unwrap();
    let ours = charge_mah(&f);
    assert!(
        (ours / firmware_mah - 1.0).abs() < 0.03,
        "integrated {ours:.1} mAh, CurrTot {firmware_mah:.1} mAh"
    );
}

#[test]
fn a_battery_hole_in_a_text_log_is_named_by_its_line() {
    let e = Flight::read(&common::data("ardupilot-text/robert_lefebvre_octo_PM.log")).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("line 1272") && text.contains("CURR (times from GPS.Time)"),
        "{text}"
    );
    assert!(text.contains("without a sample"), "{text}");
}

#[test]
fn a_text_log_with_no_time_anywhere_says_so() {
    let e = Flight::read(&common::data("ardupilot-text/underpowered_first60k.log")).unwrap_err();
    assert!(matches!(e, FlightLogError::MissingData { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("no other message of the log has a time to take theirs from"),
        "{e}"
    );
}

#[test]
fn a_px4_ulog2csv_battery_export_agrees_with_px4s_own_counter() {
    let path =
        common::data("px4-ulog2csv/7c824ee5-cf25-4c19-8739-12455adfae23_battery_status_0.csv");
    let f = Flight::read(&path).unwrap();
    assert_eq!(f.format, LogFormat::Csv);
    assert_eq!(f.samples.len(), 1539);
    // The pack PX4 was told of: 5 cells, 3000 mAh.
    assert_eq!(f.meta.cells, Some(5));
    assert_eq!(f.meta.capacity_mah, Some(3000.0));
    assert!((f.samples.duration_s() - 307.4).abs() < 0.1);
    // PX4's `discharged_mah`, first row to last (read here from the file's own column).
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == "discharged_mah").unwrap();
    let column: Vec<f64> = lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect();
    let px4_mah = column.last().unwrap() - column.first().unwrap();
    let ours = charge_mah(&f);
    assert!(
        (ours / px4_mah - 1.0).abs() < 0.01,
        "integrated {ours:.2} mAh, PX4 {px4_mah:.2} mAh"
    );
}
