//! Real measurements from other people's rigs (read from `../shared/data/real`, which CI has
//! beside the clone; licences and sources are in each folder there).

use std::path::{Path, PathBuf};

use import::stand::{ColumnMap, LogKind, StandLog, StandOptions};

/// The stand's own power agrees with its voltage × current at every step, within 2 % and
/// `floor_w` (the power monitor's resolution at idle).
fn power_agrees(log: &StandLog, floor_w: f64) {
    for s in &log.steps {
        let (v, i, p) = (
            s.voltage_v.unwrap(),
            s.current_a.unwrap(),
            s.power_w.unwrap(),
        );
        assert!(
            (v * i - p).abs() <= 0.02 * p.abs() + floor_w,
            "{}: {v} V × {i} A vs {p} W",
            log.source_name
        );
    }
}

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real")
        .join(rel)
}

#[test]
fn every_rcbenchmark_export_imports() {
    let dir = shared("rcbenchmark");
    let mut files = 0;
    for entry in std::fs::read_dir(&dir).expect("../shared/data/real/rcbenchmark") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "csv") {
            continue;
        }
        files += 1;
        let log = StandLog::read(&path, &StandOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(log.kind, LogKind::Tyto, "{}", path.display());
        assert!(log.power_logged);
        assert!(!log.steps.is_empty());
        // The stand logs electrical power beside voltage and current: they must agree.
        power_agrees(&log, 0.05);
        for s in &log.steps {
            assert!((1000.0..=2200.0).contains(&s.throttle.unwrap()));
        }
    }
    assert_eq!(files, 12);
}

#[test]
fn rcbenchmark_step_export_gives_one_row_per_step() {
    let log = StandLog::read(
        &shared("rcbenchmark/StepsTest_2020-05-22_102946.csv"),
        &StandOptions::default(),
    )
    .unwrap();
    assert_eq!(log.steps.len(), 21);
    assert_eq!(log.steps[0].throttle, Some(1200.0));
    assert!((log.steps[0].thrust_g - 6.3848).abs() < 1e-3);
    // thrust rises with the ESC command over the step test
    assert!(log.steps.last().unwrap().thrust_g > 5.0 * log.steps[0].thrust_g);
}

#[test]
fn ctu_mrs_table_filters_to_one_motor_and_propeller() {
    let opts = StandOptions {
        filters: vec!["propeller=DJI plastic 9450".parse().unwrap()],
        ..Default::default()
    };
    let log = StandLog::read(&shared("ctu-mrs/motor_tests.csv"), &opts).unwrap();
    assert_eq!(log.kind, LogKind::Hoverbench);
    assert_eq!(log.steps.len(), 6);
    assert_eq!(log.steps[5].thrust_g, 1024.0);
    assert!((log.steps[5].power_w.unwrap() - 232.72).abs() < 1e-9);
}

#[test]
fn mit_gfx_sweep_without_header_or_voltage() {
    let opts = StandOptions {
        names: Some(
            ["esc_us", "torque_nm", "thrust_n", "rpm", "current_a"]
                .map(String::from)
                .to_vec(),
        ),
        columns: ColumnMap {
            throttle: Some("esc_us".into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let log = StandLog::read(&shared("mit-gfx/motor_10inch_prop.txt"), &opts).unwrap();
    // The file sweeps up to 2000 µs and back down: the two readings at 2000 µs form one step.
    let last = log
        .steps
        .iter()
        .find(|s| s.throttle == Some(2000.0))
        .unwrap();
    assert_eq!(last.samples + last.transient_samples, 2);
    // 7.2182 N and 7.1553 N at 2000 µs, averaged: in grams-force.
    assert!(
        (last.thrust_g - (7.2182 + 7.1553) / 2.0 * 101.971_6).abs() < 0.5,
        "{}",
        last.thrust_g
    );
    assert!(last.power_w.is_none(), "no voltage: power cannot be known");
    assert!(last.current_a.is_some());
}

/// A flight log handed to the stand importer is named for what it is (and where it is read),
/// not reported as a CSV parse error at byte 0.
#[test]
fn flight_logs_are_named_not_parsed_as_tables() {
    for (rel, what) in [
        (
            "flightlogs/ulog/pyulog_sample_log_small.ulg",
            "a PX4 ULog flight log",
        ),
        (
            "flightlogs/dataflash/dronekit_log171_copter33_curr.bin",
            "an ArduPilot DataFlash flight log",
        ),
    ] {
        let path = shared(rel);
        let err = StandLog::read(&path, &StandOptions::default()).unwrap_err();
        let text = err.to_string();
        assert!(
            matches!(err, import::ImportError::NotATable { .. }),
            "{rel}: {text}"
        );
        assert!(text.contains(what), "{rel}: {text}");
        assert!(text.contains("hoverbench flights"), "{rel}: {text}");
    }
}

/// Bitcraze's Crazyflie 2.1 stand run (`tests/data/crazyflie-system-id`, MIT): a scale's
/// `weight[g]` as thrust and a power monitor's `v[V]`, `i[A]`, `p[W]` beside the drone's own
/// `vbat[V]`. The monitor's three columns must agree with each other, step by step (within
/// 2 % and 0.1 W: at idle its power reads 0.07 W under its voltage × current).
#[test]
fn a_scale_and_power_monitor_stand_imports() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/crazyflie-system-id/cf21_stock2.csv");
    let log = StandLog::read(&path, &StandOptions::default()).unwrap();
    assert_eq!(log.kind, LogKind::Generic);
    assert_eq!(log.columns.thrust.as_deref(), Some("weight[g]"));
    assert_eq!(log.columns.voltage.as_deref(), Some("v[V]"));
    assert_eq!(log.columns.current.as_deref(), Some("i[A]"));
    assert_eq!(log.columns.power.as_deref(), Some("p[W]"));
    assert!(log.power_logged);
    assert_eq!(log.steps.len(), 17);
    let top = log
        .steps
        .iter()
        .map(|s| s.thrust_g)
        .fold(f64::MIN, f64::max);
    assert!((top - 29.39).abs() < 0.01, "{top}");
    power_agrees(&log, 0.1);
}

/// A Tyto "time constant" test sampled fast (`tests/data/sar-simulation`, MIT, its first 2,000
/// lines): its sensors are logged at different rates, so a third of the rows have an empty
/// thrust or power cell. Those rows are left out and said so; the rest reduce to the throttle
/// steps, where the stand's own power agrees with its voltage × current.
#[test]
fn a_tyto_export_with_sensors_at_different_rates_imports() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/sar-simulation/TimeConstant_Test_2023-12-16_130840_first2000lines.csv");
    let log = StandLog::read(&path, &StandOptions::default()).unwrap();
    assert_eq!(log.kind, LogKind::Tyto);
    assert!(
        log.notes[0].starts_with("687 of 1999 row(s) left out for an empty cell"),
        "{:?}",
        log.notes
    );
    assert_eq!(log.steps.len(), 6);
    power_agrees(&log, 0.1);
    // Thrust rises with the command over the first five steps.
    assert!(
        log.steps[..5]
            .windows(2)
            .all(|w| w[1].thrust_g > w[0].thrust_g)
    );
}
