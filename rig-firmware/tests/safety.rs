//! The firmware core's protocol handling, sampling and safety state machine, driven by a
//! manual clock and fake peripherals (no wall-clock time anywhere).

use rig_firmware::{
    Config, Firmware, LoadCellAdc, PowerMonitor, PowerReading, ThrottleOutput, Watchdog,
};
use rig_protocol::frame::{Decoder, encode_frame};
use rig_protocol::{Clock, FaultCause, Message, NackReason, PROTOCOL_VERSION, RigState, Sample};
use std::cell::{Cell, RefCell};
use std::rc::Rc;

#[derive(Default)]
struct World {
    now_us: Cell<u64>,
    raw: Cell<i32>,
    adc_period_us: Cell<u64>,
    next_adc_us: Cell<u64>,
    voltage_v: Cell<f32>,
    current_a: Cell<f32>,
    esc_writes: RefCell<Vec<(u64, u16)>>,
    feeds: Cell<u32>,
    power_fails: Cell<bool>,
}

#[derive(Clone)]
struct H(Rc<World>);

impl Clock for H {
    fn now_us(&self) -> u64 {
        self.0.now_us.get()
    }
}
impl LoadCellAdc for H {
    type Error = ();
    fn try_read_raw(&mut self) -> Result<Option<i32>, ()> {
        let w = &self.0;
        if w.now_us.get() >= w.next_adc_us.get() {
            w.next_adc_us.set(w.now_us.get() + w.adc_period_us.get());
            Ok(Some(w.raw.get()))
        } else {
            Ok(None)
        }
    }
}
impl PowerMonitor for H {
    type Error = ();
    fn read(&mut self) -> Result<PowerReading, ()> {
        if self.0.power_fails.get() {
            return Err(());
        }
        Ok(PowerReading {
            voltage_v: self.0.voltage_v.get(),
            current_a: self.0.current_a.get(),
        })
    }
}
impl ThrottleOutput for H {
    type Error = ();
    fn set_throttle_us(&mut self, us: u16) -> Result<(), ()> {
        self.0
            .esc_writes
            .borrow_mut()
            .push((self.0.now_us.get(), us));
        Ok(())
    }
}
impl Watchdog for H {
    fn feed(&mut self) {
        self.0.feeds.set(self.0.feeds.get() + 1);
    }
}

struct Bench {
    w: Rc<World>,
    fw: Firmware<H, H, H, H, H>,
    seq: u16,
    dec: Decoder,
    received: Vec<Message>,
}

impl Bench {
    fn new(cfg: Config) -> Self {
        let w = Rc::new(World::default());
        w.adc_period_us.set(12_500); // 80 SPS
        w.voltage_v.set(12.5);
        w.current_a.set(0.2);
        let h = H(w.clone());
        let fw = Firmware::new(h.clone(), h.clone(), h.clone(), h.clone(), h, cfg);
        Self {
            w,
            fw,
            seq: 0,
            dec: Decoder::new(),
            received: Vec::new(),
        }
    }

    fn collect(dec: &mut Decoder, rx: &mut Vec<Message>, bytes: &[u8]) {
        for &b in bytes {
            if let Some(Ok(f)) = dec.push(b) {
                rx.push(f.message);
            }
        }
    }

    fn send_raw(&mut self, seq: u16, m: Message) -> Vec<Message> {
        let mut wire = [0u8; 64];
        let n = encode_frame(seq, &m, &mut wire).unwrap();
        let mut out = Vec::new();
        self.fw
            .receive(&wire[..n], &mut |b: &[u8]| out.extend_from_slice(b));
        let mut msgs = Vec::new();
        Self::collect(&mut self.dec, &mut msgs, &out);
        self.received.extend(msgs.iter().copied());
        msgs
    }

    fn send(&mut self, m: Message) -> Vec<Message> {
        self.seq += 1;
        self.send_raw(self.seq, m)
    }

    /// Advances the clock in 1 ms ticks.
    fn run_ms(&mut self, ms: u64) {
        for _ in 0..ms {
            self.w.now_us.set(self.w.now_us.get() + 1000);
            let mut out = Vec::new();
            self.fw.tick(&mut |b: &[u8]| out.extend_from_slice(b));
            Self::collect(&mut self.dec, &mut self.received, &out);
        }
    }

    fn ready(cfg: Config) -> Self {
        let mut b = Self::new(cfg);
        assert!(matches!(
            b.send(Message::Hello {
                protocol_version: PROTOCOL_VERSION
            })[..],
            [Message::HelloAck { accepted: true, .. }]
        ));
        b
    }

    fn arm(&mut self) {
        assert!(matches!(self.send(Message::Arm)[..], [Message::Ack { .. }]));
    }

    fn faults(&self) -> Vec<rig_protocol::FaultReport> {
        self.received
            .iter()
            .filter_map(|m| {
                if let Message::Fault(f) = m {
                    Some(*f)
                } else {
                    None
                }
            })
            .collect()
    }

    fn samples(&self) -> Vec<Sample> {
        self.received
            .iter()
            .filter_map(|m| {
                if let Message::Sample(s) = m {
                    Some(*s)
                } else {
                    None
                }
            })
            .collect()
    }
}

fn nack(msgs: &[Message]) -> Option<NackReason> {
    match msgs {
        [Message::Nack { reason, .. }] => Some(*reason),
        _ => None,
    }
}

#[test]
fn handshake_and_arming_are_required_before_throttle() {
    let mut b = Bench::new(Config::default());
    assert_eq!(
        nack(&b.send(Message::Arm)),
        Some(NackReason::HandshakeRequired)
    );
    let r = b.send(Message::Hello {
        protocol_version: PROTOCOL_VERSION + 1,
    });
    assert!(matches!(
        r[..],
        [Message::HelloAck {
            accepted: false,
            ..
        }]
    ));
    assert_eq!(
        nack(&b.send(Message::SetThrottle { throttle_us: 1500 })),
        Some(NackReason::HandshakeRequired)
    );
    let r = b.send(Message::Hello {
        protocol_version: PROTOCOL_VERSION,
    });
    assert!(matches!(r[..], [Message::HelloAck { accepted: true, .. }]));
    assert_eq!(
        nack(&b.send(Message::SetThrottle { throttle_us: 1500 })),
        Some(NackReason::NotArmed)
    );
    b.run_ms(100);
    assert_eq!(b.fw.output_us(), 1000);
    b.arm();
    assert_eq!(
        nack(&b.send(Message::SetThrottle { throttle_us: 2500 })),
        Some(NackReason::BadArgument)
    );
    assert!(matches!(
        b.send(Message::SetThrottle { throttle_us: 1500 })[..],
        [Message::Ack { .. }]
    ));
    assert!(b.w.feeds.get() >= 100, "watchdog fed every tick");
}

#[test]
fn output_is_slew_limited_both_ways() {
    let cfg = Config {
        slew_us_per_s: 1000.0,
        ..Config::default()
    };
    let mut b = Bench::ready(cfg);
    b.arm();
    b.send(Message::SetThrottle { throttle_us: 2000 });
    let mut last = b.fw.output_us();
    for _ in 0..20 {
        for _ in 0..50 {
            b.run_ms(1);
            let now = b.fw.output_us();
            assert!(now >= last && now - last <= 2, "step {last}->{now}");
            last = now;
        }
        b.send(Message::Ping); // keep the host alive
    }
    assert_eq!(b.fw.output_us(), 2000);
    b.send(Message::SetThrottle { throttle_us: 1000 });
    b.run_ms(100);
    let out = b.fw.output_us();
    assert!(
        (1899..=1901).contains(&out),
        "spin-down slew limited too: {out}"
    );
    // disarm ramps down with the same limit
    b.send(Message::Disarm);
    b.run_ms(50);
    assert!(b.fw.output_us() > 1800);
    for _ in 0..10 {
        b.run_ms(100);
    }
    assert_eq!(b.fw.output_us(), 1000);
    assert_eq!(b.fw.state(), RigState::Disarmed);
    let writes = b.w.esc_writes.borrow();
    assert!(writes.windows(2).all(|w| w[0].1.abs_diff(w[1].1) <= 2));
}

#[test]
fn host_silence_cuts_throttle_within_250_ms_and_latches_until_rearmed() {
    let mut b = Bench::ready(Config::default());
    b.arm();
    b.send(Message::SetThrottle { throttle_us: 1600 });
    for _ in 0..10 {
        b.run_ms(100);
        b.send(Message::Ping);
    }
    assert_eq!(b.fw.output_us(), 1600);
    let silent_from = b.w.now_us.get();
    // corrupt frames do not count as host frames
    let mut run = 0;
    while b.fw.output_us() != 1000 {
        b.fw.receive(&[0x05, 0x11, 0x22, 0x33, 0x44, 0x00], &mut |_| {});
        b.run_ms(1);
        run += 1;
        assert!(run < 1000);
    }
    let cut_at = b.w.now_us.get();
    assert!(
        cut_at - silent_from <= 250_000,
        "cut after {} µs",
        cut_at - silent_from
    );
    assert!(cut_at - silent_from >= 249_000);
    assert_eq!(b.fw.state(), RigState::Faulted);
    assert!(b.fw.faults().contains(FaultCause::HostTimeout));
    let f = b.faults();
    assert_eq!(f.len(), 1);
    assert_eq!(f[0].cause, FaultCause::HostTimeout);
    assert!(b.fw.rx_stats().dropped() > 0);
    // latched: throttle refused until re-armed, even when the host talks again
    assert_eq!(
        nack(&b.send(Message::SetThrottle { throttle_us: 1500 })),
        Some(NackReason::Faulted)
    );
    b.run_ms(10);
    assert_eq!(b.fw.state(), RigState::Faulted);
    b.arm();
    assert!(b.fw.faults().is_empty());
    assert_eq!(b.fw.state(), RigState::Armed);
    assert!(matches!(
        b.send(Message::SetThrottle { throttle_us: 1500 })[..],
        [Message::Ack { .. }]
    ));
}

#[test]
fn fault_ramp_option_ramps_down_instead_of_cutting() {
    let cfg = Config {
        fault_ramp_us_per_s: 10_000.0,
        ..Config::default()
    };
    let mut b = Bench::ready(cfg);
    b.arm();
    b.send(Message::SetThrottle { throttle_us: 2000 });
    for _ in 0..6 {
        b.run_ms(100);
        b.send(Message::Ping);
    }
    assert_eq!(b.fw.output_us(), 2000);
    b.run_ms(250);
    assert_eq!(b.fw.state(), RigState::Faulted);
    b.run_ms(50);
    let mid = b.fw.output_us();
    assert!((1400..1600).contains(&mid), "{mid}");
    b.run_ms(60);
    assert_eq!(b.fw.output_us(), 1000);
}

fn limit_trips(cause: FaultCause, set: impl Fn(&Bench)) {
    let cfg = Config {
        max_current_a: 10.0,
        max_thrust_g: 300.0,
        min_voltage_v: 8.5,
        nominal_scale_g_per_count: 0.01,
        ..Config::default()
    };
    let mut b = Bench::ready(cfg);
    b.arm();
    b.send(Message::SetThrottle { throttle_us: 1500 });
    b.run_ms(50);
    assert_eq!(b.fw.state(), RigState::Armed);
    set(&b);
    for _ in 0..4 {
        b.run_ms(25);
        b.send(Message::Ping);
    }
    assert_eq!(b.fw.state(), RigState::Faulted, "{cause:?}");
    assert_eq!(b.fw.output_us(), 1000);
    let f = b.faults();
    assert_eq!(f.len(), 1, "{f:?}");
    assert_eq!(f[0].cause, cause);
    assert!(b.fw.faults().contains(cause));
    let st = b.fw.status();
    assert_eq!(st.state, RigState::Faulted);
    assert!(st.faults.contains(cause));
    match cause {
        FaultCause::OverCurrent => assert!(f[0].value > 10.0 && f[0].limit == 10.0),
        FaultCause::OverThrust => assert!(f[0].value > 300.0 && f[0].limit == 300.0),
        FaultCause::UnderVoltage => assert!(f[0].value < 8.5 && f[0].limit == 8.5),
        _ => unreachable!(),
    }
    assert_eq!(
        nack(&b.send(Message::SetThrottle { throttle_us: 1500 })),
        Some(NackReason::Faulted)
    );
}

#[test]
fn over_current_latches() {
    limit_trips(FaultCause::OverCurrent, |b| b.w.current_a.set(12.0));
}

#[test]
fn over_thrust_latches() {
    limit_trips(FaultCause::OverThrust, |b| b.w.raw.set(40_000)); // 400 g at 0.01 g/count
}

#[test]
fn under_voltage_latches() {
    limit_trips(FaultCause::UnderVoltage, |b| b.w.voltage_v.set(8.0));
}

#[test]
fn a_single_spike_does_not_trip_but_a_sustained_one_does() {
    let cfg = Config {
        max_current_a: 10.0,
        power_period_us: 2000,
        ..Config::default()
    };
    let mut b = Bench::ready(cfg);
    b.arm();
    b.w.current_a.set(15.0);
    b.run_ms(1); // one reading
    b.w.current_a.set(1.0);
    b.run_ms(20);
    b.send(Message::Ping);
    assert_eq!(b.fw.state(), RigState::Armed);
}

#[test]
fn tare_and_multi_point_calibration() {
    let mut b = Bench::ready(Config::default());
    b.w.raw.set(123_456);
    assert!(
        b.send(Message::Tare { samples: 8 }).is_empty(),
        "answered when readings are in"
    );
    assert_eq!(
        nack(&b.send(Message::Tare { samples: 8 })),
        Some(NackReason::Busy)
    );
    b.run_ms(200);
    let tare: Vec<_> = b
        .received
        .iter()
        .filter(|m| matches!(m, Message::TareDone { .. }))
        .collect();
    assert!(matches!(
        tare[..],
        [Message::TareDone {
            offset_counts: 123_456,
            ..
        }]
    ));
    // 0.02 g per count
    for (mass, expect_points) in [(100.0f32, 1u8), (200.0, 2), (500.0, 3)] {
        b.w.raw.set(123_456 + (mass / 0.02) as i32);
        b.send(Message::Calibrate { known_mass_g: mass });
        b.run_ms(200);
        match b
            .received
            .iter()
            .rev()
            .find(|m| matches!(m, Message::Calibrated { .. }))
        {
            Some(Message::Calibrated {
                scale_g_per_count,
                points,
                ..
            }) => {
                assert!((scale_g_per_count - 0.02).abs() < 1e-6);
                assert_eq!(*points, expect_points);
            }
            other => panic!("{other:?}"),
        }
    }
    b.w.raw.set(123_456 + 5000);
    b.run_ms(20);
    assert!((b.fw.thrust_g() - 100.0).abs() < 1e-3);
    // not while armed
    b.arm();
    assert_eq!(
        nack(&b.send(Message::Tare { samples: 4 })),
        Some(NackReason::Armed)
    );
    assert_eq!(
        nack(&b.send(Message::Calibrate {
            known_mass_g: f32::NAN
        })),
        Some(NackReason::BadArgument)
    );
}

#[test]
fn streams_time_stamped_samples_at_the_requested_rate() {
    let mut b = Bench::ready(Config::default());
    b.w.voltage_v.set(12.3);
    b.w.current_a.set(1.5);
    assert_eq!(
        nack(&b.send(Message::StartStream { rate_hz: 0 })),
        None.or(Some(NackReason::BadArgument))
    );
    b.send(Message::StartStream { rate_hz: 200 });
    b.run_ms(1000);
    let s = b.samples();
    assert!((199..=201).contains(&s.len()), "{}", s.len());
    assert!(s.windows(2).all(|w| w[1].time_us - w[0].time_us == 5000));
    assert!(
        s.iter()
            .all(|x| x.voltage_v == 12.3 && x.current_a == 1.5 && x.throttle_us == 1000)
    );
    b.send(Message::StopStream);
    let n = b.samples().len();
    b.run_ms(100);
    assert_eq!(b.samples().len(), n);
}

#[test]
fn a_repeated_sequence_number_is_answered_but_not_executed_twice() {
    let mut b = Bench::ready(Config::default());
    b.w.raw.set(1000);
    b.send(Message::Tare { samples: 2 });
    b.run_ms(50);
    let seq = b.seq;
    // the host lost the answer and retries with the same seq
    let again = b.send_raw(seq, Message::Tare { samples: 2 });
    assert!(matches!(
        again[..],
        [Message::TareDone {
            offset_counts: 1000,
            ..
        }]
    ));
    assert_eq!(b.fw.stats().duplicate_commands, 1);
    b.arm();
    let s1 = b.seq;
    let r = b.send_raw(s1, Message::Arm);
    assert!(matches!(r[..], [Message::Ack { .. }]));
}

#[test]
fn a_retry_after_interleaved_keepalives_is_not_executed_twice() {
    let mut b = Bench::ready(Config::default());
    b.w.raw.set(500);
    b.send(Message::Tare { samples: 1 });
    b.run_ms(20);
    b.w.raw.set(500 + 10_000);
    b.send(Message::Calibrate {
        known_mass_g: 100.0,
    });
    let cal_seq = b.seq;
    b.run_ms(200);
    // the answer was lost; the host pinged meanwhile and then retries with the same seq
    b.send(Message::Ping);
    b.send(Message::GetStatus);
    let again = b.send_raw(
        cal_seq,
        Message::Calibrate {
            known_mass_g: 100.0,
        },
    );
    assert!(
        matches!(again[..], [Message::Calibrated { points: 1, .. }]),
        "{again:?}"
    );
    assert_eq!(b.fw.load_cell().points(), 1);
}

#[test]
fn a_failing_sensor_and_a_watchdog_reset_latch_faults() {
    let mut b = Bench::ready(Config::default());
    b.arm();
    b.send(Message::SetThrottle { throttle_us: 1300 });
    b.run_ms(100);
    b.w.power_fails.set(true);
    b.run_ms(5);
    assert_eq!(b.fw.state(), RigState::Faulted);
    assert!(b.fw.faults().contains(FaultCause::SensorFailure));
    assert_eq!(b.fw.output_us(), 1000);
    b.w.power_fails.set(false);
    b.arm();
    let mut out = Vec::new();
    b.fw.report_watchdog_reset(&mut |x: &[u8]| out.extend_from_slice(x));
    let mut msgs = Vec::new();
    Bench::collect(&mut b.dec, &mut msgs, &out);
    assert!(matches!(msgs[..], [Message::Fault(f)] if f.cause == FaultCause::Watchdog));
    assert_eq!(b.fw.state(), RigState::Faulted);
}

#[test]
fn a_new_session_is_not_mistaken_for_a_retry() {
    let mut b = Bench::ready(Config::default());
    b.w.raw.set(100);
    b.send_raw(7, Message::Tare { samples: 1 });
    b.run_ms(20);
    // a new host starts its sequence numbers again and happens to reuse 7
    b.send_raw(
        1,
        Message::Hello {
            protocol_version: PROTOCOL_VERSION,
        },
    );
    b.w.raw.set(900);
    assert!(
        b.send_raw(7, Message::Tare { samples: 1 }).is_empty(),
        "executed, not replayed"
    );
    b.run_ms(20);
    assert_eq!(b.fw.load_cell().offset_counts(), 900);
}
