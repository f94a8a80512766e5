//! ESC output: a 1000–2000 µs servo pulse on a PWM channel ([`SetDutyCycle`]).
//!
//! The pulse width maps to a duty cycle `throttle_us / period_us × max_duty`. A 50 Hz frame
//! (20 000 µs) is the classic servo rate; most ESCs also take 400 Hz (2 500 µs).

use embedded_hal::pwm::{self, ErrorKind, SetDutyCycle};
use thiserror::Error;

/// Errors of the ESC driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum EscError {
    /// The PWM channel failed.
    #[error("ESC PWM error: {0:?}")]
    Pwm(ErrorKind),
    /// The PWM period is shorter than the longest pulse.
    #[error("PWM period {period_us} µs shorter than the maximum pulse {max_us} µs")]
    PeriodTooShort {
        /// The period.
        period_us: u32,
        /// The longest pulse.
        max_us: u16,
    },
}

/// The ESC driver.
#[derive(Debug)]
pub struct Esc<P> {
    pwm: P,
    period_us: u32,
    min_us: u16,
    max_us: u16,
}

impl<P: SetDutyCycle> Esc<P> {
    /// An ESC on `pwm` with a frame of `period_us` and pulses clamped to `min_us..=max_us`.
    pub fn new(pwm: P, period_us: u32, min_us: u16, max_us: u16) -> Result<Self, EscError> {
        if period_us < u32::from(max_us) || min_us > max_us {
            return Err(EscError::PeriodTooShort { period_us, max_us });
        }
        Ok(Self {
            pwm,
            period_us,
            min_us,
            max_us,
        })
    }

    /// Duty value for a pulse width (clamped) given the channel's maximum duty.
    pub fn duty_for(&self, throttle_us: u16, max_duty: u16) -> u16 {
        let us = u64::from(throttle_us.clamp(self.min_us, self.max_us));
        let duty =
            (us * u64::from(max_duty) + u64::from(self.period_us) / 2) / u64::from(self.period_us);
        duty.min(u64::from(max_duty)) as u16
    }

    /// Outputs a pulse of `throttle_us` (clamped to the range).
    pub fn set_pulse_us(&mut self, throttle_us: u16) -> Result<(), EscError> {
        let max = self.pwm.max_duty_cycle();
        let duty = self.duty_for(throttle_us, max);
        self.pwm
            .set_duty_cycle(duty)
            .map_err(|e| EscError::Pwm(pwm::Error::kind(&e)))
    }

    /// Gives the channel back.
    pub fn release(self) -> P {
        self.pwm
    }
}

impl<P: SetDutyCycle> crate::ThrottleOutput for Esc<P> {
    type Error = EscError;
    fn set_throttle_us(&mut self, throttle_us: u16) -> Result<(), Self::Error> {
        self.set_pulse_us(throttle_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::pwm::{Mock, Transaction as T};

    #[test]
    fn maps_pulses_to_duty_and_clamps() {
        // 400 Hz frame (2500 µs), 16-bit-ish timer with max duty 25 000 -> 10 counts per µs
        let expectations = [
            T::max_duty_cycle(25_000),
            T::set_duty_cycle(10_000),
            T::max_duty_cycle(25_000),
            T::set_duty_cycle(15_000),
            T::max_duty_cycle(25_000),
            T::set_duty_cycle(20_000), // 2300 µs clamped to 2000
            T::max_duty_cycle(25_000),
            T::set_duty_cycle(10_000), // 0 clamped to 1000
        ];
        let mut pwm = Mock::new(&expectations);
        let mut esc = Esc::new(pwm.clone(), 2500, 1000, 2000).unwrap();
        for us in [1000, 1500, 2300, 0] {
            esc.set_pulse_us(us).unwrap();
        }
        pwm.done();
    }

    #[test]
    fn rejects_a_short_period() {
        let mut pwm = Mock::new(&[]);
        assert!(Esc::new(pwm.clone(), 1500, 1000, 2000).is_err());
        pwm.done();
    }
}
