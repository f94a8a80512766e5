//! Drivers against the simulated supply over real pseudo-terminals, opened with `serialport`
//! exactly as a USB port would be.
#![cfg(unix)]

use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use supply::sim::{Dialect, Faults, ResistiveLoad, SimConfig, SimulatedSupply};
use supply::{
    KoradConfig, KoradSupply, RegulationMode, ScpiConfig, ScpiSupply, SerialSettings, Supply,
    SupplyError, Timing,
};

const REPLY_TIMEOUT: Duration = Duration::from_millis(250);

/// A simulated supply that counts pacing violations but does not drop the commands: over a
/// pseudo-terminal on a loaded machine the simulator timestamps bytes when its thread gets to
/// read them, so well-paced commands can look bunched. The exact pacing checks are in
/// `in_process.rs`; the dedicated tests below use the strict simulator.
fn sim(dialect: Dialect, load_ohm: f64) -> SimulatedSupply {
    SimulatedSupply::spawn(
        dialect,
        ResistiveLoad {
            resistance_ohm: load_ohm,
        },
        SimConfig {
            strict_pacing: false,
            ..SimConfig::default()
        },
    )
    .expect("pseudo-terminal")
}

fn strict_sim(dialect: Dialect, load_ohm: f64) -> SimulatedSupply {
    SimulatedSupply::spawn(
        dialect,
        ResistiveLoad {
            resistance_ohm: load_ohm,
        },
        SimConfig::default(),
    )
    .expect("pseudo-terminal")
}

fn scpi(sim: &SimulatedSupply) -> ScpiSupply<Box<dyn serialport::SerialPort>> {
    let config = ScpiConfig {
        timing: Timing {
            reply_timeout: REPLY_TIMEOUT,
            ..ScpiConfig::default().timing
        },
        ..ScpiConfig::default()
    };
    ScpiSupply::open(sim.port_path(), SerialSettings::default(), config).expect("open pty")
}

fn korad_config() -> KoradConfig {
    KoradConfig {
        timing: Timing {
            reply_timeout: REPLY_TIMEOUT,
            ..KoradConfig::default().timing
        },
        ..KoradConfig::default()
    }
}

fn korad(sim: &SimulatedSupply) -> KoradSupply<Box<dyn serialport::SerialPort>> {
    KoradSupply::open(sim.port_path(), SerialSettings::default(), korad_config()).expect("open pty")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

// ---- SCPI ----------------------------------------------------------------------------------

#[test]
fn scpi_set_and_measure_round_trip() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    assert!(
        psu.identify()
            .unwrap()
            .starts_with("RIGOL TECHNOLOGIES,DP832")
    );
    psu.apply(12.5, 5.0).unwrap();
    assert_eq!(psu.setpoints().unwrap(), (12.5, 5.0));
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert!(
        close(m.voltage_v, 12.5) && close(m.current_a, 1.25),
        "{m:?}"
    );
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantVoltage);
    // One set-point at a time keeps the other.
    psu.set_voltage(10.0).unwrap();
    assert_eq!(psu.setpoints().unwrap(), (10.0, 5.0));
    let log = sim.device().command_log();
    assert!(log.iter().any(|c| c == ":APPL CH1,12.5,5"), "{log:?}");
    assert!(log.iter().any(|c| c == ":APPL CH1,10,5"), "{log:?}");
}

#[test]
fn scpi_output_on_off() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    psu.apply(5.0, 1.0).unwrap();
    assert_eq!(psu.mode().unwrap(), RegulationMode::Off);
    let m = psu.measure().unwrap();
    assert_eq!((m.voltage_v, m.current_a), (0.0, 0.0));
    psu.set_output(true).unwrap();
    assert!(psu.output_on().unwrap());
    assert!(close(psu.measure_voltage().unwrap(), 5.0));
    psu.set_output(false).unwrap();
    assert!(!sim.device().settings().output_on);
    assert_eq!(psu.mode().unwrap(), RegulationMode::Off);
}

#[test]
fn scpi_constant_current_when_the_load_exceeds_the_limit() {
    let sim = sim(Dialect::Scpi, 2.0);
    let mut psu = scpi(&sim);
    // 12 V into 2 Ω would be 6 A: held at 3 A, so 6 V.
    psu.apply(12.0, 3.0).unwrap();
    psu.set_output(true).unwrap();
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantCurrent);
    let m = psu.measure().unwrap();
    assert!(close(m.voltage_v, 6.0) && close(m.current_a, 3.0), "{m:?}");
    // Lower the set-point below the limit's reach: back to constant voltage.
    psu.set_voltage(5.0).unwrap();
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantVoltage);
    assert!(close(psu.measure_current().unwrap(), 2.5));
}

#[test]
fn scpi_source_resistance_sags_the_output() {
    let sim = sim(Dialect::Scpi, 5.5);
    sim.device().set_source_resistance_ohm(0.5);
    let mut psu = scpi(&sim);
    psu.apply(12.0, 5.0).unwrap();
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert!(close(m.voltage_v, 11.0) && close(m.current_a, 2.0), "{m:?}");
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantVoltage);
}

#[test]
fn scpi_retries_a_dropped_reply_and_a_garbled_one() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    psu.apply(10.0, 2.0).unwrap();
    psu.set_output(true).unwrap();
    sim.device().set_faults(Faults {
        drop_replies: 1,
        ..Faults::default()
    });
    assert!(close(psu.measure_current().unwrap(), 1.0));
    sim.device().set_faults(Faults {
        corrupt_replies: 1,
        ..Faults::default()
    });
    assert!(close(psu.measure_voltage().unwrap(), 10.0));
    assert_eq!(sim.device().stats().faulted_replies, 2);
    let measures = sim
        .device()
        .command_log()
        .iter()
        .filter(|c| c.as_str() == ":MEAS:ALL? CH1")
        .count();
    assert!(measures >= 4, "each faulted query was sent again");
}

#[test]
fn scpi_bad_replies_exhaust_the_retries() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    sim.device().set_faults(Faults {
        corrupt_replies: 10,
        ..Faults::default()
    });
    match psu.measure() {
        Err(SupplyError::BadReply {
            command,
            reply,
            attempts,
            ..
        }) => {
            assert_eq!(command, ":MEAS:ALL? CH1");
            assert_eq!(reply.0, b"?#!%&");
            assert_eq!(attempts, 3);
        }
        other => panic!("expected a bad reply, got {other:?}"),
    }
}

#[test]
fn scpi_silent_supply_times_out() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    sim.device().set_faults(Faults {
        silent: true,
        ..Faults::default()
    });
    let start = Instant::now();
    let err = psu.identify().unwrap_err();
    assert!(start.elapsed() >= REPLY_TIMEOUT * 3);
    match &err {
        SupplyError::Timeout {
            command,
            timeout,
            attempts,
            partial,
        } => {
            assert_eq!(command, "*IDN?");
            assert_eq!((*timeout, *attempts), (REPLY_TIMEOUT, 3));
            assert!(partial.0.is_empty());
        }
        other => panic!("expected a timeout, got {other:?}"),
    }
    let text = err.to_string();
    assert!(
        text.contains("*IDN?") && text.contains("3 attempt"),
        "{text}"
    );
}

#[test]
fn scpi_setting_that_did_not_take_is_sent_again() {
    let sim = sim(Dialect::Scpi, 10.0);
    let mut psu = scpi(&sim);
    psu.apply(5.0, 1.0).unwrap();
    sim.device().set_faults(Faults {
        ignore_commands: 1,
        ..Faults::default()
    });
    psu.set_voltage(7.5).unwrap();
    assert_eq!(sim.device().settings().voltage_v, 7.5);
    assert_eq!(sim.device().stats().ignored, 1);
}

// ---- Korad / Tenma -------------------------------------------------------------------------

#[test]
fn korad_set_and_measure_round_trip() {
    let sim = sim(Dialect::Korad, 10.0);
    let mut psu = korad(&sim);
    assert!(psu.identify().unwrap().starts_with("KORAD KA3005P"));
    psu.apply(12.5, 2.0).unwrap();
    assert_eq!(psu.voltage_setpoint().unwrap(), 12.5);
    assert_eq!(psu.current_limit().unwrap(), 2.0);
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert!(
        close(m.voltage_v, 12.5) && close(m.current_a, 1.25),
        "{m:?}"
    );
    let status = psu.status().unwrap();
    assert!(status.output_on());
    assert_eq!(status.mode(), RegulationMode::ConstantVoltage);
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantVoltage);
    let log = sim.device().command_log();
    assert!(log.iter().any(|c| c == "VSET1:12.50"), "{log:?}");
    assert!(log.iter().any(|c| c == "ISET1:2.000"), "{log:?}");
}

#[test]
fn korad_output_on_off() {
    let sim = sim(Dialect::Korad, 10.0);
    let mut psu = korad(&sim);
    psu.set_voltage(5.0).unwrap();
    assert_eq!(psu.mode().unwrap(), RegulationMode::Off);
    assert_eq!(psu.measure_voltage().unwrap(), 0.0);
    psu.set_output(true).unwrap();
    assert!(sim.device().settings().output_on);
    assert_eq!(psu.measure_voltage().unwrap(), 5.0);
    psu.set_output(false).unwrap();
    assert!(!psu.status().unwrap().output_on());
    assert_eq!(psu.mode().unwrap(), RegulationMode::Off);
}

#[test]
fn korad_constant_current_when_the_load_exceeds_the_limit() {
    let sim = sim(Dialect::Korad, 2.0);
    let mut psu = korad(&sim);
    psu.apply(12.0, 3.0).unwrap();
    psu.set_output(true).unwrap();
    let status = psu.status().unwrap();
    assert_eq!(
        status.0 & supply::KoradStatus::CH1_CV,
        0,
        "bit 0 clear in CC"
    );
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantCurrent);
    let m = psu.measure().unwrap();
    assert!(close(m.voltage_v, 6.0) && close(m.current_a, 3.0), "{m:?}");
}

#[test]
fn korad_retries_a_dropped_reply() {
    let sim = sim(Dialect::Korad, 10.0);
    let mut psu = korad(&sim);
    psu.set_voltage(10.0).unwrap();
    sim.device().set_faults(Faults {
        drop_replies: 1,
        ..Faults::default()
    });
    assert_eq!(psu.voltage_setpoint().unwrap(), 10.0);
    assert_eq!(sim.device().stats().faulted_replies, 1);
    assert_eq!(sim.device().faults(), Faults::default());
}

#[test]
fn korad_silent_supply_times_out() {
    let sim = sim(Dialect::Korad, 10.0);
    let mut psu = korad(&sim);
    sim.device().set_faults(Faults {
        silent: true,
        ..Faults::default()
    });
    match psu.measure() {
        Err(SupplyError::Timeout {
            command, attempts, ..
        }) => {
            assert_eq!(command, "VOUT1?");
            assert_eq!(attempts, 3);
        }
        other => panic!("expected a timeout, got {other:?}"),
    }
}

#[test]
fn korad_pacing_is_respected_over_a_pty() {
    let config = SimConfig {
        // Half the driver's 60 ms: room for a late-scheduled simulator thread. (The exact
        // check, at 55 ms, is in `in_process.rs`.)
        min_command_gap: Duration::from_millis(30),
        strict_pacing: false,
        ..SimConfig::default()
    };
    let sim = SimulatedSupply::spawn(
        Dialect::Korad,
        ResistiveLoad {
            resistance_ohm: 10.0,
        },
        config,
    )
    .unwrap();
    let mut psu = korad(&sim);
    let start = Instant::now();
    // 2 sets + 2 read-backs, output + status, 2 measurement queries: 8 exchanges.
    psu.apply(9.0, 1.5).unwrap();
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert!(close(m.voltage_v, 9.0) && close(m.current_a, 0.9), "{m:?}");
    assert!(start.elapsed() >= Duration::from_millis(7 * 60));
    let stats = sim.device().stats();
    let log = sim.device().command_log();
    assert!(stats.commands >= 8, "{stats:?} {log:?}");
    // Unpaced, all 7 gaps would be violations; at most a scheduling hiccup of the simulator
    // thread may show one or two.
    assert!(stats.pacing_violations <= 2, "{stats:?} {log:?}");
}

#[test]
fn korad_strict_simulator_drops_unpaced_commands() {
    let sim = strict_sim(Dialect::Korad, 10.0);
    let config = KoradConfig {
        timing: Timing {
            pacing: Duration::ZERO,
            ..korad_config().timing
        },
        verify_settings: false,
        ..korad_config()
    };
    let mut psu = KoradSupply::open(sim.port_path(), SerialSettings::default(), config).unwrap();
    // Back to back, as a careless host would send them: the simulator drops what follows too
    // closely, as the instrument does.
    psu.apply(5.0, 0.5).unwrap();
    psu.apply(6.0, 0.6).unwrap();
    psu.set_output(true).unwrap();
    poll_until(|| sim.device().stats().pacing_violations >= 1);
    assert!(sim.device().stats().ignored >= 1);
    assert!(
        sim.device()
            .command_log()
            .iter()
            .any(|c| c.starts_with("(dropped"))
    );
}

// ---- the terminal itself -------------------------------------------------------------------

#[test]
fn port_can_be_reopened_and_disappears_on_drop() {
    let sim = sim(Dialect::Scpi, 10.0);
    let path = sim.port_path().to_owned();
    for _ in 0..2 {
        let mut psu = scpi(&sim);
        assert!(psu.identify().is_ok());
    }
    assert!(Path::new(&path).exists());
    let start = Instant::now();
    drop(sim);
    assert!(
        start.elapsed() < Duration::from_secs(2),
        "server thread stops promptly"
    );
    poll_until(|| !Path::new(&path).exists());
}

#[test]
fn opening_a_missing_port_names_it() {
    let err = ScpiSupply::open(
        "/dev/hoverbench-no-such-port",
        SerialSettings::default(),
        ScpiConfig::default(),
    )
    .err()
    .expect("no such port");
    assert!(matches!(err, SupplyError::Open { .. }));
    assert!(err.to_string().contains("/dev/hoverbench-no-such-port"));
}

/// Waits (up to 5 s, never a fixed sleep) for `cond`.
fn poll_until(mut cond: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while !cond() {
        assert!(
            Instant::now() < deadline,
            "condition not reached within 5 s"
        );
        thread::sleep(Duration::from_millis(5));
    }
}
