//! Generic flight CSV: a header naming the columns, then one row per sample.
//!
//! Required columns: `time_s` (s, strictly increasing, median interval at most 1 s, no hole
//! longer than [`crate::MAX_GAP_S`]) and `voltage_v` (V, positive). Optional: `current_a` (A),
//! `phase` (`ground`, `hover`, `climb`, `descend`, `attached`, `transition`), `altitude_m` (m),
//! `throttle`, and the motor commands `motor1_us`, `motor2_us`, … (PWM µs, one column per motor,
//! consecutive from 1, at most [`crate::motors::MAX_MOTORS`]; a set with a hole or past 16 is
//! an error naming the header's line and the column). Other columns are ignored and listed in the flight's warnings. A UTF-8
//! byte-order mark, `#` comment lines, blank lines and spaces around cells are accepted; every
//! cell of a present column must hold a finite number (or a phase name).
//!
//! Where a column of those exact names is absent, one that other tools write is taken in its
//! place, its unit read from the header ([`alias`]): a name (`time`, `timestamp`, `TimeUS`;
//! `voltage`, `volt`, `vbat`, `vbatLatest`; `current`, `curr`, `amps`, `amperageLatest`;
//! `altitude`, `alt`, `height`; any case) with its unit as a suffix (`_ms`), in brackets
//! (`time (us)`, `Voltage [V]`) or in the name (`TimeUS`). So a PX4 `ulog2csv` export of
//! `battery_status` (`timestamp` in µs, `voltage_v`, `current_a`), Betaflight's
//! `blackbox_decode` CSV (`time (us)`, `vbatLatest (V)`, `amperageLatest (A)`) and ArduPilot's
//! `BAT` exported as CSV (`TimeUS`, `Volt`, `Curr`) and the Crazyflie client's log
//! (`Timestamp` in ms, `pm.vbat`, `stateEstimate.z`) read as they are. A column read so is
//! named in the flight's warnings. A PX4 export (its `discharged_mah` column) also gives the
//! flight's `cells` (`cell_count`) and, when PX4 was told it, `capacity_mah` (`capacity`).

use std::path::Path;

use crate::{Decoded, FlightLogError, Phase, Samples};

/// Columns this format reads.
pub const COLUMNS: [&str; 6] = [
    "time_s",
    "voltage_v",
    "current_a",
    "phase",
    "altitude_m",
    "throttle",
];

/// Parses a flight CSV; `path` names it in errors.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // A spreadsheet saved where the decimal mark is a comma separates fields by semicolons
    // (told by the header: semicolons and no comma); its numbers then read `12,5` as 12.5.
    let semicolon = bytes
        .split(|&b| b == b'\n')
        .map(<[u8]>::trim_ascii)
        .find(|l| !l.is_empty() && !l.starts_with(b"#"))
        .is_some_and(|h| h.contains(&b';') && !h.contains(&b','));
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(if semicolon { b';' } else { b',' })
        .has_headers(false)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(bytes);
    let csv_error = |e: csv::Error| {
        let line = e.position().map_or(0, csv::Position::line);
        let message = match e.kind() {
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => format!("{len} fields where the header has {expected_len}"),
            csv::ErrorKind::Utf8 { err, .. } => {
                format!("not UTF-8 text (field {})", err.field() + 1)
            }
            _ => e.to_string(),
        };
        FlightLogError::Csv {
            path: path.to_owned(),
            line,
            message,
        }
    };

    let mut records = reader.records();
    let header = loop {
        match records.next() {
            None => {
                return Err(FlightLogError::Csv {
                    path: path.to_owned(),
                    line: 1,
                    message: "no header row".to_owned(),
                });
            }
            Some(r) => {
                let r = r.map_err(csv_error)?;
                if r.iter().any(|f| !f.is_empty()) {
                    break r;
                }
            }
        }
    };
    let header_line = header.position().map_or(1, csv::Position::line);
    let names: Vec<String> = header.iter().map(str::to_owned).collect();
    let mut index = [None::<usize>; 6];
    let mut scale = [1.0f64; 6];
    let mut ignored = Vec::new();
    for (i, name) in names.iter().enumerate() {
        match COLUMNS.iter().position(|c| c == name) {
            Some(k) if index[k].is_some() => {
                return Err(FlightLogError::DuplicateColumn {
                    path: path.to_owned(),
                    line: header_line,
                    column: name.clone(),
                });
            }
            Some(k) => index[k] = Some(i),
            None => ignored.push(i),
        }
    }
    // A thrust stand's export has a thrust column and no flight clock: say where it goes.
    let stand = names.iter().any(|n| n.to_lowercase().contains("thrust"));
    // Columns other tools write, for the columns not named exactly (the first of each); not
    // in a thrust stand's export, whose time and voltage are a bench's, not a flight's.
    let mut read_as = Vec::new();
    // The Crazyflie client (cfclient, cflib) writes `Timestamp` in ms since power-on beside
    // its `group.name` variables (`pm.vbat`); PX4's `ulog2csv` in µs.
    let crazyflie_client = names.iter().any(|n| n.eq_ignore_ascii_case("pm.vbat"));
    let timestamp_unit = if crazyflie_client { "ms" } else { "us" };
    ignored.retain(
        |&i| match alias_with(&names[i], timestamp_unit).filter(|_| !stand) {
            Some((k, s)) if index[k].is_none() => {
                index[k] = Some(i);
                scale[k] = s;
                read_as.push(
                    if crazyflie_client && names[i].eq_ignore_ascii_case("timestamp") {
                        format!("{:?} as time_s (ms, the Crazyflie client's)", names[i])
                    } else if s == 1.0 {
                        format!("{:?} as {}", names[i], COLUMNS[k])
                    } else {
                        format!("{:?} as {} (× {s})", names[i], COLUMNS[k])
                    },
                );
                false
            }
            _ => true,
        },
    );
    let motor_columns = motor_columns(&names, &mut ignored, path, header_line)?;
    let ignored: Vec<String> = ignored.iter().map(|&i| names[i].clone()).collect();
    let require = |k: usize| {
        index[k].ok_or_else(|| FlightLogError::MissingColumn {
            path: path.to_owned(),
            column: COLUMNS[k].to_owned(),
            available: names.join(","),
            hint: if stand {
                "; it looks like a thrust-stand log (a thrust column), which `hoverbench import`, `fit` and `rig-gap` read"
            } else {
                ""
            },
        })
    };
    let (i_time, i_volt) = (require(0)?, require(1)?);
    let (i_cur, i_phase, i_alt, i_thr) = (index[2], index[3], index[4], index[5]);
    // A PX4 `ulog2csv` export of `battery_status` (told by PX4's own pair of columns) also
    // says the pack's cells and, when set, its capacity (mAh).
    let px4_column = |name: &str| {
        let has = |n: &str| names.iter().position(|c| c == n);
        has("discharged_mah").and(has(name))
    };
    let (i_cells, i_capacity) = (px4_column("cell_count"), px4_column("capacity"));
    let (mut cells, mut capacity_mah) = (None::<f64>, None::<f64>);

    let mut samples = Samples {
        current_a: i_cur.map(|_| Vec::new()),
        phase: i_phase.map(|_| Vec::new()),
        altitude_m: i_alt.map(|_| Vec::new()),
        throttle: i_thr.map(|_| Vec::new()),
        motor_us: (!motor_columns.is_empty()).then(|| vec![Vec::new(); motor_columns.len()]),
        ..Samples::default()
    };
    let mut lines = Vec::new();
    for record in records {
        let record = record.map_err(csv_error)?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.iter().all(str::is_empty) {
            continue;
        }
        let cell = |i: usize| record.get(i).unwrap_or("");
        let bad = |i: usize, expected: &str| FlightLogError::BadValue {
            path: path.to_owned(),
            line,
            column: names.get(i).cloned().unwrap_or_default(),
            value: cell(i).to_owned(),
            expected: expected.to_owned(),
        };
        let number = |i: usize| -> Result<f64, FlightLogError> {
            let c = cell(i);
            let decimal_comma = semicolon && c.matches(',').count() == 1 && !c.contains('.');
            if decimal_comma {
                c.replace(',', ".").parse::<f64>()
            } else {
                c.parse::<f64>()
            }
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(i, "a finite number"))
        };
        samples.time_s.push(number(i_time)? * scale[0]);
        let v = number(i_volt)? * scale[1];
        if v <= 0.0 {
            return Err(bad(i_volt, "a positive voltage"));
        }
        samples.voltage_v.push(v);
        if let (Some(i), Some(col)) = (i_cur, samples.current_a.as_mut()) {
            col.push(number(i)? * scale[2]);
        }
        if let (Some(i), Some(col)) = (i_alt, samples.altitude_m.as_mut()) {
            col.push(number(i)? * scale[4]);
        }
        if let (Some(i), Some(col)) = (i_thr, samples.throttle.as_mut()) {
            col.push(number(i)?);
        }
        if let Some(cols) = samples.motor_us.as_mut() {
            for (&i, col) in motor_columns.iter().zip(cols) {
                col.push(number(i)?);
            }
        }
        if let (Some(i), Some(col)) = (i_phase, samples.phase.as_mut()) {
            col.push(Phase::parse(cell(i)).ok_or_else(|| {
                bad(
                    i,
                    "a phase (ground, hover, climb, descend, attached, transition)",
                )
            })?);
        }
        let positive = |i: Option<usize>| {
            i.and_then(|i| cell(i).parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        cells = cells.or(positive(i_cells).filter(|c| c.fract() == 0.0 && *c <= 30.0));
        capacity_mah = capacity_mah.or(positive(i_capacity));
        lines.push(line);
    }
    let mut warnings = Vec::new();
    let mut info = crate::LogInfo::default();
    if let Some(c) = cells {
        info.set("cells", "battery_status.cell_count column", |m| {
            m.cells = Some(c as u32);
        });
    }
    if let Some(mah) = capacity_mah {
        info.set("capacity_mah", "battery_status.capacity column", |m| {
            m.capacity_mah = Some(mah);
        });
    }
    info.derive_energy();
    // PX4 writes −1 for a current it does not measure: a column that holds nothing else is no
    // current.
    if let Some(i) = i_cur
        && samples
            .current_a
            .as_ref()
            .is_some_and(|c| !c.is_empty() && c.iter().all(|&a| a < crate::battery::MIN_CURRENT_A))
    {
        samples.current_a = None;
        warnings.push(format!(
            "column {:?} is below {} A throughout (a current not measured, as PX4 logs it): read as no current",
            names[i],
            crate::battery::MIN_CURRENT_A
        ));
    }
    let time_name = &names[i_time];
    crate::check_time(path, &samples.time_s, time_name, |i| {
        format!("line {}", lines.get(i).copied().unwrap_or(header_line))
    })?;
    if !read_as.is_empty() {
        warnings.push(format!("columns read: {}", read_as.join(", ")));
    }
    if !ignored.is_empty() {
        warnings.push(format!("columns ignored: {}", ignored.join(", ")));
    }
    Ok(Decoded {
        samples,
        landed: None,
        warnings,
        info,
    })
}

/// The motor of a motor-command column's name: `motor3_us` → 3 (any case); `None` for any
/// other name.
pub fn motor_number(name: &str) -> Option<usize> {
    let lower = name.to_ascii_lowercase();
    let digits = lower.strip_prefix("motor")?.strip_suffix("_us")?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) || digits.starts_with('0') {
        return None;
    }
    digits.parse().ok()
}

/// The header's motor-command columns (taken out of `ignored`), motor 1 first: they must be
/// `motor1_us` … `motorN_us`, each once, N at most [`crate::motors::MAX_MOTORS`].
fn motor_columns(
    names: &[String],
    ignored: &mut Vec<usize>,
    path: &Path,
    line: u64,
) -> Result<Vec<usize>, FlightLogError> {
    let mut found: Vec<(usize, usize)> = Vec::new();
    ignored.retain(|&i| match motor_number(&names[i]) {
        Some(m) => {
            found.push((m, i));
            false
        }
        None => true,
    });
    found.sort_unstable();
    let fail = |i: usize, message: String| FlightLogError::MotorColumns {
        path: path.to_owned(),
        line,
        column: names[i].clone(),
        message,
    };
    let max = crate::motors::MAX_MOTORS;
    for (k, &(m, i)) in found.iter().enumerate() {
        if k > 0 && found[k - 1].0 == m {
            return Err(FlightLogError::DuplicateColumn {
                path: path.to_owned(),
                line,
                column: names[i].clone(),
            });
        }
        if m > max {
            return Err(fail(
                i,
                format!(
                    "motor {m}: at most {max} motor-command columns (motor1_us … motor{max}_us) are read"
                ),
            ));
        }
        if m != k + 1 {
            return Err(fail(
                i,
                format!(
                    "motor-command columns must be consecutive from motor1_us; motor{}_us is missing",
                    k + 1
                ),
            ));
        }
    }
    Ok(found.into_iter().map(|(_, i)| i).collect())
}

/// The column of [`COLUMNS`] a header name of another tool stands for, and the scale from its
/// unit to that column's (`time (us)` → `time_s`, 1e-6). `None` for a name it does not know,
/// or a known name with a unit that does not fit (`voltage (A)`). The unit is taken from
/// brackets (`(us)`, `[V]`), else a `_unit` suffix, else the name itself (`TimeUS`); without
/// one, a column is in the canonical unit, except `timestamp` (µs, as PX4 writes it).
pub fn alias(header: &str) -> Option<(usize, f64)> {
    alias_with(header, "us")
}

/// [`alias`], with the unit a bare `timestamp` is in (`us` for PX4, `ms` for the Crazyflie
/// client).
pub fn alias_with(header: &str, timestamp_unit: &str) -> Option<(usize, f64)> {
    let lower = header.trim().to_lowercase();
    let (stem, unit) = match lower.find(['(', '[']) {
        Some(open) => {
            let unit = lower[open + 1..].trim_end_matches([')', ']']).trim();
            (lower[..open].trim(), Some(unit.to_owned()))
        }
        None => match lower.rsplit_once('_') {
            Some((stem, u)) if unit_scale(u).is_some() => (stem, Some(u.to_owned())),
            _ => (lower.as_str(), None),
        },
    };
    let stem = stem.trim_end_matches(['_', ' ']);
    // (column, unit when the header gives none, whether the name fixes its unit)
    let (column, default, fixed) = match stem {
        "time" | "t" | "time_boot" | "time_since_start" => (0, None, false),
        "timestamp" => (0, Some(timestamp_unit), false),
        "timeus" => (0, Some("us"), true),
        "timems" => (0, Some("ms"), true),
        "voltage" | "volt" | "volts" | "vbat" | "battery_voltage" | "batteryvoltage"
        | "bat_voltage" | "pack_voltage" | "pm.vbat" => (1, None, false),
        "current" | "curr" | "amps" | "amp" | "amperage" | "battery_current" | "batterycurrent"
        | "bat_current" | "pack_current" => (2, None, false),
        // Betaflight's raw ADC units unless its decoder wrote a unit.
        "vbatlatest" if unit.is_some() => (1, None, false),
        "amperagelatest" if unit.is_some() => (2, None, false),
        "altitude" | "alt" | "height" | "relative_alt" | "rel_alt" | "stateestimate.z"
        | "baroalt" => (4, None, false),
        _ => return None,
    };
    let unit = match (unit, default) {
        (Some(u), Some(d)) if fixed && u != d => return None,
        (Some(u), _) => Some(u),
        (None, d) => d.map(str::to_owned),
    };
    let scale = match unit.as_deref() {
        None => 1.0,
        Some(u) => {
            let (dimension, scale) = unit_scale(u)?;
            if dimension != column {
                return None;
            }
            scale
        }
    };
    Some((column, scale))
}

/// The column a unit measures (0 time, 1 voltage, 2 current, 4 altitude) and its scale to
/// the canonical unit (s, V, A, m).
fn unit_scale(unit: &str) -> Option<(usize, f64)> {
    Some(match unit {
        "s" | "sec" | "secs" | "seconds" => (0, 1.0),
        "ms" => (0, 1e-3),
        "us" | "µs" | "μs" => (0, 1e-6),
        "v" | "volt" | "volts" => (1, 1.0),
        "mv" => (1, 1e-3),
        "a" | "amp" | "amps" => (2, 1.0),
        "ma" => (2, 1e-3),
        "m" => (4, 1.0),
        "cm" => (4, 0.01),
        "mm" => (4, 1e-3),
        "ft" => (4, 0.3048),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Decoded, FlightLogError> {
        parse(s.as_bytes(), Path::new("f.csv"))
    }

    #[test]
    fn reads_all_columns_and_phases() {
        let d = parse_str(
            "\u{feff}# comment\ntime_s, voltage_v, current_a, phase, altitude_m, throttle, note\n\
             0, 12.6, 0.3, ground, 0, 0, a\n1, 12.5, 8, Hover, 1, 0.5, b\n",
        )
        .unwrap();
        assert_eq!(d.samples.time_s, [0.0, 1.0]);
        assert_eq!(d.samples.phase.unwrap(), [Phase::Ground, Phase::Hover]);
        assert_eq!(d.samples.throttle.unwrap(), [0.0, 0.5]);
        assert_eq!(d.warnings, ["columns ignored: note"]);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse_str("time_s,voltage_v\n0,12\n1,x\n").unwrap_err();
        assert!(
            matches!(&e, FlightLogError::BadValue { line: 3, column, .. } if column == "voltage_v"),
            "{e}"
        );
        let e = parse_str("time_s,current_a\n0,1\n").unwrap_err();
        assert!(
            matches!(&e, FlightLogError::MissingColumn { column, .. } if column == "voltage_v")
        );
        assert!(!e.to_string().contains("thrust-stand"), "{e}");
        // An RCbenchmark export handed over as a flight: named for what it looks like.
        let e = parse_str("Time (s),ESC signal (µs),Thrust (kgf),Voltage (V)\n0,1000,0,12\n")
            .unwrap_err();
        assert!(
            e.to_string().ends_with(
                "; it looks like a thrust-stand log (a thrust column), which `hoverbench import`, `fit` and `rig-gap` read"
            ),
            "{e}"
        );
        let e = parse_str("time_s,voltage_v\n0,12\n1,12,3\n").unwrap_err();
        assert!(matches!(&e, FlightLogError::Csv { line: 3, .. }), "{e}");
        // Semicolons between fields and decimal commas: read as numbers; an error still
        // names its line and column.
        let d = parse_str("# de-DE\ntime_s;voltage_v;current_a\n0;12,5;1,25\n1;12;-0,5\n").unwrap();
        assert_eq!(d.samples.voltage_v, [12.5, 12.0]);
        assert_eq!(d.samples.current_a.unwrap(), [1.25, -0.5]);
        let e = parse_str("time_s;voltage_v\n0;12,5\n1;1.234,5\n").unwrap_err();
        assert!(
            matches!(&e, FlightLogError::BadValue { line: 3, column, .. } if column == "voltage_v"),
            "{e}"
        );
        let e = parse_str("time_s,voltage_v\n0,12\n1,12,3\n").unwrap_err();
        assert!(matches!(&e, FlightLogError::Csv { line: 3, .. }), "{e}");
        let e = parse_str("time_s,voltage_v,phase\n0,12,flying\n1,12,hover\n").unwrap_err();
        assert!(e.to_string().contains("a phase"), "{e}");
        let e = parse_str("time_s,voltage_v\n0,12\n1,12\n1,12\n").unwrap_err();
        assert!(e.to_string().contains("line 4"), "{e}");
        let e = parse_str("time_s,voltage_v,time_s\n").unwrap_err();
        assert!(matches!(e, FlightLogError::DuplicateColumn { .. }));
        assert!(parse_str("").is_err());
    }

    #[test]
    fn other_tools_headers_are_read_with_their_units() {
        for (header, column, scale) in [
            ("time (us)", 0, 1e-6),
            ("Time (s)", 0, 1.0),
            ("time_ms", 0, 1e-3),
            ("timestamp", 0, 1e-6),
            ("timestamp (ms)", 0, 1e-3),
            ("TimeUS", 0, 1e-6),
            ("time_boot_ms", 0, 1e-3),
            ("vbatLatest (V)", 1, 1.0),
            ("Voltage [V]", 1, 1.0),
            ("Volt", 1, 1.0),
            ("vbat_mv", 1, 1e-3),
            ("amperageLatest (A)", 2, 1.0),
            ("Curr", 2, 1.0),
            ("current (mA)", 2, 1e-3),
            ("Alt", 4, 1.0),
            ("altitude_cm", 4, 0.01),
            ("BaroAlt (cm)", 4, 0.01),
        ] {
            assert_eq!(alias(header), Some((column, scale)), "{header}");
        }
        // A unit of another quantity, a name that fixes another unit, raw ADC units, unknowns.
        for header in [
            "voltage (A)",
            "TimeUS (ms)",
            "vbatLatest",
            "amperageLatest",
            "voltage_filtered_v",
            "VoltR",
            "CurrTot",
            "remaining",
            "",
        ] {
            assert_eq!(alias(header), None, "{header}");
        }
    }

    #[test]
    fn a_px4_ulog2csv_battery_export_reads_as_it_is() {
        // `ulog2csv -m battery_status`: `timestamp` in µs beside `voltage_filtered_v`.
        let d = parse_str(
            "timestamp,connected,voltage_v,voltage_filtered_v,current_a,current_filtered_a,remaining\n\
             35000000,1,16.4,16.41,0.5,0.5,1\n35100000,1,16.3,16.32,12.5,12.0,0.99\n",
        )
        .unwrap();
        assert_eq!(d.samples.time_s, [35.0, 35.1]);
        assert_eq!(d.samples.voltage_v, [16.4, 16.3]);
        assert_eq!(d.samples.current_a.unwrap(), [0.5, 12.5]);
        assert_eq!(
            d.warnings,
            [
                "columns read: \"timestamp\" as time_s (× 0.000001)",
                "columns ignored: connected, voltage_filtered_v, current_filtered_a, remaining"
            ]
        );
        // A battery that measures no current logs −1: no current.
        let d = parse_str("timestamp,voltage_v,current_a\n0,12,-1\n100000,12,-1\n").unwrap();
        assert!(d.samples.current_a.is_none());
        assert!(
            d.warnings[0].contains("read as no current"),
            "{:?}",
            d.warnings
        );
    }

    #[test]
    fn betaflight_and_ardupilot_csv_exports_read_as_they_are() {
        // blackbox_decode: spaces after the commas, units in brackets, many other columns.
        let d = parse_str(
            "loopIteration, time (us), axisP[0], vbatLatest (V), amperageLatest (A), rcCommand[3]\n\
             0, 1000000, 3, 16.20, 1.50, 1200\n1, 1002000, 4, 16.18, 9.75, 1500\n",
        )
        .unwrap();
        assert_eq!(d.samples.time_s, [1.0, 1.002]);
        assert_eq!(d.samples.voltage_v, [16.2, 16.18]);
        assert_eq!(d.samples.current_a.unwrap(), [1.5, 9.75]);
        // Mission Planner's CSV of BAT: TimeUS, Volt, Curr (VoltR and CurrTot are not them).
        let d = parse_str(
            "TimeUS,Instance,Volt,VoltR,Curr,CurrTot\n5000000,0,12.5,12.6,8,10\n5100000,0,12.4,12.6,8.1,10.2\n",
        )
        .unwrap();
        assert_eq!(d.samples.time_s, [5.0, 5.1]);
        assert_eq!(d.samples.current_a.unwrap(), [8.0, 8.1]);
        // The exact names win over another tool's; a missing column still says what it needs.
        let d = parse_str("time_s,timestamp,voltage_v\n0,7,12\n1,9,12\n").unwrap();
        assert_eq!(d.samples.time_s, [0.0, 1.0]);
        let e = parse_str("vbatLatest,time (us)\n1600,0\n").unwrap_err();
        assert!(e.to_string().contains("no column \"voltage_v\""), "{e}");
    }

    #[test]
    fn a_crazyflie_client_log_reads_its_timestamp_in_ms() {
        let d = parse_str("Timestamp,pm.vbat,stateEstimate.z\n9103,3.74,0.0\n9113,3.73,0.01\n")
            .unwrap();
        assert_eq!(d.samples.time_s, [9.103, 9.113]);
        assert_eq!(d.samples.voltage_v, [3.74, 3.73]);
        assert_eq!(d.samples.altitude_m.unwrap(), [0.0, 0.01]);
        assert!(
            d.warnings[0].contains("ms, the Crazyflie client's"),
            "{:?}",
            d.warnings
        );
    }

    #[test]
    fn motor_columns_are_consecutive_from_one() {
        let d = parse_str(
            "time_s,voltage_v,Motor2_us,motor1_us,note\n0,12,1100,1000,a\n1,12,1200.5,1300,b\n",
        )
        .unwrap();
        // Motor 1 first, whatever the header's order.
        assert_eq!(
            d.samples.motor_us.unwrap(),
            [vec![1000.0, 1300.0], vec![1100.0, 1200.5]]
        );
        assert_eq!(d.warnings, ["columns ignored: note"]);
        assert!(
            parse_str("time_s,voltage_v\n0,12\n1,12\n")
                .unwrap()
                .samples
                .motor_us
                .is_none()
        );
        // A hole, a start past 1, a duplicate, more than 16, a bad cell: errors with context.
        let e = parse_str("time_s,voltage_v,motor1_us,motor3_us\n0,12,1,1\n").unwrap_err();
        assert!(
            matches!(&e, FlightLogError::MotorColumns { line: 1, column, .. } if column == "motor3_us"),
            "{e}"
        );
        assert!(e.to_string().contains("motor2_us is missing"), "{e}");
        let e = parse_str("time_s,voltage_v,motor2_us\n0,12,1\n").unwrap_err();
        assert!(e.to_string().contains("motor1_us is missing"), "{e}");
        let e = parse_str("time_s,voltage_v,motor1_us,MOTOR1_us\n0,12,1,1\n").unwrap_err();
        assert!(matches!(e, FlightLogError::DuplicateColumn { .. }), "{e}");
        let header: Vec<String> = (1..=17).map(|m| format!("motor{m}_us")).collect();
        let row = vec!["1500"; 17].join(",");
        let e = parse_str(&format!(
            "time_s,voltage_v,{}\n0,12,{row}\n",
            header.join(",")
        ))
        .unwrap_err();
        assert!(
            matches!(&e, FlightLogError::MotorColumns { column, .. } if column == "motor17_us"),
            "{e}"
        );
        let header16 = header[..16].join(",");
        let row16 = vec!["1500"; 16].join(",");
        let d = parse_str(&format!(
            "time_s,voltage_v,{header16}\n0,12,{row16}\n1,12,{row16}\n"
        ))
        .unwrap();
        assert_eq!(d.samples.motor_us.unwrap().len(), 16);
        let e = parse_str("time_s,voltage_v,motor1_us\n0,12,1000\n1,12,nan\n").unwrap_err();
        assert!(
            matches!(&e, FlightLogError::BadValue { line: 3, column, .. } if column == "motor1_us"),
            "{e}"
        );
        // Names that are not motor commands stay other columns.
        for name in [
            "motor_us",
            "motor01_us",
            "motor1",
            "motor1_ms",
            "xmotor1_us",
            "motor-1_us",
        ] {
            assert_eq!(motor_number(name), None, "{name}");
        }
    }

    proptest::proptest! {
        #[test]
        fn a_motor_column_name_gives_its_number_back(m in 1usize..100_000, upper: bool) {
            let name = format!("motor{m}_us");
            let name = if upper { name.to_uppercase() } else { name };
            proptest::prop_assert_eq!(motor_number(&name), Some(m));
        }

        #[test]
        fn any_name_is_a_motor_column_only_as_motor_n_us(name in "\\PC{0,16}") {
            if let Some(m) = motor_number(&name) {
                proptest::prop_assert_eq!(name.to_ascii_lowercase(), format!("motor{m}_us"));
            }
        }

        #[test]
        fn any_header_name_is_a_known_column_with_a_positive_scale_or_none(name in "\\PC{0,24}") {
            if let Some((column, scale)) = alias(&name) {
                proptest::prop_assert!([0, 1, 2, 4].contains(&column));
                proptest::prop_assert!(scale > 0.0 && scale.is_finite());
            }
        }
    }
}
