//! End-to-end tests of `hoverbench sweep` and `hoverbench characterise` over real
//! pseudo-terminals: the simulated rig (the real firmware core) and the simulated bench
//! supply, coupled electrically, driven by the binary as hardware would be.
//!
//! The rig runs 5× faster than real time; every wait polls with a generous deadline. The
//! tests take a lock so that no two simulated benches compete for the CPU at once.

#![cfg(unix)]

use std::collections::HashSet;
use std::path::Path;
use std::process::{Child, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use rig_host::rig_protocol::{FaultCause, RigState};
use rig_host::simbench::{SimBench, SimBenchOptions};
use serde_json::Value;
use sim::pty::{CorruptingProxy, Corruption, ProxyOptions};

mod common;
use common::{bin, ok, run};

const SPEED: f64 = 5.0;

static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The rig's host timeout in rig time: the paper preset's 250 ms of the host's (real) time,
/// which `SimBench` scales by `SPEED` (rig-host's `simbench` docs).
fn host_timeout_rig_us() -> u64 {
    rig_host::simbench::host_timeout_in_rig_time_us(
        sim::presets::paper().firmware.host_timeout_us,
        SPEED,
    )
}

fn bench(seed: u64, record: bool) -> SimBench {
    SimBench::spawn(
        sim::presets::paper(),
        SimBenchOptions {
            speed: SPEED,
            seed,
            record_samples: record,
            ..SimBenchOptions::default()
        },
    )
    .unwrap()
}

fn sweep_args<'a>(rig: &'a str, supply: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "sweep", "--rig", rig, "--supply", supply, "--speed", "5", "-o", out,
    ]
}

/// The step rows of a sweep log (data lines after the header), as text.
fn rows(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .skip(1)
        .map(str::to_owned)
        .collect()
}

fn field(row: &str, i: usize) -> &str {
    row.split(',').nth(i).unwrap()
}

/// Power (W) at `thrust_g` of the curve that `hoverbench fit --json` found.
fn fitted_power(fit: &Value, thrust_g: f64) -> f64 {
    fit["coefficients"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .fold(0.0, |acc, c| acc * thrust_g + c.as_f64().unwrap())
}

/// `hoverbench fit` of a characterise session's sweep and limit logs, as JSON.
fn fit_session(session: &Path) -> Value {
    serde_json::from_str(&ok(&[
        "fit",
        session.join("sweep.csv").to_str().unwrap(),
        "--limit",
        session.join("limit.csv").to_str().unwrap(),
        "--json",
    ]))
    .unwrap()
}

fn wait_for(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let end = Instant::now() + timeout;
    while !f() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn kill_at_rows(child: &mut Child, log: &Path, n: usize) {
    wait_for("steps in the log", Duration::from_secs(120), || {
        if let Ok(Some(status)) = child.try_wait() {
            let mut err = String::new();
            if let Some(e) = child.stderr.as_mut() {
                use std::io::Read;
                let _ = e.read_to_string(&mut err);
            }
            panic!("sweep ended early: {status}\n{err}");
        }
        rows(log).len() >= n
    });
}

#[test]
fn characterise_on_the_simulated_bench_lands_on_the_paper_optima() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    let s = session.to_str().unwrap();
    let out = ok(&["characterise", "--speed", "5", "-o", s]);
    let first = out.lines().next().unwrap();
    assert!(first.starts_with("simulated bench:"), "{first}");
    assert!(first.contains("5× real time"), "{first}");
    for f in [
        "sweep.csv",
        "sweep-samples.csv",
        "limit.csv",
        "limit-samples.csv",
        "params.toml",
        "summary.txt",
        "summary.json",
    ] {
        assert!(session.join(f).exists(), "{f} missing");
    }
    let params = session.join("params.toml");
    let opt: Value = serde_json::from_str(&ok(&[
        "optimise",
        "--params",
        params.to_str().unwrap(),
        "--structure-mass",
        "431g",
        "--avionics-power",
        "2.44",
        "--energy-density",
        "164",
        "--json",
    ]))
    .unwrap();
    let g = |a: &str, b: &str| opt[a][b].as_f64().unwrap();
    let (im, it) = (g("ideal", "battery_mass_kg"), g("ideal", "endurance_min"));
    let (rm, rt) = (
        g("realistic", "battery_mass_kg"),
        g("realistic", "endurance_min"),
    );
    println!("ideal {im:.4} kg {it:.3} min, realistic {rm:.4} kg {rt:.3} min");
    assert!((im - 0.353).abs() <= 0.005, "ideal m_B {im}");
    assert!((it / 19.76 - 1.0).abs() <= 0.01, "ideal t_E {it}");
    assert!((rm - 0.169).abs() <= 0.005, "realistic m_B {rm}");
    assert!((rt / 15.28 - 1.0).abs() <= 0.01, "realistic t_E {rt}");
    // The session's logs are what `hoverbench fit` reads.
    let fit = fit_session(&session);
    assert_eq!(fit["log_kind"], "hoverbench sweep");
    let m_l = fit["thrust_limit"]["total_kg"].as_f64().unwrap();
    assert!((m_l - 0.600).abs() <= 0.005, "m_L {m_l}");
    // The motor map: power from the ESC command and the supply voltage, from both sweeps, in
    // params.toml, the blob, the summaries and `hoverbench fit --json`.
    let file = estimator::file::ParamsFile::load(&params).unwrap();
    let motor = file.motor.as_ref().expect("a [motor] section");
    assert_eq!(motor.full_us, 2000.0);
    // The simulated ESC drives from the rig's 1000 µs: the search finds it.
    assert!(
        (motor.zero_us - 1000.0).abs() < 10.0,
        "zero_us {}",
        motor.zero_us
    );
    assert_eq!(motor.sweeps.len(), 2);
    for (sweep, volts) in motor.sweeps.iter().zip([12.5, 9.0]) {
        assert!((sweep.supply_voltage_v - volts).abs() < 0.1, "{sweep:?}");
        assert!(sweep.rmse_fraction < 0.02, "{sweep:?}");
    }
    let p = file.to_params().unwrap();
    let map = p.motor.unwrap();
    let mut blob = [0u8; estimator::params::MAX_BLOB_LEN];
    let n = p.encode(&mut blob).unwrap();
    assert_eq!(
        estimator::Params::decode(&blob[..n]).unwrap().motor,
        Some(map)
    );
    // The map's power at each limit step's command and voltage is the logged power.
    for row in rows(&session.join("limit.csv")) {
        let (us, thrust, volts, power): (f64, f64, f64, f64) = (
            field(&row, 1).parse().unwrap(),
            field(&row, 2).parse().unwrap(),
            field(&row, 6).parse().unwrap(),
            field(&row, 8).parse().unwrap(),
        );
        if thrust < 20.0 {
            continue;
        }
        let p = map.power_w(us, volts).unwrap();
        assert!((p / power - 1.0).abs() < 0.02, "{row}: map {p} W");
    }
    assert!(fit["motor_map"]["zero_us"].as_f64().is_some(), "{fit}");
    let text = std::fs::read_to_string(session.join("summary.txt")).unwrap();
    assert!(text.contains("motor map: power_w = p(duty × V)"), "{text}");
    assert!(out.contains("motor map: "), "{out}");
    // Every nominal step hit its target within ±1 g, except the last at full throttle.
    let r = rows(&session.join("sweep.csv"));
    assert!(r.len() >= 26, "{} steps", r.len());
    for row in &r[..r.len() - 1] {
        let target: f64 = field(row, 1).parse().unwrap();
        let thrust: f64 = field(row, 3).parse().unwrap();
        assert!((thrust - target).abs() <= 1.0, "{row}");
        assert_eq!(field(row, 14), "CV");
    }
    assert_eq!(field(r.last().unwrap(), 2), "2000");

    // The session stored its platform: the report needs no --structure-mass/--avionics-power.
    let report = dir.path().join("report-again");
    ok(&["report", s, "-o", report.to_str().unwrap()]);
    assert!(report.join("report.html").exists());

    // A second run on the folder while one holds it is refused, and nothing moves.
    let before = std::fs::read(session.join("sweep.csv")).unwrap();
    {
        let _held = rig_host::session::SessionLock::acquire(&session).unwrap();
        let out = run(&["characterise", "--speed", "5", "--resume", "-o", s]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("in use by another hoverbench run"), "{err}");
    }
    assert_eq!(std::fs::read(session.join("sweep.csv")).unwrap(), before);

    // Resuming the finished session neither calibrates again nor forgets the rig time.
    let summary = |p: &Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(p.join("summary.json")).unwrap()).unwrap()
    };
    let first_summary = summary(&session);
    let out = run(&["characterise", "--speed", "5", "--resume", "-o", s]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let all = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!all.contains("calibrating"), "{all}");
    let again = summary(&session);
    for sweep in ["nominal", "limit"] {
        let t0 = first_summary[sweep]["rig_time_s"].as_f64().unwrap();
        let t1 = again[sweep]["rig_time_s"].as_f64().unwrap();
        assert!(t0 > 0.0 && t1 == t0, "{sweep}: {t0} then {t1}");
    }
    assert_eq!(again["calibration"], first_summary["calibration"]);
    assert_eq!(std::fs::read(session.join("sweep.csv")).unwrap(), before);
}

/// The physical `paper-physical` preset through the whole session: what must hold for a rotor
/// of those values (its thrust limit at 9.0 V, its overall figure of merit), and that the
/// session completes with the paper's platform figures but without Battery A's mission, which
/// that rotor cannot lift at 9.0 V. It does not land on the paper's optima, and no physical
/// rotor does (`sim::presets` module docs).
#[test]
fn characterise_with_the_physical_paper_preset() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    let s = session.to_str().unwrap();
    let out = ok(&[
        "characterise",
        "--preset",
        "paper-physical",
        "--speed",
        "5",
        "-o",
        s,
    ]);
    assert!(out.contains("simulated `paper-physical` rig"), "{out}");
    assert!(session.join("report").join("report.html").exists());
    let platform = std::fs::read_to_string(session.join("platform.toml")).unwrap();
    assert!(platform.contains("structure_mass_kg = 0.431"), "{platform}");
    assert!(!platform.contains("battery_mass_kg"), "{platform}");
    let fit = fit_session(&session);
    // 260 g at 12.6 V gives ≈ 260·(9/12.6)² = 133 g at 9.0 V for a low-resistance motor.
    let per_rotor = fit["thrust_limit"]["total_kg"].as_f64().unwrap() * 250.0;
    assert!((130.0..=140.0).contains(&per_rotor), "limit {per_rotor} g");
    // Electrical power at 150 g against momentum theory's ideal for a 200 mm disk: the overall
    // figure of merit of typical parts, 0.35–0.55 (Fig. 3's reconstruction has 0.24).
    let p150 = fitted_power(&fit, 150.0);
    let ideal_w =
        (0.150f64 * 9.80665).powf(1.5) / (2.0 * 1.225 * std::f64::consts::PI * 0.01).sqrt();
    let overall = ideal_w / p150;
    println!(
        "paper-physical session: limit {per_rotor:.1} g, {p150:.2} W at 150 g, overall FM {overall:.3}"
    );
    assert!((0.35..=0.55).contains(&overall), "{overall}");
}

#[test]
fn bad_characterise_settings_fail_before_the_rig_moves() {
    let dir = tempfile::tempdir().unwrap();
    for bad in [
        &["--degree", "40"][..],
        &["--rate", "0"][..],
        &["--limit-step-us", "0"][..],
    ] {
        let session = dir.path().join(bad[0].trim_start_matches('-'));
        let mut args = vec![
            "characterise",
            "--speed",
            "5",
            "-o",
            session.to_str().unwrap(),
        ];
        args.extend_from_slice(bad);
        let t = Instant::now();
        let out = run(&args);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("invalid setting"), "{bad:?}: {err}");
        // Nothing was started: no simulated bench line, no logs.
        assert!(String::from_utf8_lossy(&out.stdout).is_empty(), "{bad:?}");
        assert!(!session.join("sweep.csv").exists(), "{bad:?}");
        assert!(t.elapsed() < Duration::from_secs(20), "{bad:?}");
    }
}

#[test]
fn host_killed_mid_sweep_watchdog_drops_throttle_and_resume_matches_an_uninterrupted_fit() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("sweep.csv");
    let l = log.to_str().unwrap();
    let b = bench(5, false);
    let (rp, sp) = (b.rig_path(), b.supply_path().to_owned());
    let mut child = bin()
        .args(sweep_args(&rp, &sp, l))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    kill_at_rows(&mut child, &log, 8);
    let before = rows(&log);
    assert!(
        b.rig_snapshot().truth.unwrap().throttle_us > 1100.0,
        "spinning at the kill"
    );
    // The watchdog: throttle to minimum and a latched host-timeout fault within the host
    // timeout (`host_timeout_rig_us()` of rig time) after the last frame from the host, at the
    // first pass of the rig's loop after it ran out. The rig's snapshots (refreshed every pass
    // of its loop), traced from before the kill, bracket that last frame by the
    // frames-received counter: it arrived after the last snapshot with a lower count and no
    // later than the first with the final count.
    let trace: Vec<(u64, u32, bool)> = std::thread::scope(|scope| {
        let tracer = scope.spawn(|| {
            let mut trace = Vec::new();
            let end = Instant::now() + Duration::from_secs(10);
            while Instant::now() < end {
                let s = b.rig_snapshot();
                let dropped = s.faults.contains(FaultCause::HostTimeout)
                    && s.truth.is_some_and(|t| t.throttle_us <= 1000.0);
                trace.push((s.sim_time_us, s.rx_stats.frames_ok, dropped));
                if dropped {
                    break;
                }
                std::thread::sleep(Duration::from_micros(200));
            }
            trace
        });
        std::thread::sleep(Duration::from_millis(20));
        child.kill().unwrap();
        child.wait().unwrap();
        tracer.join().unwrap()
    });
    assert!(
        trace.last().unwrap().2,
        "the watchdog did not trip within 10 s"
    );
    let &(t_drop_us, final_count, _) = trace.last().unwrap();
    let i_before = trace
        .iter()
        .rposition(|(_, n, _)| *n < final_count)
        .expect("frames arrived while the trace ran");
    let t_before_last_frame_us = trace[i_before].0;
    let t_after_last_frame_us = trace[i_before + 1].0;
    // The pass of the loop before the one that dropped the throttle (the tracer polls faster
    // than the loop runs, so repeated snapshots are skipped).
    let t_pass_before_drop_us = trace
        .iter()
        .rev()
        .map(|(t, _, _)| *t)
        .find(|t| *t < t_drop_us)
        .expect("the trace saw the rig before the drop");
    let frame_window_ms = (t_after_last_frame_us - t_before_last_frame_us) as f64 / 1000.0;
    let last_pass_ms = (t_drop_us - t_pass_before_drop_us) as f64 / 1000.0;
    let bound_ms = (t_drop_us - t_before_last_frame_us) as f64 / 1000.0;
    println!(
        "throttle at minimum ≤ {bound_ms:.0} ms of rig time after the host's last frame \
         (frame window {frame_window_ms:.0} ms, last loop pass {last_pass_ms:.0} ms)"
    );
    // The timeout, plus the window that brackets the last frame and the loop pass in which the
    // timeout ran out (on a loaded machine a pass can be descheduled, and rig time runs on).
    let timeout_ms = host_timeout_rig_us() as f64 / 1000.0;
    assert!(
        bound_ms <= timeout_ms + frame_window_ms + last_pass_ms,
        "{bound_ms} ms > {timeout_ms} ms + {frame_window_ms} ms + {last_pass_ms} ms"
    );
    // ... and not before the timeout ran out.
    assert!(
        bound_ms >= timeout_ms,
        "dropped {bound_ms} ms after a frame, before the {timeout_ms} ms timeout"
    );
    assert_eq!(b.rig_snapshot().state, RigState::Faulted);
    // Every step completed before the kill is intact, in order.
    let after_kill = rows(&log);
    assert!(after_kill.len() >= before.len());
    assert_eq!(after_kill[..before.len()], before[..]);
    for (i, r) in after_kill.iter().enumerate() {
        assert_eq!(r.split(',').count(), 16, "{r}");
        assert_eq!(field(r, 0), i.to_string());
    }
    // Resume to the end.
    let mut args = sweep_args(&rp, &sp, l);
    args.push("--resume");
    let out = ok(&args);
    assert!(out.contains("resuming after"), "{out}");
    let resumed = rows(&log);
    assert_eq!(resumed[..after_kill.len()], after_kill[..]);
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains("# resumed: after"));
    assert!(text.trim_end().ends_with("# end: complete"), "{text}");
    for (i, r) in resumed.iter().enumerate() {
        assert_eq!(field(r, 0), i.to_string());
    }
    drop(b);

    // An uninterrupted sweep on a fresh bench.
    let b2 = bench(6, false);
    let log2 = dir.path().join("uninterrupted.csv");
    ok(&sweep_args(
        &b2.rig_path(),
        b2.supply_path(),
        log2.to_str().unwrap(),
    ));
    drop(b2);
    let fit = |p: &Path| -> Value {
        serde_json::from_str(&ok(&["fit", p.to_str().unwrap(), "--json"])).unwrap()
    };
    if std::env::var_os("RIG_TEST_KEEP").is_some() {
        std::fs::copy(&log, "/tmp/hb/resumed.csv").unwrap();
        std::fs::copy(&log2, "/tmp/hb/uninterrupted.csv").unwrap();
        std::fs::copy(
            dir.path().join("sweep-samples.csv"),
            "/tmp/hb/resumed-samples.csv",
        )
        .unwrap();
    }
    let (f1, f2) = (fit(&log), fit(&log2));
    for t in [30.0, 80.0, 130.0, 180.0, 230.0] {
        let (p1, p2) = (fitted_power(&f1, t), fitted_power(&f2, t));
        println!("{t} g: resumed {p1:.3} W, uninterrupted {p2:.3} W");
        assert!((p1 / p2 - 1.0).abs() < 0.01, "{t} g: {p1} vs {p2}");
    }
}

#[test]
fn bit_flips_and_dropped_bytes_never_log_a_wrong_sample() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("sweep.csv");
    let b = bench(9, true);
    let damage = Corruption {
        flip_probability: 2e-3,
        drop_probability: 1e-3,
    };
    let proxy = CorruptingProxy::spawn(
        b.rig().path(),
        ProxyOptions {
            to_host: damage,
            to_rig: damage,
            seed: 3,
        },
    )
    .unwrap();
    let proxy_path = proxy.path().display().to_string();
    let mut args = sweep_args(&proxy_path, b.supply_path(), log.to_str().unwrap());
    args.extend(["--max-target", "120"]);
    let out = run(&args);
    let stats = proxy.stats();
    println!("{stats:?}\n{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    if out.status.success() {
        assert!(stats.corrupted_to_host > 10, "{stats:?}");
        assert!(text.trim_end().ends_with("# end: complete"));
        assert_eq!(rows(&log).len(), 12);
    } else {
        // Stopped safely: the reason closes the log, the rig is at rest, the supply off.
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            text.is_empty() || text.contains("# end: stopped:"),
            "{text}"
        );
        assert!(err.contains("error:"), "{err}");
        assert_ne!(b.rig_snapshot().state, RigState::Armed);
        assert!(!b.supply_device().settings().output_on);
    }
    // Every logged sample is one the rig sent, bit for bit.
    let sent: HashSet<(u64, u16, u32, u32, u32)> = b
        .rig_snapshot()
        .sent_samples
        .iter()
        .map(|s| {
            (
                s.time_us,
                s.throttle_us,
                s.thrust_g.to_bits(),
                s.current_a.to_bits(),
                s.voltage_v.to_bits(),
            )
        })
        .collect();
    let samples = std::fs::read_to_string(dir.path().join("sweep-samples.csv")).unwrap_or_default();
    let mut n = 0;
    for l in samples
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("step"))
    {
        let c: Vec<&str> = l.split(',').collect();
        let key = (
            c[3].parse().unwrap(),
            c[4].parse().unwrap(),
            c[5].parse::<f32>().unwrap().to_bits(),
            c[6].parse::<f32>().unwrap().to_bits(),
            c[7].parse::<f32>().unwrap().to_bits(),
        );
        assert!(sent.contains(&key), "logged sample the rig never sent: {l}");
        n += 1;
    }
    println!("{n} samples logged, every one as the rig sent it");
    if out.status.success() {
        assert!(n > 1000, "{n} samples");
    }
}

#[test]
fn supply_current_limit_marks_rows_invalid_backs_off_and_the_fit_skips_them() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("sweep.csv");
    let b = bench(11, false);
    let rp = b.rig_path();
    let mut args = sweep_args(&rp, b.supply_path(), log.to_str().unwrap());
    args.extend(["--current-limit", "4"]);
    let out = ok(&args);
    assert!(out.contains("current limit"), "{out}");
    let r = rows(&log);
    let invalid: Vec<&String> = r.iter().filter(|r| field(r, 15) == "false").collect();
    assert_eq!(invalid.len(), 1, "{r:#?}");
    let bad = invalid[0];
    println!("current-limited row: {bad}");
    assert_eq!(field(bad, 14), "CC");
    assert_eq!(
        bad,
        r.last().unwrap(),
        "the sweep stops at the limited step"
    );
    // Current-limited: the bus sagged below the set voltage at the limit.
    let (i, v): (f64, f64) = (
        field(bad, 5).parse().unwrap(),
        field(bad, 7).parse().unwrap(),
    );
    assert!(i <= 4.05 && v < 12.4, "{bad}");
    for row in &r[..r.len() - 1] {
        assert_eq!(field(row, 14), "CV");
    }
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.contains("# end: stopped: supply current-limited"),
        "{text}"
    );
    // Backed off: throttle at minimum, disarmed, supply off.
    assert_eq!(b.rig_snapshot().state, RigState::Disarmed);
    assert!(!b.supply_device().settings().output_on);
    let fit: Value = serde_json::from_str(&ok(&[
        "fit",
        log.to_str().unwrap(),
        "--degree",
        "3",
        "--json",
    ]))
    .unwrap();
    assert_eq!(fit["skipped_invalid_rows"], 1);
    assert_eq!(fit["n_points"].as_u64().unwrap() as usize, r.len() - 1);
}

#[test]
fn ctrl_c_stops_safely_with_the_reason_in_the_log() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("sweep.csv");
    let b = bench(13, false);
    let mut child = bin()
        .args(sweep_args(
            &b.rig_path(),
            b.supply_path(),
            log.to_str().unwrap(),
        ))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    kill_at_rows(&mut child, &log, 4);
    // SAFETY: sending SIGINT to our own child process.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    assert_eq!(rc, 0);
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("interrupted") && err.contains("--resume"),
        "{err}"
    );
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.trim_end().ends_with("# end: stopped: interrupted"),
        "{text}"
    );
    assert_eq!(b.rig_snapshot().state, RigState::Disarmed);
    assert!(b.rig_snapshot().truth.unwrap().throttle_us <= 1000.0);
    assert!(!b.supply_device().settings().output_on);
}

#[test]
fn ports_lists_without_failing() {
    let v: Value = serde_json::from_str(&ok(&["ports", "--json"])).unwrap();
    assert!(v.is_array());
}

#[test]
fn a_vanished_rig_port_stops_the_sweep_safely() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("sweep.csv");
    let b = bench(17, false);
    // The proxy stands in for a USB adapter that is unplugged mid-sweep.
    let proxy = CorruptingProxy::spawn(
        b.rig().path(),
        ProxyOptions {
            to_host: Corruption::NONE,
            to_rig: Corruption::NONE,
            seed: 1,
        },
    )
    .unwrap();
    let pp = proxy.path().display().to_string();
    let mut child = bin()
        .args(sweep_args(&pp, b.supply_path(), log.to_str().unwrap()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    kill_at_rows(&mut child, &log, 3);
    drop(proxy);
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err}");
    assert!(err.contains("sweep stopped"), "{err}");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.trim_end()
            .lines()
            .last()
            .unwrap()
            .starts_with("# end: stopped:"),
        "{text}"
    );
    assert!(rows(&log).len() >= 3);
    // The host switched the supply off; the rig's watchdog stopped the motor.
    assert!(!b.supply_device().settings().output_on);
    wait_for("the rig's watchdog", Duration::from_secs(10), || {
        let s = b.rig_snapshot();
        s.state != RigState::Armed && s.truth.is_some_and(|t| t.throttle_us <= 1000.0)
    });
}
