//! Peripheral drivers, generic over embedded-hal 1.0 traits.

pub mod clock;
pub mod esc;
pub mod hx711;
pub mod ina226;
