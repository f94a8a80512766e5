//! Drivers against the simulated supply in memory ([`supply::sim::InProcessTransport`]), where
//! the simulator timestamps bytes as they are written: the exact pacing checks. And the reply
//! framing against scripted transports.

use std::collections::{HashMap, VecDeque};
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use supply::sim::{ConstantPowerLoad, Device, Dialect, ResistiveLoad, SimConfig};
use supply::{
    KoradConfig, KoradSupply, RegulationMode, ReplyError, ScpiConfig, ScpiSupply, Supply,
    SupplyError, Timing, Transport,
};

fn korad_device(min_gap_ms: u64) -> Device {
    Device::new(
        Dialect::Korad,
        ResistiveLoad {
            resistance_ohm: 10.0,
        },
        SimConfig {
            min_command_gap: Duration::from_millis(min_gap_ms),
            ..SimConfig::default()
        },
    )
}

fn korad_config(pacing_ms: u64, verify_settings: bool) -> KoradConfig {
    KoradConfig {
        timing: Timing {
            reply_timeout: Duration::from_millis(150),
            pacing: Duration::from_millis(pacing_ms),
            ..KoradConfig::default().timing
        },
        verify_settings,
        ..KoradConfig::default()
    }
}

#[test]
fn korad_pacing_is_respected_exactly() {
    // The simulator asks for 55 ms; the driver keeps its default 60 ms.
    let dev = korad_device(55);
    let mut psu = KoradSupply::new(dev.connect(), korad_config(60, true));
    let start = Instant::now();
    psu.identify().unwrap();
    psu.apply(12.0, 2.0).unwrap();
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert_eq!((m.voltage_v, m.current_a), (12.0, 1.2));
    let stats = dev.stats();
    assert_eq!(stats.commands, 9, "{stats:?}");
    assert_eq!(stats.pacing_violations, 0, "{stats:?}");
    assert!(stats.min_command_gap.unwrap() >= Duration::from_millis(60));
    assert!(start.elapsed() >= Duration::from_millis(8 * 60));
}

#[test]
fn korad_unpaced_commands_are_dropped() {
    let dev = korad_device(40);
    let mut psu = KoradSupply::new(dev.connect(), korad_config(0, false));
    psu.apply(5.0, 0.5).unwrap();
    // The query right behind is dropped too; its retry, a reply timeout later, is answered.
    assert_eq!(psu.voltage_setpoint().unwrap(), 5.0);
    let s = dev.settings();
    assert_eq!(s.voltage_v, 5.0);
    assert_eq!(
        s.current_limit_a,
        SimConfig::default().initial.current_limit_a
    );
    assert_eq!(dev.stats().pacing_violations, 2);
    assert!(
        dev.command_log()
            .iter()
            .any(|c| c.contains("(dropped") && c.ends_with("ISET1:0.500"))
    );
}

#[test]
fn korad_read_back_recovers_an_unpaced_setting() {
    let dev = korad_device(40);
    let mut psu = KoradSupply::new(dev.connect(), korad_config(0, true));
    // The read-back right after the set is dropped; the retry, a reply timeout later, is not.
    psu.set_current_limit(0.5).unwrap();
    assert_eq!(dev.settings().current_limit_a, 0.5);
    assert_eq!(dev.stats().pacing_violations, 1);
}

#[test]
fn korad_unverified_setting_takes_effect_when_written() {
    let dev = korad_device(40);
    let mut psu = KoradSupply::new(dev.connect(), korad_config(60, false));
    psu.set_voltage(7.25).unwrap();
    assert_eq!(dev.settings().voltage_v, 7.25);
    psu.set_output(true).unwrap();
    assert!(dev.settings().output_on);
    assert_eq!(dev.stats().pacing_violations, 0);
}

#[test]
fn scpi_constant_power_load_browns_out_in_constant_current() {
    let dev = Device::new(
        Dialect::Scpi,
        ConstantPowerLoad {
            power_w: 30.0,
            cutoff_voltage_v: 6.0,
        },
        SimConfig::default(),
    );
    let mut psu = ScpiSupply::new(dev.connect(), ScpiConfig::default());
    psu.apply(12.0, 5.0).unwrap();
    psu.set_output(true).unwrap();
    let m = psu.measure().unwrap();
    assert_eq!((m.voltage_v, m.current_a), (12.0, 2.5));
    // 2 A cannot carry 30 W at any voltage up to 12 V: the supply limits, the ESC cuts out.
    psu.set_current_limit(2.0).unwrap();
    assert_eq!(psu.mode().unwrap(), RegulationMode::ConstantCurrent);
    assert!(psu.measure_voltage().unwrap() <= 6.0);
}

#[test]
fn out_of_range_set_points_are_never_sent() {
    let dev = Device::new(
        Dialect::Scpi,
        ResistiveLoad {
            resistance_ohm: 10.0,
        },
        SimConfig::default(),
    );
    let mut psu = ScpiSupply::new(dev.connect(), ScpiConfig::default());
    for v in [-1.0, 31.0, f64::NAN] {
        let err = psu.set_voltage(v).unwrap_err();
        assert!(
            matches!(
                err,
                SupplyError::OutOfRange {
                    quantity: "voltage_v",
                    ..
                }
            ),
            "{err}"
        );
    }
    assert!(matches!(
        psu.set_current_limit(9.0),
        Err(SupplyError::OutOfRange {
            quantity: "current_limit_a",
            ..
        })
    ));
    assert_eq!(dev.stats().commands, 0);
}

/// A transport that answers each write from a table, in fragments.
struct Scripted {
    replies: HashMap<&'static [u8], &'static [u8]>,
    pending: VecDeque<u8>,
    written: Vec<Vec<u8>>,
    fragment: usize,
}

impl Scripted {
    fn new(replies: &[(&'static [u8], &'static [u8])], fragment: usize) -> Self {
        Self {
            replies: replies.iter().copied().collect(),
            pending: VecDeque::new(),
            written: Vec::new(),
            fragment,
        }
    }
}

impl Read for Scripted {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pending.is_empty() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        let n = buf.len().min(self.pending.len()).min(self.fragment);
        for (d, s) in buf.iter_mut().zip(self.pending.drain(..n)) {
            *d = s;
        }
        Ok(n)
    }
}

impl Write for Scripted {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.written.push(buf.to_vec());
        if let Some(r) = self.replies.get(buf) {
            self.pending.extend(r.iter());
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Transport for Scripted {
    fn set_read_timeout(&mut self, _timeout: Duration) -> io::Result<()> {
        Ok(())
    }
    fn discard_input(&mut self) -> io::Result<()> {
        self.pending.clear();
        Ok(())
    }
}

fn fast_korad() -> KoradConfig {
    korad_config(0, true)
}

#[test]
fn korad_reply_with_a_trailing_byte_does_not_leak_into_the_next() {
    // Some firmware answers ISET1? with a sixth byte; it is discarded before the next command.
    let t = Scripted::new(&[(b"ISET1?", b"2.000\x00"), (b"VSET1?", b"12.00")], 2);
    let mut psu = KoradSupply::new(t, fast_korad());
    assert_eq!(psu.current_limit().unwrap(), 2.0);
    assert_eq!(psu.voltage_setpoint().unwrap(), 12.0);
}

#[test]
fn korad_status_byte_may_be_any_byte() {
    for byte in [b'\n', 0x00, 0xff, 0x40] {
        let reply: &'static [u8] = Box::leak(vec![byte].into_boxed_slice());
        let mut psu = KoradSupply::new(Scripted::new(&[(b"STATUS?", reply)], 1), fast_korad());
        assert_eq!(psu.status().unwrap().0, byte);
    }
}

#[test]
fn scpi_line_arrives_in_fragments() {
    let t = Scripted::new(&[(b":MEAS:ALL? CH1\n", b"12.500,1.234,15.425\r\n")], 3);
    let mut psu = ScpiSupply::new(t, ScpiConfig::default());
    let m = psu.measure().unwrap();
    assert_eq!((m.voltage_v, m.current_a), (12.5, 1.234));
    assert_eq!(psu.into_inner().written, vec![b":MEAS:ALL? CH1\n".to_vec()]);
}

#[test]
fn scpi_endless_reply_is_refused() {
    static LONG: [u8; 400] = [b'7'; 400];
    let t = Scripted::new(&[(b"*IDN?\n", &LONG)], 64);
    let config = ScpiConfig {
        timing: Timing {
            retries: 1,
            ..ScpiConfig::default().timing
        },
        ..ScpiConfig::default()
    };
    let mut psu = ScpiSupply::new(t, config);
    match psu.identify() {
        Err(SupplyError::BadReply {
            reason: ReplyError::TooLong,
            attempts: 2,
            ..
        }) => {}
        other => panic!("expected a too-long reply, got {other:?}"),
    }
}

mod properties {
    use super::*;
    use proptest::prelude::*;
    use supply::sim::{Settings, solve};

    fn driver(dialect: Dialect, dev: &Device) -> Box<dyn Supply> {
        let timing = Timing {
            reply_timeout: Duration::from_millis(100),
            retries: 1,
            pacing: Duration::ZERO,
            quiet_gap: Duration::from_millis(1),
        };
        match dialect {
            Dialect::Scpi => Box::new(ScpiSupply::new(
                dev.connect(),
                ScpiConfig {
                    timing,
                    ..ScpiConfig::default()
                },
            )),
            Dialect::Korad => Box::new(KoradSupply::new(
                dev.connect(),
                KoradConfig {
                    timing,
                    ..KoradConfig::default()
                },
            )),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Set, switch on, measure: what the driver reads is the model's operating point, to
        /// the dialect's display resolution, and the mode is the model's.
        #[test]
        fn drivers_read_the_model(
            korad in any::<bool>(),
            voltage_v in 0.0f64..30.0,
            limit_a in 0.01f64..5.0,
            load_ohm in 0.5f64..100.0,
            source_ohm in 0.0f64..0.5,
        ) {
            let dialect = if korad { Dialect::Korad } else { Dialect::Scpi };
            let config = SimConfig { min_command_gap: Duration::ZERO, ..SimConfig::default() };
            let dev = Device::new(dialect, ResistiveLoad { resistance_ohm: load_ohm }, config);
            dev.set_source_resistance_ohm(source_ohm);
            let mut psu = driver(dialect, &dev);
            psu.apply(voltage_v, limit_a).unwrap();
            psu.set_output(true).unwrap();
            let m = psu.measure().unwrap();
            let mode = psu.mode().unwrap();
            // The set-points as the instrument took them (rounded by the driver).
            let s = dev.settings();
            prop_assert!((s.voltage_v - voltage_v).abs() <= 0.005 + 1e-9);
            prop_assert!((s.current_limit_a - limit_a).abs() <= 0.0005 + 1e-9);
            let expected = solve(
                &Settings { output_on: true, ..s },
                &mut ResistiveLoad { resistance_ohm: load_ohm },
            );
            let (tol_v, tol_a) = if korad { (0.005, 0.0005) } else { (0.0005, 0.0005) };
            prop_assert!((m.voltage_v - expected.voltage_v).abs() <= tol_v + 1e-9, "{m:?} {expected:?}");
            prop_assert!((m.current_a - expected.current_a).abs() <= tol_a + 1e-9, "{m:?} {expected:?}");
            prop_assert_eq!(mode, expected.mode);
        }

        /// Whatever bytes come back, a driver returns a value or an error, never panics.
        #[test]
        fn drivers_survive_arbitrary_replies(
            korad in any::<bool>(),
            reply in proptest::collection::vec(any::<u8>(), 0..40),
        ) {
            let reply: &'static [u8] = Box::leak(reply.into_boxed_slice());
            let t = Echo { reply, pending: VecDeque::new() };
            let timing = Timing {
                reply_timeout: Duration::from_millis(2),
                retries: 0,
                pacing: Duration::ZERO,
                quiet_gap: Duration::from_millis(1),
            };
            let mut psu: Box<dyn Supply> = if korad {
                Box::new(KoradSupply::new(t, KoradConfig { timing, ..KoradConfig::default() }))
            } else {
                Box::new(ScpiSupply::new(t, ScpiConfig { timing, ..ScpiConfig::default() }))
            };
            let _ = psu.identify();
            let _ = psu.measure();
            let _ = psu.mode();
            let _ = psu.set_voltage(3.0);
            let _ = psu.set_current_limit(1.0);
            let _ = psu.set_output(true);
        }
    }

    /// Answers every write with the same bytes.
    struct Echo {
        reply: &'static [u8],
        pending: VecDeque<u8>,
    }

    impl Read for Echo {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            if self.pending.is_empty() {
                return Err(io::ErrorKind::TimedOut.into());
            }
            let n = buf.len().min(self.pending.len());
            for (d, s) in buf.iter_mut().zip(self.pending.drain(..n)) {
                *d = s;
            }
            Ok(n)
        }
    }

    impl Write for Echo {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.pending.extend(self.reply.iter());
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    impl Transport for Echo {
        fn set_read_timeout(&mut self, _timeout: Duration) -> io::Result<()> {
            Ok(())
        }
        fn discard_input(&mut self) -> io::Result<()> {
            self.pending.clear();
            Ok(())
        }
    }
}
