//! PX4 ULog: round trips through files built by the test writer.

mod common;

use std::path::Path;

use common::{ULOG_FORMATS, UlogWriter, battery_status, land_detected, local_position, profile};
use flightlog::{
    Flight, FlightLogError, FlightMeta, InferenceSignals, LogFormat, MetaLayer, MetaSource, Phase,
    PhaseSource,
};

const T0_US: u64 = 1_000_000;

/// A log of the profile: battery at 10 Hz, local position at 20 Hz, land detector at 1 Hz.
fn profile_log() -> Vec<u8> {
    let mut w = UlogWriter::new(T0_US);
    w.flag_bits([0; 8], [0; 3]);
    w.info("sys_name", "PX4");
    for f in ULOG_FORMATS {
        w.format(f);
    }
    w.subscribe(0, 0, "battery_status");
    w.subscribe(1, 1, "battery_status"); // a second battery: ignored
    w.subscribe(0, 2, "vehicle_local_position");
    w.subscribe(0, 3, "vehicle_land_detected");
    for k in 0..=960 {
        let t = f64::from(k) * 0.05;
        let us = T0_US + (t * 1e6).round() as u64;
        let (alt, current, landed) = profile(t);
        if k % 2 == 0 {
            let v = common::voltage(t, current);
            w.data(0, &battery_status(us, v as f32, current as f32));
            w.data(1, &battery_status(us, 1.0, 99.0));
        }
        w.data(2, &local_position(us, -alt as f32, 0.0, true));
        if k % 20 == 0 {
            w.data(3, &land_detected(us, landed));
        }
        if k == 500 {
            w.logging(us, "Takeoff detected");
            w.dropout(3);
        }
    }
    w.finish()
}

fn parse(bytes: &[u8]) -> Result<Flight, FlightLogError> {
    Flight::parse(bytes, Path::new("flight.ulg"), LogFormat::Ulog)
}

#[test]
fn round_trip() {
    let flight = parse(&profile_log()).unwrap();
    assert_eq!(flight.name, "flight");
    let s = &flight.samples;
    assert!(s.is_consistent());
    assert_eq!(s.len(), 481);
    assert!((s.duration_s() - common::PROFILE_S).abs() < 1e-9);
    for (k, (&t, &v)) in s.time_s.iter().zip(&s.voltage_v).enumerate() {
        assert!((t - k as f64 * 0.1).abs() < 1e-9);
        let expected = common::voltage(t, profile(t).1) as f32;
        assert_eq!(v, f64::from(expected), "sample {k}");
    }
    let current = s.current_a.as_ref().unwrap();
    assert!((current[100] - 9.0).abs() < 1e-6);
    let altitude = s.altitude_m.as_ref().unwrap();
    assert!((altitude[100] - 2.0).abs() < 1e-6);
    assert!((altitude[300] - 2.5).abs() < 1e-6);
    // Nothing says the robot perches: the ceiling period is not `attached`.
    assert_eq!(s.phase.as_ref().unwrap()[280], Phase::Hover);
    let mut flight = flight.clone();
    flight.set_metadata(
        &[],
        &[MetaLayer::new(
            FlightMeta {
                perches: Some(true),
                ..FlightMeta::default()
            },
            MetaSource::Folder {
                path: "flights.toml".into(),
            },
        )],
    );
    let s = &flight.samples;
    let phases = s.phase.as_ref().unwrap();
    assert_eq!(phases[20], Phase::Ground);
    assert_eq!(phases[60], Phase::Climb);
    assert_eq!(phases[120], Phase::Hover);
    assert_eq!(phases[280], Phase::Attached);
    assert_eq!(phases[405], Phase::Descend);
    assert_eq!(phases[470], Phase::Ground);
    let PhaseSource::Inferred { method, .. } = &flight.phase_source else {
        panic!("{:?}", flight.phase_source)
    };
    assert_eq!(method.signals, InferenceSignals::LandDetector);
    assert!(method.current_split_a.is_some_and(|a| a > 0.35 && a < 8.5));
    // The second battery (1 V, 99 A) is skipped, and says why.
    assert_eq!(flight.warnings.len(), 1, "{:?}", flight.warnings);
    assert!(
        flight.warnings[0].contains("skipped battery_status instance 1: median voltage 1.000 V"),
        "{:?}",
        flight.warnings
    );
}

#[test]
fn appended_data_and_truncated_tail() {
    // The main section ends in a cut message; appended data carries on at the given offset.
    let mut w = UlogWriter::new(T0_US);
    let flags_at = w.len();
    w.flag_bits([1, 0, 0, 0, 0, 0, 0, 0], [0; 3]);
    w.format(ULOG_FORMATS[0]);
    w.subscribe(0, 7, "battery_status");
    for k in 0..10u64 {
        w.data(7, &battery_status(T0_US + k * 100_000, 12.0, 5.0));
    }
    w.raw(&[40, 0, b'D', 7, 0, 1, 2]); // cut short
    let appended = w.len() as u64;
    for k in 10..20u64 {
        w.data(7, &battery_status(T0_US + k * 100_000, 11.9, 5.0));
    }
    w.raw(&[200, 0, b'D', 7]); // truncated final message
    let mut bytes = w.finish();
    // Patch the appended offset into the flag bits (payload after 3-byte header, 16 flag bytes).
    let at = flags_at + 3 + 16;
    bytes[at..at + 8].copy_from_slice(&appended.to_le_bytes());
    let flight = parse(&bytes).unwrap();
    assert_eq!(flight.samples.len(), 20);
    assert_eq!(flight.samples.voltage_v[19], f64::from(11.9f32));
    assert!(
        flight.warnings.iter().any(|w| w.contains("truncated")),
        "{:?}",
        flight.warnings
    );
    // No altitude: current only.
    assert!(matches!(
        &flight.phase_source,
        PhaseSource::Inferred { method, .. } if method.signals == InferenceSignals::Current
    ));
}

#[test]
fn unknown_incompatible_flags_are_refused() {
    let mut w = UlogWriter::new(0);
    let at = w.len();
    w.flag_bits([2, 0, 0, 0, 0, 0, 0, 0], [0; 3]);
    let err = parse(&w.finish()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::Binary { offset, .. } if *offset == at as u64),
        "{err}"
    );
}

#[test]
fn missing_battery_and_short_fields_name_offsets() {
    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[3]);
    w.subscribe(0, 0, "vehicle_land_detected");
    w.data(0, &land_detected(0, true));
    let err = parse(&w.finish()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::MissingData { field, message, .. }
            if field == "battery_status" && message.contains("vehicle_land_detected")),
        "{err}"
    );

    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[0]);
    w.subscribe(0, 0, "battery_status");
    w.data(0, &battery_status(0, 12.0, 1.0));
    let short_at = w.len();
    w.data(0, &battery_status(100_000, 12.0, 1.0)[..10]);
    let err = parse(&w.finish()).unwrap_err();
    let FlightLogError::Binary { offset, field, .. } = &err else {
        panic!("{err}")
    };
    assert_eq!(
        (*offset, field.as_str()),
        (short_at as u64, "battery_status.voltage_v")
    );
    assert!(err.to_string().contains("flight.ulg"));
}

#[test]
fn time_backwards_names_the_message() {
    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[0]);
    w.subscribe(0, 0, "battery_status");
    w.data(0, &battery_status(1_000_000, 12.0, 1.0));
    w.data(0, &battery_status(1_100_000, 12.0, 1.0));
    let back_at = w.len();
    w.data(0, &battery_status(1_050_000, 12.0, 1.0));
    let err = parse(&w.finish()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::Time { location, field, .. }
            if *location == format!("byte {back_at}") && field == "battery_status.timestamp"),
        "{err}"
    );
}

#[test]
fn unmeasured_voltage_and_unknown_current() {
    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[0]);
    w.subscribe(0, 0, "battery_status");
    w.data(0, &battery_status(0, 0.0, -1.0));
    for k in 1..5u64 {
        w.data(0, &battery_status(k * 200_000, 12.0, -1.0));
    }
    let flight = parse(&w.finish()).unwrap();
    assert_eq!(flight.samples.len(), 4);
    assert_eq!(flight.samples.time_s[0], 0.0);
    assert!(flight.samples.current_a.is_none());
    assert_eq!(flight.phase_source, PhaseSource::None);
    assert!(
        flight
            .warnings
            .iter()
            .any(|w| w.contains("1 battery_status instance 0 sample"))
    );
}

#[test]
fn read_from_file_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("px4.ulg");
    std::fs::write(&path, profile_log()).unwrap();
    let flight = Flight::read(&path).unwrap();
    assert_eq!(flight.format, LogFormat::Ulog);
    assert_eq!(flight.source, path);
}

/// An `actuator_outputs` message: `noutputs` and the 16 outputs.
fn actuator_outputs(timestamp_us: u64, noutputs: u32, output: [f32; 16]) -> Vec<u8> {
    let mut p = timestamp_us.to_le_bytes().to_vec();
    p.extend_from_slice(&noutputs.to_le_bytes());
    for o in output {
        p.extend_from_slice(&o.to_le_bytes());
    }
    p.extend_from_slice(&[0; 4]);
    p
}

/// A log with a battery at 5 Hz for 2 s and `actuator_outputs` at 10 Hz, 25 ms after each
/// tenth of a second, output `j` of message `k` at 1000 + 10·k + j µs; `CA_ROTOR_COUNT` as an
/// `int32_t` parameter when given.
fn motor_log(rotor_count: Option<i32>, noutputs: u32) -> Vec<u8> {
    let mut w = UlogWriter::new(0);
    w.format(ULOG_FORMATS[0]);
    w.format("actuator_outputs:uint64_t timestamp;uint32_t noutputs;float[16] output;uint8_t[4] _padding0;");
    if let Some(n) = rotor_count {
        let key = "int32_t CA_ROTOR_COUNT";
        let mut p = vec![key.len() as u8];
        p.extend_from_slice(key.as_bytes());
        p.extend_from_slice(&n.to_le_bytes());
        w.message(b'P', &p);
    }
    w.subscribe(0, 0, "battery_status");
    w.subscribe(0, 1, "actuator_outputs");
    for k in 0..=20u64 {
        if k % 2 == 0 {
            w.data(0, &battery_status(k * 100_000, 12.0, 5.0));
        }
        let output: [f32; 16] = std::array::from_fn(|j| 1000.0 + 10.0 * k as f32 + j as f32);
        w.data(1, &actuator_outputs(k * 100_000 + 25_000, noutputs, output));
    }
    w.finish()
}

#[test]
fn motor_commands_from_the_rotor_count_interpolated_onto_the_battery() {
    let flight = parse(&motor_log(Some(6), 8)).unwrap();
    assert!(flight.samples.is_consistent());
    let m = flight.samples.motor_us.as_ref().unwrap();
    assert_eq!(m.len(), 6);
    // Battery sample 1 at 0.2 s: three quarters of the way from message 1 (0.125 s) to 2
    // (0.225 s).
    assert!((m[0][1] - 1017.5).abs() < 1e-9, "{}", m[0][1]);
    assert!((m[5][1] - 1022.5).abs() < 1e-9, "{}", m[5][1]);
    // Battery sample 0 at 0 s, before the first message: its value held.
    assert_eq!(m[2][0], 1002.0);
    assert_eq!(
        flight.log.motors.as_deref(),
        Some("actuator_outputs instance 0, output[0]–output[5] (CA_ROTOR_COUNT 6)")
    );
    // Six rotors asked for, four outputs sent: motor 5 has no command, nothing is read.
    let flight = parse(&motor_log(Some(6), 4)).unwrap();
    assert!(flight.samples.motor_us.is_none());
    assert!(
        flight.warnings.iter().any(|w| w
            == "actuator_outputs.output[4] has no value during the flight: no motor commands read"),
        "{:?}",
        flight.warnings
    );
    // No rotor count and no vehicle type: not read, and said so.
    let flight = parse(&motor_log(None, 8)).unwrap();
    assert!(flight.samples.motor_us.is_none());
    assert!(
        flight.warnings.iter().any(|w| w
            == "actuator_outputs not read as motor commands: no CA_ROTOR_COUNT and no vehicle type"),
        "{:?}",
        flight.warnings
    );
}
