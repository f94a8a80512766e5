//! Rig parameters as flight firmware consumes them: the curve, the rotor count and the thrust
//! limit, with a fixed little-endian binary form (`.hbp`) that decodes without allocation.
//!
//! The canonical, human-readable form is `params.toml` ([`crate::file`], `std` feature); `hoverbench
//! fit --blob params.hbp` writes this binary form beside it. In firmware:
//!
//! ```
//! # let bytes = {
//! #     let curve = estimator::PolyCurve::new(&[10.0, 12.0, 3.0], 130.0, 130.0, (0.0, 260.0), Some(12.5)).unwrap();
//! #     let p = estimator::Params { rotor_count: 4, curve, thrust_limit: None, battery: None, vehicle: None, motor: None };
//! #     let mut buf = [0u8; estimator::params::MAX_BLOB_LEN];
//! #     let n = p.encode(&mut buf).unwrap();
//! #     buf[..n].to_vec()
//! # };
//! // static PARAMS: &[u8] = include_bytes!("params.hbp");
//! let params = estimator::Params::decode(&bytes).expect("a valid parameter blob");
//! assert_eq!(params.rotor_count, 4);
//! ```
//!
//! Layout (little-endian): magic `HBPR`, version, rotor count, curve degree, flags (bit 0 thrust
//! limit, bit 1 supply voltage, bit 2 battery model, bit 3 vehicle, bit 4 motor map); centre,
//! scale, range and supply voltage of the curve (5 × f64); the scaled coefficients; the thrust
//! limit (3 × f64) when flagged; from version 2, the battery model ([`BATTERY_BLOCK_LEN`] bytes:
//! cells, chemistry code, 6 zero bytes, rated capacity, 21 open-circuit knots, series
//! resistance, RC resistance, RC time constant, cut-off voltage, as f64), the vehicle (5 × f64:
//! structure, battery and payload mass, avionics and payload power) and the motor map
//! ([`motor_block_len`] bytes: the degree `d` of its power curve, 7 zero bytes; zero and full
//! command in µs, centre and half-width of the drive-voltage scaling, drive-voltage range min
//! and max in V, fit RMSE as a fraction (7 × f64); the `d + 1` scaled coefficients) when
//! flagged; CRC-32 of everything before it. A blob without battery, vehicle or motor map is
//! written as version 1, byte for byte what earlier versions wrote, and both versions are
//! read.

use crate::EstimateError;
use crate::curve::{MAX_DEGREE, PolyCurve};
use crate::motor::MotorMap;
use crate::online::{BatteryModel, Chemistry, OCV_KNOTS, Vehicle};

/// First four bytes of every blob.
pub const MAGIC: [u8; 4] = *b"HBPR";
/// Newest binary layout version this crate writes and reads (version 1, without battery and
/// vehicle, is still read, and written when there is neither).
pub const BLOB_VERSION: u8 = 2;
/// Bytes of the battery block (version 2).
pub const BATTERY_BLOCK_LEN: usize = 8 + (1 + OCV_KNOTS + 4) * 8;
/// Bytes of the vehicle block (version 2).
pub const VEHICLE_BLOCK_LEN: usize = 5 * 8;
/// Bytes of the motor-map block (version 2) for a power curve of degree `degree`: degree byte
/// and 7 zero bytes, 7 × f64, `degree + 1` coefficients.
pub const fn motor_block_len(degree: usize) -> usize {
    8 + 7 * 8 + (degree + 1) * 8
}
/// Longest possible blob, bytes: header (magic, version, rotors, degree, flags), scaling and
/// range, coefficients, thrust limit, battery, vehicle, motor map, CRC.
pub const MAX_BLOB_LEN: usize = 8
    + 5 * 8
    + (MAX_DEGREE + 1) * 8
    + 3 * 8
    + BATTERY_BLOCK_LEN
    + VEHICLE_BLOCK_LEN
    + motor_block_len(MAX_DEGREE)
    + 4;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Per-rotor thrust limit at minimum battery voltage (the paper's `m_L / rotor_count`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustLimit {
    /// Sustained maximum thrust of one rotor, g.
    pub per_rotor_g: f64,
    /// Its standard uncertainty, g.
    pub uncertainty_g: f64,
    /// Supply voltage the limit sweep was taken at, V.
    pub supply_voltage_v: f64,
}

/// What the estimator needs from a rig characterisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Rotors sharing the take-off mass.
    pub rotor_count: u8,
    /// Per-rotor thrust → power curve at the nominal voltage.
    pub curve: PolyCurve,
    /// Thrust limit at minimum battery voltage, when measured.
    pub thrust_limit: Option<ThrustLimit>,
    /// The pack the robot flies (the `[battery]` section), for the online estimator.
    pub battery: Option<BatteryModel>,
    /// The robot's masses and powers (the `[vehicle]` section), for the online estimator.
    pub vehicle: Option<Vehicle>,
    /// Per-rotor power from the ESC command and supply voltage (the `[motor]` section), when
    /// both sweeps gave one.
    pub motor: Option<MotorMap>,
}

impl Params {
    /// The parameters of `rotor_count` rotors on `curve`, with no optional section (thrust
    /// limit, battery, vehicle, motor map); set those with struct update syntax:
    ///
    /// ```
    /// # use estimator::{Params, PolyCurve};
    /// let curve = PolyCurve::new(&[22.4, 29.1, 6.8], 130.0, 130.0, (0.0, 260.0), None).unwrap();
    /// let p = Params::new(4, curve);
    /// assert!(p.thrust_limit.is_none() && p.motor.is_none());
    /// ```
    #[must_use]
    pub const fn new(rotor_count: u8, curve: PolyCurve) -> Self {
        Self {
            rotor_count,
            curve,
            thrust_limit: None,
            battery: None,
            vehicle: None,
            motor: None,
        }
    }

    /// `m_L`: total thrust limit over all rotors, kg.
    pub fn thrust_limit_kg(&self) -> Option<f64> {
        self.thrust_limit
            .map(|l| l.per_rotor_g * f64::from(self.rotor_count) / 1000.0)
    }

    /// Writes the binary form into `buf`, returning the number of bytes written.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, EstimateError> {
        let coeffs = self.curve.coefficients_scaled();
        let len = 8
            + 5 * 8
            + coeffs.len() * 8
            + if self.thrust_limit.is_some() { 24 } else { 0 }
            + if self.battery.is_some() {
                BATTERY_BLOCK_LEN
            } else {
                0
            }
            + if self.vehicle.is_some() {
                VEHICLE_BLOCK_LEN
            } else {
                0
            }
            + self.motor.map_or(0, |m| motor_block_len(m.degree()))
            + 4;
        if let Some(b) = &self.battery {
            b.validate()?;
        }
        if let Some(v) = &self.vehicle {
            v.validate()?;
        }
        let version = if self.battery.is_some() || self.vehicle.is_some() || self.motor.is_some() {
            BLOB_VERSION
        } else {
            1
        };
        if buf.len() < len {
            return Err(EstimateError::OutputTooShort {
                needed: len,
                given: buf.len(),
            });
        }
        let mut w = Writer { buf, pos: 0 };
        w.bytes(&MAGIC);
        w.bytes(&[
            version,
            self.rotor_count,
            // MAX_DEGREE < 256, so the degree fits a byte.
            self.curve.degree() as u8,
            u8::from(self.thrust_limit.is_some())
                | (u8::from(self.curve.supply_voltage_v().is_some()) << 1)
                | (u8::from(self.battery.is_some()) << 2)
                | (u8::from(self.vehicle.is_some()) << 3)
                | (u8::from(self.motor.is_some()) << 4),
        ]);
        let (lo, hi) = crate::PowerCurve::valid_range_g(&self.curve);
        for v in [
            self.curve.center_g(),
            self.curve.scale_g(),
            lo,
            hi,
            self.curve.supply_voltage_v().unwrap_or(0.0),
        ] {
            w.f64(v);
        }
        for &c in coeffs {
            w.f64(c);
        }
        if let Some(l) = self.thrust_limit {
            w.f64(l.per_rotor_g);
            w.f64(l.uncertainty_g);
            w.f64(l.supply_voltage_v);
        }
        if let Some(b) = &self.battery {
            w.bytes(&[b.cells, b.chemistry as u8, 0, 0, 0, 0, 0, 0]);
            w.f64(b.rated_capacity_ah);
            for &v in &b.ocv_cell_v {
                w.f64(v);
            }
            w.f64(b.series_resistance_cell_ohm);
            w.f64(b.rc_resistance_cell_ohm);
            w.f64(b.rc_time_constant_s);
            w.f64(b.cutoff_cell_v);
        }
        if let Some(v) = &self.vehicle {
            for x in [
                v.structure_mass_kg,
                v.battery_mass_kg,
                v.payload_mass_kg,
                v.avionics_power_w,
                v.payload_power_w,
            ] {
                w.f64(x);
            }
        }
        if let Some(m) = &self.motor {
            // MAX_DEGREE < 256, so the degree fits a byte.
            w.bytes(&[m.degree() as u8, 0, 0, 0, 0, 0, 0, 0]);
            let (lo, hi) = m.drive_range_v();
            for x in [
                m.zero_us(),
                m.full_us(),
                m.center_v(),
                m.scale_v(),
                lo,
                hi,
                m.fit_rmse_fraction(),
            ] {
                w.f64(x);
            }
            for &c in m.coefficients_scaled() {
                w.f64(c);
            }
        }
        let crc = CRC32.checksum(&w.buf[..w.pos]);
        w.bytes(&crc.to_le_bytes());
        Ok(w.pos)
    }

    /// Reads the binary form, checking magic, version, length, CRC and every value.
    pub fn decode(bytes: &[u8]) -> Result<Self, EstimateError> {
        if bytes.len() < 8 + 4 || bytes[..4] != MAGIC {
            return Err(EstimateError::Blob {
                reason: "not a hoverbench parameter blob (bad magic or too short)",
            });
        }
        let version = bytes[4];
        if version == 0 || version > BLOB_VERSION {
            return Err(EstimateError::BlobVersion {
                found: version,
                supported: BLOB_VERSION,
            });
        }
        let (body, crc) = bytes.split_at(bytes.len() - 4);
        let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if CRC32.checksum(body) != crc {
            return Err(EstimateError::Blob {
                reason: "CRC mismatch: the blob is corrupted",
            });
        }
        let rotor_count = body[5];
        let degree = usize::from(body[6]);
        let known_flags = if version == 1 { 0b11 } else { 0b1_1111 };
        if body[7] & !known_flags != 0 {
            return Err(EstimateError::Blob {
                reason: "unknown flags byte",
            });
        }
        let has_limit = body[7] & 1 != 0;
        let has_voltage = body[7] & 2 != 0;
        let has_battery = body[7] & 4 != 0;
        let has_vehicle = body[7] & 8 != 0;
        let has_motor = body[7] & 16 != 0;
        if degree > MAX_DEGREE {
            return Err(EstimateError::CurveDegree {
                coefficients: degree + 1,
                max_degree: MAX_DEGREE,
            });
        }
        let before_motor = 8
            + 5 * 8
            + (degree + 1) * 8
            + if has_limit { 24 } else { 0 }
            + if has_battery { BATTERY_BLOCK_LEN } else { 0 }
            + if has_vehicle { VEHICLE_BLOCK_LEN } else { 0 };
        // The motor block's length follows from its own degree byte, its first.
        let motor_degree = if has_motor {
            let d = usize::from(*body.get(before_motor).ok_or(EstimateError::Blob {
                reason: "length does not match the degree and flags",
            })?);
            if d > MAX_DEGREE {
                return Err(EstimateError::CurveDegree {
                    coefficients: d + 1,
                    max_degree: MAX_DEGREE,
                });
            }
            Some(d)
        } else {
            None
        };
        let want = before_motor + motor_degree.map_or(0, motor_block_len);
        if body.len() != want {
            return Err(EstimateError::Blob {
                reason: "length does not match the degree and flags",
            });
        }
        if rotor_count == 0 {
            return Err(EstimateError::NoRotors);
        }
        let mut r = Reader { buf: body, pos: 8 };
        let center = r.f64();
        let scale = r.f64();
        let lo = r.f64();
        let hi = r.f64();
        let volts = r.f64();
        let mut coeffs = [0.0; MAX_DEGREE + 1];
        for c in coeffs.iter_mut().take(degree + 1) {
            *c = r.f64();
        }
        let volts = if has_voltage {
            Some(volts)
        } else if volts == 0.0 {
            None
        } else {
            return Err(EstimateError::Blob {
                reason: "a voltage is stored but the flags say there is none",
            });
        };
        let curve = PolyCurve::new(&coeffs[..=degree], center, scale, (lo, hi), volts)?;
        let thrust_limit = if has_limit {
            let l = ThrustLimit {
                per_rotor_g: r.f64(),
                uncertainty_g: r.f64(),
                supply_voltage_v: r.f64(),
            };
            crate::curve::require_positive("thrust limit per rotor (g)", l.per_rotor_g)?;
            crate::curve::require_non_negative("thrust limit uncertainty (g)", l.uncertainty_g)?;
            crate::curve::require_positive("thrust limit voltage (V)", l.supply_voltage_v)?;
            Some(l)
        } else {
            None
        };
        let battery = if has_battery {
            let head = r.bytes8();
            if head[2..].iter().any(|&b| b != 0) {
                return Err(EstimateError::Blob {
                    reason: "battery block: reserved bytes are not zero",
                });
            }
            let chemistry = Chemistry::from_code(head[1]).ok_or(EstimateError::Blob {
                reason: "battery block: unknown chemistry code",
            })?;
            let rated_capacity_ah = r.f64();
            let mut ocv_cell_v = [0.0; OCV_KNOTS];
            for v in &mut ocv_cell_v {
                *v = r.f64();
            }
            let b = BatteryModel {
                cells: head[0],
                rated_capacity_ah,
                chemistry,
                ocv_cell_v,
                series_resistance_cell_ohm: r.f64(),
                rc_resistance_cell_ohm: r.f64(),
                rc_time_constant_s: r.f64(),
                cutoff_cell_v: r.f64(),
            };
            b.validate()?;
            Some(b)
        } else {
            None
        };
        let vehicle = if has_vehicle {
            let v = Vehicle {
                structure_mass_kg: r.f64(),
                battery_mass_kg: r.f64(),
                payload_mass_kg: r.f64(),
                avionics_power_w: r.f64(),
                payload_power_w: r.f64(),
            };
            v.validate()?;
            Some(v)
        } else {
            None
        };
        let motor = match motor_degree {
            None => None,
            Some(d) => {
                let head = r.bytes8();
                if head[1..].iter().any(|&b| b != 0) {
                    return Err(EstimateError::Blob {
                        reason: "motor block: reserved bytes are not zero",
                    });
                }
                let zero_us = r.f64();
                let full_us = r.f64();
                let center_v = r.f64();
                let scale_v = r.f64();
                let lo = r.f64();
                let hi = r.f64();
                let rmse = r.f64();
                let mut c = [0.0; MAX_DEGREE + 1];
                for c in c.iter_mut().take(d + 1) {
                    *c = r.f64();
                }
                Some(MotorMap::new(
                    zero_us,
                    full_us,
                    &c[..=d],
                    center_v,
                    scale_v,
                    (lo, hi),
                    rmse,
                )?)
            }
        };
        Ok(Self {
            rotor_count,
            curve,
            thrust_limit,
            battery,
            vehicle,
            motor,
        })
    }
}

struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        self.buf[self.pos..self.pos + b.len()].copy_from_slice(b);
        self.pos += b.len();
    }
    fn f64(&mut self, v: f64) {
        self.bytes(&v.to_le_bytes());
    }
}

struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    /// Callers check the length first.
    fn f64(&mut self) -> f64 {
        let mut b = [0u8; 8];
        b.copy_from_slice(&self.buf[self.pos..self.pos + 8]);
        self.pos += 8;
        f64::from_le_bytes(b)
    }
    /// Callers check the length first.
    fn bytes8(&mut self) -> [u8; 8] {
        let mut b = [0u8; 8];
        b.copy_from_slice(&self.buf[self.pos..self.pos + 8]);
        self.pos += 8;
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample(limit: bool) -> Params {
        Params {
            rotor_count: 4,
            curve: PolyCurve::new(
                &[20.0, 25.0, 8.0, 1.5, 0.2, 0.05],
                135.0,
                125.0,
                (10.0, 260.0),
                Some(12.5),
            )
            .unwrap(),
            thrust_limit: limit.then_some(ThrustLimit {
                per_rotor_g: 150.0,
                uncertainty_g: 0.4,
                supply_voltage_v: 9.0,
            }),
            battery: None,
            vehicle: None,
            motor: None,
        }
    }

    fn with_battery(limit: bool) -> Params {
        let mut p = sample(limit);
        let mut b = BatteryModel::lipo(3, 2.2).unwrap();
        b.chemistry = Chemistry::Measured;
        b.rc_resistance_cell_ohm = 0.003;
        b.rc_time_constant_s = 25.0;
        p.battery = Some(b);
        p.vehicle = Some(Vehicle {
            structure_mass_kg: 0.431,
            battery_mass_kg: 0.144,
            payload_mass_kg: 0.02,
            avionics_power_w: 2.44,
            payload_power_w: 0.5,
        });
        p
    }

    #[test]
    fn battery_and_vehicle_round_trip_as_version_2() {
        for limit in [false, true] {
            let p = with_battery(limit);
            let mut buf = [0u8; MAX_BLOB_LEN];
            let n = p.encode(&mut buf).unwrap();
            assert_eq!(buf[4], 2);
            assert_eq!(Params::decode(&buf[..n]).unwrap(), p);
            // Battery alone, vehicle alone.
            let mut q = p;
            q.vehicle = None;
            let n = q.encode(&mut buf).unwrap();
            assert_eq!(Params::decode(&buf[..n]).unwrap(), q);
            let mut q = p;
            q.battery = None;
            let n = q.encode(&mut buf).unwrap();
            assert_eq!(Params::decode(&buf[..n]).unwrap(), q);
        }
        // The longest blob without a motor map: MAX_BLOB_LEN less the longest motor block.
        let p = longest_without_motor();
        let mut buf = [0u8; MAX_BLOB_LEN];
        assert_eq!(
            p.encode(&mut buf).unwrap(),
            MAX_BLOB_LEN - motor_block_len(MAX_DEGREE)
        );
    }

    /// Every section but the motor map, the curve of the highest degree.
    fn longest_without_motor() -> Params {
        Params {
            curve: PolyCurve::new(
                &[1.0; MAX_DEGREE + 1],
                135.0,
                125.0,
                (10.0, 260.0),
                Some(12.5),
            )
            .unwrap(),
            ..with_battery(true)
        }
    }

    fn motor_map(coefficients: &[f64]) -> MotorMap {
        MotorMap::new(1083.5, 2000.0, coefficients, 6.2, 5.1, (1.1, 11.3), 0.012).unwrap()
    }

    #[test]
    fn a_motor_map_round_trips_behind_flag_bit_4_as_version_2() {
        for limit in [false, true] {
            let mut p = sample(limit);
            p.motor = Some(motor_map(&[30.0, 40.0, 12.0, 1.5]));
            let mut buf = [0u8; MAX_BLOB_LEN];
            let n = p.encode(&mut buf).unwrap();
            assert_eq!(buf[4], 2, "a motor block needs version 2");
            assert_eq!(buf[7] & 0b1_0000, 0b1_0000);
            assert_eq!(buf[7] & 0b1100, 0, "no battery, no vehicle");
            // The block sits last, before the CRC, and is as long as its degree says.
            let mut without = p;
            without.motor = None;
            let mut old = [0u8; MAX_BLOB_LEN];
            let m = without.encode(&mut old).unwrap();
            assert_eq!(n, m + motor_block_len(3));
            assert_eq!(buf[m - 4], 3, "the block starts with its degree");
            assert_eq!(Params::decode(&buf[..n]).unwrap(), p);
            // With battery and vehicle too.
            let mut q = with_battery(limit);
            q.motor = p.motor;
            let n = q.encode(&mut buf).unwrap();
            assert_eq!(buf[7] & 0b1_1100, 0b1_1100);
            assert_eq!(Params::decode(&buf[..n]).unwrap(), q);
        }
        // The longest blob, with a motor curve of the highest degree, fits MAX_BLOB_LEN exactly.
        let mut p = longest_without_motor();
        p.motor = Some(motor_map(&[2.0; MAX_DEGREE + 1]));
        let mut buf = [0u8; MAX_BLOB_LEN];
        assert_eq!(p.encode(&mut buf).unwrap(), MAX_BLOB_LEN);
        assert_eq!(Params::decode(&buf).unwrap(), p);
    }

    #[test]
    fn a_version_1_blob_may_not_claim_a_motor_map_and_a_bad_motor_block_is_refused() {
        let fix_crc = |b: &mut Vec<u8>| {
            let n = b.len();
            let crc = CRC32.checksum(&b[..n - 4]);
            b[n - 4..].copy_from_slice(&crc.to_le_bytes());
        };
        let mut p = sample(false);
        p.motor = Some(motor_map(&[30.0, 40.0]));
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = p.encode(&mut buf).unwrap();
        let good = buf[..n].to_vec();
        let mut v1 = good.clone();
        v1[4] = 1;
        fix_crc(&mut v1);
        assert!(Params::decode(&v1).is_err());
        // Its degree byte disagreeing with the length.
        let start = n - 4 - motor_block_len(1);
        let mut longer = good.clone();
        longer[start] = 2;
        fix_crc(&mut longer);
        assert!(matches!(
            Params::decode(&longer),
            Err(EstimateError::Blob { .. })
        ));
        // A degree above the estimator's.
        let mut huge = good.clone();
        huge[start] = 200;
        fix_crc(&mut huge);
        assert!(matches!(
            Params::decode(&huge),
            Err(EstimateError::CurveDegree { .. })
        ));
        // Reserved bytes.
        let mut reserved = good.clone();
        reserved[start + 3] = 1;
        fix_crc(&mut reserved);
        assert!(Params::decode(&reserved).is_err());
        // zero_us above full_us.
        let mut swapped = good.clone();
        swapped[start + 8..start + 16].copy_from_slice(&2500.0f64.to_le_bytes());
        fix_crc(&mut swapped);
        assert!(matches!(
            Params::decode(&swapped),
            Err(EstimateError::MotorCommandRange { .. })
        ));
        // Truncated right after the flags say there is a motor block.
        let mut cut = good[..n - 4 - motor_block_len(1)].to_vec();
        cut.extend_from_slice(&[0; 4]);
        fix_crc(&mut cut);
        assert!(Params::decode(&cut).is_err());
    }

    #[test]
    fn version_1_blobs_are_written_and_read_as_before() {
        // Bytes of a version-1 blob as hoverbench 0.1 wrote it (degree 2, no limit, no voltage).
        let p = Params {
            rotor_count: 4,
            curve: PolyCurve::new(&[1.0, 2.0, 3.0], 0.0, 1.0, (0.0, 1.0), None).unwrap(),
            thrust_limit: None,
            battery: None,
            vehicle: None,
            motor: None,
        };
        let mut old = b"HBPR\x01\x04\x02\x00".to_vec();
        for v in [0.0f64, 1.0, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0] {
            old.extend_from_slice(&v.to_le_bytes());
        }
        let crc = CRC32.checksum(&old);
        old.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(Params::decode(&old).unwrap(), p);
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = p.encode(&mut buf).unwrap();
        assert_eq!(&buf[..n], &old[..]);
        // A version-1 blob may not claim a battery.
        let mut bad = old.clone();
        bad[7] = 4;
        let n = bad.len();
        let crc = CRC32.checksum(&bad[..n - 4]);
        bad[n - 4..].copy_from_slice(&crc.to_le_bytes());
        assert!(Params::decode(&bad).is_err());
    }

    #[test]
    fn newer_versions_are_refused_by_number() {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = with_battery(true).encode(&mut buf).unwrap();
        buf[4] = 3;
        assert!(matches!(
            Params::decode(&buf[..n]),
            Err(EstimateError::BlobVersion {
                found: 3,
                supported: 2
            })
        ));
    }

    #[test]
    fn round_trip_with_and_without_limit() {
        for limit in [false, true] {
            let p = sample(limit);
            let mut buf = [0u8; MAX_BLOB_LEN];
            let n = p.encode(&mut buf).unwrap();
            assert_eq!(Params::decode(&buf[..n]).unwrap(), p);
        }
        assert!((sample(true).thrust_limit_kg().unwrap() - 0.6).abs() < 1e-12);
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        let mut p = with_battery(true);
        p.motor = Some(motor_map(&[30.0, 40.0, 12.0]));
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = p.encode(&mut buf).unwrap();
        for byte in 0..n {
            for bit in 0..8 {
                let mut b = buf;
                b[byte] ^= 1 << bit;
                assert!(Params::decode(&b[..n]).is_err(), "flip {byte}:{bit}");
            }
        }
    }

    #[test]
    fn too_small_output_buffer_is_an_error() {
        let mut buf = [0u8; 10];
        assert!(matches!(
            sample(true).encode(&mut buf),
            Err(EstimateError::OutputTooShort { .. })
        ));
    }

    proptest! {
        #[test]
        fn motor_maps_round_trip_bit_for_bit(
            zero_us in 800.0f64..1300.0,
            span_us in 100.0f64..1500.0,
            coefficients in proptest::collection::vec(-1e3f64..1e3, 1..=MAX_DEGREE + 1),
            center_v in 0.0f64..50.0,
            scale_v in 1e-3f64..50.0,
            lo_v in 0.0f64..20.0,
            width_v in 1e-6f64..40.0,
            rmse in 0.0f64..1.0,
            limit in any::<bool>(),
            battery in any::<bool>(),
        ) {
            let mut p = if battery { with_battery(limit) } else { sample(limit) };
            p.motor = Some(MotorMap::new(zero_us, zero_us + span_us, &coefficients, center_v, scale_v, (lo_v, lo_v + width_v), rmse).unwrap());
            let mut buf = [0u8; MAX_BLOB_LEN];
            let n = p.encode(&mut buf).unwrap();
            let back = Params::decode(&buf[..n]).unwrap();
            prop_assert_eq!(back, p);
            // Without the map, the bytes are what they were before the map existed.
            let mut q = p;
            q.motor = None;
            let mut old = [0u8; MAX_BLOB_LEN];
            let m = q.encode(&mut old).unwrap();
            prop_assert_eq!(old[7] & 0b1_0000, 0);
            prop_assert_eq!(old[4], if battery { 2 } else { 1 });
            prop_assert_eq!(&buf[8..m - 4], &old[8..m - 4]);
        }

        #[test]
        fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = Params::decode(&bytes);
        }

        #[test]
        fn decode_never_panics_on_valid_header(mut tail in proptest::collection::vec(any::<u8>(), 0..200), deg in 0u8..20, flags in 0u8..32, version in 1u8..3) {
            let mut bytes = MAGIC.to_vec();
            bytes.extend_from_slice(&[version, 4, deg, flags]);
            bytes.append(&mut tail);
            let _ = Params::decode(&bytes);
        }
    }
}
