//! HX711 24-bit load-cell ADC, bit-banged over two GPIOs (PD_SCK out, DOUT in).
//!
//! Protocol (datasheet): DOUT goes low when a conversion is ready. The host then clocks 24
//! PD_SCK pulses, reading DOUT (MSB first, two's complement) after each rising edge, followed
//! by 1–3 extra pulses that choose channel and gain for the *next* conversion (25 = A/128,
//! 26 = B/32, 27 = A/64). Holding PD_SCK high for more than 60 µs powers the chip down; taking
//! it low powers it up again (it then resets to A/128). The output rate (10 or 80 SPS) is set
//! by the RATE pin, driven here through an optional output pin ([`FixedRate`] when the pin is
//! strapped on the board).

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{self, ErrorKind, InputPin, OutputPin};
use thiserror::Error;

/// Errors of the HX711 driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum Hx711Error {
    /// A GPIO operation failed.
    #[error("HX711 {pin} pin error: {kind:?}")]
    Pin {
        /// Which pin.
        pin: &'static str,
        /// What the HAL reported.
        kind: ErrorKind,
    },
}

fn pin_err<E: digital::Error>(pin: &'static str) -> impl Fn(E) -> Hx711Error {
    move |e| Hx711Error::Pin {
        pin,
        kind: e.kind(),
    }
}

/// Channel and gain of the next conversion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Gain {
    /// Channel A, gain 128 (25 pulses). The power-on default.
    #[default]
    A128,
    /// Channel B, gain 32 (26 pulses).
    B32,
    /// Channel A, gain 64 (27 pulses).
    A64,
}

impl Gain {
    /// Total PD_SCK pulses per read for this gain.
    pub const fn pulses(self) -> u8 {
        match self {
            Gain::A128 => 25,
            Gain::B32 => 26,
            Gain::A64 => 27,
        }
    }
}

/// Output data rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rate {
    /// 10 samples per second (RATE pin low): better noise rejection.
    #[default]
    Sps10,
    /// 80 samples per second (RATE pin high).
    Sps80,
}

impl Rate {
    /// Samples per second.
    pub const fn sps(self) -> u32 {
        match self {
            Rate::Sps10 => 10,
            Rate::Sps80 => 80,
        }
    }
}

/// A RATE "pin" for boards that strap RATE in hardware: setting it does nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct FixedRate;

impl digital::ErrorType for FixedRate {
    type Error = core::convert::Infallible;
}

impl OutputPin for FixedRate {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Half period of PD_SCK, µs (the datasheet needs ≥ 0.2 µs and < 50 µs high).
const HALF_PERIOD_US: u32 = 1;
/// PD_SCK high time that powers the chip down, µs (> 60 µs).
const POWER_DOWN_US: u32 = 80;

/// The HX711 driver.
#[derive(Debug)]
pub struct Hx711<SCK, DOUT, RATE, D> {
    sck: SCK,
    dout: DOUT,
    rate_pin: RATE,
    delay: D,
    gain: Gain,
    rate: Rate,
}

impl<SCK: OutputPin, DOUT: InputPin, RATE: OutputPin, D: DelayNs> Hx711<SCK, DOUT, RATE, D> {
    /// A driver on the given pins. Does not touch them; call [`Hx711::init`].
    pub fn new(sck: SCK, dout: DOUT, rate_pin: RATE, delay: D) -> Self {
        Self {
            sck,
            dout,
            rate_pin,
            delay,
            gain: Gain::A128,
            rate: Rate::Sps10,
        }
    }

    /// Powers the chip up (PD_SCK low) and sets the rate and the gain of the next conversion.
    pub fn init(&mut self, gain: Gain, rate: Rate) -> Result<(), Hx711Error> {
        self.sck.set_low().map_err(pin_err("PD_SCK"))?;
        self.set_rate(rate)?;
        self.gain = gain;
        Ok(())
    }

    /// Drives the RATE pin.
    pub fn set_rate(&mut self, rate: Rate) -> Result<(), Hx711Error> {
        match rate {
            Rate::Sps10 => self.rate_pin.set_low(),
            Rate::Sps80 => self.rate_pin.set_high(),
        }
        .map_err(pin_err("RATE"))?;
        self.rate = rate;
        Ok(())
    }

    /// The configured rate.
    pub fn rate(&self) -> Rate {
        self.rate
    }

    /// Chooses channel/gain; takes effect from the conversion after the next read.
    pub fn set_gain(&mut self, gain: Gain) {
        self.gain = gain;
    }

    /// Whether a conversion is ready (DOUT low).
    pub fn is_ready(&mut self) -> Result<bool, Hx711Error> {
        self.dout.is_low().map_err(pin_err("DOUT"))
    }

    /// Reads a conversion if one is ready (`Ok(None)` otherwise). Never blocks.
    pub fn read_raw(&mut self) -> Result<Option<i32>, Hx711Error> {
        if !self.is_ready()? {
            return Ok(None);
        }
        let mut value: u32 = 0;
        for _ in 0..24 {
            self.sck.set_high().map_err(pin_err("PD_SCK"))?;
            self.delay.delay_us(HALF_PERIOD_US);
            let bit = self.dout.is_high().map_err(pin_err("DOUT"))?;
            self.sck.set_low().map_err(pin_err("PD_SCK"))?;
            self.delay.delay_us(HALF_PERIOD_US);
            value = (value << 1) | u32::from(bit);
        }
        for _ in 24..self.gain.pulses() {
            self.sck.set_high().map_err(pin_err("PD_SCK"))?;
            self.delay.delay_us(HALF_PERIOD_US);
            self.sck.set_low().map_err(pin_err("PD_SCK"))?;
            self.delay.delay_us(HALF_PERIOD_US);
        }
        // Sign-extend the 24-bit two's complement value.
        Ok(Some(((value << 8) as i32) >> 8))
    }

    /// Powers the chip down (PD_SCK high for > 60 µs).
    pub fn power_down(&mut self) -> Result<(), Hx711Error> {
        self.sck.set_low().map_err(pin_err("PD_SCK"))?;
        self.sck.set_high().map_err(pin_err("PD_SCK"))?;
        self.delay.delay_us(POWER_DOWN_US);
        Ok(())
    }

    /// Powers the chip up again; it restarts at channel A, gain 128.
    pub fn power_up(&mut self) -> Result<(), Hx711Error> {
        self.sck.set_low().map_err(pin_err("PD_SCK"))?;
        self.gain = Gain::A128;
        Ok(())
    }

    /// Gives the pins and the delay back.
    pub fn release(self) -> (SCK, DOUT, RATE, D) {
        (self.sck, self.dout, self.rate_pin, self.delay)
    }
}

impl<SCK: OutputPin, DOUT: InputPin, RATE: OutputPin, D: DelayNs> crate::LoadCellAdc
    for Hx711<SCK, DOUT, RATE, D>
{
    type Error = Hx711Error;
    fn try_read_raw(&mut self) -> Result<Option<i32>, Self::Error> {
        self.read_raw()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::delay::NoopDelay;
    use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as T};

    /// Expected pin transactions of one read of `value` with `pulses` pulses.
    fn read_transactions(value: i32, pulses: u8) -> (Vec<T>, Vec<T>) {
        let raw = (value as u32) & 0x00FF_FFFF;
        let mut sck = Vec::new();
        let mut dout = vec![T::get(State::Low)]; // ready
        for i in (0..24).rev() {
            sck.push(T::set(State::High));
            dout.push(T::get(if raw >> i & 1 == 1 {
                State::High
            } else {
                State::Low
            }));
            sck.push(T::set(State::Low));
        }
        for _ in 24..pulses {
            sck.push(T::set(State::High));
            sck.push(T::set(State::Low));
        }
        (sck, dout)
    }

    #[test]
    fn reads_positive_and_negative_values_with_each_gain() {
        for (value, gain) in [
            (0x12_3456, Gain::A128),
            (-1234, Gain::B32),
            (-8_388_608, Gain::A64),
            (8_388_607, Gain::A128),
        ] {
            let (mut sck_t, dout_t) = read_transactions(value, gain.pulses());
            sck_t.insert(0, T::set(State::Low)); // init
            let rate_t = [T::set(State::High)];
            let mut sck = PinMock::new(&sck_t);
            let mut dout = PinMock::new(&dout_t);
            let mut rate = PinMock::new(&rate_t);
            let mut adc = Hx711::new(sck.clone(), dout.clone(), rate.clone(), NoopDelay::new());
            adc.init(gain, Rate::Sps80).unwrap();
            assert_eq!(adc.rate().sps(), 80);
            assert_eq!(adc.read_raw().unwrap(), Some(value));
            sck.done();
            dout.done();
            rate.done();
        }
    }

    #[test]
    fn not_ready_reads_nothing() {
        let mut sck = PinMock::new(&[]);
        let mut dout = PinMock::new(&[T::get(State::High)]);
        let mut adc = Hx711::new(sck.clone(), dout.clone(), FixedRate, NoopDelay::new());
        assert_eq!(adc.read_raw().unwrap(), None);
        sck.done();
        dout.done();
    }

    #[test]
    fn power_down_and_up() {
        let mut sck = PinMock::new(&[T::set(State::Low), T::set(State::High), T::set(State::Low)]);
        let mut dout = PinMock::new(&[]);
        let mut adc = Hx711::new(sck.clone(), dout.clone(), FixedRate, NoopDelay::new());
        adc.set_gain(Gain::B32);
        adc.power_down().unwrap();
        adc.power_up().unwrap();
        let (_, _, _, _) = adc.release();
        sck.done();
        dout.done();
    }

    #[test]
    fn pin_errors_are_reported() {
        use embedded_hal_mock::eh1::MockError;
        let err = MockError::Io(std::io::ErrorKind::Other);
        let mut sck = PinMock::new(&[]);
        let mut dout = PinMock::new(&[T::get(State::Low).with_error(err)]);
        let mut adc = Hx711::new(sck.clone(), dout.clone(), FixedRate, NoopDelay::new());
        assert!(matches!(
            adc.read_raw(),
            Err(Hx711Error::Pin { pin: "DOUT", .. })
        ));
        sck.done();
        dout.done();
    }
}
