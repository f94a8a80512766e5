//! The one error type of the crate.

use std::path::PathBuf;

/// Why a flight log, a metadata file or a flight folder could not be read.
///
/// Every variant names the file; text formats add the 1-based line (and column where it is
/// known), binary formats the byte offset of the message, and both the field concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FlightLogError {
    /// A file or folder could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        #[source]
        error: std::io::Error,
    },
    /// Malformed CSV (unbalanced quotes, a row with another number of fields, bad UTF-8).
    #[error("{}, line {line}: {message}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A required column is not in the header.
    #[error("{}: no column {column:?}; the header has: {available}{hint}", path.display())]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column required.
        column: String,
        /// The columns present, comma-separated.
        available: String,
        /// What the file looks like instead, when its header says (starts with "; "; else empty).
        hint: &'static str,
    },
    /// The same column twice in a header.
    #[error("{}, line {line}: column {column:?} appears twice in the header", path.display())]
    DuplicateColumn {
        /// The file.
        path: PathBuf,
        /// 1-based line of the header.
        line: u64,
        /// The repeated column.
        column: String,
    },
    /// A cell that is not what its column holds.
    #[error("{}, line {line}, column {column:?}: {value:?} is not {expected}", path.display())]
    BadValue {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column.
        column: String,
        /// The cell's text.
        value: String,
        /// What was expected.
        expected: String,
    },
    /// Motor-command columns (`motor1_us`, `motor2_us`, …) that are not consecutive from 1, or
    /// more than [`crate::motors::MAX_MOTORS`] of them.
    #[error("{}, line {line}, column {column:?}: {message}", path.display())]
    MotorColumns {
        /// The file.
        path: PathBuf,
        /// 1-based line of the header.
        line: u64,
        /// The column concerned.
        column: String,
        /// What is wrong.
        message: String,
    },
    /// Time that runs backwards, stands still, or is sampled slower than 1 Hz.
    #[error("{}, {location}, field {field:?}: {message}", path.display())]
    Time {
        /// The file.
        path: PathBuf,
        /// Where: `line 12` for text logs, `byte 4096` for binary logs.
        location: String,
        /// The time field (`time_s`, `battery_status.timestamp`, `BAT.TimeUS`).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Too few samples to be a flight.
    #[error("{}: {samples} sample(s); a flight needs at least 2", path.display())]
    TooShort {
        /// The file.
        path: PathBuf,
        /// Samples found.
        samples: usize,
    },
    /// A metadata file that is not valid TOML, or has an unknown key or a value of the wrong
    /// type.
    #[error("{}, line {line}, column {column}: {message}", path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the TOML reader said.
        message: String,
    },
    /// A metadata value out of its range, or two keys that exclude each other.
    #[error("{}, line {line}, key {key:?}: {message}", path.display())]
    Meta {
        /// The file (or a description of the built-in defaults).
        path: PathBuf,
        /// 1-based line of the key (0 when not located).
        line: usize,
        /// The key.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A binary log (ULog, DataFlash) that does not follow its format.
    #[error("{}, byte {offset}, {field}: {message}", path.display())]
    Binary {
        /// The file.
        path: PathBuf,
        /// Byte offset of the message (or header) concerned.
        offset: u64,
        /// The message or field concerned (`header`, `FMT.Format`, `battery_status.voltage_v`).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A text log (ArduPilot's DataFlash as text) whose line does not follow its format.
    #[error("{}, line {line}, {field}: {message}", path.display())]
    TextLog {
        /// The file.
        path: PathBuf,
        /// 1-based line of the message (or of its `FMT`) concerned.
        line: u64,
        /// The message or field concerned (`BAT.Volt`, `FMT`).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A log that is well-formed but lacks what a flight needs (no battery voltage).
    #[error("{}: no {field}: {message}", path.display())]
    MissingData {
        /// The file.
        path: PathBuf,
        /// The message or field that is missing.
        field: String,
        /// Context.
        message: String,
    },
    /// A log whose every battery was skipped: not connected, no voltage, or a voltage
    /// implausible for its cell count.
    #[error("{}: no usable battery: {}", path.display(), batteries.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    NoUsableBattery {
        /// The file.
        path: PathBuf,
        /// Each battery of the log and why it was skipped.
        batteries: Vec<crate::battery::SkippedBattery>,
    },
    /// A file that is none of the formats this crate reads.
    #[error("{}: {message}", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// What was seen.
        message: String,
    },
    /// A folder with nothing to read.
    #[error(
        "{}: no flight logs (*.csv, *.ulg, *.bin, *.log, *.tlog, or a Crazyflie Real_path/ folder){}",
        path.display(),
        subfolder_hint(subfolders)
    )]
    NoFlights {
        /// The folder.
        path: PathBuf,
        /// Its subfolders, which are not searched (sorted; empty when it has none).
        subfolders: Vec<String>,
    },
}

/// `; subfolders are not searched: give them (a/, b/)`, or nothing.
fn subfolder_hint(subfolders: &[String]) -> String {
    if subfolders.is_empty() {
        return String::new();
    }
    let names: Vec<String> = subfolders.iter().map(|s| format!("{s}/")).collect();
    format!(
        "; subfolders are not searched: give them ({})",
        names.join(", ")
    )
}

impl FlightLogError {
    /// A [`FlightLogError::Binary`]: `field` of the message at byte `offset` of `path`.
    pub(crate) fn binary(
        path: &std::path::Path,
        offset: u64,
        field: impl Into<String>,
        message: String,
    ) -> Self {
        Self::Binary {
            path: path.to_owned(),
            offset,
            field: field.into(),
            message,
        }
    }

    /// The file (or folder) the error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Io { path, .. }
            | Self::Csv { path, .. }
            | Self::MissingColumn { path, .. }
            | Self::DuplicateColumn { path, .. }
            | Self::BadValue { path, .. }
            | Self::MotorColumns { path, .. }
            | Self::Time { path, .. }
            | Self::TooShort { path, .. }
            | Self::Toml { path, .. }
            | Self::Meta { path, .. }
            | Self::Binary { path, .. }
            | Self::TextLog { path, .. }
            | Self::MissingData { path, .. }
            | Self::UnknownFormat { path, .. }
            | Self::NoUsableBattery { path, .. }
            | Self::NoFlights { path, .. } => path,
        }
    }
}
