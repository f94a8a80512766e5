//! Session time of the `paper` preset's nominal sweep (10 g steps to the plateau at 12.5 V) on
//! the simulated clock, in process: adaptive settle detection against fixed dwells, with the
//! per-step accuracy of each — the mean power of a step against the steady state at the
//! step's throttle, measured afterwards through the same firmware and sensors (3 s to settle,
//! then 3 s averaged: 600 samples), so that sensor offsets and resolution, which no settle
//! policy can remove, are in the reference too.
//!
//! `cargo bench -p rig-host --bench settle` (add `-- SEEDS` for more seeds, default 3).

use std::sync::atomic::AtomicBool;

use rig_host::bench_supply::IdealSupply;
use rig_host::settle::SettlePolicy;
use rig_host::sweep::{MemorySink, SweepConfig, SweepEnv, SweepEvent, run_sweep};
use rig_protocol::{ClientConfig, Clock, Rig};
use sim::{SimRig, presets};

struct Run {
    rig_time_s: f64,
    steps: usize,
    max_err: f64,
    mean_err: f64,
    within: usize,
    compared: usize,
    max_target_miss_g: f64,
}

fn run(policy: SettlePolicy, seed: u64) -> Run {
    let preset = presets::paper();
    let mut rig = SimRig::new(&preset, seed).expect("rig");
    rig.advance(200_000);
    let clock = rig.clock();
    let mut host = rig.into_client(ClientConfig::default());
    host.handshake().expect("handshake");
    // Calibrate the load cell as an operator would: tare, then known masses.
    host.tare(40).expect("tare");
    for m in [100.0, 200.0, 500.0] {
        host.transport_mut().rig_mut().place_mass_g(m);
        host.transport_mut().rig_mut().advance(500_000);
        host.calibrate(m as f32).expect("calibrate");
    }
    host.transport_mut().rig_mut().place_mass_g(0.0);
    host.transport_mut().rig_mut().advance(500_000);
    let identity = host.identify().expect("identify");
    let config = SweepConfig {
        settle: policy,
        ..SweepConfig::default()
    };
    let mut sink = MemorySink::default();
    let env = SweepEnv {
        clock: &clock,
        identity: &identity,
        supply: &mut IdealSupply::new(),
        observer: &mut |_e: SweepEvent<'_>| {},
        stop: &AtomicBool::new(false),
    };
    let outcome = run_sweep(&mut host, env, &config, &[], &mut sink).expect("sweep");
    if std::env::var_os("SETTLE_DEBUG").is_some() {
        for l in sink.samples.iter().filter(|l| l.step == 1) {
            let s = l.sample;
            eprintln!(
                "{} {} {} {} {:.4} {:.2}",
                l.attempt,
                u8::from(l.in_window),
                s.time_us,
                s.throttle_us,
                f64::from(s.current_a) * f64::from(s.voltage_v),
                s.thrust_g
            );
        }
    }
    // The steady-state reference of every step, measured at leisure.
    host.arm().expect("arm");
    host.start_stream(200).expect("stream");
    let mut p_refs = Vec::new();
    for r in &outcome.rows {
        host.set_throttle(r.throttle_us).expect("throttle");
        let (mut sum, mut n) = (0.0, 0.0);
        let t0 = clock.now_us();
        while clock.now_us() < t0 + 6_000_000 {
            if let Some(s) = host.next_sample().expect("sample") {
                if s.time_us > t0 + 3_000_000 && s.throttle_us == r.throttle_us {
                    sum += f64::from(s.current_a) * f64::from(s.voltage_v);
                    n += 1.0;
                }
            }
        }
        p_refs.push(sum / n);
    }
    host.set_throttle(1000).expect("throttle");
    let (mut max_err, mut sum, mut within, mut compared, mut miss) = (0.0f64, 0.0, 0, 0, 0.0f64);
    for (r, &p_ref) in outcome.rows.iter().zip(&p_refs) {
        if let Some(t) = r.target_g {
            if r.throttle_us < identity.throttle_max_us {
                miss = miss.max((r.thrust_g - t).abs());
            }
        }
        let err = (r.power_w / p_ref - 1.0).abs();
        max_err = max_err.max(err);
        sum += err;
        compared += 1;
        if err <= 0.005 {
            within += 1;
        } else {
            eprintln!(
                "  seed {seed}: step {} at {} us: {:.3} W vs steady {:.3} W ({:+.2} %), {} samples, settle {:.2} s",
                r.step,
                r.throttle_us,
                r.power_w,
                p_ref,
                100.0 * (r.power_w / p_ref - 1.0),
                r.samples,
                r.settle_s
            );
        }
    }
    Run {
        rig_time_s: outcome.rig_time_s,
        steps: outcome.rows.len(),
        max_err,
        mean_err: sum / compared.max(1) as f64,
        within,
        compared,
        max_target_miss_g: miss,
    }
}

fn main() {
    let seeds: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(3);
    let policies = [
        ("adaptive (default)", SettlePolicy::default()),
        ("fixed 3 s + 20 samples", SettlePolicy::STAND_DEFAULT),
        (
            "fixed 3 s + 200 samples",
            SettlePolicy::FixedDwell {
                dwell_s: 3.0,
                samples: 200,
            },
        ),
    ];
    println!(
        "paper preset, nominal sweep at 12.5 V, 10 g steps to the plateau, 200 Hz samples, {seeds} seeds"
    );
    println!(
        "{:<26} {:>10} {:>6} {:>16} {:>11} {:>11} {:>12}",
        "settle policy",
        "session_s",
        "steps",
        "within_0.5%",
        "mean_err_%",
        "max_err_%",
        "max_miss_g"
    );
    let mut times = Vec::new();
    for (name, policy) in policies {
        let runs: Vec<Run> = (0..seeds).map(|s| run(policy, 100 + s)).collect();
        let n = runs.len() as f64;
        let t = runs.iter().map(|r| r.rig_time_s).sum::<f64>() / n;
        let within: usize = runs.iter().map(|r| r.within).sum();
        let compared: usize = runs.iter().map(|r| r.compared).sum();
        println!(
            "{:<26} {:>10.1} {:>6.1} {:>16} {:>11.3} {:>11.3} {:>12.2}",
            name,
            t,
            runs.iter().map(|r| r.steps as f64).sum::<f64>() / n,
            format!("{within}/{compared}"),
            100.0 * runs.iter().map(|r| r.mean_err).sum::<f64>() / n,
            100.0 * runs.iter().map(|r| r.max_err).fold(0.0, f64::max),
            runs.iter().map(|r| r.max_target_miss_g).fold(0.0, f64::max),
        );
        times.push((name, t));
    }
    for (name, t) in &times[1..] {
        println!("speed-up of adaptive over {name}: {:.2}x", t / times[0].1);
    }
}
