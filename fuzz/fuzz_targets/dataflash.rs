//! Fuzz the ArduPilot DataFlash reader: arbitrary bytes must never panic it (as a raw log or
//! as a flight), and a flight it accepts keeps its invariants.
#![no_main]

use std::path::Path;

use flightlog::{Flight, LogFormat, dataflash::DataFlash};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(log) = DataFlash::parse(data, Path::new("fuzz.bin")) {
        let _ = log.parameters();
        let _ = log.texts("MSG", "Message");
        for name in log.names() {
            let _ = log.rows(name, None, &[("TimeUS", false), ("Volt", false)], Path::new("f"));
        }
    }
    if let Ok(f) = Flight::parse(data, Path::new("fuzz.bin"), LogFormat::DataFlash) {
        assert!(f.samples.is_consistent());
        assert!(f.samples.len() >= 2);
        assert!(f.samples.voltage_v.iter().all(|v| *v > 0.0));
    }
});
