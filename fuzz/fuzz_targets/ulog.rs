//! Fuzz the PX4 ULog reader: arbitrary bytes must never panic it (as a raw log or as a
//! flight), and a flight it accepts keeps its invariants.
#![no_main]

use std::path::Path;

use flightlog::{Flight, LogFormat, ulog::ULog};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(log) = ULog::parse(data, Path::new("fuzz.ulg")) {
        for topic in log.topics() {
            for instance in log.instances(topic) {
                let _ = log.rows(topic, instance, &[("timestamp", false)], Path::new("f"));
            }
        }
    }
    if let Ok(f) = Flight::parse(data, Path::new("fuzz.ulg"), LogFormat::Ulog) {
        assert!(f.samples.is_consistent());
        assert!(f.samples.len() >= 2);
        assert!(f.samples.voltage_v.iter().all(|v| *v > 0.0));
    }
});
