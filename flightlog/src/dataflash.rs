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

use crate::battery::{self, Track};
use crate::{Decoded, FlightLogError, LogInfo, Row, Samples, Vehicle, VehicleKind};

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
            FlightLogError::binary(path, offset, format!("{name}.{field}"), message)
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
        for &(offset, payload) in messages {
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
fn battery_tracks(log: &DataFlash<'_>, path: &Path) -> Result<Vec<Track>, FlightLogError> {
    let mut tracks = Vec::new();
    let cells = logged_cells(log, path);
    for name in ["BAT", "BAT2", "CURR", "BCL"] {
        let Some(format) = log.format(name) else {
            continue;
        };
        if !log.has(name) {
            continue;
        }
        if let Some(problem) = &format.problem {
            return Err(FlightLogError::binary(
                path,
                format.defined_at,
                format!("{name}.FMT"),
                problem.clone(),
            ));
        }
        let Some((time_label, time_scale)) = log.time_field(name) else {
            return Err(FlightLogError::MissingData {
                path: path.to_owned(),
                field: format!("{name}.TimeUS"),
                message: format!(
                    "{name} messages have neither a TimeUS nor a TimeMS field (labels: {})",
                    format.labels.join(",")
                ),
            });
        };
        let (v_scale, i_scale) = (battery_scale(format, "Volt"), battery_scale(format, "Curr"));
        let instances: Vec<Option<u8>> = match log.instances(name) {
            v if v.is_empty() => vec![None],
            v => v.into_iter().map(Some).collect(),
        };
        for instance in instances {
            let rows = log.rows(
                name,
                instance,
                &[
                    (time_label, true),
                    ("Volt", true),
                    ("Curr", false),
                    ("RemPct", false),
                ],
                path,
            )?;
            // Time and voltage are required fields: every row has them.
            let rows = Row::having(&rows, &[0, 1]);
            if rows.is_empty() {
                continue;
            }
            let col = |k: usize| rows.iter().map(move |r| r.values[k]);
            let has_remaining = rows.first().is_some_and(|r| r.values[3].is_some());
            tracks.push(Track {
                name: match instance {
                    Some(i) => format!("{name} instance {i}"),
                    None => name.to_owned(),
                },
                offsets: rows.iter().map(|r| r.offset).collect(),
                time_s: col(0).flatten().map(|t| t * time_scale).collect(),
                voltage_v: col(1).flatten().map(|v| v * v_scale).collect(),
                current_a: col(2).map(|c| c.map(|c| c * i_scale)).collect(),
                connected: None,
                remaining: has_remaining
                    .then(|| col(3).map(|r| r.map_or(-1.0, |r| r / 100.0)).collect()),
                warning: None,
                cells: cells.clone(),
            });
        }
    }
    Ok(tracks)
}

/// What ArduPilot firmware names a `FRAME_CLASS`.
fn frame_class_name(class: u32) -> Option<(&'static str, VehicleKind)> {
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

/// Parses a `.bin` into a flight's samples.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let log = DataFlash::parse(bytes, path)?;
    let mut warnings = log.warnings.clone();
    let tracks = battery_tracks(&log, path)?;
    let mut chosen = battery::choose(
        path,
        &tracks,
        "BAT or CURR (battery voltage)",
        &log.names().join(", "),
    )?;
    warnings.append(&mut chosen.warnings);
    let t0 = chosen.t0_s;
    let time_s = chosen.time_s.clone();
    let time_label = log
        .time_field(chosen.info.battery.split(' ').next().unwrap_or("BAT"))
        .map_or("TimeUS", |(l, _)| l);
    crate::check_time(
        path,
        &time_s,
        &format!(
            "{}.{time_label}",
            chosen.info.battery.split(' ').next().unwrap_or("BAT")
        ),
        |i| format!("byte {}", chosen.offsets.get(i).copied().unwrap_or(0)),
    )?;

    // What the log says about itself.
    let messages = log.texts("MSG", "Message");
    let params = log.parameters();
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
    let (vehicle, frame) = vehicle(firmware.as_deref(), &messages, &params);
    let mut info = LogInfo {
        firmware,
        hardware,
        ..LogInfo::default()
    };
    let cells = chosen
        .info
        .cells
        .clone()
        .or_else(|| estimate_cells_for(&chosen.voltage_v));
    if let Some((c, origin)) = &cells {
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
    chosen.info.cells = cells;
    info.vehicle = vehicle;
    info.battery = Some(chosen.info.clone());

    // Altitude and throttle: CTUN, else BARO for altitude.
    let series = |name: &str, field: &str| -> Result<Option<Vec<f64>>, FlightLogError> {
        let Some((label, scale)) = log.time_field(name) else {
            return Ok(None);
        };
        let instance = log.instances(name).first().copied();
        let rows = log.rows(name, instance, &[(label, true), (field, false)], path)?;
        let (t, v): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter_map(|r| Some((r.values[0]? * scale - t0, r.values[1]?)))
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .unzip();
        Ok(crate::resample::linear(&t, &v, &time_s))
    };
    let altitude_m = match series("CTUN", "Alt")? {
        Some(a) => Some(a),
        None => series("BARO", "Alt")?,
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
    Ok(Decoded {
        samples: Samples {
            time_s,
            voltage_v: chosen.voltage_v,
            current_a: chosen.current_a,
            phase: None,
            altitude_m,
            throttle,
            landed: None,
            vtol_transition: None,
        },
        landed: None,
        warnings,
        info,
    })
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
