//! End-to-end tests of `hoverbench rig-gap` and `hoverbench rig-gap-eval`.

mod common;
use common::{bin, json, ok, shared};

#[test]
fn rig_gap_json_on_a_one_cell_stand_names_the_sag() {
    let v = json(&[
        "rig-gap",
        "--json",
        &shared("rcbenchmark/StepsTest20230615_2023-06-15_174003.csv"),
    ]);
    for key in ["verdict", "unexplained", "effects", "where", "baseline"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    let e = &v["effects"][0];
    assert_eq!(e["effect"], "supply_sag");
    for key in [
        "parameters",
        "share_of_gap",
        "heldout_error_before_pct",
        "heldout_error_after_pct",
    ] {
        assert!(e.get(key).is_some(), "effect misses {key}");
    }
    let before = e["heldout_error_before_pct"]["voltage_v"]
        .as_f64()
        .expect("number");
    let after = e["heldout_error_after_pct"]["voltage_v"]
        .as_f64()
        .expect("number");
    assert!(after < 0.2 * before, "{before} → {after}");
}

#[test]
fn rig_gap_writes_its_figure_and_residuals() {
    let dir = tempfile::tempdir().expect("temp dir");
    ok(&[
        "rig-gap",
        "--where",
        "propeller=DJI plastic 9450",
        "-o",
        dir.path().to_str().unwrap(),
        &shared("ctu-mrs/motor_tests.csv"),
    ]);
    for f in [
        "rig-gap.json",
        "rig-gap.svg",
        "rig-gap.png",
        "rig-gap-residuals.csv",
    ] {
        let p = dir.path().join(f);
        assert!(p.metadata().map(|m| m.len() > 100).unwrap_or(false), "{f}");
    }
}

#[test]
fn rig_gap_says_what_is_wrong_with_a_log_without_power() {
    let dir = tempfile::tempdir().expect("temp dir");
    let f = dir.path().join("thrust-only.csv");
    std::fs::write(
        &f,
        "throttle,thrust_g\n0.2,50\n0.4,150\n0.6,300\n0.8,480\n1.0,700\n",
    )
    .expect("write");
    let out = bin().arg("rig-gap").arg(&f).output().expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no power"), "{err}");
    assert!(!err.contains("panicked"));
}

#[test]
fn rig_gap_eval_runs_blind_and_makes_nothing_worse() {
    let v = json(&[
        "rig-gap-eval",
        "--scenarios",
        "8",
        "--seed",
        "1000",
        "--json",
    ]);
    assert_eq!(v["summary"]["worse"], 0);
    assert_eq!(v["runs"].as_array().map(Vec::len), Some(8));
    let none = &v["summary"]["none_right"];
    assert_eq!(none[0], none[1], "every none scenario called none");
}
