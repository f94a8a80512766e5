//! Fuzz the MAVLink telemetry-log reader: arbitrary bytes must never panic it (as packets or
//! as a flight), and a flight it accepts keeps its invariants.
#![no_main]

use std::path::Path;

use flightlog::{Flight, LogFormat, tlog::Tlog};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(log) = Tlog::parse(data, Path::new("fuzz.tlog")) {
        assert!(log.packets.windows(2).all(|w| w[1].offset > w[0].offset));
    }
    if let Ok(f) = Flight::parse(data, Path::new("fuzz.tlog"), LogFormat::Tlog) {
        assert!(f.samples.is_consistent());
        assert!(f.samples.len() >= 2);
        assert!(f.samples.voltage_v.iter().all(|v| *v > 0.0));
    }
});
