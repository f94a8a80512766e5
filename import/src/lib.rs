//! Reading rig sweeps and other tables of measurements into numeric columns.
//!
//! hoverbench's own sweep CSV (written by `rig-host`) has a `#` comment block, then a header of
//! unit-suffixed names (`thrust_g`, `power_w`, `voltage_v`, `current_a`, `throttle`, `valid`, …)
//! and one row per settled thrust step. Any other CSV with named columns reads the same way.
//! Rows whose `valid` column is `false`/`0` (e.g. taken while the bench supply was
//! current-limiting) are skipped and counted, never fitted.
//!
//! Main types: [`Table`] (named numeric columns with the source line of every row),
//! [`YSource`] (a column, or a product of two such as `voltage_v × current_a`), [`XySeries`].
//! Every error names the source, the line and the column.
//!
//! ```
//! use import::{Table, YSource};
//!
//! let csv = "# rig: sim-paper\nthrust_g,voltage_v,current_a,valid\n10,12.5,0.13,true\n20,12.5,0.26,false\n30,12.5,0.40,true\n";
//! let table = Table::parse(csv.as_bytes(), "sweep.csv")?;
//! let xy = table.xy("thrust_g", &YSource::power_default())?;
//! assert_eq!(xy.x, [10.0, 30.0]);
//! assert!((xy.y[1] - 5.0).abs() < 1e-12);
//! assert_eq!(xy.y_name, "power_w = voltage_v × current_a");
//! assert_eq!(xy.skipped_invalid, 1);
//! # Ok::<(), import::ImportError>(())
//! ```

use std::path::Path;

pub mod catalogue;
pub mod stand;
pub mod units;

use sha2::{Digest, Sha256};

/// Why a table could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// The file could not be read.
    #[error("cannot read {source_name}")]
    Io {
        /// The file.
        source_name: String,
        /// The cause.
        #[source]
        error: std::io::Error,
    },
    /// Malformed CSV (unbalanced quotes, a row with another number of fields, bad UTF-8).
    #[error("{source_name}, line {line}: {message}")]
    Csv {
        /// The file.
        source_name: String,
        /// 1-based line.
        line: u64,
        /// What the CSV reader said.
        message: String,
    },
    /// The file has no header or no data rows.
    #[error("{source_name}: {message}")]
    Empty {
        /// The file.
        source_name: String,
        /// What is missing.
        message: String,
    },
    /// A column asked for is not in the header.
    #[error("{source_name}: no column {column}; the header has: {available}")]
    MissingColumn {
        /// The file.
        source_name: String,
        /// The column asked for.
        column: String,
        /// The columns present, comma-separated.
        available: String,
    },
    /// A cell is not a finite number.
    #[error("{source_name}, line {line}, column {column:?}: {value:?} is not a finite number")]
    BadNumber {
        /// The file.
        source_name: String,
        /// 1-based line.
        line: u64,
        /// The column.
        column: String,
        /// The cell's text.
        value: String,
    },
    /// A cell whose number is out of its allowed range.
    #[error("{source_name}, line {line}, column {column:?}: {value:?} is not {expected}")]
    BadValue {
        /// The file.
        source_name: String,
        /// 1-based line.
        line: u64,
        /// The column.
        column: String,
        /// The cell's text.
        value: String,
        /// What was expected.
        expected: String,
    },
    /// A column's unit cannot hold the quantity mapped to it.
    #[error("{source_name}: column {column:?} is in {unit:?}, which is not a unit of {quantity}")]
    BadUnit {
        /// The file.
        source_name: String,
        /// The column.
        column: String,
        /// Its unit.
        unit: String,
        /// The quantity it was mapped to.
        quantity: String,
    },
    /// A file without a header row, and no column names given.
    #[error(
        "{source_name}: the first row holds numbers, not column names; name the columns (e.g. --columns esc_us,torque_nm,thrust_n,rpm,current_a)"
    )]
    NoHeader {
        /// The file.
        source_name: String,
    },
    /// Electrical power cannot be had from the log.
    #[error(
        "{source_name}: {}",
        if *has_current {
            "no voltage column, so electrical power cannot be computed. Give --volts V to assume a constant supply voltage, or fit another pair of columns with --x/--y"
        } else {
            "neither power nor voltage and current are logged: electrical power cannot be computed; name the columns with --power or --voltage/--current"
        }
    )]
    NoPower {
        /// The file.
        source_name: String,
        /// Whether current is logged (then an assumed voltage would do).
        has_current: bool,
    },
    /// A header that names a column twice, or holds a control character (a NUL byte, …).
    #[error("{source_name}, line {line}, column {column}: {message}")]
    BadHeader {
        /// The file.
        source_name: String,
        /// 1-based line of the header.
        line: u64,
        /// 1-based field number in the header.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A quoted field that is never closed.
    #[error("{source_name}, line {line}, column {column}: a quote opens here and is never closed")]
    UnterminatedQuote {
        /// The file.
        source_name: String,
        /// 1-based line of the opening quote.
        line: u64,
        /// 1-based character column of the opening quote.
        column: usize,
    },
    /// The file is a flight log, given where a table belongs.
    #[error("{source_name}: {what}, not a CSV table{hint}")]
    NotATable {
        /// The file.
        source_name: String,
        /// What the file's first bytes say it is.
        what: &'static str,
        /// What reads it instead (starts with "; ").
        hint: &'static str,
    },
    /// A `valid` cell that is neither true nor false.
    #[error("{source_name}, line {line}: the valid column holds {value:?}; use true/false or 1/0")]
    BadFlag {
        /// The file.
        source_name: String,
        /// 1-based line.
        line: u64,
        /// The cell's text.
        value: String,
    },
}

/// Where the y values come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum YSource {
    /// One column.
    Column(String),
    /// The product of two columns (electrical power = voltage × current).
    Product(String, String),
    /// The first source present in the table.
    FirstOf(Vec<YSource>),
}

impl YSource {
    /// How the source reads in a message: `"power_w"`, `"voltage_v" × "current_a"`.
    pub fn describe(&self) -> String {
        match self {
            Self::Column(c) => format!("{c:?}"),
            Self::Product(a, b) => format!("{a:?} × {b:?}"),
            Self::FirstOf(o) => o
                .iter()
                .map(Self::describe)
                .collect::<Vec<_>>()
                .join(" or "),
        }
    }

    /// `power_w` if the table has it, else `voltage_v × current_a`.
    pub fn power_default() -> Self {
        Self::FirstOf(vec![
            Self::Column("power_w".into()),
            Self::Product("voltage_v".into(), "current_a".into()),
        ])
    }
}

/// Paired (x, y) values read from a table.
#[derive(Debug, Clone, PartialEq)]
pub struct XySeries {
    /// Abscissa values.
    pub x: Vec<f64>,
    /// Ordinate values.
    pub y: Vec<f64>,
    /// Name of the x column.
    pub x_name: String,
    /// Name of the y column, or `power_w = voltage_v × current_a` when derived.
    pub y_name: String,
    /// Source line of each pair.
    pub lines: Vec<u64>,
    /// Rows skipped because their `valid` column was false.
    pub skipped_invalid: usize,
}

/// A CSV table: its header, its rows as text, the line of each row.
///
/// The cells are kept as one text buffer and an end offset per cell (not a `String` per cell),
/// so that a table takes little more memory than its file.
#[derive(Debug, Clone)]
pub struct Table {
    source_name: String,
    header: Vec<String>,
    /// Every cell's text, row after row.
    cells: String,
    /// End of each cell in `cells`; row `r`, column `c` is cell `r × width + c`.
    ends: Vec<usize>,
    n_rows: usize,
    lines: Vec<u64>,
    /// The `#` comment lines before the header, without the `#`.
    pub comments: Vec<String>,
}

/// SHA-256 of some bytes as lowercase hex, for provenance records.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// What a file that is not text is, from its first bytes: a PX4 ULog or ArduPilot DataFlash
/// flight log (by their magic numbers), with what reads it instead. (Any other binary file
/// fails on its first control character or bad UTF-8, with the line and column.)
fn binary_kind(bytes: &[u8]) -> Option<(&'static str, &'static str)> {
    const FLIGHT_LOG: &str = "; flight logs are read by `hoverbench flights`, `gap` and `replay`";
    if bytes.starts_with(b"ULog\x01\x12\x35") {
        Some(("a PX4 ULog flight log", FLIGHT_LOG))
    } else if bytes.starts_with(&[0xA3, 0x95]) {
        Some(("an ArduPilot DataFlash flight log", FLIGHT_LOG))
    } else if bytes.get(..9).is_some_and(|b| {
        // A MAVLink telemetry log: a time of reception (µs since 1970, 2000–2100), then a
        // MAVLink 1 or 2 start byte.
        let t = u64::from_be_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
        (946_684_800_000_000..4_102_444_800_000_000).contains(&t) && matches!(b[8], 0xFE | 0xFD)
    }) {
        Some(("a MAVLink telemetry log (.tlog)", FLIGHT_LOG))
    } else if bytes
        .split(|&b| b == b'\n')
        .take(20)
        .any(|l| l.trim_ascii_start().starts_with(b"FMT, 128,"))
    {
        // Every converter of a `.bin` to text opens with the FMT message's own definition
        // (APM 2's own text logs after a short banner).
        Some(("an ArduPilot DataFlash flight log as text", FLIGHT_LOG))
    } else {
        None
    }
}

impl Table {
    /// Reads and parses a CSV file.
    pub fn read(path: &Path) -> Result<(Self, Vec<u8>), ImportError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|error| ImportError::Io {
            source_name: name.clone(),
            error,
        })?;
        let table = Self::parse(&bytes, &name)?;
        Ok((table, bytes))
    }

    /// Parses CSV text. `source_name` is used in error messages. A UTF-8 byte-order mark, `#`
    /// comment lines, blank lines, surrounding spaces and a trailing comma are all accepted.
    pub fn parse(bytes: &[u8], source_name: &str) -> Result<Self, ImportError> {
        Self::parse_with(bytes, source_name, None)
    }

    /// Like [`Table::parse`], and also reads whitespace-separated files, semicolon-separated
    /// ones with decimal commas (a spreadsheet's CSV in a comma-decimal locale) and, given
    /// `columns`, files without a header row. A file whose first row is all numbers needs `columns`.
    pub fn parse_with(
        bytes: &[u8],
        source_name: &str,
        columns: Option<&[String]>,
    ) -> Result<Self, ImportError> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        if let Some((what, hint)) = binary_kind(bytes) {
            return Err(ImportError::NotATable {
                source_name: source_name.to_owned(),
                what,
                hint,
            });
        }
        let lossy = String::from_utf8_lossy(bytes);
        let first_row = |text: &str| {
            text.lines()
                .map(str::trim)
                .find(|l| !l.is_empty() && !l.starts_with('#'))
                .unwrap_or_default()
                .to_owned()
        };
        // A spreadsheet saved in a locale whose decimal mark is the comma separates fields by
        // semicolons: such a file becomes comma-separated, line for line, its decimal commas
        // decimal points.
        let first = first_row(&lossy);
        let semicolon = first.contains(';') && !first.contains(',');
        let lossy = if semicolon {
            std::borrow::Cow::Owned(semicolons_to_commas(&lossy))
        } else {
            lossy
        };
        let first = first_row(&lossy);
        let whitespace = !semicolon && !first.contains(',') && first.split_whitespace().count() > 1;
        let numeric_first = !first.is_empty()
            && first
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|f| !f.is_empty())
                .all(|f| f.parse::<f64>().is_ok());
        if numeric_first && columns.is_none() {
            return Err(ImportError::NoHeader {
                source_name: source_name.to_owned(),
            });
        }
        // Whitespace-separated files become comma-separated, line for line, so that line
        // numbers in errors still point into the original file.
        let normalised;
        let bytes = if whitespace {
            normalised = lossy
                .split('\n')
                .map(|l| {
                    let t = l.trim();
                    if t.starts_with('#') {
                        t.to_owned()
                    } else {
                        t.split_whitespace().collect::<Vec<_>>().join(",")
                    }
                })
                .collect::<Vec<_>>()
                .join("\n");
            normalised.as_bytes()
        } else if semicolon {
            lossy.as_bytes()
        } else {
            bytes
        };
        check_quotes(bytes, source_name)?;
        let comments = bytes
            .split(|&b| b == b'\n')
            .map(|l| String::from_utf8_lossy(l).trim().to_owned())
            .take_while(|l| l.is_empty() || l.starts_with('#'))
            .filter_map(|l| l.strip_prefix('#').map(|c| c.trim().to_owned()))
            .collect();
        let mut rdr = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(false)
            .has_headers(!numeric_first)
            .from_reader(bytes);
        let csv_err = |e: csv::Error| ImportError::Csv {
            source_name: source_name.to_owned(),
            line: e.position().map_or(0, csv::Position::line),
            message: match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => format!("{len} fields where the header has {expected_len}"),
                _ => e.to_string(),
            },
        };
        let mut header_line = 1;
        let mut header: Vec<String> = if numeric_first {
            Vec::new()
        } else {
            // the first line that is neither blank nor a comment
            header_line = bytes
                .split(|&b| b == b'\n')
                .position(|l| {
                    let t = l.trim_ascii();
                    !t.is_empty() && !t.starts_with(b"#")
                })
                .map_or(1, |i| i as u64 + 1);
            rdr.headers()
                .map_err(csv_err)?
                .iter()
                .map(str::to_owned)
                .collect()
        };
        if let Some(cols) = columns {
            header = cols.iter().map(|c| c.trim().to_owned()).collect();
        }
        if header.iter().all(String::is_empty) {
            return Err(ImportError::Empty {
                source_name: source_name.to_owned(),
                message: "no header row".into(),
            });
        }
        check_header(&header, header_line, source_name)?;
        let mut cells = String::new();
        let mut ends = Vec::new();
        let mut lines = Vec::new();
        let mut rec = csv::StringRecord::new();
        while rdr.read_record(&mut rec).map_err(csv_err)? {
            if rec.iter().all(str::is_empty) {
                continue;
            }
            let line = rec.position().map_or(0, csv::Position::line);
            if rec.len() != header.len() {
                return Err(ImportError::Csv {
                    source_name: source_name.to_owned(),
                    line,
                    message: format!("{} fields where the header has {}", rec.len(), header.len()),
                });
            }
            lines.push(line);
            for field in &rec {
                cells.push_str(field);
                ends.push(cells.len());
            }
        }
        cells.shrink_to_fit();
        ends.shrink_to_fit();
        lines.shrink_to_fit();
        if lines.is_empty() {
            return Err(ImportError::Empty {
                source_name: source_name.to_owned(),
                message: "the header is followed by no data rows".into(),
            });
        }
        Ok(Self {
            source_name: source_name.to_owned(),
            header,
            cells,
            ends,
            n_rows: lines.len(),
            lines,
            comments,
        })
    }

    /// The text of row `r`, column index `c`.
    fn cell(&self, r: usize, c: usize) -> &str {
        let i = r * self.header.len() + c;
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        &self.cells[start..self.ends[i]]
    }

    /// A numeric column over the valid rows in which an empty cell means "not recorded" (a
    /// single-sample step has no standard deviation): `None` for an empty cell.
    pub fn optional_column(&self, name: &str) -> Result<Vec<Option<f64>>, ImportError> {
        self.optional_values(name, |_, v| Ok(v))
    }

    /// An uncertainty column (a standard deviation) over the valid rows: empty cells are `None`,
    /// and every value must be a finite number ≥ 0.
    pub fn uncertainty_column(&self, name: &str) -> Result<Vec<Option<f64>>, ImportError> {
        self.optional_values(name, |r, v| {
            if v < 0.0 {
                Err(self.bad_value(r, name, "a standard deviation ≥ 0"))
            } else {
                Ok(v)
            }
        })
    }

    /// Column `name` over the valid rows, `None` for an empty cell; `check(row, value)`
    /// accepts or refuses each number.
    fn optional_values(
        &self,
        name: &str,
        check: impl Fn(usize, f64) -> Result<f64, ImportError>,
    ) -> Result<Vec<Option<f64>>, ImportError> {
        let col = self.index(name)?;
        let valid = self.valid_rows()?;
        (0..self.n_rows)
            .filter(|&r| valid[r])
            .map(|r| {
                if self.cell(r, col).is_empty() {
                    Ok(None)
                } else {
                    check(r, self.number(r, col)?).map(Some)
                }
            })
            .collect()
    }

    /// Column names, in file order.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.n_rows
    }

    /// True when the table has no data rows (never, for a parsed table).
    pub fn is_empty(&self) -> bool {
        self.n_rows == 0
    }

    /// Whether a column exists.
    pub fn has(&self, column: &str) -> bool {
        self.header.iter().any(|h| h == column)
    }

    pub(crate) fn available(&self) -> String {
        self.header
            .iter()
            .filter(|h| !h.is_empty())
            .cloned()
            .collect::<Vec<_>>()
            .join(", ")
    }

    pub(crate) fn index(&self, column: &str) -> Result<usize, ImportError> {
        self.header
            .iter()
            .position(|h| h == column)
            .ok_or_else(|| ImportError::MissingColumn {
                source_name: self.source_name.clone(),
                column: format!("{column:?}"),
                available: self.available(),
            })
    }

    fn number(&self, row: usize, col: usize) -> Result<f64, ImportError> {
        let text = self.cell(row, col);
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(ImportError::BadNumber {
                source_name: self.source_name.clone(),
                line: self.lines[row],
                column: self.header[col].clone(),
                value: text.to_owned(),
            }),
        }
    }

    /// Source line of row `r`.
    pub fn line(&self, r: usize) -> u64 {
        self.lines[r]
    }

    /// The text of one cell (empty when the column is missing).
    pub fn cell_text(&self, r: usize, column: &str) -> &str {
        self.header
            .iter()
            .position(|h| h == column)
            .map_or("", |c| self.cell(r, c))
    }

    /// One cell as a finite number.
    pub fn cell_number(&self, r: usize, column: &str) -> Result<f64, ImportError> {
        let c = self.index(column)?;
        self.number(r, c)
    }

    /// An error for a cell whose value is out of range.
    pub fn bad_value(&self, r: usize, column: &str, expected: &str) -> ImportError {
        ImportError::BadValue {
            source_name: self.source_name.clone(),
            line: self.lines[r],
            column: column.to_owned(),
            value: self.cell_text(r, column).to_owned(),
            expected: expected.to_owned(),
        }
    }

    /// Which rows count: all, or those whose `valid` column is true.
    pub(crate) fn valid_rows(&self) -> Result<Vec<bool>, ImportError> {
        let Ok(col) = self.index("valid") else {
            return Ok(vec![true; self.n_rows]);
        };
        (0..self.n_rows)
            .map(|r| match self.cell(r, col).to_ascii_lowercase().as_str() {
                "true" | "1" | "yes" => Ok(true),
                "false" | "0" | "no" => Ok(false),
                other => Err(ImportError::BadFlag {
                    source_name: self.source_name.clone(),
                    line: self.lines[r],
                    value: other.to_owned(),
                }),
            })
            .collect()
    }

    /// A numeric column over the valid rows.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, ImportError> {
        let col = self.index(name)?;
        let valid = self.valid_rows()?;
        (0..self.n_rows)
            .filter(|&r| valid[r])
            .map(|r| self.number(r, col))
            .collect()
    }

    /// The text of a column over all rows (for flags and labels).
    pub fn text_column(&self, name: &str) -> Result<Vec<&str>, ImportError> {
        let col = self.index(name)?;
        Ok((0..self.n_rows).map(|r| self.cell(r, col)).collect())
    }

    fn resolve(&self, y: &YSource) -> Result<(Vec<usize>, String), ImportError> {
        match y {
            YSource::Column(c) => Ok((vec![self.index(c)?], c.clone())),
            YSource::Product(a, b) => {
                Ok((vec![self.index(a)?, self.index(b)?], format!("{a} × {b}")))
            }
            YSource::FirstOf(options) => {
                for o in options {
                    if let Ok(r) = self.resolve(o) {
                        return Ok(r);
                    }
                }
                Err(ImportError::MissingColumn {
                    source_name: self.source_name.clone(),
                    column: options
                        .iter()
                        .map(YSource::describe)
                        .collect::<Vec<_>>()
                        .join(" or "),
                    available: self.available(),
                })
            }
        }
    }

    /// Pairs an x column with a y source over the valid rows.
    pub fn xy(&self, x: &str, y: &YSource) -> Result<XySeries, ImportError> {
        let xi = self.index(x)?;
        let (yi, y_label) = self.resolve(y)?;
        let y_name = if yi.len() == 2 {
            format!("power_w = {y_label}")
        } else {
            y_label
        };
        let valid = self.valid_rows()?;
        let mut out = XySeries {
            x: Vec::with_capacity(self.n_rows),
            y: Vec::with_capacity(self.n_rows),
            x_name: x.to_owned(),
            y_name,
            lines: Vec::with_capacity(self.n_rows),
            skipped_invalid: 0,
        };
        for (r, &is_valid) in valid.iter().enumerate() {
            if !is_valid {
                out.skipped_invalid += 1;
                continue;
            }
            out.x.push(self.number(r, xi)?);
            let mut y = 1.0;
            for &c in &yi {
                y *= self.number(r, c)?;
            }
            out.y.push(y);
            out.lines.push(self.lines[r]);
        }
        if out.x.is_empty() {
            return Err(ImportError::Empty {
                source_name: self.source_name.clone(),
                message: if out.skipped_invalid == 1 {
                    "the only row is marked invalid: nothing to fit".to_owned()
                } else {
                    format!(
                        "all {} rows are marked invalid: nothing to fit",
                        out.skipped_invalid
                    )
                },
            });
        }
        Ok(out)
    }
}

/// Refuses a header that names a column twice or holds a control character.
fn check_header(header: &[String], line: u64, source_name: &str) -> Result<(), ImportError> {
    let bad = |column: usize, message: String| ImportError::BadHeader {
        source_name: source_name.to_owned(),
        line,
        column,
        message,
    };
    for (i, h) in header.iter().enumerate() {
        if let Some(c) = h.chars().find(|c| c.is_control()) {
            return Err(bad(
                i + 1,
                format!(
                    "the column name {h:?} holds the control character U+{:04X}; the file is corrupt or not text",
                    u32::from(c)
                ),
            ));
        }
        if h.is_empty() {
            continue;
        }
        if let Some(first) = header[..i].iter().position(|o| o == h) {
            return Err(bad(
                i + 1,
                format!(
                    "column {h:?} appears twice (also column {}); which one is meant is not clear",
                    first + 1
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses text whose last quoted field is never closed (the CSV reader would otherwise take the
/// rest of the file as one cell). `#` comment lines are not CSV and are skipped.
/// A semicolon-separated text as comma-separated CSV, line for line: `#` comment lines as they
/// are; in every other line each field (double quotes kept together, a `;` inside them is
/// text) has a decimal comma (`12,5`, one comma and no point) turned into a point, and a field
/// that still holds a comma or a quote is quoted.
fn semicolons_to_commas(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 16);
    for (i, line) in text.split('\n').enumerate() {
        if i > 0 {
            out.push('\n');
        }
        let line = line.strip_suffix('\r').unwrap_or(line);
        if line.trim_start().starts_with('#') {
            out.push_str(line);
            continue;
        }
        let mut fields = Vec::new();
        let mut field = String::new();
        let mut quoted = false;
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                '"' if quoted && chars.peek() == Some(&'"') => {
                    field.push('"');
                    chars.next();
                }
                '"' => quoted = !quoted,
                ';' if !quoted => fields.push(std::mem::take(&mut field)),
                c => field.push(c),
            }
        }
        if quoted {
            // An unclosed quote: left as it was, for the quote check to name.
            out.push_str(line);
            continue;
        }
        fields.push(field);
        for (j, f) in fields.iter().enumerate() {
            if j > 0 {
                out.push(',');
            }
            let t = f.trim();
            let decimal = t.matches(',').count() == 1
                && !t.contains('.')
                && t.replace(',', ".").parse::<f64>().is_ok();
            if decimal {
                out.push_str(&t.replace(',', "."));
            } else if t.contains([',', '"']) {
                out.push('"');
                out.push_str(&t.replace('"', "\"\""));
                out.push('"');
            } else {
                out.push_str(t);
            }
        }
    }
    out
}

fn check_quotes(bytes: &[u8], source_name: &str) -> Result<(), ImportError> {
    let mut in_quote: Option<(u64, usize)> = None;
    let mut line = 1u64;
    let mut line_start = 0usize;
    let mut at_line_start = true;
    let mut comment = false;
    for (i, &b) in bytes.iter().enumerate() {
        if at_line_start && in_quote.is_none() {
            comment = b == b'#';
        }
        at_line_start = false;
        match b {
            b'\n' => {
                line += 1;
                line_start = i + 1;
                at_line_start = true;
                if in_quote.is_none() {
                    comment = false;
                }
            }
            b'"' if !comment => {
                in_quote = match in_quote {
                    Some(_) => None,
                    None => {
                        let column = String::from_utf8_lossy(&bytes[line_start..i])
                            .chars()
                            .count()
                            + 1;
                        Some((line, column))
                    }
                };
            }
            _ => {}
        }
    }
    match in_quote {
        Some((line, column)) => Err(ImportError::UnterminatedQuote {
            source_name: source_name.to_owned(),
            line,
            column,
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn semicolon_files_with_decimal_commas_read_as_their_numbers() {
        let text = "# Stand export, de-DE\r\nZeit (s);Schub [N];Spannung (V);Strom (A);Notiz\r\n\
                    0;0,5;12,1;1,25;\"a; b\"\r\n1;1,5;12;3,4;\"x,y\"\r\n2;-2,5e-1;11,9;5;\r\n";
        let t = Table::parse(text.as_bytes(), "de.csv").unwrap();
        assert_eq!(
            t.header(),
            [
                "Zeit (s)",
                "Schub [N]",
                "Spannung (V)",
                "Strom (A)",
                "Notiz"
            ]
        );
        assert_eq!(t.column("Schub [N]").unwrap(), [0.5, 1.5, -0.25]);
        assert_eq!(t.column("Spannung (V)").unwrap(), [12.1, 12.0, 11.9]);
        assert_eq!(t.cell_text(0, "Notiz"), "a; b");
        assert_eq!(t.cell_text(1, "Notiz"), "x,y");
        assert_eq!(t.line(2), 5);
        let e = t
            .xy("Zeit (s)", &YSource::Column("Notiz".into()))
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("de.csv, line 3, column \"Notiz\""),
            "{e}"
        );
        // A thousands separator with a decimal comma is not guessed at.
        let t = Table::parse(b"a;b\n1.234,5;2\n", "t.csv").unwrap();
        assert!(t.column("a").is_err());
    }

    #[test]
    fn flight_logs_are_refused_by_what_they_are() {
        let e = Table::parse(b"ULog\x01\x12\x35\x01\0", "f.ulg").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("f.ulg: a PX4 ULog flight log, not a CSV table")
        );
        let e = Table::parse(b"\xA3\x95\x80rest", "log.bin").unwrap_err();
        assert!(e.to_string().starts_with(
            "log.bin: an ArduPilot DataFlash flight log, not a CSV table; flight logs are read"
        ));
        let e = Table::parse(
            b"FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\r\nFMT, 147, 21, BAT, Qff, TimeUS,Volt,Curr\r\n",
            "00000042.log",
        )
        .unwrap_err();
        assert!(e.to_string().starts_with(
            "00000042.log: an ArduPilot DataFlash flight log as text, not a CSV table; flight logs"
        ));
        let e = Table::parse(
            b"9\r\n\r\nArduCopter V3.1 (5c6503e2)\r\nFree RAM: 1044\r\nAPM 2\r\nFMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format\r\n",
            "mechanical_fail.log",
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .contains("an ArduPilot DataFlash flight log as text"),
            "{e}"
        );
        let mut tlog = 1_436_056_003_000_000u64.to_be_bytes().to_vec();
        tlog.extend([0xFE, 9, 0, 255, 0, 0]);
        let e = Table::parse(&tlog, "flight.tlog").unwrap_err();
        assert!(e.to_string().starts_with(
            "flight.tlog: a MAVLink telemetry log (.tlog), not a CSV table; flight logs"
        ));
        // Text that is not UTF-8 (a Latin-1 degree sign in a comment) is still a table.
        let t = Table::parse(b"# rig at 20 \xB0C\nthrust_g,power_w\n10,1.5\n", "l.csv").unwrap();
        assert_eq!(t.len(), 1);
    }

    #[test]
    fn errors_name_line_and_column() {
        let t = Table::parse(b"thrust_g,power_w\n10,1.5\n20,NaN\n", "s.csv").unwrap();
        let e = t.xy("thrust_g", &YSource::power_default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.csv, line 3, column \"power_w\": \"NaN\" is not a finite number"
        );
        let e = t.xy("thrust", &YSource::power_default()).unwrap_err();
        assert!(
            e.to_string()
                .contains("no column \"thrust\"; the header has: thrust_g, power_w")
        );
        let e = Table::parse(b"a,b\n1,2\n3\n", "r.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "r.csv, line 3: 1 fields where the header has 2"
        );
        assert!(Table::parse(b"a,b\n", "e.csv").is_err());
        assert!(Table::parse(b"", "e.csv").is_err());
    }

    #[test]
    fn a_column_named_twice_is_an_error() {
        let e = Table::parse(b"# x\nthrust_g,power_w,thrust_g\n1,2,3\n", "d.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "d.csv, line 2, column 3: column \"thrust_g\" appears twice (also column 1); which one is meant is not clear"
        );
        // several empty names (trailing commas) are fine
        assert!(Table::parse(b"a,b,,\n1,2,,\n", "e.csv").is_ok());
    }

    #[test]
    fn a_nul_byte_in_the_header_is_an_error() {
        let e = Table::parse(b"thrust_g,power_w,val\0id\n1,2,false\n", "n.csv").unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("n.csv, line 1, column 3: "), "{msg}");
        assert!(msg.contains("U+0000"), "{msg}");
    }

    #[test]
    fn an_unterminated_quote_is_an_error_at_the_quote() {
        let e = Table::parse(b"name,cells\nA,3\n\"B,4\n", "c.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "c.csv, line 3, column 1: a quote opens here and is never closed"
        );
        // quotes in comments, doubled quotes and quoted commas are fine
        let t = Table::parse(b"# the \"rig\nname,cells\n\"A, \"\"big\"\"\",3\n", "q.csv").unwrap();
        assert_eq!(t.cell_text(0, "name"), "A, \"big\"");
    }

    #[test]
    fn empty_uncertainties_are_missing_and_negative_ones_refused() {
        let t = Table::parse(b"thrust_g,thrust_std_g\n1,\n2,0.5\n3,-1\n", "u.csv").unwrap();
        let e = t.uncertainty_column("thrust_std_g").unwrap_err();
        assert_eq!(
            e.to_string(),
            "u.csv, line 4, column \"thrust_std_g\": \"-1\" is not a standard deviation ≥ 0"
        );
        let t = Table::parse(b"thrust_g,thrust_std_g\n1,\n2,0.5\n", "u.csv").unwrap();
        assert_eq!(
            t.uncertainty_column("thrust_std_g").unwrap(),
            [None, Some(0.5)]
        );
        let t = Table::parse(b"thrust_g,thrust_std_g\n1,NaN\n", "u.csv").unwrap();
        assert!(t.uncertainty_column("thrust_std_g").is_err());
    }

    #[test]
    fn bom_comments_and_trailing_comma() {
        let t = Table::parse(
            "\u{feff}# rig: x\n# supply: 12.5 V\nTime (s),Thrust (gf),\n0.5, 12 ,\n1.0,13,\n"
                .as_bytes(),
            "tyto.csv",
        )
        .unwrap();
        assert_eq!(t.comments, ["rig: x", "supply: 12.5 V"]);
        assert_eq!(t.column("Thrust (gf)").unwrap(), [12.0, 13.0]);
    }

    #[test]
    fn a_single_invalid_row_is_not_one_rows() {
        let t = Table::parse(b"thrust_g,power_w,valid\n1,2,false\n", "v.csv").unwrap();
        let e = t.xy("thrust_g", &YSource::power_default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "v.csv: the only row is marked invalid: nothing to fit"
        );
    }

    #[test]
    fn power_column_wins_over_product() {
        let t = Table::parse(b"thrust_g,voltage_v,current_a,power_w\n1,2,3,7\n", "p").unwrap();
        let xy = t.xy("thrust_g", &YSource::power_default()).unwrap();
        assert_eq!(xy.y, [7.0]);
        assert_eq!(xy.y_name, "power_w");
    }

    #[test]
    fn sha256_of_known_text() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    proptest! {
        #[test]
        fn parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
            if let Ok(t) = Table::parse(&bytes, "fuzz") {
                let first = t.header()[0].clone();
                let _ = t.xy(&first, &YSource::power_default());
            }
        }

        #[test]
        fn numbers_round_trip(v in proptest::collection::vec(-1e6f64..1e6, 1..20)) {
            let mut s = String::from("x,y\n");
            for (i, x) in v.iter().enumerate() {
                s.push_str(&format!("{i},{x}\n"));
            }
            let t = Table::parse(s.as_bytes(), "p").unwrap();
            prop_assert_eq!(t.column("y").unwrap(), v);
        }

        #[test]
        fn decimal_commas_read_as_the_same_numbers(
            v in proptest::collection::vec(-1e6f64..1e6, 1..20),
            semicolon_text in "[a-z ;,]{0,8}",
        ) {
            // What a spreadsheet in a comma-decimal locale writes: `;` between fields, `,` for
            // the decimal mark, text with either quoted.
            let quoted = format!("\"{semicolon_text}\"");
            let mut s = String::from("i;y (V);note\n");
            for (i, x) in v.iter().enumerate() {
                s.push_str(&format!("{i};{};{quoted}\n", format!("{x}").replace('.', ",")));
            }
            let t = Table::parse(s.as_bytes(), "p").unwrap();
            prop_assert_eq!(t.column("y (V)").unwrap(), v);
            prop_assert_eq!(t.cell_text(0, "note"), semicolon_text.trim());
        }
    }
}
