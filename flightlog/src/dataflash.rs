//! ArduPilot DataFlash (`.bin`): a small, bounds-checked reader of the self-describing format
//! (ArduPilot `libraries/AP_Logger/LogStructure.h`), and what a flight takes from it.
//!
//! A log is a sequence of messages `{0xA3, 0x95, type, payload}`. Type 128 (`FMT`, 89 bytes)
//! defines a type: `Type` (u8), `Length` (u8, the whole message), `Name` (`char[4]`), `Format`
//! (`char[16]`, one character per field) and `Labels` (`char[64]`, comma-separated). Format
//! characters: `b`/`B` i8/u8, `M` u8 mode, `h`/`H` i16/u16, `i`/`I` i32/u32, `f` f32,
//! `d` f64, `q`/`Q` i64/u64, `n`/`N`/`Z` `char[4]`/`[16]`/`[64]`, `a` `i16[32]`, `c`/`C` i16/u16 × 0.01,
//! `e`/`E` i32/u32 × 0.01, `L` i32 latitude/longitude × 1e-7. This reader applies those scale
//! factors (not the optional `FMTU`/`MULT` unit tables), skips bytes that are not a known
//! message (counted as a warning, as logs written to flash blocks can hold them), refuses a
//! `FMT` whose length disagrees with its format, and ends at a truncated final message with a
//! warning.
//!
//! The same log as text (`.log`, [`DataFlash::parse_text`]) has one message per line,
//! `NAME, value, …`, each type defined by an `FMT, type, length, NAME, format, labels` line;
//! each line is encoded as the `.bin` would hold it, so a text log is read by the same code
//! and gives the same flight (a test checks it on every real `.bin` of `../shared`), its
//! positions in errors and warnings being lines instead of bytes.
//!
//! A flight takes `BAT` (`TimeUS`, `Volt`, `Curr`; the lowest `Instance`), and for altitude
//! `CTUN.Alt` (else ArduCopter 3.0–3.2's `CTUN.BarAlt`, else `BARO.Alt`, lowest instance) and throttle `CTUN.ThO` (0–1), both
//! interpolated onto the battery's times, as are the motor commands: `RCOU`'s `C1`…`C14`
//! (ArduCopter 3.x: `Ch1`…), PWM µs, of the frame's motors (`FRAME_CLASS`, else the `Frame:`
//! message of older firmware; their outputs from `SERVOn_FUNCTION` when logged), not read (a
//! warning says why) for a frame not known or a command outside
//! [`crate::motors::PWM_RANGE_US`] ([`crate::motors`]). Time is `BAT.TimeUS` (or `TimeMS`) from its first
//! sample, s. A message without a time field (ArduCopter 3.0–3.1's `CURR` and `CTUN`) takes
//! its times from the log's [`Clock`]: those of the most frequent message type that has them
//! (`IMU.TimeMS`, `GPS.TimeMS`, 3.0's `GPS.Time`), interpolated by position in the log
//! (checked on a real 3.1 log against the firmware's own charge counter: 1 %).

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;

use crate::battery::{self, Track};
use crate::{Decoded, FlightLogError, LogInfo, Row, Vehicle, VehicleKind};

/// The two bytes that start every message.
pub const MAGIC: [u8; 2] = [0xA3, 0x95];
/// Type of the `FMT` message.
pub const FMT_TYPE: u8 = 0x80;
/// Length of the `FMT` message, bytes (header included).
pub const FMT_LEN: usize = 89;

/// Size in bytes of one format character's field.
pub fn field_size(c: u8) -> Option<usize> {
    Some(match c {
        b'b' | b'B' | b'M' => 1,
        b'h' | b'H' | b'c' | b'C' => 2,
        b'i' | b'I' | b'f' | b'e' | b'E' | b'L' | b'n' => 4,
        b'd' | b'q' | b'Q' => 8,
        b'N' => 16,
        b'a' | b'Z' => 64,
        _ => return None,
    })
}

/// Decodes one numeric field as `f64` with its format's scale (`None` for text and arrays or
/// when `bytes` is too short).
pub fn decode_field(c: u8, bytes: &[u8]) -> Option<f64> {
    fn arr<const N: usize>(b: &[u8]) -> Option<[u8; N]> {
        b.get(..N)?.try_into().ok()
    }
    Some(match c {
        b'b' => f64::from(i8::from_le_bytes(arr(bytes)?)),
        b'B' | b'M' => f64::from(*bytes.first()?),
        b'h' => f64::from(i16::from_le_bytes(arr(bytes)?)),
        b'H' => f64::from(u16::from_le_bytes(arr(bytes)?)),
        b'i' => f64::from(i32::from_le_bytes(arr(bytes)?)),
        b'I' => f64::from(u32::from_le_bytes(arr(bytes)?)),
        b'f' => f64::from(f32::from_le_bytes(arr(bytes)?)),
        b'd' => f64::from_le_bytes(arr(bytes)?),
        b'q' => i64::from_le_bytes(arr(bytes)?) as f64,
        b'Q' => u64::from_le_bytes(arr(bytes)?) as f64,
        b'c' => f64::from(i16::from_le_bytes(arr(bytes)?)) * 0.01,
        b'C' => f64::from(u16::from_le_bytes(arr(bytes)?)) * 0.01,
        b'e' => f64::from(i32::from_le_bytes(arr(bytes)?)) * 0.01,
        b'E' => f64::from(u32::from_le_bytes(arr(bytes)?)) * 0.01,
        b'L' => f64::from(i32::from_le_bytes(arr(bytes)?)) * 1e-7,
        _ => return None,
    })
}

/// A message type defined by a `FMT`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MessageFormat {
    /// Type byte.
    pub msg_type: u8,
    /// Whole message length, bytes.
    pub length: usize,
    /// Name (`BAT`, `CTUN`, …).
    pub name: String,
    /// Format characters.
    pub format: Vec<u8>,
    /// Field labels.
    pub labels: Vec<String>,
    /// Byte offset of its `FMT` message.
    pub defined_at: u64,
    /// Why its fields cannot be located (an unknown format character, a length that disagrees
    /// with the format), if so; its messages are still skipped by their length.
    pub problem: Option<String>,
}

impl MessageFormat {
    /// Offset in the payload and format character of a labelled field.
    pub fn field(&self, label: &str) -> Option<(usize, u8)> {
        if self.problem.is_some() {
            return None;
        }
        let k = self.labels.iter().position(|l| l == label)?;
        let offset = self
            .format
            .get(..k)?
            .iter()
            .map(|&c| field_size(c).unwrap_or(0))
            .sum();
        Some((offset, *self.format.get(k)?))
    }
}

/// One message: its position (byte offset, or line of a text log) and payload.
type Message<'a> = (u64, Cow<'a, [u8]>);

/// A DataFlash log's formats and messages: borrowed from its bytes for a `.bin`, encoded from
/// its lines for a text log ([`DataFlash::parse_text`]).
#[derive(Debug)]
pub struct DataFlash<'a> {
    formats: HashMap<u8, MessageFormat>,
    /// Messages per type: `(position, payload)`, in file order; the position is a byte offset
    /// in a `.bin` and a 1-based line number in a text log.
    messages: HashMap<u8, Vec<Message<'a>>>,
    /// Whether the log was text (positions are lines, not bytes).
    text: bool,
    /// The lines of a text log before its first `FMT` (APM 2's banner: log number, firmware,
    /// free RAM, board); empty for a `.bin`.
    pub preamble: Vec<String>,
    /// What was skipped (bytes that are not a message, a truncated tail).
    pub warnings: Vec<String>,
}

/// Text of a NUL-padded char array.
fn text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).trim().to_owned()
}

/// Lines a text log may open with before its first `FMT` line: APM 2's banner (log number,
/// firmware, free RAM, board), none of them with a comma.
pub const MAX_PREAMBLE_LINES: usize = 16;

/// Whether bytes look like ArduPilot's DataFlash as text: an `FMT` line
/// (`FMT, 128, 89, FMT, BBnNZ, …` in every converter's output) first, or after APM 2's
/// banner of at most [`MAX_PREAMBLE_LINES`] lines without a comma.
pub fn is_text_log(bytes: &[u8]) -> bool {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    for line in bytes
        .split(|&b| b == b'\n')
        .map(<[u8]>::trim_ascii)
        .filter(|l| !l.is_empty())
        .take(MAX_PREAMBLE_LINES + 1)
    {
        let mut t = line.split(|&b| b == b',').map(<[u8]>::trim_ascii);
        if t.next() == Some(b"FMT") {
            return t
                .next()
                .is_some_and(|x| !x.is_empty() && x.iter().all(u8::is_ascii_digit));
        }
        if line.contains(&b',') {
            return false;
        }
    }
    false
}

/// An integer value of a text log as the field stores it: written as an integer, or as a
/// number with a fraction (rounded), within `lo..=hi`.
fn text_integer(token: &str, lo: i128, hi: i128) -> Result<i128, String> {
    let v = match token.parse::<i128>() {
        Ok(v) => v,
        Err(_) => {
            let x: f64 = token
                .parse()
                .map_err(|_| format!("{token:?} is not a number"))?;
            if !x.is_finite() {
                return Err(format!("{token:?} is not a finite number"));
            }
            x.round() as i128
        }
    };
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{token} is outside {lo}…{hi}"))
    }
}

/// Encodes the values of one text-log line (split at commas, untrimmed) into the payload a
/// `.bin` would hold for it.
fn encode_text_line(format: &MessageFormat, values: &[&str]) -> Result<Vec<u8>, String> {
    let fields = format.format.len();
    let joined: Vec<String>;
    let values: Vec<&str> = if values.len() > fields {
        // A text field that held commas: join the extra values back into it.
        let texts: Vec<usize> = (0..fields)
            .filter(|&k| matches!(format.format[k], b'n' | b'N' | b'Z'))
            .collect();
        let [k] = texts.as_slice() else {
            return Err(format!("{} values for {fields} fields", values.len()));
        };
        let extra = values.len() - fields;
        joined = vec![values[*k..=*k + extra].join(",").trim().to_owned()];
        values[..*k]
            .iter()
            .copied()
            .chain(joined.iter().map(String::as_str))
            .chain(values[*k + extra + 1..].iter().copied())
            .collect()
    } else {
        values.to_vec()
    };
    if values.len() < fields {
        return Err(format!("{} values for {fields} fields", values.len()));
    }
    let mut out = Vec::with_capacity(format.length.saturating_sub(3));
    for (&c, token) in format.format.iter().zip(&values) {
        let token = token.trim();
        let real = || -> Result<f64, String> {
            token
                .parse::<f64>()
                .map_err(|_| format!("{token:?} is not a number"))
        };
        let scaled = |scale: f64, lo: i128, hi: i128| -> Result<i128, String> {
            let x = real()?;
            if !x.is_finite() {
                return Err(format!("{token:?} is not a finite number"));
            }
            let v = (x * scale).round() as i128;
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(format!("{token} is outside the field's range"))
            }
        };
        match c {
            b'b' => out.extend((text_integer(token, -128, 127)? as i8).to_le_bytes()),
            b'B' => out.extend((text_integer(token, 0, 255)? as u8).to_le_bytes()),
            // A flight mode, which text logs may write by name (`STABILIZE`): a name is kept
            // as 255, as nothing here reads modes.
            b'M' => out.push(text_integer(token, 0, 255).map_or(255, |m| m as u8)),
            b'h' => out.extend(
                (text_integer(token, i16::MIN.into(), i16::MAX.into())? as i16).to_le_bytes(),
            ),
            b'H' => out.extend((text_integer(token, 0, u16::MAX.into())? as u16).to_le_bytes()),
            b'i' => out.extend(
                (text_integer(token, i32::MIN.into(), i32::MAX.into())? as i32).to_le_bytes(),
            ),
            b'I' => out.extend((text_integer(token, 0, u32::MAX.into())? as u32).to_le_bytes()),
            b'q' => out.extend(
                (text_integer(token, i64::MIN.into(), i64::MAX.into())? as i64).to_le_bytes(),
            ),
            b'Q' => out.extend((text_integer(token, 0, u64::MAX.into())? as u64).to_le_bytes()),
            b'f' => out.extend((real()? as f32).to_le_bytes()),
            b'd' => out.extend(real()?.to_le_bytes()),
            b'c' => {
                out.extend((scaled(100.0, i16::MIN.into(), i16::MAX.into())? as i16).to_le_bytes())
            }
            b'C' => out.extend((scaled(100.0, 0, u16::MAX.into())? as u16).to_le_bytes()),
            b'e' => {
                out.extend((scaled(100.0, i32::MIN.into(), i32::MAX.into())? as i32).to_le_bytes())
            }
            b'E' => out.extend((scaled(100.0, 0, u32::MAX.into())? as u32).to_le_bytes()),
            b'L' => {
                // Degrees as converters write them; an integer beyond ±1000 is raw 1e-7 units.
                let raw = match token.parse::<i64>() {
                    Ok(v) if v.abs() > 1000 => i128::from(v),
                    _ => scaled(1e7, i32::MIN.into(), i32::MAX.into())?,
                };
                let v = i32::try_from(raw)
                    .map_err(|_| format!("{token} is outside the field's range"))?;
                out.extend(v.to_le_bytes());
            }
            b'n' | b'N' | b'Z' => {
                let size = field_size(c).unwrap_or(0);
                let mut b = token.as_bytes().to_vec();
                b.resize(size, 0);
                out.extend(b);
            }
            // `int16[32]`: no text form is agreed on and nothing here reads one.
            b'a' => out.extend([0u8; 64]),
            other => return Err(format!("unknown format character {:?}", char::from(other))),
        }
    }
    Ok(out)
}

impl<'a> DataFlash<'a> {
    /// Parses a DataFlash log held in memory; `path` names it in errors.
    pub fn parse(bytes: &'a [u8], path: &Path) -> Result<Self, FlightLogError> {
        let fail = |offset: usize, field: &str, message: String| {
            FlightLogError::binary(path, offset as u64, field, message)
        };
        if !bytes.starts_with(&MAGIC) {
            return Err(fail(
                0,
                "header",
                "not a DataFlash log (it does not start with bytes A3 95)".to_owned(),
            ));
        }
        let mut log = DataFlash {
            formats: HashMap::new(),
            messages: HashMap::new(),
            text: false,
            preamble: Vec::new(),
            warnings: Vec::new(),
        };
        let mut skipped = 0usize;
        let mut first_skip = None;
        let mut pos = 0usize;
        while pos < bytes.len() {
            let known = bytes[pos..].starts_with(&MAGIC)
                && bytes
                    .get(pos + 2)
                    .is_some_and(|&t| t == FMT_TYPE || log.formats.contains_key(&t));
            if !known {
                if pos + 3 > bytes.len()
                    && bytes[pos..].iter().all(|&b| b == MAGIC[0] || b == MAGIC[1])
                {
                    log.warnings.push(format!(
                        "byte {pos}: truncated message header at the end; ignored"
                    ));
                    break;
                }
                // Not a message: resynchronise at the next magic.
                let next = bytes[pos + 1..]
                    .windows(2)
                    .position(|w| w == MAGIC)
                    .map_or(bytes.len(), |p| pos + 1 + p);
                first_skip.get_or_insert(pos);
                skipped += next - pos;
                pos = next;
                continue;
            }
            let kind = bytes[pos + 2];
            let length = if kind == FMT_TYPE {
                FMT_LEN
            } else {
                log.formats.get(&kind).map_or(FMT_LEN, |f| f.length)
            };
            let Some(payload) = bytes.get(pos + 3..pos + length) else {
                log.warnings.push(format!(
                    "byte {pos}: final message ({length} bytes) truncated at the end; ignored"
                ));
                break;
            };
            if kind == FMT_TYPE {
                let msg_type = payload[0];
                let length = usize::from(payload[1]);
                let name = text(&payload[2..6]);
                let format: Vec<u8> = payload[6..22]
                    .iter()
                    .copied()
                    .take_while(|&b| b != 0)
                    .collect();
                let labels: Vec<String> = text(&payload[22..86])
                    .split(',')
                    .map(|s| s.trim().to_owned())
                    .collect();
                if msg_type == FMT_TYPE {
                    if length != FMT_LEN {
                        return Err(fail(
                            pos,
                            "FMT.Length",
                            format!("FMT redefined with length {length}, not {FMT_LEN}"),
                        ));
                    }
                    pos += FMT_LEN;
                    continue;
                }
                if length < 3 {
                    log.warnings.push(format!(
                        "byte {pos}: FMT of type {msg_type} ({name}) has length {length} < 3; type ignored"
                    ));
                    pos += FMT_LEN;
                    continue;
                }
                let problem = if let Some(&bad) = format.iter().find(|&&c| field_size(c).is_none())
                {
                    Some(format!("unknown format character {:?}", char::from(bad)))
                } else {
                    let size: usize =
                        3 + format.iter().filter_map(|&c| field_size(c)).sum::<usize>();
                    (size != length).then(|| {
                        format!(
                            "length {length} but its format {:?} takes {size} bytes",
                            String::from_utf8_lossy(&format)
                        )
                    })
                };
                if let Some(p) = &problem {
                    log.warnings
                        .push(format!("byte {pos}: FMT of type {msg_type} ({name}): {p}"));
                }
                if labels.len() != format.len() {
                    log.warnings.push(format!(
                        "byte {pos}: FMT of type {msg_type} ({name}): {} labels for {} fields",
                        labels.len(),
                        format.len()
                    ));
                }
                log.formats.insert(
                    msg_type,
                    MessageFormat {
                        msg_type,
                        length,
                        name,
                        format,
                        labels,
                        defined_at: pos as u64,
                        problem,
                    },
                );
            } else {
                log.messages
                    .entry(kind)
                    .or_default()
                    .push((pos as u64, Cow::Borrowed(payload)));
            }
            pos += length;
        }
        if skipped > 0 {
            log.warnings.push(format!(
                "{skipped} byte(s) that are not a known message skipped (first at byte {})",
                first_skip.unwrap_or(0)
            ));
        }
        Ok(log)
    }

    /// Parses ArduPilot's DataFlash as text (Mission Planner's "convert .bin to .log", older
    /// firmware's own text logs): one message per line, `NAME, value, value, …`, each type
    /// defined by an earlier `FMT, type, length, NAME, format, Label1,Label2,…` line; the
    /// lines before the first `FMT` (APM 2's banner) are kept as [`DataFlash::preamble`]. Each
    /// line is encoded as the `.bin` would hold it, so everything after this reads a text log
    /// exactly as a binary one; positions are 1-based lines.
    ///
    /// Values are read as the text writes them: scaled fields (`c`, `C`, `e`, `E`) in their
    /// units (`12.34`, not `1234`) and `L` in degrees (an integer beyond ±1000 is taken as the
    /// raw 1e-7 units). A text field may hold commas (a `MSG`): when a line has more values
    /// than its format, the extra ones are joined back into its one text field. A flight mode
    /// (`M`) written by name is kept as 255 (nothing here reads modes). Lines of an
    /// undefined type, with too few values or a value that does not fit its field, are
    /// skipped and counted in [`DataFlash::warnings`]; an `FMT` line that cannot be read is an
    /// error.
    pub fn parse_text(bytes: &[u8], path: &Path) -> Result<DataFlash<'static>, FlightLogError> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        if !is_text_log(bytes) {
            return Err(FlightLogError::TextLog {
                path: path.to_owned(),
                line: 1,
                field: "FMT".to_owned(),
                message: "not an ArduPilot text log (its first line is not an FMT line)".to_owned(),
            });
        }
        let mut log = DataFlash {
            formats: HashMap::new(),
            messages: HashMap::new(),
            text: true,
            preamble: Vec::new(),
            warnings: Vec::new(),
        };
        let mut by_name: HashMap<String, u8> = HashMap::new();
        let mut in_preamble = true;
        // (count, first line) of each kind of line skipped.
        let mut undefined = (0usize, 0u64);
        let mut malformed = (0usize, 0u64, String::new());
        for (k, raw) in bytes.split(|&b| b == b'\n').enumerate() {
            let line_no = k as u64 + 1;
            let line = String::from_utf8_lossy(raw);
            let line = line.trim();
            if line.is_empty() {
                continue;
            }
            // Untrimmed: a text field that held commas is joined back as it was written.
            let raw_tokens: Vec<&str> = line.split(',').collect();
            let tokens: Vec<&str> = raw_tokens.iter().map(|t| t.trim()).collect();
            let name = tokens[0];
            in_preamble &= name != "FMT";
            if in_preamble {
                log.preamble.push(line.to_owned());
                continue;
            }
            if name == "FMT" {
                let fail = |field: &str, message: String| FlightLogError::TextLog {
                    path: path.to_owned(),
                    line: line_no,
                    field: format!("FMT.{field}"),
                    message,
                };
                if tokens.len() < 5 {
                    return Err(fail(
                        "Format",
                        format!(
                            "{} values where an FMT line has at least 5 (type, length, name, format, labels)",
                            tokens.len() - 1
                        ),
                    ));
                }
                let msg_type: u8 = tokens[1].parse().map_err(|_| {
                    fail(
                        "Type",
                        format!("{:?} is not a message type (0–255)", tokens[1]),
                    )
                })?;
                let length: usize = tokens[2]
                    .parse()
                    .map_err(|_| fail("Length", format!("{:?} is not a length", tokens[2])))?;
                if msg_type == FMT_TYPE {
                    continue;
                }
                let type_name = tokens[3].to_owned();
                let format = tokens[4].as_bytes().to_vec();
                let labels: Vec<String> = tokens[5..]
                    .iter()
                    .map(|l| (*l).to_owned())
                    .filter(|l| !l.is_empty())
                    .collect();
                let problem = format
                    .iter()
                    .find(|&&c| field_size(c).is_none())
                    .map(|&bad| format!("unknown format character {:?}", char::from(bad)));
                if let Some(p) = &problem {
                    log.warnings.push(format!(
                        "line {line_no}: FMT of type {msg_type} ({type_name}): {p}"
                    ));
                }
                if labels.len() != format.len() {
                    log.warnings.push(format!(
                        "line {line_no}: FMT of type {msg_type} ({type_name}): {} labels for {} fields",
                        labels.len(),
                        format.len()
                    ));
                }
                by_name.insert(type_name.clone(), msg_type);
                log.formats.insert(
                    msg_type,
                    MessageFormat {
                        msg_type,
                        length,
                        name: type_name,
                        format,
                        labels,
                        defined_at: line_no,
                        problem,
                    },
                );
                continue;
            }
            let Some(format) = by_name.get(name).and_then(|t| log.formats.get(t)) else {
                if undefined.0 == 0 {
                    undefined.1 = line_no;
                }
                undefined.0 += 1;
                continue;
            };
            if format.problem.is_some() {
                continue;
            }
            match encode_text_line(format, &raw_tokens[1..]) {
                Ok(payload) => log
                    .messages
                    .entry(format.msg_type)
                    .or_default()
                    .push((line_no, Cow::Owned(payload))),
                Err(why) => {
                    if malformed.0 == 0 {
                        malformed.1 = line_no;
                        malformed.2 = format!("{name}: {why}");
                    }
                    malformed.0 += 1;
                }
            }
        }
        if undefined.0 > 0 {
            log.warnings.push(format!(
                "{} line(s) of a message type no FMT line defines skipped (first at line {})",
                undefined.0, undefined.1
            ));
        }
        if malformed.0 > 0 {
            log.warnings.push(format!(
                "{} line(s) that do not fit their format skipped (first at line {}, {})",
                malformed.0, malformed.1, malformed.2
            ));
        }
        Ok(log)
    }

    /// Where a message is, as errors and warnings say it: `byte N` in a `.bin`, `line N` in
    /// a text log.
    pub fn position(&self, at: u64) -> String {
        if self.text {
            format!("line {at}")
        } else {
            format!("byte {at}")
        }
    }

    /// An error about `field` of the message at position `at` (a byte offset, or a line of a
    /// text log).
    pub fn error(
        &self,
        path: &Path,
        at: u64,
        field: impl Into<String>,
        message: String,
    ) -> FlightLogError {
        if self.text {
            FlightLogError::TextLog {
                path: path.to_owned(),
                line: at,
                field: field.into(),
                message,
            }
        } else {
            FlightLogError::binary(path, at, field, message)
        }
    }

    /// The format of a message name.
    pub fn format(&self, name: &str) -> Option<&MessageFormat> {
        self.formats.values().find(|f| f.name == name)
    }

    /// Names of the message types that have messages, sorted.
    pub fn names(&self) -> Vec<&str> {
        let mut n: Vec<&str> = self
            .messages
            .keys()
            .filter_map(|k| self.formats.get(k).map(|f| f.name.as_str()))
            .collect();
        n.sort_unstable();
        n
    }

    /// Values of numeric fields of one message type, one row per message, keeping the lowest
    /// instance when the type has an `Instance`/`Inst`/`I` field. `Ok(None)` when there are
    /// no such messages; a field the format lacks is `None` when `required` is false, else an
    /// error. (See [`DataFlash::rows`] for any instance.)
    pub fn columns(
        &self,
        name: &str,
        fields: &[(&str, bool)],
        path: &Path,
    ) -> Result<Option<Vec<Row>>, FlightLogError> {
        if !self.has(name) {
            return Ok(None);
        }
        let instance = self.instances(name).first().copied();
        self.rows(name, instance, fields, path).map(Some)
    }

    /// Whether the log has messages of a type.
    pub fn has(&self, name: &str) -> bool {
        self.format(name)
            .is_some_and(|f| self.messages.contains_key(&f.msg_type))
    }

    /// The label of a type's instance field (`Instance`, `Inst` or `I`), if it has one.
    fn instance_slot(&self, name: &str) -> Option<(usize, u8)> {
        let format = self.format(name)?;
        ["Instance", "Inst", "I"]
            .iter()
            .find_map(|l| format.field(l))
    }

    /// The instances of a message type that have messages, ascending; empty when the type has
    /// no instance field (or no messages).
    pub fn instances(&self, name: &str) -> Vec<u8> {
        let (Some(format), Some(slot)) = (self.format(name), self.instance_slot(name)) else {
            return Vec::new();
        };
        let Some(messages) = self.messages.get(&format.msg_type) else {
            return Vec::new();
        };
        let mut v: Vec<u8> = messages
            .iter()
            .filter_map(|(_, p)| p.get(slot.0..).and_then(|b| decode_field(slot.1, b)))
            .filter(|v| (0.0..=255.0).contains(v))
            .map(|v| v as u8)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Values of numeric fields of one message type, one row per message, only the messages
    /// of `instance` when given and the type has an instance field. Empty when there are no
    /// such messages; a field the format lacks (or holds text) is `None` when `required` is
    /// false, else an error.
    pub fn rows(
        &self,
        name: &str,
        instance: Option<u8>,
        fields: &[(&str, bool)],
        path: &Path,
    ) -> Result<Vec<Row>, FlightLogError> {
        let Some(format) = self.format(name) else {
            return Ok(Vec::new());
        };
        let Some(messages) = self.messages.get(&format.msg_type) else {
            return Ok(Vec::new());
        };
        let fail = |offset: u64, field: &str, message: String| {
            self.error(path, offset, format!("{name}.{field}"), message)
        };
        if let Some(problem) = &format.problem {
            return Err(fail(format.defined_at, "FMT", problem.clone()));
        }
        let mut layout = Vec::with_capacity(fields.len());
        for &(label, required) in fields {
            let found = format
                .field(label)
                .filter(|&(_, c)| decode_field(c, &[0; 8]).is_some());
            if found.is_none() && required {
                return Err(fail(
                    format.defined_at,
                    label,
                    format!(
                        "no numeric field {label:?} in its format (labels: {})",
                        format.labels.join(",")
                    ),
                ));
            }
            layout.push(found);
        }
        let slot = self.instance_slot(name);
        let value = |payload: &[u8], (off, c): (usize, u8)| {
            payload.get(off..).and_then(|b| decode_field(c, b))
        };
        let mut rows = Vec::with_capacity(messages.len());
        for (offset, payload) in messages {
            let (offset, payload) = (*offset, payload.as_ref());
            if let (Some(slot), Some(w)) = (slot, instance)
                && value(payload, slot) != Some(f64::from(w))
            {
                continue;
            }
            let mut values = Vec::with_capacity(fields.len());
            for (k, s) in layout.iter().enumerate() {
                values.push(match s {
                    None => None,
                    Some(s) => Some(value(payload, *s).ok_or_else(|| {
                        fail(offset, fields[k].0, "field beyond the message".to_owned())
                    })?),
                });
            }
            rows.push(Row { offset, values });
        }
        Ok(rows)
    }

    /// The text of a `char[n]` field (`n`, `N`, `Z`) of every message of a type, in file
    /// order; empty when the type or field is absent.
    pub fn texts(&self, name: &str, label: &str) -> Vec<String> {
        let Some(format) = self.format(name) else {
            return Vec::new();
        };
        let Some((off, c)) = format.field(label) else {
            return Vec::new();
        };
        let Some(size) = field_size(c).filter(|_| matches!(c, b'n' | b'N' | b'Z')) else {
            return Vec::new();
        };
        self.messages
            .get(&format.msg_type)
            .map(|m| {
                m.iter()
                    .filter_map(|(_, p)| p.get(off..off + size).map(text))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Parameters (`PARM` messages, `Name` and `Value`): the first value of each.
    pub fn parameters(&self) -> HashMap<String, f64> {
        let mut out = HashMap::new();
        let Some(format) = self.format("PARM") else {
            return out;
        };
        let (Some((noff, nc)), Some((voff, vc))) = (format.field("Name"), format.field("Value"))
        else {
            return out;
        };
        let Some(nsize) = field_size(nc) else {
            return out;
        };
        for (_, p) in self.messages.get(&format.msg_type).into_iter().flatten() {
            if let (Some(n), Some(v)) = (
                p.get(noff..noff + nsize).map(text),
                p.get(voff..).and_then(|b| decode_field(vc, b)),
            ) && !n.is_empty()
            {
                out.entry(n).or_insert(v);
            }
        }
        out
    }

    /// The log's [`Clock`] for messages without a time field: the message type with a
    /// `TimeUS` or `TimeMS` field (or, in ArduCopter 3.0, the GPS's `Time`, ms) that has the
    /// most messages, its times in seconds against their positions; a time that is zero or
    /// not above the one before (a GPS without a fix) is left out. `None` when no type has
    /// two usable times.
    pub fn clock(&self, path: &Path) -> Option<Clock> {
        let mut best: Option<(usize, &str, &'static str, f64)> = None;
        for name in self.names() {
            let field = self.time_field(name).or_else(|| {
                (name == "GPS" && self.format(name)?.field("Time").is_some())
                    .then_some(("Time", 1e-3))
            });
            let Some((label, scale)) = field else {
                continue;
            };
            let count = self
                .format(name)
                .and_then(|f| self.messages.get(&f.msg_type))
                .map_or(0, Vec::len);
            if best.is_none_or(|b| count > b.0) {
                best = Some((count, name, label, scale));
            }
        }
        let (_, name, label, scale) = best?;
        let rows = self.rows(name, None, &[(label, true)], path).ok()?;
        let mut points: Vec<(u64, f64)> = Vec::with_capacity(rows.len());
        for r in &rows {
            let Some(t) = r.values[0].map(|t| t * scale).filter(|t| *t > 0.0) else {
                continue;
            };
            if points
                .last()
                .is_none_or(|&(p, last)| t > last && r.offset > p)
            {
                points.push((r.offset, t));
            }
        }
        (points.len() >= 2).then(|| Clock {
            label: format!("{name}.{label}"),
            points,
        })
    }

    /// The time field of a message type and its scale to seconds: `("TimeUS", 1e-6)` or
    /// `("TimeMS", 1e-3)`.
    pub fn time_field(&self, name: &str) -> Option<(&'static str, f64)> {
        let format = self.format(name)?;
        if format.field("TimeUS").is_some() {
            Some(("TimeUS", 1e-6))
        } else if format.field("TimeMS").is_some() {
            Some(("TimeMS", 1e-3))
        } else {
            None
        }
    }
}

/// A time for messages that carry none (ArduCopter 3.0–3.1's `CURR`, `CTUN`): the times of
/// one message type that has them, against their positions in the log, interpolated.
#[derive(Debug, Clone, PartialEq)]
pub struct Clock {
    /// Where the times come from (`IMU.TimeMS`, `GPS.Time`).
    pub label: String,
    /// (position, time in s), positions and times strictly increasing.
    points: Vec<(u64, f64)>,
}

impl Clock {
    /// The time at a position in the log, s: interpolated between the stamped messages
    /// around it; `None` before the first or after the last.
    pub fn at(&self, position: u64) -> Option<f64> {
        let k = self.points.partition_point(|&(p, _)| p <= position);
        if k == 0 {
            return None;
        }
        let (p0, t0) = self.points[k - 1];
        if p0 == position {
            return Some(t0);
        }
        let &(p1, t1) = self.points.get(k)?;
        Some(t0 + (t1 - t0) * (position - p0) as f64 / (p1 - p0) as f64)
    }
}

/// The time of a row, s: its own time field (value `k`, with its scale) if the message has
/// one, else the log's clock at its position.
fn row_time(own: Option<(&str, f64)>, clock: Option<&Clock>, r: &Row, k: usize) -> Option<f64> {
    match (own, clock) {
        (Some((_, scale)), _) => r.values[k].map(|t| t * scale),
        (None, Some(c)) => c.at(r.offset),
        (None, None) => None,
    }
}

/// Scale of a battery field to volts or amps: `0.01` for an integer field (ArduCopter 3.x
/// `CURR.Volt` and `CURR.Curr` are centivolts and centiamps in `h`), 1 otherwise (`f`, and
/// `c`/`C`, already scaled by [`decode_field`]).
fn battery_scale(format: &MessageFormat, label: &str) -> f64 {
    match format.field(label) {
        Some((_, b'h' | b'H' | b'i' | b'I' | b'b' | b'B')) => 0.01,
        _ => 1.0,
    }
}

/// The cell count from the per-cell voltages (`BCL`, ArduPilot's `CURR_CELL` log structure):
/// `NumCells` in older firmware, else the number of `V1`…`V14` between 1 and 5 V (mV).
fn logged_cells(log: &DataFlash<'_>, path: &Path) -> Option<(u32, String)> {
    if let Ok(rows) = log.rows("BCL", None, &[("NumCells", true)], path)
        && let Some(c) = rows
            .iter()
            .filter_map(|r| r.values[0])
            .find(|&c| (1.0..=30.0).contains(&c))
    {
        return Some((c as u32, "BCL.NumCells".to_owned()));
    }
    let labels: Vec<String> = (1..=14).map(|k| format!("V{k}")).collect();
    let fields: Vec<(&str, bool)> = labels.iter().map(|l| (l.as_str(), false)).collect();
    let rows = log.rows("BCL", None, &fields, path).ok()?;
    rows.iter()
        .map(|r| {
            r.values
                .iter()
                .flatten()
                .filter(|&&mv| (1000.0..=5000.0).contains(&mv))
                .count()
        })
        .find(|&c| c > 0)
        .map(|c| (c as u32, "BCL: cells with a voltage".to_owned()))
}

/// The battery tracks of a log: `BAT` per instance, `BAT2` (older firmware's second
/// battery), `CURR` (ArduCopter 3.x), then `BCL` (per-cell voltages, ArduPilot's
/// `CURR_CELL` structure, whose `Volt` is the pack voltage, without current).
fn battery_tracks(
    log: &DataFlash<'_>,
    clock: Option<&Clock>,
    path: &Path,
) -> Result<(Vec<Track>, Vec<String>), FlightLogError> {
    let mut tracks = Vec::new();
    let mut notes = Vec::new();
    let cells = logged_cells(log, path);
    for name in ["BAT", "BAT2", "CURR", "BCL"] {
        let Some(format) = log.format(name) else {
            continue;
        };
        if !log.has(name) {
            continue;
        }
        if let Some(problem) = &format.problem {
            return Err(log.error(
                path,
                format.defined_at,
                format!("{name}.FMT"),
                problem.clone(),
            ));
        }
        // The message's own time, else the log's clock (ArduCopter 3.0–3.1's CURR has none).
        let own_time = log.time_field(name);
        let clock = match own_time {
            Some(_) => None,
            None => Some(clock.ok_or_else(|| FlightLogError::MissingData {
                path: path.to_owned(),
                field: format!("{name}.TimeUS"),
                message: format!(
                    "{name} messages have neither a TimeUS nor a TimeMS field (labels: {}), and no other message of the log has a time to take theirs from",
                    format.labels.join(",")
                ),
            })?),
        };
        let (v_scale, i_scale) = (battery_scale(format, "Volt"), battery_scale(format, "Curr"));
        let instances: Vec<Option<u8>> = match log.instances(name) {
            v if v.is_empty() => vec![None],
            v => v.into_iter().map(Some).collect(),
        };
        for instance in instances {
            let mut fields = vec![("Volt", true), ("Curr", false), ("RemPct", false)];
            if let Some((label, _)) = own_time {
                fields.push((label, true));
            }
            let all = log.rows(name, instance, &fields, path)?;
            let time_of = |r: &Row| row_time(own_time, clock, r, 3);
            // Voltage is a required field: a row without a time is one outside the clock.
            let rows: Vec<(&Row, f64)> = all
                .iter()
                .filter(|r| r.values[0].is_some())
                .filter_map(|r| Some((r, time_of(r)?)))
                .collect();
            if let Some(c) = clock {
                notes.push(format!(
                    "{name} has no time field: its times are interpolated by position in the log between the {} of the messages around it{}",
                    c.label,
                    match all.len() - rows.len() {
                        0 => String::new(),
                        n => format!(" ({n} message(s) outside them left out)"),
                    }
                ));
            }
            if rows.is_empty() {
                continue;
            }
            let col = |k: usize| rows.iter().map(move |(r, _)| r.values[k]);
            let has_remaining = rows.first().is_some_and(|(r, _)| r.values[2].is_some());
            tracks.push(Track {
                name: match instance {
                    Some(i) => format!("{name} instance {i}"),
                    None => name.to_owned(),
                },
                offsets: rows.iter().map(|(r, _)| r.offset).collect(),
                time_s: rows.iter().map(|&(_, t)| t).collect(),
                voltage_v: col(0).flatten().map(|v| v * v_scale).collect(),
                current_a: col(1).map(|c| c.map(|c| c * i_scale)).collect(),
                connected: None,
                remaining: has_remaining
                    .then(|| col(2).map(|r| r.map_or(-1.0, |r| r / 100.0)).collect()),
                warning: None,
                cells: cells.clone(),
            });
        }
    }
    Ok((tracks, notes))
}

/// What ArduPilot firmware names a `FRAME_CLASS`.
pub(crate) fn frame_class_name(class: u32) -> Option<(&'static str, VehicleKind)> {
    Some(match class {
        1 => ("quad", VehicleKind::Multirotor),
        2 => ("hexa", VehicleKind::Multirotor),
        3 => ("octa", VehicleKind::Multirotor),
        4 => ("octaquad", VehicleKind::Multirotor),
        5 => ("y6", VehicleKind::Multirotor),
        6 => ("heli", VehicleKind::Helicopter),
        7 => ("tri", VehicleKind::Multirotor),
        8 => ("singlecopter", VehicleKind::Multirotor),
        9 => ("coaxcopter", VehicleKind::Multirotor),
        10 => ("bicopter", VehicleKind::Multirotor),
        11 => ("heli_dual", VehicleKind::Helicopter),
        12 => ("dodecahexa", VehicleKind::Multirotor),
        13 => ("heli_quad", VehicleKind::Helicopter),
        14 => ("deca", VehicleKind::Multirotor),
        _ => return None,
    })
}

/// The vehicle from the firmware banner (`ArduCopter V4.6.2`, `APM:Copter V3.3`), its frame
/// (`FRAME_CLASS`, or the `Frame: QUAD` message of older firmware) and, for ArduPlane,
/// `Q_ENABLE` (a quadplane is a VTOL).
fn vehicle(
    firmware: Option<&str>,
    messages: &[String],
    params: &HashMap<String, f64>,
) -> (Option<Vehicle>, Option<String>) {
    let Some(fw) = firmware else {
        return (None, None);
    };
    let frame_msg = messages
        .iter()
        .find_map(|m| m.strip_prefix("Frame: "))
        .map(|f| f.trim().to_ascii_lowercase());
    let lower = fw.to_ascii_lowercase();
    if lower.contains("copter") {
        let class = params
            .get("FRAME_CLASS")
            .and_then(|&c| frame_class_name(c as u32).map(|n| (c as u32, n)));
        match (class, frame_msg) {
            (Some((c, (frame, kind))), _) => (
                Some(Vehicle {
                    kind,
                    description: format!("{fw}, {frame} (FRAME_CLASS {c})"),
                }),
                Some(frame.to_owned()),
            ),
            (None, Some(frame)) => {
                let kind = if frame.contains("heli") {
                    VehicleKind::Helicopter
                } else {
                    VehicleKind::Multirotor
                };
                (
                    Some(Vehicle {
                        kind,
                        description: format!("{fw}, {frame} (message \"Frame: …\")"),
                    }),
                    Some(frame),
                )
            }
            (None, None) => (
                Some(Vehicle {
                    kind: VehicleKind::Multirotor,
                    description: format!("{fw} (firmware banner)"),
                }),
                None,
            ),
        }
    } else if lower.contains("plane") {
        let q = params.get("Q_ENABLE").copied().unwrap_or(0.0);
        let (kind, how) = if q >= 1.0 {
            (VehicleKind::Vtol, "quadplane, Q_ENABLE 1")
        } else {
            (VehicleKind::FixedWing, "Q_ENABLE 0 or absent")
        };
        (
            Some(Vehicle {
                kind,
                description: format!("{fw} ({how})"),
            }),
            None,
        )
    } else if lower.contains("rover") || lower.contains("sub") {
        (
            Some(Vehicle {
                kind: VehicleKind::Rover,
                description: format!("{fw} (firmware banner)"),
            }),
            None,
        )
    } else {
        (None, None)
    }
}

/// What an ArduPilot log says about itself, from its text messages (`MSG`, or a telemetry
/// log's `STATUSTEXT`) and parameters: firmware and board, the vehicle and frame, and the
/// battery's cells (as found by the caller), capacity, cut-off and arm voltages, and the hover
/// throttle. Shared by the DataFlash readers and the telemetry-log reader.
pub(crate) fn ardupilot_info(
    messages: &[String],
    params: &HashMap<String, f64>,
    cells: Option<&(u32, String)>,
) -> LogInfo {
    let firmware = messages
        .iter()
        .find(|m| {
            [
                "ArduCopter",
                "ArduPlane",
                "ArduRover",
                "ArduSub",
                "APM:",
                "Blimp",
                "AntennaTracker",
            ]
            .iter()
            .any(|p| m.starts_with(p))
        })
        .cloned();
    let hardware = messages
        .iter()
        .find(|m| {
            m.split(' ').count() == 4
                && m.split(' ')
                    .skip(1)
                    .all(|w| w.chars().all(|c| c.is_ascii_hexdigit()))
        })
        .map(|m| m.split(' ').next().unwrap_or_default().to_owned());
    let (vehicle, frame) = vehicle(firmware.as_deref(), messages, params);
    let mut info = LogInfo {
        firmware,
        hardware,
        ..LogInfo::default()
    };
    if let Some((c, origin)) = cells {
        info.set("cells", origin.clone(), |m| m.cells = Some(*c));
    }
    let p = |name: &str, ok: &dyn Fn(f64) -> bool| params.get(name).copied().filter(|&v| ok(v));
    if let Some(v) = p("BATT_CAPACITY", &|v| v > 0.0) {
        info.set("capacity_mah", "BATT_CAPACITY", |m| {
            m.capacity_mah = Some(v)
        });
    }
    if let Some(v) = p("BATT_LOW_VOLT", &|v| v > 0.0) {
        info.set("cutoff_voltage_v", "BATT_LOW_VOLT", |m| {
            m.cutoff_voltage_v = Some(v);
        });
    } else if let Some(v) = p("FS_BATT_VOLTAGE", &|v| v > 0.0) {
        // ArduCopter 3.0–3.3 (before BATT_LOW_VOLT): the voltage it calls a low battery.
        info.set("cutoff_voltage_v", "FS_BATT_VOLTAGE", |m| {
            m.cutoff_voltage_v = Some(v);
        });
    }
    if let Some(v) = p("BATT_ARM_VOLT", &|v| v > 0.0) {
        info.set("arm_voltage_v", "BATT_ARM_VOLT", |m| {
            m.arm_voltage_v = Some(v)
        });
    }
    if let Some(v) = p("MOT_THST_HOVER", &|v| v > 0.0 && v <= 1.0) {
        info.set("hover_throttle", "MOT_THST_HOVER", |m| {
            m.hover_throttle = Some(v);
        });
    } else if let Some(v) = p("THR_MID", &|v| v > 0.0 && v <= 1000.0) {
        info.set("hover_throttle", "THR_MID ÷ 1000", |m| {
            m.hover_throttle = Some(v / 1000.0);
        });
    }
    if let Some(v) = &vehicle {
        info.set("vehicle", v.description.clone(), |m| {
            m.vehicle = Some(v.kind)
        });
    }
    if let (Some(f), Some(v)) = (frame, &vehicle) {
        info.set("frame", v.description.clone(), |m| m.frame = Some(f));
    }
    info.derive_energy();
    info.vehicle = vehicle;
    info
}

/// Parses a `.bin` into a flight's samples.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    decode(&DataFlash::parse(bytes, path)?, path)
}

/// Parses a text DataFlash log (`.log`) into a flight's samples, as [`parse`] a `.bin`.
pub(crate) fn parse_text(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    decode(&DataFlash::parse_text(bytes, path)?, path)
}

/// A flight's samples from a DataFlash log, binary or text.
fn decode(log: &DataFlash<'_>, path: &Path) -> Result<Decoded, FlightLogError> {
    let mut warnings = log.warnings.clone();
    // The clock, only for a log whose battery, altitude or throttle message has no time field
    // (ArduCopter 3.0–3.1): built once, for both.
    let clock = ["BAT", "BAT2", "CURR", "BCL", "CTUN", "BARO"]
        .iter()
        .any(|n| log.has(n) && log.time_field(n).is_none())
        .then(|| log.clock(path))
        .flatten();
    let (tracks, mut notes) = battery_tracks(log, clock.as_ref(), path)?;
    warnings.append(&mut notes);
    let mut chosen = battery::choose(
        path,
        &tracks,
        "BAT or CURR (battery voltage)",
        &log.names().join(", "),
    )?;
    warnings.append(&mut chosen.warnings);
    let t0 = chosen.t0_s;
    let time_s = chosen.time_s.clone();
    let battery_type = chosen.info.battery.split(' ').next().unwrap_or("BAT");
    let time_label = match log.time_field(battery_type) {
        Some((label, _)) => format!("{battery_type}.{label}"),
        None => format!(
            "{battery_type} (times from {})",
            clock
                .as_ref()
                .map_or("the log's clock", |c| c.label.as_str())
        ),
    };
    crate::check_time(path, &time_s, &time_label, |i| {
        log.position(chosen.offsets.get(i).copied().unwrap_or(0))
    })?;

    // What the log says about itself.
    // APM 2's text logs name their firmware in the banner before the first FMT.
    let mut messages = log.texts("MSG", "Message");
    messages.extend(log.preamble.iter().cloned());
    let params = log.parameters();
    let cells = chosen
        .info
        .cells
        .clone()
        .or_else(|| estimate_cells_for(&chosen.voltage_v));
    let mut info = ardupilot_info(&messages, &params, cells.as_ref());
    chosen.info.cells = cells;
    info.battery = Some(chosen.info.clone());

    // Altitude and throttle: CTUN, else BARO for altitude.
    // A message without a time field takes the log's clock, as the battery's may have.
    let series = |name: &str, field: &str| -> Result<Option<Vec<f64>>, FlightLogError> {
        let own = log.time_field(name);
        if own.is_none() && clock.is_none() {
            return Ok(None);
        }
        let instance = log.instances(name).first().copied();
        let mut fields = vec![(field, false)];
        if let Some((label, _)) = own {
            fields.push((label, true));
        }
        let rows = log.rows(name, instance, &fields, path)?;
        let time_of = |r: &Row| row_time(own, clock.as_ref(), r, 1);
        let (t, v): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter_map(|r| Some((time_of(r)? - t0, r.values[0]?)))
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .unzip();
        Ok(crate::resample::linear(&t, &v, &time_s))
    };
    // ArduCopter 3.0–3.2 name CTUN's barometric altitude `BarAlt`.
    let altitude_m = match series("CTUN", "Alt")? {
        Some(a) => Some(a),
        None => match series("CTUN", "BarAlt")? {
            Some(a) => Some(a),
            None => series("BARO", "Alt")?,
        },
    };
    // Throttle: CTUN.ThO (0–1) in current firmware; ArduCopter 3.x logs CTUN.ThrOut in 0–1000
    // (ArduPlane's ThrOut is a percentage of another meaning: not read).
    let copter = info
        .firmware
        .as_deref()
        .is_some_and(|f| f.to_ascii_lowercase().contains("copter"));
    let throttle = match series("CTUN", "ThO")? {
        Some(t) => Some(t),
        None if copter => {
            series("CTUN", "ThrOut")?.map(|t| t.into_iter().map(|x| x / 1000.0).collect())
        }
        None => None,
    };
    let motor_us = match motor_commands(log, path, &params, &info, clock.as_ref(), t0, &time_s) {
        Ok(None) => None,
        Ok(Some((columns, source))) => {
            info.motors = Some(source);
            Some(columns)
        }
        Err(why) => {
            warnings.push(why);
            None
        }
    };
    Ok(Decoded::battery_log(
        chosen, altitude_m, throttle, motor_us, warnings, info,
    ))
}

/// The labels of output `n` (1-based) in `RCOU`: `C1` in current firmware, `Ch1` (or `Chan1`)
/// in ArduCopter 3.x.
const RCOU_LABELS: [&str; 3] = ["C", "Ch", "Chan"];

/// The motor commands of a DataFlash log, on the battery's times `time_s` (its first at `t0`
/// on the log's clock), with where they were read: `RCOU`'s outputs of the frame's motors
/// ([`crate::motors`]). `Ok(None)` without `RCOU`; `Err` is the warning that says why they were
/// not read.
#[allow(clippy::too_many_arguments)]
fn motor_commands(
    log: &DataFlash<'_>,
    path: &Path,
    params: &HashMap<String, f64>,
    info: &LogInfo,
    clock: Option<&Clock>,
    t0: f64,
    time_s: &[f64],
) -> Result<Option<crate::motors::Read>, String> {
    const NAME: &str = "RCOU";
    let Some(format) = log.format(NAME).filter(|_| log.has(NAME)) else {
        return Ok(None);
    };
    let not_read = |why: String| format!("{NAME} not read as motor commands: {why}");
    let frame = info.meta.frame.as_deref().ok_or_else(|| {
        not_read(
            "the log names no multirotor frame (FRAME_CLASS, or ArduCopter's \"Frame:\" message)"
                .to_owned(),
        )
    })?;
    let origin = match params.get("FRAME_CLASS") {
        Some(c) => format!("FRAME_CLASS {c} ({frame})"),
        None => format!("frame {frame} from the log's \"Frame:\" message"),
    };
    let outputs = crate::motors::ardupilot_outputs(params, frame, &origin).map_err(not_read)?;
    let prefix = RCOU_LABELS
        .iter()
        .find(|p| format.field(&format!("{p}1")).is_some())
        .ok_or_else(|| {
            not_read(format!(
                "no output field C1 (labels: {})",
                format.labels.join(",")
            ))
        })?;
    let labels: Vec<String> = outputs
        .channels
        .iter()
        .map(|c| format!("{prefix}{c}"))
        .collect();
    let own = log.time_field(NAME);
    if own.is_none() && clock.is_none() {
        return Err(not_read(
            "its messages have no time field, and the log no clock to take one from".to_owned(),
        ));
    }
    let mut fields: Vec<(&str, bool)> = labels.iter().map(|l| (l.as_str(), true)).collect();
    if let Some((label, _)) = own {
        fields.push((label, true));
    }
    let rows = log
        .rows(NAME, None, &fields, path)
        .map_err(|e| not_read(crate::summary::error_chain(&e)))?;
    let k = labels.len();
    let (mut t, mut values) = (
        Vec::with_capacity(rows.len()),
        Vec::with_capacity(rows.len()),
    );
    for r in &rows {
        if let Some(time) = row_time(own, clock, r, k) {
            t.push(time - t0);
            values.push(r.values[..k].to_vec());
        }
    }
    let name = |m: usize| format!("{NAME}.{}", labels[m]);
    let columns = crate::motors::align(&t, &values, k, time_s, &name)?;
    let source = format!(
        "{NAME}.{}–{} ({})",
        labels[0],
        labels[k - 1],
        outputs.origin
    );
    Ok(Some((columns, source)))
}

/// ArduPilot logs no cell count: estimated from the highest voltage.
fn estimate_cells_for(voltage_v: &[f64]) -> Option<(u32, String)> {
    battery::estimate_cells(voltage_v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_scales() {
        assert_eq!(field_size(b'Q'), Some(8));
        assert_eq!(field_size(b'Z'), Some(64));
        assert_eq!(field_size(b'x'), None);
        assert_eq!(decode_field(b'c', &1234i16.to_le_bytes()), Some(12.34));
        assert_eq!(decode_field(b'N', &[0; 16]), None);
        assert_eq!(decode_field(b'f', &[0; 2]), None);
    }

    #[test]
    fn rejects_non_dataflash() {
        let e = DataFlash::parse(b"ULog", Path::new("x.bin")).unwrap_err();
        assert!(matches!(e, FlightLogError::Binary { offset: 0, .. }));
    }
}
