//! Writers of small, valid ULog and DataFlash files for the tests, following the formats'
//! documentation (PX4 "ULog File Format"; ArduPilot `AP_Logger/LogStructure.h`), and a flight
//! profile to fill them with.

#![allow(dead_code)]

/// ULog file writer.
pub struct UlogWriter {
    buf: Vec<u8>,
}

impl UlogWriter {
    /// A file with its 16-byte header.
    pub fn new(start_us: u64) -> Self {
        let mut buf = vec![0x55, 0x4C, 0x6F, 0x67, 0x01, 0x12, 0x35, 1];
        buf.extend_from_slice(&start_us.to_le_bytes());
        Self { buf }
    }

    /// Current length, bytes.
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    /// Any message.
    pub fn message(&mut self, kind: u8, payload: &[u8]) {
        let size = u16::try_from(payload.len()).expect("payload fits a ULog message");
        self.buf.extend_from_slice(&size.to_le_bytes());
        self.buf.push(kind);
        self.buf.extend_from_slice(payload);
    }

    /// `B`: flag bits.
    pub fn flag_bits(&mut self, incompat: [u8; 8], appended: [u64; 3]) {
        let mut p = vec![0u8; 8];
        p.extend_from_slice(&incompat);
        for a in appended {
            p.extend_from_slice(&a.to_le_bytes());
        }
        self.message(b'B', &p);
    }

    /// `F`: a format definition.
    pub fn format(&mut self, text: &str) {
        self.message(b'F', text.as_bytes());
    }

    /// `I`: an info string.
    pub fn info(&mut self, key: &str, value: &str) {
        let key = format!("char[{}] {key}", value.len());
        let mut p = vec![u8::try_from(key.len()).unwrap()];
        p.extend_from_slice(key.as_bytes());
        p.extend_from_slice(value.as_bytes());
        self.message(b'I', &p);
    }

    /// `A`: subscribe `msg_id` to a topic instance.
    pub fn subscribe(&mut self, multi_id: u8, msg_id: u16, name: &str) {
        let mut p = vec![multi_id];
        p.extend_from_slice(&msg_id.to_le_bytes());
        p.extend_from_slice(name.as_bytes());
        self.message(b'A', &p);
    }

    /// `D`: data.
    pub fn data(&mut self, msg_id: u16, payload: &[u8]) {
        let mut p = msg_id.to_le_bytes().to_vec();
        p.extend_from_slice(payload);
        self.message(b'D', &p);
    }

    /// `L`: a logged string.
    pub fn logging(&mut self, timestamp_us: u64, text: &str) {
        let mut p = vec![b'6'];
        p.extend_from_slice(&timestamp_us.to_le_bytes());
        p.extend_from_slice(text.as_bytes());
        self.message(b'L', &p);
    }

    /// `O`: a dropout.
    pub fn dropout(&mut self, ms: u16) {
        self.message(b'O', &ms.to_le_bytes());
    }

    /// Raw bytes (to cut a message or insert garbage).
    pub fn raw(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The file.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// Formats of the PX4 topics the reader uses (trimmed to a few fields, with a nested type, an
/// array and padding so that field offsets are exercised).
pub const ULOG_FORMATS: [&str; 4] = [
    "battery_status:uint64_t timestamp;float voltage_v;float[4] voltage_cell_v;float current_a;uint8_t cell_count;bool connected;uint8_t[2] _padding0;",
    "pos_sub:uint64_t t;int16_t[3] v;",
    "vehicle_local_position:uint64_t timestamp;pos_sub[2] sub;float z;float vz;bool z_valid;uint8_t[3] _padding0;",
    "vehicle_land_detected:uint64_t timestamp;bool landed;bool maybe_landed;uint8_t[6] _padding0;",
];

/// A `battery_status` payload.
pub fn battery_status(timestamp_us: u64, voltage_v: f32, current_a: f32) -> Vec<u8> {
    let mut p = timestamp_us.to_le_bytes().to_vec();
    p.extend_from_slice(&voltage_v.to_le_bytes());
    for _ in 0..4 {
        p.extend_from_slice(&(voltage_v / 4.0).to_le_bytes());
    }
    p.extend_from_slice(&current_a.to_le_bytes());
    p.extend_from_slice(&[4, 1, 0, 0]);
    p
}

/// A `vehicle_local_position` payload (NED `z`).
pub fn local_position(timestamp_us: u64, z: f32, vz: f32, valid: bool) -> Vec<u8> {
    let mut p = timestamp_us.to_le_bytes().to_vec();
    p.extend_from_slice(&[0xEE; 28]); // pos_sub[2]: 2 × (8 + 3 × 2) bytes
    p.extend_from_slice(&z.to_le_bytes());
    p.extend_from_slice(&vz.to_le_bytes());
    p.push(u8::from(valid));
    p.extend_from_slice(&[0; 3]);
    p
}

/// A `vehicle_land_detected` payload.
pub fn land_detected(timestamp_us: u64, landed: bool) -> Vec<u8> {
    let mut p = timestamp_us.to_le_bytes().to_vec();
    p.push(u8::from(landed));
    p.push(u8::from(landed));
    p.extend_from_slice(&[0; 6]);
    p
}

/// DataFlash writer.
pub struct DataFlashWriter {
    buf: Vec<u8>,
    formats: Vec<(u8, String)>,
}

impl DataFlashWriter {
    /// A log that starts, as ArduPilot's do, with the FMT message defining FMT.
    pub fn new() -> Self {
        let mut w = Self {
            buf: Vec::new(),
            formats: Vec::new(),
        };
        w.define(0x80, "FMT", "BBnNZ", "Type,Length,Name,Format,Labels");
        w
    }

    /// Current length, bytes.
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    /// Size of one format character.
    fn size(c: char) -> usize {
        match c {
            'b' | 'B' | 'M' => 1,
            'h' | 'H' | 'c' | 'C' => 2,
            'i' | 'I' | 'f' | 'e' | 'E' | 'L' | 'n' => 4,
            'd' | 'q' | 'Q' => 8,
            'N' => 16,
            'a' | 'Z' => 64,
            _ => panic!("unknown format character {c}"),
        }
    }

    /// A FMT message defining `msg_type` with the length its format takes.
    pub fn define(&mut self, msg_type: u8, name: &str, format: &str, labels: &str) {
        let length = 3 + format.chars().map(Self::size).sum::<usize>();
        self.define_with_length(
            msg_type,
            u8::try_from(length).unwrap(),
            name,
            format,
            labels,
        );
        self.formats.push((msg_type, format.to_owned()));
    }

    /// A FMT message with an explicit (possibly wrong) length.
    pub fn define_with_length(
        &mut self,
        msg_type: u8,
        length: u8,
        name: &str,
        format: &str,
        labels: &str,
    ) {
        let mut p = [0u8; 86];
        p[0] = msg_type;
        p[1] = length;
        p[2..2 + name.len()].copy_from_slice(name.as_bytes());
        p[6..6 + format.len()].copy_from_slice(format.as_bytes());
        p[22..22 + labels.len()].copy_from_slice(labels.as_bytes());
        self.buf.extend_from_slice(&[0xA3, 0x95, 0x80]);
        self.buf.extend_from_slice(&p);
    }

    /// A message of a defined type; numeric fields from `values` in order (text fields are
    /// written empty and take no value).
    pub fn write(&mut self, msg_type: u8, values: &[f64]) {
        let format = self
            .formats
            .iter()
            .find(|(t, _)| *t == msg_type)
            .map(|(_, f)| f.clone())
            .expect("type defined");
        self.buf.extend_from_slice(&[0xA3, 0x95, msg_type]);
        let mut vals = values.iter().copied();
        for c in format.chars() {
            let mut next = || vals.next().expect("a value per numeric field");
            match c {
                'b' => self.buf.push(next() as i8 as u8),
                'B' | 'M' => self.buf.push(next() as u8),
                'h' => self.buf.extend_from_slice(&(next() as i16).to_le_bytes()),
                'H' => self.buf.extend_from_slice(&(next() as u16).to_le_bytes()),
                'i' => self.buf.extend_from_slice(&(next() as i32).to_le_bytes()),
                'I' => self.buf.extend_from_slice(&(next() as u32).to_le_bytes()),
                'f' => self.buf.extend_from_slice(&(next() as f32).to_le_bytes()),
                'd' => self.buf.extend_from_slice(&next().to_le_bytes()),
                'q' => self.buf.extend_from_slice(&(next() as i64).to_le_bytes()),
                'Q' => self.buf.extend_from_slice(&(next() as u64).to_le_bytes()),
                'c' => self
                    .buf
                    .extend_from_slice(&((next() * 100.0).round() as i16).to_le_bytes()),
                'C' => self
                    .buf
                    .extend_from_slice(&((next() * 100.0).round() as u16).to_le_bytes()),
                'e' => self
                    .buf
                    .extend_from_slice(&((next() * 100.0).round() as i32).to_le_bytes()),
                'E' => self
                    .buf
                    .extend_from_slice(&((next() * 100.0).round() as u32).to_le_bytes()),
                'L' => self
                    .buf
                    .extend_from_slice(&((next() * 1e7).round() as i32).to_le_bytes()),
                other => self.buf.extend(std::iter::repeat_n(0u8, Self::size(other))),
            }
        }
    }

    /// Raw bytes (garbage, a cut message).
    pub fn raw(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The file.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// A flight with a ceiling attachment, sampled at time `t` (s): `(altitude_m, current_a,
/// landed)`. Ground 5 s, climb 2 s at 1 m/s, hover 10 s at 2 m, climb 1 s to 2.5 m, attached
/// 20 s (motors off), descend 5 s, ground 5 s: 48 s.
pub fn profile(t: f64) -> (f64, f64, bool) {
    match t {
        t if t < 5.0 => (0.0, 0.3, true),
        t if t < 7.0 => (t - 5.0, 10.0, false),
        t if t < 17.0 => (2.0, 9.0, false),
        t if t < 18.0 => (2.0 + 0.5 * (t - 17.0), 9.5, false),
        t if t < 38.0 => (2.5, 0.35, false),
        t if t < 43.0 => (2.5 - 0.5 * (t - 38.0), 8.5, false),
        _ => (0.0, 0.3, true),
    }
}

/// Length of [`profile`], s.
pub const PROFILE_S: f64 = 48.0;

/// A battery voltage that sags under load and falls with time.
pub fn voltage(t: f64, current_a: f64) -> f64 {
    12.6 - 0.02 * t - 0.05 * current_a
}

/// A file of `tests/data/` (real logs kept with their licences).
pub fn data(rel: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

/// Charge drawn between a flight's first and last sample, mAh (trapezoids).
pub fn charge_mah(f: &flightlog::Flight) -> f64 {
    let (t, i) = (&f.samples.time_s, f.samples.current_a.as_ref().unwrap());
    (1..t.len())
        .map(|k| 0.5 * (i[k] + i[k - 1]) * (t[k] - t[k - 1]))
        .sum::<f64>()
        / 3.6
}
