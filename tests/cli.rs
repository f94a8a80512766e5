//! End-to-end tests of the `hoverbench` binary: the paper reproduction, the fit → params →
//! estimator chain, and bad input (one clear message, exit code 2, nothing written).

use serde_json::Value;

mod common;
use common::{data_path, json, nested_plan, ok, refused, replace_line, run};

fn f(v: &Value, path: &str) -> f64 {
    path.split('.')
        .fold(v, |v, k| match k.parse::<usize>() {
            Ok(i) => &v[i],
            Err(_) => &v[k],
        })
        .as_f64()
        .unwrap_or_else(|| panic!("{path} missing in {v}"))
}

fn assert_close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, want {want} ± {tol}"
    );
}

/// Asserts each `(path, want, tolerance, what)` of `checks` on the JSON `v`.
fn assert_fields(v: &Value, checks: &[(&str, f64, f64, &str)]) {
    for &(path, want, tol, what) in checks {
        assert_close(f(v, path), want, tol, what);
    }
}

/// The paper's optimum, ideal and realistic (battery mass and endurance); `realistic_t_tol` is
/// the tolerance on the realistic endurance, min.
fn assert_paper_optimum(v: &Value, realistic_t_tol: f64) {
    assert_fields(
        v,
        &[
            ("ideal.battery_mass_kg", 0.3529, 0.001, "ideal m_B"),
            ("ideal.endurance_min", 19.762, 0.01, "ideal t_E"),
            ("realistic.battery_mass_kg", 0.1690, 0.001, "realistic m_B"),
            (
                "realistic.endurance_min",
                15.278,
                realistic_t_tol,
                "realistic t_E",
            ),
        ],
    );
}

#[test]
fn paper_reproduces_the_reconstruction_column() {
    let v = json(&["paper", "--json"]);
    assert_paper_optimum(&v, 0.01);
    assert_fields(
        &v,
        &[
            ("batteries.0.endurance_min", 13.826, 0.01, "Battery-A"),
            ("batteries.1.endurance_min", 9.854, 0.01, "Battery-B"),
            ("table_i.printed_eq8_min", 103.33, 0.01, "Table I printed"),
            (
                "table_i.consistent_eq8_min",
                101.68,
                0.01,
                "Table I consistent",
            ),
        ],
    );
    assert_eq!(f(&v, "table_i.measured_mean_min"), 102.3);
}

#[test]
fn paper_human_output() {
    insta::assert_snapshot!(ok(&["paper"]));
}

#[test]
fn fit_then_optimise_and_mission_from_the_written_params() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    let blob = dir.path().join("params.hbp");
    let sweep = data_path("paper-sweep.csv");
    let limit = data_path("paper-limit-9v.csv");
    let v = json(&[
        "fit",
        sweep.to_str().unwrap(),
        "--limit",
        limit.to_str().unwrap(),
        "-o",
        params.to_str().unwrap(),
        "--blob",
        blob.to_str().unwrap(),
        "--json",
    ]);
    // The invalid row is skipped, the 27 valid ones fitted.
    assert_eq!(f(&v, "n_points"), 27.0);
    assert_eq!(f(&v, "skipped_invalid_rows"), 1.0);
    assert_eq!(v["coefficients"].as_array().unwrap().len(), 6);
    assert_close(f(&v, "thrust_limit.per_rotor_g"), 150.0, 0.5, "limit");

    let p = params.to_str().unwrap();
    let platform = ["--structure-mass", "0.431", "--avionics-power", "2.44"];
    let mut args = vec![
        "optimise",
        "--params",
        p,
        "--energy-density",
        "164",
        "--json",
    ];
    args.extend(platform);
    let o = json(&args);
    assert_paper_optimum(&o, 0.02);

    let mut args = vec![
        "mission",
        "--params",
        p,
        "--battery-mass",
        "144g",
        "--energy-density",
        "164",
        "--plan",
        "3x(hover 2m; attach 30m); hover until empty",
        "--json",
    ];
    args.extend(platform);
    let m = json(&args);
    assert_close(f(&m, "total_min"), 101.68, 0.02, "Table I consistent");

    let bytes = std::fs::read(&blob).unwrap();
    let decoded = estimator::Params::decode(&bytes).unwrap();
    assert_eq!(decoded.rotor_count, 4);
    assert_close(decoded.thrust_limit_kg().unwrap(), 0.6, 0.002, "blob m_L");
}

#[test]
fn catalogue_ranking_marks_packs_over_the_limit() {
    let cat = data_path("paper-batteries.csv");
    let v = json(&[
        "optimise",
        "--paper",
        "--catalogue",
        cat.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v[0]["name"], "TP-2100-3S1P (Battery-A)");
    assert_close(f(&v, "0.endurance_min"), 13.826, 0.01, "A");
    // With 150 g more payload, Battery-A is over the 0.600 kg limit and ranks at zero.
    let v = json(&[
        "optimise",
        "--paper",
        "--payload-mass",
        "30g",
        "--catalogue",
        cat.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v[1]["over_payload_limit"], true);
    assert_eq!(f(&v, "1.endurance_min"), 0.0);
    insta::assert_snapshot!(ok(&[
        "optimise",
        "--paper",
        "--payload-mass",
        "30g",
        "--catalogue",
        cat.to_str().unwrap(),
    ]));
}

#[test]
fn estimate_and_mission_human_output() {
    insta::assert_snapshot!(
        "estimate",
        ok(&[
            "estimate",
            "--paper",
            "--battery-mass",
            "0.144",
            "--energy-density",
            "164"
        ])
    );
    insta::assert_snapshot!(
        "mission",
        ok(&[
            "mission",
            "--paper",
            "--battery-mass",
            "0.144",
            "--energy-density",
            "164",
            "--plan",
            "3x(hover 2m; attach 30m); hover until empty",
        ])
    );
}

#[test]
fn mission_that_runs_out_says_where() {
    let v = json(&[
        "mission",
        "--paper",
        "--battery-mass",
        "0.144",
        "--energy-density",
        "164",
        "--plan",
        "hover 10m; hover 10m; attach 5m",
        "--json",
    ]);
    assert_eq!(f(&v, "depletion.segment_index"), 1.0);
    assert_close(f(&v, "depletion.at_min"), 13.826, 0.01, "depletion minute");
}

/// Certified values from NIST StRD Wampler1: y = 1 + x + x² + x³ + x⁴ + x⁵, x = 0..20.
#[test]
fn generic_fit_of_named_columns() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("w1.csv");
    let mut s = String::from("x,y\n");
    for x in 0..=20u32 {
        let x = f64::from(x);
        s.push_str(&format!(
            "{x},{}\n",
            1.0 + x + x * x + x.powi(3) + x.powi(4) + x.powi(5)
        ));
    }
    std::fs::write(&csv, s).unwrap();
    let v = json(&[
        "fit",
        csv.to_str().unwrap(),
        "--x",
        "x",
        "--y",
        "y",
        "--json",
    ]);
    for (k, b) in v["coefficients"].as_array().unwrap().iter().enumerate() {
        assert_close(b.as_f64().unwrap(), 1.0, 1e-9, &format!("b{k}"));
    }
}

/// Runs a command expected to fail on bad input: exit code 2, one clear message on stderr
/// that contains `needle`, no panic, no stdout.
fn fails_with(args: &[&str], needle: &str) {
    let out = run(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(
        stderr.contains(needle),
        "{args:?}: expected {needle:?} in {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    assert!(out.stdout.is_empty(), "{args:?} printed to stdout");
}

#[test]
fn bad_input_gives_one_clear_message_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let w = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let out = dir.path().join("out.toml");
    let o = out.to_str().unwrap();

    fails_with(
        &[
            "estimate",
            "--paper",
            "--battery-mass",
            "-1",
            "--energy-density",
            "164",
        ],
        "is negative",
    );
    fails_with(
        &[
            "estimate",
            "--paper",
            "--battery-mass",
            "0.1",
            "--energy-density",
            "0",
        ],
        "must be greater than zero",
    );
    fails_with(
        &[
            "estimate",
            "--paper",
            "--battery-mass",
            "0.1",
            "--energy-density",
            "NaN",
        ],
        "not a finite number",
    );
    fails_with(
        &[
            "estimate",
            "--paper",
            "--battery-mass",
            "2kg",
            "--energy-density",
            "164",
        ],
        "outside the measured thrust curve",
    );
    fails_with(
        &[
            "mission",
            "--paper",
            "--battery-mass",
            "0.1",
            "--energy-density",
            "164",
            "--plan",
            "hover 2m; jump 3m",
        ],
        "unknown segment 'jump'",
    );
    let missing = w("missing.csv", "thrust_g,current_a\n10,1\n20,2\n");
    fails_with(
        &["fit", &missing, "-o", o],
        "no voltage column, so electrical power cannot be computed",
    );
    let nan = w("nan.csv", "thrust_g,power_w\n10,1\n20,NaN\n30,3\n");
    fails_with(
        &["fit", &nan, "-o", o],
        "line 3, column \"power_w\": \"NaN\" is not a finite number",
    );
    let few = w("few.csv", "thrust_g,power_w\n10,1\n20,2\n30,3\n");
    fails_with(
        &["fit", &few, "-o", o],
        "needs at least 6 distinct x values",
    );
    let foreign = w("foreign.toml", "schema = \"something.else\"\n");
    fails_with(
        &[
            "optimise",
            "--params",
            &foreign,
            "--structure-mass",
            "0.4",
            "--avionics-power",
            "2",
            "--energy-density",
            "150",
        ],
        "not a hoverbench parameter file",
    );
    let newer = w(
        "newer.toml",
        "schema = \"hoverbench.params\"\nschema_version = 99\n",
    );
    fails_with(
        &[
            "optimise",
            "--params",
            &newer,
            "--structure-mass",
            "0.4",
            "--avionics-power",
            "2",
            "--energy-density",
            "150",
        ],
        "schema_version 99 is newer",
    );
    fails_with(
        &["fit", "/nonexistent/sweep.csv", "-o", o],
        "/nonexistent/sweep.csv",
    );
    assert!(!out.exists(), "a failed command wrote {o}");
}

#[test]
fn a_catalogue_with_an_unterminated_quote_is_refused_at_the_quote() {
    let dir = tempfile::tempdir().unwrap();
    let cat = dir.path().join("cat.csv");
    std::fs::write(
        &cat,
        "name,cells,capacity_mah,mass_g\nA,3,2100,170\n\"B,3,1500,120\nC,3,1000,90\n",
    )
    .unwrap();
    let o = run(&["optimise", "--paper", "--catalogue", cat.to_str().unwrap()]);
    refused(
        &o,
        "cat.csv, line 3, column 1: a quote opens here and is never closed",
    );
}

#[test]
fn a_params_file_whose_total_contradicts_its_per_rotor_limit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("p.toml");
    let o = run(&[
        "fit",
        data_path("paper-sweep.csv").to_str().unwrap(),
        "--limit",
        data_path("paper-limit-9v.csv").to_str().unwrap(),
        "-o",
        params.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let line = replace_line(&params, "total_kg", "total_kg = 0.9");
    let o = run(&[
        "estimate",
        "--params",
        params.to_str().unwrap(),
        "--structure-mass",
        "0.431",
        "--avionics-power",
        "2.44",
        "--battery-mass",
        "0.144",
        "--energy-density",
        "164",
    ]);
    refused(
        &o,
        &format!("line {line}, column 12: thrust_limit.total_kg = 0.9 contradicts"),
    );
}

#[test]
fn a_mission_plan_nested_thousands_deep_is_an_error_not_a_crash() {
    let plan = nested_plan(19_000);
    let o = run(&[
        "mission",
        "--paper",
        "--battery-mass",
        "0.144",
        "--energy-density",
        "164",
        "--plan",
        &plan,
    ]);
    refused(&o, "nested more than 32 deep");
}

#[test]
fn sim_rig_prints_its_port_as_json() {
    use std::io::BufRead;
    let mut child = common::bin()
        .args(["sim-rig", "--json", "--speed", "10"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    let v: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line:?}"));
    assert!(v["port"].as_str().unwrap().starts_with("/dev/pts/"), "{v}");
    assert_eq!(v["preset"], "paper");
    assert_eq!(f(&v, "speed"), 10.0);
}

#[test]
fn a_bare_mass_implausible_in_kg_suggests_grams() {
    let o = run(&[
        "estimate",
        "--paper",
        "--structure-mass",
        "431",
        "--battery-mass",
        "0.144",
        "--energy-density",
        "164",
    ]);
    refused(
        &o,
        "hint: --structure-mass 431 is read as 431 kg (a bare number is kg); for grams write --structure-mass 431g",
    );
}
