//! Simulated peripherals behind embedded-hal 1.0 traits, so the firmware's real drivers
//! (HX711 bit-banging, INA226 over I²C, ESC PWM) run unchanged against the simulated bench.

use crate::world::World;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{self, InputPin, OutputPin};
use embedded_hal::i2c::{self, I2c, Operation};
use embedded_hal::pwm::{self, SetDutyCycle};
use rig_protocol::Clock;
use std::cell::{Cell, RefCell};
use std::convert::Infallible;
use std::rc::Rc;

/// Shared handle to the bench.
pub type Shared = Rc<RefCell<World>>;

/// I²C address of the simulated INA226.
pub const INA226_ADDRESS: u8 = 0x40;
/// PWM frame of the simulated ESC output, µs (400 Hz).
pub const PWM_PERIOD_US: u32 = 2500;
/// Maximum duty value of the simulated PWM channel.
pub const PWM_MAX_DUTY: u16 = 20_000;

/// The simulated clock: simulated microseconds, advanced by the simulation loop.
#[derive(Debug, Clone, Default)]
pub struct SimClock(pub(crate) Rc<Cell<u64>>);

impl Clock for SimClock {
    fn now_us(&self) -> u64 {
        self.0.get()
    }
}

/// A delay that returns at once (simulated bit-banging takes no simulated time).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoDelay;

impl DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// HX711 PD_SCK pin.
#[derive(Debug, Clone)]
pub struct SimSck(pub(crate) Shared);
/// HX711 DOUT pin.
#[derive(Debug, Clone)]
pub struct SimDout(pub(crate) Shared);

impl digital::ErrorType for SimSck {
    type Error = Infallible;
}
impl digital::ErrorType for SimDout {
    type Error = Infallible;
}

impl OutputPin for SimSck {
    fn set_high(&mut self) -> Result<(), Infallible> {
        let mut w = self.0.borrow_mut();
        let hx = &mut w.hx;
        if !hx.sck_high && hx.ready {
            hx.pulses += 1;
            if hx.pulses <= 24 {
                hx.dout_high = (hx.data >> (24 - hx.pulses)) & 1 == 1;
            } else {
                hx.dout_high = true; // gain-select pulses: DOUT back high
            }
        }
        hx.sck_high = true;
        Ok(())
    }

    fn set_low(&mut self) -> Result<(), Infallible> {
        let mut w = self.0.borrow_mut();
        let period = 1_000_000 / u64::from(w.load_cell.rate_sps.max(1));
        let hx = &mut w.hx;
        hx.sck_high = false;
        if hx.ready && hx.pulses >= 25 {
            hx.ready = false;
            hx.pulses = 0;
            hx.dout_high = true;
            hx.next_conversion_us += period;
        }
        Ok(())
    }
}

impl SimDout {
    fn level_high(&mut self) -> bool {
        let mut w = self.0.borrow_mut();
        let now = w.now_us();
        if !w.hx.ready && !w.hx.sck_high && now >= w.hx.next_conversion_us {
            let period = 1_000_000 / u64::from(w.load_cell.rate_sps.max(1));
            if now >= w.hx.next_conversion_us + period {
                // the host skipped conversions; the chip keeps its own cadence
                w.hx.next_conversion_us = now - (now - w.hx.next_conversion_us) % period;
            }
            let data = w.convert_load_cell();
            w.hx.data = data;
            w.hx.ready = true;
            w.hx.pulses = 0;
            w.hx.dout_high = false;
        }
        w.hx.dout_high
    }
}

impl InputPin for SimDout {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.level_high())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.level_high())
    }
}

/// I²C error of the simulated bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimI2cError(pub i2c::ErrorKind);

impl i2c::Error for SimI2cError {
    fn kind(&self) -> i2c::ErrorKind {
        self.0
    }
}

/// I²C bus with a simulated INA226 at [`INA226_ADDRESS`].
#[derive(Debug, Clone)]
pub struct SimI2c(pub(crate) Shared);

impl i2c::ErrorType for SimI2c {
    type Error = SimI2cError;
}

impl SimI2c {
    fn read_register(&self, reg: u8) -> u16 {
        let mut w = self.0.borrow_mut();
        match reg {
            0x00 => w.ina.config,
            0x01 => w.shunt_voltage_register() as u16,
            0x02 => w.bus_voltage_register(),
            0x03 => {
                let shunt = i32::from(w.shunt_voltage_register());
                let bus = i32::from(w.bus_voltage_register());
                let current = shunt * i32::from(w.ina.calibration) / 2048;
                (current.unsigned_abs() * bus as u32 / 20_000).min(0xFFFF) as u16
            }
            0x04 => {
                let shunt = i32::from(w.shunt_voltage_register());
                (shunt * i32::from(w.ina.calibration) / 2048).clamp(-32768, 32767) as i16 as u16
            }
            0x05 => w.ina.calibration,
            0xFE => 0x5449,
            0xFF => 0x2260,
            _ => 0,
        }
    }
}

impl I2c for SimI2c {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), SimI2cError> {
        if address != INA226_ADDRESS {
            return Err(SimI2cError(i2c::ErrorKind::NoAcknowledge(
                i2c::NoAcknowledgeSource::Address,
            )));
        }
        for op in operations {
            match op {
                Operation::Write(bytes) => {
                    if let Some(&reg) = bytes.first() {
                        self.0.borrow_mut().ina.pointer = reg;
                    }
                    if bytes.len() >= 3 {
                        let value = u16::from_be_bytes([bytes[1], bytes[2]]);
                        let mut w = self.0.borrow_mut();
                        match bytes[0] {
                            0x00 => w.ina.config = value,
                            0x05 => w.ina.calibration = value & 0x7FFF,
                            _ => {}
                        }
                    }
                }
                Operation::Read(buf) => {
                    let reg = self.0.borrow().ina.pointer;
                    let v = self.read_register(reg).to_be_bytes();
                    for (i, b) in buf.iter_mut().enumerate() {
                        *b = v.get(i).copied().unwrap_or(0xFF);
                    }
                }
            }
        }
        Ok(())
    }
}

/// PWM channel driving the simulated ESC.
#[derive(Debug, Clone)]
pub struct SimPwm(pub(crate) Shared);

impl pwm::ErrorType for SimPwm {
    type Error = Infallible;
}

impl SetDutyCycle for SimPwm {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        let us = f64::from(duty) * f64::from(PWM_PERIOD_US) / f64::from(PWM_MAX_DUTY);
        self.0.borrow_mut().throttle_us = us;
        Ok(())
    }
}

/// A watchdog that records when it was last fed.
#[derive(Debug, Clone, Default)]
pub struct SimWatchdog {
    pub(crate) clock: SimClock,
    pub(crate) last_feed_us: Rc<Cell<u64>>,
    pub(crate) feeds: Rc<Cell<u64>>,
}

impl rig_firmware::Watchdog for SimWatchdog {
    fn feed(&mut self) {
        self.last_feed_us.set(self.clock.now_us());
        self.feeds.set(self.feeds.get() + 1);
    }
}
