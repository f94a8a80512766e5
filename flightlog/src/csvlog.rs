//! Generic flight CSV: a header naming the columns, then one row per sample.
//!
//! Required columns: `time_s` (s, strictly increasing, median interval at most 1 s, no hole
//! longer than [`crate::MAX_GAP_S`]) and `voltage_v` (V, positive). Optional: `current_a` (A),
//! `phase` (`ground`, `hover`, `climb`, `descend`, `attached`, `transition`), `altitude_m` (m),
//! `throttle`. Other columns are ignored and listed in the flight's warnings. A UTF-8
//! byte-order mark, `#` comment lines, blank lines and spaces around cells are accepted; every
//! cell of a present column must hold a finite number (or a phase name).

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
            None => ignored.push(name.clone()),
        }
    }
    // A thrust stand's export has a thrust column and no flight clock: say where it goes.
    let stand = names.iter().any(|n| n.to_lowercase().contains("thrust"));
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

    let mut samples = Samples {
        current_a: i_cur.map(|_| Vec::new()),
        phase: i_phase.map(|_| Vec::new()),
        altitude_m: i_alt.map(|_| Vec::new()),
        throttle: i_thr.map(|_| Vec::new()),
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
        samples.time_s.push(number(i_time)?);
        let v = number(i_volt)?;
        if v <= 0.0 {
            return Err(bad(i_volt, "a positive voltage"));
        }
        samples.voltage_v.push(v);
        if let (Some(i), Some(col)) = (i_cur, samples.current_a.as_mut()) {
            col.push(number(i)?);
        }
        if let (Some(i), Some(col)) = (i_alt, samples.altitude_m.as_mut()) {
            col.push(number(i)?);
        }
        if let (Some(i), Some(col)) = (i_thr, samples.throttle.as_mut()) {
            col.push(number(i)?);
        }
        if let (Some(i), Some(col)) = (i_phase, samples.phase.as_mut()) {
            col.push(Phase::parse(cell(i)).ok_or_else(|| {
                bad(
                    i,
                    "a phase (ground, hover, climb, descend, attached, transition)",
                )
            })?);
        }
        lines.push(line);
    }
    crate::check_time(path, &samples.time_s, "time_s", |i| {
        format!("line {}", lines.get(i).copied().unwrap_or(header_line))
    })?;
    let warnings = if ignored.is_empty() {
        Vec::new()
    } else {
        vec![format!("columns ignored: {}", ignored.join(", "))]
    };
    Ok(Decoded {
        samples,
        landed: None,
        warnings,
        info: crate::LogInfo::default(),
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
}
