//! The simulated rig over real pseudo-terminals, reached by the host side of the protocol
//! exactly as a serial port would be. Timing is generous and everything is polled: no fixed
//! sleeps decide an outcome.

use rig_protocol::{
    Client, ClientConfig, ClientError, FaultCause, NackReason, Rig, RigState, Sample,
};
use sim::physics::{Propulsion, Supply};
use sim::presets;
use sim::pty::{
    CorruptingProxy, Corruption, HostPort, ProxyOptions, PtyRig, PtyRigOptions, WallClock,
};
use std::time::{Duration, Instant};

type Host = Client<HostPort, WallClock>;

/// The pty tests run one at a time: each runs a real-time rig thread and a host that must
/// keep talking to it, and the machine may have only two cores.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The paper preset with a 1 s host timeout, for the tests that are not about the timeout:
/// a host thread descheduled for 250 ms on a loaded two-core machine is silent in earnest.
fn tolerant_paper() -> sim::Preset {
    let mut p = presets::paper();
    p.firmware.host_timeout_us = 1_000_000;
    p
}

/// Keep-alives well inside the rig's 250 ms host timeout, so a briefly starved host thread
/// does not look silent.
fn config() -> ClientConfig {
    ClientConfig {
        keepalive_us: 30_000,
        ..ClientConfig::default()
    }
}

fn connect(path: &std::path::Path, config: ClientConfig) -> Host {
    let port = HostPort::open(path, Duration::from_millis(5)).unwrap();
    Client::connect(port, WallClock::new(), config).unwrap()
}

fn collect_for(h: &mut Host, wall: Duration) -> Vec<Sample> {
    let end = Instant::now() + wall;
    let mut v = Vec::new();
    while Instant::now() < end {
        if let Some(s) = h.next_sample().unwrap() {
            v.push(s);
        }
    }
    v
}

#[test]
fn host_arms_tares_streams_and_sets_throttle_over_a_pty() {
    let _serial = serial();
    let preset = tolerant_paper();
    let rig = PtyRig::spawn(preset.clone(), PtyRigOptions::default()).unwrap();
    assert!(rig.path().exists());
    let mut h = connect(rig.path(), config());
    let id = h.identify().unwrap();
    assert_eq!((id.throttle_min_us, id.throttle_max_us), (1000, 2000));
    let offset = h.tare(16).unwrap();
    assert!(offset > 8_000, "preload counted: {offset}");
    h.start_stream(100).unwrap();
    h.arm().unwrap();
    h.set_throttle(1500).unwrap();
    let samples = collect_for(&mut h, Duration::from_millis(1500));
    h.set_throttle(1000).unwrap();
    let st = h.status().unwrap();
    assert_eq!(st.state, RigState::Armed);
    h.disarm().unwrap();

    assert!(samples.len() > 80, "{}", samples.len());
    // time-stamped by the rig clock at the stream rate
    for w in samples.windows(2) {
        assert!(w[1].time_us > w[0].time_us);
        assert_eq!((w[1].time_us - w[0].time_us) % 10_000, 0, "{w:?}");
    }
    // the throttle ramps (slew-limited) to the command
    let first_full = samples
        .iter()
        .position(|s| s.throttle_us == 1500)
        .expect("reached 1500");
    assert!(
        samples[..first_full]
            .windows(2)
            .all(|w| w[1].throttle_us >= w[0].throttle_us)
    );
    // consistent with the physics once settled
    let settled: Vec<_> = samples
        .iter()
        .filter(|s| s.time_us > samples[first_full].time_us + 400_000)
        .collect();
    assert!(settled.len() > 20, "{}", settled.len());
    let n = settled.len() as f64;
    let thrust = settled.iter().map(|s| f64::from(s.thrust_g)).sum::<f64>() / n;
    let power = settled
        .iter()
        .map(|s| f64::from(s.voltage_v * s.current_a))
        .sum::<f64>()
        / n;
    let volts = settled.iter().map(|s| f64::from(s.voltage_v)).sum::<f64>() / n;
    let u = Propulsion::new(preset.motor, preset.prop, preset.esc);
    let ss = u.steady_state(1500.0, Supply { ..preset.supply });
    // nominal (uncalibrated) load-cell scale is 4 % off the true one
    assert!(
        (thrust / ss.thrust_g - 1.0).abs() < 0.06,
        "{thrust} vs {}",
        ss.thrust_g
    );
    assert!(
        (power / ss.power_w() - 1.0).abs() < 0.02,
        "{power} vs {}",
        ss.power_w()
    );
    assert!(
        (volts - ss.electrical.bus_voltage_v).abs() < 0.02,
        "{volts}"
    );
    drop(h);
    rig.stop().unwrap();
}

#[test]
fn host_silence_cuts_throttle_within_250_ms_and_rearming_clears_it() {
    let _serial = serial();
    let rig = PtyRig::spawn(presets::paper(), PtyRigOptions::default()).unwrap();
    let mut h = connect(rig.path(), config());
    h.tare(8).unwrap();
    h.start_stream(200).unwrap();
    h.arm().unwrap();
    h.set_throttle(1600).unwrap();
    let before = collect_for(&mut h, Duration::from_millis(700));
    assert_eq!(before.last().unwrap().throttle_us, 1600);

    // Go silent: keep reading (no keep-alive), wait for the fault report.
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut after = Vec::new();
    let fault = loop {
        h.drain().unwrap();
        while let Some(s) = h.pop_sample() {
            after.push(s);
        }
        if let Some(f) = h.take_fault_queued() {
            break f;
        }
        assert!(Instant::now() < deadline, "no fault within 5 s of silence");
    };
    assert_eq!(fault.cause, FaultCause::HostTimeout);
    assert!(
        (250.0..=252.0).contains(&fault.value),
        "silence {} ms",
        fault.value
    );
    // collect a little more (still silent)
    let end = Instant::now() + Duration::from_millis(100);
    while Instant::now() < end {
        h.drain().unwrap();
        while let Some(s) = h.pop_sample() {
            after.push(s);
        }
    }
    let last_full = after
        .iter()
        .rev()
        .find(|s| s.throttle_us > 1000)
        .map(|s| s.time_us)
        .unwrap_or(0);
    let last_before = before.last().unwrap().time_us;
    assert!(
        last_full <= fault.time_us,
        "throttle above minimum after the fault"
    );
    assert!(fault.time_us - last_before <= 260_000 + 5_000 * 2 + 100_000);
    assert!(
        after
            .iter()
            .filter(|s| s.time_us >= fault.time_us)
            .all(|s| s.throttle_us == 1000)
    );
    assert!(
        after.iter().any(|s| s.time_us > fault.time_us),
        "samples after the cut"
    );

    // Latched until re-armed.
    assert!(matches!(
        h.set_throttle(1500),
        Err(ClientError::Nack {
            reason: NackReason::Faulted,
            ..
        })
    ));
    let st = h.status().unwrap();
    assert_eq!(st.state, RigState::Faulted);
    assert!(st.faults.contains(FaultCause::HostTimeout));
    h.arm().unwrap();
    let st = h.status().unwrap();
    assert_eq!(st.state, RigState::Armed);
    assert!(st.faults.is_empty());
    h.set_throttle(1200).unwrap();
    h.set_throttle(1000).unwrap();
    h.disarm().unwrap();
}

#[test]
fn a_corrupting_proxy_gets_every_bad_frame_rejected_and_no_wrong_sample_accepted() {
    let _serial = serial();
    let rig = PtyRig::spawn(
        tolerant_paper(),
        PtyRigOptions {
            record_samples: true,
            ..PtyRigOptions::default()
        },
    )
    .unwrap();
    let proxy = CorruptingProxy::spawn(
        rig.path(),
        ProxyOptions {
            // ~20 % of 27-byte sample frames, ~25 % of 10-byte command frames
            to_host: Corruption {
                flip_probability: 0.006,
                drop_probability: 0.003,
            },
            to_rig: Corruption {
                flip_probability: 0.02,
                drop_probability: 0.01,
            },
            seed: 99,
        },
    )
    .unwrap();
    let config = ClientConfig {
        retries: 10,
        response_timeout_us: 150_000,
        keepalive_us: 20_000,
    };
    let mut h = connect(proxy.path(), config);
    h.start_stream(200).unwrap();
    h.arm().unwrap();
    h.set_throttle(1400).unwrap();
    let mut accepted = collect_for(&mut h, Duration::from_millis(2000));
    h.set_throttle(1000).unwrap();
    h.stop_stream().unwrap();
    h.disarm().unwrap();
    // Quiesce: read without sending until nothing moves for 300 ms.
    let mut quiet_since = Instant::now();
    let mut last = (h.decoder_stats(), proxy.stats());
    while quiet_since.elapsed() < Duration::from_millis(300) {
        h.drain().unwrap();
        while let Some(s) = h.pop_sample() {
            accepted.push(s);
        }
        let now = (h.decoder_stats(), proxy.stats());
        if now != last {
            last = now;
            quiet_since = Instant::now();
        }
    }
    let p = proxy.stats();
    let d = h.decoder_stats();
    let snap = rig.snapshot();
    println!(
        "proxy {p:?}\nhost decoder {d:?}\nrig rx {:?}\nclient {:?}",
        snap.rx_stats,
        h.stats()
    );
    assert!(
        p.corrupted_to_host >= 20 && p.corrupted_to_rig >= 5,
        "{p:?}"
    );
    // every damaged frame rejected and counted, every intact one accepted
    assert_eq!(u64::from(d.dropped()), p.corrupted_to_host);
    assert_eq!(
        u64::from(d.frames_ok),
        p.frames_to_host - p.corrupted_to_host
    );
    assert_eq!(u64::from(snap.rx_stats.dropped()), p.corrupted_to_rig);
    assert_eq!(
        u64::from(snap.rx_stats.frames_ok),
        p.frames_to_rig - p.corrupted_to_rig
    );
    // no wrong sample accepted
    let sent: std::collections::HashMap<u64, Sample> =
        snap.sent_samples.iter().map(|s| (s.time_us, *s)).collect();
    assert!(accepted.len() > 200, "{}", accepted.len());
    for s in &accepted {
        assert_eq!(
            sent.get(&s.time_us),
            Some(s),
            "accepted a sample the rig never sent"
        );
    }
    assert!(
        accepted.len() < sent.len(),
        "some samples were lost to corruption"
    );
}

#[test]
fn the_simulated_clock_runs_faster_than_real_time() {
    let _serial = serial();
    let rig = PtyRig::spawn(
        presets::paper(),
        PtyRigOptions {
            speed: 20.0,
            ..PtyRigOptions::default()
        },
    )
    .unwrap();
    let start = Instant::now();
    let deadline = start + Duration::from_secs(10);
    while rig.snapshot().sim_time_us < 4_000_000 {
        assert!(Instant::now() < deadline, "sim too slow");
        std::thread::yield_now();
        std::thread::sleep(Duration::from_millis(5));
    }
    let wall = start.elapsed().as_secs_f64();
    assert!(wall < 4.0 / 3.0, "4 s of rig time took {wall} s");
    assert!(rig.is_running());
}
