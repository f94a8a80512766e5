//! Property test of the safety state machine: whatever the host sends and whatever the
//! sensors read, on every tick the output obeys the slew limit (except a fault's cut to
//! minimum), never rises unless armed, sits at minimum while a fault is latched, and a host
//! silent for the timeout while armed is faulted.

use proptest::prelude::*;
use rig_firmware::{
    Config, Firmware, LoadCellAdc, NoWatchdog, PowerMonitor, PowerReading, ThrottleOutput,
};
use rig_protocol::frame::encode_frame;
use rig_protocol::{Clock, Message, PROTOCOL_VERSION, RigState};
use std::cell::Cell;
use std::rc::Rc;

#[derive(Default)]
struct World {
    now_us: Cell<u64>,
    raw: Cell<i32>,
    voltage_v: Cell<f32>,
    current_a: Cell<f32>,
    written: Cell<u16>,
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
        Ok((self.0.now_us.get() % 12_000 == 0).then(|| self.0.raw.get()))
    }
}
impl PowerMonitor for H {
    type Error = ();
    fn read(&mut self) -> Result<PowerReading, ()> {
        Ok(PowerReading {
            voltage_v: self.0.voltage_v.get(),
            current_a: self.0.current_a.get(),
        })
    }
}
impl ThrottleOutput for H {
    type Error = ();
    fn set_throttle_us(&mut self, us: u16) -> Result<(), ()> {
        self.0.written.set(us);
        Ok(())
    }
}

#[derive(Debug, Clone)]
enum Event {
    Command(Message),
    Garbage(Vec<u8>),
    Sensors {
        raw: i32,
        voltage_v: f32,
        current_a: f32,
    },
    Wait {
        ms: u16,
    },
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        4 => prop_oneof![
            Just(Message::Arm),
            Just(Message::Disarm),
            Just(Message::Ping),
            Just(Message::GetStatus),
            (900u16..2100).prop_map(|t| Message::SetThrottle { throttle_us: t }),
            (0u16..300).prop_map(|r| Message::StartStream { rate_hz: r }),
            Just(Message::StopStream),
            (0u16..5).prop_map(|n| Message::Tare { samples: n }),
            (-10.0f32..600.0).prop_map(|m| Message::Calibrate { known_mass_g: m }),
        ]
        .prop_map(Event::Command),
        1 => proptest::collection::vec(any::<u8>(), 0..40).prop_map(Event::Garbage),
        2 => (-200_000i32..200_000, 5.0f32..20.0, -1.0f32..40.0)
            .prop_map(|(raw, voltage_v, current_a)| Event::Sensors { raw, voltage_v, current_a }),
        3 => (1u16..400).prop_map(|ms| Event::Wait { ms }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn safety_invariants_hold_on_every_tick(events in proptest::collection::vec(event(), 1..60)) {
        let cfg = Config {
            max_current_a: 20.0,
            max_thrust_g: 300.0,
            min_voltage_v: 8.0,
            max_voltage_v: 17.0,
            nominal_scale_g_per_count: 0.01,
            ..Config::default()
        };
        let w = Rc::new(World::default());
        w.voltage_v.set(12.0);
        let h = H(w.clone());
        let mut fw = Firmware::new(h.clone(), h.clone(), h.clone(), h, NoWatchdog, cfg);
        let mut seq = 0u16;
        let mut wire = [0u8; 64];
        let mut sink = |_: &[u8]| {};
        let n = encode_frame(seq, &Message::Hello { protocol_version: PROTOCOL_VERSION }, &mut wire).unwrap();
        fw.receive(&wire[..n], &mut sink);
        let mut last_host_us = 0u64;
        let mut prev_out = fw.output_us();
        for e in events {
            match e {
                Event::Command(m) => {
                    seq = seq.wrapping_add(1);
                    let n = encode_frame(seq, &m, &mut wire).unwrap();
                    fw.receive(&wire[..n], &mut sink);
                    last_host_us = w.now_us.get();
                }
                Event::Garbage(bytes) => fw.receive(&bytes, &mut sink),
                Event::Sensors { raw, voltage_v, current_a } => {
                    w.raw.set(raw);
                    w.voltage_v.set(voltage_v);
                    w.current_a.set(current_a);
                }
                Event::Wait { ms } => {
                    for _ in 0..ms {
                        let state_before = fw.state();
                        w.now_us.set(w.now_us.get() + 1000);
                        fw.tick(&mut sink);
                        let out = fw.output_us();
                        let state = fw.state();
                        // slew limit (2 µs per 1 ms tick at 2000 µs/s), except the cut to minimum
                        prop_assert!(out.abs_diff(prev_out) <= 2 || out == cfg.throttle_min_us,
                            "{prev_out} -> {out} in {state:?}");
                        // never rises unless armed
                        if state != RigState::Armed || state_before != RigState::Armed {
                            prop_assert!(out <= prev_out, "rose while {state:?}");
                        }
                        if state == RigState::Faulted {
                            prop_assert_eq!(out, cfg.throttle_min_us);
                            prop_assert!(!fw.faults().is_empty());
                        }
                        prop_assert!((cfg.throttle_min_us..=cfg.throttle_max_us).contains(&out));
                        prop_assert_eq!(w.written.get(), out, "ESC gets what the core reports");
                        if state_before == RigState::Armed && w.now_us.get() - last_host_us >= cfg.host_timeout_us {
                            prop_assert_eq!(state, RigState::Faulted, "silent host not faulted");
                        }
                        prev_out = out;
                    }
                }
            }
        }
    }
}
