//! `hoverbench simulate-flights`, `gap` and `gap-eval` end to end, and the gap on real
//! Crazyflie flights (read from `../shared/data/real/crazyflie`, which CI has beside the clone).

use std::path::Path;

use assert_cmd::Command;
use serde_json::Value;

fn json(args: &[&str]) -> Value {
    let out = Command::cargo_bin("hoverbench")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn simulated_set_is_diagnosed_from_its_files_without_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    let o = out.to_str().unwrap();
    Command::cargo_bin("hoverbench")
        .unwrap()
        .args([
            "simulate-flights",
            "-o",
            o,
            "--effect",
            "capacity_fade=0.12",
            "--seed",
            "4",
        ])
        .assert()
        .success();
    // The truth lies beside the flights, in a file the reader does not take.
    let truth: Value =
        serde_json::from_slice(&std::fs::read(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["effect"]["kind"], "library");
    std::fs::rename(
        out.join("truth.json"),
        dir.path().join("truth-elsewhere.json"),
    )
    .unwrap();
    let train = out.join("train");
    let held = out.join("heldout");
    let v = json(&[
        "gap",
        train.to_str().unwrap(),
        "--holdout",
        held.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v["verdict"], serde_json::json!(["capacity_fade"]));
    assert_eq!(v["unexplained"], false);
    let e = &v["effects"][0];
    assert!((e["parameters"]["fade_fraction"].as_f64().unwrap() - 0.12).abs() < 0.02);
    assert!(
        e["heldout_error_after_pct"].as_f64().unwrap()
            < 0.5 * e["heldout_error_before_pct"].as_f64().unwrap()
    );
    assert!(v["where"]["by_phase"].is_array());
    // The plots, before and after.
    let plots = dir.path().join("plots");
    Command::cargo_bin("hoverbench")
        .unwrap()
        .args([
            "gap",
            train.to_str().unwrap(),
            "--holdout",
            held.to_str().unwrap(),
            "-o",
            plots.to_str().unwrap(),
        ])
        .assert()
        .success();
    for f in ["gap-voltage-over-time", "gap-residual-by-phase"] {
        for ext in ["svg", "png"] {
            assert!(plots.join(format!("{f}.{ext}")).exists(), "{f}.{ext}");
        }
    }
}

#[test]
fn gap_eval_reports_its_rates() {
    let v = json(&[
        "gap-eval",
        "--scenarios",
        "4",
        "--seed-start",
        "200",
        "--json",
    ]);
    assert_eq!(v["scenarios"].as_array().unwrap().len(), 4);
    assert!(v["confusion"].is_array());
}

#[test]
fn crazyflie_voltage_gap_is_mostly_pack_resistance() {
    let cf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real/crazyflie");
    let v = json(&["gap", cf.to_str().unwrap(), "--json"]);
    assert!(
        v["baseline_source"]
            .as_str()
            .unwrap()
            .contains("estimated from the training flights")
    );
    assert_eq!(v["verdict"][0], "internal_resistance");
    let before = v["baseline"]["heldout"]["voltage_rmse_v"].as_f64().unwrap();
    let after = v["after"]["heldout"]["voltage_rmse_v"].as_f64().unwrap();
    assert!(
        after < 0.5 * before,
        "held-out voltage RMSE {before} → {after} V"
    );
    // 30 of the 90 flights are held out by the default rule.
    assert_eq!(v["split"]["heldout"].as_array().unwrap().len(), 30);
}

#[test]
fn table_i_summary_says_how_much_the_printed_eq8_accounts_for() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/table-i.csv");
    let v = json(&["gap-summary", file.to_str().unwrap(), "--paper", "--json"]);
    let g = &v[0];
    assert!((g["printed_min"].as_f64().unwrap() - 103.33).abs() < 0.01);
    assert!((g["consistent_min"].as_f64().unwrap() - 101.68).abs() < 0.01);
    assert!((g["eq8_accounts_for_min"].as_f64().unwrap() - 1.65).abs() < 0.02);
}
