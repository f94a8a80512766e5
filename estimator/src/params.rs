//! Rig parameters as flight firmware consumes them: the curve, the rotor count and the thrust
//! limit, with a fixed little-endian binary form (`.hbp`) that decodes without allocation.
//!
//! The canonical, human-readable form is `params.toml` ([`crate::file`], `std` feature); `hoverbench
//! fit --blob params.hbp` writes this binary form beside it. In firmware:
//!
//! ```
//! # let bytes = {
//! #     let curve = estimator::PolyCurve::new(&[10.0, 12.0, 3.0], 130.0, 130.0, (0.0, 260.0), Some(12.5)).unwrap();
//! #     let p = estimator::Params { rotor_count: 4, curve, thrust_limit: None, battery: None, vehicle: None };
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
//! limit, bit 1 supply voltage, bit 2 battery model, bit 3 vehicle); centre, scale, range and
//! supply voltage of the curve (5 × f64); the scaled coefficients; the thrust limit (3 × f64)
//! when flagged; from version 2, the battery model ([`BATTERY_BLOCK_LEN`] bytes: cells,
//! chemistry code, 6 zero bytes, rated capacity, 21 open-circuit knots, series resistance, RC
//! resistance, RC time constant, cut-off voltage, as f64) and the vehicle (5 × f64: structure,
//! battery and payload mass, avionics and payload power) when flagged; CRC-32 of everything
//! before it. A blob without battery or vehicle is written as version 1, byte for byte what
//! earlier versions wrote, and both versions are read.

use crate::EstimateError;
use crate::curve::{MAX_DEGREE, PolyCurve};
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
/// Longest possible blob, bytes: header (magic, version, rotors, degree, flags), scaling and
/// range, coefficients, thrust limit, battery, vehicle, CRC.
pub const MAX_BLOB_LEN: usize =
    8 + 5 * 8 + (MAX_DEGREE + 1) * 8 + 3 * 8 + BATTERY_BLOCK_LEN + VEHICLE_BLOCK_LEN + 4;

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
}

impl Params {
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
            + 4;
        if let Some(b) = &self.battery {
            b.validate()?;
        }
        if let Some(v) = &self.vehicle {
            v.validate()?;
        }
        let version = if self.battery.is_some() || self.vehicle.is_some() {
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
                | (u8::from(self.vehicle.is_some()) << 3),
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
        let known_flags = if version == 1 { 0b11 } else { 0b1111 };
        if body[7] & !known_flags != 0 {
            return Err(EstimateError::Blob {
                reason: "unknown flags byte",
            });
        }
        let has_limit = body[7] & 1 != 0;
        let has_voltage = body[7] & 2 != 0;
        let has_battery = body[7] & 4 != 0;
        let has_vehicle = body[7] & 8 != 0;
        if degree > MAX_DEGREE {
            return Err(EstimateError::CurveDegree {
                coefficients: degree + 1,
                max_degree: MAX_DEGREE,
            });
        }
        let want = 8
            + 5 * 8
            + (degree + 1) * 8
            + if has_limit { 24 } else { 0 }
            + if has_battery { BATTERY_BLOCK_LEN } else { 0 }
            + if has_vehicle { VEHICLE_BLOCK_LEN } else { 0 };
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
        Ok(Self {
            rotor_count,
            curve,
            thrust_limit,
            battery,
            vehicle,
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
        // The longest blob fits MAX_BLOB_LEN exactly.
        let mut p = with_battery(true);
        p.curve = PolyCurve::new(
            &[1.0; MAX_DEGREE + 1],
            135.0,
            125.0,
            (10.0, 260.0),
            Some(12.5),
        )
        .unwrap();
        let mut buf = [0u8; MAX_BLOB_LEN];
        assert_eq!(p.encode(&mut buf).unwrap(), MAX_BLOB_LEN);
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
        let p = with_battery(true);
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
        fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = Params::decode(&bytes);
        }

        #[test]
        fn decode_never_panics_on_valid_header(mut tail in proptest::collection::vec(any::<u8>(), 0..200), deg in 0u8..20, flags in 0u8..16, version in 1u8..3) {
            let mut bytes = MAGIC.to_vec();
            bytes.extend_from_slice(&[version, 4, deg, flags]);
            bytes.append(&mut tail);
            let _ = Params::decode(&bytes);
        }
    }
}
