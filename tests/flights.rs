//! `hoverbench flights` end to end on the real logs in `../shared/data/real/flightlogs/`
//! (which CI has beside the clone).

use std::path::PathBuf;

use serde_json::Value;

mod common;
use common::{bin, json, shared_path};

fn logs() -> PathBuf {
    shared_path("flightlogs")
}

fn flights(args: &[&str]) -> std::process::Output {
    bin()
        .current_dir(logs())
        .arg("flights")
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn one_shared_log_in_words() {
    let out = flights(&["dataflash/dronekit_log171_copter33_curr.bin"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    insta::assert_snapshot!(String::from_utf8(out.stdout).unwrap());
}

#[test]
fn every_shared_log_as_json_with_the_skipped_and_why() {
    let out = flights(&["ulog", "dataflash", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let flights = v["flights"].as_array().unwrap();
    let names: Vec<&str> = flights
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "flightreview_ekf_failure",
            "flightreview_gps_interference",
            "px4ulogrs_esc_status_log",
            "pyulog_sample_log_small",
            "dronekit_log171_copter33_curr",
            "methodicconfigurator_arducopter46_first80k",
            "pymavlink_test_arduplane_first64k",
        ]
    );
    for f in flights {
        for key in [
            "format",
            "duration_s",
            "samples",
            "voltage_v",
            "phases",
            "metadata",
        ] {
            assert!(!f[key].is_null(), "{key} in {f}");
        }
        assert_eq!(f["voltage_v"].as_array().unwrap().len(), 2);
        // Energy only where current is logged; every metadata value says its source.
        assert_eq!(f["current_a"].is_null(), f["energy_wh"].is_null());
        for (key, m) in f["metadata"].as_object().unwrap() {
            assert!(
                m["source"].as_str().unwrap().starts_with("log ("),
                "{key}: {m}"
            );
        }
    }
    let solo = &flights[4];
    assert_eq!(solo["format"], "dataflash");
    assert!((solo["energy_wh"].as_f64().unwrap() - 11.24).abs() < 0.01);
    assert_eq!(solo["metadata"]["capacity_mah"]["value"], 5200.0);
    let skipped = v["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 2, "{skipped:?}");
    assert!(
        skipped[0]["file"]
            .as_str()
            .unwrap()
            .ends_with("flightreview_battery_disconnected.ulg")
    );
    assert!(
        skipped[0]["reason"]
            .as_str()
            .unwrap()
            .contains("not connected")
    );
    assert!(
        skipped[1]["reason"]
            .as_str()
            .unwrap()
            .contains("no battery_status")
    );
}

#[test]
fn sidecar_overrides_the_log_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("solo.bin");
    std::fs::copy(
        logs().join("dataflash/dronekit_log171_copter33_curr.bin"),
        &log,
    )
    .unwrap();
    std::fs::write(
        dir.path().join("solo.toml"),
        "capacity_mah = 5000.0\nperches = false\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("flights.toml"), "cells = 4\n").unwrap();
    let v = json(&["flights", "--json", dir.path().to_str().unwrap()]);
    let m = &v["flights"][0]["metadata"];
    assert_eq!(m["capacity_mah"]["value"], 5000.0);
    assert_eq!(m["capacity_mah"]["source"], "sidecar (solo.toml)");
    assert_eq!(m["cells"]["source"], "folder (flights.toml)");
    assert_eq!(m["frame"]["value"], "quad");
}

#[test]
fn a_voltage_implausible_for_the_cells_of_the_metadata_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let rows: String = (0..20).map(|k| format!("{}.0,1.2,0.5\n", k)).collect();
    std::fs::write(
        dir.path().join("usb.csv"),
        format!("time_s,voltage_v,current_a\n{rows}"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("ok.csv"),
        format!(
            "time_s,voltage_v,current_a\n{}",
            rows.replace(",1.2,", ",11.8,")
        ),
    )
    .unwrap();
    std::fs::write(dir.path().join("flights.toml"), "cells = 3\n").unwrap();
    let v = json(&["flights", "--json", dir.path().to_str().unwrap()]);
    assert_eq!(v["flights"].as_array().unwrap().len(), 1);
    assert_eq!(v["flights"][0]["name"], "ok");
    let reason = v["skipped"][0]["reason"].as_str().unwrap();
    assert!(
        reason.contains("implausible for 3 cells") && reason.contains("folder (flights.toml)"),
        "{reason}"
    );
}

#[test]
fn nothing_readable_is_an_error_after_the_reasons() {
    let out = flights(&["ulog/flightreview_battery_disconnected.ulg"]);
    assert_eq!(out.status.code(), Some(2));
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("not connected"), "{stdout}");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("no flight could be read"), "{stderr}");
}

/// The logs other tools write (in `flightlog/tests/data/`, with their licences): an APM 2 text
/// DataFlash log, a PX4 `ulog2csv` battery export and two ground stations' MAVLink telemetry
/// logs are read, and the three that cannot be are listed with their reasons.
#[test]
fn logs_of_other_tools_in_words() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("flightlog/tests/data");
    let out = bin()
        .current_dir(&data)
        .args([
            "flights",
            "ardupilot-text",
            "px4-ulog2csv",
            "tlog/dronekit+dronekit-python",
            "tlog/clydemcqueen+ardusub_log_tools",
            "tlog/ArduPilot+UAVLogViewer",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    insta::assert_snapshot!(String::from_utf8(out.stdout).unwrap());
}
