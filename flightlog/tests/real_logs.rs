//! Every real log in `../shared/data/real/flightlogs/` (PX4 ULog and ArduPilot DataFlash
//! recorded by other people; sources and licences in its README): what is read from each is
//! snapshotted, so a test fails if a log stops being read or its numbers change.

use std::path::{Path, PathBuf};

use flightlog::{Flight, FlightLogError, FlightSummary, Phase, SkipReason, VehicleKind};

/// The shared real logs (beside the repository's clone, as CI has them).
fn real(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real/flightlogs")
        .join(rel)
}

fn read(rel: &str) -> Result<Flight, FlightLogError> {
    Flight::read(&real(rel))
}

/// The summary without the machine-specific file path.
fn summary(rel: &str) -> FlightSummary {
    let flight = read(rel).unwrap_or_else(|e| panic!("{rel}: {e}"));
    assert!(flight.samples.is_consistent());
    FlightSummary {
        file: rel.to_owned(),
        ..FlightSummary::of(&flight)
    }
}

macro_rules! snapshot {
    ($test:ident, $file:expr) => {
        #[test]
        fn $test() {
            insta::assert_json_snapshot!(summary($file));
        }
    };
}

snapshot!(
    px4_vtol_sample_log_small,
    "ulog/pyulog_sample_log_small.ulg"
);
snapshot!(px4_esc_status_crash, "ulog/px4ulogrs_esc_status_log.ulg");
snapshot!(px4_ekf_failure_6s_quad, "ulog/flightreview_ekf_failure.ulg");
snapshot!(
    px4_gps_interference,
    "ulog/flightreview_gps_interference.ulg"
);
snapshot!(
    arduplane_bat_truncated,
    "dataflash/pymavlink_test_arduplane_first64k.BIN"
);
snapshot!(
    arducopter46_bat_truncated,
    "dataflash/methodicconfigurator_arducopter46_first80k.bin"
);
snapshot!(
    arducopter33_curr,
    "dataflash/dronekit_log171_copter33_curr.bin"
);

#[test]
fn arducopter33_curr_scaling_and_time_base() {
    let f = read("dataflash/dronekit_log171_copter33_curr.bin").unwrap();
    let s = &f.samples;
    // README: a 243 s 3DR Solo flight, 14.9–16.5 V, 0.5–27 A.
    assert!((s.duration_s() - 242.6).abs() < 1.0, "{}", s.duration_s());
    let (vmin, vmax) = minmax(&s.voltage_v);
    assert!(vmin > 14.8 && vmax < 16.6, "{vmin}–{vmax}");
    let (imin, imax) = minmax(s.current_a.as_ref().unwrap());
    assert!(imin > 0.4 && imax > 27.0 && imax < 28.0, "{imin}–{imax}");
    assert_eq!(f.log.battery.as_ref().unwrap().battery, "CURR");
    assert_eq!(f.meta.vehicle, Some(VehicleKind::Multirotor));
    assert_eq!(f.meta.cells, Some(4));
    assert_eq!(f.meta.capacity_mah, Some(5200.0));
    assert!(
        f.metadata["capacity_mah"]
            .source
            .to_string()
            .contains("BATT_CAPACITY")
    );
}

#[test]
fn disconnected_battery_is_refused_with_the_reason() {
    let e = read("ulog/flightreview_battery_disconnected.ulg").unwrap_err();
    let FlightLogError::NoUsableBattery { batteries, .. } = &e else {
        panic!("{e}")
    };
    assert_eq!(batteries.len(), 1);
    assert!(matches!(
        batteries[0].reason,
        SkipReason::NotConnected { samples: 382 }
    ));
    assert!(e.to_string().contains("not connected"), "{e}");
}

#[test]
fn no_battery_names_what_was_looked_for() {
    let e = read("ulog/pyulog_sample_no_battery.ulg").unwrap_err();
    assert!(
        matches!(&e, FlightLogError::MissingData { field, .. } if field == "battery_status"),
        "{e}"
    );
    assert!(e.to_string().contains("no battery_status"), "{e}");
}

#[test]
fn a_plain_quad_has_no_transition_or_attached() {
    for rel in [
        "ulog/flightreview_ekf_failure.ulg",
        "ulog/flightreview_gps_interference.ulg",
        "ulog/px4ulogrs_esc_status_log.ulg",
        "dataflash/dronekit_log171_copter33_curr.bin",
    ] {
        let f = read(rel).unwrap();
        assert_eq!(f.meta.vehicle, Some(VehicleKind::Multirotor), "{rel}");
        let phases = f.samples.phase.as_ref().unwrap();
        assert!(
            !phases.contains(&Phase::Transition) && !phases.contains(&Phase::Attached),
            "{rel}: {:?}",
            f.phase_source
        );
    }
}

#[test]
fn the_vtol_is_a_vtol() {
    let f = read("ulog/pyulog_sample_log_small.ulg").unwrap();
    assert_eq!(f.meta.vehicle, Some(VehicleKind::Vtol));
    assert!(
        f.metadata["vehicle"]
            .source
            .to_string()
            .contains("MAV_TYPE")
    );
    assert!(f.capabilities().vtol.is_some());
    assert!(f.capabilities().perches.is_none());
}

fn minmax(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}
