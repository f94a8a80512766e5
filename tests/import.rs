//! The binary on other stands' logs: Tyto RCbenchmark exports, a transcribed table and a
//! headerless sweep without voltage (read from `../shared/data/real`, which CI has beside the
//! clone).

use serde_json::Value;

mod common;
use common::{outcome, shared};

#[test]
fn rcbenchmark_export_imports_and_fits() {
    let file = shared("rcbenchmark/StepsTest_2020-06-16_220513.csv");
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.csv");
    let (code, _, err) = outcome(&["import", &file, "-o", sweep.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    // The converted sweep fits exactly like the original export.
    let (code, a, err) = outcome(&["fit", &file, "--json"]);
    assert_eq!(code, 0, "{err}");
    let (code, b, err) = outcome(&["fit", sweep.to_str().unwrap(), "--json"]);
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
    let (code, out, err) = outcome(&[
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
    let (code, _, err) = outcome(&["fit", &file, "--where", "propeller=none"]);
    assert_eq!(code, 2);
    assert!(err.contains("propeller=Carbon fiber 9450"), "{err}");
}

#[test]
fn sweep_without_voltage_says_what_cannot_be_fitted() {
    let file = shared("mit-gfx/motor_14inch_prop.txt");
    let cols = "esc_us,torque_nm,thrust_n,rpm,current_a";
    let (code, _, err) = outcome(&["fit", &file]);
    assert_eq!(code, 2);
    assert!(err.contains("name the columns"), "{err}");
    let (code, _, err) = outcome(&["fit", &file, "--columns", cols]);
    assert_eq!(code, 2);
    assert!(err.contains("electrical power cannot be computed"), "{err}");
    let (code, out, err) = outcome(&["import", &file, "--columns", cols]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("cannot: electrical power"), "{out}");
    let (code, out, err) = outcome(&["fit", &file, "--columns", cols, "--volts", "11.1", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["notes"].to_string().contains("--volts"));
}

#[test]
fn a_sweep_written_by_import_is_read_by_report() {
    // The MIT sweep has single-sample steps: their spreads are written as empty cells.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("ramp.csv");
    let mut text = String::from("thrust,voltage_v,current_a,throttle\n");
    for (i, t) in [10.0, 40.0, 90.0, 160.0, 250.0, 360.0, 490.0]
        .iter()
        .enumerate()
    {
        let p = 0.1 * t + 0.0003 * t * t;
        text.push_str(&format!("{t},12,{},{}\n", p / 12.0, 1100 + 100 * i));
    }
    std::fs::write(&csv, text).unwrap();
    let sweep = dir.path().join("sweep.csv");
    let (code, _, err) = outcome(&[
        "import",
        csv.to_str().unwrap(),
        "-o",
        sweep.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    // a unitless thrust column: what was assumed is said on stderr
    assert!(
        err.contains("warning: column \"thrust\" names no unit: read as grams (g)"),
        "{err}"
    );
    let written = std::fs::read_to_string(&sweep).unwrap();
    assert!(
        written.contains(",,"),
        "expected empty spread cells:\n{written}"
    );
    let params = dir.path().join("params.toml");
    let (code, _, err) = outcome(&[
        "fit",
        sweep.to_str().unwrap(),
        "-o",
        params.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let out = dir.path().join("report");
    let (code, _, err) = outcome(&[
        "report",
        params.to_str().unwrap(),
        "--sweep",
        sweep.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--structure-mass",
        "0.5",
        "--avionics-power",
        "2",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.join("fig3-thrust-curve.png").is_file());
}

#[test]
fn a_table_of_several_propellers_warns_and_points_to_where() {
    let (code, _, err) = outcome(&["import", &shared("ctu-mrs/motor_tests.csv")]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("column \"propeller\" takes") && err.contains("--where \"propeller="),
        "{err}"
    );
}

/// Files that parse as CSV but hold something no one meant: each is exit 2 with file, line and
/// column.
#[test]
fn silently_wrong_tables_are_refused_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[u8], &str); 5] = [
        (
            "dup.csv",
            b"thrust_g,power_w,thrust_g\n1,2,3\n4,5,6\n",
            "dup.csv, line 1, column 3: column \"thrust_g\" appears twice",
        ),
        (
            "nul.csv",
            b"thrust_g,power_w,val\0id\n1,2,true\n4,5,false\n",
            "nul.csv, line 1, column 3: the column name",
        ),
        (
            "neg-samples.csv",
            b"thrust_g,power_w,samples\n1,2,4\n4,5,-3\n",
            "neg-samples.csv, line 3, column \"samples\": \"-3\" is not a whole number",
        ),
        (
            "frac-samples.csv",
            b"thrust_g,power_w,samples\n1,2,2.5\n4,5,3\n",
            "frac-samples.csv, line 2, column \"samples\": \"2.5\" is not a whole number",
        ),
        (
            "neg-std.csv",
            b"thrust_g,thrust_std_g,power_w\n1,0.1,2\n4,-0.2,5\n",
            "neg-std.csv, line 3, column \"thrust_std_g\": \"-0.2\" is not a standard deviation",
        ),
    ];
    for (name, bytes, expected) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let (code, _, err) = outcome(&["import", p.to_str().unwrap()]);
        assert_eq!(code, 2, "{name}: {err}");
        let p = p.to_str().unwrap();
        assert!(err.contains(&expected.replace(name, p)), "{name}: {err}");
    }
    // NaN spread
    let p = dir.path().join("nan-std.csv");
    std::fs::write(&p, "thrust_g,thrust_std_g,power_w\n1,NaN,2\n4,0.1,5\n").unwrap();
    let (code, _, err) = outcome(&["import", p.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("line 2, column \"thrust_std_g\": \"NaN\" is not a finite number"),
        "{err}"
    );
}
