//! The real Crazyflie 2.0 dataset in `../shared/data/real/crazyflie/` (CC-BY-SA-4.0; read in
//! place, not copied).

use std::path::{Path, PathBuf};

use flightlog::{Flight, FlightSet, LogFormat, Phase, PhaseSource, crazyflie};

/// Waypoints in `Planned_trajectories/Trajectories_2.csv` (22 lines: header and 21 rows).
const PLAN_2_ROWS: usize = 21;
/// Its second waypoint.
const PLAN_2_SECOND: [f64; 3] = [0.75, 1.02, 0.5];

fn dataset() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/real/crazyflie")
}

#[test]
fn one_flight_reads_as_the_readme_describes() {
    let path = dataset().join("Real_path/Real_path_1.csv");
    let flight = Flight::read(&path).unwrap();
    assert_eq!(flight.format, LogFormat::Crazyflie);
    assert_eq!(flight.name, "Real_path_1");
    let s = &flight.samples;
    assert!(s.is_consistent());
    // 7950 rows after the header at 100 Hz.
    assert_eq!(s.len(), 7950);
    assert!((s.time_s[1] - 0.01).abs() < 1e-12);
    assert!((s.duration_s() - 79.49).abs() < 1e-9);
    assert!(s.current_a.is_none());
    let first_v = s.voltage_v[0];
    assert!((first_v - 4.05395936965942).abs() < 1e-12);
    assert!((s.altitude_m.as_ref().unwrap()[0] + 0.22).abs() < 1e-12);
    // Phases from altitude: on the ground at first, in the air later, never attached.
    let phases = s.phase.as_ref().unwrap();
    assert_eq!(phases[0], Phase::Ground);
    assert!(phases.iter().any(|p| p.is_flying()));
    assert!(!phases.contains(&Phase::Attached));
    let PhaseSource::Inferred { method, notes } = &flight.phase_source else {
        panic!("{:?}", flight.phase_source)
    };
    assert_eq!(method.signals, flightlog::InferenceSignals::Altitude);
    assert!(method.fractions.ground < 0.5, "{method}");
    assert!(notes.iter().any(|n| n.contains("no current")));
    // Platform defaults.
    assert_eq!(flight.meta, crazyflie::platform_defaults());
}

#[test]
fn folder_layout_subset_with_plans_and_override() {
    // A copy of the layout with three flights (one broken) and a flights.toml override.
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::create_dir_all(root.join("Real_path")).unwrap();
    std::fs::create_dir_all(root.join("Planned_trajectories")).unwrap();
    for n in [2, 10] {
        for (dir, stem) in [
            ("Real_path", "Real_path"),
            ("Planned_trajectories", "Trajectories"),
        ] {
            let name = format!("{stem}_{n}.csv");
            std::fs::copy(dataset().join(dir).join(&name), root.join(dir).join(&name)).unwrap();
        }
    }
    std::fs::write(
        root.join("Real_path/Real_path_3.csv"),
        "x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4.0\n0,0,0,oops\n",
    )
    .unwrap();
    std::fs::write(
        root.join("flights.toml"),
        "battery_mass_kg = 0.0075\nend = \"landed\"\n",
    )
    .unwrap();
    std::fs::write(
        root.join("Real_path/Real_path_10.toml"),
        "end = \"cutoff\"\n",
    )
    .unwrap();

    let set = FlightSet::read(root).unwrap();
    let names: Vec<&str> = set.flights.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["Real_path_2", "Real_path_10"]);
    assert_eq!(set.skipped.len(), 1);
    let reason = set.skipped[0].reason.to_string();
    assert!(
        reason.contains("Real_path_3.csv")
            && reason.contains("line 3")
            && reason.contains("battery_voltage"),
        "{reason}"
    );
    assert_eq!(set.defaults.battery_mass_kg, Some(0.0075));
    assert_eq!(
        set.defaults.structure_mass_kg,
        crazyflie::platform_defaults().structure_mass_kg
    );
    let f2 = set.get("Real_path_2").unwrap();
    assert_eq!(f2.meta.end, Some(flightlog::End::Landed));
    assert_eq!(f2.meta.battery_mass_kg, Some(0.0075));
    let plan = f2.planned_waypoints_m.as_ref().unwrap();
    assert_eq!(plan.len(), PLAN_2_ROWS);
    assert_eq!(plan[1], PLAN_2_SECOND);
    assert_eq!(
        set.get("Real_path_10").unwrap().meta.end,
        Some(flightlog::End::Cutoff)
    );
}

/// All 90 flights (735,170 rows, 23 MB). Its speed is a benchmark's business, not a test's
/// (shared 2-core machines are too noisy for timed tests).
#[test]
fn full_dataset() {
    let set = FlightSet::read(&dataset()).unwrap();
    assert_eq!(set.flights.len(), 90, "{:?}", set.skipped);
    assert!(set.skipped.is_empty());
    let rows: usize = set.flights.iter().map(|f| f.samples.len()).sum();
    assert_eq!(rows, 735_260 - 90);
    assert!(set.flights.iter().all(|f| f.planned_waypoints_m.is_some()));
    assert!(set.flights.iter().all(|f| f.warnings.is_empty()));
}
