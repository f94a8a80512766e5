//! Flight metadata: a sidecar `NAME.toml` merged over a folder's `flights.toml` defaults.
//!
//! Both files have the same keys, all optional (see [`FlightMeta`]). Unknown keys, values of the
//! wrong type and values out of range are errors naming the file, the line and the column or key.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::FlightLogError;

/// How a flight ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum End {
    /// The flight ran until the minimum-voltage landing: its duration is a measured endurance.
    Cutoff,
    /// The flight was landed before the battery was empty.
    Landed,
}

/// What is known about a flight beyond its samples: the paper's masses and powers, the battery,
/// the air, and how the flight ended. Every key is optional; a sidecar's keys override the
/// folder's defaults key by key (see [`FlightMeta::merged_over`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightMeta {
    /// Structure mass without battery and payload (the paper's `m^S`), kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure_mass_kg: Option<f64>,
    /// Battery mass (`m^B`), kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_mass_kg: Option<f64>,
    /// Battery specific energy (`e^D`), Wh/kg; excludes [`FlightMeta::battery_energy_wh`] in
    /// the same file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_energy_density_wh_per_kg: Option<f64>,
    /// Battery energy, Wh; excludes [`FlightMeta::battery_energy_density_wh_per_kg`] in the
    /// same file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_energy_wh: Option<f64>,
    /// Cells in series.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells: Option<u32>,
    /// Payload mass (`m^P`), kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload_mass_kg: Option<f64>,
    /// Payload power (`p^P`), W.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload_power_w: Option<f64>,
    /// Avionics power (`p^A`), W.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub avionics_power_w: Option<f64>,
    /// Which battery pack flew.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_id: Option<String>,
    /// Charge cycles of that pack before this flight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_cycles: Option<u32>,
    /// Ambient temperature, °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ambient_temperature_c: Option<f64>,
    /// Air density, kg/m³.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub air_density_kg_m3: Option<f64>,
    /// Minimum battery voltage (the landing or cut-off voltage), V.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cutoff_voltage_v: Option<f64>,
    /// How the flight ended: `cutoff` (a measured endurance) or `landed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end: Option<End>,
    /// Battery capacity, mAh (PX4 `BAT*_CAPACITY`, ArduPilot `BATT_CAPACITY`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub capacity_mah: Option<f64>,
    /// Voltage of the charged pack, V (PX4 `BAT*_V_CHARGED` × cells).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charged_voltage_v: Option<f64>,
    /// Lowest voltage at which the autopilot arms, V (ArduPilot `BATT_ARM_VOLT`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arm_voltage_v: Option<f64>,
    /// Throttle that hovers, 0–1 (PX4 `MPC_THR_HOVER`, ArduPilot `MOT_THST_HOVER`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hover_throttle: Option<f64>,
    /// The kind of vehicle (`multirotor`, `helicopter`, `vtol`, `fixed_wing`, `rover`,
    /// `other`); only a `vtol` has `transition` phases.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::VehicleKind>,
    /// Frame (`quad`, `hexa`, …; ArduPilot `FRAME_CLASS`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<String>,
    /// Whether the robot perches (attaches to a ceiling or wall with its motors off): only
    /// then are `attached` phases inferred.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perches: Option<bool>,
    /// A measured open-circuit curve of the pack, `soc,ocv_v` per cell (CSV), that overrides
    /// the chemistry prior of the gap diagnosis. Written relative to the metadata file; read
    /// ([`FlightMeta::parse`], [`FlightMeta::read`]) it is that file's folder joined with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_ocv_csv: Option<PathBuf>,
    /// Height of the ceiling above the take-off point, m (site knowledge: where a ceiling
    /// effect can act).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ceiling_height_m: Option<f64>,
}

/// Keys that must be positive, with their accessors, for validation.
const POSITIVE_KEYS: [&str; 11] = [
    "structure_mass_kg",
    "battery_mass_kg",
    "battery_energy_density_wh_per_kg",
    "battery_energy_wh",
    "air_density_kg_m3",
    "cutoff_voltage_v",
    "cells",
    "capacity_mah",
    "charged_voltage_v",
    "arm_voltage_v",
    "ceiling_height_m",
];

impl FlightMeta {
    /// Parses and validates the text of a metadata file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, FlightLogError> {
        let mut meta: Self = toml::from_str(text).map_err(|e| {
            let (line, column) = e
                .span()
                .map_or((1, 1), |span| line_column(text.as_bytes(), span.start));
            FlightLogError::Toml {
                path: path.to_owned(),
                line,
                column,
                message: e.message().trim().to_owned(),
            }
        })?;
        meta.validate(path, Some(text))?;
        meta.resolve_paths(path);
        Ok(meta)
    }

    /// Makes a relative `battery_ocv_csv` relative to the folder of the metadata file at
    /// `path` (as it is written), so that it names the same file from anywhere.
    pub fn resolve_paths(&mut self, path: &Path) {
        if let Some(p) = &self.battery_ocv_csv
            && p.is_relative()
            && let Some(dir) = path.parent()
        {
            self.battery_ocv_csv = Some(dir.join(p));
        }
    }

    /// Reads and validates a metadata file.
    pub fn read(path: &Path) -> Result<Self, FlightLogError> {
        let bytes = std::fs::read(path).map_err(|error| FlightLogError::Io {
            path: path.to_owned(),
            error,
        })?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            let (line, column) = line_column(&bytes, e.valid_up_to());
            FlightLogError::Toml {
                path: path.to_owned(),
                line,
                column,
                message: "not UTF-8 text".to_owned(),
            }
        })?;
        Self::parse(text, path)
    }

    /// These values, with every key this one leaves unset taken from `defaults`.
    ///
    /// The battery energy is one quantity given one of two ways: when `self` sets either
    /// `battery_energy_wh` or `battery_energy_density_wh_per_kg`, neither is taken from
    /// `defaults`.
    pub fn merged_over(&self, defaults: &Self) -> Self {
        let own_energy =
            self.battery_energy_wh.is_some() || self.battery_energy_density_wh_per_kg.is_some();
        let (energy_wh, density) = if own_energy {
            (
                self.battery_energy_wh,
                self.battery_energy_density_wh_per_kg,
            )
        } else {
            (
                defaults.battery_energy_wh,
                defaults.battery_energy_density_wh_per_kg,
            )
        };
        Self {
            structure_mass_kg: self.structure_mass_kg.or(defaults.structure_mass_kg),
            battery_mass_kg: self.battery_mass_kg.or(defaults.battery_mass_kg),
            battery_energy_density_wh_per_kg: density,
            battery_energy_wh: energy_wh,
            cells: self.cells.or(defaults.cells),
            payload_mass_kg: self.payload_mass_kg.or(defaults.payload_mass_kg),
            payload_power_w: self.payload_power_w.or(defaults.payload_power_w),
            avionics_power_w: self.avionics_power_w.or(defaults.avionics_power_w),
            battery_id: self
                .battery_id
                .clone()
                .or_else(|| defaults.battery_id.clone()),
            battery_cycles: self.battery_cycles.or(defaults.battery_cycles),
            ambient_temperature_c: self
                .ambient_temperature_c
                .or(defaults.ambient_temperature_c),
            air_density_kg_m3: self.air_density_kg_m3.or(defaults.air_density_kg_m3),
            cutoff_voltage_v: self.cutoff_voltage_v.or(defaults.cutoff_voltage_v),
            end: self.end.or(defaults.end),
            capacity_mah: self.capacity_mah.or(defaults.capacity_mah),
            charged_voltage_v: self.charged_voltage_v.or(defaults.charged_voltage_v),
            arm_voltage_v: self.arm_voltage_v.or(defaults.arm_voltage_v),
            hover_throttle: self.hover_throttle.or(defaults.hover_throttle),
            vehicle: self.vehicle.or(defaults.vehicle),
            frame: self.frame.clone().or_else(|| defaults.frame.clone()),
            perches: self.perches.or(defaults.perches),
            battery_ocv_csv: self
                .battery_ocv_csv
                .clone()
                .or_else(|| defaults.battery_ocv_csv.clone()),
            ceiling_height_m: self.ceiling_height_m.or(defaults.ceiling_height_m),
        }
    }

    /// Battery energy in Wh: `battery_energy_wh`, else density × battery mass.
    pub fn battery_energy(&self) -> Option<f64> {
        self.battery_energy_wh
            .or_else(|| Some(self.battery_energy_density_wh_per_kg? * self.battery_mass_kg?))
    }

    /// Battery specific energy in Wh/kg: `battery_energy_density_wh_per_kg`, else energy ÷
    /// battery mass.
    pub fn battery_energy_density(&self) -> Option<f64> {
        self.battery_energy_density_wh_per_kg
            .or_else(|| Some(self.battery_energy_wh? / self.battery_mass_kg?))
    }

    /// Take-off mass (structure + battery + payload, payload 0 when unset), kg.
    pub fn take_off_mass_kg(&self) -> Option<f64> {
        Some(self.structure_mass_kg? + self.battery_mass_kg? + self.payload_mass_kg.unwrap_or(0.0))
    }

    /// Checks ranges and exclusive keys. `text` (the file's text) locates the offending line.
    pub fn validate(&self, path: &Path, text: Option<&str>) -> Result<(), FlightLogError> {
        let fail = |key: &str, message: String| FlightLogError::Meta {
            path: path.to_owned(),
            line: text.map_or(0, |t| key_line(t, key)),
            key: key.to_owned(),
            message,
        };
        if self.battery_energy_wh.is_some() && self.battery_energy_density_wh_per_kg.is_some() {
            return Err(fail(
                "battery_energy_wh",
                "give battery_energy_wh or battery_energy_density_wh_per_kg, not both".to_owned(),
            ));
        }
        let positive = [
            self.structure_mass_kg,
            self.battery_mass_kg,
            self.battery_energy_density_wh_per_kg,
            self.battery_energy_wh,
            self.air_density_kg_m3,
            self.cutoff_voltage_v,
            self.cells.map(f64::from),
            self.capacity_mah,
            self.charged_voltage_v,
            self.arm_voltage_v,
            self.ceiling_height_m,
        ];
        for (key, value) in POSITIVE_KEYS.iter().zip(positive) {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0)
            {
                return Err(fail(key, format!("{v} must be a positive number")));
            }
        }
        let non_negative = [
            ("payload_mass_kg", self.payload_mass_kg),
            ("payload_power_w", self.payload_power_w),
            ("avionics_power_w", self.avionics_power_w),
        ];
        for (key, value) in non_negative {
            if let Some(v) = value
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(fail(key, format!("{v} must be zero or more")));
            }
        }
        if let Some(h) = self.hover_throttle
            && !(h.is_finite() && h > 0.0 && h <= 1.0)
        {
            return Err(fail(
                "hover_throttle",
                format!("{h} is not a throttle in (0, 1]"),
            ));
        }
        if let Some(p) = &self.battery_ocv_csv
            && p.as_os_str().is_empty()
        {
            return Err(fail(
                "battery_ocv_csv",
                "is empty: give the path of a `soc,ocv_v` CSV file, relative to this file"
                    .to_owned(),
            ));
        }
        if let Some(t) = self.ambient_temperature_c
            && !(t.is_finite() && t > -273.15)
        {
            return Err(fail(
                "ambient_temperature_c",
                format!("{t} is not a temperature in °C"),
            ));
        }
        Ok(())
    }
}

/// Where a metadata value came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum MetaSource {
    /// Built-in defaults (a platform's, such as the Crazyflie dataset's).
    Default {
        /// Whose defaults.
        what: String,
    },
    /// The log itself: a parameter or message field (or a value derived from them).
    Log {
        /// Which (`BAT1_N_CELLS`, `battery_status.cell_count`, `BATT_LOW_VOLT`).
        origin: String,
    },
    /// The folder's `flights.toml`.
    Folder {
        /// The file.
        path: PathBuf,
    },
    /// The flight's own `NAME.toml`.
    Sidecar {
        /// The file.
        path: PathBuf,
    },
}

impl std::fmt::Display for MetaSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Default { what } => write!(f, "default ({what})"),
            Self::Log { origin } => write!(f, "log ({origin})"),
            Self::Folder { path } => write!(f, "folder ({})", file_name(path)),
            Self::Sidecar { path } => write!(f, "sidecar ({})", file_name(path)),
        }
    }
}

/// A file's name, for short messages.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// One metadata value with its source.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetaValue {
    /// The value, as it would be written in TOML.
    pub value: toml::Value,
    /// Where it came from.
    pub source: MetaSource,
}

/// One layer of metadata: values and where they came from. For a [`MetaSource::Log`] layer,
/// `origins` names each key's parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct MetaLayer {
    /// The values this layer sets.
    pub meta: FlightMeta,
    /// Where they came from.
    pub source: MetaSource,
    /// Per key, a more precise origin inside a log (replaces `source`'s origin for that key).
    pub origins: BTreeMap<String, String>,
}

impl MetaLayer {
    /// A layer whose every value has the same source.
    pub fn new(meta: FlightMeta, source: MetaSource) -> Self {
        Self {
            meta,
            source,
            origins: BTreeMap::new(),
        }
    }
}

impl FlightMeta {
    /// The keys this metadata sets, each with its value as TOML.
    pub fn entries(&self) -> BTreeMap<String, toml::Value> {
        match toml::Value::try_from(self) {
            Ok(toml::Value::Table(t)) => t.into_iter().collect(),
            _ => BTreeMap::new(),
        }
    }

    /// Merges layers (lowest first; each overrides those before it key by key, as
    /// [`FlightMeta::merged_over`]) and says where each resulting value came from.
    pub fn resolve(layers: &[MetaLayer]) -> (FlightMeta, BTreeMap<String, MetaValue>) {
        let mut merged = FlightMeta::default();
        let mut sources: BTreeMap<String, MetaSource> = BTreeMap::new();
        for layer in layers {
            merged = layer.meta.merged_over(&merged);
            for key in layer.meta.entries().into_keys() {
                let source = match (&layer.source, layer.origins.get(&key)) {
                    (MetaSource::Log { .. }, Some(origin)) => MetaSource::Log {
                        origin: origin.clone(),
                    },
                    (s, _) => s.clone(),
                };
                sources.insert(key, source);
            }
        }
        let values = merged
            .entries()
            .into_iter()
            .filter_map(|(key, value)| {
                let source = sources.remove(&key)?;
                Some((key, MetaValue { value, source }))
            })
            .collect();
        (merged, values)
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub(crate) fn line_column(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = &bytes[..offset.min(bytes.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let column = String::from_utf8_lossy(&before[start..]).chars().count() + 1;
    (line, column)
}

/// 1-based line on which `key` is assigned (`key = …`), or 0.
fn key_line(text: &str, key: &str) -> usize {
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            l.strip_prefix(key)
                .or_else(|| {
                    l.strip_prefix('"')
                        .and_then(|r| r.strip_prefix(key))
                        .and_then(|r| r.strip_prefix('"'))
                })
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map_or(0, |i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_key_names_line_and_column() {
        let text = "structure_mass_kg = 0.4\nbattery_mas_kg = 0.1\n";
        let err = FlightMeta::parse(text, Path::new("f.toml")).unwrap_err();
        let FlightLogError::Toml {
            line,
            column,
            message,
            ..
        } = &err
        else {
            panic!("{err}");
        };
        assert_eq!((*line, *column), (2, 1));
        assert!(message.contains("battery_mas_kg"), "{message}");
    }

    #[test]
    fn end_values_and_ranges() {
        let m = FlightMeta::parse("end = \"cutoff\"\ncells = 3\n", Path::new("a.toml")).unwrap();
        assert_eq!(m.end, Some(End::Cutoff));
        assert!(FlightMeta::parse("end = \"crashed\"\n", Path::new("a.toml")).is_err());
        let err = FlightMeta::parse("\nbattery_mass_kg = -1.0\n", Path::new("a.toml")).unwrap_err();
        assert!(matches!(err, FlightLogError::Meta { line: 2, .. }), "{err}");
        let err = FlightMeta::parse(
            "battery_energy_wh = 20.0\nbattery_energy_density_wh_per_kg = 150.0\n",
            Path::new("a.toml"),
        )
        .unwrap_err();
        assert!(err.to_string().contains("not both"), "{err}");
    }

    #[test]
    fn battery_ocv_csv_is_relative_to_the_metadata_file() {
        let m = FlightMeta::parse(
            "battery_ocv_csv = \"curves/pack-a.csv\"\n",
            Path::new("/data/flights/a.toml"),
        )
        .unwrap();
        assert_eq!(
            m.battery_ocv_csv.as_deref(),
            Some(Path::new("/data/flights/curves/pack-a.csv"))
        );
        let abs = FlightMeta::parse(
            "battery_ocv_csv = \"/curves/b.csv\"\n",
            Path::new("/data/a.toml"),
        )
        .unwrap();
        assert_eq!(
            abs.battery_ocv_csv.as_deref(),
            Some(Path::new("/curves/b.csv"))
        );
        // A sidecar's curve overrides the folder's, key by key.
        let folder = FlightMeta::parse(
            "battery_ocv_csv = \"lipo.csv\"\ncells = 3\n",
            Path::new("/d/flights.toml"),
        )
        .unwrap();
        let merged = FlightMeta::parse("cells = 4\n", Path::new("/d/x.toml"))
            .unwrap()
            .merged_over(&folder);
        assert_eq!(
            merged.battery_ocv_csv.as_deref(),
            Some(Path::new("/d/lipo.csv"))
        );
        assert_eq!(merged.cells, Some(4));
    }

    #[test]
    fn bad_battery_ocv_csv_and_ceiling_height_name_file_line_and_key() {
        let err = FlightMeta::parse("cells = 3\nbattery_ocv_csv = \"\"\n", Path::new("f.toml"))
            .unwrap_err();
        assert!(
            matches!(&err, FlightLogError::Meta { line: 2, key, .. } if key == "battery_ocv_csv"),
            "{err}"
        );
        let text = err.to_string();
        assert!(
            text.contains("f.toml") && text.contains("battery_ocv_csv"),
            "{text}"
        );
        // Not a string: the TOML error with line and column.
        let err = FlightMeta::parse("battery_ocv_csv = 3\n", Path::new("f.toml")).unwrap_err();
        assert!(
            matches!(&err, FlightLogError::Toml { line: 1, .. }),
            "{err}"
        );
        let err =
            FlightMeta::parse("\n\nceiling_height_m = -2.5\n", Path::new("g.toml")).unwrap_err();
        assert!(
            matches!(&err, FlightLogError::Meta { line: 3, key, .. } if key == "ceiling_height_m"),
            "{err}"
        );
        assert!(err.to_string().contains("-2.5"), "{err}");
        let err =
            FlightMeta::parse("ceiling_height_m = \"high\"\n", Path::new("g.toml")).unwrap_err();
        assert!(
            matches!(&err, FlightLogError::Toml { line: 1, .. }),
            "{err}"
        );
        let m = FlightMeta::parse("ceiling_height_m = 3.2\n", Path::new("g.toml")).unwrap();
        assert_eq!(m.ceiling_height_m, Some(3.2));
        assert_eq!(
            m.entries().get("ceiling_height_m"),
            Some(&toml::Value::Float(3.2))
        );
    }

    #[test]
    fn layers_resolve_with_their_sources() {
        let log = MetaLayer {
            meta: FlightMeta {
                cells: Some(4),
                battery_energy_wh: Some(74.0),
                capacity_mah: Some(5000.0),
                ..FlightMeta::default()
            },
            source: MetaSource::Log {
                origin: "log".to_owned(),
            },
            origins: [("cells".to_owned(), "BAT1_N_CELLS".to_owned())].into(),
        };
        let folder = MetaLayer::new(
            FlightMeta {
                cells: Some(6),
                perches: Some(true),
                ..FlightMeta::default()
            },
            MetaSource::Folder {
                path: "/f/flights.toml".into(),
            },
        );
        let sidecar = MetaLayer::new(
            FlightMeta {
                battery_energy_density_wh_per_kg: Some(150.0),
                ..FlightMeta::default()
            },
            MetaSource::Sidecar {
                path: "/f/a.toml".into(),
            },
        );
        let (meta, values) = FlightMeta::resolve(&[log, folder, sidecar]);
        assert_eq!(meta.cells, Some(6));
        assert_eq!(values["cells"].source.to_string(), "folder (flights.toml)");
        assert_eq!(values["capacity_mah"].source.to_string(), "log (log)");
        assert_eq!(values["perches"].value, toml::Value::Boolean(true));
        // The sidecar gives the battery energy another way: the log's value is gone, not
        // reported with a stale source.
        assert_eq!(meta.battery_energy_wh, None);
        assert!(!values.contains_key("battery_energy_wh"));
        assert_eq!(
            values["battery_energy_density_wh_per_kg"]
                .source
                .to_string(),
            "sidecar (a.toml)"
        );
        let (_, only_log) = FlightMeta::resolve(&[MetaLayer {
            meta: FlightMeta {
                cells: Some(4),
                ..FlightMeta::default()
            },
            source: MetaSource::Log {
                origin: "log".to_owned(),
            },
            origins: [("cells".to_owned(), "BAT1_N_CELLS".to_owned())].into(),
        }]);
        assert_eq!(only_log["cells"].source.to_string(), "log (BAT1_N_CELLS)");
    }

    #[test]
    fn merge_takes_battery_energy_as_one_quantity() {
        let defaults = FlightMeta {
            battery_energy_density_wh_per_kg: Some(150.0),
            battery_mass_kg: Some(0.1),
            cells: Some(3),
            ..FlightMeta::default()
        };
        let own = FlightMeta {
            battery_energy_wh: Some(20.0),
            ..FlightMeta::default()
        };
        let m = own.merged_over(&defaults);
        assert_eq!(m.battery_energy_wh, Some(20.0));
        assert_eq!(m.battery_energy_density_wh_per_kg, None);
        assert_eq!(m.cells, Some(3));
        assert_eq!(m.battery_energy(), Some(20.0));
        let inherited = FlightMeta::default().merged_over(&defaults);
        assert!((inherited.battery_energy().unwrap() - 15.0).abs() < 1e-12);
    }
}
