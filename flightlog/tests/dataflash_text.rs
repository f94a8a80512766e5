//! ArduPilot DataFlash as text (`.log`): every real `.bin` of `../shared/data/real/flightlogs`
//! written out line by line as a converter writes it (scaled fields in their units, text
//! fields as text) reads as the same flight as the `.bin`; and what a text log gets wrong is
//! named by its line.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use flightlog::dataflash::DataFlash;
use flightlog::{Flight, FlightLogError, LogFormat};

fn real(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real/flightlogs")
        .join(rel)
}

/// The text a converter writes for a `.bin`: every `FMT` first, then each type's messages.
fn as_text(bin: &[u8], path: &Path) -> String {
    let log = DataFlash::parse(bin, path).unwrap();
    let mut out = String::from("FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\r\n");
    let names = log.names();
    for name in &names {
        let f = log.format(name).unwrap();
        let format = String::from_utf8(f.format.clone()).unwrap();
        writeln!(
            out,
            "FMT, {}, {}, {}, {}, {}\r",
            f.msg_type,
            f.length,
            f.name,
            format,
            f.labels.join(",")
        )
        .unwrap();
    }
    for name in &names {
        let f = log.format(name).unwrap();
        if f.problem.is_some() {
            continue;
        }
        let fields: Vec<(&str, bool)> = f.labels.iter().map(|l| (l.as_str(), false)).collect();
        let rows = log.rows(name, None, &fields, path).unwrap();
        let texts: Vec<Vec<String>> = f.labels.iter().map(|l| log.texts(name, l)).collect();
        for (i, row) in rows.iter().enumerate() {
            let mut line = (*name).to_owned();
            for (k, v) in row.values.iter().enumerate() {
                line.push_str(", ");
                match (v, f.format[k]) {
                    (_, b'n' | b'N' | b'Z') => line.push_str(&texts[k][i]),
                    (Some(v), _) => write!(line, "{v}").unwrap(),
                    (None, _) => line.push('0'),
                }
            }
            writeln!(out, "{line}\r").unwrap();
        }
    }
    out
}

#[test]
fn every_real_bin_written_as_text_reads_as_the_same_flight() {
    for rel in [
        "dataflash/dronekit_log171_copter33_curr.bin",
        "dataflash/methodicconfigurator_arducopter46_first80k.bin",
        "dataflash/pymavlink_test_arduplane_first64k.BIN",
    ] {
        let path = real(rel);
        let bin = std::fs::read(&path).unwrap();
        let from_bin = Flight::read(&path).unwrap();
        let text = as_text(&bin, &path);
        let log_path = path.with_extension("log");
        assert_eq!(
            LogFormat::detect(&log_path, text.as_bytes()).unwrap(),
            LogFormat::DataFlashText
        );
        let from_text = Flight::parse(text.as_bytes(), &log_path, LogFormat::DataFlashText)
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
        assert_eq!(from_text.format, LogFormat::DataFlashText);
        assert!(!from_text.samples.time_s.is_empty(), "{rel}");
        assert_eq!(from_text.samples, from_bin.samples, "{rel}");
        assert_eq!(from_text.log, from_bin.log, "{rel}");
        assert_eq!(from_text.meta, from_bin.meta, "{rel}");
        assert_eq!(from_text.phase_source, from_bin.phase_source, "{rel}");
    }
}

const HEAD: &str = "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n\
FMT, 147, 39, BAT, QBfffffcf, TimeUS,Instance,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res\n\
FMT, 91, 93, MSG, QZ, TimeUS,Message\n";

/// A text log of `n` BAT lines at 10 Hz and one `MSG` with commas in it.
fn small_log(n: usize) -> String {
    let mut s = HEAD.to_owned();
    s.push_str("MSG, 1000000, ArduCopter V4.5.7 (2a3dc4b7)\n");
    s.push_str("MSG, 1000001, PreArm: Battery 1 low voltage, check cells, now\n");
    for k in 0..n {
        let t = 2_000_000 + k * 100_000;
        let v = 16.4 - 0.001 * k as f64;
        writeln!(
            s,
            "BAT, {t}, 0, {v:.3}, {:.3}, 12.5, 0, 0, 25.00, 0.012",
            v + 0.2
        )
        .unwrap();
    }
    s
}

fn parse(text: &str) -> Result<Flight, FlightLogError> {
    Flight::parse(
        text.as_bytes(),
        Path::new("copter.log"),
        LogFormat::DataFlashText,
    )
}

#[test]
fn a_text_log_reads_its_battery_firmware_and_commas_in_messages() {
    let f = parse(&small_log(600)).unwrap();
    assert_eq!(f.samples.time_s.len(), 600);
    assert!((f.samples.duration_s() - 59.9).abs() < 1e-9);
    assert!((f.samples.voltage_v[0] - 16.4).abs() < 1e-5);
    assert_eq!(f.samples.current_a.as_ref().unwrap()[3], 12.5);
    assert_eq!(
        f.log.firmware.as_deref(),
        Some("ArduCopter V4.5.7 (2a3dc4b7)")
    );
    let log = DataFlash::parse_text(small_log(3).as_bytes(), Path::new("x.log")).unwrap();
    assert_eq!(
        log.texts("MSG", "Message")[1],
        "PreArm: Battery 1 low voltage, check cells, now"
    );
    assert!(log.warnings.is_empty(), "{:?}", log.warnings);
}

#[test]
fn bad_lines_are_skipped_and_counted_and_bad_fmt_lines_named() {
    let mut text = small_log(600);
    text.push_str("BAT, 70000000, 0, twelve, 0, 0, 0, 0, 0, 0\nXYZ, 1, 2\nBAT, 1\n");
    let f = parse(&text).unwrap();
    assert_eq!(f.samples.time_s.len(), 600);
    let log = DataFlash::parse_text(text.as_bytes(), Path::new("x.log")).unwrap();
    let lines = text.lines().count();
    assert_eq!(
        log.warnings,
        [
            format!(
                "1 line(s) of a message type no FMT line defines skipped (first at line {})",
                lines - 1
            ),
            format!(
                "2 line(s) that do not fit their format skipped (first at line {}, BAT: \"twelve\" is not a number)",
                lines - 2
            ),
        ]
    );

    let e = parse("FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\nFMT, 300, 39, BAT, Qf, TimeUS,Volt\n")
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "copter.log, line 2, FMT.Type: \"300\" is not a message type (0–255)"
    );
    let e = parse("time_s,voltage_v\n0,12\n").unwrap_err();
    assert!(e.to_string().contains("not an ArduPilot text log"), "{e}");
    let e = LogFormat::detect(Path::new("ground.log"), b"12:00 connected\n").unwrap_err();
    assert!(e.to_string().contains("not an ArduPilot text log"), "{e}");
}

#[test]
fn a_text_log_without_a_battery_says_what_it_has() {
    let text = format!("{HEAD}MSG, 1000000, ArduCopter V4.5.7\n");
    let e = parse(&text).unwrap_err();
    assert!(
        matches!(
            e,
            FlightLogError::NoUsableBattery { .. } | FlightLogError::MissingData { .. }
        ),
        "{e}"
    );
}
