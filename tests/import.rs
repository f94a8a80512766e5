//! The binary on other stands' logs: Tyto RCbenchmark exports, a transcribed table and a
//! headerless sweep without voltage (read from `../shared/data/real`, which CI has beside the
//! clone).

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use serde_json::Value;

fn shared(rel: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/real")
        .join(rel);
    p.to_str().unwrap().to_owned()
}

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::cargo_bin("hoverbench")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn rcbenchmark_export_imports_and_fits() {
    let file = shared("rcbenchmark/StepsTest_2020-06-16_220513.csv");
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.csv");
    let (code, _, err) = run(&["import", &file, "-o", sweep.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    // The converted sweep fits exactly like the original export.
    let (code, a, err) = run(&["fit", &file, "--json"]);
    assert_eq!(code, 0, "{err}");
    let (code, b, err) = run(&["fit", sweep.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let (a, b): (Value, Value) = (
        serde_json::from_str(&a).unwrap(),
        serde_json::from_str(&b).unwrap(),
    );
    assert_eq!(a["log_kind"], "Tyto RCbenchmark / Flight Stand export");
    assert_eq!(b["log_kind"], "hoverbench sweep");
    for k in 0..=5 {
        let (x, y) = (
            a["coefficients"][k].as_f64().unwrap(),
            b["coefficients"][k].as_f64().unwrap(),
        );
        assert!(
            (x - y).abs() <= 1e-9 * x.abs().max(1e-12),
            "b{k}: {x} vs {y}"
        );
    }
    assert!(a["r_squared"].as_f64().unwrap() > 0.99);
}

#[test]
fn ctu_mrs_table_needs_a_filter_and_fits_with_one() {
    let file = shared("ctu-mrs/motor_tests.csv");
    let (code, out, err) = run(&[
        "fit",
        &file,
        "--where",
        "propeller=Carbon fiber 9450",
        "--degree",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["n_points"], 6);
    let (code, _, err) = run(&["fit", &file, "--where", "propeller=none"]);
    assert_eq!(code, 2);
    assert!(err.contains("propeller=Carbon fiber 9450"), "{err}");
}

#[test]
fn sweep_without_voltage_says_what_cannot_be_fitted() {
    let file = shared("mit-gfx/motor_14inch_prop.txt");
    let cols = "esc_us,torque_nm,thrust_n,rpm,current_a";
    let (code, _, err) = run(&["fit", &file]);
    assert_eq!(code, 2);
    assert!(err.contains("name the columns"), "{err}");
    let (code, _, err) = run(&["fit", &file, "--columns", cols]);
    assert_eq!(code, 2);
    assert!(err.contains("electrical power cannot be computed"), "{err}");
    let (code, out, err) = run(&["import", &file, "--columns", cols]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("cannot: electrical power"), "{out}");
    let (code, out, err) = run(&["fit", &file, "--columns", cols, "--volts", "11.1", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["notes"].to_string().contains("--volts"));
}
