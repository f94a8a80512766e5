//! Fuzz the bench-supply side: every reply parser on arbitrary bytes (none may panic, and
//! what they accept must be finite), and the simulated supply's command interpreters of both
//! dialects on arbitrary input (the first byte picks the dialect and how the input is split
//! into writes).
#![no_main]

use std::io::{Read, Write};
use std::time::Duration;

use libfuzzer_sys::fuzz_target;
use supply::Transport;
use supply::parse;
use supply::sim::{Device, Dialect, ResistiveLoad, SimConfig};

fuzz_target!(|data: &[u8]| {
    if let Ok(v) = parse::number(data) {
        assert!(v.is_finite());
    }
    if let Ok(v) = parse::korad_number(data) {
        assert!(v.is_finite() && v >= 0.0);
    }
    if let Ok(m) = parse::scpi_measure_all(data) {
        assert!(m.voltage_v.is_finite() && m.current_a.is_finite());
    }
    if let Ok((v, i)) = parse::scpi_applied(data) {
        assert!(v >= 0.0 && i >= 0.0);
    }
    if let Ok(id) = parse::identity(data) {
        assert!(!id.is_empty());
    }
    let _ = parse::scpi_mode(data);
    let _ = parse::scpi_output_state(data);
    let _ = parse::korad_status(data);

    let Some((&head, rest)) = data.split_first() else {
        return;
    };
    let dialect = if head & 1 == 0 {
        Dialect::Scpi
    } else {
        Dialect::Korad
    };
    let chunk = usize::from(head >> 1).max(1);
    let config = SimConfig {
        min_command_gap: Duration::ZERO,
        ..SimConfig::default()
    };
    let device = Device::new(
        dialect,
        ResistiveLoad {
            resistance_ohm: 3.0,
        },
        config,
    );
    let mut link = device.connect();
    let _ = link.set_read_timeout(Duration::ZERO);
    let mut reply = [0u8; 512];
    for piece in rest.chunks(chunk) {
        let _ = link.write(piece);
    }
    // Reading completes whatever is pending; nothing may panic.
    let _ = link.read(&mut reply);
    let s = device.settings();
    assert!((0.0..=device.config().rating_voltage_v).contains(&s.voltage_v));
    assert!((0.0..=device.config().rating_current_a).contains(&s.current_limit_a));
    let out = device.output();
    assert!(out.voltage_v.is_finite() && out.current_a.is_finite());
});
