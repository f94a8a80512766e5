//! Flight folders: formats side by side, metadata merging, bad flights skipped with reasons.

mod common;

use std::path::Path;

use common::{DataFlashWriter, ULOG_FORMATS, UlogWriter, battery_status};
use flightlog::{End, FlightLogError, FlightSet, LogFormat, PhaseSource, crazyflie};

fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) {
    std::fs::write(dir.join(name), contents).unwrap();
}

fn ulog() -> Vec<u8> {
    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[0]);
    w.subscribe(0, 0, "battery_status");
    for k in 0..30u64 {
        w.data(0, &battery_status(k * 100_000, 11.1, 4.0));
    }
    w.finish()
}

fn dataflash() -> Vec<u8> {
    let mut w = DataFlashWriter::new();
    w.define(150, "BAT", "QBff", "TimeUS,Instance,Volt,Curr");
    for k in 0..30 {
        w.write(150, &[f64::from(k) * 1e5, 0.0, 12.0, 12.0]);
    }
    w.finish()
}

#[test]
fn mixed_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(
        d,
        "flights.toml",
        "# bench defaults\nstructure_mass_kg = 0.416\nbattery_mass_kg = 0.144\n\
         battery_energy_density_wh_per_kg = 164.0\ncells = 3\navionics_power_w = 2.44\n\
         end = \"cutoff\"\n",
    );
    write(
        d,
        "hover2.csv",
        "time_s,voltage_v,current_a,phase\n0,12.5,9,hover\n1,12.4,9,hover\n2,12.3,9,hover\n",
    );
    write(
        d,
        "hover2.toml",
        "battery_energy_wh = 22.0\nend = \"landed\"\nbattery_id = \"A\"\nbattery_cycles = 12\n",
    );
    write(
        d,
        "hover10.csv",
        "time_s,voltage_v\n0,12.5\n0.5,12.4\n1,12.3\n",
    );
    write(
        d,
        "backwards.csv",
        "time_s,voltage_v\n0,12.5\n1,12.4\n0.5,12.3\n",
    );
    write(d, "typo.csv", "time_s,voltage_v\n0,12.5\n1,12.4\n");
    write(d, "typo.toml", "cells = 3\nbattery_mas_kg = 0.1\n");
    write(d, "px4.ulg", ulog());
    write(d, "copter.BIN", dataflash());
    write(d, "broken.bin", b"\xA3\x95\x80garbage");
    write(
        d,
        "cf.csv",
        "x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4.1\n0,0,0,4.1\n0,0,0.5,4.0\n",
    );
    // The folder's 3 cells do not fit a Crazyflie's 4 V: its sidecar says 1 cell; a second
    // Crazyflie log without one is skipped, saying why.
    write(d, "cf.toml", "cells = 1\n");
    write(
        d,
        "cf3.csv",
        "x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4.1\n0,0,0,4.1\n0,0,0.5,4.0\n",
    );
    write(d, "orphan.toml", "cells = 2\n");
    write(d, "README.md", "not a flight");

    let set = FlightSet::read(d).unwrap();
    let names: Vec<&str> = set.flights.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["cf", "copter", "hover2", "hover10", "px4"]);
    let skipped: Vec<String> = set
        .skipped
        .iter()
        .map(|s| s.path.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        skipped,
        [
            "backwards.csv",
            "broken.bin",
            "cf3.csv",
            "typo.csv",
            "orphan.toml"
        ]
    );

    // Reasons name the file and where.
    let reason = |name: &str| {
        set.skipped
            .iter()
            .find(|s| s.path.ends_with(name))
            .unwrap()
            .reason
            .to_string()
    };
    assert!(
        reason("backwards.csv").contains("line 4"),
        "{}",
        reason("backwards.csv")
    );
    let typo = &set
        .skipped
        .iter()
        .find(|s| s.path.ends_with("typo.csv"))
        .unwrap()
        .reason;
    assert!(
        matches!(typo, FlightLogError::Toml { line: 2, column: 1, message, path }
            if message.contains("battery_mas_kg") && path.ends_with("typo.toml")),
        "{typo}"
    );
    assert!(reason("broken.bin").contains("broken.bin"));

    // Metadata: sidecar over folder defaults; battery energy taken as one quantity.
    assert_eq!(set.defaults.cells, Some(3));
    let h2 = set.get("hover2").unwrap();
    assert_eq!(h2.phase_source, PhaseSource::Logged);
    assert_eq!(h2.meta.end, Some(End::Landed));
    assert_eq!(h2.meta.battery_energy_wh, Some(22.0));
    assert_eq!(h2.meta.battery_energy_density_wh_per_kg, None);
    assert_eq!(h2.meta.structure_mass_kg, Some(0.416));
    assert_eq!(h2.meta.battery_id.as_deref(), Some("A"));
    let h10 = set.get("hover10").unwrap();
    assert_eq!(h10.meta.end, Some(End::Cutoff));
    assert!((h10.meta.battery_energy().unwrap() - 0.144 * 164.0).abs() < 1e-12);
    assert_eq!(h10.phase_source, PhaseSource::None);

    // Crazyflie by header: platform defaults under the folder's.
    let cf = set.get("cf").unwrap();
    assert_eq!(cf.format, LogFormat::Crazyflie);
    assert_eq!(cf.meta.structure_mass_kg, Some(0.416));
    assert_eq!(cf.meta.battery_mass_kg, Some(0.144));
    assert_eq!(
        cf.meta.payload_mass_kg,
        crazyflie::platform_defaults().payload_mass_kg
    );
    // The folder gives a density, which replaces the platform's energy.
    assert_eq!(cf.meta.battery_energy_wh, None);
    assert_eq!(cf.meta.cells, Some(1));
    assert_eq!(cf.metadata["cells"].source.to_string(), "sidecar (cf.toml)");
    assert_eq!(
        cf.metadata["payload_mass_kg"].source.to_string(),
        "default (Crazyflie 2.0 platform)"
    );
    assert_eq!(
        cf.metadata["structure_mass_kg"].source.to_string(),
        "folder (flights.toml)"
    );
    let why = reason("cf3.csv");
    assert!(
        why.contains("implausible for 3 cells") && why.contains("folder (flights.toml)"),
        "{why}"
    );

    assert_eq!(set.get("px4").unwrap().format, LogFormat::Ulog);
    let copter = set.get("copter").unwrap();
    assert_eq!(copter.format, LogFormat::DataFlash);
    assert_eq!(copter.samples.power_w().unwrap()[0], 12.0 * 12.0);
}

#[test]
fn folder_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let err = FlightSet::read(tmp.path()).unwrap_err();
    assert!(matches!(err, FlightLogError::NoFlights { .. }), "{err}");
    let err = FlightSet::read(&tmp.path().join("absent")).unwrap_err();
    assert!(matches!(err, FlightLogError::Io { .. }), "{err}");

    write(tmp.path(), "a.csv", "time_s,voltage_v\n0,12\n1,12\n");
    write(tmp.path(), "flights.toml", "cells = 0\n");
    let err = FlightSet::read(tmp.path()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::Meta { line: 1, key, .. } if key == "cells"),
        "{err}"
    );
    write(tmp.path(), "flights.toml", "end = \"crashed\"\n");
    let err = FlightSet::read(tmp.path()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::Toml { line: 1, .. }),
        "{err}"
    );
}

#[test]
fn explicit_file_list() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(d, "a.csv", "time_s,voltage_v\n0,12\n1,12\n");
    write(d, "b.csv", "time_s\n0\n");
    let set =
        FlightSet::read_files(d, &[d.join("b.csv"), d.join("a.csv"), d.join("c.csv")]).unwrap();
    assert_eq!(set.flights.len(), 1);
    assert_eq!(set.skipped.len(), 2);
    assert!(matches!(set.skipped[1].reason, FlightLogError::Io { .. }));
}

/// A vehicle that does not hover gets no flight phases, and a warning says why; the same
/// samples from a multirotor are given their phases.
#[test]
fn a_vehicle_that_does_not_hover_gets_no_phases() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let mut csv = String::from("time_s,voltage_v,current_a,altitude_m\n");
    for k in 0..120 {
        let t = f64::from(k);
        let (i, z) = if (10..110).contains(&k) {
            (12.0, 5.0)
        } else {
            (0.3, 0.0)
        };
        csv.push_str(&format!("{t},{:.3},{i},{z}\n", 12.4 - 0.005 * t));
    }
    for (kind, phases) in [
        ("fixed_wing", false),
        ("rover", false),
        ("multirotor", true),
        ("helicopter", true),
    ] {
        write(d, "f.csv", &csv);
        write(d, "f.toml", format!("vehicle = \"{kind}\"\ncells = 3\n"));
        let set = FlightSet::read(d).unwrap();
        let f = &set.flights[0];
        assert_eq!(f.samples.phase.is_some(), phases, "{kind}");
        let warned = f.warnings.iter().any(|w| w.contains("does not hover"));
        assert_eq!(warned, !phases, "{kind}: {:?}", f.warnings);
        assert_eq!(f.not_hovering().is_some(), !phases, "{kind}");
        if !phases {
            assert_eq!(f.phase_source, PhaseSource::None);
            assert!(
                f.not_hovering()
                    .unwrap()
                    .contains("according to the sidecar"),
                "{:?}",
                f.not_hovering()
            );
        }
    }
}
