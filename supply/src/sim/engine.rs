//! The simulated instrument's command interpreters: bytes in, replies out.

use std::time::{Duration, Instant};

use super::{Device, Dialect, Inner, LOG_LEN, Settings};
use crate::parse;
use crate::supply::RegulationMode;

/// Longest command kept before the buffer is thrown away as garbage.
const MAX_COMMAND: usize = 512;
/// What a corrupted reply looks like.
const GARBAGE: &[u8] = b"?#!%&";

const SCPI_IDENTITY: &str = "RIGOL TECHNOLOGIES,DP832,DP8SIM00001,00.01.16";
const KORAD_IDENTITY: &str = "KORAD KA3005P V5.8 SN:00000001";

/// A connection's interpreter state (framing and pacing) in front of a shared [`Device`].
pub(crate) struct Engine {
    device: Device,
    buf: Vec<u8>,
    /// Arrival time of each byte in `buf`.
    times: Vec<Instant>,
    /// End of the previous exchange: its last byte received, or its reply sent.
    last_exchange: Option<Instant>,
}

/// How the Korad buffer starts.
enum Frame {
    /// A whole command of this length.
    Complete(usize),
    /// The start of a command; wait for more bytes or a quiet gap.
    NeedMore,
    /// Not the start of any command: drop this many bytes.
    Garbage(usize),
}

const KORAD_FIXED: [&[u8]; 14] = [
    b"*IDN?", b"STATUS?", b"VOUT1?", b"IOUT1?", b"VSET1?", b"ISET1?", b"OUT1", b"OUT0", b"BEEP1",
    b"BEEP0", b"OCP1", b"OCP0", b"OVP1", b"OVP0",
];
const KORAD_SETTERS: [&[u8]; 2] = [b"VSET1:", b"ISET1:"];

fn korad_frame(buf: &[u8]) -> Frame {
    let mut maybe = false;
    for token in KORAD_FIXED {
        if buf.starts_with(token) {
            return Frame::Complete(token.len());
        }
        maybe |= token.starts_with(buf);
    }
    for prefix in KORAD_SETTERS {
        if let Some(rest) = buf.strip_prefix(prefix) {
            let digits = rest
                .iter()
                .take_while(|b| b.is_ascii_digit() || **b == b'.')
                .count();
            return if digits < rest.len() {
                Frame::Complete(prefix.len() + digits)
            } else {
                Frame::NeedMore
            };
        }
        maybe |= prefix.starts_with(buf);
    }
    if maybe {
        Frame::NeedMore
    } else {
        Frame::Garbage(1)
    }
}

fn fmt_korad_v(v: f64) -> Vec<u8> {
    format!("{:05.2}", v.clamp(0.0, 99.99)).into_bytes()
}

fn fmt_korad_i(i: f64) -> Vec<u8> {
    format!("{:.3}", i.clamp(0.0, 9.999)).into_bytes()
}

impl Engine {
    pub(crate) fn new(device: Device) -> Self {
        Self {
            device,
            buf: Vec::new(),
            times: Vec::new(),
            last_exchange: None,
        }
    }

    pub(crate) fn device(&self) -> &Device {
        &self.device
    }

    /// Takes received bytes; returns the replies to send now.
    pub(crate) fn feed(&mut self, bytes: &[u8], now: Instant) -> Vec<u8> {
        self.buf.extend_from_slice(bytes);
        self.times.extend(std::iter::repeat_n(now, bytes.len()));
        let mut out = Vec::new();
        match self.device.dialect {
            Dialect::Scpi => self.scpi_lines(now, &mut out),
            Dialect::Korad => self.korad_frames(now, false, &mut out),
        }
        if self.buf.len() > MAX_COMMAND {
            self.discard(self.buf.len());
            self.device.lock().stats.unknown += 1;
        }
        out
    }

    /// Completes a Korad set command that has been quiet for the frame gap; returns replies.
    pub(crate) fn tick(&mut self, now: Instant) -> Vec<u8> {
        let gap = self.device.config.frame_gap;
        match self.times.last() {
            Some(&t) if now.duration_since(t) >= gap => self.flush(now),
            _ => Vec::new(),
        }
    }

    /// How long until [`Engine::tick`] may have work, if anything is buffered.
    pub(crate) fn tick_due(&self, now: Instant) -> Option<Duration> {
        let t = *self.times.last()?;
        let due = t.checked_add(self.device.config.frame_gap)?;
        Some(due.saturating_duration_since(now))
    }

    /// Treats whatever is buffered as complete (the sender has gone quiet); returns replies.
    pub(crate) fn flush(&mut self, now: Instant) -> Vec<u8> {
        let mut out = Vec::new();
        if self.device.dialect == Dialect::Korad {
            self.korad_frames(now, true, &mut out);
        }
        if !self.buf.is_empty() {
            // An SCPI line without its newline, or a Korad fragment: not a command.
            self.discard(self.buf.len());
            self.device.lock().stats.unknown += 1;
        }
        out
    }

    fn discard(&mut self, n: usize) -> (Vec<u8>, Instant, Instant) {
        let cmd: Vec<u8> = self.buf.drain(..n).collect();
        let times: Vec<Instant> = self.times.drain(..n).collect();
        let first = times.first().copied().unwrap_or_else(Instant::now);
        let last = times.last().copied().unwrap_or(first);
        (cmd, first, last)
    }

    fn scpi_lines(&mut self, now: Instant, out: &mut Vec<u8>) {
        while let Some(pos) = self.buf.iter().position(|&b| b == b'\n') {
            let (line, first, last) = self.discard(pos + 1);
            let line = &line[..pos];
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            let device = self.device.clone();
            let mut inner = device.lock();
            for cmd in line.split(|&b| b == b';') {
                let cmd = cmd.trim_ascii();
                if cmd.is_empty() {
                    continue;
                }
                if let Some(mut reply) =
                    self.handle(&mut inner, cmd, first, last, now, Self::scpi_execute)
                {
                    reply.push(b'\n');
                    out.extend_from_slice(&reply);
                }
            }
        }
    }

    fn korad_frames(&mut self, now: Instant, quiet: bool, out: &mut Vec<u8>) {
        while !self.buf.is_empty() {
            let n = match korad_frame(&self.buf) {
                Frame::Complete(n) => n,
                Frame::NeedMore if quiet => {
                    if KORAD_SETTERS.iter().any(|p| self.buf.starts_with(p)) {
                        self.buf.len()
                    } else {
                        // A fragment that went quiet before it became a command.
                        self.discard(self.buf.len());
                        self.device.lock().stats.unknown += 1;
                        return;
                    }
                }
                Frame::NeedMore => return,
                Frame::Garbage(n) => {
                    self.discard(n);
                    // Count one unknown per run of garbage bytes.
                    if !matches!(korad_frame(&self.buf), Frame::Garbage(_)) || self.buf.is_empty() {
                        self.device.lock().stats.unknown += 1;
                    }
                    continue;
                }
            };
            let (cmd, first, last) = self.discard(n);
            let device = self.device.clone();
            let mut inner = device.lock();
            if let Some(reply) =
                self.handle(&mut inner, &cmd, first, last, now, Self::korad_execute)
            {
                out.extend_from_slice(&reply);
            }
        }
    }

    /// Pacing, faults, logging and counting around one command.
    fn handle(
        &mut self,
        inner: &mut Inner,
        cmd: &[u8],
        first: Instant,
        last: Instant,
        now: Instant,
        execute: fn(&Device, &mut Inner, &[u8]) -> Option<Vec<u8>>,
    ) -> Option<Vec<u8>> {
        if inner.faults.silent {
            inner.stats.ignored += 1;
            return None;
        }
        let previous = self.last_exchange.replace(last);
        if self.device.dialect == Dialect::Korad {
            if let Some(prev) = previous {
                let gap = first.saturating_duration_since(prev);
                let min = &mut inner.stats.min_command_gap;
                *min = Some(min.map_or(gap, |m| m.min(gap)));
                if gap < self.device.config.min_command_gap {
                    inner.stats.pacing_violations += 1;
                    if self.device.config.strict_pacing {
                        inner.stats.ignored += 1;
                        push_log(
                            inner,
                            format!(
                                "(dropped, {gap:?} after the previous exchange) {}",
                                cmd.escape_ascii()
                            ),
                        );
                        return None;
                    }
                }
            }
        }
        if inner.faults.ignore_commands > 0 {
            inner.faults.ignore_commands -= 1;
            inner.stats.ignored += 1;
            return None;
        }
        push_log(inner, cmd.escape_ascii().to_string());
        inner.stats.commands += 1;
        let reply = execute(&self.device, inner, cmd)?;
        if inner.faults.drop_replies > 0 {
            inner.faults.drop_replies -= 1;
            inner.stats.faulted_replies += 1;
            return None;
        }
        self.last_exchange = Some(now.max(last));
        inner.stats.replies += 1;
        if inner.faults.corrupt_replies > 0 {
            inner.faults.corrupt_replies -= 1;
            inner.stats.faulted_replies += 1;
            return Some(GARBAGE.to_vec());
        }
        Some(reply)
    }

    fn korad_execute(device: &Device, inner: &mut Inner, cmd: &[u8]) -> Option<Vec<u8>> {
        let cfg = &device.config;
        match cmd {
            b"*IDN?" => Some(
                cfg.identity
                    .as_deref()
                    .unwrap_or(KORAD_IDENTITY)
                    .as_bytes()
                    .to_vec(),
            ),
            b"STATUS?" => {
                let out = super::solve(&inner.settings, inner.load.as_mut());
                let mut status = parse::KoradStatus::BEEP;
                if out.mode != RegulationMode::ConstantCurrent {
                    status |= parse::KoradStatus::CH1_CV;
                }
                if inner.settings.output_on {
                    status |= parse::KoradStatus::OUTPUT_ON;
                }
                Some(vec![status])
            }
            b"VOUT1?" => {
                let out = super::solve(&inner.settings, inner.load.as_mut());
                Some(fmt_korad_v(out.voltage_v))
            }
            b"IOUT1?" => {
                let out = super::solve(&inner.settings, inner.load.as_mut());
                Some(fmt_korad_i(out.current_a))
            }
            b"VSET1?" => Some(fmt_korad_v(inner.settings.voltage_v)),
            b"ISET1?" => Some(fmt_korad_i(inner.settings.current_limit_a)),
            b"OUT1" => {
                inner.settings.output_on = true;
                None
            }
            b"OUT0" => {
                inner.settings.output_on = false;
                None
            }
            // Beeper, over-current and over-voltage protection: accepted, no effect.
            b"BEEP1" | b"BEEP0" | b"OCP1" | b"OCP0" | b"OVP1" | b"OVP0" => None,
            _ => {
                if let Some(v) = cmd.strip_prefix(b"VSET1:") {
                    match parse::number(v) {
                        Ok(v) if (0.0..=cfg.rating_voltage_v).contains(&v) => {
                            inner.settings.voltage_v = v;
                        }
                        _ => inner.stats.unknown += 1,
                    }
                } else if let Some(i) = cmd.strip_prefix(b"ISET1:") {
                    match parse::number(i) {
                        Ok(i) if (0.0..=cfg.rating_current_a).contains(&i) => {
                            inner.settings.current_limit_a = i;
                        }
                        _ => inner.stats.unknown += 1,
                    }
                } else {
                    inner.stats.unknown += 1;
                }
                None
            }
        }
    }

    fn scpi_execute(device: &Device, inner: &mut Inner, cmd: &[u8]) -> Option<Vec<u8>> {
        let cfg = &device.config;
        let text = String::from_utf8_lossy(cmd);
        let (header, args) = match text.split_once(char::is_whitespace) {
            Some((h, a)) => (h, a),
            None => (text.as_ref(), ""),
        };
        let header = scpi_normalise(header);
        let args: Vec<String> = args
            .split(',')
            .map(|a| a.trim().to_ascii_uppercase())
            .filter(|a| !a.is_empty())
            .collect();
        let error = |inner: &mut Inner, e: &str| {
            if inner.scpi_errors.len() < 16 {
                inner.scpi_errors.push_back(e.to_owned());
            }
            inner.stats.unknown += 1;
        };
        const BAD_CHANNEL: &str = "-114,\"Header suffix out of range\"";
        const BAD_VALUE: &str = "-224,\"Illegal parameter value\"";
        // Channel argument: "CH1" (the only channel), optional where it can be.
        let (channel_ok, rest): (bool, &[String]) = match args.split_first() {
            Some((first, rest)) if first.starts_with("CH") => (first == "CH1", rest),
            _ => (true, &args[..]),
        };
        let output = |inner: &mut Inner| super::solve(&inner.settings, inner.load.as_mut());
        let reply: Option<String> = match header.as_str() {
            "*IDN?" => Some(cfg.identity.clone().unwrap_or_else(|| SCPI_IDENTITY.into())),
            "*OPC?" => Some("1".into()),
            "*RST" => {
                inner.settings = Settings {
                    source_resistance_ohm: inner.settings.source_resistance_ohm,
                    ..cfg.initial
                };
                None
            }
            "SYST:ERR?" => Some(
                inner
                    .scpi_errors
                    .pop_front()
                    .unwrap_or_else(|| "0,\"No error\"".into()),
            ),
            _ if !channel_ok => {
                error(inner, BAD_CHANNEL);
                None
            }
            "APPL" => {
                let v = rest.first().map(|v| parse::number(v.as_bytes()));
                let i = rest.get(1).map(|i| parse::number(i.as_bytes()));
                match (v, i) {
                    (Some(Ok(v)), i)
                        if (0.0..=cfg.rating_voltage_v).contains(&v)
                            && rest.len() <= 2
                            && i.is_none_or(|i| {
                                i.is_ok_and(|i| (0.0..=cfg.rating_current_a).contains(&i))
                            }) =>
                    {
                        inner.settings.voltage_v = v;
                        if let Some(Ok(i)) = i {
                            inner.settings.current_limit_a = i;
                        }
                    }
                    _ => error(inner, BAD_VALUE),
                }
                None
            }
            "APPL?" => Some(format!(
                "CH1:{}V/{}A,{:.3},{:.3}",
                cfg.rating_voltage_v,
                cfg.rating_current_a,
                inner.settings.voltage_v,
                inner.settings.current_limit_a
            )),
            "OUTP" | "OUTP:STAT" => {
                match rest {
                    [s] if s == "ON" || s == "1" => inner.settings.output_on = true,
                    [s] if s == "OFF" || s == "0" => inner.settings.output_on = false,
                    _ => error(inner, BAD_VALUE),
                }
                None
            }
            "OUTP?" | "OUTP:STAT?" => Some(
                if inner.settings.output_on {
                    "ON"
                } else {
                    "OFF"
                }
                .into(),
            ),
            "OUTP:MODE?" => Some(
                match output(inner).mode {
                    RegulationMode::ConstantVoltage => "CV",
                    RegulationMode::ConstantCurrent => "CC",
                    RegulationMode::Unregulated | RegulationMode::Off => "UR",
                }
                .into(),
            ),
            "MEAS:ALL?" => {
                let o = output(inner);
                Some(format!(
                    "{:.3},{:.3},{:.3}",
                    o.voltage_v,
                    o.current_a,
                    o.voltage_v * o.current_a
                ))
            }
            "MEAS?" | "MEAS:VOLT?" => Some(format!("{:.3}", output(inner).voltage_v)),
            "MEAS:CURR?" => Some(format!("{:.3}", output(inner).current_a)),
            "MEAS:POWE?" => {
                let o = output(inner);
                Some(format!("{:.3}", o.voltage_v * o.current_a))
            }
            _ => {
                error(inner, "-113,\"Undefined header\"");
                None
            }
        };
        reply.map(String::into_bytes)
    }
}

fn push_log(inner: &mut Inner, entry: String) {
    if inner.log.len() == LOG_LEN {
        inner.log.pop_front();
    }
    inner.log.push_back(entry);
}

/// Upper case, no leading colon, every node in its short form (`:OUTPut:STATe?` →
/// `OUTP:STAT?`).
fn scpi_normalise(header: &str) -> String {
    let upper = header.trim().trim_start_matches(':').to_ascii_uppercase();
    let (body, query) = match upper.strip_suffix('?') {
        Some(b) => (b, "?"),
        None => (upper.as_str(), ""),
    };
    let nodes: Vec<&str> = body
        .split(':')
        .map(|n| match n {
            "APPLY" => "APPL",
            "OUTPUT" => "OUTP",
            "MEASURE" => "MEAS",
            "VOLTAGE" => "VOLT",
            "CURRENT" => "CURR",
            "POWER" => "POWE",
            "STATE" => "STAT",
            "SYSTEM" => "SYST",
            "ERROR" => "ERR",
            other => other,
        })
        .collect();
    format!("{}{query}", nodes.join(":"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{ResistiveLoad, SimConfig};

    fn engine(dialect: Dialect) -> Engine {
        let config = SimConfig {
            min_command_gap: Duration::from_millis(40),
            ..SimConfig::default()
        };
        Engine::new(Device::new(
            dialect,
            ResistiveLoad {
                resistance_ohm: 10.0,
            },
            config,
        ))
    }

    #[test]
    fn scpi_headers_normalise() {
        assert_eq!(scpi_normalise(":OUTPut:STATe?"), "OUTP:STAT?");
        assert_eq!(scpi_normalise("meas:all?"), "MEAS:ALL?");
        assert_eq!(scpi_normalise("*idn?"), "*IDN?");
    }

    #[test]
    fn scpi_session() {
        let mut e = engine(Dialect::Scpi);
        let t = Instant::now();
        assert!(e.feed(b":APPL CH1,12.5,5\n:OUTP CH1,ON\n", t).is_empty());
        assert_eq!(e.feed(b":MEAS:ALL? CH1\r\n", t), b"12.500,1.250,15.625\n");
        assert_eq!(
            e.feed(b":OUTP:MODE? CH1\n:APPL? CH1\n", t),
            b"CV\nCH1:30V/5A,12.500,5.000\n"
        );
        assert!(e.feed(b":APPL CH2,1,1\n", t).is_empty());
        assert_eq!(
            e.feed(b":SYST:ERR?\n", t),
            b"-114,\"Header suffix out of range\"\n"
        );
        assert_eq!(e.feed(b":SYST:ERR?\n", t), b"0,\"No error\"\n");
        assert_eq!(e.device().settings().voltage_v, 12.5);
    }

    #[test]
    fn korad_framing_and_pacing() {
        let mut e = engine(Dialect::Korad);
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        // A set command waits for the quiet gap, then counts from its last byte.
        assert!(e.feed(b"VSET1:12.00", ms(0)).is_empty());
        assert!(e.tick(ms(5)).is_empty());
        assert_eq!(e.device().settings().voltage_v, 0.0);
        assert!(e.tick(ms(10)).is_empty());
        assert_eq!(e.device().settings().voltage_v, 12.0);
        assert!(e.feed(b"OUT1", ms(50)).is_empty());
        // 12 V into 10 Ω wants 1.2 A; the 1 A power-up limit holds it at 10 V, CC.
        assert_eq!(e.feed(b"VOUT1?", ms(100)), b"10.00");
        assert_eq!(e.feed(b"STATUS?", ms(150)), [0x50]);
        // Too soon: dropped and counted.
        assert!(e.feed(b"IOUT1?", ms(160)).is_empty());
        let s = e.device().stats();
        assert_eq!(s.pacing_violations, 1);
        assert_eq!(s.min_command_gap, Some(Duration::from_millis(10)));
        // Garbage is skipped; a command behind it still runs.
        assert_eq!(e.feed(b"xyzIOUT1?", ms(300)), b"1.000");
        assert_eq!(e.device().stats().unknown, 1);
        // A fragment that goes quiet is discarded, not executed.
        assert!(e.feed(b"VOU", ms(400)).is_empty());
        assert!(e.tick(ms(420)).is_empty());
        assert_eq!(e.device().stats().unknown, 2);
        assert!(!e.device().command_log().iter().any(|c| c == "VOU"));
    }
}
