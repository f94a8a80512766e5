//! Fuzz the flight CSV readers (the generic `time_s,voltage_v,…` CSV and the Crazyflie
//! dataset's): arbitrary bytes must never panic them, and a flight they accept keeps its
//! invariants.
#![no_main]

use std::path::Path;

use flightlog::{Flight, LogFormat, crazyflie};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for format in [LogFormat::Csv, LogFormat::Crazyflie] {
        if let Ok(f) = Flight::parse(data, Path::new("fuzz.csv"), format) {
            assert!(f.samples.is_consistent());
            assert!(f.samples.time_s.windows(2).all(|w| w[1] > w[0]));
        }
    }
    let _ = crazyflie::parse_plan(data, Path::new("plan.csv"));
    let _ = LogFormat::detect(Path::new("fuzz.csv"), data);
});
