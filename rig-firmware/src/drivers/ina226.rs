//! INA226 current / voltage / power monitor over I²C.
//!
//! Registers (datasheet SBOS547): configuration `0x00`, shunt voltage `0x01` (signed,
//! 2.5 µV/LSB), bus voltage `0x02` (1.25 mV/LSB), power `0x03` (25 × current LSB), current
//! `0x04` (signed, current LSB), calibration `0x05`, manufacturer ID `0xFE` (`0x5449`, "TI"),
//! die ID `0xFF` (`0x2260`). Registers are 16-bit big-endian.
//!
//! Calibration: choose a current LSB (here `max_current_a / 2¹⁵`), then
//! `CAL = 0.00512 / (current_lsb_a × shunt_ohm)` (datasheet eq. 1).

use embedded_hal::i2c::{self, ErrorKind, I2c};
use thiserror::Error;

/// Register addresses.
pub mod reg {
    /// Configuration.
    pub const CONFIG: u8 = 0x00;
    /// Shunt voltage.
    pub const SHUNT_VOLTAGE: u8 = 0x01;
    /// Bus voltage.
    pub const BUS_VOLTAGE: u8 = 0x02;
    /// Power.
    pub const POWER: u8 = 0x03;
    /// Current.
    pub const CURRENT: u8 = 0x04;
    /// Calibration.
    pub const CALIBRATION: u8 = 0x05;
    /// Manufacturer ID.
    pub const MANUFACTURER_ID: u8 = 0xFE;
    /// Die ID.
    pub const DIE_ID: u8 = 0xFF;
}

/// Manufacturer ID of a genuine INA226 ("TI").
pub const MANUFACTURER_ID: u16 = 0x5449;
/// Shunt-voltage LSB, V.
pub const SHUNT_LSB_V: f32 = 2.5e-6;
/// Bus-voltage LSB, V.
pub const BUS_LSB_V: f32 = 1.25e-3;

/// Default configuration: 16 averages, 1.1 ms bus and shunt conversion, continuous
/// shunt-and-bus mode (`0x4527`).
pub const DEFAULT_CONFIG: u16 = 0x4527;

/// Errors of the INA226 driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum Ina226Error {
    /// An I²C transfer failed.
    #[error("INA226 I2C error on register {register:#04x}: {kind:?}")]
    I2c {
        /// Register being accessed.
        register: u8,
        /// What the HAL reported.
        kind: ErrorKind,
    },
    /// The chip at the address is not an INA226.
    #[error("not an INA226: manufacturer ID {id:#06x}")]
    WrongDevice {
        /// The ID read.
        id: u16,
    },
    /// Shunt and maximum current give a calibration value outside `1..=0x7FFF`.
    #[error(
        "shunt {shunt_milliohm} mΩ and max current {max_current_ma} mA give an invalid calibration"
    )]
    BadCalibration {
        /// Shunt resistance, mΩ.
        shunt_milliohm: u32,
        /// Maximum current, mA.
        max_current_ma: u32,
    },
}

/// Calibration register value and current LSB for a shunt and a maximum expected current.
///
/// ```
/// // 2 mΩ shunt, 20 A full scale: LSB = 20/32768 A, CAL = 0.00512/(LSB·0.002) = 4194
/// let (cal, lsb) = rig_firmware::drivers::ina226::calibration(0.002, 20.0).unwrap();
/// assert_eq!(cal, 4194);
/// assert!((lsb - 20.0 / 32768.0).abs() < 1e-9);
/// ```
pub fn calibration(shunt_ohm: f32, max_current_a: f32) -> Result<(u16, f32), Ina226Error> {
    let err = Ina226Error::BadCalibration {
        shunt_milliohm: (shunt_ohm * 1000.0) as u32,
        max_current_ma: (max_current_a * 1000.0) as u32,
    };
    if !(shunt_ohm > 0.0
        && max_current_a > 0.0
        && shunt_ohm.is_finite()
        && max_current_a.is_finite())
    {
        return Err(err);
    }
    let current_lsb_a = max_current_a / 32768.0;
    let cal = libm::truncf(0.00512 / (current_lsb_a * shunt_ohm));
    if !(1.0..=32767.0).contains(&cal) {
        return Err(err);
    }
    Ok((cal as u16, current_lsb_a))
}

/// The INA226 driver.
#[derive(Debug)]
pub struct Ina226<I2C> {
    i2c: I2C,
    address: u8,
    calibration: u16,
    current_lsb_a: f32,
}

impl<I2C: I2c> Ina226<I2C> {
    /// A driver for the chip at 7-bit `address` (0x40 with A0 = A1 = GND) on a shunt of
    /// `shunt_ohm` for currents up to `max_current_a`. Does no I/O; call [`Ina226::init`].
    pub fn new(
        i2c: I2C,
        address: u8,
        shunt_ohm: f32,
        max_current_a: f32,
    ) -> Result<Self, Ina226Error> {
        let (calibration, current_lsb_a) = calibration(shunt_ohm, max_current_a)?;
        Ok(Self {
            i2c,
            address,
            calibration,
            current_lsb_a,
        })
    }

    /// The calibration register value.
    pub fn calibration_register(&self) -> u16 {
        self.calibration
    }

    /// The current LSB, A.
    pub fn current_lsb_a(&self) -> f32 {
        self.current_lsb_a
    }

    /// Checks the manufacturer ID, writes the configuration and the calibration register.
    pub fn init(&mut self, config: u16) -> Result<(), Ina226Error> {
        let id = self.read_register(reg::MANUFACTURER_ID)?;
        if id != MANUFACTURER_ID {
            return Err(Ina226Error::WrongDevice { id });
        }
        self.write(reg::CONFIG, config)?;
        self.write(reg::CALIBRATION, self.calibration)
    }

    fn read_register(&mut self, register: u8) -> Result<u16, Ina226Error> {
        let mut buf = [0u8; 2];
        self.i2c
            .write_read(self.address, &[register], &mut buf)
            .map_err(|e| Ina226Error::I2c {
                register,
                kind: i2c::Error::kind(&e),
            })?;
        Ok(u16::from_be_bytes(buf))
    }

    fn write(&mut self, register: u8, value: u16) -> Result<(), Ina226Error> {
        let [hi, lo] = value.to_be_bytes();
        self.i2c
            .write(self.address, &[register, hi, lo])
            .map_err(|e| Ina226Error::I2c {
                register,
                kind: i2c::Error::kind(&e),
            })
    }

    /// Bus voltage, V.
    pub fn bus_voltage_v(&mut self) -> Result<f32, Ina226Error> {
        Ok(f32::from(self.read_register(reg::BUS_VOLTAGE)?) * BUS_LSB_V)
    }

    /// Shunt voltage, V (signed).
    pub fn shunt_voltage_v(&mut self) -> Result<f32, Ina226Error> {
        Ok(f32::from(self.read_register(reg::SHUNT_VOLTAGE)? as i16) * SHUNT_LSB_V)
    }

    /// Current, A (signed), from the current register.
    pub fn current_a(&mut self) -> Result<f32, Ina226Error> {
        Ok(f32::from(self.read_register(reg::CURRENT)? as i16) * self.current_lsb_a)
    }

    /// Power, W, from the power register.
    pub fn power_w(&mut self) -> Result<f32, Ina226Error> {
        Ok(f32::from(self.read_register(reg::POWER)?) * 25.0 * self.current_lsb_a)
    }

    /// Gives the bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }
}

impl<I2C: I2c> crate::PowerMonitor for Ina226<I2C> {
    type Error = Ina226Error;
    fn read(&mut self) -> Result<crate::PowerReading, Self::Error> {
        Ok(crate::PowerReading {
            voltage_v: self.bus_voltage_v()?,
            current_a: self.current_a()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

    const ADDR: u8 = 0x40;

    #[test]
    fn init_writes_config_and_calibration() {
        let expectations = [
            T::write_read(ADDR, vec![reg::MANUFACTURER_ID], vec![0x54, 0x49]),
            T::write(ADDR, vec![reg::CONFIG, 0x45, 0x27]),
            // 2 mΩ, 20 A -> CAL 4194 = 0x1062
            T::write(ADDR, vec![reg::CALIBRATION, 0x10, 0x62]),
        ];
        let mut i2c = Mock::new(&expectations);
        let mut ina = Ina226::new(i2c.clone(), ADDR, 0.002, 20.0).unwrap();
        assert_eq!(ina.calibration_register(), 4194);
        ina.init(DEFAULT_CONFIG).unwrap();
        i2c.done();
    }

    #[test]
    fn rejects_a_foreign_chip() {
        let mut i2c = Mock::new(&[T::write_read(
            ADDR,
            vec![reg::MANUFACTURER_ID],
            vec![0x12, 0x34],
        )]);
        let mut ina = Ina226::new(i2c.clone(), ADDR, 0.002, 20.0).unwrap();
        assert_eq!(
            ina.init(DEFAULT_CONFIG),
            Err(Ina226Error::WrongDevice { id: 0x1234 })
        );
        i2c.done();
    }

    #[test]
    fn converts_bus_shunt_current_and_power() {
        let expectations = [
            // 12.5 V / 1.25 mV = 10000 = 0x2710
            T::write_read(ADDR, vec![reg::BUS_VOLTAGE], vec![0x27, 0x10]),
            // -4 mV / 2.5 µV = -1600 = 0xF9C0
            T::write_read(ADDR, vec![reg::SHUNT_VOLTAGE], vec![0xF9, 0xC0]),
            // 3276.8 counts * (20/32768) = 2.0 A -> 3277 = 0x0CCD
            T::write_read(ADDR, vec![reg::CURRENT], vec![0x0C, 0xCD]),
            // 1000 * 25 * LSB = 15.26 W
            T::write_read(ADDR, vec![reg::POWER], vec![0x03, 0xE8]),
        ];
        let mut i2c = Mock::new(&expectations);
        let mut ina = Ina226::new(i2c.clone(), ADDR, 0.002, 20.0).unwrap();
        assert!((ina.bus_voltage_v().unwrap() - 12.5).abs() < 1e-4);
        assert!((ina.shunt_voltage_v().unwrap() + 0.004).abs() < 1e-7);
        assert!((ina.current_a().unwrap() - 2.0).abs() < 1e-3);
        assert!((ina.power_w().unwrap() - 1000.0 * 25.0 * 20.0 / 32768.0).abs() < 1e-3);
        i2c.done();
    }

    #[test]
    fn power_monitor_trait_reads_bus_then_current() {
        use crate::PowerMonitor;
        let expectations = [
            T::write_read(ADDR, vec![reg::BUS_VOLTAGE], vec![0x1C, 0x20]), // 7200 -> 9.0 V
            T::write_read(ADDR, vec![reg::CURRENT], vec![0xFF, 0x00]),     // -256 counts
        ];
        let mut i2c = Mock::new(&expectations);
        let mut ina = Ina226::new(i2c.clone(), ADDR, 0.002, 20.0).unwrap();
        let r = ina.read().unwrap();
        assert!((r.voltage_v - 9.0).abs() < 1e-4);
        assert!((r.current_a + 256.0 * 20.0 / 32768.0).abs() < 1e-5);
        i2c.done();
    }

    #[test]
    fn i2c_errors_carry_the_register() {
        let mut i2c = Mock::new(&[
            T::write_read(ADDR, vec![reg::CURRENT], vec![0, 0]).with_error(ErrorKind::Bus)
        ]);
        let mut ina = Ina226::new(i2c.clone(), ADDR, 0.002, 20.0).unwrap();
        assert_eq!(
            ina.current_a(),
            Err(Ina226Error::I2c {
                register: reg::CURRENT,
                kind: ErrorKind::Bus
            })
        );
        i2c.done();
    }

    #[test]
    fn bad_calibrations_are_rejected() {
        assert!(calibration(0.0, 10.0).is_err());
        assert!(calibration(10.0, 100.0).is_err()); // CAL < 1
        assert!(calibration(f32::NAN, 1.0).is_err());
    }
}
