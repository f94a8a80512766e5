//! The Crazyflie 2.0 battery dataset (Crăciun, "Crazyflie 2.0 battery data", CC-BY-SA-4.0,
//! <https://github.com/RaresCraciun/Crazyflie-2.0-battery-data>).
//!
//! The dataset is a folder with `Real_path/Real_path_N.csv` (header
//! `x_estimate,y_estimate,z_estimate,battery_voltage`: the on-board Kalman filter's position, m,
//! and the battery voltage, V, logged every 10 ms, with no time column and no current) and
//! `Planned_trajectories/Trajectories_N.csv` (header `x,y,z`: the planned waypoints, m). A file
//! is recognised by its header wherever it lies; the folder by its `Real_path/` sub-folder.
//!
//! Time is `row index / 100 Hz` ([`RATE_HZ`]); altitude is `z_estimate`; phases are inferred
//! from the altitude (there is no current, so no attachment). The platform defaults
//! ([`platform_defaults`]) apply below a folder's `flights.toml` and a flight's sidecar.

use std::path::{Path, PathBuf};

use crate::{Decoded, End, FlightLogError, FlightMeta, MetaLayer, MetaSource, Samples};

/// Header of a `Real_path_N.csv`.
pub const HEADER: &str = "x_estimate,y_estimate,z_estimate,battery_voltage";
/// Header of a `Trajectories_N.csv`.
pub const PLAN_HEADER: &str = "x,y,z";
/// Logging rate of the dataset, Hz (one row every 10 ms, per its README).
pub const RATE_HZ: f64 = 100.0;
/// Folder of the flown paths.
pub const REAL_PATH_DIR: &str = "Real_path";
/// Folder of the planned trajectories.
pub const PLAN_DIR: &str = "Planned_trajectories";

/// Bare Crazyflie 2.0 without battery, kg: the 27 g take-off weight of Bitcraze's Crazyflie 2.0
/// datasheet (which includes the stock battery) less the 7.1 g of that battery.
pub const BARE_MASS_KG: f64 = 0.027 - STOCK_BATTERY_MASS_KG;
/// Stock 1S LiPo, kg: 7.1 g (Bitcraze datasheet "240mAh LiPo battery including 500mA USB
/// charger"; the later 250 mAh pack's datasheet gives the same 7.1 g).
pub const STOCK_BATTERY_MASS_KG: f64 = 0.0071;
/// Stock battery capacity, mAh: the Crazyflie 2.0 kit's 240 mAh LiPo (Bitcraze Crazyflie 2.0
/// datasheet, package contents).
pub const STOCK_BATTERY_CAPACITY_MAH: f64 = 240.0;
/// Nominal cell voltage of the stock pack, V (Bitcraze battery datasheet: 3.7 V, 1 cell).
pub const STOCK_BATTERY_NOMINAL_V: f64 = 3.7;
/// Multi-ranger deck, kg: 2.3 g (Bitcraze Multi-ranger deck datasheet).
pub const MULTI_RANGER_DECK_KG: f64 = 0.0023;
/// Qi 1.2 wireless charging deck, kg: 5.0 g (Bitcraze Qi 1.2 deck datasheet).
pub const QI_DECK_KG: f64 = 0.0050;
/// Loco Positioning deck, kg: 3.3 g (Bitcraze Loco Positioning deck datasheet).
pub const LOCO_DECK_KG: f64 = 0.0033;
/// Critical-low battery voltage of the Crazyflie firmware, V (`PM_BAT_CRITICAL_LOW_VOLTAGE`
/// = 3.0 in bitcraze/crazyflie-firmware `src/hal/interface/pm.h`; its low-battery warning,
/// `PM_BAT_LOW_VOLTAGE`, is 3.2 V).
pub const CUTOFF_VOLTAGE_V: f64 = 3.0;

/// Defaults for the dataset's platform: a Crazyflie 2.0 with the Multi-ranger, Qi 1.2 and Loco
/// Positioning decks on its stock 1S LiPo.
///
/// | key | value | source |
/// | --- | --- | --- |
/// | `structure_mass_kg` | 0.0199 | Crazyflie 2.0 datasheet take-off weight 27 g, which includes the 7.1 g battery |
/// | `payload_mass_kg` | 0.0106 | the three decks: Multi-ranger 2.3 g + Qi 1.2 5.0 g + Loco 3.3 g (their datasheets) |
/// | `battery_mass_kg` | 0.0071 | Bitcraze 240 mAh (and 250 mAh) LiPo datasheets |
/// | `battery_energy_wh` | 0.888 | 240 mAh × 3.7 V nominal (Crazyflie 2.0 datasheet: the kit's battery is 240 mAh) |
/// | `cells` | 1 | the datasheets: 1-cell LiPo |
/// | `cutoff_voltage_v` | 3.0 | crazyflie-firmware `PM_BAT_CRITICAL_LOW_VOLTAGE` |
///
/// Datasheets: bitcraze/hardware `src/products/{crazyflie-2_0, lipo-charger-500ma-w-battery,
/// 250mah-battery, multi-ranger-deck, qi-deck-1_2, loco-deck}/datasheet/index.md`, as published
/// on bitcraze.io. Unknown and left unset: avionics and payload power (no current is logged),
/// battery identity and cycles, temperature, air density, and how each flight ended (the
/// dataset's README does not say; its flights end in the air at 3.1–3.3 V under load). A
/// folder-level `flights.toml` overrides any of these.
pub fn platform_defaults() -> FlightMeta {
    FlightMeta {
        structure_mass_kg: Some(BARE_MASS_KG),
        battery_mass_kg: Some(STOCK_BATTERY_MASS_KG),
        battery_energy_density_wh_per_kg: None,
        battery_energy_wh: Some(STOCK_BATTERY_CAPACITY_MAH / 1000.0 * STOCK_BATTERY_NOMINAL_V),
        cells: Some(1),
        payload_mass_kg: Some(MULTI_RANGER_DECK_KG + QI_DECK_KG + LOCO_DECK_KG),
        payload_power_w: None,
        avionics_power_w: None,
        battery_id: None,
        battery_cycles: None,
        ambient_temperature_c: None,
        air_density_kg_m3: None,
        cutoff_voltage_v: Some(CUTOFF_VOLTAGE_V),
        end: None::<End>,
        ..FlightMeta::default()
    }
}

/// [`platform_defaults`] as a metadata layer ([`MetaSource::Default`]).
pub fn platform_layer() -> MetaLayer {
    MetaLayer::new(
        platform_defaults(),
        MetaSource::Default {
            what: "Crazyflie 2.0 platform".to_owned(),
        },
    )
}

/// The first non-blank, non-comment line of a text, without a byte-order mark or line ending.
fn first_line(bytes: &[u8]) -> &[u8] {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    bytes
        .split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty() && !l.starts_with(b"#"))
        .unwrap_or_default()
}

/// Whether a CSV has the dataset's `Real_path` header.
pub fn has_header(bytes: &[u8]) -> bool {
    let line = first_line(bytes);
    let fields: Vec<&[u8]> = line.split(|&b| b == b',').map(<[u8]>::trim_ascii).collect();
    fields.len() == 4
        && fields
            .iter()
            .zip(HEADER.split(','))
            .all(|(f, h)| f.eq_ignore_ascii_case(h.as_bytes()))
}

/// Whether a folder is laid out as the dataset (it has a `Real_path/` sub-folder).
pub fn is_dataset_folder(dir: &Path) -> bool {
    dir.join(REAL_PATH_DIR).is_dir()
}

/// The planned-trajectory file of a `Real_path_N.csv` in the dataset layout
/// (`../Planned_trajectories/Trajectories_N.csv`), if its name has that form.
pub fn plan_path(real_path_csv: &Path) -> Option<PathBuf> {
    let stem = real_path_csv.file_stem()?.to_str()?;
    let n = stem.strip_prefix("Real_path_")?;
    let dataset = real_path_csv.parent()?.parent()?;
    Some(dataset.join(PLAN_DIR).join(format!("Trajectories_{n}.csv")))
}

/// Rows of a numeric CSV of up to 4 columns after a header (read with the `csv` crate):
/// `(line, values)`; errors name the line and the column.
fn numeric_rows(
    bytes: &[u8],
    path: &Path,
    header: &str,
) -> Result<Vec<(u64, [f64; 4])>, FlightLogError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let names: Vec<&str> = header.split(',').collect();
    let width = names.len();
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(bytes);
    let csv_error = |e: csv::Error| {
        let line = e.position().map_or(1, csv::Position::line);
        let message = match e.kind() {
            csv::ErrorKind::Utf8 { .. } => "not UTF-8 text".to_owned(),
            _ => e.to_string(),
        };
        FlightLogError::Csv {
            path: path.to_owned(),
            line,
            message,
        }
    };
    let mut head = csv::StringRecord::new();
    loop {
        if !reader.read_record(&mut head).map_err(csv_error)? {
            return Err(FlightLogError::Csv {
                path: path.to_owned(),
                line: 1,
                message: format!("no header row (expected {header:?})"),
            });
        }
        if head.iter().any(|f| !f.is_empty()) {
            break;
        }
    }
    let same = head.len() == width
        && head
            .iter()
            .zip(&names)
            .all(|(a, b)| a.eq_ignore_ascii_case(b));
    if !same {
        return Err(FlightLogError::Csv {
            path: path.to_owned(),
            line: head.position().map_or(1, csv::Position::line),
            message: format!(
                "the header is {:?}, not {header:?}",
                head.iter().collect::<Vec<_>>().join(",")
            ),
        });
    }
    let mut rows = Vec::new();
    let mut record = csv::StringRecord::new();
    while reader.read_record(&mut record).map_err(csv_error)? {
        if record.iter().all(str::is_empty) {
            continue;
        }
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != width {
            return Err(FlightLogError::Csv {
                path: path.to_owned(),
                line,
                message: format!("{} fields where the header has {width}", record.len()),
            });
        }
        let mut out = [0.0; 4];
        for (k, cell) in record.iter().enumerate() {
            match cell.parse::<f64>() {
                Ok(v) if v.is_finite() => out[k] = v,
                _ => {
                    return Err(FlightLogError::BadValue {
                        path: path.to_owned(),
                        line,
                        column: names[k].to_owned(),
                        value: cell.to_owned(),
                        expected: "a finite number".to_owned(),
                    });
                }
            }
        }
        rows.push((line, out));
    }
    Ok(rows)
}

/// Parses a `Real_path_N.csv`.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let mut samples = Samples {
        altitude_m: Some(Vec::new()),
        ..Samples::default()
    };
    let mut altitude = Vec::new();
    for (line, [_, _, z, v]) in numeric_rows(bytes, path, HEADER)? {
        if v <= 0.0 {
            return Err(FlightLogError::BadValue {
                path: path.to_owned(),
                line,
                column: "battery_voltage".to_owned(),
                value: v.to_string(),
                expected: "a positive voltage".to_owned(),
            });
        }
        samples
            .time_s
            .push(samples.voltage_v.len() as f64 / RATE_HZ);
        samples.voltage_v.push(v);
        altitude.push(z);
    }
    if samples.time_s.len() < 2 {
        return Err(FlightLogError::TooShort {
            path: path.to_owned(),
            samples: samples.time_s.len(),
        });
    }
    samples.altitude_m = Some(altitude);
    Ok(Decoded {
        samples,
        landed: None,
        warnings: Vec::new(),
        info: crate::LogInfo::default(),
    })
}

/// Parses a `Trajectories_N.csv` into waypoints (x, y, z), m.
pub fn parse_plan(bytes: &[u8], path: &Path) -> Result<Vec<[f64; 3]>, FlightLogError> {
    let mut out = Vec::new();
    for (_, [x, y, z, _]) in numeric_rows(bytes, path, PLAN_HEADER)? {
        out.push([x, y, z]);
    }
    Ok(out)
}

/// Reads a `Trajectories_N.csv`.
pub fn read_plan(path: &Path) -> Result<Vec<[f64; 3]>, FlightLogError> {
    let bytes = std::fs::read(path).map_err(|error| FlightLogError::Io {
        path: path.to_owned(),
        error,
    })?;
    parse_plan(&bytes, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_recognised() {
        assert!(has_header(
            b"x_estimate,y_estimate,z_estimate,battery_voltage\n1,2,3,4\n"
        ));
        assert!(has_header(
            b"\xEF\xBB\xBFx_estimate, y_estimate ,z_estimate,battery_voltage\r\n"
        ));
        assert!(!has_header(b"time_s,voltage_v\n"));
        assert!(!has_header(b""));
    }

    #[test]
    fn parses_rows_at_100_hz() {
        let d = parse(
            b"x_estimate,y_estimate,z_estimate,battery_voltage\r\n0,0,-0.2,4.1\r\n0,0,0.1,4.0\r\n0,0,0.3,3.9\r\n",
            Path::new("Real_path_1.csv"),
        )
        .unwrap();
        assert_eq!(d.samples.time_s, [0.0, 0.01, 0.02]);
        assert_eq!(d.samples.altitude_m.unwrap(), [-0.2, 0.1, 0.3]);
        assert_eq!(d.samples.voltage_v, [4.1, 4.0, 3.9]);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse(
            b"x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4\n0,0,nan,4\n",
            Path::new("r.csv"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, FlightLogError::BadValue { line: 3, column, .. } if column == "z_estimate"),
            "{e}"
        );
        let e = parse(
            b"x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4\n0,0,0\n",
            Path::new("r.csv"),
        )
        .unwrap_err();
        assert!(matches!(&e, FlightLogError::Csv { line: 3, .. }), "{e}");
        let e = parse(
            b"x_estimate,y_estimate,z_estimate,battery_voltage\n0,0,0,4,5\n",
            Path::new("r.csv"),
        )
        .unwrap_err();
        assert!(matches!(&e, FlightLogError::Csv { line: 2, .. }), "{e}");
        assert!(parse(b"x,y,z\n1,2,3\n", Path::new("r.csv")).is_err());
    }

    #[test]
    fn defaults_add_up() {
        let m = platform_defaults();
        let total = m.take_off_mass_kg().unwrap();
        assert!((total - 0.0376).abs() < 1e-9, "{total}");
        assert!((m.battery_energy().unwrap() - 0.888).abs() < 1e-9);
        assert_eq!(
            plan_path(Path::new("/d/Real_path/Real_path_7.csv")).unwrap(),
            Path::new("/d/Planned_trajectories/Trajectories_7.csv")
        );
    }
}
