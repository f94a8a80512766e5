//! Real MAVLink telemetry logs, kept in `tests/data/tlog/` with their licences (`SOURCE.md`
//! in each folder): a Mission Planner log of an ArduCopter quad (MAVLink 1, 23 minutes with a
//! telemetry dropout), a QGroundControl log of an ArduSub ROV (MAVLink 2, both battery
//! messages) and the start of a simulated VTOL's log that reports no battery. The charge
//! integrated from the samples is checked against what the autopilot counted itself
//! (`battery_remaining` × `BATT_CAPACITY`; `BATTERY_STATUS.current_consumed`).

mod common;

use std::path::Path;

use common::charge_mah;

use flightlog::tlog::Tlog;
use flightlog::{Flight, FlightLogError, LogFormat, VehicleKind};

#[test]
fn a_mission_planner_tlog_keeps_the_stretch_that_flew() {
    let f = Flight::read(&common::data("tlog/dronekit+dronekit-python/flight.tlog")).unwrap();
    assert_eq!(f.format, LogFormat::Tlog);
    assert_eq!(f.meta.vehicle, Some(VehicleKind::Multirotor));
    assert_eq!(f.meta.capacity_mah, Some(2650.0));
    assert_eq!(f.meta.cells, Some(3));
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("kept 252.0–1049.5 s of the log")),
        "{:?}",
        f.warnings
    );
    assert!((f.samples.duration_s() - 797.4).abs() < 0.1);
    assert!(f.samples.altitude_m.is_some() && f.samples.throttle.is_some());
    // ArduPilot's remaining charge counts down its own integral of the current against
    // BATT_CAPACITY (in whole percent): the reception times agree with it within 3 %.
    let remaining = |at: usize| -> f64 {
        let bytes =
            std::fs::read(common::data("tlog/dronekit+dronekit-python/flight.tlog")).unwrap();
        let log = Tlog::parse(&bytes, Path::new("flight.tlog")).unwrap();
        let sys: Vec<_> = log
            .packets
            .iter()
            .filter(|p| p.system == 1 && p.msg_id == 1)
            .collect();
        let t0 = sys[0].time_us;
        // The first SYS_STATUS at or after the sample's time of reception.
        let t = t0 + ((252.0 + f.samples.time_s[at]) * 1e6).round() as u64;
        let p = sys.iter().find(|p| p.time_us >= t).unwrap();
        f64::from(p.payload[30] as i8)
    };
    let counted_mah = (remaining(0) - remaining(f.samples.len() - 1)) / 100.0 * 2650.0;
    let ours = charge_mah(&f);
    assert!(
        (ours / counted_mah - 1.0).abs() < 0.03,
        "integrated {ours:.0} mAh, the autopilot's remaining {counted_mah:.0} mAh"
    );
}

#[test]
fn a_mavlink2_tlog_reads_both_battery_messages_alike() {
    let path = common::data("tlog/clydemcqueen+ardusub_log_tools/small.tlog");
    let f = Flight::read(&path).unwrap();
    assert_eq!(f.samples.len(), 528);
    assert_eq!(f.meta.vehicle, Some(VehicleKind::Rover));
    assert_eq!(
        f.log.firmware.as_deref(),
        Some("ArduSub V4.1.1 BETA5 (66c674c1)")
    );
    let battery = f.log.battery.as_ref().unwrap();
    assert_eq!(battery.battery, "SYS_STATUS");
    assert_eq!(battery.others, ["BATTERY_STATUS id 0: usable, not used"]);
    // BATTERY_STATUS.current_consumed, mAh, over the same span (the autopilot's own count).
    let bytes = std::fs::read(&path).unwrap();
    let log = Tlog::parse(&bytes, &path).unwrap();
    let consumed: Vec<(u64, i32)> = log
        .packets
        .iter()
        .filter(|p| p.system == 1 && p.msg_id == 147)
        .map(|p| {
            let c = &p.payload;
            (p.time_us, i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        })
        .collect();
    let counted_mah = f64::from(consumed.last().unwrap().1 - consumed[0].1);
    let ours = charge_mah(&f);
    assert!(
        (ours - counted_mah).abs() < 0.03 * counted_mah + 1.0,
        "integrated {ours:.1} mAh, current_consumed {counted_mah} mAh"
    );
}

#[test]
fn a_tlog_without_a_battery_says_so() {
    let e = Flight::read(&common::data(
        "tlog/ArduPilot+UAVLogViewer/vtol_first120k.tlog",
    ))
    .unwrap_err();
    assert!(matches!(e, FlightLogError::NoUsableBattery { .. }), "{e}");
    assert!(e.to_string().contains("SYS_STATUS: no voltage"), "{e}");
}
