//! Flight sets as files: the CSV and TOML a generated set is written as (the same format
//! `flightlog` reads), and the truth beside them.

use std::fmt::Write as _;

use crate::flight::FlightRecord;

/// A flight as `NAME.csv`: `time_s,voltage_v,current_a,phase,altitude_m`.
pub fn flight_csv(f: &FlightRecord) -> String {
    let mut s = String::with_capacity(f.time_s.len() * 48);
    s.push_str("time_s,voltage_v");
    if f.current_a.is_some() {
        s.push_str(",current_a");
    }
    s.push_str(",phase");
    if f.altitude_m.is_some() {
        s.push_str(",altitude_m");
    }
    s.push('\n');
    for i in 0..f.time_s.len() {
        let _ = write!(s, "{},{:.4}", f.time_s[i], f.voltage_v[i]);
        if let Some(c) = &f.current_a {
            let _ = write!(s, ",{:.4}", c[i]);
        }
        let _ = write!(s, ",{}", f.phase[i].name());
        if let Some(z) = &f.altitude_m {
            let _ = write!(s, ",{:.3}", z[i]);
        }
        s.push('\n');
    }
    s
}

/// A flight's metadata as its sidecar `NAME.toml`.
pub fn sidecar_toml(f: &FlightRecord) -> String {
    let i = &f.info;
    let mut s = String::new();
    let _ = writeln!(s, "structure_mass_kg = {}", i.structure_mass_kg);
    let _ = writeln!(s, "battery_mass_kg = {}", i.battery_mass_kg);
    let _ = writeln!(s, "battery_energy_wh = {}", i.battery_energy_wh);
    let _ = writeln!(s, "cells = {}", i.cells);
    let _ = writeln!(s, "payload_mass_kg = {}", i.payload_mass_kg);
    let _ = writeln!(s, "payload_power_w = {}", i.payload_power_w);
    let _ = writeln!(s, "avionics_power_w = {}", i.avionics_power_w);
    if let Some(b) = &i.battery_id {
        let _ = writeln!(s, "battery_id = {b:?}");
    }
    if let Some(c) = i.battery_cycles {
        let _ = writeln!(s, "battery_cycles = {c}");
    }
    if let Some(t) = i.ambient_temperature_c {
        let _ = writeln!(s, "ambient_temperature_c = {t}");
    }
    if let Some(r) = i.air_density_kg_m3 {
        let _ = writeln!(s, "air_density_kg_m3 = {r}");
    }
    let _ = writeln!(s, "cutoff_voltage_v = {}", i.cutoff_voltage_v);
    let _ = writeln!(
        s,
        "end = \"{}\"",
        if i.ended_at_cutoff {
            "cutoff"
        } else {
            "landed"
        }
    );
    s
}
