//! The simulated bench's coupling: the simulated supply, driven over its pseudo-terminal, sets
//! the simulated rig's bus voltage, and the rig's current is the supply's load.

#![cfg(unix)]

use std::time::{Duration, Instant};

use rig_host::bench_supply::{Dialect, SupplyControl, SupplyMonitor, open_supply};
use rig_host::simbench::{SimBench, SimBenchOptions};
use rig_host::supply::RegulationMode;

fn bus_v(b: &SimBench) -> f64 {
    b.rig_snapshot()
        .truth
        .map_or(f64::NAN, |t| t.electrical.bus_voltage_v)
}

fn eventually(what: &str, mut f: impl FnMut() -> bool) {
    let end = Instant::now() + Duration::from_secs(20);
    while !f() {
        assert!(Instant::now() < end, "timed out: {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn the_supply_sets_the_rig_bus_and_sees_its_load() {
    for dialect in [Dialect::Scpi, Dialect::Korad] {
        let b = SimBench::spawn(
            sim::presets::paper(),
            SimBenchOptions {
                dialect,
                ..SimBenchOptions::default()
            },
        )
        .unwrap();
        // Output off at power-up: no bus voltage.
        eventually("a dead bus", || bus_v(&b) == 0.0);
        let mut psu = SupplyMonitor::start(open_supply(b.supply_path(), dialect).unwrap()).unwrap();
        psu.apply(9.0, 5.0).unwrap();
        psu.set_output(true).unwrap();
        eventually("9 V on the rig's bus", || (bus_v(&b) - 9.0).abs() < 1e-3);
        eventually("constant voltage", || {
            psu.status().unwrap().mode == RegulationMode::ConstantVoltage
        });
        psu.set_output(false).unwrap();
        eventually("the bus off again", || bus_v(&b) == 0.0);
        assert!(b.supply_device().stats().commands > 3, "{dialect}");
    }
}
