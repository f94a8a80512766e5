//! A monotonic 64-bit microsecond clock from a free-running, wrapping 32-bit counter
//! (a SysTick-style or timer peripheral).
//!
//! The counter must be read at least once per wrap (at 1 MHz: every 71 minutes), which the
//! firmware's main loop does thousands of times a second.

use core::cell::Cell;
use rig_protocol::Clock;

/// A free-running, wrapping 32-bit tick counter.
pub trait TickCounter {
    /// The current count.
    fn ticks(&self) -> u32;
}

impl<F: Fn() -> u32> TickCounter for F {
    fn ticks(&self) -> u32 {
        self()
    }
}

/// Extends a wrapping [`TickCounter`] to a monotonic [`Clock`].
#[derive(Debug)]
pub struct MonotonicClock<T> {
    counter: T,
    ticks_per_us: u32,
    last: Cell<u32>,
    total_ticks: Cell<u64>,
}

impl<T: TickCounter> MonotonicClock<T> {
    /// A clock on `counter` running at `ticks_per_us` MHz (≥ 1).
    pub fn new(counter: T, ticks_per_us: u32) -> Self {
        let last = counter.ticks();
        Self {
            counter,
            ticks_per_us: ticks_per_us.max(1),
            last: Cell::new(last),
            total_ticks: Cell::new(0),
        }
    }
}

impl<T: TickCounter> Clock for MonotonicClock<T> {
    fn now_us(&self) -> u64 {
        let now = self.counter.ticks();
        let delta = now.wrapping_sub(self.last.get());
        self.last.set(now);
        self.total_ticks
            .set(self.total_ticks.get() + u64::from(delta));
        self.total_ticks.get() / u64::from(self.ticks_per_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survives_wraparound() {
        let raw = Cell::new(u32::MAX - 100);
        let clock = MonotonicClock::new(|| raw.get(), 1);
        assert_eq!(clock.now_us(), 0);
        raw.set(u32::MAX);
        assert_eq!(clock.now_us(), 100);
        raw.set(50); // wrapped
        assert_eq!(clock.now_us(), 151);
        for _ in 0..3 {
            raw.set(raw.get().wrapping_add(2_000_000_000));
            clock.now_us();
        }
        assert_eq!(clock.now_us(), 6_000_000_151);
    }

    #[test]
    fn divides_ticks() {
        let raw = Cell::new(0u32);
        let clock = MonotonicClock::new(|| raw.get(), 125);
        raw.set(125_000);
        assert_eq!(clock.now_us(), 1000);
    }
}
