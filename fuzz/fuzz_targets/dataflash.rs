//! Fuzz the ArduPilot DataFlash readers, binary and text: arbitrary bytes must never panic
//! them (as a raw log or as a flight), and a flight they accept keeps its invariants.
#![no_main]

use std::path::Path;

use flightlog::{Flight, LogFormat, dataflash::DataFlash};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for log in [
        DataFlash::parse(data, Path::new("fuzz.bin")),
        DataFlash::parse_text(data, Path::new("fuzz.log")),
    ]
    .into_iter()
    .flatten()
    {
        let _ = log.parameters();
        let _ = log.texts("MSG", "Message");
        for name in log.names() {
            let _ = log.rows(name, None, &[("TimeUS", false), ("Volt", false)], Path::new("f"));
        }
    }
    for (name, format) in [
        ("fuzz.bin", LogFormat::DataFlash),
        ("fuzz.log", LogFormat::DataFlashText),
    ] {
        if let Ok(f) = Flight::parse(data, Path::new(name), format) {
            assert!(f.samples.is_consistent());
            assert!(f.samples.len() >= 2);
            assert!(f.samples.voltage_v.iter().all(|v| *v > 0.0));
        }
    }
});
