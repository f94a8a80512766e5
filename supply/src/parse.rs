//! Reply parsers of both dialects. They take arbitrary bytes and never panic (property-tested
//! and fuzzed); they are public so that tools and fuzzers can call them.

use crate::error::ReplyError;
use crate::supply::{Measurement, RegulationMode};

/// `bytes` without leading and trailing ASCII whitespace and NULs.
fn trim(bytes: &[u8]) -> &[u8] {
    let junk = |b: &u8| b.is_ascii_whitespace() || *b == 0;
    let start = bytes.iter().position(|b| !junk(b)).unwrap_or(bytes.len());
    let end = bytes
        .iter()
        .rposition(|b| !junk(b))
        .map_or(start, |e| e + 1);
    &bytes[start..end]
}

/// A decimal number such as `12.50`, `-0.001` or `1.5E+01`, surrounded by optional whitespace.
/// Refuses anything else, including `inf`, `nan` and values that overflow.
pub fn number(bytes: &[u8]) -> Result<f64, ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    if t.len() > 32
        || !t.iter().any(u8::is_ascii_digit)
        || !t
            .iter()
            .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'+' | b'-' | b'e' | b'E'))
    {
        return Err(ReplyError::NotANumber);
    }
    // Only ASCII bytes remain, so this is valid UTF-8.
    let s = std::str::from_utf8(t).map_err(|_| ReplyError::NotANumber)?;
    let v: f64 = s.parse().map_err(|_| ReplyError::NotANumber)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ReplyError::OutOfRange)
    }
}

/// An identification string: trimmed, non-empty, printable ASCII (anything else is replaced
/// by `?`).
pub fn identity(bytes: &[u8]) -> Result<String, ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    Ok(t.iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                char::from(b)
            } else {
                '?'
            }
        })
        .collect())
}

fn fields(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    trim(bytes).split(|&b| b == b',')
}

/// SCPI `:MEAS:ALL? CHn` → `voltage,current,power` (e.g. `12.500,1.234,15.425`). The power
/// field must be present and numeric but is not used: it is the product of the other two.
pub fn scpi_measure_all(bytes: &[u8]) -> Result<Measurement, ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    let mut f = fields(t);
    let (Some(v), Some(i), Some(p), None) = (f.next(), f.next(), f.next(), f.next()) else {
        return Err(ReplyError::FieldCount);
    };
    let voltage_v = number(v)?;
    let current_a = number(i)?;
    number(p)?;
    Ok(Measurement {
        voltage_v,
        current_a,
    })
}

/// SCPI `:OUTP:MODE? CHn` → `CV`, `CC` or `UR` (any case). Says nothing about the output
/// switch: `UR` is [`RegulationMode::Unregulated`].
pub fn scpi_mode(bytes: &[u8]) -> Result<RegulationMode, ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    if t.eq_ignore_ascii_case(b"CV") {
        Ok(RegulationMode::ConstantVoltage)
    } else if t.eq_ignore_ascii_case(b"CC") {
        Ok(RegulationMode::ConstantCurrent)
    } else if t.eq_ignore_ascii_case(b"UR") {
        Ok(RegulationMode::Unregulated)
    } else {
        Err(ReplyError::UnknownKeyword)
    }
}

/// SCPI `:OUTP? CHn` → `ON`/`OFF` (or `1`/`0`): whether the output is on.
pub fn scpi_output_state(bytes: &[u8]) -> Result<bool, ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    if t.eq_ignore_ascii_case(b"ON") || t == b"1" {
        Ok(true)
    } else if t.eq_ignore_ascii_case(b"OFF") || t == b"0" {
        Ok(false)
    } else {
        Err(ReplyError::UnknownKeyword)
    }
}

/// SCPI `:APPL? CHn` → `(voltage_v, current_a)` set-points, from `CH1:30V/5A,12.500,5.000`
/// (Rigol: rating, then the set-points) or plain `12.500,5.000`.
pub fn scpi_applied(bytes: &[u8]) -> Result<(f64, f64), ReplyError> {
    let t = trim(bytes);
    if t.is_empty() {
        return Err(ReplyError::Empty);
    }
    let f: Vec<&[u8]> = fields(t).take(4).collect();
    let (v, i) = match f.as_slice() {
        [v, i] | [_, v, i] => (v, i),
        _ => return Err(ReplyError::FieldCount),
    };
    let voltage_v = number(v)?;
    let current_a = number(i)?;
    if voltage_v < 0.0 || current_a < 0.0 {
        return Err(ReplyError::OutOfRange);
    }
    Ok((voltage_v, current_a))
}

/// The KA3005P `STATUS?` byte.
///
/// Bit layout implemented (after the Korad/Tenma 72-2550 protocol notes; other bits are kept
/// but not interpreted):
///
/// | bit | meaning |
/// | --- | --- |
/// | 0 | CH1 regulation: 0 = constant current, 1 = constant voltage |
/// | 1 | CH2 regulation (two-channel models), same encoding |
/// | 2–3 | tracking mode (two-channel models) |
/// | 4 | beeper on |
/// | 5 | keyboard locked |
/// | 6 | output on |
/// | 7 | not used |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct KoradStatus(pub u8);

impl KoradStatus {
    /// Bit 0: CH1 in constant-voltage (set) or constant-current (clear) regulation.
    pub const CH1_CV: u8 = 1 << 0;
    /// Bit 4: beeper on.
    pub const BEEP: u8 = 1 << 4;
    /// Bit 5: keyboard locked.
    pub const LOCKED: u8 = 1 << 5;
    /// Bit 6: output on.
    pub const OUTPUT_ON: u8 = 1 << 6;

    /// Whether the output is on (bit 6).
    pub fn output_on(self) -> bool {
        self.0 & Self::OUTPUT_ON != 0
    }

    /// Channel 1's regulation mode: [`RegulationMode::Off`] when the output is off, else CV or
    /// CC from bit 0.
    pub fn mode(self) -> RegulationMode {
        if !self.output_on() {
            RegulationMode::Off
        } else if self.0 & Self::CH1_CV != 0 {
            RegulationMode::ConstantVoltage
        } else {
            RegulationMode::ConstantCurrent
        }
    }
}

/// KA3005P `STATUS?` → exactly one raw byte (it may be any value, including `\n` or `0x00`).
pub fn korad_status(bytes: &[u8]) -> Result<KoradStatus, ReplyError> {
    match bytes {
        [b] => Ok(KoradStatus(*b)),
        [] => Err(ReplyError::Empty),
        _ => Err(ReplyError::WrongLength),
    }
}

/// A KA3005P numeric reply (`VOUT1?` → `12.50`, `IOUT1?` → `1.234`, `VSET1?`, `ISET1?`):
/// unterminated, fixed width. Must not be negative.
pub fn korad_number(bytes: &[u8]) -> Result<f64, ReplyError> {
    let v = number(bytes)?;
    if v < 0.0 {
        Err(ReplyError::OutOfRange)
    } else {
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn numbers() {
        assert_eq!(number(b"12.50"), Ok(12.5));
        assert_eq!(number(b" 1.234\r\n"), Ok(1.234));
        assert_eq!(number(b"1.5E+01"), Ok(15.0));
        assert_eq!(number(b"-0.001"), Ok(-0.001));
        assert_eq!(number(b""), Err(ReplyError::Empty));
        assert_eq!(number(b"inf"), Err(ReplyError::NotANumber));
        assert_eq!(number(b"NaN"), Err(ReplyError::NotANumber));
        assert_eq!(number(b"1e999"), Err(ReplyError::OutOfRange));
        assert_eq!(number(b"1.2.3"), Err(ReplyError::NotANumber));
        assert_eq!(number(b"-"), Err(ReplyError::NotANumber));
    }

    #[test]
    fn scpi_replies() {
        let m = scpi_measure_all(b"12.500,1.234,15.425\n").unwrap();
        assert_eq!((m.voltage_v, m.current_a), (12.5, 1.234));
        assert_eq!(
            scpi_measure_all(b"12.500,1.234"),
            Err(ReplyError::FieldCount)
        );
        assert_eq!(scpi_measure_all(b"1,2,3,4"), Err(ReplyError::FieldCount));
        assert_eq!(scpi_measure_all(b"1,x,3"), Err(ReplyError::NotANumber));
        assert_eq!(scpi_mode(b"cc"), Ok(RegulationMode::ConstantCurrent));
        assert_eq!(scpi_mode(b"UR"), Ok(RegulationMode::Unregulated));
        assert_eq!(scpi_mode(b"XX"), Err(ReplyError::UnknownKeyword));
        assert_eq!(scpi_output_state(b"ON"), Ok(true));
        assert_eq!(scpi_output_state(b"0"), Ok(false));
        assert_eq!(scpi_applied(b"CH1:30V/5A,12.500,5.000"), Ok((12.5, 5.0)));
        assert_eq!(scpi_applied(b"12.5,5"), Ok((12.5, 5.0)));
        assert_eq!(scpi_applied(b"12.5"), Err(ReplyError::FieldCount));
    }

    #[test]
    fn korad_replies() {
        assert_eq!(korad_number(b"12.50"), Ok(12.5));
        assert_eq!(korad_number(b"-1.00"), Err(ReplyError::OutOfRange));
        let s = korad_status(&[0x51]).unwrap(); // output on, beep, CV
        assert!(s.output_on());
        assert_eq!(s.mode(), RegulationMode::ConstantVoltage);
        assert_eq!(
            korad_status(&[0x40]).unwrap().mode(),
            RegulationMode::ConstantCurrent
        );
        assert_eq!(korad_status(&[0x01]).unwrap().mode(), RegulationMode::Off);
        assert_eq!(korad_status(b""), Err(ReplyError::Empty));
        assert_eq!(korad_status(b"AB"), Err(ReplyError::WrongLength));
        assert_eq!(
            identity(b"KORAD KA3005P V5.8\0"),
            Ok("KORAD KA3005P V5.8".into())
        );
        assert_eq!(identity(b"A\xffB"), Ok("A?B".into()));
        assert_eq!(identity(b" \r\n"), Err(ReplyError::Empty));
    }

    proptest! {
        #[test]
        fn parsers_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..80)) {
            let _ = number(&bytes);
            let _ = identity(&bytes);
            let _ = scpi_measure_all(&bytes);
            let _ = scpi_mode(&bytes);
            let _ = scpi_output_state(&bytes);
            let _ = scpi_applied(&bytes);
            let _ = korad_status(&bytes);
            let _ = korad_number(&bytes);
        }

        #[test]
        fn accepted_numbers_are_finite(bytes in proptest::collection::vec(
            prop_oneof![Just(b'0'), Just(b'7'), Just(b'.'), Just(b'-'), Just(b'+'), Just(b'e'),
                        Just(b' '), any::<u8>()], 0..24)) {
            if let Ok(v) = number(&bytes) {
                prop_assert!(v.is_finite());
            }
            if let Ok(m) = scpi_measure_all(&bytes) {
                prop_assert!(m.voltage_v.is_finite() && m.current_a.is_finite());
            }
        }

        #[test]
        fn formatted_numbers_round_trip(v in 0.0f64..40.0) {
            let korad = format!("{v:05.2}");
            prop_assert!((korad_number(korad.as_bytes()).unwrap() - v).abs() <= 0.005 + 1e-9);
            let line = format!("{v:.3},{:.3},{:.3}\n", v / 10.0, v * v / 10.0);
            let m = scpi_measure_all(line.as_bytes()).unwrap();
            prop_assert!((m.voltage_v - v).abs() <= 0.0005 + 1e-9);
        }
    }
}
