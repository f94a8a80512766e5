//! Every decoder, on arbitrary and on corrupted input: an error or a flight, never a panic; and
//! every flight it does return is consistent. 256 cases per property (proptest's default);
//! `PROPTEST_CASES=100000 cargo test --release -p flightlog --test integration never_panics::`
//! for more.

mod common;

use std::path::Path;

use common::{
    DataFlashWriter, ULOG_FORMATS, UlogWriter, battery_status, land_detected, local_position,
};
use flightlog::phase::{self, Signals};
use flightlog::{Flight, FlightMeta, LogFormat};
use proptest::prelude::*;

const FORMATS: [LogFormat; 6] = [
    LogFormat::Csv,
    LogFormat::Crazyflie,
    LogFormat::Ulog,
    LogFormat::DataFlash,
    LogFormat::DataFlashText,
    LogFormat::Tlog,
];

/// The first 40 kB of a real telemetry log (MAVLink 1, `tests/data/tlog/`): a flight of its own.
fn valid_tlog() -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/tlog/dronekit+dronekit-python/flight.tlog");
    let mut bytes = std::fs::read(path).unwrap();
    bytes.truncate(40_000);
    bytes
}

#[test]
fn the_tlog_that_is_corrupted_is_a_flight() {
    let f = Flight::parse(&valid_tlog(), Path::new("t.tlog"), LogFormat::Tlog).unwrap();
    assert!(f.samples.len() >= 10, "{}", f.samples.len());
}

/// A small ArduPilot text log: BAT at 10 Hz, a CTUN, a MSG with commas, a PARM.
fn valid_text_log() -> String {
    let mut s = String::from(
        "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n\
         FMT, 147, 39, BAT, QBfffffcf, TimeUS,Instance,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res\n\
         FMT, 148, 27, CTUN, Qfff, TimeUS,ThO,Alt,CRt\n\
         FMT, 91, 75, MSG, QZ, TimeUS,Message\n\
         FMT, 64, 31, PARM, QNf, TimeUS,Name,Value\n\
         MSG, 100, ArduCopter V4.5.7 (2a3dc4b7)\n\
         MSG, 101, Frame: QUAD, ok\n\
         PARM, 102, BATT_CAPACITY, 5000\n",
    );
    for k in 0..40u64 {
        let us = 1_000_000 + k * 100_000;
        let amps = if k < 10 { 0.3 } else { 9.0 };
        s.push_str(&format!(
            "BAT, {us}, 0, {:.3}, 12.1, {amps}, 0, 0, 25.00, 0.01\nCTUN, {us}, 0.4, {}, 0\n",
            12.0 - k as f64 * 0.01,
            if k < 10 { 0.0 } else { 2.0 }
        ));
    }
    s
}

/// Parses as `format`; checks the invariants of any flight returned.
fn check(bytes: &[u8], format: LogFormat) {
    if let Ok(f) = Flight::parse(bytes, Path::new("fuzz.log"), format) {
        let s = &f.samples;
        assert!(s.is_consistent());
        assert!(s.len() >= 2);
        assert!(s.time_s.windows(2).all(|w| w[1] > w[0]));
        assert!(s.voltage_v.iter().all(|v| v.is_finite() && *v > 0.0));
        if let Some(p) = &s.phase {
            assert_eq!(p.len(), s.len());
        }
        let summary = flightlog::FlightSummary::of(&f);
        assert_eq!(summary.samples, s.len());
        let [lo, hi] = summary.voltage_v.expect("finite voltages give a range");
        assert!(lo <= hi);
        let _ = f.plausibility_warnings();
    }
}

#[test]
fn the_text_log_that_is_corrupted_is_a_flight() {
    let f = Flight::parse(
        valid_text_log().as_bytes(),
        Path::new("t.log"),
        LogFormat::DataFlashText,
    )
    .unwrap();
    assert_eq!(f.samples.len(), 40);
    assert!(f.samples.altitude_m.is_some() && f.samples.throttle.is_some());
    assert_eq!(f.meta.capacity_mah, Some(5000.0));
}

fn valid_ulog() -> Vec<u8> {
    let mut w = UlogWriter::new(7);
    w.flag_bits([0; 8], [0; 3]);
    for f in ULOG_FORMATS {
        w.format(f);
    }
    w.subscribe(0, 0, "battery_status");
    w.subscribe(0, 1, "vehicle_local_position");
    w.subscribe(0, 2, "vehicle_land_detected");
    for k in 0..40u64 {
        w.data(
            0,
            &battery_status(
                k * 100_000,
                12.0 - k as f32 * 0.01,
                if k < 10 { 0.3 } else { 9.0 },
            ),
        );
        w.data(
            1,
            &local_position(k * 100_000, -(k as f32) * 0.05, 0.0, true),
        );
        w.data(2, &land_detected(k * 100_000, k < 10));
    }
    w.finish()
}

fn valid_dataflash() -> Vec<u8> {
    let mut w = DataFlashWriter::new();
    w.define(150, "BAT", "QBffc", "TimeUS,Instance,Volt,Curr,Temp");
    w.define(151, "CTUN", "Qff", "TimeUS,Alt,ThO");
    for k in 0..40 {
        let t = f64::from(k) * 1e5;
        w.write(
            150,
            &[
                t,
                0.0,
                16.0 - f64::from(k) * 0.01,
                if k < 10 { 0.5 } else { 12.0 },
                25.0,
            ],
        );
        w.write(151, &[t, f64::from(k) * 0.05, 0.4]);
    }
    w.finish()
}

const CSV: &str = "time_s,voltage_v,current_a,phase,altitude_m,throttle\n\
                   0,12.6,0.3,ground,0,0\n0.5,12.5,9,climb,0.5,0.5\n1,12.4,9,hover,1,0.5\n";
const CRAZYFLIE: &str = "x_estimate,y_estimate,z_estimate,battery_voltage\n\
                         0,0,-0.2,4.1\n0,0,0.1,4.0\n0,0,0.4,3.9\n";

/// A corruption of `base`: overwrite bytes, then cut or extend.
fn corrupt(base: &[u8], edits: &[(usize, u8)], cut: Option<usize>, tail: &[u8]) -> Vec<u8> {
    let mut b = base.to_vec();
    for &(i, v) in edits {
        if !b.is_empty() {
            let n = b.len();
            b[i % n] = v;
        }
    }
    if let Some(c) = cut {
        b.truncate(c % (base.len() + 1));
    }
    b.extend_from_slice(tail);
    b
}

proptest! {
    #[test]
    fn arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        for format in FORMATS {
            check(&bytes, format);
        }
        let _ = LogFormat::detect(Path::new("x"), &bytes);
    }

    #[test]
    fn arbitrary_bytes_after_a_valid_header(body in proptest::collection::vec(any::<u8>(), 0..800)) {
        let mut u = valid_ulog()[..16].to_vec();
        u.extend_from_slice(&body);
        check(&u, LogFormat::Ulog);
        let mut d = valid_dataflash()[..89].to_vec();
        d.extend_from_slice(&body);
        check(&d, LogFormat::DataFlash);
    }

    #[test]
    fn corrupted_binary_logs(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        cut in proptest::option::of(any::<usize>()),
        tail in proptest::collection::vec(any::<u8>(), 0..40),
    ) {
        check(&corrupt(&valid_ulog(), &edits, cut, &tail), LogFormat::Ulog);
        check(&corrupt(&valid_dataflash(), &edits, cut, &tail), LogFormat::DataFlash);
        check(&corrupt(&valid_tlog(), &edits, cut, &tail), LogFormat::Tlog);
    }

    #[test]
    fn corrupted_text_logs(
        edits in proptest::collection::vec((any::<usize>(), prop::sample::select(b",.\n\r-e0 #\"x\xff".to_vec())), 0..6),
        cut in proptest::option::of(any::<usize>()),
    ) {
        check(&corrupt(CSV.as_bytes(), &edits, cut, b""), LogFormat::Csv);
        check(&corrupt(CRAZYFLIE.as_bytes(), &edits, cut, b""), LogFormat::Crazyflie);
        check(&corrupt(valid_text_log().as_bytes(), &edits, cut, b""), LogFormat::DataFlashText);
        let _ = flightlog::crazyflie::parse_plan(&corrupt(b"x,y,z\n1,2,3\n", &edits, cut, b""), Path::new("p.csv"));
    }

    #[test]
    fn arbitrary_metadata(text in "[a-z_ =\"0-9.\\-\\[\\]\n#]{0,120}") {
        let _ = FlightMeta::parse(&text, Path::new("m.toml"));
        let keys = "structure_mass_kg = 1.0\ncells = 3\nend = \"landed\"\n";
        let _ = FlightMeta::parse(&format!("{keys}{text}"), Path::new("m.toml"));
    }

    #[test]
    fn inference_on_any_signal(
        rows in proptest::collection::vec((0.001f64..2.0, any::<f64>(), any::<f64>(), any::<bool>()), 0..200),
    ) {
        let mut t = Vec::new();
        let mut acc = 0.0;
        for r in &rows {
            acc += r.0;
            t.push(acc);
        }
        let current: Vec<f64> = rows.iter().map(|r| r.1).collect();
        let altitude: Vec<f64> = rows.iter().map(|r| r.2).collect();
        let landed: Vec<bool> = rows.iter().map(|r| r.3).collect();
        for (c, a, l) in [
            (true, true, true), (true, false, false), (false, true, false), (true, true, false), (false, false, true),
        ] {
            let signals = Signals {
                time_s: &t,
                current_a: c.then_some(&current[..]),
                altitude_m: a.then_some(&altitude[..]),
                landed: l.then_some(&landed[..]),
            };
            if let Some((phases, _)) = phase::infer(signals) {
                prop_assert_eq!(phases.len(), t.len());
            }
            // A vehicle that neither perches nor is a VTOL never gets those phases.
            if let Some((phases, _)) = phase::infer_for(signals, &phase::Capabilities::default()) {
                prop_assert_eq!(phases.len(), t.len());
                prop_assert!(!phases.contains(&flightlog::Phase::Attached));
                prop_assert!(!phases.contains(&flightlog::Phase::Transition));
            }
            let vtol = phase::Capabilities { vtol: Some("test".into()), ..Default::default() };
            if let Some((phases, _)) = phase::infer_vtol(signals, &vtol, Some(&landed[..])) {
                prop_assert_eq!(phases.len(), t.len());
                prop_assert!(!phases.contains(&flightlog::Phase::Attached));
            }
        }
    }

    #[test]
    fn natural_order_is_a_total_order_by_number(
        a in "[a-c0-9_]{0,8}", b in "[a-c0-9_]{0,8}", c in "[a-c0-9_]{0,8}",
        x in 0u32..100_000, y in 0u32..100_000,
    ) {
        use std::cmp::Ordering;
        use flightlog::natural_cmp;
        prop_assert_eq!(natural_cmp(&a, &b), natural_cmp(&b, &a).reverse());
        prop_assert_eq!(natural_cmp(&a, &b) == Ordering::Equal, a == b);
        if natural_cmp(&a, &b) != Ordering::Greater && natural_cmp(&b, &c) != Ordering::Greater {
            prop_assert!(natural_cmp(&a, &c) != Ordering::Greater);
        }
        prop_assert_eq!(
            natural_cmp(&format!("flight{x}"), &format!("flight{y}")),
            x.cmp(&y).then_with(|| Ordering::Equal)
        );
    }
}
