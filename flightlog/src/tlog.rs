//! MAVLink telemetry logs (`.tlog`): what a ground station (Mission Planner, MAVProxy,
//! QGroundControl) recorded of a vehicle's telemetry, when the autopilot's own log is not at
//! hand. A bounds-checked reader of the few messages a flight needs.
//!
//! A telemetry log is a sequence of `{u64 big-endian time of reception, µs since 1970;
//! MAVLink packet}`. A packet is MAVLink 1 (`0xFE`, length, sequence, system, component,
//! message id, payload, CRC) or MAVLink 2 (`0xFD`, length, incompatibility and compatibility
//! flags, sequence, system, component, 3-byte message id, payload with its trailing zeros cut,
//! CRC, and a 13-byte signature when flagged). The checksum (X.25 over the header from the
//! length to the payload, then the message's `CRC_EXTRA`) is checked for every message read
//! here; a packet that fails it, or bytes that are not a packet, are skipped and counted (the
//! reader resynchronises on the next timestamp and start byte).
//!
//! Read, from the vehicle (the system that sends the battery): `SYS_STATUS` (`voltage_battery`
//! mV, `current_battery` cA, −1 unknown, `battery_remaining` %) as the battery, else
//! `BATTERY_STATUS` (its cells' voltages summed, `current_battery` cA) per battery `id`;
//! `GLOBAL_POSITION_INT.relative_alt` (mm) as altitude and `VFR_HUD.throttle` (%) as throttle,
//! both interpolated onto the battery's times, as is `SERVO_OUTPUT_RAW` (port 0,
//! `servo1_raw`…, µs) for the motor commands of the motors the log's parameters or vehicle
//! type name ([`crate::motors`]); `HEARTBEAT` for the vehicle type and
//! autopilot; `STATUSTEXT` and `PARAM_VALUE` for what an ArduPilot log says about itself
//! (firmware, frame, `BATT_CAPACITY`, …, as in [`crate::dataflash`]) or a PX4 one's parameters
//! (`BAT1_N_CELLS`, `BAT1_CAPACITY`, `BAT1_V_EMPTY`, …, as in [`crate::ulog`]). Time is the ground
//! station's time of reception from the battery's first message, s: a telemetry link drops
//! packets, so its rate is what arrived.

use std::collections::HashMap;
use std::path::Path;

use crate::battery::{self, Track};
use crate::{Decoded, FlightLogError, LogInfo, Vehicle, VehicleKind};

/// Start byte of a MAVLink 1 packet.
pub const V1: u8 = 0xFE;
/// Start byte of a MAVLink 2 packet.
pub const V2: u8 = 0xFD;

/// Message ids read, with their `CRC_EXTRA` (MAVLink's `common.xml`) and the payload length
/// they are read at (MAVLink 2 cuts trailing zeros; a shorter payload is zero-extended).
const HEARTBEAT: u32 = 0;
const SYS_STATUS: u32 = 1;
const PARAM_VALUE: u32 = 22;
const GLOBAL_POSITION_INT: u32 = 33;
const SERVO_OUTPUT_RAW: u32 = 36;
const VFR_HUD: u32 = 74;
const BATTERY_STATUS: u32 = 147;
const STATUSTEXT: u32 = 253;

/// `CRC_EXTRA` and the length read, of a message this reader reads.
fn known(msg_id: u32) -> Option<(u8, usize)> {
    Some(match msg_id {
        HEARTBEAT => (50, 9),
        SYS_STATUS => (124, 31),
        PARAM_VALUE => (220, 25),
        GLOBAL_POSITION_INT => (104, 28),
        // Wire order (MAVLink sorts the base fields by size): time_usec u32 at 0,
        // servo1_raw…servo8_raw u16 at 4–19, port u8 at 20; the MAVLink 2 extension
        // servo9_raw…servo16_raw u16 at 21–36 (not in CRC_EXTRA).
        SERVO_OUTPUT_RAW => (222, 21),
        VFR_HUD => (20, 20),
        BATTERY_STATUS => (154, 49),
        STATUSTEXT => (83, 51),
        _ => return None,
    })
}

/// The X.25 checksum (CRC-16/MCRF4XX) MAVLink uses, accumulated over `bytes`.
pub fn crc_x25(mut crc: u16, bytes: &[u8]) -> u16 {
    for &b in bytes {
        let mut tmp = b ^ (crc & 0xFF) as u8;
        tmp ^= tmp << 4;
        crc = (crc >> 8) ^ (u16::from(tmp) << 8) ^ (u16::from(tmp) << 3) ^ (u16::from(tmp) >> 4);
    }
    crc
}

/// Earliest and latest plausible reception times, µs since 1970 (2000 and 2100): a timestamp
/// outside them is not one.
const TIME_RANGE_US: std::ops::Range<u64> = 946_684_800_000_000..4_102_444_800_000_000;

/// One packet of a message this reader reads.
#[derive(Debug, Clone, PartialEq)]
pub struct Packet {
    /// Byte offset of its timestamp in the file.
    pub offset: u64,
    /// Time of reception, µs since 1970.
    pub time_us: u64,
    /// Sending system and component.
    pub system: u8,
    /// Sending component.
    pub component: u8,
    /// Message id.
    pub msg_id: u32,
    /// Payload, zero-extended to the length this reader reads it at.
    pub payload: Vec<u8>,
}

/// The packets of a telemetry log that this reader reads, and what was skipped.
#[derive(Debug, Default)]
pub struct Tlog {
    /// Packets of the messages read, in file order.
    pub packets: Vec<Packet>,
    /// Packets of other messages (not checked, not read).
    pub others: usize,
    /// What was skipped (bytes that are not a packet, failed checksums, a truncated tail).
    pub warnings: Vec<String>,
}

/// Whether bytes start like a telemetry log: a plausible timestamp, then a MAVLink start byte.
pub fn looks_like_tlog(bytes: &[u8]) -> bool {
    bytes.get(..9).is_some_and(|b| {
        let t = u64::from_be_bytes(b[..8].try_into().unwrap_or_default());
        TIME_RANGE_US.contains(&t) && (b[8] == V1 || b[8] == V2)
    })
}

impl Tlog {
    /// Parses a telemetry log held in memory; `path` names it in errors.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self, FlightLogError> {
        if !looks_like_tlog(bytes) {
            return Err(FlightLogError::binary(
                path,
                0,
                "header",
                "not a MAVLink telemetry log (no timestamp and MAVLink start byte at its start)"
                    .to_owned(),
            ));
        }
        let mut log = Tlog::default();
        let (mut skipped, mut first_skip, mut bad_crc) = (0usize, None::<usize>, 0usize);
        let mut pos = 0usize;
        while pos < bytes.len() {
            match packet_at(bytes, pos) {
                Step::Packet(p, len) => {
                    log.packets.push(p);
                    pos += len;
                }
                Step::Other(len) => {
                    log.others += 1;
                    pos += len;
                }
                Step::Truncated => {
                    log.warnings.push(format!(
                        "byte {pos}: final packet truncated at the end; ignored"
                    ));
                    break;
                }
                step @ (Step::BadCrc | Step::NotAPacket) => {
                    if matches!(step, Step::BadCrc) {
                        bad_crc += 1;
                    }
                    first_skip.get_or_insert(pos);
                    // Resynchronise: the next byte that could start a timestamp and packet.
                    let next = (pos + 1..bytes.len())
                        .find(|&p| looks_like_tlog(&bytes[p..]))
                        .unwrap_or(bytes.len());
                    skipped += next - pos;
                    pos = next;
                }
            }
        }
        if skipped > 0 {
            log.warnings.push(format!(
                "{skipped} byte(s) that are not a packet skipped (first at byte {}; {bad_crc} packet(s) with a wrong checksum)",
                first_skip.unwrap_or(0)
            ));
        }
        Ok(log)
    }
}

/// What is at a position of a telemetry log.
enum Step {
    /// A packet read, and its length with its timestamp.
    Packet(Packet, usize),
    /// A packet of a message not read, and its length.
    Other(usize),
    /// A packet whose checksum is wrong.
    BadCrc,
    /// Bytes that are not a timestamp and packet.
    NotAPacket,
    /// A packet cut by the end of the file.
    Truncated,
}

fn packet_at(bytes: &[u8], pos: usize) -> Step {
    let rest = &bytes[pos..];
    if rest.len() < 9 {
        return if rest.iter().all(|&b| b == 0) {
            Step::Other(rest.len())
        } else {
            Step::Truncated
        };
    }
    if !looks_like_tlog(rest) {
        return Step::NotAPacket;
    }
    let time_us = u64::from_be_bytes(rest[..8].try_into().unwrap_or_default());
    let frame = &rest[8..];
    let (header, msg_id, system, component, signature) = match frame[0] {
        V1 => {
            let Some(h) = frame.get(..6) else {
                return Step::Truncated;
            };
            (6usize, u32::from(h[5]), h[3], h[4], 0usize)
        }
        _ => {
            let Some(h) = frame.get(..10) else {
                return Step::Truncated;
            };
            let id = u32::from(h[7]) | u32::from(h[8]) << 8 | u32::from(h[9]) << 16;
            (10usize, id, h[5], h[6], if h[2] & 1 == 1 { 13 } else { 0 })
        }
    };
    let payload_len = usize::from(frame[1]);
    let total = 8 + header + payload_len + 2 + signature;
    if rest.len() < total {
        return Step::Truncated;
    }
    let Some((extra, read_len)) = known(msg_id) else {
        return Step::Other(total);
    };
    let crc_end = header + payload_len;
    let crc = crc_x25(crc_x25(0xFFFF, &frame[1..crc_end]), &[extra]);
    if crc.to_le_bytes() != frame[crc_end..crc_end + 2] {
        return Step::BadCrc;
    }
    let mut payload = frame[header..crc_end].to_vec();
    payload.resize(payload_len.max(read_len), 0);
    Step::Packet(
        Packet {
            offset: pos as u64,
            time_us,
            system,
            component,
            msg_id,
            payload,
        },
        total,
    )
}

fn u16_at(p: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([p[at], p[at + 1]])
}

fn i16_at(p: &[u8], at: usize) -> i16 {
    i16::from_le_bytes([p[at], p[at + 1]])
}

fn i32_at(p: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([p[at], p[at + 1], p[at + 2], p[at + 3]])
}

fn f32_at(p: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([p[at], p[at + 1], p[at + 2], p[at + 3]])
}

/// A battery current field (`int16` cA, −1 unknown), A.
fn current_at(p: &[u8], at: usize) -> Option<f64> {
    match i16_at(p, at) {
        -1 => None,
        ca => Some(f64::from(ca) / 100.0),
    }
}

/// A `battery_remaining` field (`int8` %, −1 unknown), as a fraction (negative: unknown).
fn remaining_at(p: &[u8], at: usize) -> f64 {
    match p[at] as i8 {
        r @ 0..=100 => f64::from(r) / 100.0,
        _ => -1.0,
    }
}

/// Text of a NUL-padded `char[n]`.
fn text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).trim().to_owned()
}

/// A telemetry link drops out (range, a restart of the autopilot or of the ground station):
/// where the battery's messages stop for longer than [`crate::MAX_GAP_S`], the log is cut into
/// stretches and the one that drew the most charge (without a current, the longest) is kept,
/// its time from its own first sample. Returns what was done, when anything was.
fn keep_one_stretch(chosen: &mut battery::Chosen) -> Option<String> {
    let t = &chosen.time_s;
    let mut bounds = vec![0usize];
    bounds.extend((1..t.len()).filter(|&i| t[i] - t[i - 1] > crate::MAX_GAP_S));
    bounds.push(t.len());
    if bounds.len() <= 2 {
        return None;
    }
    let worth = |a: usize, b: usize| match &chosen.current_a {
        Some(c) => (a + 1..b)
            .map(|k| 0.5 * (c[k] + c[k - 1]) * (t[k] - t[k - 1]))
            .sum::<f64>(),
        None => t[b - 1] - t[a],
    };
    let stretches: Vec<(usize, usize)> = bounds.windows(2).map(|w| (w[0], w[1])).collect();
    let &(a, b) = stretches
        .iter()
        .max_by(|x, y| worth(x.0, x.1).total_cmp(&worth(y.0, y.1)))?;
    let (from, to) = (t[a], t[b - 1]);
    let shift = t[a];
    chosen.time_s = t[a..b].iter().map(|x| x - shift).collect();
    chosen.t0_s += shift;
    chosen.offsets = chosen.offsets[a..b].to_vec();
    chosen.voltage_v = chosen.voltage_v[a..b].to_vec();
    if let Some(c) = chosen.current_a.as_mut() {
        *c = c[a..b].to_vec();
    }
    Some(format!(
        "the telemetry stops for more than {} s {} time(s): kept {from:.1}–{to:.1} s of the log, the stretch that drew the most {}; {} other stretch(es) left out",
        crate::MAX_GAP_S,
        stretches.len() - 1,
        if chosen.current_a.is_some() {
            "charge"
        } else {
            "time (no current)"
        },
        stretches.len() - 1
    ))
}

/// Parses a `.tlog` into a flight's samples.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Decoded, FlightLogError> {
    let log = Tlog::parse(bytes, path)?;
    let mut warnings = log.warnings.clone();
    // The vehicle: the system that sends the battery.
    let mut battery_counts: HashMap<u8, usize> = HashMap::new();
    for p in &log.packets {
        if matches!(p.msg_id, SYS_STATUS | BATTERY_STATUS) {
            *battery_counts.entry(p.system).or_default() += 1;
        }
    }
    let mut by_count: Vec<(u8, usize)> = battery_counts.into_iter().collect();
    by_count.sort_by_key(|&(s, n)| (std::cmp::Reverse(n), s));
    let Some(&(system, _)) = by_count.first() else {
        let mut seen: Vec<u32> = log.packets.iter().map(|p| p.msg_id).collect();
        seen.sort_unstable();
        seen.dedup();
        return Err(FlightLogError::MissingData {
            path: path.to_owned(),
            field: "SYS_STATUS or BATTERY_STATUS (battery voltage)".to_owned(),
            message: format!(
                "the log has none ({} packets of the messages read: ids {seen:?}; {} of others)",
                log.packets.len(),
                log.others
            ),
        });
    };
    if by_count.len() > 1 {
        warnings.push(format!(
            "battery messages from {} systems; system {system} (the most) read",
            by_count.len()
        ));
    }
    let of = |id: u32| {
        log.packets
            .iter()
            .filter(move |p| p.system == system && p.msg_id == id)
    };
    let seconds = |p: &Packet| p.time_us as f64 * 1e-6;

    // Batteries: SYS_STATUS, then BATTERY_STATUS per id.
    let mut tracks = Vec::new();
    let sys: Vec<&Packet> = of(SYS_STATUS).collect();
    if !sys.is_empty() {
        tracks.push(Track {
            name: "SYS_STATUS".to_owned(),
            offsets: sys.iter().map(|p| p.offset).collect(),
            time_s: sys.iter().map(|p| seconds(p)).collect(),
            voltage_v: sys
                .iter()
                .map(|p| match u16_at(&p.payload, 14) {
                    0 | u16::MAX => f64::NAN,
                    mv => f64::from(mv) / 1000.0,
                })
                .collect(),
            current_a: sys.iter().map(|p| current_at(&p.payload, 16)).collect(),
            connected: None,
            remaining: Some(sys.iter().map(|p| remaining_at(&p.payload, 30)).collect()),
            warning: None,
            cells: None,
        });
    }
    let mut ids: Vec<u8> = of(BATTERY_STATUS).map(|p| p.payload[32]).collect();
    ids.sort_unstable();
    ids.dedup();
    for id in ids {
        let b: Vec<&Packet> = of(BATTERY_STATUS).filter(|p| p.payload[32] == id).collect();
        let cells_in = |p: &Packet| -> Vec<u16> {
            let main = (0..10).map(|k| u16_at(&p.payload, 10 + 2 * k));
            let ext = (0..4).map(|k| u16_at(&p.payload, 41 + 2 * k));
            main.chain(ext)
                .filter(|&mv| mv != u16::MAX && mv != 0)
                .collect()
        };
        tracks.push(Track {
            name: format!("BATTERY_STATUS id {id}"),
            offsets: b.iter().map(|p| p.offset).collect(),
            time_s: b.iter().map(|p| seconds(p)).collect(),
            voltage_v: b
                .iter()
                .map(|p| match cells_in(p) {
                    c if c.is_empty() => f64::NAN,
                    c => c.iter().map(|&mv| f64::from(mv)).sum::<f64>() / 1000.0,
                })
                .collect(),
            current_a: b.iter().map(|p| current_at(&p.payload, 30)).collect(),
            connected: None,
            remaining: Some(b.iter().map(|p| remaining_at(&p.payload, 35)).collect()),
            warning: None,
            cells: None,
        });
    }
    let available = {
        let mut names: Vec<&str> = log
            .packets
            .iter()
            .filter(|p| p.system == system)
            .map(|p| match p.msg_id {
                HEARTBEAT => "HEARTBEAT",
                SYS_STATUS => "SYS_STATUS",
                PARAM_VALUE => "PARAM_VALUE",
                GLOBAL_POSITION_INT => "GLOBAL_POSITION_INT",
                SERVO_OUTPUT_RAW => "SERVO_OUTPUT_RAW",
                VFR_HUD => "VFR_HUD",
                BATTERY_STATUS => "BATTERY_STATUS",
                _ => "STATUSTEXT",
            })
            .collect();
        names.sort_unstable();
        names.dedup();
        names.join(", ")
    };
    let mut chosen = battery::choose(
        path,
        &tracks,
        "SYS_STATUS or BATTERY_STATUS (battery voltage)",
        &available,
    )?;
    warnings.append(&mut chosen.warnings);
    if let Some(note) = keep_one_stretch(&mut chosen) {
        warnings.push(note);
    }
    let t0 = chosen.t0_s;
    let time_s = chosen.time_s.clone();
    crate::check_time(
        path,
        &time_s,
        &format!("{} (time of reception)", chosen.info.battery),
        |i| format!("byte {}", chosen.offsets.get(i).copied().unwrap_or(0)),
    )?;

    // What the log says about itself.
    let heartbeat = of(HEARTBEAT)
        .map(|p| (p.payload[4], p.payload[5]))
        .find(|&(_, autopilot)| autopilot != 8);
    let messages: Vec<String> = of(STATUSTEXT).map(|p| text(&p.payload[1..51])).collect();
    let mut params: HashMap<String, f64> = HashMap::new();
    for p in of(PARAM_VALUE) {
        let name = text(&p.payload[8..24]);
        let value = f64::from(f32_at(&p.payload, 0));
        if !name.is_empty() && value.is_finite() {
            params.entry(name).or_insert(value);
        }
    }
    // PX4 names its cells in a parameter; otherwise they are estimated from the voltage.
    let px4 = matches!(heartbeat, Some((_, 12)));
    let cells = params
        .get("BAT1_N_CELLS")
        .or_else(|| params.get("BAT_N_CELLS"))
        .filter(|&&c| px4 && (1.0..=30.0).contains(&c))
        .map(|&c| (c as u32, "BAT1_N_CELLS".to_owned()))
        .or_else(|| battery::estimate_cells(&chosen.voltage_v));
    let mut info = match heartbeat {
        Some((_, 3)) => crate::dataflash::ardupilot_info(&messages, &params, cells.as_ref()),
        _ => {
            let mut info = LogInfo::default();
            if let Some((c, origin)) = &cells {
                info.set("cells", origin.clone(), |m| m.cells = Some(*c));
            }
            if px4 {
                crate::ulog::px4_battery_info(&mut info, &params, 1);
            }
            info
        }
    };
    if info.vehicle.is_none()
        && let Some((t, autopilot)) = heartbeat
        && VehicleKind::from_mav_type(u32::from(t)) != VehicleKind::Other
    {
        let kind = VehicleKind::from_mav_type(u32::from(t));
        let who = match autopilot {
            3 => "ArduPilot",
            12 => "PX4",
            _ => "autopilot",
        };
        let description = format!(
            "{who} {} (HEARTBEAT type {t})",
            crate::ulog::mav_type_name(u32::from(t))
        );
        info.set("vehicle", description.clone(), |m| m.vehicle = Some(kind));
        info.vehicle = Some(Vehicle { kind, description });
    }
    chosen.info.cells = cells;
    info.battery = Some(chosen.info.clone());

    // Altitude and throttle, onto the battery's times.
    let series = |id: u32, value: &dyn Fn(&[u8]) -> f64| {
        let (t, v): (Vec<f64>, Vec<f64>) = of(id)
            .map(|p| (seconds(p) - t0, value(&p.payload)))
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .unzip();
        crate::resample::linear(&t, &v, &time_s)
    };
    let altitude_m = series(GLOBAL_POSITION_INT, &|p| f64::from(i32_at(p, 16)) / 1000.0);
    let throttle = series(VFR_HUD, &|p| f64::from(u16_at(p, 18)) / 100.0);

    // The motor commands: SERVO_OUTPUT_RAW of port 0, the motors' outputs.
    let servo: Vec<&Packet> = of(SERVO_OUTPUT_RAW)
        .filter(|p| p.payload[20] == 0)
        .collect();
    let motor_us = if servo.is_empty() {
        None
    } else {
        let read = motor_outputs(&params, &info, heartbeat).and_then(|outputs| {
            // servo1_raw…servo8_raw at 4–19; servo9_raw… at 21 on, when the packet has them.
            let at = |c: usize| {
                if c <= 8 {
                    4 + 2 * (c - 1)
                } else {
                    21 + 2 * (c - 9)
                }
            };
            let t: Vec<f64> = servo.iter().map(|p| seconds(p) - t0).collect();
            let rows: Vec<Vec<Option<f64>>> = servo
                .iter()
                .map(|p| {
                    outputs
                        .channels
                        .iter()
                        .map(|&c| {
                            p.payload
                                .get(at(c)..at(c) + 2)
                                .map(|b| f64::from(u16::from_le_bytes([b[0], b[1]])))
                        })
                        .collect()
                })
                .collect();
            let name = |m: usize| format!("SERVO_OUTPUT_RAW.servo{}_raw", outputs.channels[m]);
            let columns = crate::motors::align(&t, &rows, outputs.channels.len(), &time_s, &name)?;
            let c = &outputs.channels;
            Ok((
                columns,
                format!(
                    "SERVO_OUTPUT_RAW.servo{}_raw–servo{}_raw ({})",
                    c[0],
                    c[c.len() - 1],
                    outputs.origin
                ),
            ))
        });
        match read {
            Ok((columns, source)) => {
                info.motors = Some(source);
                Some(columns)
            }
            Err(why) => {
                warnings.push(why);
                None
            }
        }
    };
    Ok(Decoded::battery_log(
        chosen, altitude_m, throttle, motor_us, warnings, info,
    ))
}

/// The outputs of a telemetry log's motors ([`crate::motors`]): for ArduPilot the frame from
/// `FRAME_CLASS`, else the one its messages name, else the `HEARTBEAT`'s vehicle type, on the
/// outputs `SERVOn_FUNCTION` gives them when the log has those; for PX4 `CA_ROTOR_COUNT`, else
/// the vehicle type. `heartbeat` is the vehicle's (type, autopilot). `Err` is the warning.
fn motor_outputs(
    params: &HashMap<String, f64>,
    info: &LogInfo,
    heartbeat: Option<(u8, u8)>,
) -> Result<crate::motors::MotorOutputs, String> {
    let not_read = |why: String| format!("SERVO_OUTPUT_RAW not read as motor commands: {why}");
    match heartbeat {
        Some((t, 3)) => {
            let class = params
                .get("FRAME_CLASS")
                .and_then(|&c| Some((c, crate::dataflash::frame_class_name(c as u32)?.0)));
            let (frame, origin) = match (class, info.meta.frame.as_deref()) {
                (Some((c, name)), _) => (name.to_owned(), format!("FRAME_CLASS {c} ({name})")),
                (None, Some(f)) => (f.to_owned(), format!("frame {f} from the log's messages")),
                (None, None) => {
                    let frame = match t {
                        2 => "quad",
                        13 => "hexa",
                        14 => "octa",
                        _ => {
                            return Err(not_read(format!(
                                "no FRAME_CLASS, and the vehicle type (HEARTBEAT type {t}, {}) is not a quad-, hexa- or octorotor",
                                crate::ulog::mav_type_name(u32::from(t))
                            )));
                        }
                    };
                    (
                        frame.to_owned(),
                        format!(
                            "HEARTBEAT type {t}, {}",
                            crate::ulog::mav_type_name(u32::from(t))
                        ),
                    )
                }
            };
            crate::motors::ardupilot_outputs(params, &frame, &origin).map_err(not_read)
        }
        Some((t, 12)) => crate::motors::px4_outputs(params, Some((u32::from(t), "HEARTBEAT type")))
            .map_err(not_read),
        _ => Err(not_read(
            "the autopilot is neither ArduPilot nor PX4 (HEARTBEAT), so its motors are not known"
                .to_owned(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_checksum_is_mavlinks() {
        // CRC-16/MCRF4XX check value.
        assert_eq!(crc_x25(0xFFFF, b"123456789"), 0x6F91);
    }

    /// A MAVLink 2 packet from system 1 with its timestamp, its payload's trailing zeros cut
    /// as MAVLink 2 sends it.
    fn v2(time_us: u64, msg_id: u32, payload: &[u8]) -> Vec<u8> {
        let (extra, _) = known(msg_id).unwrap();
        let len = payload.iter().rposition(|&b| b != 0).map_or(1, |k| k + 1);
        let mut frame = vec![V2, len as u8, 0, 0, 0, 1, 1];
        frame.extend(&msg_id.to_le_bytes()[..3]);
        frame.extend(&payload[..len]);
        let crc = crc_x25(crc_x25(0xFFFF, &frame[1..]), &[extra]);
        frame.extend(crc.to_le_bytes());
        let mut out = time_us.to_be_bytes().to_vec();
        out.extend(frame);
        out
    }

    fn param_value(name: &str, value: f32) -> Vec<u8> {
        let mut p = value.to_le_bytes().to_vec();
        p.extend([0; 4]);
        let mut id = name.as_bytes().to_vec();
        id.resize(16, 0);
        p.extend(id);
        p.push(9);
        p
    }

    #[test]
    fn a_px4_telemetry_log_reads_its_battery_parameters() {
        let t0 = 1_700_000_000_000_000u64;
        let mut log = Vec::new();
        let mut heartbeat = vec![0u8; 9];
        heartbeat[4] = 2; // quadrotor
        heartbeat[5] = 12; // PX4
        log.extend(v2(t0, HEARTBEAT, &heartbeat));
        for (name, value) in [
            ("BAT1_N_CELLS", 4.0),
            ("BAT1_CAPACITY", 5000.0),
            ("BAT1_V_EMPTY", 3.5),
        ] {
            log.extend(v2(t0, PARAM_VALUE, &param_value(name, value)));
        }
        for k in 0..40u64 {
            let mut sys = vec![0u8; 31];
            sys[14..16].copy_from_slice(&(16_000u16 - 10 * k as u16).to_le_bytes());
            sys[16..18].copy_from_slice(&(if k < 5 { 30i16 } else { 1_200 }).to_le_bytes());
            sys[30] = 90;
            log.extend(v2(t0 + 1_000 + k * 500_000, SYS_STATUS, &sys));
        }
        // A corrupted packet in between is skipped and counted.
        let mut bad = v2(t0 + 30_000_000, SYS_STATUS, &[1; 31]);
        let n = bad.len();
        bad[n - 1] ^= 0xFF;
        log.extend(bad);
        let d = parse(&log, Path::new("px4.tlog")).unwrap();
        assert_eq!(d.samples.time_s.len(), 40);
        assert!((d.samples.time_s[39] - 19.5).abs() < 1e-9);
        assert_eq!(d.samples.voltage_v[1], 15.99);
        assert_eq!(d.samples.current_a.as_ref().unwrap()[10], 12.0);
        assert_eq!(d.info.meta.cells, Some(4));
        assert_eq!(d.info.meta.capacity_mah, Some(5000.0));
        assert_eq!(d.info.meta.cutoff_voltage_v, Some(14.0));
        assert_eq!(
            d.info.vehicle.unwrap().description,
            "PX4 quadrotor (HEARTBEAT type 2)"
        );
        assert!(
            d.warnings
                .iter()
                .any(|w| w.contains("1 packet(s) with a wrong checksum")),
            "{:?}",
            d.warnings
        );
    }

    /// MAVLink's `CRC_EXTRA` of a message from its definition: X.25 over `NAME `, then
    /// `type name ` of each base field in wire order (extensions left out), folded to a byte.
    fn crc_extra(name: &str, fields: &[(&str, &str)]) -> u8 {
        let mut crc = crc_x25(0xFFFF, format!("{name} ").as_bytes());
        for (ty, field) in fields {
            crc = crc_x25(crc, format!("{ty} {field} ").as_bytes());
        }
        ((crc & 0xFF) ^ (crc >> 8)) as u8
    }

    #[test]
    fn servo_output_raw_has_the_crc_extra_of_its_definition() {
        // common.xml: time_usec uint32, servo1_raw…servo8_raw uint16, port uint8 (sorted by
        // size on the wire), then the extension servo9_raw…servo16_raw.
        let servos: Vec<String> = (1..=8).map(|k| format!("servo{k}_raw")).collect();
        let mut fields = vec![("uint32_t", "time_usec")];
        fields.extend(servos.iter().map(|s| ("uint16_t", s.as_str())));
        fields.push(("uint8_t", "port"));
        assert_eq!(crc_extra("SERVO_OUTPUT_RAW", &fields), 222);
        assert_eq!(known(SERVO_OUTPUT_RAW), Some((222, 21)));
        // The derivation, checked on a message read before: VFR_HUD's 20.
        let vfr = [
            ("float", "airspeed"),
            ("float", "groundspeed"),
            ("float", "alt"),
            ("float", "climb"),
            ("int16_t", "heading"),
            ("uint16_t", "throttle"),
        ];
        assert_eq!(
            Some(crc_extra("VFR_HUD", &vfr)),
            known(VFR_HUD).map(|k| k.0)
        );
    }

    /// A SERVO_OUTPUT_RAW payload: `servo` µs on outputs 1…, port 0.
    fn servo_output_raw(servo: &[u16]) -> Vec<u8> {
        let mut p = vec![0u8; 37];
        for (k, &v) in servo.iter().enumerate() {
            let at = if k < 8 { 4 + 2 * k } else { 21 + 2 * (k - 8) };
            p[at..at + 2].copy_from_slice(&v.to_le_bytes());
        }
        p
    }

    /// An ArduCopter telemetry log: its HEARTBEAT, parameters, then SYS_STATUS and
    /// SERVO_OUTPUT_RAW at 2 Hz, the outputs of each from `servo(k)`.
    fn ardupilot_tlog(params: &[(&str, f32)], servo: impl Fn(u64) -> Vec<u16>) -> Vec<u8> {
        let t0 = 1_700_000_000_000_000u64;
        let mut log = Vec::new();
        let mut heartbeat = vec![0u8; 9];
        heartbeat[4] = 2; // quadrotor
        heartbeat[5] = 3; // ArduPilot
        log.extend(v2(t0, HEARTBEAT, &heartbeat));
        for &(name, value) in params {
            log.extend(v2(t0, PARAM_VALUE, &param_value(name, value)));
        }
        for k in 0..20u64 {
            let mut sys = vec![0u8; 31];
            sys[14..16].copy_from_slice(&16_000u16.to_le_bytes());
            sys[16..18].copy_from_slice(&1_000i16.to_le_bytes());
            log.extend(v2(t0 + k * 500_000, SYS_STATUS, &sys));
            log.extend(v2(
                t0 + k * 500_000 + 250_000,
                SERVO_OUTPUT_RAW,
                &servo_output_raw(&servo(k)),
            ));
        }
        log
    }

    #[test]
    fn servo_outputs_of_the_frames_motors_on_their_outputs() {
        // A hexa whose motors SERVOn_FUNCTION puts on outputs 3–8: 1100 + 10·k + output.
        let mut params = vec![("FRAME_CLASS", 2.0), ("SERVO1_FUNCTION", 4.0)];
        let names: Vec<String> = (3..=8).map(|n| format!("SERVO{n}_FUNCTION")).collect();
        for (m, n) in names.iter().enumerate() {
            params.push((n.as_str(), 33.0 + m as f32));
        }
        let log = ardupilot_tlog(&params, |k| {
            (1..=10).map(|c| 1100 + 10 * k as u16 + c).collect()
        });
        let d = parse(&log, Path::new("hexa.tlog")).unwrap();
        let m = d.samples.motor_us.as_ref().unwrap();
        assert_eq!(m.len(), 6);
        // Sample 2 at 1.0 s sits halfway between the packets of k = 1 and 2.
        assert_eq!(m[0][2], 1100.0 + 15.0 + 3.0);
        assert_eq!(m[5][2], 1100.0 + 15.0 + 8.0);
        // Before the first packet: its value held.
        assert_eq!(m[0][0], 1103.0);
        assert_eq!(
            d.info.motors.as_deref(),
            Some(
                "SERVO_OUTPUT_RAW.servo3_raw–servo8_raw (FRAME_CLASS 2 (hexa); outputs from SERVOn_FUNCTION)"
            )
        );
        // A disarmed 0 among the motors' outputs: not PWM, not read, and said so.
        let log = ardupilot_tlog(&[("FRAME_CLASS", 1.0)], |k| {
            vec![if k == 5 { 0 } else { 1500 }; 4]
        });
        let d = parse(&log, Path::new("quad.tlog")).unwrap();
        assert!(d.samples.motor_us.is_none());
        assert!(
            d.warnings
                .iter()
                .any(|w| w.starts_with("SERVO_OUTPUT_RAW.servo1_raw reads 0 at 2.750 s")),
            "{:?}",
            d.warnings
        );
        // A helicopter's outputs are not motors.
        let log = ardupilot_tlog(&[("FRAME_CLASS", 6.0)], |_| vec![1500; 8]);
        let d = parse(&log, Path::new("heli.tlog")).unwrap();
        assert!(d.samples.motor_us.is_none());
        assert!(
            d.warnings.iter().any(|w| w.contains("the frame \"heli\"")),
            "{:?}",
            d.warnings
        );
        // Without FRAME_CLASS, the HEARTBEAT's quadrotor: outputs 1–4.
        let log = ardupilot_tlog(&[], |_| vec![1234; 8]);
        let d = parse(&log, Path::new("q.tlog")).unwrap();
        assert_eq!(d.samples.motor_us.unwrap(), vec![vec![1234.0; 20]; 4]);
    }

    #[test]
    fn rejects_what_is_not_a_tlog() {
        let e = Tlog::parse(b"\xA3\x95\x80", Path::new("x.tlog")).unwrap_err();
        assert!(e.to_string().contains("not a MAVLink telemetry log"), "{e}");
        assert!(!looks_like_tlog(&[0; 9]));
    }
}
