//! Over-current, over-thrust and under-voltage on the simulated rig: each a latched fault
//! with its cause, value and limit, the output at minimum, cleared only by re-arming.
//! In process, on the simulated clock.

use rig_protocol::{ClientConfig, ClientError, FaultCause, FaultReport, NackReason, Rig, RigState};
use sim::{ClientClockExt, Preset, SimRig, presets};

type Host = rig_protocol::Client<sim::SimLink, sim::peripherals::SimClock>;

fn host(preset: &Preset) -> Host {
    let mut h = SimRig::new(preset, 7)
        .unwrap()
        .into_client(ClientConfig::default());
    h.handshake().unwrap();
    h.tare(16).unwrap();
    h.start_stream(50).unwrap();
    h.arm().unwrap();
    h
}

fn run_until_fault(h: &mut Host, max_us: u64) -> Option<FaultReport> {
    let end = h.clock_now_us() + max_us;
    while h.clock_now_us() < end {
        let _ = h.next_sample().unwrap();
        if let Some(f) = h.take_fault().unwrap() {
            return Some(f);
        }
    }
    None
}

fn assert_latched(h: &mut Host, cause: FaultCause) {
    let st = h.status().unwrap();
    assert_eq!(st.state, RigState::Faulted);
    assert!(st.faults.contains(cause), "{st:?}");
    assert_eq!(st.throttle_us, 1000);
    assert!(matches!(
        h.set_throttle(1300),
        Err(ClientError::Nack {
            reason: NackReason::Faulted,
            ..
        })
    ));
    // the rotor spins down
    let w0 = h.transport_mut().rig().truth().omega_rad_s;
    h.transport_mut().rig_mut().advance(500_000);
    assert!(h.transport_mut().rig().truth().omega_rad_s < 0.5 * w0 + 1.0);
}

#[test]
fn over_current_latches_with_its_cause() {
    let mut p = presets::paper();
    p.firmware.max_current_a = 3.0;
    let mut h = host(&p);
    h.set_throttle(1800).unwrap();
    let f = run_until_fault(&mut h, 3_000_000).expect("over-current fault");
    assert_eq!(f.cause, FaultCause::OverCurrent);
    assert!(f.value > 3.0 && f.value < 4.0 && f.limit == 3.0, "{f:?}");
    assert_latched(&mut h, FaultCause::OverCurrent);
    h.arm().unwrap();
    assert_eq!(h.status().unwrap().state, RigState::Armed);
    h.set_throttle(1300).unwrap();
}

#[test]
fn over_thrust_latches_with_its_cause() {
    let mut p = presets::paper();
    p.firmware.max_thrust_g = 100.0;
    let mut h = host(&p);
    h.set_throttle(1750).unwrap();
    let f = run_until_fault(&mut h, 3_000_000).expect("over-thrust fault");
    assert_eq!(f.cause, FaultCause::OverThrust);
    assert!(
        f.value > 100.0 && f.value < 140.0 && f.limit == 100.0,
        "{f:?}"
    );
    assert_latched(&mut h, FaultCause::OverThrust);
}

#[test]
fn under_voltage_latches_with_its_cause() {
    let p = presets::paper();
    let mut h = host(&p);
    h.set_throttle(1400).unwrap();
    assert!(run_until_fault(&mut h, 1_000_000).is_none());
    h.transport_mut().rig_mut().set_supply_voltage(7.5);
    let f = run_until_fault(&mut h, 1_000_000).expect("under-voltage fault");
    assert_eq!(f.cause, FaultCause::UnderVoltage);
    assert!(f.value < 8.0 && f.value > 7.0 && f.limit == 8.0, "{f:?}");
    assert_latched(&mut h, FaultCause::UnderVoltage);
    // re-arming with the supply still low re-trips: the limit is the firmware's
    h.arm().unwrap();
    let f = run_until_fault(&mut h, 1_000_000).expect("re-trip");
    assert_eq!(f.cause, FaultCause::UnderVoltage);
    h.transport_mut().rig_mut().set_supply_voltage(12.5);
    h.arm().unwrap();
    assert!(run_until_fault(&mut h, 1_000_000).is_none());
    assert_eq!(h.status().unwrap().state, RigState::Armed);
}

#[test]
fn host_silence_in_simulated_time() {
    let p = presets::paper();
    let mut h = host(&p);
    h.set_throttle(1600).unwrap();
    let end = h.clock_now_us() + 1_000_000;
    while h.clock_now_us() < end {
        h.next_sample().unwrap();
    }
    // host goes silent: time passes on the rig with nobody talking
    let rig = h.transport_mut().rig_mut();
    let silent_from = rig.now_us();
    let mut cut = None;
    while rig.now_us() < silent_from + 400_000 {
        rig.advance(1000);
        if cut.is_none() && rig.firmware().output_us() == 1000 {
            cut = Some(rig.now_us());
        }
    }
    let cut = cut.expect("throttle cut");
    assert!(cut - silent_from <= 250_000, "{}", cut - silent_from);
    assert!(rig.firmware().faults().contains(FaultCause::HostTimeout));
    let (feeds, last) = rig.watchdog();
    assert!(
        feeds > 1000 && rig.now_us() - last <= 1000,
        "watchdog fed every tick"
    );
}
