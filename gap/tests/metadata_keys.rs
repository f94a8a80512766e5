//! The flight-log metadata keys the diagnosis reads beyond the paper's: `battery_ocv_csv` (a
//! measured open-circuit curve, relative to the metadata file) and `ceiling_height_m`, read from
//! a folder on disk as `hoverbench gap` reads it.

use std::path::{Path, PathBuf};

use flightlog::FlightSet;
use gap::GapError;
use gap::battery::LearnedBattery;
use gap::logs::record_from_log;

/// A fresh folder under the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gap-metadata-keys-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("curves")).unwrap();
    dir
}

/// A one-minute 3S hover log at 1 Hz.
fn write_log(dir: &Path, name: &str) {
    let mut csv = String::from("time_s,voltage_v,current_a,phase\n");
    for k in 0..60 {
        let phase = if k < 5 { "ground" } else { "hover" };
        let amps = if k < 5 { 0.2 } else { 12.0 };
        csv.push_str(&format!(
            "{k},{:.3},{amps},{phase}\n",
            12.3 - 0.004 * f64::from(k)
        ));
    }
    std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
}

const CURVE: &str = "soc,ocv_v\n0,3.0\n0.1,3.45\n0.5,3.75\n0.9,4.05\n1,4.2\n";

#[test]
fn a_curve_named_by_the_folder_is_read_relative_to_it_and_the_ceiling_by_the_sidecar() {
    let dir = scratch("ok");
    write_log(&dir, "a");
    std::fs::write(
        dir.join("flights.toml"),
        "cells = 3\nbattery_energy_wh = 40.0\nbattery_ocv_csv = \"curves/cell.csv\"\n",
    )
    .unwrap();
    std::fs::write(dir.join("a.toml"), "ceiling_height_m = 3.2\n").unwrap();
    std::fs::write(dir.join("curves/cell.csv"), CURVE).unwrap();
    let set = FlightSet::read(&dir).unwrap();
    let r = record_from_log(&set.flights[0]).unwrap();
    assert_eq!(r.info.ceiling_height_m, Some(3.2));
    assert_eq!(
        r.info.measured_ocv,
        Some(LearnedBattery::from_ocv_csv(CURVE).unwrap())
    );
    // Without the keys: no curve, no ceiling.
    std::fs::write(
        dir.join("flights.toml"),
        "cells = 3\nbattery_energy_wh = 40.0\n",
    )
    .unwrap();
    std::fs::remove_file(dir.join("a.toml")).unwrap();
    let set = FlightSet::read(&dir).unwrap();
    let r = record_from_log(&set.flights[0]).unwrap();
    assert_eq!((r.info.ceiling_height_m, r.info.measured_ocv), (None, None));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_curve_that_does_not_read_names_the_flight_the_files_the_key_and_the_line() {
    let dir = scratch("bad");
    write_log(&dir, "b");
    std::fs::write(
        dir.join("flights.toml"),
        "cells = 3\nbattery_energy_wh = 40.0\n",
    )
    .unwrap();
    std::fs::write(dir.join("b.toml"), "battery_ocv_csv = \"curves/bad.csv\"\n").unwrap();
    std::fs::write(
        dir.join("curves/bad.csv"),
        "soc,ocv_v\n0,3.0\nhalf,3.7\n1,4.2\n",
    )
    .unwrap();
    let set = FlightSet::read(&dir).unwrap();
    let e = record_from_log(&set.flights[0]).unwrap_err();
    assert!(matches!(e, GapError::BatteryCurve { .. }), "{e}");
    let text = e.to_string();
    for want in [
        "flight b",
        "battery_ocv_csv",
        "bad.csv",
        "b.toml",
        "line 3",
        "half",
    ] {
        assert!(text.contains(want), "{want:?} not in {text}");
    }
    // A file that is not there.
    std::fs::write(
        dir.join("b.toml"),
        "battery_ocv_csv = \"curves/none.csv\"\n",
    )
    .unwrap();
    let set = FlightSet::read(&dir).unwrap();
    let text = record_from_log(&set.flights[0]).unwrap_err().to_string();
    assert!(
        text.contains("none.csv") && text.contains("reading it") && text.contains("b.toml"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
