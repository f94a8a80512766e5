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
//! A flight takes `BAT` (`TimeUS`, `Volt`, `Curr`; the lowest `Instance`), and for altitude
//! `CTUN.Alt` (else `BARO.Alt`, lowest instance) and throttle `CTUN.ThO` (0–1), both
//! interpolated onto the battery's times. Time is `BAT.TimeUS` (or `TimeMS`) from its first
//! sample, s.

use std::collections::HashMap;
use std::path::Path;

use crate::{Decoded, FlightLogError, Record, Samples};

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

/// A DataFlash log's formats and messages, borrowed from its bytes.
#[derive(Debug)]
pub struct DataFlash<'a> {
    formats: HashMap<u8, MessageFormat>,
    /// Messages per type: `(byte offset, payload)`, in file order.
    messages: HashMap<u8, Vec<(u64, &'a [u8])>>,
    /// What was skipped (bytes that are not a message, a truncated tail).
    pub warnings: Vec<String>,
}

/// Text of a NUL-padded char array.
fn text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).trim().to_owned()
}

impl<'a> DataFlash<'a> {
    /// Parses a DataFlash log held in memory; `path` names it in errors.
    pub fn parse(bytes: &'a [u8], path: &Path) -> Result<Self, FlightLogError> {
        let fail = |offset: usize, field: &str, message: String| FlightLogError::Binary {
            path: path.to_owned(),
            offset: offset as u64,
            field: field.to_owned(),
            message,
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
                    .push((pos as u64, payload));
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

    /// Values of numeric fields of one message type, one row per message: `(byte offset,
    /// values)`, keeping the lowest instance when the type has an `Instance`/`Inst`/`I` field.
    /// `Ok(None)` when there are no such messages; a missing field is `NaN` when `required` is
    /// false, else an error.
    pub fn columns(
        &self,
        name: &str,
        fields: &[(&str, bool)],
        path: &Path,
    ) -> Result<Option<Vec<Record>>, FlightLogError> {
        let Some(format) = self.format(name) else {
            return Ok(None);
        };
        let Some(messages) = self.messages.get(&format.msg_type) else {
            return Ok(None);
        };
        let fail = |offset: u64, field: &str, message: String| FlightLogError::Binary {
            path: path.to_owned(),
            offset,
            field: format!("{name}.{field}"),
            message,
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
        let instance = ["Instance", "Inst", "I"]
            .iter()
            .find_map(|l| format.field(l));
        let value = |payload: &[u8], (off, c): (usize, u8)| {
            payload.get(off..).and_then(|b| decode_field(c, b))
        };
        let wanted = instance.and_then(|slot| {
            messages
                .iter()
                .filter_map(|(_, p)| value(p, slot))
                .min_by(f64::total_cmp)
        });
        let mut rows = Vec::with_capacity(messages.len());
        for &(offset, payload) in messages {
            if let (Some(slot), Some(w)) = (instance, wanted)
                && value(payload, slot) != Some(w)
            {
                continue;
            }
            let mut values = Vec::with_capacity(fields.len());
            for (k, slot) in layout.iter().enumerate() {
                values.push(match slot {
                    None => f64::NAN,
                    Some(s) => value(payload, *s).ok_or_else(|| {
                        fail(offset, fields[k].0, "field beyond the message".to_owned())
                    })?,
                });
            }
            rows.push(Record { offset, values });
        }
        Ok(Some(rows))
    }

    /// Time of each message of a type, µs, from `TimeUS` or `TimeMS`.
    fn time_field(&self, name: &str) -> Option<(&'static str, f64)> {
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

/// Parses a `.bin` into a flight's samples.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let log = DataFlash::parse(bytes, path)?;
    let mut warnings = log.warnings.clone();
    let missing = |message: String| FlightLogError::MissingData {
        path: path.to_owned(),
        field: "BAT".to_owned(),
        message,
    };
    if let Some(format) = log.format("BAT")
        && let Some(problem) = &format.problem
    {
        return Err(FlightLogError::Binary {
            path: path.to_owned(),
            offset: format.defined_at,
            field: "BAT.FMT".to_owned(),
            message: problem.clone(),
        });
    }
    let (time_label, time_scale) = log.time_field("BAT").ok_or_else(|| {
        missing(format!(
            "no BAT messages with a TimeUS field (messages: {})",
            log.names().join(", ")
        ))
    })?;
    let battery = log
        .columns(
            "BAT",
            &[(time_label, true), ("Volt", true), ("Curr", false)],
            path,
        )?
        .ok_or_else(|| {
            missing(format!(
                "no BAT messages (messages: {})",
                log.names().join(", ")
            ))
        })?;
    let mut offsets = Vec::new();
    let mut stamps = Vec::new();
    let mut voltage = Vec::new();
    let mut current = Vec::new();
    let mut dropped = 0usize;
    for Record {
        offset,
        values: row,
    } in &battery
    {
        if !(row[1].is_finite() && row[1] > 0.0) {
            dropped += 1;
            continue;
        }
        offsets.push(*offset);
        stamps.push(row[0] * time_scale);
        voltage.push(row[1]);
        current.push(row[2]);
    }
    if dropped > 0 {
        warnings.push(format!(
            "{dropped} BAT sample(s) without a voltage (≤ 0 or not finite) dropped"
        ));
    }
    let t0 = stamps.first().copied().unwrap_or(0.0);
    let time_s: Vec<f64> = stamps.iter().map(|t| t - t0).collect();
    crate::check_time(path, &time_s, &format!("BAT.{time_label}"), |i| {
        format!("byte {}", offsets.get(i).copied().unwrap_or(0))
    })?;
    let current_a = current.iter().any(|c| c.is_finite()).then(|| {
        current
            .iter()
            .map(|&c| if c.is_finite() { c } else { 0.0 })
            .collect()
    });

    // Altitude and throttle: CTUN, else BARO for altitude.
    let series = |name: &str, field: &str| -> Result<Option<Vec<f64>>, FlightLogError> {
        let Some((label, scale)) = log.time_field(name) else {
            return Ok(None);
        };
        let Some(rows) = log.columns(name, &[(label, true), (field, false)], path)? else {
            return Ok(None);
        };
        let (t, v): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter(|r| r.values[1].is_finite())
            .map(|r| (r.values[0] * scale - t0, r.values[1]))
            .unzip();
        Ok((!t.is_empty()).then(|| crate::resample::linear(&t, &v, &time_s)))
    };
    let altitude_m = match series("CTUN", "Alt")? {
        Some(a) => Some(a),
        None => series("BARO", "Alt")?,
    };
    let throttle = series("CTUN", "ThO")?;
    Ok(Decoded {
        samples: Samples {
            time_s,
            voltage_v: voltage,
            current_a,
            phase: None,
            altitude_m,
            throttle,
        },
        landed: None,
        warnings,
    })
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
