//! ArduPilot DataFlash: round trips through files built by the test writer.

mod common;

use std::path::Path;

use common::{DataFlashWriter, profile};
use flightlog::{
    Flight, FlightLogError, FlightMeta, InferenceSignals, LogFormat, MetaLayer, MetaSource, Phase,
    PhaseSource,
};

const BAT: u8 = 147;
const CTUN: u8 = 148;
const BARO: u8 = 149;

fn define_standard(w: &mut DataFlashWriter) {
    w.define(
        BAT,
        "BAT",
        "QBfffffcf",
        "TimeUS,Instance,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res",
    );
    w.define(
        CTUN,
        "CTUN",
        "Qffffffefffhh",
        "TimeUS,ThI,ABst,ThO,ThH,DAlt,Alt,BAlt,DSAlt,SAlt,TAlt,DCRt,CRt",
    );
    w.define(
        BARO,
        "BARO",
        "QBfffcfIffB",
        "TimeUS,I,Alt,AltAMSL,Press,Temp,CRt,SMS,Offset,GndTemp,Health",
    );
}

/// The profile: BAT at 10 Hz (two instances), CTUN at 25 Hz, BARO at 5 Hz.
fn profile_log(with_ctun: bool) -> Vec<u8> {
    let mut w = DataFlashWriter::new();
    define_standard(&mut w);
    for k in 0..=1200 {
        let t = f64::from(k) * 0.04;
        let us = 5e6 + t * 1e6;
        let (alt, current, _) = profile(t);
        if k % 10 == 0 || k % 10 == 5 {
            // BAT at 20 Hz alternating instances 0 and 1: 10 Hz each.
            if k % 10 == 0 {
                let v = common::voltage(t, current);
                w.write(BAT, &[us, 0.0, v, v + 0.1, current, 0.0, 0.0, 25.0, 0.01]);
            } else {
                w.write(BAT, &[us, 1.0, 5.0, 5.0, 50.0, 0.0, 0.0, 25.0, 0.01]);
            }
        }
        let throttle = if current > 1.0 { 0.45 } else { 0.0 };
        if with_ctun {
            w.write(
                CTUN,
                &[
                    us, 0.0, 0.0, throttle, 0.4, alt, alt, alt, 0.0, 0.0, 0.0, 0.0, 0.0,
                ],
            );
        }
        if k % 5 == 0 {
            w.write(
                BARO,
                &[
                    us,
                    0.0,
                    alt + 100.0,
                    0.0,
                    101_325.0,
                    20.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    1.0,
                ],
            );
        }
    }
    w.finish()
}

fn parse(bytes: &[u8]) -> Result<Flight, FlightLogError> {
    Flight::parse(bytes, Path::new("copter.bin"), LogFormat::DataFlash)
}

#[test]
fn round_trip_with_ctun() {
    let mut flight = parse(&profile_log(true)).unwrap();
    // Nothing says this robot perches: its ceiling period is no `attached` phase.
    assert!(
        !flight
            .samples
            .phase
            .as_ref()
            .unwrap()
            .contains(&Phase::Attached),
        "{:?}",
        flight.phase_source
    );
    let perches = FlightMeta {
        perches: Some(true),
        ..FlightMeta::default()
    };
    flight.set_metadata(
        &[],
        &[MetaLayer::new(
            perches,
            MetaSource::Sidecar {
                path: "copter.toml".into(),
            },
        )],
    );
    assert_eq!(
        flight.metadata["perches"].source.to_string(),
        "sidecar (copter.toml)"
    );
    let s = &flight.samples;
    assert!(s.is_consistent());
    assert_eq!(s.len(), 121);
    assert!((s.duration_s() - common::PROFILE_S).abs() < 1e-9);
    for (k, (&t, &v)) in s.time_s.iter().zip(&s.voltage_v).enumerate() {
        assert!((t - k as f64 * 0.4).abs() < 1e-9, "{t}");
        let expected = common::voltage(t, profile(t).1) as f32;
        assert_eq!(v, f64::from(expected));
    }
    let altitude = s.altitude_m.as_ref().unwrap();
    assert!((altitude[30] - 2.0).abs() < 1e-6); // t = 12 s
    assert_eq!(s.throttle.as_ref().unwrap()[30], f64::from(0.45f32));
    let phases = s.phase.as_ref().unwrap();
    assert_eq!(phases[5], Phase::Ground);
    assert_eq!(phases[30], Phase::Hover);
    assert_eq!(phases[70], Phase::Attached);
    assert_eq!(phases[100], Phase::Descend);
    let PhaseSource::Inferred { method, .. } = &flight.phase_source else {
        panic!()
    };
    assert_eq!(method.signals, InferenceSignals::CurrentAndAltitude);
    let attached = method
        .evidence
        .iter()
        .find(|e| e.phase == Phase::Attached)
        .unwrap();
    assert!(
        attached.evidence.contains("perches = true from sidecar"),
        "{attached:?}"
    );
    assert!(flight.warnings.is_empty(), "{:?}", flight.warnings);
}

#[test]
fn baro_altitude_when_no_ctun() {
    let flight = parse(&profile_log(false)).unwrap();
    let altitude = flight.samples.altitude_m.as_ref().unwrap();
    assert!((altitude[30] - 102.0).abs() < 1e-4);
    assert!(flight.samples.throttle.is_none());
}

/// A BAT message of instance 0 at `time_us`: 12 V, 3 A.
fn steady_bat(w: &mut DataFlashWriter, time_us: f64) {
    w.write(BAT, &[time_us, 0.0, 12.0, 12.0, 3.0, 0.0, 0.0, 20.0, 0.0]);
}

#[test]
fn garbage_is_skipped_and_counted() {
    let mut w = DataFlashWriter::new();
    define_standard(&mut w);
    for k in 0..10 {
        steady_bat(&mut w, f64::from(k) * 1e5);
        if k == 4 {
            w.raw(&[0xFF; 37]);
            w.raw(&[0xA3, 0x95, 0x07]); // an undefined type
        }
    }
    w.raw(&[0xA3, 0x95, BAT, 1, 2]); // truncated
    let flight = parse(&w.finish()).unwrap();
    assert_eq!(flight.samples.len(), 10);
    assert!(
        flight.warnings.iter().any(|m| m.contains("40 byte(s)")),
        "{:?}",
        flight.warnings
    );
    assert!(flight.warnings.iter().any(|m| m.contains("truncated")));
}

#[test]
fn old_style_scaled_fields_and_time_ms() {
    let mut w = DataFlashWriter::new();
    w.define(BAT, "BAT", "Icc", "TimeMS,Volt,Curr");
    for k in 0..5 {
        w.write(
            BAT,
            &[f64::from(k) * 100.0, 11.1 - 0.01 * f64::from(k), 2.5],
        );
    }
    let flight = parse(&w.finish()).unwrap();
    assert_eq!(flight.samples.time_s, [0.0, 0.1, 0.2, 0.3, 0.4]);
    assert!((flight.samples.voltage_v[1] - 11.09).abs() < 1e-12);
    assert_eq!(flight.samples.current_a.as_ref().unwrap()[0], 2.5);
}

#[test]
fn arducopter3_curr_in_centivolts_and_cell_voltages() {
    // ArduCopter 3.x: no BAT; CURR with Volt and Curr as centivolts and centiamps ('h') and
    // TimeMS; the per-cell voltages (log structure BCL, message BCL) with NumCells.
    const CURR: u8 = 0x31;
    const BCL: u8 = 0x32;
    let mut w = DataFlashWriter::new();
    w.define(
        CURR,
        "CURR",
        "IhhhHfh",
        "TimeMS,Throttle,Volt,Curr,Vcc,CurrTot,Volt2",
    );
    w.define(BCL, "BCL", "IBfHHH", "TimeMS,NumCells,Volt,V1,V2,V3");
    for k in 0..20u32 {
        let t = f64::from(k) * 100.0 + 5000.0;
        w.write(CURR, &[t, 400.0, 1250.0, 1075.0, 5000.0, 0.0, 0.0]);
        w.write(BCL, &[t, 3.0, 12.5, 4170.0, 4160.0, 4170.0]);
    }
    let f = parse(&w.finish()).unwrap();
    assert_eq!(f.log.battery.as_ref().unwrap().battery, "CURR");
    assert!((f.samples.voltage_v[0] - 12.5).abs() < 1e-12);
    assert!((f.samples.current_a.as_ref().unwrap()[0] - 10.75).abs() < 1e-12);
    assert!((f.samples.time_s[1] - 0.1).abs() < 1e-12);
    assert_eq!(f.meta.cells, Some(3));
    assert_eq!(f.metadata["cells"].source.to_string(), "log (BCL.NumCells)");

    // BCL alone: the pack voltage, no current.
    let mut w = DataFlashWriter::new();
    w.define(BCL, "BCL", "IBfHHH", "TimeMS,NumCells,Volt,V1,V2,V3");
    for k in 0..20u32 {
        w.write(
            BCL,
            &[f64::from(k) * 100.0, 3.0, 12.5, 4170.0, 4160.0, 4170.0],
        );
    }
    let f = parse(&w.finish()).unwrap();
    assert_eq!(f.log.battery.as_ref().unwrap().battery, "BCL");
    assert!(f.samples.current_a.is_none());

    // A 3-cell pack reading 30 V is skipped with the reason.
    let mut w = DataFlashWriter::new();
    w.define(BCL, "BCL", "IBfHHH", "TimeMS,NumCells,Volt,V1,V2,V3");
    for k in 0..20u32 {
        w.write(BCL, &[f64::from(k) * 100.0, 3.0, 30.0, 0.0, 0.0, 0.0]);
    }
    let e = parse(&w.finish()).unwrap_err();
    assert!(e.to_string().contains("implausible for 3 cells"), "{e}");
}

#[test]
fn bad_definitions_and_missing_battery() {
    // A BAT whose FMT length disagrees with its format: its messages are skipped by length,
    // and reading it names the FMT's offset.
    let mut w = DataFlashWriter::new();
    let fmt_at = w.len();
    w.define_with_length(BAT, 20, "BAT", "Qff", "TimeUS,Volt,Curr");
    w.raw(&[0xA3, 0x95, BAT]);
    w.raw(&[0; 17]);
    let err = parse(&w.finish()).unwrap_err();
    let FlightLogError::Binary {
        offset,
        field,
        message,
        ..
    } = &err
    else {
        panic!("{err}")
    };
    assert_eq!((*offset, field.as_str()), (fmt_at as u64, "BAT.FMT"));
    assert!(message.contains("length 20"), "{message}");

    let mut w = DataFlashWriter::new();
    w.define(CTUN, "CTUN", "Qf", "TimeUS,Alt");
    w.write(CTUN, &[0.0, 1.0]);
    let err = parse(&w.finish()).unwrap_err();
    assert!(
        matches!(&err, FlightLogError::MissingData { field, message, .. }
            if field.contains("BAT") && field.contains("CURR") && message.contains("CTUN")),
        "{err}"
    );

    let mut w = DataFlashWriter::new();
    w.define(BAT, "BAT", "QB", "TimeUS,Instance");
    w.write(BAT, &[0.0, 0.0]);
    let err = parse(&w.finish()).unwrap_err();
    assert!(err.to_string().contains("BAT.Volt"), "{err}");

    let err = parse(b"not a log").unwrap_err();
    assert!(matches!(err, FlightLogError::Binary { offset: 0, .. }));
}

#[test]
fn slow_battery_rate_is_refused() {
    let mut w = DataFlashWriter::new();
    define_standard(&mut w);
    for k in 0..5 {
        steady_bat(&mut w, f64::from(k) * 2e6);
    }
    let err = parse(&w.finish()).unwrap_err();
    assert!(err.to_string().contains("1 Hz"), "{err}");
}

#[test]
fn more_labels_than_fields() {
    let mut w = DataFlashWriter::new();
    w.define(BAT, "BAT", "Qf", "TimeUS,Volt,Curr");
    for k in 0..5 {
        w.write(BAT, &[f64::from(k) * 1e5, 12.0]);
    }
    let flight = parse(&w.finish()).unwrap();
    assert_eq!(flight.samples.len(), 5);
    assert!(flight.samples.current_a.is_none());
    assert!(
        flight
            .warnings
            .iter()
            .any(|m| m.contains("3 labels for 2 fields")),
        "{:?}",
        flight.warnings
    );
}
