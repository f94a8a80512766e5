//! PX4 ULog (`.ulg`): a small, bounds-checked reader of the documented format
//! (<https://docs.px4.io/main/en/dev_log/ulog_file_format.html>), and what a flight takes from it.
//!
//! File: a 16-byte header (`ULog` magic `55 4C 6F 67 01 12 35`, a version byte, the start
//! timestamp as `u64` µs), then messages `{u16 msg_size, u8 msg_type, payload[msg_size]}`, all
//! little-endian. This reader uses the flag bits (`B`: refuses unknown incompatible flags,
//! follows appended-data offsets), formats (`F`: `name:type field;type[n] field;…`, nested types
//! included), subscriptions (`A`/`R`) and data (`D`); every other message type is skipped, as
//! the specification asks. A truncated final message ends the log with a warning.
//!
//! A flight takes (instance 0 of each topic):
//!
//! - `battery_status`: `timestamp`, `voltage_v` (samples with a voltage at or below 0, PX4's
//!   "not measured", are dropped and counted), `current_a` (absent when every value is negative,
//!   PX4's "unknown");
//! - `vehicle_local_position`: `z` (NED, so altitude = −z; samples with `z_valid` false are
//!   dropped), interpolated onto the battery's times;
//! - `vehicle_land_detected`: `landed`, held onto the battery's times, as the ground test of the
//!   phase inference;
//! - `actuator_outputs` instance 0: `output[0]`…`output[N−1]` as the motor commands (PWM µs),
//!   N from `CA_ROTOR_COUNT`, else the vehicle type (quadrotor 4, hexarotor 6, octorotor 8),
//!   interpolated onto the battery's times; not read (a warning says why) when N is not known
//!   or a command is outside [`crate::motors::PWM_RANGE_US`] (DShot, a disarmed 0)
//!   ([`crate::motors`], [`ULog::motor_commands`]).
//!
//! Time is the battery's `timestamp` from its first sample, s.

use std::collections::HashMap;
use std::path::Path;

use crate::battery::{self, Track};
use crate::{Decoded, FlightLogError, LogInfo, Row, Samples, Vehicle, VehicleKind};

/// The first seven bytes of every ULog file.
pub const MAGIC: [u8; 7] = [0x55, 0x4C, 0x6F, 0x67, 0x01, 0x12, 0x35];
/// Header length, bytes.
pub const HEADER_LEN: usize = 16;
/// Deepest nesting of message formats followed.
const MAX_NESTING: usize = 16;

/// A scalar ULog field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// `int8_t`.
    I8,
    /// `uint8_t`.
    U8,
    /// `int16_t`.
    I16,
    /// `uint16_t`.
    U16,
    /// `int32_t`.
    I32,
    /// `uint32_t`.
    U32,
    /// `int64_t`.
    I64,
    /// `uint64_t`.
    U64,
    /// `float`.
    F32,
    /// `double`.
    F64,
    /// `bool`.
    Bool,
    /// `char`.
    Char,
}

impl Scalar {
    /// The scalar type of a ULog type name.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "int8_t" => Self::I8,
            "uint8_t" => Self::U8,
            "int16_t" => Self::I16,
            "uint16_t" => Self::U16,
            "int32_t" => Self::I32,
            "uint32_t" => Self::U32,
            "int64_t" => Self::I64,
            "uint64_t" => Self::U64,
            "float" => Self::F32,
            "double" => Self::F64,
            "bool" => Self::Bool,
            "char" => Self::Char,
            _ => return None,
        })
    }

    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 | Self::Bool | Self::Char => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
        }
    }

    /// Decodes a little-endian value as `f64` (`None` when `bytes` is too short).
    pub fn decode(self, bytes: &[u8]) -> Option<f64> {
        fn arr<const N: usize>(b: &[u8]) -> Option<[u8; N]> {
            b.get(..N)?.try_into().ok()
        }
        Some(match self {
            Self::I8 => f64::from(i8::from_le_bytes(arr(bytes)?)),
            Self::U8 | Self::Char => f64::from(*bytes.first()?),
            Self::Bool => f64::from(u8::from(*bytes.first()? != 0)),
            Self::I16 => f64::from(i16::from_le_bytes(arr(bytes)?)),
            Self::U16 => f64::from(u16::from_le_bytes(arr(bytes)?)),
            Self::I32 => f64::from(i32::from_le_bytes(arr(bytes)?)),
            Self::U32 => f64::from(u32::from_le_bytes(arr(bytes)?)),
            Self::I64 => i64::from_le_bytes(arr(bytes)?) as f64,
            Self::U64 => u64::from_le_bytes(arr(bytes)?) as f64,
            Self::F32 => f64::from(f32::from_le_bytes(arr(bytes)?)),
            Self::F64 => f64::from_le_bytes(arr(bytes)?),
        })
    }
}

/// One field of a message format, as written: type name, array length, field name.
#[derive(Debug, Clone, PartialEq, Eq)]
struct FieldDef {
    type_name: String,
    count: usize,
    name: String,
}

/// A data message: where it is and its payload after the `msg_id`.
#[derive(Debug, Clone, Copy)]
struct DataMessage<'a> {
    offset: u64,
    data: &'a [u8],
}

/// A ULog file's formats, subscriptions and data, borrowed from its bytes.
#[derive(Debug)]
pub struct ULog<'a> {
    /// File format version (header byte 7).
    pub version: u8,
    /// Start of logging, µs (header).
    pub start_timestamp_us: u64,
    formats: HashMap<String, Vec<FieldDef>>,
    /// Data per (topic, multi_id), in file order.
    data: HashMap<(String, u8), Vec<DataMessage<'a>>>,
    /// Parameters (`P` messages): the first value of each, as logged at the start.
    pub parameters: HashMap<String, f64>,
    /// Information (`I` messages, e.g. `sys_name`, `ver_hw`): text for `char[n]` values,
    /// the number's decimal text otherwise.
    pub info: HashMap<String, String>,
    /// What was skipped or odd (truncated tail, data without subscription).
    pub warnings: Vec<String>,
}

/// Decodes an `I` or `P` message body `{u8 key_len, key "type name", value}` into the name
/// and the value: a number for a scalar type, text for `char[n]`.
fn key_value(payload: &[u8]) -> Option<(String, KeyValue)> {
    let len = usize::from(*payload.first()?);
    let key = std::str::from_utf8(payload.get(1..1 + len)?).ok()?;
    let value = payload.get(1 + len..)?;
    let (ty, name) = key.trim().rsplit_once(' ')?;
    let ty = ty.trim();
    let name = name.trim().to_owned();
    if ty.starts_with("char[") {
        let end = value.iter().position(|&b| b == 0).unwrap_or(value.len());
        let text = String::from_utf8_lossy(&value[..end]).trim().to_owned();
        return Some((name, KeyValue::Text(text)));
    }
    let scalar = Scalar::from_name(ty)?;
    Some((name, KeyValue::Number(scalar.decode(value)?)))
}

/// The value of an `I` or `P` message.
enum KeyValue {
    Number(f64),
    Text(String),
}

/// A `u16` at `pos` (little-endian), if in range.
fn u16_at(b: &[u8], pos: usize) -> Option<u16> {
    Some(u16::from_le_bytes(
        b.get(pos..pos.checked_add(2)?)?.try_into().ok()?,
    ))
}

/// A `u64` at `pos` (little-endian), if in range.
fn u64_at(b: &[u8], pos: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        b.get(pos..pos.checked_add(8)?)?.try_into().ok()?,
    ))
}

/// Parses a format's text `name:type field;…` into its name and fields.
fn parse_format(text: &str) -> Result<(String, Vec<FieldDef>), String> {
    let (name, body) = text
        .split_once(':')
        .ok_or_else(|| format!("format {text:?} has no ':'"))?;
    let mut fields = Vec::new();
    for def in body.split(';') {
        let def = def.trim_matches(|c: char| c.is_whitespace() || c == '\0');
        if def.is_empty() {
            continue;
        }
        let (ty, field) = def
            .rsplit_once(' ')
            .ok_or_else(|| format!("field {def:?} of {name:?} is not \"type name\""))?;
        let ty = ty.trim();
        let (type_name, count) = match ty.split_once('[') {
            Some((base, rest)) => {
                let n = rest
                    .strip_suffix(']')
                    .and_then(|n| n.parse::<usize>().ok())
                    .ok_or_else(|| format!("field {def:?} of {name:?}: bad array length"))?;
                (base.to_owned(), n)
            }
            None => (ty.to_owned(), 1),
        };
        fields.push(FieldDef {
            type_name,
            count,
            name: field.trim().to_owned(),
        });
    }
    Ok((name.trim().to_owned(), fields))
}

impl<'a> ULog<'a> {
    /// Parses a ULog file held in memory; `path` names it in errors.
    pub fn parse(bytes: &'a [u8], path: &Path) -> Result<Self, FlightLogError> {
        let fail = |offset: usize, field: &str, message: String| {
            FlightLogError::binary(path, offset as u64, field, message)
        };
        if bytes.len() < HEADER_LEN || !bytes.starts_with(&MAGIC) {
            return Err(fail(
                0,
                "header",
                "not a ULog file (no ULog magic in a 16-byte header)".to_owned(),
            ));
        }
        let mut log = ULog {
            version: bytes[7],
            start_timestamp_us: u64_at(bytes, 8).unwrap_or(0),
            formats: HashMap::new(),
            data: HashMap::new(),
            parameters: HashMap::new(),
            info: HashMap::new(),
            warnings: Vec::new(),
        };
        let mut subscriptions: HashMap<u16, (String, u8)> = HashMap::new();
        let mut boundaries: Vec<usize> = Vec::new();
        let mut orphans = 0usize;
        let mut pos = HEADER_LEN;
        while pos < bytes.len() {
            if let Some(&b) = boundaries.first()
                && pos >= b
            {
                boundaries.remove(0);
                continue;
            }
            let (Some(size), Some(&kind)) = (u16_at(bytes, pos), bytes.get(pos + 2)) else {
                log.warnings.push(format!(
                    "byte {pos}: truncated message header at the end; ignored"
                ));
                break;
            };
            let end = pos + 3 + usize::from(size);
            if let Some(&b) = boundaries.first()
                && end > b
            {
                // A message cut by the start of appended data: continue there.
                pos = b;
                boundaries.remove(0);
                continue;
            }
            let Some(payload) = bytes.get(pos + 3..end) else {
                log.warnings.push(format!(
                    "byte {pos}: final message ({size} bytes) truncated at the end; ignored"
                ));
                break;
            };
            match kind {
                b'B' => {
                    let compat_len = 8;
                    let incompat = payload.get(compat_len..compat_len + 8).ok_or_else(|| {
                        fail(pos, "flag bits", "message shorter than 40 bytes".to_owned())
                    })?;
                    if incompat[0] & !1 != 0 || incompat[1..].iter().any(|&b| b != 0) {
                        return Err(fail(
                            pos,
                            "flag bits",
                            "unknown incompatible flags set: this file needs a newer reader"
                                .to_owned(),
                        ));
                    }
                    if incompat[0] & 1 != 0 {
                        for k in 0..3 {
                            if let Some(off) = u64_at(payload, 16 + 8 * k)
                                && off > 0
                                && let Ok(off) = usize::try_from(off)
                                && off > pos
                            {
                                boundaries.push(off);
                            }
                        }
                        boundaries.sort_unstable();
                    }
                }
                b'F' => {
                    let text = std::str::from_utf8(payload).map_err(|_| {
                        fail(pos, "format", "format definition is not UTF-8".to_owned())
                    })?;
                    let (name, fields) = parse_format(text).map_err(|m| fail(pos, "format", m))?;
                    log.formats.insert(name, fields);
                }
                b'A' => {
                    let (Some(&multi), Some(id)) = (payload.first(), u16_at(payload, 1)) else {
                        return Err(fail(
                            pos,
                            "subscription",
                            "message shorter than 3 bytes".to_owned(),
                        ));
                    };
                    let name = String::from_utf8_lossy(&payload[3..])
                        .trim_end_matches('\0')
                        .to_owned();
                    subscriptions.insert(id, (name, multi));
                }
                b'P' => {
                    if let Some((name, KeyValue::Number(v))) = key_value(payload) {
                        log.parameters.entry(name).or_insert(v);
                    }
                }
                b'I' => match key_value(payload) {
                    Some((name, KeyValue::Text(t))) => {
                        log.info.entry(name).or_insert(t);
                    }
                    Some((name, KeyValue::Number(v))) => {
                        log.info.entry(name).or_insert_with(|| v.to_string());
                    }
                    None => {}
                },
                b'R' => {
                    if let Some(id) = u16_at(payload, 0) {
                        subscriptions.remove(&id);
                    }
                }
                b'D' => {
                    let Some(id) = u16_at(payload, 0) else {
                        return Err(fail(pos, "data", "message shorter than 2 bytes".to_owned()));
                    };
                    match subscriptions.get(&id) {
                        Some(key) => log.data.entry(key.clone()).or_default().push(DataMessage {
                            offset: pos as u64,
                            data: &payload[2..],
                        }),
                        None => orphans += 1,
                    }
                }
                _ => {}
            }
            pos = end;
        }
        if orphans > 0 {
            log.warnings.push(format!(
                "{orphans} data message(s) without a subscription ignored"
            ));
        }
        Ok(log)
    }

    /// Names of the topics with data, sorted.
    pub fn topics(&self) -> Vec<&str> {
        let mut t: Vec<&str> = self.data.keys().map(|(n, _)| n.as_str()).collect();
        t.sort_unstable();
        t.dedup();
        t
    }

    /// Size in bytes of a type (scalar or nested format); `memo` keeps the sizes of nested
    /// formats already computed, so that deep or wide nesting costs one visit per format.
    fn type_size(
        &self,
        type_name: &str,
        depth: usize,
        memo: &mut HashMap<String, usize>,
    ) -> Result<usize, String> {
        if let Some(s) = Scalar::from_name(type_name) {
            return Ok(s.size());
        }
        if let Some(&s) = memo.get(type_name) {
            return Ok(s);
        }
        if depth >= MAX_NESTING {
            return Err(format!(
                "formats nested deeper than {MAX_NESTING} at {type_name:?}"
            ));
        }
        let fields = self
            .formats
            .get(type_name)
            .ok_or_else(|| format!("no format for type {type_name:?}"))?;
        let mut total = 0usize;
        for f in fields {
            total = self
                .type_size(&f.type_name, depth + 1, memo)?
                .checked_mul(f.count)
                .and_then(|s| s.checked_add(total))
                .ok_or_else(|| format!("format {type_name:?} is too large"))?;
        }
        memo.insert(type_name.to_owned(), total);
        Ok(total)
    }

    /// Offset and scalar type of a top-level scalar field of a topic, or of one element of a
    /// top-level array of scalars (`output[3]`, 0-based; `None` past its length).
    fn field(&self, topic: &str, field: &str) -> Result<Option<(usize, Scalar)>, String> {
        let fields = self
            .formats
            .get(topic)
            .ok_or_else(|| format!("no format for {topic:?}"))?;
        let (field, element) = match field.split_once('[') {
            Some((name, rest)) => {
                match rest.strip_suffix(']').and_then(|k| k.parse::<usize>().ok()) {
                    Some(k) => (name, Some(k)),
                    None => return Ok(None),
                }
            }
            None => (field, None),
        };
        let mut memo = HashMap::new();
        let mut offset = 0usize;
        for f in fields {
            if f.name == field {
                let Some(scalar) = Scalar::from_name(&f.type_name) else {
                    return Ok(None);
                };
                return Ok(match element {
                    None => Some((offset, scalar)),
                    Some(k) if k < f.count => Some((offset + k * scalar.size(), scalar)),
                    Some(_) => None,
                });
            }
            offset = self
                .type_size(&f.type_name, 0, &mut memo)?
                .checked_mul(f.count)
                .and_then(|s| s.checked_add(offset))
                .ok_or_else(|| format!("format {topic:?} is too large"))?;
        }
        Ok(None)
    }

    /// The lowest instance (multi_id) of a topic that has data.
    fn first_instance(&self, topic: &str) -> Option<u8> {
        self.data
            .keys()
            .filter(|(n, _)| n == topic)
            .map(|&(_, m)| m)
            .min()
    }

    /// The instances (multi_id) of a topic that have data, ascending.
    pub fn instances(&self, topic: &str) -> Vec<u8> {
        let mut v: Vec<u8> = self
            .data
            .keys()
            .filter(|(n, _)| n == topic)
            .map(|&(_, m)| m)
            .collect();
        v.sort_unstable();
        v
    }

    /// Values of top-level scalar fields of a topic's first instance, one row per message.
    /// `Ok(None)` when the topic has no data; a field the format lacks is `None` in every
    /// row when `required` is false, else an error. (See [`ULog::rows`] for any instance.)
    pub fn columns(
        &self,
        topic: &str,
        fields: &[(&str, bool)],
        path: &Path,
    ) -> Result<Option<Vec<Row>>, FlightLogError> {
        let Some(multi) = self.first_instance(topic) else {
            return Ok(None);
        };
        self.rows(topic, multi, fields, path).map(Some)
    }

    /// Values of top-level scalar fields of one instance of a topic, one row per message.
    /// Empty when that instance has no data; a field the format lacks is `None` in every row
    /// when `required` is false, else an error.
    pub fn rows(
        &self,
        topic: &str,
        instance: u8,
        fields: &[(&str, bool)],
        path: &Path,
    ) -> Result<Vec<Row>, FlightLogError> {
        let Some(messages) = self.data.get(&(topic.to_owned(), instance)) else {
            return Ok(Vec::new());
        };
        let first_offset = messages.first().map_or(0, |m| m.offset);
        let fail = |offset: u64, field: &str, message: String| {
            FlightLogError::binary(path, offset, format!("{topic}.{field}"), message)
        };
        let mut layout = Vec::with_capacity(fields.len());
        for &(name, required) in fields {
            let found = self
                .field(topic, name)
                .map_err(|m| fail(first_offset, name, m))?;
            if found.is_none() && required {
                return Err(fail(
                    first_offset,
                    name,
                    "the topic's format has no such scalar field".to_owned(),
                ));
            }
            layout.push(found);
        }
        let mut rows = Vec::with_capacity(messages.len());
        for m in messages {
            let mut values = Vec::with_capacity(fields.len());
            for (k, slot) in layout.iter().enumerate() {
                values.push(match slot {
                    None => None,
                    Some((off, ty)) => Some(
                        m.data
                            .get(*off..)
                            .and_then(|b| ty.decode(b))
                            .ok_or_else(|| {
                                fail(
                                    m.offset,
                                    fields[k].0,
                                    format!(
                                        "message has {} data bytes; the field needs {}",
                                        m.data.len(),
                                        off + ty.size()
                                    ),
                                )
                            })?,
                    ),
                });
            }
            rows.push(Row {
                offset: m.offset,
                values,
            });
        }
        Ok(rows)
    }
}

/// The motor commands of a ULog as logged, before they are put on a flight's time base.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorCommands {
    /// The motors' outputs and how they are known.
    pub outputs: crate::motors::MotorOutputs,
    /// The time of each `actuator_outputs` message, s (`timestamp`).
    pub time_s: Vec<f64>,
    /// Each message's command per motor, µs, motor 1 first (`None`: beyond its `noutputs`).
    pub rows: Vec<Vec<Option<f64>>>,
}

impl MotorCommands {
    /// Where they were read, in words.
    pub fn source(&self) -> String {
        let c = &self.outputs.channels;
        let outputs = match (c.first(), c.last()) {
            (Some(a), Some(b)) if c.len() > 1 => format!("output[{}]–output[{}]", a - 1, b - 1),
            (Some(a), _) => format!("output[{}]", a - 1),
            _ => String::new(),
        };
        format!(
            "actuator_outputs instance 0, {outputs} ({})",
            self.outputs.origin
        )
    }
}

impl ULog<'_> {
    /// The motor commands: `actuator_outputs` instance 0, `output[0]`…`output[N−1]`, N from
    /// `CA_ROTOR_COUNT`, else from `mav_type` (the vehicle type and where it came from;
    /// [`crate::motors`]); a message's output at or past its `noutputs` is `None`. `Ok(None)`
    /// when the log has no `actuator_outputs` instance 0; `Err` says why the outputs cannot be
    /// read as the motors' (the motor count not known, a field the format lacks).
    pub fn motor_commands(
        &self,
        path: &Path,
        mav_type: Option<(u32, &str)>,
    ) -> Result<Option<MotorCommands>, String> {
        const TOPIC: &str = "actuator_outputs";
        if !self.data.contains_key(&(TOPIC.to_owned(), 0)) {
            return Ok(None);
        }
        let not_read = |why: String| format!("{TOPIC} not read as motor commands: {why}");
        let outputs = crate::motors::px4_outputs(&self.parameters, mav_type).map_err(not_read)?;
        let names: Vec<String> = outputs
            .channels
            .iter()
            .map(|c| format!("output[{}]", c - 1))
            .collect();
        let mut fields = vec![("timestamp", true), ("noutputs", false)];
        fields.extend(names.iter().map(|n| (n.as_str(), true)));
        let rows = self
            .rows(TOPIC, 0, &fields, path)
            .map_err(|e| not_read(e.to_string()))?;
        let mut time_s = Vec::with_capacity(rows.len());
        let mut values = Vec::with_capacity(rows.len());
        for r in &rows {
            let Some(t) = r.values[0] else { continue };
            let n = r.values[1];
            time_s.push(t / 1e6);
            values.push(
                outputs
                    .channels
                    .iter()
                    .zip(&r.values[2..])
                    .map(|(&c, &v)| v.filter(|_| n.is_none_or(|n| (c as f64) <= n)))
                    .collect(),
            );
        }
        Ok(Some(MotorCommands {
            outputs,
            time_s,
            rows: values,
        }))
    }
}

/// The first parameter of `names` the log has with a value accepted by `ok`.
fn param<'n>(
    log: &ULog<'_>,
    names: &[&'n str],
    ok: impl Fn(f64) -> bool,
) -> Option<(&'n str, f64)> {
    names.iter().find_map(|&n| {
        log.parameters
            .get(n)
            .copied()
            .filter(|&v| ok(v))
            .map(|v| (n, v))
    })
}

/// What a PX4 log's parameters say of battery `n` (1-based; `BATn_…`, else the older `BAT_…`)
/// and the hover throttle, into `info` (whose cells, if known, are set first): the capacity,
/// the cut-off and charged voltages per cell × cells, `MPC_THR_HOVER`. Shared by the ULog and
/// telemetry-log readers.
pub(crate) fn px4_battery_info(info: &mut LogInfo, parameters: &HashMap<String, f64>, n: u32) {
    let lookup = |suffix: &str, ok: &dyn Fn(f64) -> bool| {
        [format!("BAT{n}_{suffix}"), format!("BAT_{suffix}")]
            .into_iter()
            .find_map(|k| {
                parameters
                    .get(&k)
                    .copied()
                    .filter(|&v| ok(v))
                    .map(|v| (k, v))
            })
    };
    if let Some((k, v)) = lookup("CAPACITY", &|v| v > 0.0) {
        info.set("capacity_mah", k, |m| m.capacity_mah = Some(v));
    }
    if let Some(cells) = info.meta.cells {
        let c = f64::from(cells);
        if let Some((k, v)) = lookup("V_EMPTY", &|v| v > 0.0 && v < 5.0) {
            info.set("cutoff_voltage_v", format!("{k} × {cells} cells"), |m| {
                m.cutoff_voltage_v = Some(v * c);
            });
        }
        if let Some((k, v)) = lookup("V_CHARGED", &|v| v > 0.0 && v < 5.0) {
            info.set("charged_voltage_v", format!("{k} × {cells} cells"), |m| {
                m.charged_voltage_v = Some(v * c);
            });
        }
    }
    if let Some(v) = parameters
        .get("MPC_THR_HOVER")
        .copied()
        .filter(|&v| v > 0.0 && v <= 1.0)
    {
        info.set("hover_throttle", "MPC_THR_HOVER", |m| {
            m.hover_throttle = Some(v);
        });
    }
    info.derive_energy();
}

/// Parses a `.ulg` into a flight's samples.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let log = ULog::parse(bytes, path)?;
    let mut warnings = log.warnings.clone();
    let mut info = LogInfo {
        firmware: log.info.get("sys_name").map(|name| {
            match log.info.get("ver_sw_branch").or(log.info.get("ver_sw")) {
                Some(v) => format!("{name} {v}"),
                None => name.clone(),
            }
        }),
        hardware: log.info.get("ver_hw").cloned(),
        ..LogInfo::default()
    };

    // Every battery_status instance, each with its cell count.
    let fields = [
        ("timestamp", true),
        ("voltage_v", true),
        ("current_a", false),
        ("connected", false),
        ("remaining", false),
        ("warning", false),
        ("cell_count", false),
        ("id", false),
    ];
    let mut tracks = Vec::new();
    for instance in log.instances("battery_status") {
        let rows = log.rows("battery_status", instance, &fields, path)?;
        // Time and voltage are required fields: every row has them.
        let rows = Row::having(&rows, &[0, 1]);
        if rows.is_empty() {
            continue;
        }
        let col = |k: usize| rows.iter().map(move |r| r.values[k]);
        let id = col(7)
            .flatten()
            .find(|&v| (1.0..=9.0).contains(&v))
            .map_or(u32::from(instance) + 1, |v| v as u32);
        let cell_field = col(6).flatten().find(|&c| c >= 1.0);
        let numbered = format!("BAT{id}_N_CELLS");
        let cells = match cell_field {
            Some(c) => Some((c as u32, "battery_status.cell_count".to_owned())),
            None => param(&log, &[numbered.as_str(), "BAT_N_CELLS"], |v| v >= 1.0)
                .map(|(n, v)| (v as u32, n.to_owned())),
        };
        let present = |k: usize| rows.first().is_some_and(|r| r.values[k].is_some());
        tracks.push(Track {
            name: format!("battery_status instance {instance}"),
            offsets: rows.iter().map(|r| r.offset).collect(),
            time_s: col(0).flatten().map(|t| t / 1e6).collect(),
            voltage_v: col(1).flatten().collect(),
            current_a: col(2).collect(),
            connected: present(3).then(|| col(3).map(|c| c != Some(0.0)).collect()),
            remaining: present(4).then(|| col(4).map(|r| r.unwrap_or(-1.0)).collect()),
            warning: present(5).then(|| {
                col(5)
                    .map(|w| w.unwrap_or(0.0).clamp(0.0, 255.0) as u8)
                    .collect()
            }),
            cells,
        });
    }
    let chosen = battery::choose(path, &tracks, "battery_status", &log.topics().join(", "))?;
    warnings.extend(chosen.warnings.iter().cloned());
    let t0 = chosen.t0_s;
    let time_s = chosen.time_s.clone();
    crate::check_time(path, &time_s, "battery_status.timestamp", |i| {
        format!("byte {}", chosen.offsets.get(i).copied().unwrap_or(0))
    })?;

    // Metadata from the parameters of the battery used (BATn_…, else the older BAT_…).
    let n = chosen
        .info
        .battery
        .rsplit(' ')
        .next()
        .and_then(|i| i.parse::<u32>().ok())
        .map_or(1, |i| i + 1);
    if let Some((cells, origin)) = chosen.info.cells.clone() {
        info.set("cells", origin, |m| m.cells = Some(cells));
    }
    px4_battery_info(&mut info, &log.parameters, n);

    // Vehicle: MAV_TYPE, else vehicle_status (system_type, is_vtol).
    let status = log
        .instances("vehicle_status")
        .first()
        .map(|&i| {
            log.rows(
                "vehicle_status",
                i,
                &[("system_type", false), ("is_vtol", false)],
                path,
            )
        })
        .transpose()?
        .unwrap_or_default();
    let status_vtol = status.iter().any(|r| r.values[1] == Some(1.0));
    let status_type = status.iter().find_map(|r| r.values[0]);
    let mav_type = match (param(&log, &["MAV_TYPE"], |v| v >= 0.0), status_type) {
        (Some((_, t)), _) => Some((t as u32, "MAV_TYPE")),
        (None, Some(t)) => Some((t as u32, "vehicle_status.system_type")),
        (None, None) => None,
    };
    let vehicle = mav_type.map(|(t, origin)| {
        let mut kind = VehicleKind::from_mav_type(t);
        let mut description = format!("{} ({origin} {t})", mav_type_name(t));
        if status_vtol && kind != VehicleKind::Vtol {
            kind = VehicleKind::Vtol;
            description.push_str(", vehicle_status.is_vtol");
        }
        Vehicle { kind, description }
    });
    if let Some(v) = &vehicle {
        info.set("vehicle", v.description.clone(), |m| {
            m.vehicle = Some(v.kind)
        });
    }
    info.vehicle = vehicle;
    info.battery = Some(chosen.info.clone());

    let altitude_m = match log.columns(
        "vehicle_local_position",
        &[("timestamp", true), ("z", true), ("z_valid", false)],
        path,
    )? {
        Some(rows) => {
            // z_valid, when logged, must not be 0.
            let (t, z): (Vec<f64>, Vec<f64>) = rows
                .iter()
                .filter(|r| r.values[2] != Some(0.0))
                .filter_map(|r| match (r.values[0], r.values[1]) {
                    (Some(t), Some(z)) if z.is_finite() => Some((t / 1e6 - t0, -z)),
                    _ => None,
                })
                .unzip();
            let altitude_m = crate::resample::linear(&t, &z, &time_s);
            if altitude_m.is_none() {
                warnings.push("vehicle_local_position has no valid z".to_owned());
            }
            altitude_m
        }
        None => None,
    };
    let landed = log
        .columns(
            "vehicle_land_detected",
            &[("timestamp", true), ("landed", true)],
            path,
        )?
        .map(|rows| {
            let (t, l): (Vec<f64>, Vec<bool>) = rows
                .iter()
                .filter_map(|r| Some((r.values[0]? / 1e6 - t0, r.values[1]? != 0.0)))
                .unzip();
            crate::resample::hold(&t, &l, &time_s)
        });
    // A VTOL's own state: PX4 ≥ 1.12 logs vehicle_vtol_state (1, 2: transition to fixed wing
    // or multicopter; 4: fixed wing), older firmware vtol_in_trans_mode and vtol_in_rw_mode.
    let vtol_transition = match log.instances("vtol_vehicle_status").first() {
        Some(&i) => {
            let rows = log.rows(
                "vtol_vehicle_status",
                i,
                &[
                    ("timestamp", true),
                    ("vehicle_vtol_state", false),
                    ("vtol_in_trans_mode", false),
                    ("vtol_in_rw_mode", false),
                ],
                path,
            )?;
            let (t, v): (Vec<f64>, Vec<bool>) = rows
                .iter()
                .filter_map(|r| {
                    let t = r.values[0]? / 1e6 - t0;
                    let state = match (r.values[1], r.values[2], r.values[3]) {
                        (Some(s), _, _) => matches!(s as u8, 1 | 2 | 4),
                        (None, Some(tr), rw) => tr != 0.0 || rw == Some(0.0),
                        (None, None, Some(rw)) => rw == 0.0,
                        (None, None, None) => return None,
                    };
                    Some((t, state))
                })
                .unzip();
            (!t.is_empty()).then(|| crate::resample::hold(&t, &v, &time_s))
        }
        None => None,
    };
    // The motor commands, onto the battery's times; a log without them says nothing.
    let motor_us = match log.motor_commands(path, mav_type) {
        Ok(None) => None,
        Ok(Some(m)) => {
            let name = |k: usize| format!("actuator_outputs.output[{}]", m.outputs.channels[k] - 1);
            let time_s_log: Vec<f64> = m.time_s.iter().map(|t| t - t0).collect();
            match crate::motors::align(
                &time_s_log,
                &m.rows,
                m.outputs.channels.len(),
                &time_s,
                &name,
            ) {
                Ok(columns) => {
                    info.motors = Some(m.source());
                    Some(columns)
                }
                Err(why) => {
                    warnings.push(why);
                    None
                }
            }
        }
        Err(why) => {
            warnings.push(why);
            None
        }
    };
    Ok(Decoded {
        samples: Samples {
            vtol_transition,
            motor_us,
            time_s,
            voltage_v: chosen.voltage_v,
            current_a: chosen.current_a,
            phase: None,
            altitude_m,
            throttle: None,
            landed: None,
        },
        landed,
        warnings,
        info,
    })
}

/// MAVLink's name of a `MAV_TYPE`.
pub(crate) fn mav_type_name(t: u32) -> &'static str {
    match t {
        1 => "fixed wing",
        2 => "quadrotor",
        3 => "coaxial helicopter",
        4 => "helicopter",
        13 => "hexarotor",
        14 => "octorotor",
        15 => "tricopter",
        19 => "VTOL tailsitter duo-rotor",
        20 => "VTOL tailsitter quadrotor",
        21 => "VTOL tiltrotor",
        22 => "VTOL fixed-rotor (standard VTOL)",
        23 => "VTOL tailsitter",
        24 => "VTOL tiltwing",
        10..=12 => "ground or water vehicle",
        _ => "other vehicle",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_text() {
        let (name, fields) =
            parse_format("battery_status:uint64_t timestamp;float[4] v;uint8_t[3] _padding0;")
                .unwrap();
        assert_eq!(name, "battery_status");
        assert_eq!(fields.len(), 3);
        assert_eq!(fields[1].count, 4);
        assert!(parse_format("nocolon").is_err());
        assert!(parse_format("x:float[a] v;").is_err());
    }

    #[test]
    fn wide_and_deep_nesting_is_cheap_and_bounded() {
        // t0 has 8 fields of t1, t1 of t2, …: 8^15 visits without memoisation.
        let mut log = ULog {
            version: 1,
            start_timestamp_us: 0,
            formats: HashMap::new(),
            data: HashMap::new(),
            parameters: HashMap::new(),
            info: HashMap::new(),
            warnings: Vec::new(),
        };
        for d in 0..15 {
            let fields = (0..8)
                .map(|k| format!("t{} f{k};", d + 1))
                .collect::<String>();
            let (name, f) = parse_format(&format!("t{d}:{fields}")).unwrap();
            log.formats.insert(name, f);
        }
        let (name, f) = parse_format("t15:uint8_t x;").unwrap();
        log.formats.insert(name, f);
        let (name, f) = parse_format("top:t0 a;float b;").unwrap();
        log.formats.insert(name, f);
        let size = 8usize.pow(15);
        assert_eq!(log.field("top", "b").unwrap(), Some((size, Scalar::F32)));
        // A cycle is an error, not a stack overflow.
        let (name, f) = parse_format("loop:loop x;").unwrap();
        log.formats.insert(name, f);
        let (name, f) = parse_format("top2:loop a;float b;").unwrap();
        log.formats.insert(name, f);
        assert!(log.field("top2", "b").is_err());
    }

    #[test]
    fn rejects_non_ulog() {
        let e = ULog::parse(b"hello", Path::new("x.ulg")).unwrap_err();
        assert!(matches!(e, FlightLogError::Binary { offset: 0, .. }));
    }
}
