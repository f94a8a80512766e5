//! The C interface from C: the checked-in header is the generated one, and a C program built
//! with `cc -std=c99 -Wall -Werror` against it and the staticlib gives the Rust estimator's
//! numbers on the same samples (with a capacity reading fused after the first, as a pack's
//! history does, and the rotors' power computed from the motor commands through the blob's
//! motor map where the log has no current).

use std::path::{Path, PathBuf};
use std::process::Command;

use estimator::online::{
    BatteryModel, FilterState, FlightPhase, OnlineConfig, OnlineEstimator, Sample,
};
use estimator::{MissionOptions, MotorMap, Params, Segment};
use hoverbench_online::{HbMotorMap, HbOnlineEstimate, HbOnlineState, c_header};

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn checked_in_header_is_the_generated_one() {
    let path = manifest_dir().join("include/hoverbench_online.h");
    let generated = c_header();
    if std::env::var_os("HB_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "{} differs from hoverbench_online::c_header(); regenerate it with \
         HB_UPDATE_HEADER=1 cargo test -p estimator-c --test c_interface",
        path.display()
    );
}

#[path = "../../estimator/tests/support/fixture.rs"]
mod fixture;

/// The motor map of the test's rig: `P(x) = 0.5 W + 0.0625 W/V³ · x³` per rotor (a propeller's
/// power rises with the cube of its speed, the speed with the drive voltage `x = duty · V`;
/// 108.5 W at 12 V of drive, 26.9 W at 7.5 V), measured from 1 V to 12 V of drive,
/// the ESC driving from 1050 µs to 2000 µs.
const MOTOR_IDLE_W: f64 = 0.5;
const MOTOR_W_PER_V3: f64 = 0.0625;
const MOTOR_ZERO_US: f64 = 1050.0;
const MOTOR_FULL_US: f64 = 2000.0;

fn motor_map() -> MotorMap {
    // The cubic in the map's scaled basis t = (x − c) / s: (c + s·t)³ expanded.
    let (c, s) = (6.5, 5.5);
    let k = MOTOR_W_PER_V3;
    let coefficients = [
        MOTOR_IDLE_W + k * c * c * c,
        k * 3.0 * c * c * s,
        k * 3.0 * c * s * s,
        k * s * s * s,
    ];
    MotorMap::new(
        MOTOR_ZERO_US,
        MOTOR_FULL_US,
        &coefficients,
        c,
        s,
        (1.0, 12.0),
        0.01,
    )
    .unwrap()
}

/// The ESC command that gives one rotor `power_w` on a pack of `voltage_v` under the test's map
/// (the inverse of [`motor_map`]'s cubic): what a flight controller holding that power sends.
fn command_us(power_w: f64, voltage_v: f64) -> f64 {
    let drive_v = ((power_w - MOTOR_IDLE_W) / MOTOR_W_PER_V3).cbrt();
    MOTOR_ZERO_US + drive_v / voltage_v * (MOTOR_FULL_US - MOTOR_ZERO_US)
}

/// The estimator's test platform with a LiPo pack of 12 + 6 mΩ per cell, τ 20 s, and the
/// rig's motor map.
fn params() -> Params {
    let mut battery = BatteryModel::lipo(3, 2.1).unwrap();
    battery.series_resistance_cell_ohm = 0.012;
    battery.rc_resistance_cell_ohm = 0.006;
    battery.rc_time_constant_s = 20.0;
    Params {
        battery: Some(battery),
        motor: Some(motor_map()),
        ..fixture::params()
    }
}

/// One logged sample: the battery's (with the rotors' power left to the motor map) and the
/// four motors' ESC commands, µs, when logged.
struct Logged {
    sample: Sample,
    command_us: Option<[f64; 4]>,
}

/// A discharge at 108 W from a pack a little smaller than the file's, 5 Hz, current logged on
/// the first half only, the motor commands from 150 s on (the rotors' 105.6 W read 2 % high
/// through the map, unevenly shared as a quadrotor's yaw and balance trims do), a few garbage
/// samples (the voltage not a number: the map gives no power either).
fn samples() -> Vec<Logged> {
    let mut out = Vec::new();
    let (mut soc, mut t) = (1.0f64, 0.0);
    let mut k = 0u32;
    loop {
        let flying = t >= 4.0;
        let p = if flying { 108.0 } else { 2.44 };
        let ocv = 3.0 * (3.45 + 0.75 * soc - 0.2 * (-12.0 * soc).exp());
        let i = p / (ocv - 0.04 * p / ocv);
        let v = ocv - i * 0.04;
        if v < 10.2 {
            break;
        }
        let garbage = k % 97 == 96;
        let rotors_w = (p - 2.44) * 1.02;
        let command_us = (flying && t >= 150.0)
            .then(|| [1.03, 0.97, 1.01, 0.99].map(|share| command_us(share * rotors_w / 4.0, v)));
        out.push(Logged {
            sample: Sample {
                time_s: t,
                voltage_v: if garbage {
                    f64::NAN
                } else {
                    v + 0.01 * (f64::from(k) * 1.7).sin()
                },
                current_a: (t < 300.0).then_some(i),
                phase: Some(if flying {
                    FlightPhase::Hover
                } else {
                    FlightPhase::Ground
                }),
                motor_power_w: None,
            },
            command_us,
        });
        soc -= i * 0.2 / (3600.0 * 1.9);
        t += 0.2;
        k += 1;
    }
    out
}

/// The staticlib cargo built for this test (the lib target is built with all its crate types),
/// or the one `HB_ONLINE_STATICLIB` names (e.g. the `no_std` build).
fn staticlib() -> PathBuf {
    if let Some(p) = std::env::var_os("HB_ONLINE_STATICLIB") {
        return PathBuf::from(p);
    }
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let mut found: Vec<(std::time::SystemTime, PathBuf)> = [deps, deps.parent().unwrap()]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).into_iter().flatten().flatten())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("libhoverbench_online") && n.ends_with(".a"))
        })
        .filter_map(|p| Some((p.metadata().ok()?.modified().ok()?, p)))
        .collect();
    found.sort();
    found.pop().map(|(_, p)| p).expect(
        "libhoverbench_online.a next to the test binary: run `cargo build -p estimator-c` first",
    )
}

fn compile(dir: &Path) -> PathBuf {
    let exe = dir.join("online_main");
    let out = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Werror", "-Wextra", "-I"])
        .arg(manifest_dir().join("include"))
        .arg(manifest_dir().join("tests/c/online_main.c"))
        .arg(staticlib())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .expect("a C compiler (cc) on PATH");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

#[test]
fn c_program_agrees_with_the_rust_estimator() {
    agrees(false);
}

/// `hb_online_init_with` (1 s windows, the thrust-limit end, on a blob with a thrust limit) is
/// `OnlineConfig::with_opt_ins`, `hb_online_zero_current` is `OnlineConfig::zero_current`, and
/// a window that is not a number, or the zero read switched after the first sample, is
/// `HB_ERR_OPTION` (the C program checks it).
#[test]
fn c_program_with_the_opt_ins_agrees_with_the_rust_estimator() {
    agrees(true);
}

/// Runs the C program over [`samples`] (with the opt-ins or not) and compares every 50th
/// estimate with the Rust estimator's, the rotors' power from the motor map on both sides.
fn agrees(opt_ins: bool) {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile(dir.path());
    let mut p = params();
    let mut config = OnlineConfig::default();
    if opt_ins {
        p.thrust_limit = Some(estimator::ThrustLimit {
            per_rotor_g: 150.0,
            uncertainty_g: 3.0,
            supply_voltage_v: 10.6,
        });
        config = config.with_opt_ins(1.0, true);
        config.zero_current = true;
    }
    let map = p.motor.unwrap();
    let write_blob = |params: &Params, name: &str| {
        let mut blob = [0u8; estimator::params::MAX_BLOB_LEN];
        let n = params.encode(&mut blob).unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, &blob[..n]).unwrap();
        path
    };
    let blob_path = write_blob(&p, "params.hbp");
    let without_motor_path = write_blob(&Params { motor: None, ..p }, "no-motor.hbp");
    let mut samples = samples();
    let text: String = samples
        .iter()
        .map(|l| {
            let s = &l.sample;
            let commands = l.command_us.map_or("nan nan nan nan".to_owned(), |c| {
                c.map(|u| format!("{u:.17e}")).join(" ")
            });
            format!(
                "{:.17e} {:.17e} {} {} {commands}\n",
                s.time_s,
                s.voltage_v,
                s.current_a
                    .map_or("nan".to_owned(), |i| format!("{i:.17e}")),
                s.phase.map_or(0, |p| p as u8),
            )
        })
        .collect();
    // The Rust side: the rotors' power from the same commands and voltage through the map, as
    // the C program computes it with `hb_motor_power_w` (none when the map refuses them).
    for l in &mut samples {
        l.sample.motor_power_w = l
            .command_us
            .and_then(|c| map.total_power_w(&c, l.sample.voltage_v).ok());
    }
    let from_map = samples
        .iter()
        .filter(|l| l.sample.motor_power_w.is_some())
        .count();
    let samples_path = dir.path().join("samples.txt");
    std::fs::write(&samples_path, text).unwrap();
    let mut cmd = Command::new(&exe);
    cmd.arg(&blob_path)
        .arg(&without_motor_path)
        .arg(&samples_path);
    if opt_ins {
        cmd.arg("opt-ins");
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(out.status.success(), "exit {:?}: {stdout}", out.status);

    let mut lines = stdout.lines();
    // The motor map from C, at fixed commands: four motors hovering on 11.8 V, and sixteen.
    let motor: Vec<f64> = lines
        .next()
        .unwrap()
        .strip_prefix("motor ")
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(
        motor[0],
        map.total_power_w(&[1480.0, 1510.0, 1495.5, 1502.25], 11.8)
            .unwrap()
    );
    assert_eq!(motor[1], map.total_power_w(&[1500.0; 16], 11.8).unwrap());

    let mut est = OnlineEstimator::from_params(&p, &config).unwrap();
    est.set_plan(
        &[
            Segment::Hover { duration_min: 3.0 },
            Segment::HoverUntilEmpty,
        ],
        &MissionOptions::default(),
    )
    .unwrap();
    let mut compared = 0;
    for (k, l) in samples.iter().enumerate() {
        let e = est.update(&l.sample);
        if k == 0 {
            est.observe_state(FilterState::CapacityScale, 0.9, 0.04)
                .unwrap();
        }
        if (k + 1) % 50 != 0 {
            continue;
        }
        let line = lines.next().expect("a line per 50 samples");
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f[0].parse::<usize>().unwrap(), k + 1);
        let c: Vec<f64> = f[1..8].iter().map(|v| v.parse().unwrap()).collect();
        let rust = [
            e.remaining_phase_s,
            e.remaining_phase_sigma_s,
            e.remaining_plan_s.unwrap(),
            e.soc,
            e.usable_capacity_ah,
            e.series_resistance_ohm,
            e.extra_power_w,
        ];
        for (a, b) in c.iter().zip(rust) {
            assert!(
                (a - b).abs() <= 1e-9 * (1.0 + b.abs()),
                "sample {}: C {a} vs Rust {b}",
                k + 1
            );
        }
        assert_eq!(f[8].parse::<u32>().unwrap(), e.flags);
        assert_eq!(f[9].parse::<u32>().unwrap(), e.samples_used);
        assert_eq!(f[10], "1");
        // The reading moved the capacity (the model's 2.1 Ah, its prior one-sigma 5 %).
        assert!(c[4] < 0.97 * 2.1, "sample {}: {} Ah", k + 1, c[4]);
        compared += 1;
    }
    assert!(compared > 20, "{compared}");
    // The C program took the map's power on as many samples as the Rust side: every sample
    // with commands but the garbage ones.
    let motor_ok: usize = lines
        .next()
        .unwrap()
        .strip_prefix("motor_ok ")
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(motor_ok, from_map);
    assert!(from_map > 1000, "{from_map}");
    let sizes: Vec<usize> = lines
        .next()
        .unwrap()
        .strip_prefix("size ")
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(sizes[0], std::mem::size_of::<HbOnlineState>());
    assert_eq!(sizes[1], std::mem::size_of::<HbOnlineEstimate>());
    assert_eq!(sizes[2], sizes[0]);
    assert_eq!(sizes[3], std::mem::size_of::<HbMotorMap>());
    assert_eq!(sizes[4], sizes[3]);
}
