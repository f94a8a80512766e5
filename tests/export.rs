//! `hoverbench export`: the flight-stack files and the C header, checked end to end.

use std::process::Command as Process;

mod common;
use common::{data, ok, run, shared};

#[test]
fn px4_and_ardupilot_files_from_a_real_stand_export() {
    let sweep = shared("rcbenchmark/StepsTest_2020-05-22_102946.csv");
    for (flavour, snapshot) in [("px4", "px4_params"), ("ardupilot", "ardupilot_param")] {
        let out = ok(&[
            "export",
            flavour,
            "--sweep",
            &sweep,
            "--takeoff-mass",
            "80g",
            "--cells",
            "2",
            "--capacity",
            "650",
        ]);
        insta::assert_snapshot!(snapshot, out.replace(&sweep, "SWEEP"));
    }
}

#[test]
fn c_header_compiles_and_agrees_with_the_estimator() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    ok(&[
        "fit",
        &data("paper-sweep.csv"),
        "--limit",
        &data("paper-limit-9v.csv"),
        "-o",
        params.to_str().unwrap(),
    ]);
    let header = dir.path().join("hoverbench_params.h");
    ok(&[
        "export",
        "c-header",
        params.to_str().unwrap(),
        "-o",
        header.to_str().unwrap(),
    ]);
    let main_c = dir.path().join("main.c");
    std::fs::write(
        &main_c,
        "#include <stdio.h>\n#include \"hoverbench_params.h\"\n\
         int main(void) { printf(\"%.12e %d %d\\n\", hb_power_w(150.0), HB_ROTOR_COUNT, (int)sizeof HB_PARAMS_BLOB); return 0; }\n",
    )
    .unwrap();
    let exe = dir.path().join("check");
    let cc = Process::new("cc")
        .args(["-std=c99", "-Wall", "-Werror", "-o"])
        .arg(&exe)
        .arg(&main_c)
        .output()
        .expect("a C compiler (cc) on PATH");
    assert!(
        cc.status.success(),
        "{}",
        String::from_utf8_lossy(&cc.stderr)
    );
    // The header's layout, for review; the fitted digits and blob bytes are masked (their last
    // bits may differ between CPUs) and checked numerically below instead.
    let text = std::fs::read_to_string(&header).unwrap();
    let masked: String = text
        .lines()
        .map(|l| {
            if l.starts_with("static const double HB_CURVE_COEFFS_SCALED") {
                "static const double HB_CURVE_COEFFS_SCALED[6] = { <fitted> };".to_owned()
            } else if l.trim_start().starts_with("0x") {
                "    <blob bytes>".to_owned()
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    insta::assert_snapshot!("c_header", masked);
    let out = String::from_utf8(Process::new(&exe).output().unwrap().stdout).unwrap();
    let fields: Vec<&str> = out.split_whitespace().collect();
    let c_power: f64 = fields[0].parse().unwrap();
    let file = estimator::file::ParamsFile::load(&params).unwrap();
    let p = file.to_params().unwrap();
    let rust_power = p.curve.eval_unchecked(150.0);
    assert!(
        (c_power - rust_power).abs() < 1e-9 * rust_power,
        "{c_power} vs {rust_power}"
    );
    assert_eq!(fields[1], "4");
    let mut buf = [0u8; estimator::params::MAX_BLOB_LEN];
    assert_eq!(
        fields[2].parse::<usize>().unwrap(),
        p.encode(&mut buf).unwrap()
    );
}

/// With a `[motor]` section (`hoverbench fit` of the real 3S RCbenchmark pair: the same motor
/// and propeller minutes apart, the second run's pack 0.3 V lower), the header carries the motor
/// map: its constants and evaluators give the map's power (C against Rust every 10 µs on two
/// pack voltages, the range check included), and its blob holds the map (read back from the C
/// program's bytes), as `hb_motor_map_init` of `libhoverbench_online.a` needs it.
#[test]
fn c_header_carries_the_motor_map() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    ok(&[
        "fit",
        &shared("rcbenchmark/StepsTest_2020-06-16_220340.csv"),
        "--limit",
        &shared("rcbenchmark/StepsTest_2020-06-16_220513.csv"),
        "-o",
        params.to_str().unwrap(),
    ]);
    let p = estimator::file::ParamsFile::load(&params)
        .unwrap()
        .to_params()
        .unwrap();
    let map = p.motor.expect("a [motor] section from the two runs");
    let header = dir.path().join("hoverbench_params.h");
    ok(&[
        "export",
        "c-header",
        params.to_str().unwrap(),
        "-o",
        header.to_str().unwrap(),
    ]);
    let main_c = dir.path().join("main.c");
    std::fs::write(
        &main_c,
        r#"#include <stdio.h>
#include "hoverbench_params.h"
int main(void) {
    const double supply_v[2] = {11.4, 11.7};
    unsigned i;
    int k, us;
    for (k = 0; k < 2; ++k) {
        for (us = 1000; us <= 2000; us += 10) {
            double x = hb_motor_drive_v(us, supply_v[k]);
            int in_range = x >= HB_MOTOR_DRIVE_MIN_V && x <= HB_MOTOR_DRIVE_MAX_V;
            printf("%d %.17g %d %.17g\n", us, supply_v[k], in_range, hb_motor_power_at_drive_w(x));
        }
    }
    printf("blob");
    for (i = 0; i < sizeof HB_PARAMS_BLOB; ++i) printf(" %u", (unsigned)HB_PARAMS_BLOB[i]);
    printf("\n");
    return 0;
}
"#,
    )
    .unwrap();
    let exe = dir.path().join("check");
    let cc = Process::new("cc")
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-o"])
        .arg(&exe)
        .arg(&main_c)
        .output()
        .expect("a C compiler (cc) on PATH");
    assert!(
        cc.status.success(),
        "{}",
        String::from_utf8_lossy(&cc.stderr)
    );
    let out = String::from_utf8(Process::new(&exe).output().unwrap().stdout).unwrap();
    let (mut inside, mut outside) = (0, 0);
    for line in out.lines().filter(|l| !l.starts_with("blob")) {
        let f: Vec<f64> = line
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        let (us, volts, in_range, c_power_w) = (f[0], f[1], f[2] == 1.0, f[3]);
        match map.power_w(us, volts) {
            Ok(w) => {
                assert!(in_range, "{us} µs on {volts} V: C says outside, Rust {w} W");
                assert!(
                    (c_power_w - w).abs() <= 1e-12 * w,
                    "{us} µs on {volts} V: C {c_power_w} W vs Rust {w} W"
                );
                inside += 1;
            }
            Err(e) => {
                assert!(!in_range, "{us} µs on {volts} V: C says inside, Rust {e}");
                outside += 1;
            }
        }
    }
    // The runs' steps span most of the command range; idle and the first steps are below it.
    assert!(
        inside > 100 && outside > 0,
        "{inside} inside, {outside} outside"
    );
    let bytes: Vec<u8> = out
        .lines()
        .find_map(|l| l.strip_prefix("blob "))
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(estimator::Params::decode(&bytes).unwrap().motor, Some(map));
    // The motor block's layout, for review; the fitted values (the searched zero, the scaling,
    // the range, the residual and the coefficients) are masked, checked numerically above.
    let text = std::fs::read_to_string(&header).unwrap();
    let start = text.find("/* Motor map").expect("a motor block");
    let end = text.find("static const uint8_t HB_PARAMS_BLOB").unwrap();
    let masked: String = text[start..end]
        .lines()
        .map(|l| match l.split_whitespace().collect::<Vec<_>>()[..] {
            ["#define", name, _] if name != "HB_MOTOR_FULL_US" && name != "HB_MOTOR_DEGREE" => {
                format!("#define {name} <fitted>")
            }
            _ if l.starts_with("static const double HB_MOTOR_COEFFS_SCALED") => {
                "static const double HB_MOTOR_COEFFS_SCALED[6] = { <fitted> };".to_owned()
            }
            _ => l.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    insta::assert_snapshot!("c_header_motor_map", masked);
}

#[test]
fn export_without_throttle_says_so() {
    let out = run(&[
        "export",
        "px4",
        "--sweep",
        &shared("ctu-mrs/motor_tests.csv"),
        "--where",
        "propeller=Carbon fiber 9450",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no throttle column"));
}

#[test]
fn ardupilot_expo_across_the_nominal_and_limit_sweeps() {
    let out = ok(&[
        "export",
        "ardupilot",
        "--sweep",
        &data("paper-sweep.csv"),
        "--also-sweep",
        &data("paper-limit-9v.csv"),
        "--cells",
        "3",
        "--capacity",
        "2100",
    ]);
    assert!(
        out.contains("through ArduPilot's battery-voltage scaling"),
        "{out}"
    );
    let expo: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("MOT_THST_EXPO,"))
        .unwrap()
        .parse()
        .unwrap();
    assert!((0.0..=1.0).contains(&expo));
    assert!(out.contains("MOT_BAT_VOLT_MAX,12.600000"));
}

#[test]
fn an_also_sweep_in_microseconds_gets_the_same_pwm_check_as_the_main_sweep() {
    // The main sweep's throttle is a fraction; the extra sweep's is in µs, with a PWM range
    // that is upside down. Before, only the main sweep's command was checked.
    let dir = tempfile::tempdir().unwrap();
    let us = dir.path().join("limit-us.csv");
    let mut csv = String::from("throttle,thrust_g,thrust_std_g,voltage_v\n");
    for (i, t) in [
        38.6, 54.9, 80.0, 110.0, 140.0, 160.0, 170.0, 171.0, 171.2, 171.1,
    ]
    .iter()
    .enumerate()
    {
        csv += &format!("{},{t},0.3,9.0\n", 1100 + 100 * i);
    }
    std::fs::write(&us, csv).unwrap();
    let out = run(&[
        "export",
        "ardupilot",
        "--sweep",
        &data("paper-sweep.csv"),
        "--also-sweep",
        us.to_str().unwrap(),
        "--cells",
        "3",
        "--capacity",
        "2100",
        "--pwm-min",
        "2000",
        "--pwm-max",
        "1000",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--pwm-max"), "{err}");
}

#[test]
fn no_output_overwrites_its_input_or_leaves_a_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.csv");
    std::fs::copy(data("paper-sweep.csv"), &sweep).unwrap();
    let before = std::fs::read(&sweep).unwrap();
    let s = sweep.to_str().unwrap();
    for args in [&["import", s, "-o", s][..], &["fit", s, "-o", s][..]] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("also an input"), "{args:?}: {err}");
        assert_eq!(std::fs::read(&sweep).unwrap(), before, "{args:?}");
    }
    // An -o that is a folder fails without a stray temporary file.
    let folder = dir.path().join("out");
    std::fs::create_dir(&folder).unwrap();
    let out = run(&["fit", s, "-o", folder.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let names = common::file_names(dir.path());
    assert!(
        names.iter().all(|n| !n.contains(".tmp")),
        "temporary files left: {names:?}"
    );
}
