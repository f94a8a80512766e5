//! End-to-end tests of `hoverbench report`: a session folder and a params file in, every figure
//! as SVG and PNG and a self-contained HTML report out; bad input is one clear message and
//! exit code 2.

use std::path::{Path, PathBuf};
use std::process::Output;

use assert_cmd::Command;
use estimator::file::Provenance;

mod common;
use common::{
    assert_self_contained, data_path, file_names, nested_plan, refused, replace_line, root, run,
};

fn report_data(name: &str) -> PathBuf {
    root().join("reports/tests/data").join(name)
}

/// The paper's platform, in the units a user would type.
const PLATFORM: [&str; 4] = ["--structure-mass", "431g", "--avionics-power", "2.44"];

/// `report INPUT -o OUT FLAGS`.
fn report_args<'a>(input: &'a Path, out: &'a Path, flags: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "report",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(flags);
    args
}

/// Runs `hoverbench report INPUT -o OUT FLAGS`.
fn report(input: &Path, out: &Path, flags: &[&str]) -> Output {
    run(&report_args(input, out, flags))
}

/// A session folder: `params.toml` fitted from the paper sweep with the 9 V limit sweep, and a
/// `sweep.csv` with a `power_std_w` column (1 % of the power) so that Fig. 3 has error bars.
fn session(dir: &Path, input_file: &str) {
    let (sweep, sweep_bytes) = import::Table::read(&data_path("paper-sweep.csv")).unwrap();
    let xy = sweep
        .xy("thrust_g", &import::YSource::power_default())
        .unwrap();
    let fitted = fit::fit_polynomial(&xy.x, &xy.y, 5).unwrap();
    let (limit_table, limit_bytes) = import::Table::read(&data_path("paper-limit-9v.csv")).unwrap();
    let std = limit_table.column("thrust_std_g").unwrap();
    let limit = fit::thrust_limit(
        &limit_table.column("throttle").unwrap(),
        &limit_table.column("thrust_g").unwrap(),
        &fit::ThrustLimitOptions {
            thrust_std_g: Some(&std),
            ..Default::default()
        },
    )
    .unwrap();
    let file = fit::export::params_file(
        &fitted,
        &fit::export::CurveLabels {
            x: "thrust_g",
            y: "power_w",
            supply_voltage_v: Some(12.5),
        },
        4,
        Some(&fit::export::LimitRecord {
            limit,
            supply_voltage_v: 9.0,
        }),
        Provenance {
            input_file: input_file.to_owned(),
            input_sha256: import::sha256_hex(&sweep_bytes),
            limit_input_file: Some("paper-limit-9v.csv".to_owned()),
            limit_input_sha256: Some(import::sha256_hex(&limit_bytes)),
            created: "2026-01-01T00:00:00Z".to_owned(),
            tool: "hoverbench test".to_owned(),
        },
    );
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("params.toml"), file.to_toml_string()).unwrap();
    let mut csv =
        String::from("# paper sweep with a 1 % standard deviation\nthrust_g,power_w,power_std_w\n");
    for (x, y) in xy.x.iter().zip(&xy.y) {
        csv.push_str(&format!("{x},{y},{}\n", 0.01 * y));
    }
    std::fs::write(dir.join("sweep.csv"), csv).unwrap();
}

#[test]
fn a_session_gives_every_figure_and_a_self_contained_report() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("session");
    session(&sess, "sweep.csv");
    let out = tmp.path().join("out");
    let cat = report_data("catalogue-example.csv");
    let flights = report_data("flights-example.csv");
    let o = report(
        &sess,
        &out,
        &[
            &PLATFORM[..],
            &[
                "--catalogue",
                cat.to_str().unwrap(),
                "--flights",
                flights.to_str().unwrap(),
                "--plan",
                "3x(hover 2m; attach 30m); hover until empty",
            ],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8(o.stdout).unwrap();
    for stem in [
        "fig3-thrust-curve",
        "fig4-endurance-vs-battery-mass",
        "fig5-battery-ranking",
        "fig6-endurance-vs-payload",
        "fig7-mission-timeline",
    ] {
        for ext in ["svg", "png"] {
            let p = out.join(format!("{stem}.{ext}"));
            assert!(p.is_file(), "{} missing", p.display());
            assert!(
                stdout.contains(&format!("wrote {}", p.display())),
                "{stdout}"
            );
        }
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_self_contained(&html);
    // The limit sweep's 150 g per rotor, Fig. 3's error bars, the over-limit packs, the measured
    // flights beside their estimates and the mission end are all in the report.
    assert!(html.contains("0.600 kg (150.0"), "thrust limit missing");
    assert!(html.contains("measured (mean ± 1σ)"));
    assert!(html.contains("over the payload limit (would give"));
    assert!(html.contains("beyond the measured thrust range"));
    assert!(html.contains("Measured flights beside the estimates"));
    assert!(html.contains("Battery-A (TP-2100-3S1P)") || html.contains("TP-2100-3S1P (Battery-A)"));
    assert!(html.contains("Fig. 7 · Mission timeline"));
    // Nothing but the report's own files.
    let names = file_names(&out);
    assert_eq!(names.len(), 11, "{names:?}");
}

#[test]
fn a_params_file_finds_its_sweep_through_its_provenance() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("s");
    // Recorded as written by `hoverbench fit` run inside the folder: relative to the params file.
    session(&sess, "sweep.csv");
    let out = tmp.path().join("figs");
    let params = sess.join("params.toml");
    let o = report(
        &params,
        &out,
        &[
            "--structure-mass",
            "0.431",
            "--avionics-power",
            "2.44",
            "--battery-mass",
            "144g",
            "--battery-energy-density",
            "164",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let written = v["written"].as_array().unwrap();
    // Fig. 3, 4 and 6 (no catalogue, no plan): 3 × 2 files and the HTML.
    assert_eq!(written.len(), 7, "{v}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("27 measured steps"),
        "the sweep was not found"
    );
    assert_self_contained(&html);
}

#[test]
fn a_plan_without_a_battery_is_one_clear_error_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("s");
    session(&sess, "sweep.csv");
    let out = tmp.path().join("never");
    let o = report(
        &sess,
        &out,
        &[&PLATFORM[..], &["--plan", "hover until empty"]].concat(),
    );
    refused(&o, "--plan needs a battery");
    assert!(!out.exists());
}

/// Runs `report` on a session with a watchdog: an absurd input must end, promptly, with exit 2.
fn report_ends(sess: &Path, out: &Path) -> Output {
    Command::cargo_bin("hoverbench")
        .unwrap()
        .args(report_args(sess, out, &PLATFORM))
        .timeout(std::time::Duration::from_secs(60))
        .output()
        .unwrap()
}

#[test]
fn absurd_values_end_in_a_clear_error_not_a_hang() {
    let tmp = tempfile::tempdir().unwrap();
    type Spoil<'a> = &'a dyn Fn(&Path);
    let cases: [(&str, Spoil); 3] = [
        ("valid_max", &|s: &Path| {
            replace_line(&s.join("params.toml"), "valid_max", "valid_max = 1e300");
        }),
        ("coefficient", &|s: &Path| {
            // the first scaled coefficient (the line after `coefficients_scaled = [`)
            let p = s.join("params.toml");
            let text = std::fs::read_to_string(&p).unwrap();
            let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
            let at = lines
                .iter()
                .position(|l| l.starts_with("coefficients_scaled"))
                .unwrap();
            lines[at + 1] = "    1e308,".to_owned();
            std::fs::write(&p, lines.join("\n") + "\n").unwrap();
        }),
        ("power_w", &|s: &Path| {
            let p = s.join("sweep.csv");
            let text = std::fs::read_to_string(&p).unwrap();
            let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
            let cols: Vec<&str> = lines[5].split(',').collect();
            lines[5] = format!("{},1e308,{}", cols[0], cols[2]);
            std::fs::write(&p, lines.join("\n") + "\n").unwrap();
        }),
    ];
    for (name, spoil) in cases {
        let sess = tmp.path().join(name);
        session(&sess, "sweep.csv");
        spoil(&sess);
        let out = tmp.path().join(format!("{name}-out"));
        let o = report_ends(&sess, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains("cannot be plotted") || err.contains("not finite"),
            "{name}: {err}"
        );
        assert!(!out.join("report.html").exists(), "{name}");
    }
}

#[test]
fn a_plan_nested_thousands_deep_is_an_error_not_a_crash() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("s");
    session(&sess, "sweep.csv");
    let plan = nested_plan(19_000);
    let out = tmp.path().join("out");
    let o = report(
        &sess,
        &out,
        &[
            &PLATFORM[..],
            &[
                "--battery-mass",
                "144g",
                "--battery-energy-density",
                "164",
                "--plan",
                &plan,
            ],
        ]
        .concat(),
    );
    refused(&o, "nested more than 32 deep");
}

#[test]
fn a_long_sweep_is_drawn_decimated_into_small_files() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("s");
    session(&sess, "sweep.csv");
    // 50,000 noisy steps (a raw log): one SVG element per step made files of hundreds of MB.
    let mut csv = String::from("thrust_g,power_w,power_std_w\n");
    for i in 0..50_000u32 {
        let t = f64::from(i % 2600) / 10.0;
        let wobble = f64::from(i % 7) * 0.01;
        csv.push_str(&format!(
            "{t},{},{}\n",
            0.16 * t + 0.0004 * t * t + wobble,
            0.05
        ));
    }
    std::fs::write(sess.join("sweep.csv"), csv).unwrap();
    let out = tmp.path().join("out");
    let o = report_ends(&sess, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::metadata(out.join("fig3-thrust-curve.svg"))
        .unwrap()
        .len();
    assert!(svg < 1_500_000, "fig3 SVG is {svg} bytes");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("50000 steps"), "subtitle");
    assert!(html.contains("too many for a table"));
    assert!(
        html.len() < 3_000_000,
        "report.html is {} bytes",
        html.len()
    );
}

#[test]
fn a_params_file_alone_gives_fig3_and_the_report() {
    let tmp = tempfile::tempdir().unwrap();
    let sess = tmp.path().join("s");
    session(&sess, "sweep.csv");
    let out = tmp.path().join("out");
    let params = sess.join("params.toml");
    // exactly as the README writes it: `hoverbench report SESSION_OR_PARAMS -o DIR`
    let o = report(&params, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names = file_names(&out);
    assert_eq!(
        names,
        [
            "fig3-thrust-curve.png",
            "fig3-thrust-curve.svg",
            "report.html"
        ]
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("27 measured steps"),
        "the sweep was not found"
    );
    assert!(html.contains("not given (--structure-mass, --avionics-power)"));
    assert!(!html.contains("NaN"));
    assert_self_contained(&html);
    // the session folder works the same
    let out2 = tmp.path().join("out2");
    let o = report(&sess, &out2, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // figures that need the platform say so
    let o = report(&sess, &out2, &["--plan", "hover until empty"]);
    refused(&o, "--plan needs the platform");
}
